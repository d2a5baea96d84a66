"""Path synthesis without a start: the atlas chooses the topology.

:func:`synthesise` normalises the target as the atlas's curves are normalised
(:mod:`.curves`), retrieves the nearest stored coupler curves in both traversal
directions (:class:`.curve_atlas.CurveIndex`), ranks them by the aligned distance
(closed targets; open ones by their nearest sub-arcs, :mod:`.open_targets`), reads the first
retrieved realisations with their best tracer points (:mod:`.tracers`), carries the
best few mechanisms of each topology onto the target by the similarity that aligns
their curves, screens each by the dimensional synthesiser's local polish
(:func:`.dimensional.synthesise` with ``method="local"``, which frees every joint and
the tracer point) and polishes the best few again on more target points; a target
given as a curve (more points than that polish takes) has its returned designs refined
by the distance between the curves (:mod:`.dimensional.curve_distance`, after LInK's
chamfer), each checked as below.  A design is returned only when its driver's certified motion
(:func:`kin.solve.motion_events`) reaches every target input on one continuous branch;
an open target's design is written over its
input interval (the driver's ``range``).  Designs are ordered by RMS error, fewer
links first when their errors agree within ``tol``.  While the best error is above
``tol``, further rounds of retrieved starts are screened until the limits are spent
(:func:`_screen_and_refine`).

The run's limits are a :class:`.dimensional.budget.Budget`: its evaluations (the
designs every polish scores) or its seconds are shared out as the polishes' own limits,
so under an evaluation budget the same seed gives the same designs on any machine.

This is the retrieve-then-optimise scheme of Nobari et al. 2024 (LInK) with an
exact, isomorph-free topology space (:mod:`.inversions`) instead of learned
embeddings.
"""
from __future__ import annotations

import json
import sqlite3
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from multiloop.topo.assur import decompose
from multiloop.topo.errors import InputError, LinkageError, ParameterError, explain
from multiloop.topo.model import Mechanism, MechanismBuilder, TracerPoint
from multiloop.kin.solve import motion_events, solve

from .atlas import Atlas
from .curves import (CURVE_POINTS, aligned_distances, chamfer_score, descriptor, is_closed, normalise,
                     polyline_distance, similarity_to)
from .curve_atlas import CurveIndex, stored_curve
from .dimensional import SynthesisResult, synthesise as dimensional_synthesise
from .dimensional.budget import LIMITS, Budget, Meter
from .dimensional.curve_distance import SAMPLES, fit_curve
from .dimensional.synthesise import check_tol, one_blas_thread
from .dimensional.report import certified_motion, limits_text, reaches_targets
from .dimensional.targets import check_rows, read_table
from .inversions import inversion
from .open_targets import on_interval, ranked_windows
from .synthesis import SynthesisOptions
from .tracers import best_tracers

__all__ = ["Design", "TopologySynthesis", "synthesise", "candidate_mechanism", "parse_links", "design_files",
           "read_target", "check_top"]

#: target points handed to the dimensional synthesiser (arc-length resampled)
POLISH_POINTS = 40
#: ... and to the finalists' second polish (the whole curve between the screen's points)
REFINE_POINTS = 120
#: evaluations of a run when neither limit is given (a four-bar target polished on the
#: test atlas: about 1 700 evaluations/s on 2 busy cores, so about a minute)
DEFAULT_EVALUATIONS = 100_000
#: the least evaluations worth a polish (a few Jacobians); in seconds, 0.05
MIN_POLISH = Budget(100, 0.05)
#: share of the budget for the screen (every retrieved start polished briefly) ...
SCREEN_SHARE = 0.5
#: ... and kept for the final checks (the finalists' second polish has the rest; the
#: returned designs' refinement by the distance between the curves has half of it)
ASSESS_SHARE = 0.15
#: evaluations kept for the returned designs' refinement by the distance between the
#: curves (:func:`_curve_stage`), for a target that is a curve: one of more points than
#: the finalists' polish takes (:data:`REFINE_POINTS`: the polish sees a sample of it).
#: Fewer points are precision points, met as given: the polyline through sparse points
#: is not the curve they lie on (its chords cut its bulges), so no distance to it is asked.
CURVE_SHARE = 0.15
#: the nearest start's least share of the budget, however long the retrieval took
MIN_SHARE = 0.1
#: the most evaluations of one start's screening polish, and of one finalist's second
#: polish: a larger budget screens more starts (:func:`_screen_and_refine`)
SCREEN_EACH = 3000
REFINE_EACH = 6000
#: a finalist whose refine improved its RMS error by less than this fraction is not
#: refined again
STALL = 0.01
#: a screened design this close (relative to the target's size) ends the screen when no
#: start has fewer links
EXACT = 1e-9
#: realisations read with their best tracer points (closed targets), and points per link
REFIT_REALISATIONS = 60
REFIT_PER_LINK = 2


