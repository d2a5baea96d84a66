"""Named mechanisms bundled with multiloop (``catalogue/mechanisms/*.toml``).

Each file is a mechanism in the file format of the README with ``name``, ``description`` and
``source`` (a citation; reconstructions of the Pozhbelko & Kuts 2020 examples say so), a frame,
drivers and a reference configuration that satisfies closure.  The name of a
catalogue entry is its file stem (``four_bar``, ``excavator``, ...); the list and
the reconstruction notes are in ``docs/catalogue.md``.

Examples
--------
>>> "four_bar" in names()
True
>>> m = load_named("radial_engine_5cyl")
>>> m.n_links, m.frame
(12, 'frame')
"""
from __future__ import annotations

from importlib import resources
from pathlib import Path

from multiloop.topo.errors import InputError, explain
from multiloop.topo.io import load
from multiloop.topo.model import Mechanism

__all__ = ["names", "path", "load_named"]

_PACKAGE = "multiloop.catalogue"
_FOLDER = "mechanisms"


def _folder():
    return resources.files(_PACKAGE).joinpath(_FOLDER)


def names() -> list[str]:
    """Stems of the bundled mechanism files, sorted."""
    return sorted(entry.name[:-5] for entry in _folder().iterdir()
                  if entry.name.endswith(".toml"))


def path(name: str) -> Path:
    """Path of the TOML file of a catalogue mechanism.

    Raises
    ------
    InputError
        Unknown name (the message lists the known ones).
    """
    if name not in names():
        raise InputError(explain(f"catalogue mechanism '{name}'", expected="a bundled name",
                                 got="an unknown name", hint="known: " + ", ".join(names())))
    return Path(str(_folder().joinpath(f"{name}.toml")))


def load_named(name: str) -> Mechanism:
    """The catalogue mechanism ``name`` (file stem) as a frozen :class:`Mechanism`."""
    return load(path(name))
