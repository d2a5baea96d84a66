"""Dimensional refinement by the distance between curves, not between points.

Point matching (:mod:`.objective`) asks the tracer to pass through the target's points
in driver order, one driver value per point.  A target drawn as a curve (a letter, a
sketched path) asks less: that the traced curve and the target lie on each other.
:class:`CurveProblem` scores a design by the two halves of a chamfer distance (Barrow
et al. 1977; LInK, Nobari et al. 2024, scores its letters by it): every target point
against the traced curve, and every traced sample against the target, each to its
nearest point on the other *polyline* (a segment, not a vertex, so that the residual
does not jump from sample to sample).  As least-squares residuals (the offsets, not
their lengths) its square sum is the mean squared distance target → curve plus the
arc-length-weighted mean squared distance curve → target, both over the target's size.
One more residual keeps every dyad of the design off its reach limit along the curve
(its folded transmission angle at least :data:`MIN_MARGIN` at every sample): the
samples could otherwise step over a narrow window where the design does not assemble.

The traced curve is one turn of the driver from the design's reference (a closed
target whose driver turns fully), or the driver's span from the reference to ``span``
(an open target: the span is a variable of the problem, the stroke's start is the
reference, whose joints are variables too).  Every design is solved by
:meth:`.evaluator.Evaluator.poses` (the designs batched over the compiled plan, each on
its reference branches) at :data:`SAMPLES` inputs from its reference, dense enough for a
triad's mode to be followed.  The refinement itself is :func:`.optimise.polish`: the
same trust region, forward differences in one batched call and meter.

References
----------
.. [1] Barrow H.G., Tenenbaum J.M., Bolles R.C., Wolf H.C. Parametric correspondence
   and chamfer matching: two new techniques for image matching. Proc. 5th IJCAI (1977)
   659-663.
.. [2] Nobari A.H., Srivastava A., Gutfreund D., Xu K., Ahmed F. LInK: learning joint
   representations of design and performance spaces through contrastive learning for
   mechanism synthesis. arXiv:2405.20592 (2024).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from multiloop.kin.design import design_mechanism
from multiloop.kin.geometry import Geometry
from multiloop.topo.model import Mechanism

from .budget import Meter
from .evaluator import Evaluator, design_space
from .objective import transmission_angles
from .optimise import polish

__all__ = ["SAMPLES", "CurveProblem", "CurveFit", "nearest_on_polyline", "fit_curve"]

#: driver inputs at which a design's curve is traced while it is refined
SAMPLES = 240
#: target points kept (arc-length resampled) for the target → curve half
TARGET_POINTS = 200
#: the reach-limit angle margin (deg) below which a traced sample is penalised
MIN_MARGIN = 2.0


def nearest_on_polyline(points: np.ndarray, curve: np.ndarray, closed: bool = False,
                        tree: cKDTree | None = None) -> np.ndarray:
    """The nearest point ``(..., n, 2)`` of polyline ``curve`` (m, 2; with ``closed``, its
    last point joined to its first) to each of ``points`` (..., n, 2), or of each of the
    curves ``(D, m, 2)`` to its own points ``(D, n, 2)``: on one of the two segments at
    the curve's nearest vertex (found by a :class:`scipy.spatial.cKDTree` of each curve;
    ``tree``: a single ``curve``'s, if built already).  Exact for a
    curve sampled densely against its curvature, and continuous where the nearest
    vertex changes (both vertices share the segment between them).

    Examples
    --------
    >>> nearest_on_polyline(np.array([[0.5, 1.0], [3.0, 0.5]]), np.array([[0., 0.], [1., 0.], [2., 0.]])).tolist()
    [[0.5, 0.0], [2.0, 0.0]]
    """
    P = np.asarray(points, float)
    C = np.asarray(curve, float)
    m = C.shape[-2]
    if C.ndim == 2:
        _, k = (tree or cKDTree(C)).query(P.reshape(-1, 2))
        k, C = k.reshape(1, -1), C[None]
        P2 = P.reshape(1, -1, 2)
    else:
        P2 = P
        k = np.stack([cKDTree(c).query(p)[1] for c, p in zip(C, P2)])
    ends = np.concatenate([C, C[:, :1]], axis=1) if closed else C
    rows = np.arange(len(ends))[:, None]
    best = best_d2 = None
    for a in ((k - 1) % m if closed else np.maximum(k - 1, 0), k if closed else np.minimum(k, m - 2)):
        A = ends[rows, a]
        v = ends[rows, a + 1] - A
        t = np.clip(np.sum((P2 - A) * v, axis=-1) / np.maximum(np.sum(v * v, axis=-1), 1e-300), 0.0, 1.0)
        q = A + t[..., None] * v
        d2 = np.sum(np.square(P2 - q), axis=-1)
        if best is None:
            best, best_d2 = q, d2
        else:
            best = np.where((d2 < best_d2)[..., None], q, best)
    return best.reshape(P.shape)


class CurveProblem:
    """The chamfer residuals of designs of ``mechanism`` (module docstring), in the
    form :func:`.optimise.polish` refines: ``lower``/``upper`` bound the variables (the
    design's joints and tracer point in a box around the start and the target, and for
    an open target the driver's span), and :meth:`residuals_batch` gives ``(D, R)``.

    Parameters
    ----------
    mechanism : Mechanism
        The start; its topology, drivers and reference branches are kept.
    target : ndarray (n, 2)
        The target curve's points in order.
    closed : bool
        A closed target (one turn of the driver) or an open one (the driver's span).
    point : str
        The tracer point.
    span : float, optional
        An open target's starting span (rad or m from the reference).
    """

    free_timing = False
    constrained = False

    def __init__(self, mechanism: Mechanism, target: np.ndarray, closed: bool, point: str, span: float | None = None):
        from ..curves import resample
        self.closed, self.point = bool(closed), point
        T = np.asarray(target, float)
        self.target = resample(T, min(TARGET_POINTS, len(T)), closed) if len(T) > TARGET_POINTS else T
        self.size = float(np.max(np.ptp(self.target, axis=0))) or 1.0
        self.tree = cKDTree(self.target)
        space = design_space(mechanism, [point], region=self.target)
        self.ev = Evaluator(mechanism, space)
        self.nx = space.size
        self.rotary = mechanism.is_rotary(0)
        self.mech_size = mechanism.size
        lo, hi, x0 = space.lower, space.upper, space.x0
        if not closed:
            reach = 2 * np.pi if self.rotary else 2.0 * max(self.mech_size, self.size)
            lo, hi, x0 = np.r_[lo, -reach], np.r_[hi, reach], np.r_[x0, 0.0 if span is None else span]
        self.lower, self.upper, self.x0 = lo, hi, x0
        self.s = np.linspace(0.0, 1.0, SAMPLES) if not closed else np.arange(SAMPLES) / SAMPLES

    def timing_for(self, Z: np.ndarray) -> np.ndarray:
        """The inputs ``(D, SAMPLES)`` at which each design is traced, from its reference."""
        Z = np.atleast_2d(Z)
        span = np.full(len(Z), 2 * np.pi) if self.closed else Z[:, self.nx]
        return span[:, None] * self.s[None, :]

    def curves(self, Z: np.ndarray, PHI: np.ndarray | None = None) -> np.ndarray:
        """The traced samples ``(D, SAMPLES, 2)`` of designs ``Z`` (NaN rows where a
        design does not assemble)."""
        return self._traced(np.atleast_2d(Z), PHI)[0]

    def _traced(self, Z: np.ndarray, PHI: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """The traced samples and each design's smallest reach-limit angle margin over
        them (deg; :func:`.objective.transmission_angles`, ``inf`` when it has none)."""
        X = Z[:, :self.nx]
        st = self.ev.poses(X, self.timing_for(Z) if PHI is None else PHI)
        mu = transmission_angles(self.ev, X, st)
        return np.where(st.ok[..., None], st.point(self.point), np.nan), np.min(mu, axis=1, initial=np.inf)

    def residuals_batch(self, Z: np.ndarray, PHI: np.ndarray) -> np.ndarray:
        """Chamfer residuals ``(D, 2n + 2·SAMPLES + 1)`` (module docstring), and last the
        hinge ``max(0, 1 − μ/MIN_MARGIN)`` of the smallest reach-limit angle margin μ
        over the samples (a dyad's folded transmission angle: 0 at its reach limit), which
        keeps the refinement from a limit between two samples; a design that does not
        assemble along its whole curve gets NaN."""
        C, mu = self._traced(np.atleast_2d(Z), PHI)
        n, N = len(self.target), C.shape[1]
        out = np.full((len(C), 2 * n + 2 * N + 1), np.nan)
        whole = np.all(np.isfinite(C), axis=(1, 2))
        if not whole.any():
            return out
        c = C[whole]
        T = np.broadcast_to(self.target, (len(c), n, 2))
        to_curve = (T - nearest_on_polyline(T, c, self.closed)) / np.sqrt(n)
        seg = np.linalg.norm(np.diff(np.concatenate([c, c[:, :1]], axis=1) if self.closed else c, axis=1), axis=2)
        pad = np.zeros((len(c), 1))
        w = seg + np.roll(seg, 1, axis=1) if self.closed else np.hstack([seg, pad]) + np.hstack([pad, seg])
        w = w / np.maximum(np.sum(w, axis=1, keepdims=True), 1e-300)     # (half of each side's arc length)
        to_target = (c - nearest_on_polyline(c, self.target, self.closed, self.tree)) * np.sqrt(w)[..., None]
        out[whole, :-1] = np.concatenate([to_curve.reshape(len(c), -1), to_target.reshape(len(c), -1)], axis=1) / self.size
        out[whole, -1] = np.maximum(0.0, 1.0 - mu[whole] / MIN_MARGIN)
        return out

    def mechanism(self, z: np.ndarray) -> Mechanism:
        """Design ``z`` as a mechanism (the start's names, topology and drivers; the
        driver's ``range`` is the traced span's, none for a closed target)."""
        z = np.atleast_2d(z)
        m = design_mechanism(Geometry(self.ev.mechanism, self.ev.space.names, z[:, :self.nx]), 0)
        span = None if self.closed else float(z[0, self.nx])
        d = replace(m.drivers[0], range=None if span is None else (min(0.0, span), max(0.0, span)))
        return replace(m, drivers=(d,) + m.drivers[1:])


@dataclass(frozen=True)
class CurveFit:
    """A design refined by the curve distance: the problem, the refined variables
    (design, then an open target's span; :attr:`start`: the start's), the root of the mean squared residual
    (:class:`CurveProblem`) at both, and the designs evaluated."""

    problem: CurveProblem
    end: np.ndarray
    before: float
    after: float
    evaluations: int

    @property
    def start(self) -> np.ndarray:
        """The start's variables (the problem's own)."""
        return self.problem.x0

    def at(self, t: float = 1.0) -> tuple[Mechanism, float | None]:
        """The design a fraction ``t`` of the way from the start to the refined one, and
        its span (an open target's, rad or m from its reference; None for a closed one)."""
        return _design_of(self.problem, self.start + t * (self.end - self.start))


def fit_curve(mechanism: Mechanism, target, closed: bool, point: str, meter: Meter,
              span: float | None = None, accept=None, rounds: int = 10, chunk: int = 50) -> CurveFit | None:
    """Refine ``mechanism`` so that its tracer ``point`` traces ``target``
    (:class:`CurveProblem`) within ``meter``: at most ``rounds`` polishes
    (:func:`.optimise.polish`) of ``chunk`` residual evaluations each, each from the
    last, while they lower the residual and the meter lasts.  The result is the last
    round's design that ``accept(mechanism, span, inputs, curve) -> bool`` takes (given
    its traced ``inputs`` and the batch's ``curve`` there; asked from the last round
    back, so that a fit whose end passes costs one call), else the start.
    None when the start's own curve does not assemble or the meter cannot afford one
    Jacobian."""
    prob = CurveProblem(mechanism, target, closed, point, span)
    rms = lambda z: _rms(prob.residuals_batch(z[None], prob.timing_for(z))[0])  # noqa: E731
    if meter.affordable(len(prob.x0) + 3) < len(prob.x0) + 3:
        return None
    z, f = prob.x0.copy(), rms(prob.x0)
    meter.spend(1)
    if not np.isfinite(f):
        return None
    used, rounds_done = 1, [(z, f)]
    for _ in range(rounds):
        if meter.stop() is not None:
            break
        z1, _, n = polish(prob, z, np.empty(0), max_nfev=chunk, meter=meter)
        used += n
        if meter.take(1, whole=True) < 1:
            break
        used += 1
        f1 = rms(z1)
        if not f1 < f * (1.0 - 1e-9):
            break
        z, f = z1, f1
        rounds_done.append((z, f))
    for z, f in reversed(rounds_done[1:]):
        if accept is None or accept(*_design_of(prob, z), prob.timing_for(z)[0], prob.curves(z[None])[0]):
            return CurveFit(prob, z, rounds_done[0][1], f, used)
    return CurveFit(prob, prob.x0.copy(), rounds_done[0][1], rounds_done[0][1], used)


def _rms(r: np.ndarray) -> float:
    return float(np.sqrt(np.sum(r * r))) if np.all(np.isfinite(r)) else np.inf


def _design_of(prob: CurveProblem, z: np.ndarray) -> tuple[Mechanism, float | None]:
    return prob.mechanism(z), (None if prob.closed else float(z[prob.nx]))
