"""The public entry point :func:`synthesise` and its frozen :class:`SynthesisResult`."""
from __future__ import annotations

import itertools
import time
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from multiloop.topo.errors import InputError, ParameterError, explain
from multiloop.topo.model import Mechanism

from .budget import Budget, Meter
from .evaluator import Evaluator, design_space
from .objective import Constraints, Problem
from .optimise import METHODS, global_search, polish_batch
from .searched_timing import FREE_TIMINGS, SearchedTiming
from .report import certified_transmission, constraint_report, reaches_targets, turns_fully
from .targets import MAX_ROWS, TIMINGS, FunctionTarget, MotionTarget, PathTarget, check_rows, read_table, resample

__all__ = ["SynthesisResult", "synthesise", "path_target", "function_target", "motion_target"]


@dataclass(frozen=True)
class SynthesisResult:
    """The synthesised mechanism and how well it meets the target.

    ``error_max`` / ``error_rms`` are distances to the targets relative to the
    target's size (position error for path and motion, output error over the
    output range for function generation); ``angle_error_max`` (deg) is the pose
    angle error of motion generation.  ``inputs`` are the driver values (rad or m
    from the reference) at which the targets are met, in driver order.
    ``evaluations`` counts the designs the search and the polish scored, ``limits``
    the run's :class:`~.budget.Budget`, and ``stopped`` which one ended it (one of
    :data:`~.budget.STOPS`).  ``free_timing`` is what the search varied with free timing
    (:data:`~.searched_timing.FREE_TIMINGS`; None with prescribed driver values).
    """

    mechanism: Mechanism
    task: str
    error_max: float
    error_rms: float
    evaluations: int
    seconds: float
    method: str
    seed: int
    inputs: np.ndarray
    achieved: np.ndarray
    target: np.ndarray
    design: dict
    stopped: str
    angle_error_max: float | None = None
    history: tuple = field(default_factory=tuple, repr=False)
    notes: tuple[str, ...] = ()
    constraints: tuple = ()
    limits: Budget = Budget()
    free_timing: str | None = None

    def inputs_cli(self) -> np.ndarray:
        """``inputs`` in command-line units: degrees for an R driver, m for a P driver."""
        m = self.mechanism
        rot = m.is_rotary(0)
        return np.degrees(self.inputs) if rot else np.asarray(self.inputs, float)

    def as_dict(self) -> dict:
        """JSON-ready summary (the mechanism by name; write it with ``topo.io``)."""
        return {"task": self.task, "mechanism": self.mechanism.name, "error_max": self.error_max,
                "error_rms": self.error_rms, "angle_error_max_deg": self.angle_error_max,
                "evaluations": self.evaluations, "seconds": round(self.seconds, 4),
                "evaluations_per_second": self.evaluations / self.seconds if self.seconds > 0 else None,
                "method": self.method, "seed": self.seed, "free_timing": self.free_timing, "stopped": self.stopped,
                "limits": self.limits.as_dict(),
                "inputs": [float(x) for x in self.inputs_cli()],
                "achieved": np.asarray(self.achieved).tolist(), "target": np.asarray(self.target).tolist(),
                "design": dict(self.design), "constraints": [dict(c) for c in self.constraints],
                "constraints_met": all(c["met"] for c in self.constraints),
                "notes": list(self.notes)}


def _table(value, cols, what):
    if isinstance(value, (str, Path)):
        return read_table(value, cols, what), Path(value).name
    a = np.asarray(value, float)
    if a.ndim != 2 or a.shape[1] not in cols:
        raise InputError(explain(f"{what} target", expected=f"an array of shape (N, {' or '.join(map(str, cols))})",
                                 got=f"shape {a.shape}"))
    return check_rows(a, what, f"{what} target"), f"a {what} table of {len(a)} rows"


