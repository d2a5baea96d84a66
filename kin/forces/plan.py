"""Compiling the kinetostatic unknowns of a mechanism into solvable blocks.

Each moving link gives three equations (ΣFx, ΣFy, ΣM about its centre of mass).  The
unknowns are two per pair (``Rx, Ry`` for an R pair; normal force ``N`` and couple ``M``
for a P pair) and one per driver (balancing moment or force).  A pin joining ``k``
links carries ``k − 1`` pairs around a host link (Pozhbelko & Kuts 2020): the host is
the frame if it is on the pin, else the link solved first.

A column belongs to the block of its later link (group by group, from the last Assur
group back to the drivers; Vasilenko et al. 2018 solve the engine's dyad first, then
the crank).  :func:`compile_forces` does this bookkeeping once per mechanism; the
numerical phases live in :mod:`.solver`.
"""
from __future__ import annotations

from dataclasses import dataclass

from multiloop.topo.errors import InputError, LinkageError, MobilityError, explain
from multiloop.topo.graphs import pin_pairs
from multiloop.topo.model import JointKind, Mechanism

__all__ = ["Pair", "Column", "Block", "ForcePlan", "compile_forces", "plan_order", "METHODS"]

#: the kinetostatic routes: group by group (the default), or one system for all moving links
METHODS = ("groups", "global")


@dataclass(frozen=True, slots=True)
class Pair:
    """One kinematic pair carrying a reaction: ``a`` acts on ``b`` at ``joint``."""

    joint: str
    kind: str
    a: str
    b: str

    @property
    def name(self) -> str:
        return f"{self.joint}:{self.a}->{self.b}"


@dataclass(frozen=True, slots=True)
class Column:
    """One scalar unknown.

    ``kind`` is ``Rx``/``Ry`` (R pair), ``PN``/``PM`` (P pair normal force, couple),
    ``DR``/``DP`` (driver moment, force); ``index`` is the pair's (or driver's) index;
    the unknown acts from link ``a`` on link ``b`` at ``joint``.
    """

    kind: str
    index: int
    a: str
    b: str
    joint: str


@dataclass(frozen=True, slots=True)
class Block:
    """Links solved together and the indices of their columns (square: 3 per link)."""

    links: tuple[str, ...]
    columns: tuple[int, ...]


@dataclass(frozen=True, slots=True)
class ForcePlan:
    """The compiled bookkeeping of :func:`~kin.forces.forces` (no numbers).

    ``blocks`` are in solving order (last Assur group first); ``method`` is the route
    actually used and ``notes`` say why it differs from the one asked for.
    """

    pairs: tuple[Pair, ...]
    columns: tuple[Column, ...]
    blocks: tuple[Block, ...]
    method: str
    notes: tuple[str, ...] = ()


def plan_order(m: Mechanism, plan=None) -> list[list[str]] | None:
    """Link sets in solving order from the Assur plan (driver links, then groups), or
    None when no plan can be made."""
    if plan is None:
        from multiloop.topo.assur import decompose  # noqa: PLC0415 - topo is below kin
        try:
            plan = decompose(m)
        except LinkageError:  # no plan: the global route is used
            return None
    groups = []
    for s in getattr(plan, "steps", ()):
        links = getattr(s, "links", None)
        if links is None:
            links = (getattr(s, "link", None),)
        links = [x for x in links if x in m.link_names and not m.link(x).is_frame]
        if links:
            groups.append(links)
    return groups or None


def _pin_pairs(m: Mechanism, rank: dict[str, float]) -> list[Pair]:
    """The pairs of every joint: a P joint is one pair (guide ``links[0]`` on slider);
    an R pin on k links is k − 1 pairs around its host (the lowest-ranked link)."""
    pairs: list[Pair] = []
    for j in m.joints:
        if j.kind is JointKind.P:
            pairs.append(Pair(j.name, "P", j.links[0], j.links[1]))
            continue
        pairs.extend(Pair(j.name, "R", host, other) for host, other in pin_pairs(j.links, key=rank.__getitem__))
    return pairs


def _columns(m: Mechanism, pairs: list[Pair]) -> list[Column]:
    cols: list[Column] = []
    for i, p in enumerate(pairs):
        kinds = ("Rx", "Ry") if p.kind == "R" else ("PN", "PM")
        cols += [Column(k, i, p.a, p.b, p.joint) for k in kinds]
    for i, d in enumerate(m.drivers):
        kind = "DR" if m.is_rotary(d) else "DP"
        cols.append(Column(kind, i, d.links[0], d.links[1], d.joint))
    return cols


def _groups(m: Mechanism, method: str, plan) -> tuple[list[list[str]], str, list[str]]:
    moving = [lk.name for lk in m.links if not lk.is_frame]
    groups = plan_order(m, plan) if method == "groups" else None
    notes: list[str] = []
    used = "groups"
    if groups is None:
        used = "global"
        if method == "groups":
            notes.append("no Assur plan available: global solve")
        groups = [moving]
    covered = {x for g in groups for x in g}
    missing = [x for x in moving if x not in covered]
    if missing:
        groups = [missing] + groups
    return groups, used, notes


def compile_forces(m: Mechanism, method: str = "groups", plan=None) -> ForcePlan:
    """Pairs, unknowns and square blocks of ``m`` in solving order.

    Raises
    ------
    MobilityError
        The equations are not square (the drivers do not match the mobility).
    """
    if method not in METHODS:
        raise InputError(explain("method", expected=" or ".join(map(repr, METHODS)), got=repr(method)))
    groups, used, notes = _groups(m, method, plan)
    rank = {x: float(i) for i, g in enumerate(groups) for x in g}
    rank.update({lk.name: -1.0 for lk in m.links if lk.is_frame})
    pairs = _pin_pairs(m, rank)
    cols = _columns(m, pairs)
    n_moving = sum(not lk.is_frame for lk in m.links)
    if 3 * n_moving != len(cols):
        raise MobilityError(explain(
            "kinetostatics", expected=f"as many unknowns as equations ({3 * n_moving} = 3 x {n_moving} moving links)",
            got=f"{len(cols)} (2 per R pair, 2 per P pair, 1 per driver; {len(m.drivers)} drivers)",
            hint="the number of drivers must equal the mobility"))
    col_rank = [max(rank[c.a], rank[c.b]) for c in cols]
    blocks = [Block(tuple(g), tuple(ci for ci, r in enumerate(col_rank) if r == float(i)))
              for i, g in enumerate(groups)]
    if any(3 * len(b.links) != len(b.columns) for b in blocks):
        used = "global"
        notes.append("plan blocks not square: global solve")
        blocks = [Block(tuple(x for g in groups for x in g), tuple(range(len(cols))))]
    solving = tuple(b for b in reversed(blocks) if b.columns)
    return ForcePlan(tuple(pairs), tuple(cols), solving, used, tuple(notes))