@dataclass(frozen=True)
class Design:
    """One returned design: the mechanism (tracer point ``point``), its errors relative
    to the target's size at the polished points (the dimensional synthesiser's), its
    number of links, structure formula, LInK's chamfer score of its traced curve
    against the target, and ``deviation_max``: the largest distance from any target
    point to the traced curve (the polyline of 2000 driver steps,
    :func:`.curves.polyline_distance`), over the target's size.  ``interval``: an open
    target's input interval as written in the design's driver ``range`` (rad or m from
    its reference; :attr:`input_range` in deg or m), None for a closed target.
    ``fit``: ``"points"`` when the design is the point-matching polish's (the errors are
    at its matched points), ``"curve"`` when it was refined further by the distance
    between the curves (:mod:`.dimensional.curve_distance`; the errors are then the
    target points' distances to the traced curve, as ``deviation_max``)."""

    mechanism: Mechanism
    error_max: float
    error_rms: float
    links: int
    structure: str
    chamfer: float
    retrieved: float
    seconds: float
    deviation_max: float = float("nan")
    evaluations: int = 0
    interval: tuple[float, float] | None = None
    fit: str = "points"

    @property
    def input_range(self) -> list[float] | None:
        """The driver's ``range`` written with an open target's design (deg for an R
        driver, m for a P driver, from the written reference), else None."""
        if self.interval is None:
            return None
        rotary = self.mechanism.is_rotary(0)
        return [float(np.degrees(v)) if rotary else float(v) for v in self.interval]

    def as_dict(self, file: str | None = None) -> dict:
        return {"error_max": self.error_max, "error_rms": self.error_rms, "links": self.links,
                "structure": self.structure, "file": file, "chamfer": self.chamfer,
                "deviation_max": self.deviation_max, "retrieval_distance": self.retrieved,
                "evaluations": self.evaluations, "seconds": round(self.seconds, 3), "input_range": self.input_range,
                "fit": self.fit}


@dataclass(frozen=True)
class TopologySynthesis:
    """Outcome of :func:`synthesise`: the designs (best first), whether the target was
    read as closed, the candidates polished, the time, the evaluations spent, the limits
    and which one stopped the run (one of :data:`.dimensional.budget.STOPS`; in
    :meth:`as_list`, every row's ``stopped``)."""

    designs: tuple[Design, ...]
    closed: bool
    polished: int
    seconds: float
    evaluations: int = 0
    limits: Budget = Budget()
    stopped: str = "converged"

    def as_list(self, files=None) -> list[dict]:
        files = list(files) if files is not None else [None] * len(self.designs)
        return [{**d.as_dict(f), "stopped": self.stopped} for d, f in zip(self.designs, files)]

    def to_text(self, files=None) -> str:
        lines = [f"{len(self.designs)} designs ({'closed' if self.closed else 'open'} target, "
                 f"{self.polished} polished, {self.evaluations} evaluations in {self.seconds:.1f} s; "
                 f"limits: {limits_text(self.limits.as_dict())}; stopped: {self.stopped})"]
        for d in self.as_list(files):
            rng = "" if d["input_range"] is None else "  input range [{:.6g}, {:.6g}]".format(*d["input_range"])
            lines.append(f"  {d['links']} links  rms {d['error_rms']:.3g}  max {d['error_max']:.3g}  "
                         f"chamfer {d['chamfer']:.3g}  fit {d['fit']}  {d['structure']}{rng}"
                         + (f"  -> {d['file']}" if d["file"] else ""))
        return "\n".join(lines)


def parse_links(text) -> tuple[int, ...]:
    """``"4,6,8"`` → ``(4, 6, 8)``; even numbers of links from 4 (1-DOF chains) that an
    atlas can hold (:class:`.synthesis.SynthesisOptions`).

    Raises
    ------
    ParameterError
        Names the parameter ``links``.
    """
    why = None
    try:
        links = tuple(int(v) for v in str(text).split(","))
        for n in links:
            if n >= 4 and n % 2 == 0:
                SynthesisOptions(n, 1)    # the atlas's own bound on the number of links
    except InputError as exc:
        links, why = (), str(exc)
    except ValueError:
        links = ()
    if not links or any(n < 4 or n % 2 for n in links):
        raise ParameterError(explain("links", expected="even numbers of links >= 4, e.g. 4,6,8", got=repr(text)[:80],
                                     hint=why), "links")
    return links