def path_target(m: Mechanism, path, point: str | None, *, shape_only=False, timing: str = "reference") -> PathTarget:
    """A :class:`PathTarget` from an (N, 2|3) array or CSV file (third column: driver
    value in degrees, or m for a slider input, measured as ``timing`` says: from the
    reference, absolute, or only its steps; see :data:`~.targets.TIMINGS`)."""
    if timing not in TIMINGS:
        raise ParameterError(explain("timing", expected=" or ".join(TIMINGS), got=repr(timing)), "timing")
    a, src = _table(path, (2, 3), "path")
    names = [p.name for p in m.points]
    if point is None and len(names) == 1:
        point = names[0]
    if point not in names:
        raise InputError(explain(f"tracer point {point!r}", expected="a [[point]] of the start mechanism",
                                 got="no such point", hint=f"points: {', '.join(names) or 'none'}"))
    values = None
    if a.shape[1] == 3:
        values = np.radians(a[:, 2]) if m.is_rotary(0) else a[:, 2].copy()
    elif timing != "reference":
        raise ParameterError(explain(f"timing {timing!r}", expected="a path table with a third column",
                                     got=f"{src} with two columns", hint="free timing needs no 'timing'"), "timing")
    if timing == "absolute" and m.frame not in m.joint(m.drivers[0].joint).links:
        raise ParameterError(explain("timing 'absolute'", expected="a driver on the frame",
                                     got=f"driver joint {m.drivers[0].joint!r} between moving links",
                                     hint="set 'timing' to 'reference' or 'step'"), "timing")
    return PathTarget(a[:, :2].copy(), point, values, shape_only, src, timing)


def function_target(m: Mechanism, function, output: str) -> FunctionTarget:
    """A :class:`FunctionTarget` from rows (driver value, output value): degrees for R
    joints, m for P joints; the first row is the reference configuration."""
    a, src = _table(function, (2,), "function")
    if output not in m.joint_names:
        raise InputError(explain(f"output joint {output!r}", expected="a joint of the start mechanism",
                                 got="no such joint", hint=f"joints: {', '.join(m.joint_names)}"))
    x = np.radians(a[:, 0]) if m.is_rotary(0) else a[:, 0]
    y = np.radians(a[:, 1]) if m.joint(output).kind.is_rotary else a[:, 1]
    if np.ptp(y) == 0:
        raise InputError(explain(src, expected="output values that vary", got="a constant output"))
    return FunctionTarget(x, y, output, src)


def motion_target(m: Mechanism, motion, link: str) -> MotionTarget:
    """A :class:`MotionTarget` from rows (x, y, angle in degrees)."""
    a, src = _table(motion, (3,), "motion")
    if link not in m.link_names or link == m.frame:
        raise InputError(explain(f"link {link!r}", expected="a moving link of the start mechanism",
                                 got="no such link" if link not in m.link_names else "the frame",
                                 hint=f"links: {', '.join(m.link_names)}"))
    return MotionTarget(np.column_stack([a[:, :2], np.radians(a[:, 2])]), link, src)


def check_tol(tol) -> float:
    """``tol``, a tolerance on a relative error, as a float: a finite number >= 0.

    Raises
    ------
    ParameterError
        ``tol`` is not a number, NaN, infinite or negative.
    """
    try:
        value = float(tol)
    except (TypeError, ValueError):
        value = float("nan")
    if isinstance(tol, bool) or not (np.isfinite(value) and value >= 0.0):
        raise ParameterError(explain("tol", expected="a finite number >= 0 (a relative RMS error)", got=repr(tol),
                                     hint="1e-6 stops at a relative RMS error of one millionth"), "tol")
    return value


def _check_start(m: Mechanism, method: str, seed, tol) -> None:
    from multiloop.kin.solve import solve
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed < 2 ** 32:
        raise ParameterError(explain("seed", expected="an integer in [0, 2**32)", got=repr(seed)), "seed")
    check_tol(tol)
    if method not in METHODS:
        raise InputError(explain("method", expected=" or ".join(map(repr, METHODS)), got=repr(method)))
    if not m.has_geometry or len(m.drivers) != 1:
        raise InputError(explain(f"start mechanism '{m.name or ''}'", expected="geometry and exactly one driver",
                                 got=f"{len(m.drivers)} drivers" if m.has_geometry else "no geometry"))
    # raises AssemblyError / SingularityError when the start does not assemble: the reference
    # alone (assemble=True: no chart of the start's whole motion, 20-40 ms a run, is built)
    solve(m, 0.0, assemble=True)


