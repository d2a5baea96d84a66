"""Frozen value objects of a planar linkage and the validating builder.

A :class:`Mechanism` is immutable and hashable; no algorithm ever changes it
(anything that depends on motion lives in a result object).  It is built through
:class:`MechanismBuilder`, whose :meth:`~MechanismBuilder.build` validates the whole
description and reports *every* problem at once.

Model (the file format (README), Pozhbelko & Kuts 2020 notation):

* a **link** is a rigid body; at most one is the **frame** (a bare chain has none);
* an ``R`` **joint** (pin) joins two or more links; a pin joining ``n'`` links is a
  *multiple joint* of multiplicity ``j = n' - 1`` and counts as ``n' - 1`` pairs;
* a ``P`` **joint** (slider) joins exactly two links, guide first, slider second;
* geometry (optional): the reference position ``at`` of every joint and, for a P
  joint, the guide direction ``axis``, all in one configuration that satisfies
  closure;
* **drivers** name the joints whose relative motion is the input;
* optional mass data, tracer points, external forces, gravity.
"""
from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field
from typing import Iterable, Sequence

from .errors import InputError, TopologyError, explain, list_problems

__all__ = [
    "JointKind",
    "Link",
    "Joint",
    "Driver",
    "TracerPoint",
    "Load",
    "Mechanism",
    "MechanismBuilder",
    "chain_from_joint_lists",
    "driver_bound",
    "MAX_ANGLE_DEG",
    "MAX_SLIDE_SIZES",
]

Vec2 = tuple[float, float]


class JointKind(str, enum.Enum):
    """Lower-pair kind: ``R`` revolute pin, ``P`` prismatic slider."""

    R = "R"
    P = "P"

    @property
    def is_rotary(self) -> bool:
        """An R joint turns (a driver on it takes radians, read and shown in degrees); a P
        joint slides (metres).  :meth:`Mechanism.is_rotary` asks it of a driver's joint."""
        return self is JointKind.R


@dataclass(frozen=True, slots=True)
class Link:
    """A rigid body.

    Attributes
    ----------
    name : str
    is_frame : bool
        True for the ground link.
    mass : float or None
        Mass in kg (kinetostatics).
    cg : (float, float) or None
        Centre of mass in the reference configuration (m).
    inertia : float or None
        Moment of inertia about the centre of mass (kg m^2).
    """

    name: str
    is_frame: bool = False
    mass: float | None = None
    cg: Vec2 | None = None
    inertia: float | None = None
    color: str | None = None


@dataclass(frozen=True, slots=True)
class Joint:
    """A lower pair.

    ``links`` is ordered: for a P joint ``links[0]`` is the guide and ``links[1]``
    the slider; for an R joint used as a driver, the input is the rotation of
    ``links[1]`` relative to ``links[0]``.
    """

    name: str
    kind: JointKind
    links: tuple[str, ...]
    at: Vec2 | None = None
    axis: Vec2 | None = None

    @property
    def multiplicity(self) -> int:
        """``j = n' - 1``: 1 for a simple joint, ``j >= 2`` for a multiple joint."""
        return len(self.links) - 1

    @property
    def n_pairs(self) -> int:
        """Kinematic pairs this joint counts for (``n' - 1``)."""
        return len(self.links) - 1

    @property
    def is_multiple(self) -> bool:
        return len(self.links) > 2


#: largest |R input| accepted (deg): beyond it a float has no sub-microdegree resolution
MAX_ANGLE_DEG = 1e9
#: largest |P input| accepted, in units of the mechanism's size (the solver's lead-in
#: walks it in steps of 1 % of the size)
MAX_SLIDE_SIZES = 100.0


@dataclass(frozen=True, slots=True)
class Driver:
    """An input: relative rotation (R) or slide (P) of ``links[1]`` w.r.t. ``links[0]``.

    ``speed`` (rad/s or m/s) and ``acceleration`` are used by kinetostatics; the
    kinematic analogues assume unit speed and zero acceleration.  ``range`` is the
    driver's own limits ``(low, high)`` measured from the reference (rad or m: a motor's
    angular limits, a cylinder's stroke from retracted to extended), or None; it
    contains the reference (``low <= 0 <= high``).
    """

    joint: str
    links: tuple[str, str]
    speed: float | None = None
    acceleration: float | None = None
    range: tuple[float, float] | None = None