def design_files(out, k: int) -> list[Path]:
    """``OUT.toml``, ``OUT-2.toml``, … for ``k`` designs."""
    p = Path(out)
    return [p] + [p.with_name(f"{p.stem}-{i}{p.suffix}") for i in range(2, k + 1)]


def read_target(path) -> np.ndarray:
    """The path target as an (N, 2) array: a table file (:func:`.dimensional.targets.read_table`)
    or an array, checked (finite, spread out)."""
    if isinstance(path, (str, Path)):
        return read_table(path, (2, 3), "path")[:, :2]
    a = np.asarray(path, float)
    if a.ndim != 2 or a.shape[1] not in (2, 3):
        raise InputError(explain("path target", expected="an array of shape (N, 2)", got=f"shape {a.shape}"))
    return check_rows(a, "path", "path target")[:, :2]


def candidate_mechanism(curve: dict, transform, point: str) -> Mechanism:
    """The stored realisation of ``curve`` (:func:`.curve_atlas.stored_curve`) moved by
    ``transform`` (a similarity), with the traced point named ``point``."""
    chain = curve["joints_of_chain"]
    at = {name: tuple(transform(np.asarray(p, float))) for name, p in curve["joints"].items()}
    m = inversion(chain, curve["frame"], curve["joint"], curve["driven"],
                  name=f"atlas-{curve['n']}-bar", at=at)
    b = MechanismBuilder.from_mechanism(m)
    b.points = [TracerPoint(point, curve["link"], tuple(float(v) for v in transform(np.asarray(curve["at"]))))]
    return b.build()


def _ranked(atlas: Atlas, target: np.ndarray, closed: bool, links, candidates: int) -> list[tuple[float, dict, object]]:
    """(distance, curve, similarity) of the retrieved curves, nearest first.  A closed
    target reads each retrieved realisation with its best tracer points
    (:func:`.tracers.best_tracers`) instead of the stored ones."""
    try:
        index = CurveIndex(atlas, links)
        count = len(index)
    except sqlite3.OperationalError:        # an atlas without the curve tables
        count = 0
    if not count:
        raise InputError(explain("atlas curves", expected=f"stored coupler curves of {links}-link mechanisms",
                                 got=f"none in {atlas.path!r}",
                                 hint="build them: multiloop atlas --links 6 --dof 1 --mechanisms --curves 8"))
    if not closed:
        return ranked_windows(atlas, index, target, candidates)
    zt, ct, rt = normalise(target, CURVE_POINTS, closed)
    hits = index.query(descriptor(target, closed=closed), candidates)
    out = _refit([stored_curve(atlas, hit.curve) for hit in hits], zt, ct, rt)
    return sorted(out, key=lambda t: t[0])


def _refit(curves: list[dict], zt: np.ndarray, ct: complex, rt: float) -> list[tuple[float, dict, object]]:
    """The stored curves ranked by the aligned distance, and for each of the first
    :data:`REFIT_REALISATIONS` realisations met, its :data:`REFIT_PER_LINK` best tracer
    points on every moving link but the driven one (the realisations of one mechanism
    solved together)."""
    out, first, by_mechanism = [], {}, {}
    dists, _, rots, _ = aligned_distances(zt, np.array([c["shape"] for c in curves])) if curves else ((), 0, (), 0)
    for c, dist, rot in zip(curves, dists, rots):
        out.append((float(dist), c, similarity_to(ct, rt, c["centre"], c["radius"], complex(rot))))
        key = (c["mechanism"], json.dumps(c["joints"], sort_keys=True))
        if key not in first and len(first) < REFIT_REALISATIONS:
            first[key] = c
            by_mechanism.setdefault(c["mechanism"], []).append(c)
    for group in by_mechanism.values():
        c0 = group[0]
        m = inversion(c0["joints_of_chain"], c0["frame"], c0["joint"], c0["driven"], at=c0["joints"])
        moving = [k for k in m.link_names if k not in (m.frame, m.drivers[0].links[1])]
        fits = best_tracers(m, [c["joints"] for c in group], zt, moving, per_link=REFIT_PER_LINK)
        for c, fs in zip(group, fits):
            out += [(f.distance, {**c, "link": f.link, "at": f.at}, similarity_to(ct, rt, f.centre, f.radius, f.rotation))
                    for f in fs]
    return out