def _checked(task: str, target, direction: str):
    """Refuse a direction the timing already fixes (the target's size is checked as it
    is read, :func:`~.targets.check_rows`); resample more than :data:`~.targets.MAX_ROWS`
    rows.  Returns the target and a note or None."""
    if isinstance(target, PathTarget) and target.timing is not None and target.timing_mode != "step" \
            and direction != "any":
        raise ParameterError(explain(f"direction {direction!r}", expected=f"'any' with 'timing' {target.timing_mode!r}",
                                     got=repr(direction),
                                     hint="the third column fixes the direction; free it with 'timing' 'step'"),
                             "direction", "timing")
    n = len(target.target_points())
    if n <= MAX_ROWS:
        return target, None
    keep = resample(np.arange(n)[:, None])[:, 0]
    if task == "path":
        target = replace(target, points=target.points[keep],
                         timing=None if target.timing is None else target.timing[keep])
    elif task == "function":
        target = replace(target, inputs=target.inputs[keep], outputs=target.outputs[keep])
    else:
        target = replace(target, poses=target.poses[keep])
    return target, (f"the target's {n} rows were resampled to {len(keep)} (every {n / len(keep):.3g}th row, "
                    f"first and last kept): the search's work grows with the number of targets")


def _target(m, path, point, shape_only, function, output, motion, link, timing="reference"):
    given = [x is not None for x in (path, function, motion)]
    if sum(given) != 1:
        raise InputError(explain("synthesis task", expected="exactly one of path, function, motion",
                                 got=f"{sum(given)} given"))
    if path is not None:
        return "path", path_target(m, path, point, shape_only=shape_only, timing=timing)
    if timing != "reference":
        raise ParameterError(explain(f"timing {timing!r}", expected="a path target with a third column",
                                     got="function generation" if function is not None else "motion generation"),
                             "timing")
    if function is not None:
        if output is None:
            raise ParameterError(explain("function generation", expected="an output joint ('output')", got="none"),
                                 "output")
        return "function", function_target(m, function, output)
    if link is None:
        raise ParameterError(explain("motion generation", expected="a link ('link')", got="none"), "link")
    return "motion", motion_target(m, motion, link)


@contextmanager
def _unbounded(ev: Evaluator):
    """Lift the evaluator's deadline for a few single-design evaluations (the
    assessment of a result must not see designs cut off as failures)."""
    saved, ev.deadline = ev.deadline, None
    try:
        yield
    finally:
        ev.deadline = saved


def _assess(problem: Problem, z: np.ndarray, phi: np.ndarray):
    """Errors of design ``z`` at driver values ``phi`` and whether the motion from the
    reference reaches them continuously, in order: ``(rel (N,), ang (N,)|None, ok)``."""
    with _unbounded(problem.ev):
        return _assess_unbounded(problem, z, phi)


def _assess_unbounded(problem: Problem, z: np.ndarray, phi: np.ndarray):
    Z = z[None, :]
    grid, targets = _grid_and_targets(problem, Z, phi)
    _, valid, cphi, full = problem.curve(grid)
    d = np.diff(phi)
    ordered = bool(np.all(d >= -1e-12) or np.all(d <= 1e-12))
    if valid.any():
        # the grid proves only where the motion cannot go: a sample that does not assemble
        # (the first one past the reached run, δ beyond its ends); a target between the run's
        # last sample and that one is the certified walk's to decide (:func:`_certified`)
        lo, hi = cphi[valid].min() - problem.delta, cphi[valid].max() + problem.delta
        inside = bool(full[0]) or bool(np.all((phi > lo + 1e-9) & (phi < hi - 1e-9)))
    else:                   # (the design does not assemble at its reference: nothing is reached)
        inside = False
    F, reached = targets
    ok = ordered and inside and reached
    T, size = problem.targets_for(Z)
    r = problem.diff(F, T, size).reshape(len(phi), -1)
    ang = None
    if isinstance(problem.target, MotionTarget):
        ang = np.degrees(np.abs(r[:, 2]))
        r = r[:, :2]
    rel = np.sqrt(np.sum(np.square(r), axis=1))
    return np.where(np.isfinite(rel), rel, np.inf), ang, ok


def _at_targets(problem: Problem, Z: np.ndarray, phi: np.ndarray):
    """Design ``Z`` (1, n)'s features ``(1, N, c)`` at the targets' driver values ``phi``
    and whether every one is reached.  A path-dependent plan (a triad's or class IV
    group's mode followed along the inputs) is solved along
    :meth:`~.objective.Problem.walk` from the reference and reaches its targets when every
    input of the walk assembles."""
    X = Z[:, :problem.nx]
    W, at = problem.walk(phi[None, :]) if problem.ev.path_dependent else (phi, np.arange(len(phi)))
    st = problem.ev.poses(X, W)
    return problem.features(Z, st)[:, at], bool(st.ok.all())


