"""``check(mechanism)``: validate a design over its whole motion.

For every driver in turn (the others held at the reference), from the reference
along its assembly branch: range of motion with exact limits, branch points met,
dead centres of the links hinged to the frame and of the sliders on frame guides,
exact extremes of every transmission / pressure angle, the velocity ratio to an
output; then the assembly modes of every group, the Grashof class of every
four-bar loop, the instant centres at one position and a verdict.
"""
from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np

from multiloop.kin.memo import cached
from multiloop.kin.solve import compile_plan, held_text, solve
from multiloop.topo.assur import decompose
from multiloop.topo.errors import InputError, ParameterError, explain
from multiloop.topo.model import JointKind, Mechanism
from multiloop.topo.recent import Recent

from .angle_types import angle_type
from .circuits import group_circuits
from .events import extremes, roots
from .grashof import four_bar_loops
from .instant_centres import instant_centres
from .motion import driver_motion
from .singular_values import exact_extremes
from .report import AngleResult, CheckReport, DriverAngles, DriverCheck
from .transmission import angle_specs, angle_values, signed_dets_of
from .verdict import verdict
from .workspace import workspace as workspace_of

__all__ = ["check", "driver_check", "driver_angles", "watched", "signed_dets"]


def watched(m: Mechanism) -> tuple[tuple[str, str, str | None], ...]:
    """Links hinged to the frame ``(link, "R", None)`` and sliders on a frame guide
    ``(slider, "P", joint)``, in file order."""
    out, seen = [], set()
    for j in m.joints:
        if m.frame not in j.links:
            continue
        if j.kind is JointKind.R:
            for lk in j.links:
                if lk != m.frame and lk not in seen:
                    out.append((lk, "R", None))
                    seen.add(lk)
        elif j.links[0] == m.frame and j.links[1] not in seen:
            out.append((j.links[1], "P", j.name))
            seen.add(j.links[1])
    return tuple(out)


def _velocity(state, w) -> np.ndarray:
    """(N, len(w)) angular velocity of each watched link or slide rate of each slider."""
    m = state.mechanism
    out = np.empty((state.n_positions, len(w)))
    for c, (lk, kind, jn) in enumerate(w):
        if kind == "R":
            out[:, c] = state.omegas[:, state.link_index(lk)]
        else:
            ax = np.asarray(m.joint(jn).axis, float)
            out[:, c] = state.velocities[:, state.joint_index(jn)] @ (ax / np.hypot(*ax))
    return out


def signed_dets(plan):
    """Groups with a reach limit and their normalised signed determinant ``D(state)``,
    from each group's monitored angle whose type has one
    (:attr:`~kin.check.angle_types.AngleType.reach_limit`;
    :func:`~kin.check.transmission.angle_specs`): sin of the angle at B of a triangle
    (an RRR dyad or an actuated triangle), cos of the rod–guide angle (RRP), s/|CA| (RPR)."""
    specs = [sp for sp in angle_specs(plan) if angle_type(sp.quantity).reach_limit]
    by_label = {g.describe(): g for g in plan.groups}
    groups = [by_label[sp.group] for sp in specs]

    def D(state):
        return signed_dets_of(state, specs)
    return groups, D


def _output(m: Mechanism, w, output, driver_link):
    if output is None:
        cand = [x for x in w if x[0] != driver_link]
        return cand[-1] if cand else None
    if output in m.link_names:
        for x in w:
            if x[0] == output:
                return x
        return (output, "R", None)
    if output in tuple(p.name for p in m.points):
        return (output, "point", None)
    raise ParameterError(explain("output", expected="a link or tracer point name of the mechanism",
                                 got=repr(output), hint="links: " + ", ".join(m.link_names)), "output")


def _ratio(state, out) -> np.ndarray:
    lk, kind, _ = out
    if kind == "point":
        return np.hypot(*state.point_velocities[:, state.point_index(lk)].T)
    if kind == "R":
        return state.omegas[:, state.link_index(lk)]
    return _velocity(state, [out])[:, 0]