def _subset(target: np.ndarray, n: int, closed: bool = True) -> np.ndarray:
    """At most ``n`` of the target's own points, evenly spaced by arc length (points on
    the target, not on its chords); an open target's last point is one of them (the
    stroke's end bounds the input interval)."""
    if len(target) <= n:
        return target
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(target, axis=0), axis=1))])
    idx = np.unique(np.searchsorted(s, np.linspace(0.0, s[-1], n, endpoint=not closed)))
    return target[np.minimum(idx, len(target) - 1)]


def _error_is_the_motions(res: SynthesisResult, point: str) -> bool:
    """Whether the polished error is the design's own: the tracer solved by the
    certified motion (:func:`kin.solve.solve`) at the polished inputs meets the
    polished targets within the reported error (to 1e-6 of the target's size): the
    polish's own solve (design batches, a triad's or class IV group's mode followed
    along a walk from the reference, :meth:`.dimensional.objective.Problem.walk`)
    checked by the second route before a design is returned."""
    st = solve(res.mechanism, np.asarray(res.inputs, float))
    T = np.asarray(res.target, float)
    P = st.point_positions[:, st.point_index(point)]
    size = float(np.max(np.ptp(T, axis=0))) or 1.0
    err = np.linalg.norm(P - T, axis=1) / size
    return bool(np.all(np.isfinite(err)) and err.max() <= res.error_max + 1e-6)


def _traced(m: Mechanism, point: str, inputs: np.ndarray, closed: bool) -> np.ndarray:
    """The tracer densely (for the chamfer score and the deviation): one turn from the
    reference for a closed target met by a fully turning driver, else over the inputs'
    span (a driver that does not turn fully meets a closed target's inputs on both
    sides of its reference: a turn from the reference would trace only the part past
    it, and the deviation would count the points before it as missed)."""
    turns = closed and m.is_rotary(0) and (ev := motion_events(m)) is not None and ev.turns_fully
    lo, hi = (0.0, 2 * np.pi) if turns else (float(np.min(inputs)), float(np.max(inputs)))
    st = solve(m, np.linspace(lo, hi, 2000))
    P = st.point_positions[:, st.point_index(point)]
    return P[np.all(np.isfinite(P), axis=1)]


def _local(start: Mechanism, target: np.ndarray, closed: bool, point: str, limits: Budget,
           seed: int, points: int = POLISH_POINTS, tick=None, method: str = "local",
           tol: float = 1e-12) -> SynthesisResult | None:
    """The dimensional synthesiser on ``start`` (by default its local polish,
    ``method="local"``: no global search) on at most ``points`` target points, within
    ``limits``; ``tick()`` is called at its progress reports."""
    try:
        res = dimensional_synthesise(start, path=_subset(target, points, closed), point=point, **limits.keywords(),
                                     seed=seed, tol=tol, full_rotation=closed, method=method,
                                     progress=None if tick is None else (lambda f, b: tick()))
    except LinkageError:
        return None
    return res if np.isfinite(res.error_max) and np.isfinite(res.error_rms) else None


def _design(res: SynthesisResult, closed: bool, point: str, retrieved: float, seconds: float,
            target: np.ndarray, evaluations: int = 0) -> Design | None:
    """A :class:`Design` of a polished result, when its certified motion reaches every
    target input on one branch (an open target: within the certified range of motion,
    and the design is written over that interval, :func:`.open_targets.on_interval`);
    with LInK's chamfer score and the dense deviation."""
    m, inputs = res.mechanism, np.asarray(res.inputs, float)
    if not reaches_targets(m, inputs, closed) or not _error_is_the_motions(res, point):
        return None
    return _made(m, inputs, closed, point, target, retrieved, seconds, evaluations,
                 (float(res.error_max), float(res.error_rms)))


def _made(m: Mechanism, inputs: np.ndarray, closed: bool, point: str, target: np.ndarray, retrieved: float,
          seconds: float, evaluations: int, errors=None, fit: str = "points") -> Design | None:
    """The :class:`Design` of a checked mechanism ``m`` met at driver ``inputs`` (an open
    target's design written over their span): its traced curve, chamfer score and
    deviation; ``errors`` ``(max, rms)``, default the target points' distances to the
    traced curve (over the target's size)."""
    interval = None
    if not closed:
        try:
            m, interval = on_interval(m, inputs)
        except (LinkageError, ValueError):
            return None
    curve = _traced(m, point, np.asarray(interval if interval else inputs), closed)
    if len(curve) < 3:
        return None
    size = float(np.max(np.ptp(target, axis=0)))
    gaps = polyline_distance(target, curve)
    if errors is None:
        errors = (float(gaps.max() / size), float(np.sqrt(np.mean(np.square(gaps))) / size))
    return Design(m, errors[0], errors[1], m.n_links, decompose(m).formula,
                  chamfer_score(target, curve, closed=closed), float(retrieved), seconds, float(gaps.max() / size),
                  int(evaluations), interval, fit)