def _grid_and_targets(problem: Problem, Z: np.ndarray, phi: np.ndarray):
    """Design ``Z`` (1, n)'s driver grid's statuses ``(1, M)`` (what the motion reaches)
    and :func:`_at_targets`: a path-dependent plan's grid (:meth:`~.objective.Problem.grid_poses`)
    apart from its walk to the targets, any other's grid and targets' values in one call."""
    X = Z[:, :problem.nx]
    if problem.ev.path_dependent:
        return problem.grid_poses(X).ok[:, :problem.M], _at_targets(problem, Z, phi)
    st = problem.ev.poses(X, np.concatenate([problem.grid, phi]))
    M, F = problem.M, problem.features(Z, st)
    return st.ok[:, :M], (F[:, M:], bool(st.ok[0, M:].all()))


def synthesise(start: Mechanism, *, path=None, point: str | None = None, shape_only: bool = False,
               function=None, output: str | None = None, motion=None, link: str | None = None,
               seed: int = 0, evaluations: int | None = None, budget: float | None = None, method: str = "de",
               tol: float = 1e-6,
               bounds: dict | None = None, full_rotation: bool = False, min_transmission: float | None = None,
               length_bounds: tuple[float, float] | None = None, max_ratio: float | None = None,
               timing: str = "reference", grashof: str = "any", mode: str = "any", direction: str = "any",
               free_timing: str | None = None, popsize: int = 8, grid: int = 96, progress=None) -> SynthesisResult:
    """Dimensional synthesis of ``start``: path, function or motion generation.

    Parameters
    ----------
    start : Mechanism
        Topology, names, one driver and a starting geometry (it must assemble).
    path : array (N, 2|3) or CSV path, optional
        Points the tracer ``point`` meets in driver order (free timing), or with a
        third column the driver value (deg, m for a slider input).  ``shape_only``:
        the target may be scaled, rotated and translated.
    function, output : optional
        Rows (driver value, output value), deg for R joints / m for P joints, and the
        output joint (relative rotation of its ``links[1]`` w.r.t. ``links[0]``, or
        slide); the first row is the reference configuration.
    motion, link : optional
        Poses (x, y, angle deg) of a frame attached to ``link``, met in order.
    seed : int
        The random seed, in [0, 2**32).
    evaluations, budget : optional
        The run's limits (:class:`~.budget.Budget`): candidate designs evaluated (the
        search, its probes and the polish; the same seed gives the same design on any
        machine) and a wall-time cap in seconds.  Neither:
        :data:`~.budget.DEFAULT_EVALUATIONS` evaluations.
    method, tol, popsize, grid
        ``"de"``, ``"cmaes"`` or ``"local"`` (no global search: the start is only
        polished), early stop on the relative RMS error, population per variable,
        driver samples per turn.
    bounds : dict, optional
        ``{"J.x": (low, high), ...}`` by design-variable name (default: the box
        around the start and the target widened by its size).
    full_rotation, min_transmission, length_bounds, max_ratio
        Constraints (penalties), see :class:`~.objective.Constraints`.
    timing : {"reference", "absolute", "step"}
        What a path's third column measures: the driver value from the reference;
        the driver's absolute value (an R driver on the frame: the driven link's
        angle from the x-axis, deg; a P driver: the slider's position along its
        guide from the guide's point, m); or only the steps between consecutive
        targets, from a free start value.
    grashof : {"any", "crank-rocker", "double-crank"}
        A four-bar start only: crank-rocker, the driven link shortest and the loop
        Grashof (s + l <= p + q); double-crank, the frame shortest and Grashof.
    mode : {"any", "reference"}
        ``"reference"``: every dyad keeps the start's assembly branch.
    direction : {"any", "ccw", "cw"}
        The driven link's turning sense through the targets (a slider: ``"ccw"`` is
        forward along its guide), for free and ``step`` timing.
    free_timing : {"searched", "matched"}, optional
        Driver values searched (:mod:`.searched_timing`) or matched to each design's curve
        on the grid; default searched, matched for ``method="local"`` or a whole-motion constraint.
    progress : callable(fraction, best), optional

    Returns
    -------
    SynthesisResult

    Raises
    ------
    InputError
        Too few targets, NaN, unknown point/joint/link, unknown method.
    ParameterError
        A limit out of range (``evaluations`` not a whole number in [1, 10**12],
        ``budget`` not a number of seconds up to a day), ``tol`` not a finite number >= 0,
        a bad ``seed``, ``free_timing`` unknown or ``"searched"`` with prescribed timing.
    AssemblyError, SingularityError
        The start does not assemble in its reference configuration.
    """
    _import_optimisers(method)          # one-off module imports (seconds) are not synthesis time
    limits = Budget.of(evaluations, budget)
    with one_blas_thread():
        return _synthesise(start, path, point, shape_only, function, output, motion, link, seed, limits, method,
                           tol, bounds, full_rotation, min_transmission, length_bounds, max_ratio, timing, grashof,
                           mode, direction, free_timing, popsize, grid, progress)


