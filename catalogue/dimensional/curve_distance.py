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
same trust region and meter, with the exact Jacobian of :meth:`CurveProblem.jacobian_batch`.

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
    return _nearest_segments(P, curve, closed, tree)[0].reshape(P.shape)


def _nearest_segments(points, curve, closed: bool, tree=None):
    """:func:`nearest_on_polyline`'s nearest points ``q`` (D, n, 2), and which segment and
    where: its first vertex's index ``a`` (D, n) into the curve, its direction ``v``
    (D, n, 2), the parameter ``t`` (D, n) clipped to [0, 1] and whether the unclipped one
    was inside (``inner``), for the derivatives of :meth:`CurveProblem.jacobian_batch`."""
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
    best = None
    for a in ((k - 1) % m if closed else np.maximum(k - 1, 0), k if closed else np.minimum(k, m - 2)):
        A = ends[rows, a]
        v = ends[rows, a + 1] - A
        raw = np.sum((P2 - A) * v, axis=-1) / np.maximum(np.sum(v * v, axis=-1), 1e-300)
        t = np.clip(raw, 0.0, 1.0)
        q = A + t[..., None] * v
        d2 = np.sum(np.square(P2 - q), axis=-1)
        if best is None:
            best = [q, a, v, t, (raw > 0.0) & (raw < 1.0), d2]
        else:
            nearer = d2 < best[5]
            best = [np.where(nearer[..., None] if x.ndim == 3 else nearer, y, x)
                    for x, y in zip(best, (q, a, v, t, (raw > 0.0) & (raw < 1.0), d2))]
    lead = P.shape[:-1]
    return tuple(x.reshape(lead + x.shape[2:]) for x in best[:5])


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
    exact_jacobian = True

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
        return self._chamfer(C, mu)[0]

    def jacobian_batch(self, Z: np.ndarray, PHI=None) -> tuple[np.ndarray, np.ndarray]:
        """The residuals ``(D, R)`` of designs ``Z`` (:meth:`residuals_batch`, traced at
        :meth:`timing_for`; ``PHI``, the polish's, is that) and their exact Jacobian
        ``(D, R, n)`` with respect to the variables.

        The traced samples' derivatives are the poses' design sensitivities
        (:func:`multiloop.kin.sensitivity.pose_sensitivity`: every step's velocity
        analogue; an open target's span moves the samples by their velocity times their
        fraction of the span).  The chamfer halves are differentiated on their nearest
        segments (a point's nearest point on a moving segment; a sample's offset from a
        fixed one and its arc-length weight), where they are smooth (a nearest segment
        that changes is a kink of the distance itself).  The hinge's margin is a check's
        angle formula, an explicit function of the poses, differenced along their exact
        tangents (:class:`multiloop.kin.sensitivity.TangentView`, a millionth of each
        variable's range)."""
        from multiloop.kin import kernel
        from multiloop.kin.sensitivity import pose_sensitivity
        Z = np.atleast_2d(Z)
        X, nx = Z[:, :self.nx], self.nx
        st = self.ev.poses(X, self.timing_for(Z))
        with kernel.for_batches():
            sens = pose_sensitivity(st)
        C = np.where(st.ok[..., None], st.point(self.point), np.nan)
        mu = transmission_angles(self.ev, X, st)
        dC = self._by_variables(sens.point(self.point), nx)
        worst = np.argmin(np.where(np.isnan(mu), np.inf, mu), axis=1)
        rows = np.arange(len(Z))
        dmu = np.zeros((len(Z), len(self.x0)))
        if np.any(mu[rows, worst] < MIN_MARGIN):
            span = self.upper - self.lower
            eps = 1e-6 * np.r_[span[:nx], span[nx] if not self.closed else 1.0]
            tv = sens.tangent(eps)
            d = tv.derivative(transmission_angles(self.ev, X, tv))            # (D, N, q)
            dmu = self._by_variables(d[:, :, None, :], nx)[rows, worst, 0]
        return self._chamfer(C, mu[rows, worst], dC, dmu)

    def _by_variables(self, d: np.ndarray, nx: int) -> np.ndarray:
        """Derivatives ``(D, N, c, q)`` by design variables and input → by the problem's
        variables ``(D, N, c, n)`` (the input's column, times each sample's fraction of the
        span, is an open target's span's)."""
        if self.closed:
            return d[..., :nx]
        return np.concatenate([d[..., :nx], d[..., nx:nx + 1] * self.s[None, :, None, None]], axis=-1)

    def _chamfer(self, C: np.ndarray, mu: np.ndarray, dC: np.ndarray | None = None,
                 dmu: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
        """The residuals ``(D, R)`` of traced curves ``C`` (D, N, 2) whose smallest margins
        are ``mu`` (D,), and with the derivatives ``dC`` (D, N, 2, n) and ``dmu`` (D, n)
        their Jacobian ``(D, R, n)`` (else None)."""
        n, N = len(self.target), C.shape[1]
        out = np.full((len(C), 2 * n + 2 * N + 1), np.nan)
        jac = None if dC is None else np.full(out.shape + (dC.shape[-1],), np.nan)
        whole = np.all(np.isfinite(C), axis=(1, 2))
        if not whole.any():
            return out, jac
        c = C[whole]
        dc = None if dC is None else dC[whole]
        r1, j1 = self._to_curve(c, dc)
        r2, j2 = self._to_target(c, dc)
        out[whole, :-1] = np.concatenate([r1.reshape(len(c), -1), r2.reshape(len(c), -1)], axis=1) / self.size
        hinge = 1.0 - mu[whole] / MIN_MARGIN
        out[whole, -1] = np.maximum(0.0, hinge)
        if jac is not None:
            last = np.where((hinge > 0.0)[:, None], -dmu[whole] / MIN_MARGIN, 0.0)
            jac[whole] = np.concatenate([j1.reshape(len(c), 2 * n, -1) / self.size,
                                         j2.reshape(len(c), 2 * N, -1) / self.size, last[:, None, :]], axis=1)
        return out, jac

    def _to_curve(self, c: np.ndarray, dc: np.ndarray | None):
        """Target → curve offsets ``(D, n, 2)`` over √n, and their derivatives (D, n, 2, k):
        the nearest point ``q = A + t v`` of segment AB of the curve, with
        ``t = (T − A)·v / v·v`` inside the segment (else an end), moves by
        ``dq = (1 − t) dA + t dB + v dt``."""
        n = len(self.target)
        T = np.broadcast_to(self.target, (len(c), n, 2))
        q, a, v, t, inner = _nearest_segments(T, c, self.closed)
        r = (T - q) / np.sqrt(n)
        if dc is None:
            return r, None
        rows = np.arange(len(c))[:, None]
        dA, dB = dc[rows, a], dc[rows, (a + 1) % c.shape[1]]
        kB = (T - c[rows, a]) - 2.0 * t[..., None] * v          # dt = (kA·dA + kB·dB) / v·v
        kA = -(kB + v)
        vv = np.maximum(np.sum(v * v, axis=-1), 1e-300)
        dt = np.where(inner, 1.0, 0.0)[..., None] * (np.einsum("dni,dnij->dnj", kA, dA)
                                                    + np.einsum("dni,dnij->dnj", kB, dB)) / vv[..., None]
        dq = (1.0 - t)[..., None, None] * dA + t[..., None, None] * dB + v[..., :, None] * dt[:, :, None, :]
        return r, -dq / np.sqrt(n)

    def _to_target(self, c: np.ndarray, dc: np.ndarray | None):
        """Curve → target offsets ``(D, N, 2)``, each times the root of its sample's share
        ``w`` of the curve's arc length, and their derivatives (D, N, 2, k): the offset
        from a fixed segment moves by its normal part, ``w = s_j / S`` by the lengths
        of the samples' segments."""
        q, a, v, t, inner = _nearest_segments(c, self.target, self.closed, self.tree)
        vec = np.diff(np.concatenate([c, c[:, :1]], axis=1) if self.closed else c, axis=1)
        seg = np.linalg.norm(vec, axis=2)
        s = self._shares(seg)
        S = np.maximum(np.sum(s, axis=1, keepdims=True), 1e-300)     # (half of each side's arc length)
        sw = np.sqrt(s / S)
        off = c - q
        r = off * sw[..., None]
        if dc is None:
            return r, None
        vv = np.maximum(np.sum(v * v, axis=-1), 1e-300)
        along = np.where(inner, 1.0, 0.0)[..., None] * np.einsum("dni,dnij->dnj", v, dc) / vv[..., None]
        doff = dc - v[..., :, None] * along[:, :, None, :]
        e = vec / np.maximum(seg, 1e-300)[..., None]
        ahead = np.roll(dc, -1, axis=1) if self.closed else dc[:, 1:]
        ds = self._shares(np.einsum("dki,dkij->dkj", e, ahead - dc[:, :ahead.shape[1]]))
        dw = ds / S[..., None] - s[..., None] * np.sum(ds, axis=1, keepdims=True) / S[..., None] ** 2
        dsw = np.where(sw[..., None] > 0.0, dw / (2.0 * np.maximum(sw, 1e-300)[..., None]), 0.0)
        return r, doff * sw[..., None, None] + off[..., :, None] * dsw[:, :, None, :]

    def _shares(self, seg: np.ndarray) -> np.ndarray:
        """Each sample's two half segments ``(D, N, ...)`` from segment lengths (or their
        derivatives) ``(D, N or N − 1, ...)``."""
        if self.closed:
            return seg + np.roll(seg, 1, axis=1)
        pad = np.zeros_like(seg[:, :1])
        return np.concatenate([seg, pad], axis=1) + np.concatenate([pad, seg], axis=1)

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