def _curve_fitted(d: Design, target: np.ndarray, closed: bool, point: str, meter: Meter) -> Design:
    """Design ``d`` refined by the distance between the curves
    (:func:`.dimensional.curve_distance.fit_curve`, within ``meter``): the fit's last
    round whose design passes the checks of a returned design (:func:`_holds_curve`: a
    curve traced at :data:`SAMPLES` inputs could step over a narrow window where the
    design does not assemble), when its distance to the target is lower than ``d``'s,
    else ``d`` itself.  Lower: in the target's own frame (the fit's residual, both halves), not
    by :func:`.curves.chamfer_score`, which compares shapes after a similarity and can
    prefer a design whose curve is farther from the target."""
    if d.interval is not None and 0.0 not in d.interval:
        return d                # (a stroke that does not start at the reference: a P joint's design)
    t0 = time.perf_counter()
    span = None if d.interval is None else (d.interval[1] if d.interval[0] == 0.0 else d.interval[0])
    fit = fit_curve(d.mechanism, target, closed, point, meter, span=span,
                    accept=lambda m, sp, x, curve: _holds_curve(m, x, curve, closed, point, target))
    if fit is None or not fit.after < fit.before:
        return d
    m, _ = fit.at(1.0)
    new = _made(m, fit.problem.timing_for(fit.end)[0], closed, point, target, d.retrieved,
                d.seconds + time.perf_counter() - t0, d.evaluations + fit.evaluations, fit="curve")
    return d if new is None else new


def _holds_curve(m: Mechanism, inputs: np.ndarray, curve: np.ndarray, closed: bool, point: str,
                 target: np.ndarray) -> bool:
    """Whether design ``m`` passes the checks of a returned design along ``inputs``: its
    certified motion holds them on one branch (turns fully, for a closed target), and
    the certified ``solve`` of its tracer there agrees with the batch's ``curve``
    (:meth:`.dimensional.curve_distance.CurveProblem.curves`) to 1e-6 of the target's size."""
    motion = certified_motion(m, inputs)
    if motion is None or not (motion.turns_fully if closed else reaches_targets(m, inputs, False, motion)):
        return False
    st = solve(m, inputs)
    P = st.point_positions[:, st.point_index(point)]
    return bool(np.all(np.abs(P - curve) <= 1e-6 * float(np.max(np.ptp(target, axis=0)))))


def _polish(start: Mechanism, target: np.ndarray, closed: bool, point: str, limits: Budget, seed: int,
            retrieved: float, full_target: np.ndarray) -> tuple[Design | None, SynthesisResult | None]:
    """A given start through the whole dimensional synthesiser (global search, then
    polish): its design (None when it fails the check) and the synthesiser's result."""
    t0 = time.perf_counter()
    res = _local(start, target, closed, point, limits, seed, method="de", tol=1e-9)
    if res is None:
        return None, None
    return _design(res, closed, point, retrieved, time.perf_counter() - t0, full_target, res.evaluations), res


def _order(items: list, tol: float, key=lambda d: (d.error_rms, d.links)) -> list:
    """By RMS error, in bands: a band holds the items within ``tol`` of its best error,
    and inside a band fewer links come first (``key(item) = (rms, links)``).  A NaN
    error counts as infinite (last); every band holds at least its best item, so the
    loop ends for any ``tol``."""
    def rms(d) -> float:
        e = float(key(d)[0])
        return e if e == e else np.inf
    rest = sorted(items, key=rms)
    out: list = []
    while rest:
        k = 1
        while k < len(rest) and rms(rest[k]) <= rms(rest[0]) + tol:
            k += 1
        out += sorted(rest[:k], key=lambda d: (key(d)[1], rms(d)))
        rest = rest[k:]
    return out