def _synthesise(m, path, point, shape_only, function, output, motion, link, seed, limits: Budget, method, tol,
                bounds, full_rotation, min_transmission, length_bounds, max_ratio, timing, grashof, mode, direction,
                free_timing, popsize, grid, progress) -> SynthesisResult:
    """:func:`synthesise`'s work (its arguments, checked here).  The search has 60 % of
    what the run has left after set-up (its probes included), the final polish the rest."""
    t0 = time.perf_counter()
    _check_start(m, method, seed, tol)
    cons = Constraints(full_rotation, min_transmission, length_bounds, max_ratio, grashof=grashof, mode=mode,
                       direction=direction)
    task, target = _target(m, path, point, shape_only, function, output, motion, link, timing)
    target, sampled = _checked(task, target, direction)
    problem = _problem(m, task, target, bounds, cons, grid, None if limits.seconds is None else t0 + limits.seconds)
    start_note = _closed_form(problem)
    free_timing = _free_timing(problem, free_timing, method)
    view = _search_view(problem, free_timing)
    work = Meter.start(limits, _search_deadline(problem, t0, limits.seconds))
    problem.ev.deadline = work.deadline
    polished: list = []
    search = work.share(0.6)
    res = global_search(view, method=method, seed=seed, meter=search, tol=tol, popsize=popsize, progress=progress,
                        probe=None if method == "local" else _prober(problem, view, polished, search, tol))
    z, phi = _designs(problem, view, res.z[None, :])
    best = _best(problem, z[0], phi[0], polished, skip=res.stopped == "tolerance", meter=work)
    out = _result(problem, replace(res, stopped=_stopped(res.stopped, method, best, tol, work)), best,
                  [sampled, start_note], task, target, method, seed, t0, limits)
    return replace(out, free_timing=free_timing)


def _stopped(searched: str, method: str, best, tol: float, work: Meter) -> str:
    """Why the run stopped: the global search's reason, or for the local method (whose
    search is the final polish) the tolerance met, a limit reached, or convergence."""
    if method != "local" or searched == "tolerance":
        return searched
    if np.sqrt(np.mean(best[0][0] ** 2)) <= tol:
        return "tolerance"
    return work.stop() or "converged"


def _result(problem: Problem, res, best, notes0: list, task: str, target, method: str, seed: int,
            t0: float, limits: Budget) -> SynthesisResult:
    """The :class:`SynthesisResult` of the chosen design ``best`` (see :func:`_best`)."""
    (rel, ang, ok), z, phi, n2, notes = best
    notes = [n for n in notes0 if n] + notes
    ev = problem.ev
    with _unbounded(ev):
        achieved, wanted = _achieved(problem, z, phi)
        report = tuple(constraint_report(problem, z, phi, ok))
    out = _output(ev, z[:problem.nx], task, target, method, seed, float(np.max(rel)))
    return SynthesisResult(out, task, float(np.max(rel)), float(np.sqrt(np.mean(rel ** 2))), res.evaluations + n2,
                           time.perf_counter() - t0, method, seed, phi, achieved, wanted,
                           dict(zip(problem.names, map(float, z))), res.stopped,
                           None if ang is None else float(np.max(ang)), res.history, tuple(notes), report, limits)


def _problem(m: Mechanism, task: str, target, bounds, cons: Constraints, grid: int,
             deadline: float | None) -> Problem:
    """The design space, the evaluator (with its hard ``deadline``) and the problem,
    with its start values for a motion frame, a shape-only similarity and a step
    timing's offset."""
    region = target.points if task == "path" else target.poses[:, :2] if task == "motion" else None
    space = design_space(m, [target.point] if task == "path" else [], region=region, bounds=bounds)
    ev = Evaluator(m, space)
    ev.deadline = deadline              # a hard bound for the slow path's per-candidate loop
    problem = Problem(ev, target, cons, grid)
    problem.init_motion_frame()
    problem.init_shape()
    problem.init_offset()
    if not ev.poses(space.x0[None, :], [0.0]).ok.all():
        raise InputError(explain(f"start mechanism '{m.name or ''}'", expected="a reference configuration that assembles",
                                 got="a group out of reach at the reference"))
    return problem


