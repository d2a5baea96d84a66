"""Range of motion of one driver, and the sampled motion every other check refines on.

The driver is moved from the reference in both directions (the others held at the
reference) on a grid of 0.5° (R) or 1/400 of the mechanism's size (P).  A limit is the
first input where the path cannot be assembled; it is bracketed by the last assembled
and the first failed grid value and refined by bisection on "assembled" to 1e-10 rad
(at a limit some group is at a toggle: its Jacobian determinant tends to zero, which
the report shows).  A single failed grid value with assembled neighbours on a
continuous path is a singular crossing (a change point), not a limit.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from multiloop.kin.groups.registry import has_closed_form
from multiloop.kin.motion import DriverMotion
from multiloop.kin.solve import motion_events, solved_alone
from multiloop.topo.errors import AssemblyError, explain
from multiloop.topo.model import Mechanism

from .sweep import XTOL, Side

__all__ = ["Segment", "Motion", "driver_motion", "R_STEPS", "P_STEPS"]

R_STEPS = 720            # grid steps per turn (0.5°)
_LIMIT_TOL = 1e-13       # a limit's bracket (rad, or fraction of the size for P drivers)
P_STEPS = 400            # grid steps over ± the mechanism's size


@dataclass(frozen=True)
class Segment:
    """The assembled part of one side: ``side.grid[:n]`` with its solved ``state``
    (derivatives included); ``limit`` is the refined last assembled input or None."""

    side: Side
    n: int
    state: object
    limit: float | None
    limit_bracket: tuple[float, float] | None
    singular: tuple[tuple[float, str], ...]
    bound: str | None = None         # what stops it: "assembly", "range" (the driver's own), None

    @property
    def x(self) -> np.ndarray:
        return self.side.grid[: self.n]


@dataclass(frozen=True)
class Motion:
    """The sampled motion of a driver (``driver``) from the reference: one segment
    (full rotation) or two.  ``rotary`` and ``events`` (the driver's certified motion,
    or None without one) are the driver's, copied when the motion is built: every
    refinement reads them."""

    driver: DriverMotion
    rotary: bool
    full_rotation: bool
    segments: tuple[Segment, ...]
    periodic: bool
    events: DriverMotion | None

    @classmethod
    def of(cls, driver: DriverMotion, full_rotation: bool, segments: tuple[Segment, ...],
           periodic: bool) -> "Motion":
        return cls(driver, driver.rotary, full_rotation, segments, periodic,
                   driver if driver.certified else None)

    @property
    def mechanism(self) -> Mechanism:
        return self.driver.mechanism

    @property
    def k(self) -> int:
        return self.driver.k

    @property
    def binds(self) -> tuple[str, ...]:
        """What stops the motion at each of :attr:`limits`: "assembly" or "range"."""
        return tuple(s.bound or "assembly" for s in self.segments if s.limit is not None)

    @property
    def limits(self) -> tuple[float, ...]:
        """Refined limits (rad or m, signed from the reference): (forward, backward)."""
        return tuple(s.limit for s in self.segments if s.limit is not None)


def _first_stop(st, x) -> tuple[int | None, tuple[tuple[float, str], ...]]:
    """Index of the first failure that is not an isolated singular crossing, and the
    crossings passed before it (input, the solver's reason)."""
    ok = st.ok
    singular = []
    steps = np.nanmax(np.abs(np.diff(st.positions[ok], axis=0)), axis=(1, 2)) if ok.sum() > 2 else np.array([np.inf])
    typical = float(np.median(steps))
    for f in np.flatnonzero(~ok):
        if f == 0:
            return 0, ()
        if f + 1 < ok.size and ok[f + 1] and ok[f - 1]:
            jump = np.nanmax(np.abs(st.positions[f + 1] - st.positions[f - 1]))
            if jump <= 4.0 * typical:      # bounded motion through one singular sample
                singular.append((float(x[f]), str(st.status[f])))
                continue
        return int(f), tuple(singular)
    return None, tuple(singular)


def _scan(side: Side, chunk: int | None):
    """The grid solved from the reference; with ``chunk``, in growing prefixes that stop
    after the first failure (a failed Newton position costs many retries)."""
    if chunk is None:
        return side.solve(side.grid, derivatives=True)
    end = chunk
    while True:
        st = side.solve(side.grid[:end], derivatives=True)
        if not st.ok.all() or end >= side.grid.size:
            return st
        end += chunk


def _segment(side: Side, chunk: int | None = None, stop: float | None = None) -> Segment:
    """The assembled part of ``side``; ``stop`` is the certified limit on this side
    (:func:`multiloop.kin.solve.motion_events`), where the motion ends whatever the grid
    shows (the solver reaches inputs beyond a limit of a crank by whole turns)."""
    if stop is not None and np.isfinite(stop):
        cut = np.flatnonzero(np.abs(side.grid) > abs(stop))
        if cut.size:
            f = int(cut[0])
            st_ok = side.solve(side.grid[:f], derivatives=True)
            return Segment(_guarded(side, st_ok), f, st_ok, float(stop), (float(stop), float(stop)), ())
    st = _scan(side, chunk)
    grid = side.grid[: st.n_positions]
    f, singular = _first_stop(st, grid)
    if f == 0:
        raise AssemblyError(explain("reference configuration", expected="an assembled mechanism",
                                    got=str(st.status[0])))
    if f is None and st.n_positions == side.grid.size:
        return Segment(_guarded(side, st), side.grid.size, st, None, None, singular)
    if f is None:                         # chunk ended on an isolated singular sample
        f = st.n_positions - 1
    # to 1e-13 of the size: a driven point moves like the square root of the stroke left
    # before a reach limit, so a limit known to 1e-10 of the size put a tool position
    # 1e-5 of the size off (the workspace's corners); closer than 1e-13 the rounding of
    # another path may put the end past the limit (the row would not solve)
    lo, hi = side.bisect([side.grid[f - 1]], [side.grid[f]],
                          lambda s, r: np.where(s.ok[r], 1.0, -1.0), xtol=_LIMIT_TOL * side.xtol / XTOL)
    st_ok = side.solve(side.grid[:f], derivatives=True)
    return Segment(_guarded(side, st_ok), f, st_ok, float(lo[0]), (float(lo[0]), float(hi[0])),
                   singular)


def _guarded(side: Side, st) -> Side:
    if side.branch is None:
        return side
    return replace(side, signs=np.sign(side.branch(st)))


def _side(dm: DriverMotion, plan, sign: int, heavy: bool, samples: int, branch,
          cancel=None) -> Side:
    """The grid of one side: to 361° (R) or ± the size (P), or to the end of the driver's
    ``range`` on that side at the same spacing (a range end at the reference: that value).
    An R range wider than the turn is sampled over the turn: the motion repeats beyond it,
    and a turn without a limit runs to the range's end (:func:`_bounded`)."""
    m, rotary = dm.mechanism, dm.rotary
    if rotary:
        h, n = 2.0 * np.pi / R_STEPS, R_STEPS + 2
    else:
        n = P_STEPS // 4 if heavy else P_STEPS
        h = m.size / n
    rng = m.drivers[dm.k].range
    span = n * h if rng is None else abs(rng[1] if sign > 0 else rng[0])
    if rotary:
        span = min(span, n * h)
    steps = int(np.ceil(span / h - 1e-9))
    grid = sign * (np.linspace(0.0, span, steps + 1) if steps else np.zeros(1))
    return Side(dm, plan, sign, grid, samples, branch=branch, cancel=cancel, each=heavy)


def _bounded(seg: Segment, rng, sign: int) -> Segment:
    """A segment that ran to the end of the driver's range stops there (``bound`` =
    "range"); one stopped earlier by the assembly keeps its limit (``bound`` = "assembly")."""
    if seg.limit is not None:
        return replace(seg, bound="assembly")
    if rng is None:
        return seg
    return replace(seg, limit=float(rng[1] if sign > 0 else rng[0]), bound="range")


def driver_motion(m: Mechanism, plan, k: int, kinds=(), branch=None, cancel=None) -> Motion:
    """Sample and bound the motion of driver ``k`` (see the module docstring);
    ``kinds`` are the kinds of the Assur groups (a group without a kernel coarsens the P grid);
    ``branch(state)`` gives the signed dyad determinants that guard refinements against
    branch jumps (:meth:`Side._guard`).  A driver with a ``range`` is moved within it:
    its usable range is the intersection of the range and the assembly limits, and each
    segment says which of the two binds.  ``cancel()`` is called before every solve of
    the sides (:attr:`Side.cancel`)."""
    rotary = m.is_rotary(k)
    rng = m.drivers[k].range
    # a group without a closed-form or all-modes kernel is tracked by Newton at about a
    # millisecond per position: its mechanism gets a coarser P grid, fewer samples per
    # zoom iteration (same 1e-10 tolerance, more iterations), and its brackets refined
    # one at a time (Side.each); every path leads in at the solver's own 2° step
    # (Side.stride)
    heavy = any(not has_closed_form(kd) for kd in kinds)
    samples = 8 if heavy else 32
    chunk = 8 if heavy else None
    # the certified walk searches ± the size, or the range
    extent = None if rotary or rng is None else (float(rng[0]), float(rng[1]))
    certified = len(m.drivers) == 1 or solved_alone(plan)     # (several drivers: the chart its solves walk)
    dm = motion_events(m, plan, extent=extent, k=k) if certified else DriverMotion.held(m, k)
    # the certified stops: where the walk met an assembly limit (not the end of its search)
    hi, lo = (dm.hi if "hi" in dm.limits else None, dm.lo if "lo" in dm.limits else None)
    seg_f = _segment(_side(dm, plan, +1, heavy, samples, branch, cancel), chunk, hi)
    if rotary and rng is None and seg_f.limit is None:
        st = seg_f.state
        i360 = R_STEPS
        periodic = bool(np.nanmax(np.abs(st.positions[i360] - st.positions[0])) <= 1e-9 * m.size)
        return Motion.of(dm, True, (seg_f,), periodic)
    seg_b = _segment(_side(dm, plan, -1, heavy, samples, branch, cancel), chunk, lo)
    return Motion.of(dm, False, (_bounded(seg_f, rng, +1), _bounded(seg_b, rng, -1)), False)