def _choose(ranked: list, per_topology: int, topologies: int) -> list[tuple[float, dict, object]]:
    """The best ``per_topology`` curves of each of the first ``topologies`` mechanisms
    met per link count (nearest first)."""
    taken: dict[int, int] = {}
    per_n: dict[int, set] = {}
    out = []
    for dist, c, tf in ranked:
        mids = per_n.setdefault(c["n"], set())
        if c["mechanism"] not in mids and len(mids) >= topologies:
            continue
        if taken.get(c["mechanism"], 0) >= per_topology:
            continue
        mids.add(c["mechanism"])
        taken[c["mechanism"]] = taken.get(c["mechanism"], 0) + 1
        out.append((dist, c, tf))
    return out


def synthesise(path=None, start=None, links=(4, 6, 8), *, atlas: str | Path | None = None, top: int = 3,
               evaluations: int | None = None, budget: float | None = None, point: str = "P", tol: float = 1e-4,
               per_topology: int = 2, topologies: int = 4, candidates: int = 200, finalists: int = 3, seed: int = 0,
               progress=None, build_progress: bool = False, say=None, closed: bool | None = None) -> TopologySynthesis:
    """Path synthesis that chooses the topology from the atlas (module docstring).

    Parameters
    ----------
    path : array (N, 2) or CSV path
        The target points in order (an open or closed curve, see ``closed``).
    start : Mechanism, optional
        Given a start, this is the dimensional synthesiser on that start (the
        topology is fixed); without one the atlas chooses.
    links : tuple of int
        Numbers of links to consider.
    atlas : str or Path, optional
        The atlas file with stored curves (``multiloop atlas … --mechanisms --curves K``);
        default: the default atlas, built into the user's cache on first use
        (:func:`.default_atlas.ensure_default_atlas`).
    top : int
        Designs returned.
    evaluations, budget : optional
        The run's limits (:class:`.dimensional.budget.Budget`), shared out to the
        polishes: designs evaluated in all (reproducible) and a wall-time cap in seconds.
        Neither: :data:`DEFAULT_EVALUATIONS` (with a ``start``, the dimensional
        synthesiser's default).
    point : str
        Name of the tracer point of the designs.
    tol : float
        Errors (relative RMS) that agree within ``tol`` count as ties: fewer links first.
    per_topology, topologies, candidates : int
        Polished curves per mechanism, mechanisms per link count, curves retrieved.
    finalists : int
        Screened designs polished again (at least ``top``).
    progress : callable(fraction), optional
        Called with the share of the budget spent (of the evaluations, else of the
        seconds), before every polish and during it; an exception it raises (a cancel)
        ends the run.
    build_progress, say : optional
        When the default atlas is built first: progress bars, and ``say(text)`` told
        where and what it costs (after the target and the options are checked).
    closed : bool, optional
        Whether the target is a closed curve (traced over whole turns of the driver) or
        an open one (a stroke over part of the driver's motion, :mod:`.open_targets`).
        Default: closed when the gap from its last point to its first is at most 1.1
        times its longest step (:func:`.curves.is_closed`).

    Returns
    -------
    TopologySynthesis

    Raises
    ------
    ParameterError
        ``budget`` not a positive number of seconds, ``tol`` not a finite number >= 0,
        ``top`` not a positive integer.
    """
    t0 = time.perf_counter()
    target = read_target(path)
    closed = is_closed(target) if closed is None else bool(closed)
    tol = check_tol(tol)
    if start is not None:
        return _with_start(start, target, closed, point, Budget.of(evaluations, budget), seed, t0)
    limits = Budget.of(evaluations, budget, default=DEFAULT_EVALUATIONS)
    check_top(top)
    atlas = _atlas_file(atlas, build_progress, say)
    run = Meter.start(limits, None if limits.seconds is None else t0 + limits.seconds)
    tick = None if progress is None else (lambda: progress(run.fraction()))
    with one_blas_thread():                 # (one BLAS thread: the same sums on any machine, and faster)
        with Atlas(atlas, readonly=True) as a:
            ranked = _ranked(a, target, closed, tuple(links), candidates)
        rounds = _Rounds(ranked, per_topology, topologies, point)
        curve = len(target) > REFINE_POINTS
        polished, stopped = _screen_and_refine(rounds, target, closed, point, seed,
                                               run.until(1.0 - CURVE_SHARE, 1.0) if curve else run,
                                               tol, max(top, finalists), tick)
        designs = _checked_designs(polished, target, closed, point, top, tick)
        if curve:
            designs = _curve_stage(designs, target, closed, point, run.until(1.0, 1.0 - ASSESS_SHARE / 2), tol, tick)
    return TopologySynthesis(tuple(designs), closed, rounds.taken, time.perf_counter() - t0, run.used, limits, stopped)