def _motion(m, ap, plan, k, cancel=None):
    """The groups with a reach limit, their signed determinants ``D`` and the motion of
    driver ``k`` guarded by them (:func:`~kin.check.motion.driver_motion`)."""
    groups, D = signed_dets(ap)
    return groups, D, driver_motion(m, plan, k, tuple(g.kind for g in ap.groups), D if groups else None, cancel)


def check_plan(m: Mechanism):
    """The plan :func:`check` and :func:`driver_angles` solve ``m`` with: compiled once
    per mechanism (by identity, for the last 8), its own (not
    :func:`~kin.solve.plan_of`'s, so that other solves of ``m`` leave its memo as the
    check alone makes it).  The motion and the angle extremes of each driver are kept
    beside it (:func:`_kept_motion`, :func:`_kept_angles`): a page that draws the
    motion (``driver_angles``) and then checks the same design computes them once, and
    may solve its frames on this plan too (within the charts the check's walks build,
    which they then reuse; the check's results stay those of the check alone)."""
    return _PLANS.get(m, lambda: compile_plan(m, decompose(m)))


#: the check's compiled plans of the last 8 mechanisms checked, by identity (Mechanism is frozen)
_PLANS = Recent(8)


def _kept_motion(m, plan, k, cancel=None):
    """:func:`_motion` of driver ``k`` on ``plan`` (:func:`check_plan`), computed once
    per plan; the motion returned polls ``cancel`` (not the first caller's)."""
    groups, D, mo = cached(plan, ("motion", k), lambda p, _: _motion(m, p.assur, p, k, cancel))
    segs = tuple(replace(s, side=replace(s.side, cancel=cancel)) for s in mo.segments)
    return groups, D, replace(mo, segments=segs)


def _kept_angles(plan, k, mo, specs) -> tuple[AngleResult, ...]:
    """:func:`_angles` of driver ``k``'s motion ``mo`` on ``plan``, computed once per plan."""
    return cached(plan, ("angles", k), lambda p, _: _angles(mo, specs))


def _angles(mo, specs) -> tuple[AngleResult, ...]:
    """Exact extremes of every monitored angle over the motion ``mo``, read on both sides
    of the certified walk's crossings (:func:`~kin.check.events.extremes`), with the
    exact value at a located limit or crossing (:mod:`~kin.check.singular_values`)."""
    crossings = [x for x, _ in mo.events.crossings] if mo.events is not None else []
    ext = extremes(mo, lambda s: angle_values(s, specs), events=crossings)
    ext = exact_extremes(mo, specs, ext, lambda s: angle_values(s, specs))
    return tuple(AngleResult(sp.joint, sp.quantity, sp.group, e) for sp, e in zip(specs, ext))


