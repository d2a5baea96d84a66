"""Whether a synthesised design meets each constraint, and by how much it misses.

:func:`constraint_report` measures the returned design directly (its poses on the
driver grid walked from the reference, its link lengths, its branches), not the
penalty the search minimised, so a design that trades a constraint against the
targets says so.
"""
from __future__ import annotations

from contextlib import contextmanager

import math

import numpy as np

from multiloop.topo.errors import ParameterError, explain

from .objective import Problem, grashof_margins, transmission_angles

__all__ = ["constraint_report", "turns_fully", "certified_transmission", "certified_motion", "reaches_targets",
           "parse_bounds", "synthesis_text", "limits_text", "progress_bar"]


def _row(name: str, required, value, violation: float) -> dict:
    v = float(violation) if np.isfinite(violation) else float("inf")
    return {"name": name, "required": required, "value": value, "met": bool(v <= 0.0), "violation": max(v, 0.0)}


def turns_fully(problem: Problem, z: np.ndarray) -> bool:
    """Whether the driver of design ``z`` turns fully by its certified motion
    (:func:`multiloop.kin.solve.motion_events`, the walk ``multiloop check`` starts from:
    limits found by continuation), not only on the driver grid (a design on the edge of
    full rotation may pass every grid sample and still lock between two).  A driver with
    a ``range`` does not turn fully, as ``check`` says."""
    m = problem.ev.with_design(np.asarray(z, float)[:problem.nx])
    if not m.is_rotary(0) or m.drivers[0].range is not None:
        return False
    motion = certified_motion(m, ())
    return bool(motion is not None and motion.rotary and motion.turns_fully)


def certified_motion(m, inputs):
    """Design ``m``'s certified motion (:func:`multiloop.kin.solve.motion_events`: its
    driver's limits and crossings by continuation; a slider's searched over the inputs'
    extent) over driver values ``inputs``, or None when it has none."""
    from multiloop.kin.solve import motion_events
    from multiloop.topo.errors import LinkageError
    x = np.asarray(inputs, float)
    try:
        return motion_events(m, extent=max(float(np.max(np.abs(x), initial=0.0)), 1e-12) * 1.01
                             if not m.is_rotary(0) else None)
    except (LinkageError, ValueError, FloatingPointError):
        return None


def reaches_targets(m, inputs, closed: bool = True, motion=None) -> bool:
    """Whether design ``m``'s certified motion (:func:`certified_motion`, or ``motion``
    if computed) reaches every target input ``inputs`` (rad or m from the reference) on
    the design's branch (no circuit defect); for an open target (``closed`` False) the
    inputs' span lies in it too (:meth:`~multiloop.kin.motion.DriverMotion.holds_span`:
    the targets met in order without passing a limit).  Only the motion is asked, not
    the whole design check."""
    x = np.asarray(inputs, float)
    motion = certified_motion(m, x) if motion is None else motion
    if motion is None or not motion.reaches(x).all():
        return False
    return closed or motion.holds_span(x)


def certified_transmission(problem: Problem, z: np.ndarray) -> float:
    """The smallest folded transmission angle (deg, 90 ideal) of design ``z`` over its
    certified motion: the exact extremes ``multiloop check`` finds
    (:func:`multiloop.kin.check.driver_angles`: the walk's limits by continuation, each
    extreme zoomed to 1e-10 rad from its bracket), of the same angles as the search's
    :func:`~.objective.transmission_angles` (the types whose degenerate value is a reach
    limit), each folded to its distance from that value; ``inf`` when there is none,
    NaN when the design cannot be checked."""
    from multiloop.kin.check import driver_angles
    from multiloop.kin.check.angle_types import angle_type
    from multiloop.topo.errors import LinkageError
    m = problem.ev.with_design(np.asarray(z, float)[:problem.nx])
    try:
        found = driver_angles(m, 0)
    except LinkageError:
        return float("nan")
    out = float("inf")
    for a in found.angles:
        t = angle_type(a.quantity)
        if t.reach_limit and a.extreme is not None:
            out = min(out, float(t.margin(a.extreme.min, a.extreme.max)))
    return out