@dataclass(frozen=True, slots=True)
class TracerPoint:
    """A point fixed on a link, given in the reference configuration."""

    name: str
    link: str
    at: Vec2


@dataclass(frozen=True, slots=True)
class Load:
    """An external force (and/or moment) on a link.

    ``value`` is a constant force ``(Fx, Fy)`` in the frame; ``table`` optionally gives
    it against the input as rows ``(input_deg, Fx, Fy)`` (linear interpolation,
    periodic over 360 deg, or over 720 deg when a row lies beyond 360 deg; see
    ``kin.forces``).  A force without ``at`` acts at the centre of mass.  ``moment`` is a constant couple (N m, counter-clockwise).
    """

    link: str
    at: Vec2 | None = None
    value: Vec2 = (0.0, 0.0)
    table: tuple[tuple[float, float, float], ...] | None = None
    moment: float = 0.0
    name: str | None = None


@dataclass(frozen=True, slots=True)
class Mechanism:
    """An immutable planar linkage (or bare chain when it has no frame).

    Build it with :class:`MechanismBuilder` or :func:`topo.io.load`; never mutate it.
    """

    links: tuple[Link, ...]
    joints: tuple[Joint, ...]
    drivers: tuple[Driver, ...] = ()
    points: tuple[TracerPoint, ...] = ()
    loads: tuple[Load, ...] = ()
    gravity: Vec2 | None = None
    name: str | None = None
    description: str | None = None
    source: str | None = None

    # -- lookups -----------------------------------------------------------------
    @property
    def link_names(self) -> tuple[str, ...]:
        return tuple(link.name for link in self.links)

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(joint.name for joint in self.joints)

    @property
    def n_links(self) -> int:
        return len(self.links)

    @property
    def n_joints(self) -> int:
        return len(self.joints)

    @property
    def frame(self) -> str | None:
        """Name of the frame link, or None for a bare chain."""
        for link in self.links:
            if link.is_frame:
                return link.name
        return None

    @property
    def has_geometry(self) -> bool:
        """True when every joint has a reference position (and every P joint an axis)."""
        return bool(self.joints) and all(
            j.at is not None and (j.kind is JointKind.R or j.axis is not None)
            for j in self.joints)

    @property
    def size(self) -> float:
        """The mechanism's size (m): the larger spread of its joints' reference positions
        in x and y (at least 1e-12; 1.0 with fewer than two positioned joints)."""
        return _extent([j.at for j in self.joints if j.at is not None])

    def is_rotary(self, driver: "Driver | int") -> bool:
        """True when ``driver`` (a :class:`Driver` or its index in ``drivers``) turns its
        links about an R joint (input in rad, read and shown in degrees); False when it
        slides them along a P joint (input in m).

        >>> b = MechanismBuilder()
        >>> b.add_link("ground", frame=True)
        >>> b.add_link("crank"); b.add_link("slider")
        >>> b.add_joint("O", "R", ("ground", "crank"), at=(0, 0))
        >>> b.add_joint("S", "P", ("crank", "slider"), at=(1, 0), axis=(1, 0))
        >>> b.add_driver("O"); b.add_driver("S")
        >>> m = b.build()
        >>> m.is_rotary(0), m.is_rotary(m.drivers[1])
        (True, False)
        """
        d = driver if isinstance(driver, Driver) else self.drivers[driver]
        return self.joint(d.joint).kind.is_rotary

    def link(self, name: str) -> Link:
        for lk in self.links:
            if lk.name == name:
                return lk
        raise KeyError(name)

    def joint(self, name: str) -> Joint:
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError(name)

    def joints_of(self, link: str) -> tuple[Joint, ...]:
        """All joints the link lies on, in file order."""
        return tuple(j for j in self.joints if link in j.links)

    def degree(self, link: str) -> int:
        """Number of joints on the link (an *i*-vertex link has degree *i*)."""
        return sum(1 for j in self.joints if link in j.links)

    def _repr_svg_(self) -> str:
        """Notebook preview: the reference configuration with names (:mod:`topo.svg`)."""
        from .svg import mechanism_svg  # noqa: PLC0415 - only when a notebook asks
        return mechanism_svg(self)

    def with_drivers(self, drivers: Sequence[Driver]) -> "Mechanism":
        """A copy with another driver set (validated)."""
        b = MechanismBuilder.from_mechanism(self)
        b.drivers = list(drivers)
        return b.build()

    def with_frame(self, frame: str | None) -> "Mechanism":
        """A copy with another frame link (``None`` gives the bare chain)."""
        b = MechanismBuilder.from_mechanism(self)
        b.links = [Link(lk.name, lk.name == frame, lk.mass, lk.cg, lk.inertia, lk.color)
                   for lk in b.links]
        if frame is not None and frame not in {lk.name for lk in b.links}:
            raise TopologyError(explain("frame", expected="a link of the chain",
                                        got=repr(frame)))
        return b.build()

    def relabelled(self, link_map: dict[str, str], joint_map: dict[str, str] | None = None,
                   order: Sequence[int] | None = None) -> "Mechanism":
        """A copy with links (and joints) renamed; ``order`` permutes the joint list.

        Used by tests for relabelling invariance.
        """
        joint_map = joint_map or {}
        joints = [Joint(joint_map.get(j.name, j.name), j.kind,
                        tuple(link_map[x] for x in j.links), j.at, j.axis)
                  for j in self.joints]
        if order is not None:
            joints = [joints[i] for i in order]
        links = [Link(link_map[lk.name], lk.is_frame, lk.mass, lk.cg, lk.inertia, lk.color)
                 for lk in self.links]
        drivers = [Driver(joint_map.get(d.joint, d.joint),
                          (link_map[d.links[0]], link_map[d.links[1]]), d.speed,
                          d.acceleration) for d in self.drivers]
        points = [TracerPoint(p.name, link_map[p.link], p.at) for p in self.points]
        loads = [Load(link_map[ld.link], ld.at, ld.value, ld.table, ld.moment, ld.name)
                 for ld in self.loads]
        return Mechanism(tuple(links), tuple(joints), tuple(drivers), tuple(points),
                         tuple(loads), self.gravity, self.name, self.description, self.source)