def _driver_check(m, ap, plan, k, specs, w, output, positions, cancel=None, angles=None) -> DriverCheck:
    d = m.drivers[k]
    dj = m.joint(d.joint)
    rotary = m.is_rotary(k)
    groups, D, mo = _kept_motion(m, plan, k, cancel)
    driver_link = dj.links[1] if dj.links[0] == m.frame else (dj.links[0] if m.frame in dj.links else None)
    ev = mo.events
    limit_groups = []
    for seg in mo.segments:
        if seg.limit_bracket is None:
            continue
        label = ev.limits.get("hi" if seg.side.sign > 0 else "lo") if ev is not None else None
        if label is not None:                # the group the certified walk stopped at
            limit_groups.append(f"{label}: unreachable: limit at {held_text(plan, k, seg.limit)} "
                                "(out of reach beyond it)")
            continue
        st, r = seg.side.at([seg.side.grid[seg.n]])      # the first failed grid value
        limit_groups.append(str(st.status[r[0]]))
    ww = [x for x in w if x[0] != driver_link and not (x[1] == "P" and x[2] == d.joint)]
    # one refinement for both: signed determinants (branch points), velocities (dead centres)
    found = roots(mo, lambda s: np.hstack([D(s), _velocity(s, ww)]), derivatives=True)
    crossings = [x for x, _ in ev.crossings] if ev is not None else []
    bps = [(x, groups[c].describe()) for c, xs in enumerate(found[: len(groups)]) for x in xs]
    if ev is not None:                   # the certified walk's crossings, none read off the grid
        bps = [(_on_turn(x, mo), g) for x, g in ev.crossings] + [
            b for b in bps if not any(abs(b[0] - _on_turn(c, mo)) < 1e-6 for c in crossings)]
    else:
        bps += [(x, why) for seg in mo.segments for x, why in seg.singular]
    dead = found[len(groups):] or [[] for _ in ww]
    out = _output(m, w, output, driver_link)
    if output is None and out is not None:
        # the default output must move with this driver: the last watched link that does
        # (a link hinged to the frame if one moves, else the last moving link in solving order)
        st0 = mo.segments[0].state
        order = [lk for lk, _ in sorted(ap.link_numbers, key=lambda t: t[1]) if lk != m.frame]
        for pool in (ww, [(lk, "R", None) for lk in order]):
            moving = [x for x in pool if np.nanmax(np.abs(_ratio(st0, x)), initial=0.0) > 1e-12]
            if moving:
                out = moving[-1]
                break
    xs, rs = [], []
    for seg in (mo.segments if mo.full_rotation else mo.segments[::-1]):
        xx, rr = seg.x, (_ratio(seg.state, out)[: seg.n] if out else np.full(seg.n, np.nan))
        if seg.side.sign < 0:
            xx, rr = xx[::-1], rr[::-1]
        xs.append(xx)
        rs.append(rr)
    unit = ("m" if out and out[1] in ("P", "point") else "rad") + ("/rad" if rotary else "/m")
    bad = tuple(x for x in (positions or ()) if not _reachable(mo, x))
    unbounded = tuple(seg.limit for seg in mo.segments if seg.limit is not None and out
                      and _grows_at_limit(seg, lambda st: _ratio(st, out)))
    ratio_ext = (extremes(mo, lambda s: np.abs(_ratio(s, out))[:, None], derivatives=True, events=crossings,
                          beside=(1e-5, 1e-4))[0] if out else None)
    angles = (angles() if angles is not None else None) or _kept_angles(plan, k, mo, specs)
    return DriverCheck(d.joint, rotary, mo.full_rotation, mo.periodic, mo.limits,
                       tuple(limit_groups), _distinct(bps),
                       tuple((lk, tuple(sorted(x))) for (lk, _, _), x in zip(ww, dead)),
                       angles, out[0] if out else None, unit,
                       np.concatenate(xs), np.concatenate(rs), bad, unbounded, ratio_ext,
                       d.range, mo.binds)


def _distinct(bps) -> tuple:
    """Branch points (input, group) sorted, each listed once: a motion periodic in two
    turns meets a change point twice at the same crank angle on the turn (the kite)."""
    out: list = []
    for x, g in sorted(bps):
        if not any(g == g2 and abs(x - x2) <= 1e-9 * max(1.0, abs(x)) for x2, g2 in out):
            out.append((x, g))
    return tuple(out)


def usable_box(m: Mechanism, dcs) -> tuple[tuple[float, float], ...]:
    """Each driver's usable range (low, high) from the reference: a full turn for a
    crank that turns fully, ± the mechanism's size (P) or ± half a turn (R) on a side
    without a limit."""
    out = []
    for dc in dcs:
        far = np.pi if dc.rotary else m.size
        if dc.full_rotation:
            out.append((0.0, 2 * np.pi))
        elif len(dc.limits) == 2:
            out.append((float(min(dc.limits)), float(max(dc.limits))))
        elif len(dc.limits) == 1:
            x = float(dc.limits[0])
            out.append((x, far) if x < 0 else (-far, x))
        else:
            out.append((-far, far))
    return tuple(out)