def _free_timing(problem: Problem, free_timing: str | None, method: str) -> str | None:
    """The free timing of a run: ``free_timing`` as asked (checked), or by default
    ``"searched"`` with a global search and no constraint on the whole motion, else
    ``"matched"``: for ``method="local"`` (no search to vary the values: the polish starts
    from the match) and with ``full_rotation`` or ``min_transmission`` (the grid is solved
    for them anyway, and the matched search met them as well or better: the README's
    ellipse).  None with prescribed timing (where ``"searched"`` is refused)."""
    if free_timing is None:
        if not problem.free_timing:
            return None
        return "matched" if method == "local" or problem.cons.on_motion else "searched"
    if free_timing not in FREE_TIMINGS:
        raise ParameterError(explain("free_timing", expected=" or ".join(map(repr, FREE_TIMINGS)),
                                     got=repr(free_timing)), "free_timing")
    if free_timing == "searched" and not problem.free_timing:
        raise ParameterError(explain("free_timing 'searched'", expected="free timing (a path without driver values, "
                                     "or a motion)", got="prescribed driver values",
                                     hint="leave it out (prescribed timing searches the design alone)"), "free_timing")
    return free_timing if problem.free_timing else None


def _search_view(problem: Problem, free_timing: str | None):
    """What the global search varies for the run's ``free_timing`` (see
    :func:`_free_timing`): the problem itself, or with ``"searched"`` its
    :class:`~.searched_timing.SearchedTiming` view."""
    if free_timing != "searched":
        return problem
    with _unbounded(problem.ev):
        return SearchedTiming(problem)