@dataclass
class MechanismBuilder:
    """Mutable staging area; :meth:`build` validates and freezes.

    Examples
    --------
    >>> b = MechanismBuilder(name="four-bar")
    >>> b.add_link("ground", frame=True)
    >>> for name, links, at in [("O", ("ground", "crank"), (0, 0)),
    ...                         ("A", ("crank", "coupler"), (1, 1)),
    ...                         ("B", ("coupler", "rocker"), (4, 2)),
    ...                         ("C", ("rocker", "ground"), (4, 0))]:
    ...     b.add_joint(name, "R", links, at=at)
    >>> b.add_driver("O")
    >>> m = b.build()
    >>> m.n_links, m.n_joints, m.frame
    (4, 4, 'ground')
    """

    name: str | None = None
    description: str | None = None
    source: str | None = None
    links: list[Link] = field(default_factory=list)
    joints: list[Joint] = field(default_factory=list)
    drivers: list[Driver | tuple] = field(default_factory=list)
    points: list[TracerPoint] = field(default_factory=list)
    loads: list[Load] = field(default_factory=list)
    gravity: Vec2 | None = None

    @classmethod
    def from_mechanism(cls, m: Mechanism) -> "MechanismBuilder":
        return cls(m.name, m.description, m.source, list(m.links), list(m.joints),
                   list(m.drivers), list(m.points), list(m.loads), m.gravity)

    def add_link(self, name: str, frame: bool = False, mass: float | None = None,
                 cg: Iterable[float] | None = None, inertia: float | None = None,
                 color: str | None = None) -> None:
        self.links.append(Link(name, bool(frame), mass,
                               None if cg is None else _vec2(cg), inertia, color))

    def add_joint(self, name: str, kind: str | JointKind, links: Iterable[str],
                  at: Iterable[float] | None = None,
                  axis: Iterable[float] | None = None) -> None:
        self.joints.append(Joint(name, kind if isinstance(kind, JointKind) else kind,  # type: ignore[arg-type]
                                 tuple(links), None if at is None else _vec2(at),
                                 None if axis is None else _vec2(axis)))

    def add_driver(self, joint: str, links: Sequence[str] | None = None,
                   speed: float | None = None, acceleration: float | None = None,
                   range: Sequence[float] | None = None) -> None:
        """A driver on ``joint``; ``range`` = (low, high) from the reference in rad (R)
        or m (P)."""
        self.drivers.append((joint, None if links is None else tuple(links), speed,
                             acceleration, None if range is None else tuple(range)))

    def add_point(self, name: str, link: str, at: Iterable[float]) -> None:
        self.points.append(TracerPoint(name, link, _vec2(at)))

    def add_load(self, link: str, at: Iterable[float] | None = None,
                 value: Iterable[float] = (0.0, 0.0), table=None, moment: float = 0.0,
                 name: str | None = None) -> None:
        self.loads.append(Load(link, None if at is None else _vec2(at), _vec2(value),
                               None if table is None else tuple(tuple(map(float, r)) for r in table),
                               float(moment), name))

    # ---------------------------------------------------------------------------
    def build(self) -> Mechanism:
        """Validate everything and return the frozen :class:`Mechanism`.

        The phases each add the problems they find to one list: links, joints (their
        kinds, link counts and axes), geometry (all-or-nothing, no zero-length link,
        no coincident pins), drivers, points and loads, mass data.  All problems are
        reported at once; connectivity is checked last, on its own.

        Raises
        ------
        InputError
            Malformed names, kinds, link counts, coordinates or mass data (all
            problems listed).
        TopologyError
            Unknown links, disconnected chains, drivers on unknown joints.
        """
        problems: list[str] = []
        links = _collect_links(self.links, problems)
        joints = _collect_joints(self.joints, links, problems)
        problems += _geometry_problems(joints)
        drivers = _collect_drivers(self.drivers, joints, links, problems)
        problems += _attachment_problems(self.points, self.loads, links, {j.name for j in joints})
        problems += _mass_problems(links.values())
        if problems:
            more = _CUT in problems
            raise InputError(list_problems([p for p in problems if p != _CUT], more=more))
        comps = _components(list(links), joints)
        if len(comps) > 1:
            desc = " | ".join("{" + ", ".join(sorted(c)) + "}" for c in comps)
            raise TopologyError(explain("chain", expected="one connected chain",
                                        got=f"{len(comps)} separate parts: {desc}",
                                        hint="every link must be reachable through joints"))
        return Mechanism(tuple(links.values()), tuple(joints), tuple(drivers),
                         tuple(self.points), tuple(self.loads), self.gravity, self.name,
                         self.description, self.source)


