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

from dataclasses import asdict, dataclass
from importlib import resources
from pathlib import Path

from multiloop.topo.errors import InputError, explain
from multiloop.topo.io import load
from multiloop.topo.model import Mechanism
from multiloop.topo.numbers import structural_codes

__all__ = ["names", "path", "load_named", "CatalogueEntry", "entry", "CatalogueListing", "listing"]

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


@dataclass(frozen=True, slots=True)
class CatalogueEntry:
    """The basic numbers of one catalogue mechanism (``multiloop catalogue``).

    Attributes
    ----------
    name : str
        File stem.
    n, F, K : int
        Links, Chebyshev–Grübler mobility ``F = (n − 1) − 2K`` and independent loops
        (Pozhbelko & Kuts 2020).
    code : str
        Structural code ``[LA]/V``.
    drivers : int
    description, source : str or None
    """

    name: str
    n: int
    F: int
    K: int
    code: str
    drivers: int
    description: str | None
    source: str | None

    def as_dict(self) -> dict:
        """The JSON keys of ``multiloop catalogue --json``."""
        return asdict(self)


def entry(name: str) -> CatalogueEntry:
    """The basic numbers of catalogue mechanism ``name``.

    Only the counting formulas are evaluated (no loop assortment, no degeneracy
    search), so listing stays fast; ``tests/test_catalogue.py`` checks the values
    against :func:`multiloop.topo.numbers.structural_report`.

    Examples
    --------
    >>> e = entry("four_bar")
    >>> e.n, e.F, e.K, e.code
    (4, 1, 1, '[4]/0')
    """
    m = load_named(name)
    codes = structural_codes([m.degree(x) for x in m.link_names], [j.multiplicity for j in m.joints])
    return CatalogueEntry(name, m.n_links, m.n_links - 1 - 2 * codes.K, codes.K, codes.code,
                          len(m.drivers), m.description, m.source)


@dataclass(frozen=True)
class CatalogueListing:
    """Every bundled mechanism with its basic numbers (``multiloop catalogue``)."""

    entries: tuple[CatalogueEntry, ...]

    def as_dict(self) -> list[dict]:
        """The JSON document: a list of :meth:`CatalogueEntry.as_dict`."""
        return [e.as_dict() for e in self.entries]

    def to_text(self) -> str:
        """A table: name, n, F, K, code and the first clause of the source."""
        head = ("name", "n", "F", "K", "code", "source")
        table = [(e.name, str(e.n), str(e.F), str(e.K), e.code, _short(e.source or "")) for e in self.entries]
        widths = [max(len(h), *(len(t[i]) for t in table)) for i, h in enumerate(head[:-1])]
        fmt = "  ".join(f"{{:<{w}}}" for w in widths) + "  {}"
        return "\n".join(fmt.format(*t) for t in [head, *table])


def _short(text: str, width: int = 70) -> str:
    text = " ".join(text.split()).split("; ")[0]
    return text if len(text) <= width else text[: width - 3] + "..."


def listing() -> CatalogueListing:
    """The listing of every bundled mechanism (:func:`entry` of each name)."""
    return CatalogueListing(tuple(entry(name) for name in names()))
