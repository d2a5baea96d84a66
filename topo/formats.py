"""The one table of mechanism file formats: a file's suffix → its reader and writer.

Every reader takes the file's text (so that a file on disk and an upload go through the
same parser and give the same messages) and every writer returns text:

========  ==========================================  ==================================
suffix    format                                      reader / writer
========  ==========================================  ==================================
.toml     the project's mechanism file                :func:`topo.io.loads`, :func:`topo.io.dumps_toml`
.json     the same document as JSON                   :func:`topo.io.loads`, :func:`topo.io.dumps_json`
.pyslvs   a Pyslvs project (YAML)                     :func:`topo.pyslvs.loads_pyslvs`, :func:`topo.pyslvs.dumps_pyslvs`
.expr     a bare Pyslvs expression                    :func:`topo.pyslvs.loads_pyslvs`, :func:`topo.pyslvs.dumps_expression`
========  ==========================================  ==================================
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from .errors import InputError, explain
from .model import Mechanism

__all__ = ["Format", "FORMATS", "format_of", "read_mechanism", "loads_mechanism", "dumps_mechanism"]


@dataclass(frozen=True)
class Format:
    """A mechanism file format: ``read(path)``, ``loads(text, where, name)`` and
    ``dumps(mechanism)``."""

    suffix: str
    description: str
    read: Callable[[Path], Mechanism]
    loads: Callable[[str, str, str | None], Mechanism]
    dumps: Callable[[Mechanism], str]


def _toml(text, where, name):
    from .io import loads
    return loads(text, "toml", where=where)


def _json(text, where, name):
    from .io import loads
    return loads(text, "json", where=where)


def _pyslvs(text, where, name):
    from .pyslvs import loads_pyslvs     # YAML only when used
    return loads_pyslvs(text, where, name=name)


def _read(module: str, func: str):
    def read(path: Path) -> Mechanism:
        from importlib import import_module
        return getattr(import_module(f"multiloop.topo.{module}"), func)(path)
    return read


def _dumps(module: str, func: str):
    def dumps(m: Mechanism) -> str:
        from importlib import import_module
        return getattr(import_module(f"multiloop.topo.{module}"), func)(m)
    return dumps


#: suffix → format (the table of the module docstring)
FORMATS: dict[str, Format] = {f.suffix: f for f in (
    Format(".toml", "mechanism file (TOML)", _read("io", "load"), _toml, _dumps("io", "dumps_toml")),
    Format(".json", "mechanism file (JSON)", _read("io", "load"), _json, _dumps("io", "dumps_json")),
    Format(".pyslvs", "Pyslvs project (YAML)", _read("pyslvs", "read_pyslvs"), _pyslvs,
           _dumps("pyslvs", "dumps_pyslvs")),
    Format(".expr", "bare Pyslvs expression", _read("pyslvs", "read_pyslvs"), _pyslvs,
           _dumps("pyslvs", "dumps_expression")),
)}


def format_of(name: str | Path, what: str | None = None) -> Format:
    """The format of a file name by its suffix.

    Raises
    ------
    InputError
        An unknown suffix (the message lists the known ones).
    """
    suffix = Path(name).suffix.lower()
    fmt = FORMATS.get(suffix)
    if fmt is None:
        raise InputError(explain(what or f"file '{name}'", expected="a suffix among " + ", ".join(FORMATS),
                                 got=repr(suffix or "none")))
    return fmt


def loads_mechanism(text: str, name: str | Path) -> Mechanism:
    """A mechanism from the text of a file called ``name`` (its suffix picks the reader)."""
    return format_of(name).loads(text, str(name), Path(name).stem)


def read_mechanism(path: str | Path) -> Mechanism:
    """A mechanism from a file on disk by the reader of its suffix (each reads through
    :func:`topo.io.read_input_bytes`: regular files only, size-capped)."""
    p = Path(path)
    return format_of(p).read(p)


def dumps_mechanism(m: Mechanism, name: str | Path) -> str:
    """The text of ``m`` in the format of ``name``'s suffix."""
    return format_of(name).dumps(m)