# ---- the phases of MechanismBuilder.build -------------------------------------------
def _collect_links(given: Iterable[Link], problems: list[str]) -> dict[str, Link]:
    """The explicit links by name (duplicates and a second frame reported)."""
    links: dict[str, Link] = {}
    for link in given:
        if not isinstance(link.name, str) or not link.name:
            problems.append(explain("[[link]] name", expected="a non-empty string", got=repr(link.name)))
            continue
        if link.name in links:
            problems.append(explain(f"link '{link.name}'", expected="a unique name",
                                    got="a duplicate [[link]] entry"))
        links[link.name] = link
    frames = [lk.name for lk in links.values() if lk.is_frame]
    if len(frames) > 1:
        problems.append(explain("frame", expected="exactly one link with frame = true",
                                got=f"{len(frames)} ({', '.join(frames)})"))
    return links


def _joint_problems(j: Joint, kind: JointKind) -> list[str]:
    """Link count, distinct links and the axis rule of one joint."""
    where, names, out = f"joint '{j.name}'", j.links, []
    if len(names) < 2:
        out.append(explain(where, expected="at least 2 links", got=f"{len(names)} ({', '.join(names) or 'none'})",
                           hint="a joint connects two or more links"))
    if kind is JointKind.P and len(names) != 2:
        out.append(explain(where, expected="exactly 2 links for a P joint (guide, slider)", got=f"{len(names)}"))
    if len(set(names)) != len(names):
        out.append(explain(f"{where} links", expected="distinct links", got=repr(list(names))))
    if kind is JointKind.P and j.at is not None and j.axis is None:
        out.append(explain(f"{where} axis", expected="a guide direction [dx, dy] for a P joint with geometry",
                           got="nothing"))
    if j.axis is not None:
        if kind is JointKind.R:
            out.append(explain(f"{where} axis", expected="no axis on an R joint", got=repr(j.axis)))
        elif math.hypot(*j.axis) == 0.0:
            out.append(explain(f"{where} axis", expected="a non-zero direction", got=repr(list(j.axis))))
    return out