def constraint_report(problem: Problem, z: np.ndarray, phi: np.ndarray, continuous: bool) -> list[dict]:
    """One row per constraint of ``problem`` at design ``z`` (driver values ``phi``):
    ``{"name", "required", "value", "met", "violation"}``; ``violation`` is 0 when met,
    else how far the value is from the requirement in its own units (deg, m, a ratio,
    a fraction of a turn, a count of dyads).  Full rotation is the certified one of
    ``multiloop check``; its violation is the fraction of the driver grid not reached
    (at least one sample when the grid is all reached but ``check`` finds a lock).  The
    minimum transmission angle is ``check``'s exact one too
    (:func:`certified_transmission`; the driver grid's samples only for a design
    ``check`` refuses), never read off the grid.

    Always reported: the targets reached by continuous motion from the reference in
    order (``continuous``, from the caller's assessment) and a non-singular reference
    configuration (relative determinant of every dyad at least 1e-3)."""
    c, ev = problem.cons, problem.ev
    X = np.asarray(z, float)[None, :problem.nx]
    st = problem.grid_poses(X)
    ok = st.ok[:, :problem.M]
    full = bool(problem.curve(ok)[3][0])
    margin = float(problem.reference_margin(X)[0])
    rows = [_row("continuous", "targets reached in order from the reference", bool(continuous),
                 0.0 if continuous else 1.0),
            _row("reference", "relative determinant >= 0.001", margin, max(0.0, 1e-3 - margin))]
    if c.full_rotation:
        frac = 1.0 if full else float(np.mean(ok))
        sure = turns_fully(problem, z)
        rows.append(_row("full_rotation", "the driver turns fully (multiloop check)",
                         {"certified": sure, "grid_fraction": frac}, 0.0 if sure else max(1.0 - frac, 1.0 / problem.M)))
    if c.min_transmission:
        mu = certified_transmission(problem, z)
        if mu != mu:                                # (no certified motion: the grid's samples)
            mu = float(np.where(ok, transmission_angles(ev, X, st)[:, :problem.M], np.inf).min())
        rows.append(_row("min_transmission", float(c.min_transmission), mu, c.min_transmission - mu))
    if c.length_bounds or c.max_ratio:
        L = problem.lengths(X)[0]
        if c.length_bounds:
            a, b = c.length_bounds
            rows.append(_row("length_bounds", [a, b], [float(L.min()), float(L.max())],
                             max(0.0, a - L.min(), L.max() - b)))
        if c.max_ratio:
            r = float(L.max() / max(L.min(), 1e-300))
            rows.append(_row("max_ratio", c.max_ratio, r, r - c.max_ratio))
    if c.grashof != "any":
        g = grashof_margins(problem, X)[0]
        rows.append(_row("grashof", c.grashof, {"grashof_excess": float(g[0]), "shortest_excess": float(g[1])},
                         float(g.sum())))
    if c.mode == "reference":
        n = int(np.sum(ev.branches(X) != problem.start_branches))
        rows.append(_row("mode", "every dyad on the start's branch", n, n))
    if c.direction != "any":
        d = np.diff(np.asarray(phi, float)) * problem.sense
        got = "ccw" if np.all(d >= 0) else "cw" if np.all(d <= 0) else "both"
        rows.append(_row("direction", c.direction, got, 0.0 if got == c.direction else 1.0))
    return rows


def parse_bounds(items) -> dict | None:
    """``["NAME=LOW:HIGH", ...]`` → ``{NAME: (LOW, HIGH)}`` (finite numbers, LOW < HIGH)."""
    if not items:
        return None
    out = {}
    for it in items:
        name, eq, rng = it.partition("=")
        lo, colon, hi = rng.partition(":")
        try:
            a, b = float(lo), float(hi)
        except ValueError:
            a = b = float("nan")
        if not (eq and colon and name and math.isfinite(a) and math.isfinite(b) and abs(a) <= 1e9 and abs(b) <= 1e9):
            raise ParameterError(explain(f"bounds {it[:80]!r}", expected="NAME=LOW:HIGH with finite numbers "
                                         "of magnitude at most 1e9", got=repr(it[:80]), hint="e.g. O2.x=-1:1"), "bounds")
        if name in out:
            raise ParameterError(explain(f"bounds {name!r}", expected="each variable once", got="twice"), "bounds")
        out[name] = (a, b)
    return out


def synthesis_text(doc: dict) -> str:
    """The readable report of a synthesis run from its JSON document (``as_dict`` plus
    ``out``, the file written)."""
    lines = [f"{doc['task']} generation: wrote {doc['out']}",
             f"error (relative to the target size): max {doc['error_max']:.3g}, RMS {doc['error_rms']:.3g}"]
    if doc.get("angle_error_max_deg") is not None:
        lines.append(f"pose angle error: max {doc['angle_error_max_deg']:.3g}°")
    timing = f", free timing {doc['free_timing']}" if doc.get("free_timing") else ""
    lines.append(f"{doc['evaluations']} evaluations in {doc['seconds']:.2f} s ({doc['method']}, seed {doc['seed']}{timing}; "
                 f"limits: {limits_text(doc['limits'])}; stopped: {doc['stopped']})")
    for c in doc["constraints"]:
        state = "met" if c["met"] else f"NOT met, violated by {c['violation']:.3g}"
        lines.append(f"constraint {c['name']} ({c['required']}): {state}; value {_fmt(c['value'])}")
    lines += [f"note: {n}" for n in doc["notes"]]
    return "\n".join(lines)


def limits_text(limits: dict) -> str:
    """``{"evaluations": N, "seconds": S}`` (either None) as ``"N evaluations, S s"``."""
    parts = ([f"{limits['evaluations']} evaluations"] if limits.get("evaluations") is not None else []) + \
        ([f"{limits['seconds']:g} s"] if limits.get("seconds") is not None else [])
    return ", ".join(parts) or "none"


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    if isinstance(v, list):
        return "[" + ", ".join(_fmt(x) for x in v) + "]"
    if isinstance(v, dict):
        return ", ".join(f"{k} {_fmt(x)}" for k, x in v.items())
    return str(v)


@contextmanager
def progress_bar(enabled: bool):
    """A progress bar of a synthesis run on the terminal (rich): yields the ``progress``
    callback ``(fraction, best)`` of :func:`.synthesise.synthesise`, or None when off."""
    if not enabled:
        yield None
        return
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
    bar = Progress(TextColumn("synthesis"), BarColumn(), TextColumn("best {task.fields[best]:.3g}"),
                   TimeElapsedColumn(), transient=True, console=None)
    task = bar.add_task("s", total=1.0, best=float("inf"))
    with bar:
        yield lambda frac, best: bar.update(task, completed=frac, best=best)
