"""The mechanism atlas: every inversion of every chain up to symmetry, with its Assur
structure, stored beside the chains in the same SQLite file.

An **inversion** of a 1-DOF chain is the choice of a frame and of a driver: an R joint
on the frame whose other link is driven (a multiple joint offers one driver per link
on it other than the frame).  Two inversions are the same mechanism when an
automorphism of the chain maps one onto the other; the representatives are the
orbits of :func:`~catalogue.synthesis.mechanism_choices` (iterated stabilisers,
McKay & Piperno 2014).  Each representative is decomposed into Assur groups
(:func:`topo.assur.decompose`), and the atlas records its structure formula, its
highest class (I for a lone driver, II for dyads, III for triads, ...; Artobolevsky's
convention) and whether every step has a closed-form kernel
(``kin.groups.registry.has_closed_form``: the registry of the kinds with a closed-form
step, and ``kin.groups.driver.is_closed_form`` for the driver).

Two independent routes count the same orbits (tests):

* **Burnside's lemma** (Burnside 1911): the number of orbits of a finite group ``G``
  acting on a set ``X`` is ``|G|⁻¹ Σ_g |Fix(g)|``; the group is generated from
  nauty's automorphism generators (closure of the permutations), and ``X`` is the set
  of frames, or of (frame, joint on it, driven link) triples;
* **explicit deduplication**: a canonical certificate of every inversion (the
  incidence graph with frame, driver joint and driven link coloured), counted once.

Resume: the inversions of a chain and the chain's ``done`` row are written in one
transaction, so a build killed at any moment reruns only the chains not yet stored.
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass
from typing import Iterator, Sequence

import pynauty

from multiloop.topo.assur import DriverStep, decompose
from multiloop.topo.model import Driver, Mechanism, MechanismBuilder
from multiloop.kin.groups.driver import is_closed_form as driver_closed_form
from multiloop.kin.groups.registry import has_closed_form

from . import stored_rows as sr
from .atlas import Atlas, each_with_progress
from .synthesis import ChainRecord, SynthesisOptions, mechanism_choices
from .synthesis.records import _nauty_incidence

__all__ = ["InversionRecord", "MechanismCounts", "inversion", "classify", "chain_inversions",
           "burnside_counts", "explicit_inversions", "build_mechanisms", "mechanism_counts",
           "iter_mechanisms", "ROMAN"]

_SCHEMA = """
CREATE TABLE IF NOT EXISTS mechanisms (
    id INTEGER PRIMARY KEY,
    chain TEXT NOT NULL,
    frame INTEGER NOT NULL, joint INTEGER NOT NULL, driven INTEGER NOT NULL,
    n INTEGER NOT NULL, F INTEGER NOT NULL, V INTEGER NOT NULL,
    formula TEXT NOT NULL, class INTEGER NOT NULL, closed_form INTEGER NOT NULL,
    kinds TEXT NOT NULL,
    UNIQUE (chain, frame, joint, driven)
);
CREATE TABLE IF NOT EXISTS mechanism_chains (
    chain TEXT PRIMARY KEY, frames INTEGER NOT NULL, drivers INTEGER NOT NULL,
    group_order REAL NOT NULL, seconds REAL
);
CREATE INDEX IF NOT EXISTS mechanisms_n ON mechanisms (n, F, class);
"""

#: roman numerals of the classes
ROMAN = {1: "I", 2: "II", 3: "III", 4: "IV", 5: "V", 6: "VI", 7: "VII", 8: "VIII"}


@dataclass(frozen=True, slots=True)
class InversionRecord:
    """One mechanism of the atlas: a chain with a frame and a driver.

    Attributes
    ----------
    chain : str
        Canonical form of the chain (the ``chains.canonical`` key).
    frame, joint, driven : int
        Frame link index, driver joint index, driven link index (0-based, the
        chain's ``joints`` order; the mechanism names links ``"1"…"n"``).
    formula : str
        Assur structure formula, e.g. ``I(0,1) → II1(2,3)``.
    cls : int
        Highest class (1: the driver alone).
    closed_form : bool
        Every step has a closed-form kernel in ``kin.groups``.
    kinds : tuple of str
        Group kinds in solving order.
    """

    chain: str
    n: int
    F: int
    V: int
    joints: tuple[tuple[int, ...], ...]
    frame: int
    joint: int
    driven: int
    formula: str
    cls: int
    closed_form: bool
    kinds: tuple[str, ...]

    def as_mechanism(self, name: str | None = None) -> Mechanism:
        return inversion(self.joints, self.frame, self.joint, self.driven, name=name)

    def as_dict(self) -> dict:
        return {"chain": self.chain, "n": self.n, "V": self.V, "frame": self.frame,
                "joint": self.joint, "driven": self.driven, "formula": self.formula,
                "class": ROMAN.get(self.cls, str(self.cls)), "closed_form": self.closed_form,
                "kinds": list(self.kinds), "joints": [list(j) for j in self.joints]}


def inversion(joints: Sequence[Sequence[int]], frame: int, joint: int, driven: int,
              name: str | None = None, at: dict | None = None) -> Mechanism:
    """The mechanism of a chain (link indices per joint) with a frame and a driver.

    Links are named ``"1"…"n"``, joints ``J1…Jm`` (pins), the driver is ``J<joint+1>``
    turning link ``driven`` relative to ``frame``; ``at`` optionally gives every
    joint's position (``{"J1": (x, y), ...}``).

    Examples
    --------
    >>> m = inversion([(0, 1), (1, 2), (2, 3), (3, 0)], 0, 0, 1)
    >>> m.frame, m.drivers[0].joint, m.drivers[0].links
    ('1', 'J1', ('1', '2'))
    """
    b = MechanismBuilder(name=name)
    n = 1 + max(x for j in joints for x in j)
    for x in range(n):
        b.add_link(str(x + 1), frame=x == frame)
    for a, j in enumerate(joints):
        b.add_joint(f"J{a + 1}", "R", tuple(str(x + 1) for x in j),
                    at=None if at is None else at[f"J{a + 1}"])
    b.drivers = [Driver(f"J{joint + 1}", (str(frame + 1), str(driven + 1)))]
    return b.build()


def classify(m: Mechanism) -> tuple[str, int, bool, tuple[str, ...]]:
    """Structure formula, highest class, closed form of every step, group kinds.

    Examples
    --------
    >>> classify(inversion([(0, 1), (1, 2), (2, 3), (3, 0)], 0, 0, 1))
    ('I(0,1) → II1(2,3)', 2, True, ('RRR',))
    """
    plan = decompose(m)
    closed = all(driver_closed_form(s) if isinstance(s, DriverStep)
                 else (has_closed_form(s.kind) and s.layout is not None) for s in plan.steps)
    cls = max((g.cls for g in plan.groups), default=1)
    return plan.formula, int(cls), bool(closed), tuple(str(g.kind_name) for g in plan.groups)


def _masks(record: ChainRecord) -> list[int]:
    return [sum(1 << x for x in j) for j in record.joints]


def chain_inversions(record: ChainRecord) -> tuple[list[InversionRecord], int, float]:
    """Every inversion of ``record`` up to symmetry, classified; also the number of
    distinct frames and the order of the automorphism group."""
    c = mechanism_choices(record.n, _masks(record))
    out = []
    for f, a, x in c.drivers:
        formula, cls, closed, kinds = classify(inversion(record.joints, f, a, x))
        out.append(InversionRecord(record.canonical, record.n, record.F, record.V, record.joints,
                                   f, a, x, formula, cls, closed, kinds))
    return out, c.n_frames, c.group_order


# ------------------------------------------------------------- the second routes
def _group(n: int, joints: Sequence[int]) -> list[tuple[int, ...]]:
    """Every automorphism of the chain's incidence graph (closure of nauty's generators)."""
    gens, _, _, _, _ = pynauty.autgrp(_nauty_incidence(n, joints))
    size = n + len(joints)
    ident = tuple(range(size))
    seen, todo = {ident}, [ident]
    while todo:
        p = todo.pop()
        for g in gens:
            q = tuple(g[p[v]] for v in range(size))
            if q not in seen:
                seen.add(q)
                todo.append(q)
    return list(seen)


def burnside_counts(n: int, joints: Sequence[int]) -> tuple[int, int]:
    """Distinct frames and (frame, driver joint, driven link) choices by Burnside's
    lemma, ``|X/G| = |G|⁻¹ Σ_g |Fix(g)|`` (Burnside 1911), over the whole group.

    Examples
    --------
    >>> burnside_counts(4, [0b0011, 0b0110, 0b1100, 0b1001])
    (1, 1)
    """
    group = _group(n, joints)
    triples = [(f, n + a, x) for a, jm in enumerate(joints) for f in range(n) if jm >> f & 1
               for x in range(n) if x != f and jm >> x & 1]
    fix_f = sum(sum(1 for f in range(n) if g[f] == f) for g in group)
    fix_d = sum(sum(1 for f, a, x in triples if g[f] == f and g[a] == a and g[x] == x) for g in group)
    k = len(group)
    if fix_f % k or fix_d % k:
        raise ArithmeticError("Burnside sums not divisible by the group order")
    return fix_f // k, fix_d // k


def explicit_inversions(record: ChainRecord) -> dict[bytes, tuple[int, int, int]]:
    """Every inversion of the chain by brute force, keyed by a canonical certificate of
    the incidence graph with the frame, the driver joint and the driven link coloured
    (nauty, McKay & Piperno 2014); the value is the first triple met.

    ``topo.isomorphism.canonical_form(…, "mechanism")`` is the independent route (its
    own coloured graph, with the pair of links the driver turns marked: a pin on links
    3, 4, 5 of a frame 3 driving 4 or 5 are different mechanisms); the tests compare
    the counts of both.
    """
    masks = _masks(record)
    seen: dict[bytes, tuple[int, int, int]] = {}
    for a, j in enumerate(record.joints):
        for f in j:
            for x in j:
                if x != f:
                    g = _nauty_incidence(record.n, masks, [{f}, {record.n + a}, {x}])
                    seen.setdefault(pynauty.certificate(g), (f, a, x))
    return seen


# ------------------------------------------------------------------ the store
@dataclass(frozen=True, slots=True)
class MechanismCounts:
    """Counts of a mechanism build: frames, drivers, by highest class, closed forms."""

    options: SynthesisOptions
    chains: int
    frames: int
    drivers: int
    by_class: tuple[tuple[int, int], ...]
    closed_form: int
    chains_run: int
    seconds: float

    def as_dict(self) -> dict:
        return {"chains": self.chains, "frames": self.frames, "drivers": self.drivers,
                "by_class": {ROMAN.get(c, str(c)): k for c, k in self.by_class},
                "closed_form": self.closed_form, "chains_run": self.chains_run,
                "seconds": round(self.seconds, 3)}

    def to_text(self) -> str:
        cls = ", ".join(f"class {ROMAN.get(c, str(c))}: {k}" for c, k in self.by_class)
        return (f"  mechanisms: {self.frames} distinct frames, {self.drivers} distinct (frame, driver) "
                f"choices ({cls}; every group in closed form: {self.closed_form})")


def _ensure(atlas: Atlas) -> None:
    atlas.con.executescript(_SCHEMA)


def _store(atlas: Atlas, rec: ChainRecord, rows: list[InversionRecord], frames: int,
           order: float, seconds: float) -> None:
    with atlas._tx() as con:
        con.executemany(
            "INSERT OR IGNORE INTO mechanisms (chain, frame, joint, driven, n, F, V, formula, class,"
            " closed_form, kinds) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
            [(r.chain, r.frame, r.joint, r.driven, r.n, r.F, r.V, r.formula, r.cls,
              int(r.closed_form), json.dumps(list(r.kinds))) for r in rows])
        con.execute("INSERT OR REPLACE INTO mechanism_chains (chain, frames, drivers, group_order, seconds)"
                    " VALUES (?, ?, ?, ?, ?)", (rec.canonical, frames, len(rows), order, seconds))


def build_mechanisms(atlas: Atlas, opts: SynthesisOptions, progress: bool = False,
                     max_chains: int | None = None) -> MechanismCounts:
    """Store the inversions of every chain of ``opts`` already in ``atlas`` (build the
    chains first); chains already done are skipped (resume).  1-DOF chains only: a
    mechanism here has one driver.
    """
    from multiloop.topo.errors import ParameterError, explain

    if opts.F != 1:
        raise ParameterError(explain("mechanisms", expected="'dof' 1 (one driver per mechanism)",
                                     got=f"'dof' {opts.F}"), "mechanisms", "dof")
    _ensure(atlas)
    done = {r[0] for r in atlas.con.execute("SELECT chain FROM mechanism_chains")}
    todo = [r for r in atlas.chains(opts) if r.canonical not in done]
    if max_chains is not None:
        todo = todo[:max_chains]
    t0 = time.perf_counter()

    def work(rec: ChainRecord) -> None:
        s = time.perf_counter()
        rows, frames, order = chain_inversions(rec)
        _store(atlas, rec, rows, frames, order, time.perf_counter() - s)

    each_with_progress(todo, f"mechanisms n={opts.n}", progress, work)
    return mechanism_counts(atlas, opts, len(todo), time.perf_counter() - t0)


def _chain_filter(atlas: Atlas, opts: SynthesisOptions) -> tuple[str, list]:
    where, params = atlas._where(opts, None)
    return f"chain IN (SELECT canonical FROM chains WHERE {where})", params


def mechanism_counts(atlas: Atlas, opts: SynthesisOptions, chains_run: int = 0,
                     seconds: float = 0.0) -> MechanismCounts:
    """Counts of the stored inversions of the chains of ``opts``."""
    _ensure(atlas)
    cond, params = _chain_filter(atlas, opts)
    con = atlas.con
    n_chains, frames, drivers = con.execute(
        f"SELECT count(*), coalesce(sum(frames), 0), coalesce(sum(drivers), 0) FROM mechanism_chains "
        f"WHERE {cond}", params).fetchone()
    by_class = tuple(con.execute(f"SELECT class, count(*) FROM mechanisms WHERE {cond} GROUP BY class "
                                 f"ORDER BY class", params).fetchall())
    closed = con.execute(f"SELECT count(*) FROM mechanisms WHERE {cond} AND closed_form = 1",
                         params).fetchone()[0]
    classes = tuple((sr.integer(atlas.path, "mechanisms", f"of class {c!r}", "class", c, 0, 100), int(k))
                    for c, k in by_class)
    return MechanismCounts(opts, n_chains, frames, drivers, classes, closed, chains_run, seconds)


def iter_mechanisms(atlas: Atlas, opts: SynthesisOptions, where: str = "1",
                    params: Sequence = ()) -> Iterator[InversionRecord]:
    """Stored inversions of the chains of ``opts`` (ordered by class, chain, frame,
    joint, driven); ``where`` is a trusted SQL condition on the ``mechanisms`` table."""
    _ensure(atlas)
    cond, cp = _chain_filter(atlas, opts)
    joints = {r.canonical: r.joints for r in atlas.chains(opts)}
    sql = (f"SELECT id, chain, n, F, V, frame, joint, driven, formula, class, closed_form, kinds FROM mechanisms "
           f"WHERE {cond} AND ({where}) ORDER BY class, chain, frame, joint, driven")
    for mid, ch, n, F, V, f, a, x, formula, cls, closed, kinds in atlas.con.execute(sql, list(cp) + list(params)):
        if ch not in joints:
            raise sr.corrupt(atlas.path, "mechanisms", mid, "chain: the canonical form of a stored chain",
                             "a dangling reference")
        yield InversionRecord(ch, n, F, V, joints[ch], f, a, x, formula, cls, bool(closed),
                              tuple(sr.text_list(atlas.path, "mechanisms", mid, "kinds", kinds)))