def _checked_designs(polished: list, target: np.ndarray, closed: bool, point: str, top: int, tick=None) -> list:
    """The first ``top`` polished results, in order, that make a :class:`Design`
    (:func:`_design`: they pass the check)."""
    designs = []
    for res, dist, seconds, n in polished:
        if tick is not None:
            tick()
        d = _design(res, closed, point, dist, seconds, target, n)
        if d is not None:
            designs.append(d)
            if len(designs) == top:
                break
    return designs


def _curve_stage(designs: list, target: np.ndarray, closed: bool, point: str, meter: Meter, tol: float,
                 tick=None) -> list:
    """Each design whose RMS error is above ``tol`` refined by the distance between the
    curves (:func:`_curve_fitted`), the designs sharing ``meter`` equally (what one
    leaves, the next may use); the order is kept."""
    out = []
    for k, d in enumerate(designs):
        if tick is not None:
            tick()
        if d.error_rms > tol and meter.portion(len(designs) - k, smallest=MIN_POLISH) is not None:
            d = _curve_fitted(d, target, closed, point, meter.share(1.0 / (len(designs) - k)))
        out.append(d)
    return out


def _atlas_file(atlas, progress: bool = False, say=None) -> Path:
    """The atlas to read: ``atlas``, which must be a file, or (None) the default atlas,
    built first if need be (:func:`.default_atlas.ensure_default_atlas`)."""
    if atlas is None:
        from .default_atlas import ensure_default_atlas
        return ensure_default_atlas(progress=progress, say=say)
    if not Path(atlas).is_file():
        raise ParameterError(explain("atlas", expected="an atlas file with coupler curves", got=repr(str(atlas)),
                                     hint="build one (multiloop atlas --links 6 --dof 1 --mechanisms --curves 8), "
                                          "or leave it out for the default atlas"), "atlas")
    return Path(atlas)


def check_top(top) -> int:
    """``top``, the number of designs asked for: a positive integer, else a
    :class:`ParameterError` (checked before any atlas is read or built)."""
    if isinstance(top, bool) or not isinstance(top, (int, np.integer)) or top < 1:
        raise ParameterError(explain("top", expected="a positive number of designs", got=repr(top)), "top")
    return int(top)


def _with_start(start, target: np.ndarray, closed: bool, point: str, limits: Budget, seed: int,
                t0: float) -> TopologySynthesis:
    """:func:`synthesise` given a start: the dimensional synthesiser on its topology."""
    d, res = _polish(start, target, closed, point, limits, seed, float("nan"), target)
    return TopologySynthesis(tuple([d] if d else []), closed, 1, time.perf_counter() - t0,
                             0 if res is None else res.evaluations, limits, "converged" if res is None else res.stopped)


class _Rounds:
    """The retrieved starts in rounds: each round is :func:`_choose` of the curves not
    yet taken (the nearest ``per_topology`` curves of the nearest ``topologies``
    mechanisms per link count), as mechanisms carried onto the target; ``taken``
    counts the starts handed out."""

    def __init__(self, ranked: list, per_topology: int, topologies: int, point: str):
        self.rest, self.per_topology, self.topologies, self.point = list(ranked), per_topology, topologies, point
        self.taken = 0

    def next(self) -> list[tuple[float, Mechanism]]:
        chosen = _choose(self.rest, self.per_topology, self.topologies)
        ids = {id(c) for _, c, _ in chosen}                 # (each ranked curve is its own dict)
        self.rest = [t for t in self.rest if id(t[1]) not in ids]
        self.taken += len(chosen)
        return [(dist, candidate_mechanism(c, tf, self.point)) for dist, c, tf in chosen]


