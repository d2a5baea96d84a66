"""One resolver for every command's input: a file or a catalogue name.

Every ``multiloop`` command and :func:`multiloop.load` accept, wherever they take a
file, (i) a ``.toml``/``.json`` mechanism file, (ii) a Pyslvs project ``.pyslvs`` (or a
bare Pyslvs expression in a ``.txt``/``.expr`` file, read by :mod:`multiloop.exchange.pyslvs`),
and (iii) the name of a bundled mechanism (``multiloop catalogue`` lists them), looked up
in the catalogue folders when no file of that name exists.

Examples
--------
>>> resolve("four_bar").name
'four_bar.toml'
>>> load_mechanism("four_bar").frame
'frame'
"""
from __future__ import annotations

from importlib import resources
from pathlib import Path

from multiloop.topo.errors import InputError, explain
from multiloop.topo.model import Mechanism

__all__ = ["resolve", "load_mechanism", "load_mechanism_or_engine", "PYSLVS_SUFFIXES"]

#: suffixes read as Pyslvs input (project YAML, or a bare expression)
PYSLVS_SUFFIXES = (".pyslvs", ".expr")


def resolve(arg: str | Path, folders: tuple[str, ...] = ("mechanisms", "engines")) -> Path:
    """The file ``arg`` when it exists, else the bundled ``<folder>/<arg>.toml``.

    Raises
    ------
    InputError
        Neither a file nor a catalogue name (the message lists the catalogue names).
    """
    p = Path(arg)
    if p.exists():
        return p
    base = resources.files("multiloop.catalogue")
    known: list[str] = []
    for sub in folders:
        folder = base / sub
        if not folder.is_dir():
            continue
        cand = folder / f"{arg}.toml"
        if cand.is_file():
            return Path(str(cand))
        known += sorted(e.name[:-5] for e in folder.iterdir() if e.name.endswith(".toml"))
    raise InputError(explain(f"file '{arg}'", expected="an existing file or a catalogue name",
                             got="neither", hint="catalogue names: " + ", ".join(known)))


def load_mechanism(arg: str | Path) -> Mechanism:
    """A :class:`Mechanism` from a ``.toml``/``.json``/``.pyslvs`` file or a catalogue name."""
    p = resolve(arg)
    if p.suffix.lower() in PYSLVS_SUFFIXES:
        from multiloop.exchange.pyslvs import read_pyslvs  # noqa: PLC0415 - YAML only when used
        return read_pyslvs(p)
    from multiloop.topo.io import load  # noqa: PLC0415
    return load(p)


def load_mechanism_or_engine(path: str | Path) -> Mechanism:
    """:func:`load_mechanism`, or an engine file (``[engine]`` table) built as a mechanism
    with its gas forces as 1° force tables against the crank angle."""
    from multiloop.topo.io import read_document  # noqa: PLC0415
    p = resolve(path)
    if p.suffix.lower() in (".toml", ".json") and p.exists():
        doc = read_document(p)
        if isinstance(doc, dict) and "engine" in doc:
            from multiloop.kin.engine import engine_from_dict, engine_mechanism  # noqa: PLC0415
            try:
                return engine_mechanism(engine_from_dict(doc), gas_loads=True)
            except InputError as exc:
                raise InputError(f"{p}: {exc}") from None
    return load_mechanism(p)