def _collect_joints(given: Iterable[Joint], links: dict[str, Link], problems: list[str]) -> list[Joint]:
    """The valid joints, with kinds as :class:`JointKind`; links they name but the
    file does not declare are added to ``links`` (in order of first appearance)."""
    joints: list[Joint] = []
    seen: set[str] = set()
    for j in given:
        if not isinstance(j.name, str) or not j.name:
            problems.append(explain("[[joint]] name", expected="a non-empty string", got=repr(j.name)))
            continue
        if j.name in seen:
            problems.append(explain(f"joint '{j.name}'", expected="a unique name", got="a duplicate [[joint]] entry"))
        seen.add(j.name)
        try:
            kind = JointKind(j.kind)
        except ValueError:
            problems.append(explain(f"joint '{j.name}' kind", expected="'R' or 'P'", got=repr(j.kind)))
            continue
        if not all(isinstance(x, str) and x for x in j.links):
            problems.append(explain(f"joint '{j.name}' links", expected="link names (strings)",
                                    got=repr(list(j.links))))
            continue
        problems += _joint_problems(j, kind)
        for x in j.links:
            links.setdefault(x, Link(x))
        joints.append(Joint(j.name, kind, tuple(j.links), j.at, j.axis))
    if not joints:
        problems.append(explain("chain", expected="at least one joint", got="none"))
    return joints


def _geometry_problems(joints: Sequence[Joint]) -> list[str]:
    """Geometry on every joint or on none; no two pins at one point.

    Two pins of one link at the same point make a zero-length link; two separate
    pins at the same point make every group they close singular.  Points closer
    than ``1e-9`` of the mechanism's size count as one.
    """
    with_at = [j for j in joints if j.at is not None]
    if with_at and len(with_at) != len(joints):
        missing = [j.name for j in joints if j.at is None]
        return [explain("geometry", expected="'at' on every joint or on none", got=f"missing on {', '.join(missing)}")]
    order = {j.name: i for i, j in enumerate(joints)}
    pins = sorted((j for j in with_at if j.kind is JointKind.R), key=lambda j: j.at[0])
    if len(pins) < 2:
        return []
    xs, ys = [j.at[0] for j in with_at], [j.at[1] for j in with_at]
    tol = 1e-9 * max(max(xs) - min(xs), max(ys) - min(ys))
    out: list[str] = []
    for i, a in enumerate(pins):      # a sweep along x: only pins within tol in x are compared
        for b in pins[i + 1:]:
            if b.at[0] - a.at[0] > tol:
                break
            if math.dist(a.at, b.at) <= tol:
                if len(out) == _MAX_PAIRS:
                    return out + [_CUT]
                out.append(_coincident_pins(*sorted((a, b), key=lambda j: order[j.name])))
    return out


#: coincident pairs reported before the search stops (a pile of pins has n² pairs)
_MAX_PAIRS = 200
_CUT = "\x00more"


