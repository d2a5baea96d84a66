"""Assur decomposition: the solving plan of a mechanism (driver links, then groups).

:func:`decompose` compiles the topology **once** into a frozen :class:`AssurPlan`
that the solvers of ``kin/`` loop over; they never search the graph again.

Convention (Russian TMM, Artobolevsky; stated because Western texts differ)
-------------------------------------------------------------------------
* the frame with a driver link is the *initial mechanism*, class I, written
  ``I(0,1)``;
* **class** of a group: the number of pairs of its most complex closed inner
  contour, or, when the inner pairs form no contour, the largest number of inner
  pairs on one link, and never less than II.  So a **dyad is class II order 2**, a
  **triad is class III order 3**, a four-link group whose inner pairs close a
  quadrilateral is **class IV order 2**;
* **order**: the number of outer pairs (pairs joining the group to known links);
* dyad **kind** (вид, Vasechkin et al. 2017): ``RRR`` = 1, ``RRP`` = 2, ``RPR`` = 3,
  ``PRP`` = 4, ``RPP`` = 5, read outer–inner–outer (``PRR`` ≡ ``RRP``,
  ``PPR`` ≡ ``RPP``);
* the **structure formula** numbers the links ``0`` = frame, then ``1, 2, …`` in
  solving order, e.g. ``I(0,1) → II1(2,3) → II2(4,5)``: ``IIk`` is a dyad of kind k,
  ``III`` a triad, ``IV`` a class IV group, ``Gn`` any other n-link group.

Method
------
Body coordinates with explicit pin points: every moving link has a pose
``(x, y, θ)`` (3 unknowns) and every pin (R joint) one point (2 unknowns), shared
by *all* the links on it, so a multiple joint of k links is one point with k
attachments (2k equations, 2 unknowns: k − 1 pairs) and is never broken.  A P
joint gives 2 equations (relative angle, distance from the guide line); a driver
one (relative angle, or slide).  The scalar incidence *equations × unknowns* is
put in block-triangular form by Dulmage–Mendelsohn [1]_: maximum bipartite
matching (Hopcroft–Karp), directed graph of the matched system contracted to
entities (a link's pose, a pin's point), strongly connected components and a
topological order.  Blocks that hold links are the Assur groups (as link sets,
unique by [2]_); blocks of pin points alone are points carried by a known link.

The matching checks only counts (Hall's condition).  Every block is then checked
for **rigidity**: the rank of its Jacobian at a random realisation of the same
topology (generic rank; two independent draws) must equal ``3 × links``.  A rigid
triangle tied to one pin by three bars passes the matching but fails here.

References
----------
.. [1] A. Pothen, C.-J. Fan, "Computing the block triangular form of a sparse
   matrix", ACM TOMS 16(4) (1990) 303–324.
.. [2] O. Shai, A. Sljoka, W. Whiteley, "Directed graphs, decompositions, and
   spatial linkages", Discrete Applied Mathematics (2013), arXiv:1010.5552.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from enum import Enum
from typing import NamedTuple

import networkx as nx
import numpy as np

from .constraints import Constraint, link_origins, reference_jacobian
from .errors import DecompositionError, MobilityError, explain
from .graphs import n_pairs, pin_pairs
from .mobility import actual_mobility
from .model import JointKind, Mechanism
from .recent import Kept, Recent

__all__ = ["DriverStep", "AssurGroup", "AssurPlan", "decompose", "DYAD_KINDS", "GroupKind",
           "DyadLayout", "TriadLayout", "Class4Layout", "ActuatorLayout", "add_kind_rule", "remove_kind_rule"]

# Constraint, link_origins and reference_jacobian live in topo.constraints; the names
# stay importable from here for existing callers.
_ = link_origins

class GroupKind(str, Enum):
    """The kind of an Assur group: the five dyads by their joint sequence (outer–inner–
    outer, Vasechkin et al. 2017), the class III triad, the class IV order-2 group, any
    other group (``GENERAL``, solved by Newton), a triangle with a linear actuator as one
    side (``ACTUATED``) and any other block with a driver inside (``DRIVEN``).  A member
    is its string (``GroupKind.RRR == "RRR"``); a kind registered at run time
    (:func:`add_kind_rule`, through ``kin.groups.registry.register``) is a plain string."""

    RRR = "RRR"
    RRP = "RRP"
    RPR = "RPR"
    PRP = "PRP"
    RPP = "RPP"
    TRIAD = "triad"
    CLASS_IV = "class IV"
    ACTUATED = "actuated RRR"
    GENERAL = "group"
    DRIVEN = "driven group"

    def __str__(self) -> str:
        return self.value

    def __format__(self, spec: str) -> str:
        return format(self.value, spec)

    @property
    def is_dyad(self) -> bool:
        return self.value in DYAD_KINDS


#: dyad kind → number (вид) of Vasechkin et al. 2017
DYAD_KINDS = {"RRR": 1, "RRP": 2, "RPR": 3, "PRP": 4, "RPP": 5}

#: rules that give a decomposed group a kind registered at run time, in the order added
_KIND_RULES: list = []


def add_kind_rule(rule) -> None:
    """Let :func:`decompose` ask ``rule(mechanism, group)`` for every group: it returns
    ``(kind, layout)`` to give the group another kind (the first rule that answers wins),
    or None.  ``kin.groups.registry.register`` adds the rule of the kind it registers."""
    _KIND_RULES.append(rule)


def remove_kind_rule(rule) -> None:
    """Forget a rule added by :func:`add_kind_rule`."""
    _KIND_RULES.remove(rule)


def _relabelled(m: Mechanism, g: "AssurGroup") -> "AssurGroup":
    """``g`` with the kind and layout of the first registered rule that claims it."""
    for rule in _KIND_RULES:
        hit = rule(m, g)
        if hit is not None:
            return replace(g, kind=hit[0], layout=hit[1])
    return g


class DyadLayout(NamedTuple):
    """A dyad's roles in outer–inner–outer order (joint and link names): ``link1``
    carries ``outer1`` and ``inner``, ``link2`` carries ``inner`` and ``outer2``."""

    outer1: str
    inner: str
    outer2: str
    link1: str
    link2: str


class TriadLayout(NamedTuple):
    """A class III triad: the ternary link, the three binaries, each binary's outer
    joint (to a known link) and its inner joint (on the ternary), in the same order."""

    ternary: str
    binaries: tuple[str, ...]
    outers: tuple[str, ...]
    inners: tuple[str, ...]


class Class4Layout(NamedTuple):
    """A class IV order-2 group: two ternaries each on one outer joint, two binaries
    closing the inner 4-loop; ``j_ab`` is the joint of ternary a with binary b."""

    ternary1: str
    ternary2: str
    binary1: str
    binary2: str
    outer1: str
    outer2: str
    j11: str
    j12: str
    j21: str
    j22: str


class ActuatorLayout(NamedTuple):
    """A triangle with a linear actuator as one side (an RRR dyad whose first side is a
    bar of driven length): the actuator's two halves ``near`` (on the known pin
    ``outer1``) and ``far`` (on the ``inner`` pin), joined by the driven P joint
    ``slide`` of driver ``driver``; ``link2`` carries ``inner`` and ``outer2``."""

    outer1: str
    inner: str
    outer2: str
    near: str
    far: str
    link2: str
    slide: str
    driver: int


_ROMAN = {1: "I", 2: "II", 3: "III", 4: "IV", 5: "V", 6: "VI", 7: "VII", 8: "VIII"}


@dataclass(frozen=True, slots=True)
class DriverStep:
    """An input link: link ``link`` moved by driver ``index`` relative to ``base``."""

    index: int
    joint: str
    kind: str                       # "R" or "P"
    base: str                       # driver links[0] (known before)
    link: str                       # driver links[1] (solved by this step)
    constraints: tuple[Constraint, ...]
    number: tuple[int, int] = (0, 1)   # link numbers in the structure formula


@dataclass(frozen=True, slots=True)
class AssurGroup:
    """One Assur group of the plan (or a driven block, see ``kind``).

    Attributes
    ----------
    index : int
        Position among the groups (0-based, solving order).
    cls, order : int
        Class and order (module docstring).
    kind : GroupKind
        ``RRR``, ``RRP``, ``RPR``, ``PRP``, ``RPP``, ``TRIAD``, ``CLASS_IV``,
        ``GENERAL`` or ``DRIVEN`` (a driver acts inside), or the name of a kind
        registered at run time (:func:`add_kind_rule`); :attr:`kind_name` is the
        printed name (``"<n>-link group"``, ``"driven <n>-link group"`` for the last two).
    links : tuple of str
        Real links of the group (unknown here), in file order.
    joints : tuple of (str, tuple of str)
        Each link's **full** joint set: ``(link, (joint, ...))``.
    inner_joints, outer_joints : tuple of str
        Joints with pairs inside the group / joining it to known links.
    known_links : tuple of str
        Known links its outer joints attach to.
    constraints : tuple of Constraint
        The group's equations in pair form (3 per link in total, counted by rows).
    numbers : tuple of int
        Link numbers in the structure formula.
    layout : DyadLayout, TriadLayout, Class4Layout, ActuatorLayout or None
        Kind-specific roles used by the closed-form solvers (``kin.solve``,
        ``kin.check``, ``catalogue.dimensional``); None for other groups.
    drivers : tuple of int
        Drivers acting inside the group (driven blocks only).
    """

    index: int
    cls: int
    order: int
    kind: GroupKind
    links: tuple[str, ...]
    joints: tuple[tuple[str, tuple[str, ...]], ...]
    inner_joints: tuple[str, ...]
    outer_joints: tuple[str, ...]
    known_links: tuple[str, ...]
    constraints: tuple[Constraint, ...]
    numbers: tuple[int, ...] = ()
    layout: DyadLayout | TriadLayout | Class4Layout | ActuatorLayout | None = None
    drivers: tuple[int, ...] = ()

    @property
    def is_dyad(self) -> bool:
        return str(self.kind) in DYAD_KINDS

    @property
    def kind_name(self) -> str:
        """The printed kind: ``RRR`` … ``class IV``, ``"<n>-link group"``, ``"driven <n>-link group"``."""
        if self.kind is GroupKind.GENERAL:
            return f"{len(self.links)}-link group"
        if self.kind is GroupKind.DRIVEN:
            return f"driven {len(self.links)}-link group"
        if self.kind is GroupKind.ACTUATED:
            return f"RRR (actuated: {self.layout.slide})"
        return str(self.kind)

    @property
    def label(self) -> str:
        """Formula token, e.g. ``II1(2,3)``."""
        roman = _ROMAN.get(self.cls, str(self.cls))
        if self.is_dyad:
            head = f"II{DYAD_KINDS[str(self.kind)]}"
        elif self.kind in (GroupKind.GENERAL, GroupKind.DRIVEN, GroupKind.ACTUATED):
            head = f"G{len(self.links)}"
        else:                               # a triad, a class IV group, a kind registered at run time
            head = roman
        return f"{head}({','.join(map(str, self.numbers))})"

    def describe(self) -> str:
        return f"group {self.index + 1} {self.label} ({self.kind_name}; links {', '.join(self.links)})"


@dataclass(frozen=True)
class AssurPlan:
    """The frozen solving plan of a mechanism.

    Attributes
    ----------
    mechanism : Mechanism
    steps : tuple
        :class:`DriverStep` and :class:`AssurGroup` objects in solving order.
    link_numbers : dict-like tuple of (link, number)
        ``0`` = frame, then links in solving order.
    solved_by : tuple of (link, step index)
        Which step solves each moving link.
    """

    mechanism: Mechanism
    steps: tuple
    link_numbers: tuple[tuple[str, int], ...]
    solved_by: tuple[tuple[str, int], ...]

    @property
    def drivers(self) -> tuple[DriverStep, ...]:
        return tuple(s for s in self.steps if isinstance(s, DriverStep))

    @property
    def groups(self) -> tuple[AssurGroup, ...]:
        return tuple(s for s in self.steps if isinstance(s, AssurGroup))

    @property
    def formula(self) -> str:
        """Structure formula, e.g. ``I(0,1) → II1(2,3) → II1(4,5)``."""
        parts = []
        for s in self.steps:
            if isinstance(s, DriverStep):
                parts.append(f"I({s.number[0]},{s.number[1]})")
            else:
                parts.append(s.label)
        return " → ".join(parts)

    def step_of(self, link: str) -> int:
        """Index in :attr:`steps` of the step solving ``link`` (-1 for the frame)."""
        return dict(self.solved_by).get(link, -1)

    def upstream(self, step_indices) -> tuple[int, ...]:
        """Sorted step indices needed to solve the given steps (themselves included)."""
        need: set[int] = set()
        stack = list(step_indices)
        solved = dict(self.solved_by)
        while stack:
            k = stack.pop()
            if k < 0 or k in need:
                continue
            need.add(k)
            s = self.steps[k]
            known = (s.base,) if isinstance(s, DriverStep) else s.known_links
            stack.extend(solved.get(x, -1) for x in known)
        return tuple(sorted(need))

    def to_text(self) -> str:
        """Readable plan: formula, drivers, then one block per group (``multiloop decompose``)."""
        d = self.as_dict()
        lines = [f"structure formula: {d['formula']}",
                 "link numbers: " + ", ".join(f"{n}={k}" for k, n in d["link_numbers"].items())]
        for dr in d["drivers"]:
            lines.append(f"I{tuple(dr['numbers'])}: driver {dr['joint']} ({dr['kind']}) moves "
                         f"{dr['links'][1]} relative to {dr['links'][0]}")
        for i, g in enumerate(d["groups"], 1):
            lines.append(f"group {i}: {g['label']}  class {g['class']}, order {g['order']}, kind {g['kind']}")
            for lk, js in g["link_joints"].items():
                lines.append(f"    link {lk}: joints {', '.join(js)}")
            lines.append(f"    outer joints {', '.join(g['outer_joints'])} → known links "
                         f"{', '.join(g['known_links'])}; inner joints {', '.join(g['inner_joints'])}")
        return "\n".join(lines)

    def as_dict(self) -> dict:
        """JSON-ready description (the documented JSON keys (README) ``decompose --json``)."""
        m = self.mechanism
        groups = []
        for s in self.groups:
            groups.append({
                "class": s.cls, "order": s.order, "kind": s.kind_name, "label": s.label,
                "links": list(s.links),
                "joints": sorted({j for _, js in s.joints for j in js},
                                 key=m.joint_names.index),
                "link_joints": {lk: list(js) for lk, js in s.joints},
                "inner_joints": list(s.inner_joints),
                "outer_joints": list(s.outer_joints),
                "known_links": list(s.known_links),
                "numbers": list(s.numbers),
            })
        drivers = [{"joint": d.joint, "kind": d.kind, "links": [d.base, d.link],
                    "numbers": list(d.number)} for d in self.drivers]
        return {"mechanism": m.name, "frame": m.frame, "formula": self.formula,
                "drivers": drivers, "groups": groups,
                "link_numbers": dict(self.link_numbers)}


def _random_realisation(m: Mechanism, seed: int):
    rng = np.random.default_rng(seed)
    at = {j.name: rng.uniform(-1.0, 1.0, 2) for j in m.joints}
    axis = {}
    for j in m.joints:
        if j.kind is JointKind.P:
            t = rng.uniform(0, np.pi)
            axis[j.name] = np.array([np.cos(t), np.sin(t)])
    org = {x: rng.uniform(-1.0, 1.0, 2) for x in m.link_names}
    return at, axis, org


# ---------------------------------------------------------------------------------
def decompose(mechanism: Mechanism, *, check_rigidity: bool = True) -> AssurPlan:
    """Split a mechanism into driver links and Assur groups in solving order.

    Parameters
    ----------
    mechanism : Mechanism
        With a frame and drivers (geometry is not needed).
    check_rigidity : bool
        Check every block's generic rank (default True).

    Returns
    -------
    AssurPlan

    Raises
    ------
    DecompositionError
        No frame; a part is under-/over-constrained (the free links and surplus
        joints are named); a block passes the matching but is not rigid.
    MobilityError
        The number of drivers does not fit the mobility (Chebyshev–Grübler).

    Examples
    --------
    >>> from multiloop.topo.model import MechanismBuilder
    >>> b = MechanismBuilder()
    >>> b.add_link("ground", frame=True)
    >>> for n, lk in [("O", ("ground", "crank")), ("A", ("crank", "rod")),
    ...               ("B", ("rod", "rocker")), ("C", ("rocker", "ground"))]:
    ...     b.add_joint(n, "R", lk)
    >>> b.add_driver("O")
    >>> decompose(b.build()).formula
    'I(0,1) → II1(2,3)'

    Notes
    -----
    Matching is Hopcroft–Karp, O(E √V) on the scalar incidence; SCCs are linear.  The
    plans of the last 16 mechanisms are kept, by identity (a mechanism and
    its plan are frozen, and the rigidity test's generic geometry is seeded): a page
    that draws, solves and checks one design decomposes it once.  A plan depends on
    no coordinate, so a mechanism that differs from one of the last 16 in its
    coordinates alone (a point moved: the page's drag) gets that plan with its own
    mechanism.
    """
    return _DECOMPOSED.get(mechanism, lambda: _by_structure(mechanism, check_rigidity), check_rigidity)


#: the plans of the last 16 mechanisms decomposed (by identity and check_rigidity)
_DECOMPOSED = Recent(16)
#: the plans of the last 16 mechanisms decomposed, by their coordinate-free form (:func:`_structure`)
_STRUCTURES = Kept(16)


def _structure(m: Mechanism) -> tuple:
    """What a plan may depend on: the mechanism without its joints' and points'
    coordinates and guide directions, and the group-kind rules registered so far."""
    bare = replace(m, joints=tuple(replace(j, at=None, axis=None) for j in m.joints),
                   points=tuple(replace(p, at=None) for p in m.points))
    return bare, tuple(_KIND_RULES)


def _by_structure(m: Mechanism, check_rigidity: bool) -> AssurPlan:
    try:
        plan = _STRUCTURES.get((_structure(m), check_rigidity), lambda: _decompose(m, check_rigidity))
    except TypeError:                        # a field that cannot be hashed: no reuse
        return _decompose(m, check_rigidity)
    return plan if plan.mechanism is m else replace(plan, mechanism=m)


def _decompose(m: Mechanism, check_rigidity: bool) -> AssurPlan:
    """:func:`decompose`'s work (its cache aside)."""
    if m.frame is None:
        raise DecompositionError(explain("mechanism", expected="a frame link (frame = true)",
                                         got="a bare chain", hint="mark the ground link with frame = true"))
    inc = _incidence(m)
    match = _matching(m, inc)
    return _plan(m, inc, _blocks(inc, match), check_rigidity)


# ---- the phases of decompose ------------------------------------------------------
Entity = tuple[str, str]    # ("L", link) = a link's pose, ("J", pin) = a pin's point


@dataclass(frozen=True)
class _Incidence:
    """The scalar incidence *equations × unknowns* of a mechanism.

    ``columns[c]`` is the entity an unknown belongs to (3 per moving link, 2 per pin);
    ``rows[r]`` the columns equation ``r`` involves and ``row_info[r]`` its origin:
    ``("R", pin, link)``, ``("P", joint, slider)`` or ``("D", joint, driver index)``.
    """

    columns: tuple[Entity, ...]
    rows: tuple[tuple[int, ...], ...]
    row_info: tuple[tuple, ...]


@dataclass(frozen=True)
class _Block:
    """One strongly connected block of the matched system, in solving order."""

    links: tuple[str, ...]              # file order; empty for pin points alone
    drivers: tuple[int, ...]            # drivers whose equation the block matched


def _incidence(m: Mechanism) -> _Incidence:
    """Columns (link poses, then pin points) and rows (pins, sliders, drivers)."""
    frame = m.frame
    pins = [j for j in m.joints if j.kind is JointKind.R]
    columns: list[Entity] = []
    first: dict[Entity, int] = {}
    for e in [("L", x) for x in m.link_names if x != frame] + [("J", j.name) for j in pins]:
        first[e] = len(columns)
        columns += [e] * (3 if e[0] == "L" else 2)

    def lc(link, which):
        return [] if link == frame else [first["L", link] + w for w in which]

    rows: list[tuple[int, ...]] = []
    info: list[tuple] = []
    for j in pins:
        for x in j.links:
            for k in (0, 1):       # x- and y-equation
                rows.append((first["J", j.name] + k, *lc(x, (k, 2))))
                info.append(("R", j.name, x))
    for j in m.joints:
        if j.kind is JointKind.P:
            g, sl = j.links
            rows += [tuple(lc(g, (2,)) + lc(sl, (2,))), tuple(lc(g, (0, 1, 2)) + lc(sl, (0, 1, 2)))]
            info += [("P", j.name, sl)] * 2
    for i, d in enumerate(m.drivers):
        which = (2,) if m.is_rotary(d) else (0, 1, 2)
        rows.append(tuple(lc(d.links[0], which) + lc(d.links[1], which)))
        info.append(("D", d.joint, i))
    return _Incidence(tuple(columns), tuple(rows), tuple(info))


def maximum_matching(rows, n_cols: int) -> np.ndarray:
    """A maximum bipartite matching of rows to columns: ``match[r]`` is the column of row
    ``r`` (-1: unmatched); ``rows[r]`` lists the columns row ``r`` may take.

    Augmenting paths from each row in turn (Kuhn 1955), iterative; O(rows · edges),
    a few microseconds for a mechanism's incidence (tens of rows of 2–6 entries), and
    no sparse-matrix library to import.  Which maximum matching is found does not
    change the decomposition: its coarse and fine Dulmage–Mendelsohn parts and their
    order are the same for every maximum matching (Dulmage & Mendelsohn 1958).
    """
    owner = [-1] * n_cols                   # column -> row
    for r0 in range(len(rows)):
        seen = [False] * n_cols
        parent: dict[int, tuple[int, int]] = {}   # column -> (row that reached it, previous column)
        stack = [(r0, -1)]
        end = -1
        while stack and end < 0:
            r, via = stack.pop()
            for c in rows[r]:
                if seen[c]:
                    continue
                seen[c] = True
                parent[c] = (r, via)
                if owner[c] < 0:
                    end = c
                    break
                stack.append((owner[c], c))
        while end >= 0:                     # flip the path back to r0
            r, prev = parent[end]
            owner[end] = r
            end = prev
    match = np.full(len(rows), -1, dtype=int)
    for c, r in enumerate(owner):
        if r >= 0:
            match[r] = c
    return match


def _matching(m: Mechanism, inc: _Incidence) -> np.ndarray:
    """Maximum bipartite matching row → column; raises when a part of the mechanism is
    under- or over-constrained."""
    n_rows, n_cols = len(inc.rows), len(inc.columns)
    match = maximum_matching(inc.rows, n_cols)
    free_cols = sorted(set(range(n_cols)) - set(int(c) for c in match if c >= 0))
    surplus_rows = [r for r in range(n_rows) if match[r] < 0]
    if free_cols or surplus_rows:
        raise _structure_error(m, inc, match, free_cols, surplus_rows)
    return match


def _structure_error(m: Mechanism, inc: _Incidence, match, free_cols, surplus_rows) -> Exception:
    """MobilityError (driver count ≠ F) or DecompositionError naming the free links
    and the surplus joints (Dulmage–Mendelsohn coarse parts)."""
    under, over = _dm_coarse(inc.rows, match, len(inc.columns), free_cols, surplus_rows)
    free_links = sorted({inc.columns[c][1] for c in under if inc.columns[c][0] == "L"}, key=m.link_names.index)
    free_pins = sorted({inc.columns[c][1] for c in under if inc.columns[c][0] == "J"}, key=m.joint_names.index)
    over_joints = sorted({inc.row_info[r][1] for r in over}, key=m.joint_names.index)
    parts = []
    if free_cols:
        parts.append(f"under-constrained part (moves freely): links {', '.join(free_links) or '-'}"
                     + (f" and pins {', '.join(free_pins)}" if free_pins and not free_links else ""))
    if surplus_rows:
        parts.append(f"over-constrained part (surplus constraints): joints {', '.join(over_joints)}")
    p = n_pairs(m)
    formula_f = 3 * (m.n_links - 1) - 2 * p
    got = (f"{len(m.drivers)} driver(s) for Chebyshev–Grübler mobility F = 3(n−1) − 2p = "
           f"3·{m.n_links - 1} − 2·{p} = {formula_f}; " + "; ".join(parts))
    what = f"mechanism '{m.name or ''}'"
    if formula_f == len(m.drivers):
        return DecompositionError(explain(
            what, expected="a structurally determined system (every part fixed by its joints and drivers)",
            got=got, hint="move a driver into the free part, or remove a surplus link/joint"))
    hint = ("add [[driver]] entries" if formula_f > len(m.drivers) else
            "remove drivers, or the chain has redundant links (see 'multiloop analyse')")
    if m.has_geometry:   # special dimensions: say whether the real geometry moves
        mob = actual_mobility(m)
        if mob.actual_F == len(m.drivers) and mob.redundant:
            hint = (f"the geometry does move with {mob.actual_F} DOF (special dimensions): "
                    f"redundant constraint(s) {', '.join(mob.redundant)}; remove the "
                    "redundant link or joint to solve it")
    return MobilityError(explain(what, expected=f"{formula_f} driver(s) (one per degree of freedom)",
                                 got=got, hint=hint))


def _blocks(inc: _Incidence, match: np.ndarray) -> list[_Block]:
    """Strongly connected components of the matched system's entity digraph, in a
    topological order (ties broken by first column), as blocks of links."""
    cols = inc.columns
    first = {}
    for c, e in enumerate(cols):
        first.setdefault(e, c)
    g = nx.DiGraph()
    g.add_nodes_from(sorted(first, key=lambda e: (e[0] != "J", first[e])))
    matched_rows: dict[Entity, list[int]] = {}
    for r, c in enumerate(match):
        v = cols[c]
        matched_rows.setdefault(v, []).append(r)
        g.add_edges_from((cols[c2], v) for c2 in inc.rows[r] if cols[c2] != v)
    cond = nx.condensation(g)
    members: dict[int, list[Entity]] = {}
    for e, k in cond.graph["mapping"].items():
        members.setdefault(k, []).append(e)
    key = {k: min(first[e] for e in es) for k, es in members.items()}
    out = []
    for k in nx.lexicographical_topological_sort(cond, key=key.__getitem__):
        links = sorted((e[1] for e in members[k] if e[0] == "L"), key=lambda x: first["L", x])
        if not links:
            continue  # pin points carried by a known link
        rows = [r for e in members[k] for r in matched_rows.get(e, [])]
        drv = sorted({inc.row_info[r][2] for r in rows if inc.row_info[r][0] == "D"})
        out.append(_Block(tuple(links), tuple(drv)))
    return out


def _check_rigid(m: Mechanism, links: list[str], cons: list[Constraint], realisations) -> None:
    """Generic rank of a block's Jacobian (two random realisations) must be 3 × links."""
    n = 3 * len(links)
    for at, axis, org in realisations:
        J = reference_jacobian(m, cons, links, at, axis, org)
        rank = np.linalg.matrix_rank(J, tol=1e-9 * max(1.0, np.abs(J).max()))
        if rank < n:
            jn = sorted({c.joint for c in cons}, key=m.joint_names.index)
            raise DecompositionError(explain(
                f"block of links {', '.join(links)} (joints {', '.join(jn)})",
                expected="a rigid Assur group (its equations independent for a generic geometry)",
                got=f"{n - rank} internal degree(s) of freedom with as many redundant constraints "
                    f"(rank {rank} < {n}): it passes the counting but is not rigid",
                hint="some links form a rigid sub-chain while others can move; check the joints named here"))


def _plan(m: Mechanism, inc: _Incidence, blocks: list[_Block], check_rigidity: bool) -> AssurPlan:
    """Driver steps and Assur groups in the blocks' order, with the link numbers."""
    steps: list = []
    known = {m.frame}
    solved_by: dict[str, int] = {}
    numbers = {m.frame: 0}
    realisations = [_random_realisation(m, s) for s in (12345, 67890)] if check_rigidity else []
    for blk in blocks:
        links = list(blk.links)
        cons = _pair_constraints(m, links, known)
        if sum(c.n_equations for c in cons) != 3 * len(links):  # pragma: no cover - by the matching
            raise DecompositionError(f"internal: block {links} has the wrong number of equations")
        _check_rigid(m, links, cons, realisations)
        for x in links:
            numbers[x] = len(numbers)
            solved_by[x] = len(steps)
        if len(links) == 1 and len(blk.drivers) == 1:
            steps.append(_driver_step(m, blk.drivers[0], links[0], cons, numbers))
        else:
            g = _make_group(m, sum(isinstance(s, AssurGroup) for s in steps), links, cons,
                            known, list(blk.drivers), tuple(numbers[x] for x in links))
            steps.append(_relabelled(m, g))
        known.update(links)
    return AssurPlan(m, tuple(steps), tuple(numbers.items()), tuple(solved_by.items()))


def _driver_step(m: Mechanism, i: int, link: str, cons: list[Constraint], numbers: dict) -> DriverStep:
    """The input link ``link`` moved by driver ``i`` (given either way round)."""
    d = m.drivers[i]
    base = d.links[0] if d.links[1] == link else d.links[1]
    return DriverStep(i, d.joint, m.joint(d.joint).kind.value, base, link, tuple(cons),
                      (numbers.get(base, 0), numbers[link]))


def _dm_coarse(rows, match, n_cols, free_cols, surplus_rows):
    """Columns of the under-determined part and rows of the over-determined part."""
    col_rows: dict[int, list[int]] = {}
    for r, cs in enumerate(rows):
        for c in cs:
            col_rows.setdefault(c, []).append(r)
    row_of_col = {int(c): r for r, c in enumerate(match) if c >= 0}
    # under: columns reachable from free columns: col -> row containing it -> its matched col
    under, stack = set(free_cols), list(free_cols)
    while stack:
        c = stack.pop()
        for r in col_rows.get(c, []):
            c2 = int(match[r])
            if c2 >= 0 and c2 not in under:
                under.add(c2)
                stack.append(c2)
    # over: rows reachable from surplus rows: row -> its columns -> their matched rows
    over, stack = set(surplus_rows), list(surplus_rows)
    while stack:
        r = stack.pop()
        for c in rows[r]:
            r2 = row_of_col.get(c)
            if r2 is not None and r2 not in over:
                over.add(r2)
                stack.append(r2)
    return under, over


def _pair_constraints(m: Mechanism, links: list[str], known: set[str]) -> list[Constraint]:
    """The block's equations in pair form (host of a pin = a known link if any)."""
    B = set(links)
    out: list[Constraint] = []
    frame = m.frame
    for j in m.joints:
        on_b = [x for x in j.links if x in B]
        if not on_b:
            continue
        if j.kind is JointKind.R:
            # host: a known link (the frame first), else the block's first link on the pin
            here = [x for x in j.links if x in B or x in known]
            out += [Constraint("R", j.name, host, x) for host, x in
                    pin_pairs(here, key=lambda x: (x not in known, x != frame)) if x in B]
        else:
            g, s = j.links
            if (g in B or g in known) and (s in B or s in known):
                out.append(Constraint("P", j.name, g, s))
    for i, d in enumerate(m.drivers):
        a, b = d.links
        if (a in B or b in B) and all(x in B or x in known for x in (a, b)):
            kind = "drive_R" if m.is_rotary(d) else "drive_P"
            out.append(Constraint(kind, d.joint, a, b, i))
    return out


def _make_group(m: Mechanism, index: int, links: list[str], cons: list[Constraint],
                known: set[str], drv: list[int], numbers: tuple[int, ...]) -> AssurGroup:
    B = set(links)
    pair_cons = [c for c in cons if c.kind in ("R", "P")]
    inner = [c for c in pair_cons if c.a in B and c.b in B]
    outer = [c for c in pair_cons if not (c.a in B and c.b in B)]
    inner_joints = tuple(dict.fromkeys(c.joint for c in inner))
    outer_joints = tuple(dict.fromkeys(c.joint for c in outer))
    known_links = tuple(dict.fromkeys(c.a if c.a not in B else c.b for c in outer))
    full = tuple((x, tuple(j.name for j in m.joints_of(x))) for x in links)
    # class: longest inner contour or largest inner degree, at least II
    lg = nx.MultiGraph()
    lg.add_nodes_from(links)
    for c in inner:
        lg.add_edge(c.a, c.b)
    deg = max((d for _, d in lg.degree()), default=0)
    longest = 0
    simple = nx.Graph(lg)
    if simple.number_of_edges() >= len(links):  # has a cycle
        for cyc in nx.simple_cycles(simple.to_directed()):
            if len(cyc) > 2:
                longest = max(longest, len(cyc))
    cls = max(2, longest, deg)
    order = len(outer)
    layout = None
    if drv:
        layout = _actuator_layout(m, links, cons)
        kind = GroupKind.DRIVEN if layout is None else GroupKind.ACTUATED
    elif len(links) == 2 and len(inner) == 1 and len(outer) == 2 and \
            {outer[0].a, outer[0].b} & B != {outer[1].a, outer[1].b} & B:
        o1, o2 = outer
        l1 = o1.b if o1.b in B else o1.a
        l2 = links[0] if links[1] == l1 else links[1]
        ks = [m.joint(o1.joint).kind.value, m.joint(inner[0].joint).kind.value, m.joint(o2.joint).kind.value]
        s = "".join(ks)
        if s not in DYAD_KINDS:
            s = s[::-1]
            o1, o2, l1, l2 = o2, o1, l2, l1
        kind = GroupKind(s) if s in DYAD_KINDS else GroupKind.GENERAL
        layout = DyadLayout(o1.joint, inner[0].joint, o2.joint, l1, l2) if s in DYAD_KINDS else None
        cls = 2
    elif len(links) == 4 and len(inner) == 3 and len(outer) == 3 and deg == 3 and \
            all(m.joint(c.joint).kind is JointKind.R for c in pair_cons):
        tern = next(x for x, d in lg.degree() if d == 3)
        bins = tuple(x for x in links if x != tern)
        outs = tuple(next(c.joint for c in outer if x in (c.a, c.b)) for x in bins)
        inns = tuple(next(c.joint for c in inner if x in (c.a, c.b)) for x in bins)
        kind, layout = GroupKind.TRIAD, TriadLayout(tern, bins, outs, inns)
    elif len(links) == 4 and len(inner) == 4 and len(outer) == 2 and longest == 4:
        kind = GroupKind.CLASS_IV
        with_outer = [c.b if c.b in B else c.a for c in outer]
        bins = [x for x in links if x not in with_outer]
        if len(set(with_outer)) == 2 and len(bins) == 2 and \
                all(m.joint(c.joint).kind is JointKind.R for c in pair_cons):
            def _inner(t, b_):
                return next((c.joint for c in inner if {c.a, c.b} == {t, b_}), None)
            t1, t2 = with_outer
            o1 = next(c.joint for c in outer if t1 in (c.a, c.b))
            o2 = next(c.joint for c in outer if t2 in (c.a, c.b))
            js = (_inner(t1, bins[0]), _inner(t1, bins[1]), _inner(t2, bins[0]), _inner(t2, bins[1]))
            if None not in js:
                layout = Class4Layout(t1, t2, bins[0], bins[1], o1, o2, *js)
    else:
        kind = GroupKind.GENERAL
    return AssurGroup(index, cls, order, kind, tuple(links), full, inner_joints, outer_joints,
                      known_links, tuple(cons), numbers, layout, tuple(drv))


def _actuator_layout(m: Mechanism, links: list[str], cons: list[Constraint]) -> ActuatorLayout | None:
    """The roles of a three-link block made of a linear actuator (two links, each with one
    R pin besides the driven P joint between them) and one more link pinned to it: a
    triangle whose actuator side has a known length at each input; None otherwise."""
    drive = [c for c in cons if c.kind.startswith("drive")]
    slides = [c for c in cons if c.kind == "P"]
    pins = [c for c in cons if c.kind == "R"]
    if len(links) != 3 or len(drive) != 1 or drive[0].kind != "drive_P" or len(slides) != 1 \
            or len(pins) != 3 or {slides[0].a, slides[0].b} != {drive[0].a, drive[0].b}:
        return None
    cyl = {drive[0].a, drive[0].b}
    if not cyl <= set(links) or any(len(m.joints_of(x)) != 2 for x in cyl):
        return None
    third = next(x for x in links if x not in cyl)
    inner = [c for c in pins if {c.a, c.b} <= set(links)]
    outer = [c for c in pins if not {c.a, c.b} <= set(links)]
    if len(inner) != 1 or third not in (inner[0].a, inner[0].b) or len(outer) != 2:
        return None
    far = inner[0].a if inner[0].b == third else inner[0].b
    near = next(x for x in cyl if x != far)
    o1 = next((c.joint for c in outer if near in (c.a, c.b)), None)
    o2 = next((c.joint for c in outer if third in (c.a, c.b)), None)
    if o1 is None or o2 is None:
        return None
    return ActuatorLayout(o1, inner[0].joint, o2, near, far, third, drive[0].joint, drive[0].driver)