def _on_turn(x: float, mo) -> float:
    """A crossing of a full turn reduced to [0, 2π) (as the grid's inputs are)."""
    return float(np.mod(x, 2 * np.pi)) if mo.rotary and mo.full_rotation else float(x)


def _grows_at_limit(seg, ratio) -> bool:
    """Does the velocity ratio grow without bound as the limit is approached?  At a
    turning point it grows like δ^(−1/2) with the distance δ to the limit (the input
    stops while the output moves): read at δ = 1e-4 and 1e-8 of the step to it."""
    d = seg.limit - seg.x[-1] if seg.n else 0.0
    if d == 0.0:
        return False
    st, r = seg.side.at(seg.limit - d * np.array([1e-2, 1e-6]), derivatives=True)
    v = np.abs(ratio(st)[r])
    return bool(np.all(np.isfinite(v)) and v[1] > 30.0 * max(v[0], 1e-300))


def _reachable(mo, x) -> bool:
    if mo.full_rotation:
        return True
    fwd, bwd = (mo.segments[0].limit, mo.segments[1].limit)
    hi = fwd if fwd is not None else np.inf
    lo = bwd if bwd is not None else -np.inf
    if mo.rotary:
        x = float(np.mod(x, 2 * np.pi))
        return x <= hi or x - 2 * np.pi >= lo
    return lo <= x <= hi


def driver_angles(mechanism: Mechanism, k: int = 0, cancel=None) -> DriverAngles:
    """The range of motion of driver ``k`` and the exact extremes of every monitored
    angle over it: the same motion and the same values as :func:`check`'s, without the
    branch points, dead centres, velocity ratio, instant centres and Grashof classes.

    The motion is the certified walk's (its limits and crossings found by continuation,
    not read off a grid); an extreme is refined from the grid's bracket by a zoom search
    to 1e-10 rad, and read beside each crossing (:func:`~kin.check.events.extremes`).
    Transmission angles as Alt (1932), triad angles as Hunt (1983).

    Parameters
    ----------
    mechanism : Mechanism
        With geometry, a frame and drivers (the others are held at the reference).
    k : int
        Index of the driver in ``mechanism.drivers``.
    cancel : callable, optional
        Called before every solve; it stops the computation by raising (as :func:`check`'s).

    Returns
    -------
    DriverAngles
    """
    m = mechanism
    _driver_index(m, k)
    plan = check_plan(m)
    _, _, mo = _kept_motion(m, plan, k, cancel)
    return DriverAngles(m.drivers[k].joint, mo.rotary, mo.full_rotation, mo.limits,
                        _kept_angles(plan, k, mo, angle_specs(plan.assur)))


def _driver_index(m: Mechanism, k: int) -> None:
    """Refuse ``k`` when it is not the index of one of ``m``'s drivers."""
    if not 0 <= k < len(m.drivers):
        raise InputError(explain("driver index", expected=f"0…{len(m.drivers) - 1}" if m.drivers
                                 else "a mechanism with a driver", got=repr(k)))


def driver_check(mechanism: Mechanism, k: int, *, output: str | None = None, positions=None,
                 cancel=None, angles=None) -> DriverCheck:
    """What :func:`check` computes while driver ``k`` moves (the others held at the
    reference): its motion, limits, branch points, dead centres, angle extremes and
    velocity ratio, with ``output`` and ``positions`` (that driver's values) as there.
    A check's drivers are independent of one another, so they may be computed apart
    (in other processes, on other cores) and given to :func:`check`
    (``driver_checks=``): the report is the same, bit for bit.  ``angles()``, when
    given, is called once the rest is done and gives the angles' extremes
    (``driver_angles(mechanism, k).angles``, e.g. from another process that computed
    them meanwhile), or None to have them computed here.

    Raises
    ------
    InputError
        ``k`` is not the index of a driver.
    """
    m = mechanism
    _driver_index(m, k)
    plan = check_plan(m)
    return _driver_check(m, plan.assur, plan, k, angle_specs(plan.assur), watched(m), output, positions, cancel,
                         angles)