def _coincident_pins(a: Joint, b: Joint) -> str:
    at = f"({a.at[0]:g}, {a.at[1]:g})"
    shared = [x for x in a.links if x in b.links]
    if shared:
        return explain(f"link '{shared[0]}'", expected="a length > 0 between its pins",
                       got=f"a zero-length link: its pins '{a.name}' and '{b.name}' are both at {at}",
                       hint="move one of the pins, or write one multiple joint if the links share one pin")
    return explain(f"joints '{a.name}' and '{b.name}'", expected="pins at distinct points",
                   got=f"coincident pins, both at {at}",
                   hint="links that share one pin are one [[joint]] listing all of them; otherwise move one pin")


def _collect_drivers(given: Iterable, joints: Sequence[Joint], links: dict[str, Link],
                     problems: list[str]) -> list[Driver]:
    """Drivers on known joints, each on two distinct links of its joint, one per pair."""
    joint_by_name = {j.name: j for j in joints}
    drivers: list[Driver] = []
    for d in given:
        jn, dl, speed, acc, rng = ((d.joint, d.links, d.speed, d.acceleration, d.range)
                                   if isinstance(d, Driver) else (tuple(d) + (None,))[:5])
        if jn not in joint_by_name:
            problems.append(explain(f"[[driver]] joint '{jn}'", expected="the name of a [[joint]]",
                                    got="an unknown joint",
                                    hint=f"known joints: {', '.join(sorted(joint_by_name)) or 'none'}"))
            continue
        jt = joint_by_name[jn]
        dl = tuple(jt.links[:2] if dl is None else dl)
        if len(dl) != 2 or any(x not in jt.links for x in dl) or dl[0] == dl[1]:
            bad = [x for x in dl if x not in links]
            problems.append(explain(f"[[driver]] on joint '{jn}' links",
                                    expected=f"two distinct links of that joint ({', '.join(jt.links)})",
                                    got=repr(list(dl)) + (f" (unknown link {', '.join(bad)})" if bad else "")))
            continue
        if any(x.joint == jn and set(x.links) == set(dl) for x in drivers):
            problems.append(explain(f"[[driver]] on joint '{jn}'", expected="one driver per pair", got="a duplicate"))
        bad = _range_problem(jn, jt.kind, rng, _extent([j.at for j in joints if j.at is not None]))
        if bad:
            problems.append(bad)
            rng = None
        drivers.append(Driver(jn, dl, speed, acc, None if rng is None else (float(rng[0]), float(rng[1]))))  # type: ignore[arg-type]
    return drivers


def _extent(points: Sequence) -> float:
    """The larger spread in x and y of ``points`` (at least 1e-12; 1.0 for fewer than two)."""
    if len(points) < 2:
        return 1.0
    return max(max(max(p[k] for p in points) - min(p[k] for p in points) for k in (0, 1)), 1e-12)


def driver_bound(kind, size: float) -> float:
    """The largest magnitude of a driver's input (rad for an R joint, m for a P joint of a
    mechanism of ``size`` m): :data:`MAX_ANGLE_DEG`, or :data:`MAX_SLIDE_SIZES` × the size."""
    return math.radians(MAX_ANGLE_DEG) if JointKind(kind).is_rotary else MAX_SLIDE_SIZES * size