def _designs(problem: Problem, view, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The designs ``(k, n)`` of the search's points ``Y`` and the driver values ``(k, N)``
    a polish starts them from: each design's match on the driver grid, or with searched
    timing the search's own values where they meet the targets better than that match
    (the search's values alone left the line and ellipse cases of the literature
    benchmark in poorer basins; the grid only seeds the polish here)."""
    with _unbounded(problem.ev):
        Z, own = view.split(Y) if view is not problem else (Y, None)
        matched = np.array([problem.match(z) for z in Z])
        if own is None:
            return Z, matched
        worse = [np.sum(np.nan_to_num(problem.residuals_batch(Z, P), nan=np.inf) ** 2, axis=1) for P in (own, matched)]
    return Z, np.where((worse[1] < worse[0])[:, None], matched, own)


def _prober(problem: Problem, view, polished: list, meter: Meter, tol: float):
    """The global search's probe: polish the designs of search points ``Y`` ``(k, ·)``
    together (:func:`~.optimise.polish_batch`, charged to the search's ``meter``), keep
    each result in ``polished``, and say whether one meets the tolerance and every
    constraint."""
    def probe(Y):
        if meter.stop() is not None:
            return False
        Z, PHI = _designs(problem, view, Y)
        Z2, PHI2, n = polish_batch(problem, Z, PHI, max_nfev=100, meter=meter)
        met = False
        for i, (z2, phi2) in enumerate(zip(Z2, PHI2)):
            a = _assess(problem, z2, phi2)
            polished.append((a, z2, phi2, n if i == 0 else 0))
            met = met or (a[2] and np.sqrt(np.mean(a[0] ** 2)) <= tol and _violation(problem, z2) == 0.0)
        return met
    return probe


@contextmanager
def one_blas_thread():
    """BLAS on one thread while the synthesiser runs: its matrices are small (the
    trust region's SVD of a few hundred columns at most), and a threaded BLAS spins
    when other processes share the cores (a local polish measured 4.7 times slower in
    wall time and 4.2 times in CPU time at a load of 3 on 2 cores)."""
    from threadpoolctl import threadpool_limits
    with threadpool_limits(limits=1, user_api="blas"):
        yield


def _import_optimisers(method: str) -> None:
    """Import the optimiser modules now, so that the budget's clock does not pay
    for them (``cma`` alone can take seconds to import on a loaded machine)."""
    import scipy.optimize  # noqa: F401
    if method == "cmaes":
        import cma  # noqa: F401


def _search_deadline(problem: Problem, t0: float, budget: float | None) -> float | None:
    """When the search and the polish must stop under a cap of ``budget`` seconds (None:
    no cap, no deadline): the cap less a reserve for the final assessment (about six
    single-design evaluations, timed here; at most a quarter of the budget).  It matters
    on the slow path, where one design costs one :func:`kin.solve.solve` call."""
    if budget is None:
        return None
    t = time.perf_counter()
    with _unbounded(problem.ev):
        problem.batch(problem.x0[None, :])
    return t0 + budget - min(0.25 * budget, 6.0 * (time.perf_counter() - t))


def _output(ev: Evaluator, x: np.ndarray, task: str, target, method: str, seed: int, error: float) -> Mechanism:
    """The start with design ``x``: names kept, ``source`` citing the target, and a
    description of the new design (the start's own description, which describes
    other dimensions, is replaced)."""
    m = ev.mechanism
    src = (f"dimensional synthesis ({task} generation) by multiloop synthesise: {target.source}; "
           f"method {method}, seed {seed}")
    what = (f"{m.name or 'Mechanism'} with dimensions synthesised by multiloop synthesise for {task} generation "
            f"({target.source}, {len(target.target_points())} targets, largest error {error:.3g} of the "
            f"target size).")
    return replace(ev.with_design(x), source=src, description=what)


def _closed_form(problem: Problem) -> str | None:
    """Replace the start design by the closed-form four-bar one when it scores better."""
    from .starts import closed_form_start
    cf = closed_form_start(problem)
    if cf is None:
        return None
    z, what = cf
    f = problem.batch(np.vstack([problem.x0, z]))
    if f[1] < f[0]:
        problem.x0 = z
        return f"{what} used (objective {f[1]:.3g} against {f[0]:.3g} for the given start)"
    return None


#: how many designs the final polish refines together: the global search's design and the
#: best of the candidates polished before it
FINAL_STARTS = 2


def _best(problem: Problem, z: np.ndarray, phi: np.ndarray, polished: list, skip: bool = False,
          meter: Meter | None = None):
    """The best of the global design ``z`` (at driver values ``phi``), its polish and the
    probes' polished designs:
    a design meeting the targets on the continuous branch beats one that does not.

    What ``meter`` has left is split: the global design and the best
    :data:`FINAL_STARTS` − 1 other candidates (often the probes' polished designs) are
    polished together with half of it (:func:`~.optimise.polish_batch`), then the best
    candidate so far with the rest.  When the search stopped at the tolerance
    (``skip``), only the best candidate is polished, a little (100 residual evaluations:
    near a solution the steps converge quickly)."""
    cands = [(_assess(problem, z, phi), z, phi, 0)] + polished
    notes = []
    ranked = _Ranking(problem)
    for first in ((False,) if skip else (True, False)):
        if meter is not None and meter.stop() is not None:
            break
        part = None if meter is None else meter.share(0.5) if first else meter
        picks = [cands[0]] + ranked.first(cands[1:], FINAL_STARTS - 1) if first else ranked.first(cands, 1)
        Z2, PHI2, n = polish_batch(problem, np.array([c[1] for c in picks]), np.array([c[2] for c in picks]),
                                   max_nfev=100 if skip else 1500, meter=part)
        for i, (z2, phi2) in enumerate(zip(Z2, PHI2)):
            cands.append((_assess(problem, z2, phi2), z2, phi2, n if i == 0 else 0))
            if first and i == 0 and not cands[-1][0][2]:
                notes.append("the local polish left the continuous branch")
    a, zb, phib, _ = _certified(problem, ranked.ordered(cands))
    if not a[2]:
        notes.append("the targets are not all reached by continuous motion from the reference")
    return a, zb, phib, sum(c[3] for c in cands), notes


class _Ranking:
    """Candidates ``(assessment, z, phi, n)`` ranked best first: reaching the targets on
    the continuous branch, then meeting every constraint, then accepted by ``kin.solve``
    (:func:`_solvable`: a plan compiled, the costliest test), then by RMS error.  The
    solvability is tested only where it decides the first places asked for, and every
    test is kept for the next ranking."""

    def __init__(self, problem: Problem):
        self.problem = problem
        self.known: dict = {}           # id of a design -> (its cheap key, solvable or None)

    def _cheap(self, c) -> tuple:
        hit = self.known.get(id(c[1]))
        if hit is None:
            hit = self.known[id(c[1])] = [(not c[0][2], _violation(self.problem, c[1]) > 0.0,
                                           float(np.sqrt(np.mean(c[0][0] ** 2)))), None]
        return hit

    def _solvable(self, c) -> bool:
        hit = self._cheap(c)
        if hit[1] is None:
            hit[1] = _solvable(self.problem, c[1])
        return hit[1]

    def ordered(self, cands: list):
        """``cands`` in the ranking, lazily (a plan is compiled only when the next place
        asks for it): within each class of the first two criteria, the solvable ones by
        error, then the others by error (a stable order: ties keep the candidates' order)."""
        order = sorted(cands, key=lambda c: self._cheap(c)[0])
        i = 0
        while i < len(order):
            cls, later = self._cheap(order[i])[0][:2], []
            while i < len(order) and self._cheap(order[i])[0][:2] == cls:
                if self._solvable(order[i]):
                    yield order[i]
                else:
                    later.append(order[i])
                i += 1
            yield from later

    def first(self, cands: list, n: int) -> list:
        """The first ``n`` of ``cands`` in the ranking (all of them when fewer)."""
        return list(itertools.islice(self.ordered(cands), n))


#: how many of the best ranked candidates the certified walk may try
CERTIFIED = 5


def _certified(problem: Problem, ranked):
    """The first of the best five ``ranked`` candidates (an iterable, read no further
    than needed: :meth:`_Ranking.ordered`) whose certified motion
    (``multiloop check``'s walk, :func:`~.report.reaches_targets`) reaches its targets in
    order without passing a limit and that meets the certified constraints, else the
    first, with its assessment's ``ok`` replaced by the certified answer: the targets'
    continuity (the driver grid's samples may all assemble with a limit between two), a
    full rotation that ``check`` certifies, and a minimum transmission angle that holds
    by ``check``'s exact extremes (one on the threshold at the grid's samples may dip
    below it between two)."""
    c = problem.cons
    first = None
    for cand in itertools.islice(ranked, CERTIFIED):
        first = cand if first is None else first
        if not (cand[0][2] and _reached(problem, cand)):
            continue
        if c.full_rotation and not turns_fully(problem, cand[1]):
            continue
        if c.min_transmission and not certified_transmission(problem, cand[1]) >= c.min_transmission:
            continue
        return cand
    (rel, ang, ok), rest = first[0], first[1:]
    return ((rel, ang, bool(ok and _reached(problem, first))),) + tuple(rest)


def _reached(problem: Problem, cand) -> bool:
    """Whether candidate ``cand``'s certified motion reaches its targets' driver values in
    order from the reference (:func:`~.report.reaches_targets`, the span held)."""
    m = problem.ev.with_design(np.asarray(cand[1], float)[:problem.nx])
    return reaches_targets(m, cand[2], closed=False)


def _violation(problem: Problem, z: np.ndarray) -> float:
    """The constraint violation of design ``z`` (zero when it meets every constraint:
    full rotation, transmission, lengths, ratio, a non-singular reference)."""
    X = z[None, :problem.nx]
    with _unbounded(problem.ev):
        st = problem.grid_poses(X)
    full = problem.curve(st.ok)[3]
    return float(problem.violation(X, st, full)[0])


def _solvable(problem: Problem, z: np.ndarray) -> bool:
    """Whether ``kin.solve`` accepts the design (no singular group at the reference)."""
    from multiloop.kin.solve import compile_plan
    from multiloop.topo.errors import LinkageError
    try:
        compile_plan(problem.ev.with_design(z[:problem.nx]))
    except LinkageError:
        return False
    return True


def _achieved(problem: Problem, z: np.ndarray, phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """What design ``z`` does at ``phi`` and the target, in user units: points (N, 2),
    poses (N, 3; angle deg) or outputs (N,; deg or m)."""
    Z = z[None, :]
    F = _at_targets(problem, Z, np.asarray(phi, float))[0][0]          # (a path-dependent plan: walked to)
    T = problem.targets_for(Z)[0][0]
    t = problem.target
    if isinstance(t, MotionTarget):
        return np.column_stack([F[:, :2], np.degrees(F[:, 2])]), np.column_stack([T[:, :2], np.degrees(T[:, 2])])
    if isinstance(t, FunctionTarget):
        rot = problem.ev.mechanism.joint(t.joint).kind.is_rotary
        y = F[:, 0] + t.outputs[0]
        return (np.degrees(y), np.degrees(t.outputs)) if rot else (y, t.outputs.copy())
    return F, np.asarray(T)