def check(mechanism: Mechanism, *, min_transmission: float = 40.0, output: str | None = None,
          at=None, positions=None, workspace: str | None = None, cancel=None,
          driver_checks=None) -> "CheckReport":
    """Design check of a mechanism over its whole motion (docs/check.md).

    Parameters
    ----------
    mechanism : Mechanism
        With geometry, a frame and drivers.
    min_transmission : float
        Threshold (degrees): transmission angles below it (or above 180° minus it)
        and pressure angles above 90° minus it are flagged.
    output : str, optional
        Link or tracer point for the velocity ratio / mechanical advantage (default:
        the last link hinged to the frame or slider on a frame guide that moves with
        the driver, other than the driver's own; else the last moving link).
    at : array_like (n_drivers,), optional
        Driver values (rad or m from the reference) of the instant-centre position
        (default: the reference).
    positions : dict {driver joint: sequence}, optional
        Driver values (rad or m) the design must reach: the ones outside the
        reachable motion are listed (circuit defect).
    workspace : str, optional
        A tracer point: its workspace over the box of every driver's usable range
        (:func:`~kin.check.workspace.workspace`).
    cancel : callable, optional
        Called with no argument before every solve of a driver's motion and once
        after the drivers; it stops the check by raising (its exception propagates),
        e.g. when the user of an interactive caller cancels.
    driver_checks : tuple of DriverCheck, optional
        The drivers' checks computed already, one per driver in order
        (:func:`driver_check` with the same ``output`` and ``positions``, e.g. in
        other processes): they are used as they are.

    Returns
    -------
    CheckReport
    """
    m = mechanism
    if not m.drivers:
        raise InputError(explain("mechanism", expected="at least one driver", got="none"))
    if not 0.0 <= float(min_transmission) <= 90.0:
        raise ParameterError(explain("min_transmission", expected="degrees in [0, 90]",
                                     got=repr(min_transmission)), "min_transmission")
    plan = check_plan(m)
    ap = plan.assur
    positions = positions or {}
    unknown = set(positions) - {d.joint for d in m.drivers}
    if unknown:
        raise ParameterError(explain("positions", expected="driver joint names", got=", ".join(sorted(unknown))),
                             "positions")
    if driver_checks is None:
        specs, w = angle_specs(ap), watched(m)
        dcs = tuple(_driver_check(m, ap, plan, k, specs, w, output, positions.get(d.joint), cancel)
                    for k, d in enumerate(m.drivers))
    else:
        dcs = tuple(driver_checks)
        if [dc.joint for dc in dcs] != [d.joint for d in m.drivers]:
            raise ParameterError(explain("driver_checks", expected="one per driver, in order: "
                                         + ", ".join(d.joint for d in m.drivers),
                                         got=", ".join(dc.joint for dc in dcs) or "none"), "driver_checks")
    if cancel is not None:                  # before the workspace and the last solve
        cancel()
    x0 = np.zeros(len(m.drivers)) if at is None else np.asarray(at, float).reshape(len(m.drivers))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = solve(m, x0[None, :], derivatives=True, plan=plan)
    if not st.ok[0]:
        raise InputError(explain("instant-centre position", expected="an assembled position",
                                 got=str(st.status[0])))
    ics = instant_centres(st, 0)
    circ = group_circuits(ap, dcs)
    loops = four_bar_loops(m, dict(ap.link_numbers))
    ends = [(dc.bound_at("low"), dc.bound_at("high")) for dc in dcs]
    ws = None if workspace is None else workspace_of(m, workspace, usable_box(m, dcs), ends)
    rep = CheckReport(m.name, ap.formula, float(min_transmission), dcs, circ, loops, ics,
                      tuple(float(x) for x in x0), (), ws)
    return CheckReport(**{**rep.__dict__, "verdict": verdict(rep)})