def _screen_and_refine(rounds: _Rounds, target: np.ndarray, closed: bool, point: str, seed: int, run: Meter,
                       tol: float, finalists: int, tick=None) -> tuple[list[tuple], str]:
    """Screen (:func:`_screen`) and refine (:func:`_refine`) until the best RMS error
    is at most ``tol``, the run's limits are spent, or every retrieved start was
    screened and the best ``finalists`` are polished to convergence.  The first screen
    has :data:`SCREEN_SHARE` of the run; every later one half of what is left.  After
    each screen the best ``finalists`` of all so far are refined, unless their last
    polish converged or improved the RMS error by less than :data:`STALL` (a finalist
    cut by its share while improving is polished further).  Returns
    ``(result, retrieval distance, seconds, evaluations)``, best first, and why the run
    stopped (one of :data:`.dimensional.budget.STOPS`)."""
    key = lambda r: (r[0].error_rms, r[0].mechanism.n_links)     # noqa: E731
    tick = tick or (lambda: None)
    done, stops, settled, screen = [], [], set(), run.until(SCREEN_SHARE)
    while True:
        spent = run.used
        screened, more = _screen(rounds, target, closed, point, seed, screen, run, tol, tick, stops, first=not done)
        pool = _order(done + screened, tol, key)
        again = [e for e in pool[:finalists] if id(e[0]) not in settled]
        refined = _refine(again, target, closed, point, seed, run, tick, stops)
        settled |= {id(e[0]) for e, was in zip(refined, again)       # converged, or improved by < 1 %
                    if e[0].stopped not in LIMITS or e[0].error_rms > (1.0 - STALL) * was[0].error_rms}
        done = _order([e for e in pool if all(e is not g for g in again)] + refined, tol, key)
        if "exact" in stops or (done and done[0][0].error_rms <= tol):
            return done, "tolerance"
        if run.stop() or run.portion(1, smallest=MIN_POLISH) is None or run.used == spent:
            return done, run.stop() or run.binding()
        if not more and all(id(e[0]) in settled for e in done[:finalists]):
            return done, "exhausted"
        screen = run.share(SCREEN_SHARE)


def _refine(best: list, target: np.ndarray, closed: bool, point: str, seed: int, run: Meter, tick,
            stops: list) -> list[tuple]:
    """The best results polished again on :data:`REFINE_POINTS`, sharing what is left
    of the run's evaluations and of its seconds but :data:`ASSESS_SHARE` (kept for the
    checks), at most :data:`REFINE_EACH` evaluations each; the polishes' stops are
    appended to ``stops``."""
    refine = run.until(1.0, 1.0 - ASSESS_SHARE)
    refined = []
    for k, (res, dist, secs, n) in enumerate(best):
        share = _capped(refine.portion(len(best) - k, smallest=MIN_POLISH), REFINE_EACH)
        t = time.perf_counter()
        tick()
        again = None if share is None else _local(res.mechanism, target, closed, point, share, seed, REFINE_POINTS,
                                                  tick)
        stops.append(refine.binding() if share is None else again.stopped if again is not None else "converged")
        if again is not None:
            refine.spend(again.evaluations)
        used = time.perf_counter() - t
        refined.append((res if again is None else again, dist, secs + used,
                        n + (0 if again is None else again.evaluations)))       # (errors at more points)
    return refined


def _capped(share: Budget | None, most: int) -> Budget | None:
    """``share`` with at most ``most`` evaluations (so that the budget screens more
    starts instead of polishing a few for longer)."""
    if share is None:
        return None
    return Budget(most if share.evaluations is None else min(share.evaluations, most), share.seconds)


def _screen(rounds: _Rounds, target: np.ndarray, closed: bool, point: str, seed: int, screen: Meter, run: Meter,
            tol: float, tick, stops: list, first: bool = True) -> tuple[list[tuple], bool]:
    """Rounds of starts (:class:`_Rounds`), each start polished locally on
    :data:`POLISH_POINTS` target points with an equal share of what is left of
    ``screen`` (the run's very first start at least :data:`MIN_SHARE` of the run), at
    most :data:`SCREEN_EACH` evaluations, until a share is below :data:`MIN_POLISH`, a
    round ends with an RMS error at most ``tol``, or a design is exact with the fewest
    links of its round.  Returns ``(result, retrieval distance, seconds, evaluations)``
    and whether starts are left; the polishes' stops are appended to ``stops``."""
    screened = []
    while True:
        starts = rounds.next()
        if not starts:
            return screened, False
        fewest = min(m.n_links for _, m in starts)
        for k, (dist, m) in enumerate(starts):
            t = time.perf_counter()
            # (what one start overran, the next ones lose; the nearest start is always polished)
            each = _capped(screen.portion(len(starts) - k, run.scaled(MIN_SHARE)) if first and k == 0 else
                           screen.portion(len(starts) - k, smallest=MIN_POLISH), SCREEN_EACH)
            if each is None:
                stops.append(screen.binding())
                return screened, True
            tick()
            res = _local(m, target, closed, point, each, seed, tick=tick)
            if res is not None:
                screen.spend(res.evaluations)
                screened.append((res, dist, time.perf_counter() - t, res.evaluations))
                stops.append(res.stopped)
                if res.error_max <= EXACT and m.n_links == fewest:
                    stops.append("exact")
                    return screened, True               # exact with the fewest links: nothing to beat
        if min((r[0].error_rms for r in screened), default=np.inf) <= tol:
            return screened, True