def _range_problem(jn: str, kind, rng, size: float = 1.0) -> str | None:
    """What is wrong with driver ``jn``'s ``range`` (SI), in the file's units (degrees
    for an R joint, m for a P joint), or None.  Its ends lie within :func:`driver_bound`
    (the mechanism's ``size`` for a P joint)."""
    if rng is None:
        return None
    rotary = JointKind(kind).is_rotary
    unit = "deg" if rotary else "m"
    where = f"[[driver]] on joint '{jn}' range"
    try:
        lo, hi = (float(v) for v in rng)
    except (TypeError, ValueError):
        return explain(where, expected=f"[low, high] ({unit})", got=repr(rng)[:60])
    shown = [math.degrees(v) if rotary else v for v in (lo, hi)]
    got = f"[{shown[0]:.6g}, {shown[1]:.6g}]"
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return explain(where, expected=f"two finite numbers [low, high] ({unit})", got=got)
    if lo >= hi:
        return explain(where, expected=f"low < high ({unit})", got=got,
                       hint="write the retracted (or lower) end first, e.g. [-0.4, 0.6]")
    if lo > 0.0 or hi < 0.0:
        return explain(where, expected=f"a range that contains the reference, low <= 0 <= high ({unit})",
                       got=got, hint="the range is measured from the joint's reference position, "
                                     "like every driver input")
    bound = driver_bound(kind, size)
    if max(-lo, hi) > bound:
        limit = f"{MAX_ANGLE_DEG:g} deg" if rotary else f"{bound:.6g} m ({MAX_SLIDE_SIZES:g} × the mechanism's size)"
        return explain(where, expected=f"ends of magnitude at most {limit}", got=got,
                       hint="the bound of every driver input (solve, forces, check)")
    return None


def _attachment_problems(points: Iterable[TracerPoint], loads: Iterable[Load],
                         links: dict[str, Link], joint_names: set[str] = frozenset()) -> list[str]:
    """Tracer points and loads sit on known links; point names are unique and no point
    takes a joint's name (a point and a joint share the output columns of a solve)."""
    out: list[str] = []
    seen: set[str] = set()
    for p in points:
        if p.link not in links:
            out.append(explain(f"[[point]] '{p.name}' link", expected="a known link", got=repr(p.link)))
        if p.name in seen:
            out.append(explain(f"[[point]] '{p.name}'", expected="a unique name", got="a duplicate"))
        elif p.name in joint_names:
            out.append(explain(f"[[point]] '{p.name}'", expected="a name no joint has",
                               got="the name of a [[joint]]", hint="rename the point"))
        seen.add(p.name)
    for ld in loads:
        if ld.link not in links:
            out.append(explain("[[force]] link", expected="a known link", got=repr(ld.link)))
    return out


def _mass_problems(links: Iterable[Link]) -> list[str]:
    """Mass and moment of inertia are never negative."""
    out = []
    for lk in links:
        if lk.mass is not None and lk.mass < 0:
            out.append(explain(f"link '{lk.name}' mass", expected="a mass >= 0", got=repr(lk.mass)))
        if lk.inertia is not None and lk.inertia < 0:
            out.append(explain(f"link '{lk.name}' inertia", expected="a moment of inertia >= 0 (kg m^2)",
                               got=repr(lk.inertia)))
    return out


def _components(links: list[str], joints: list[Joint]) -> list[set[str]]:
    parent = {x: x for x in links}

    def find(x: str) -> str:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for j in joints:
        for other in j.links[1:]:
            a, b = find(j.links[0]), find(other)
            if a != b:
                parent[a] = b
    groups: dict[str, set[str]] = {}
    for x in links:
        groups.setdefault(find(x), set()).add(x)
    return sorted(groups.values(), key=lambda s: (-len(s), sorted(s)))


def _vec2(v: Iterable[float]) -> Vec2:
    t = tuple(float(x) for x in v)
    if len(t) != 2:
        raise InputError(explain("coordinate", expected="2 numbers [x, y]", got=repr(list(t))))
    return (t[0], t[1])


def chain_from_joint_lists(joint_lists: Sequence[Sequence[str]], name: str | None = None,
                           frame: str | None = None) -> Mechanism:
    """A bare chain from the the file format (README) short form ``joints = [["a","b"], ["b","c","d"], ...]``.

    Joints are named ``J1, J2, …`` in the order given and are all pins (R).

    Examples
    --------
    >>> m = chain_from_joint_lists([["a", "b"], ["b", "c", "d"], ["c", "e"], ["d", "e"], ["e", "a"]])
    >>> [j.multiplicity for j in m.joints]
    [1, 2, 1, 1, 1]
    """
    b = MechanismBuilder(name=name)
    for i, lks in enumerate(joint_lists, 1):
        b.add_joint(f"J{i}", "R", tuple(lks))
    if frame is not None:
        b.add_link(frame, frame=True)
    return b.build()
