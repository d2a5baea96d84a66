"""Generic Newton solver for any group (or the whole mechanism), with continuation.

Coordinates are body poses: link ``k`` has ``Z[..., k, :] = (X, Y, θ)``, where
``(X, Y)`` is the current position of the link's reference point ``c_k`` (its
first joint's reference position, :func:`topo.constraints.link_origins`) and ``θ`` its
rotation from the reference configuration.  The material point that sat at ``r``
in the reference configuration is at ``X + R(θ)(r − c_k)``, so the reference
configuration is ``Z = (c, 0)`` for every link.

The equations are those of :class:`topo.constraints.Constraint` (pins, sliders,
drivers).  :class:`ConstraintSystem` compiles a list of them once into index
arrays; residual, Jacobian and the acceleration term ``γ = (dJ/dt) ż`` are NumPy
expressions over a leading batch axis.  Velocities and accelerations of the
unknown links follow from one linear system each, with the same matrix:

    J_u u̇ = −J_k k̇ − Φ_φ φ̇,        J_u ü = −J_k k̈ − Φ_φ φ̈ − γ.

:func:`newton` polishes a batch from a guess (vectorised), :func:`track` follows a
sequence of positions by continuation (secant predictor, step halving with
linearly interpolated knowns, a jump guard), which keeps the assembly branch of
the start.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from multiloop.topo.constraints import PairEquations

from ..result import Status
from ..continuation import Probe
from .step import SINGULAR, GroupStep, Outcome

__all__ = ["ConstraintSystem", "newton", "track", "rates", "TrackResult", "NewtonStep", "jacobian_rates", "relative_det"]


class ConstraintSystem(PairEquations):
    """Compiled equations of a set of constraints (:class:`topo.constraints.PairEquations`,
    which also owns the Jacobian), with the residual and the acceleration term."""

    def residual(self, Z: np.ndarray, inputs: np.ndarray) -> np.ndarray:
        """Φ(Z, inputs), shape (N, n_eq).  ``inputs`` is (N, n_drivers)."""
        N = Z.shape[0]
        out = np.zeros((N, self.n_eq))
        if self.R_a.size:
            pa = Z[:, self.R_a, :2] + self._rho(Z, self.R_a, self.R_ra)
            pb = Z[:, self.R_b, :2] + self._rho(Z, self.R_b, self.R_rb)
            d = pa - pb
            out[:, self.R_row] = d[..., 0]
            out[:, self.R_row + 1] = d[..., 1]
        if self.P_a.size:
            d = (Z[:, self.P_b, :2] + self._rho(Z, self.P_b, self.P_rb)
                 - Z[:, self.P_a, :2] - self._rho(Z, self.P_a, self.P_ra))
            n = self._rho(Z, self.P_a, self.P_dir)
            out[:, self.P_row] = np.sum(n * d, axis=-1)
        if self.A_a.size:
            out[:, self.A_row] = Z[:, self.A_b, 2] - Z[:, self.A_a, 2]
        rows = np.flatnonzero(self.drv >= 0)
        if rows.size:
            out[:, rows] -= inputs[:, self.drv[rows]]
        return out

    def gamma(self, Z: np.ndarray, Zd: np.ndarray) -> np.ndarray:
        """``γ = (dJ/dt) ż``: the acceleration terms not in ``J z̈``, shape (N, n_eq)."""
        N = Z.shape[0]
        out = np.zeros((N, self.n_eq))
        if self.R_a.size:
            ra = self._rho(Z, self.R_a, self.R_ra)
            rb = self._rho(Z, self.R_b, self.R_rb)
            wa = Zd[:, self.R_a, 2][..., None]
            wb = Zd[:, self.R_b, 2][..., None]
            g = -wa ** 2 * ra + wb ** 2 * rb
            out[:, self.R_row] = g[..., 0]
            out[:, self.R_row + 1] = g[..., 1]
        if self.P_a.size:
            ra = self._rho(Z, self.P_a, self.P_ra)
            rb = self._rho(Z, self.P_b, self.P_rb)
            n = self._rho(Z, self.P_a, self.P_dir)
            pn = np.stack([-n[..., 1], n[..., 0]], axis=-1)
            d = Z[:, self.P_b, :2] + rb - Z[:, self.P_a, :2] - ra
            wa = Zd[:, self.P_a, 2][..., None]
            wb = Zd[:, self.P_b, 2][..., None]
            prb = np.stack([-rb[..., 1], rb[..., 0]], axis=-1)
            pra = np.stack([-ra[..., 1], ra[..., 0]], axis=-1)
            dd = Zd[:, self.P_b, :2] + wb * prb - Zd[:, self.P_a, :2] - wa * pra
            w = wa[..., 0]
            out[:, self.P_row] = (-w ** 2 * np.sum(n * d, -1) + 2 * w * np.sum(pn * dd, -1)
                                  + np.sum(n * (-wb ** 2 * rb + wa ** 2 * ra), -1))
        return out

    @property
    def involved(self) -> np.ndarray:
        """Sorted indices of the links that appear in the equations."""
        return np.unique(np.concatenate([self.R_a, self.R_b, self.P_a, self.P_b,
                                         self.A_a, self.A_b]).astype(int))

    def input_column(self, n_drivers: int) -> np.ndarray:
        """∂Φ/∂inputs, shape (n_eq, n_drivers)."""
        G = np.zeros((self.n_eq, n_drivers))
        for r, k in enumerate(self.drv):
            if k >= 0:
                G[r, k] = -1.0
        return G


def _cols(unknown) -> np.ndarray:
    u = np.asarray(unknown, int)
    return (3 * u[:, None] + np.arange(3)).ravel()


def newton(sys: ConstraintSystem, Z: np.ndarray, inputs: np.ndarray, unknown,
           tol: float = 1e-13, maxiter: int = 30):
    """Vectorised Newton on the unknown links' poses from the guess in ``Z``.

    Parameters
    ----------
    sys : ConstraintSystem
    Z : ndarray (N, n_links, 3)
        Known poses filled in, unknown ones hold the guess (modified copy returned).
    inputs : ndarray (N, n_drivers)
    unknown : sequence of int
        Link indices solved for (``3 len(unknown) == sys.n_eq``).
    tol : float
        Stop when the Newton step ``|Δz|∞ ≤ tol · scale`` (the residual before it
        ``≤ max(tol, 1e-9) · scale``); accept when the final residual is
        ``≤ max(1e-10, 10 tol) · scale``.

    Returns
    -------
    Z : ndarray
    converged : ndarray of bool (N,)
    n_iter : int
    """
    Z = np.array(Z, float, copy=True)
    cols = _cols(unknown)
    u = np.asarray(unknown, int)
    scale = max(1.0, float(np.nanmax(np.abs(Z[..., :2]))) if Z.size else 1.0)
    active = np.all(np.isfinite(Z[:, sys.involved].reshape(Z.shape[0], -1)), axis=1)
    conv = np.zeros(Z.shape[0], bool)
    it = 0
    for it in range(1, maxiter + 1):
        idx = np.flatnonzero(active & ~conv)
        if idx.size == 0:
            break
        Zi = Z[idx]
        F = sys.residual(Zi, inputs[idx])
        J = sys.jacobian(Zi)[:, :, cols]
        try:
            dz = np.linalg.solve(J, -F[..., None])[..., 0]
        except np.linalg.LinAlgError:
            dz = np.stack([np.linalg.lstsq(Jk, -Fk, rcond=None)[0] for Jk, Fk in zip(J, F)])
        bad = ~np.all(np.isfinite(dz), axis=1)
        dz[bad] = 0.0
        Zi[:, u, :] += dz.reshape(idx.size, len(u), 3)
        Z[idx] = Zi
        res = np.max(np.abs(F), axis=1)
        step = np.max(np.abs(dz), axis=1)
        done = (step <= tol * scale) & (res <= max(tol, 1e-9) * scale)
        conv[idx[done & ~bad]] = True
        active[idx[bad]] = False
    # final residual check
    ok = conv.copy()
    if ok.any():
        F = sys.residual(Z[ok], inputs[ok])
        ok[np.flatnonzero(ok)] = np.max(np.abs(F), axis=1) <= max(1e-10, 10 * tol) * scale
    return Z, ok, it


def relative_det(J: np.ndarray) -> np.ndarray:
    """``|det J|`` of pair-equation Jacobian(s) ``J`` (..., m, m) made dimensionless, in [0, 1].

    The columns come in ``(x, y, θ)`` triples, one per unknown link; the rows mix
    lengths (a pin's closure) with pure numbers (a P pair's angle).  The plain
    ``|det J| / Π |column|`` therefore shrinks with the mechanism's size.  Here the
    rotation columns are divided by the group's longest lever arm ``L`` (the largest
    rotation entry of the rows that also hold translations), then every row and every
    column is scaled to unit 2-norm (one pass of Sinkhorn & Knopp's 1967 alternating
    scaling); the value is unchanged when the mechanism is scaled or moved and is at
    most 1 (Hadamard's inequality).
    """
    A = np.array(J, dtype=float)
    rot = np.arange(A.shape[-1]) % 3 == 2
    trans_rows = np.any(A[..., :, ~rot] != 0.0, axis=-1, keepdims=True)
    L = np.max(np.abs(np.where(trans_rows, A, 0.0)[..., :, rot]), axis=(-2, -1))
    A[..., :, rot] /= np.where(L > 0, L, 1.0)[..., None, None]
    r = np.linalg.norm(A, axis=-1, keepdims=True)
    A = A / np.where(r > 0, r, 1.0)
    c = np.linalg.norm(A, axis=-2, keepdims=True)
    A = A / np.where(c > 0, c, 1.0)
    return np.abs(np.linalg.det(A))



@dataclass(frozen=True)
class TrackResult:
    """Result of :func:`track`: poses, per-position ok mask, reasons, relative det;
    ``memo``, what a later track along the same first positions resumes from."""

    Z: np.ndarray
    ok: np.ndarray
    reason: np.ndarray
    rel_det: np.ndarray
    n_iter: int
    code: np.ndarray | None = None      # (N,) int: 0 ok, else a :class:`kin.result.Status`
    memo: "_Memo | None" = None


@dataclass(frozen=True)
class _Memo:
    """A track's inputs, the poses it was given, its settings and the tracker's state
    after each position: ``marks[n]`` = (last good position, the one before it, lost,
    corrections spent, iterations), −1 for none."""

    inputs: np.ndarray
    Z_in: np.ndarray
    settings: tuple
    max_steps: int
    marks: np.ndarray


#: Newton iterations of one correction in a continuation step (a converging correction
#: from the predictor takes 5 to 7; a step that needs more is halved instead)
CORRECTOR_ITERATIONS = 10
#: Newton corrections a :func:`track` may spend per position on average, and in addition
STEPS_PER_POSITION = 16
STEPS_BASE = 64
#: longest track kept as a memo for the next one (its inputs and poses, twice)
MEMO_POSITIONS = 20_000


def track(sys: ConstraintSystem, Z: np.ndarray, inputs: np.ndarray, unknown, *,
          start: np.ndarray | None = None, singular_tol: float = 1e-9,
          max_halvings: int = 12, tol: float = 1e-13, stop_at_loss: bool = False,
          max_steps: int | None = None, resume: TrackResult | None = None) -> TrackResult:
    """Follow the unknown links along a sequence of positions by continuation.

    Position 0 starts from ``start`` (default: the guess already in ``Z[0]``, e.g.
    the reference configuration).  Each next position is predicted by the secant
    through the two previous ones and corrected by Newton; when Newton fails, or
    the correction is larger than the last step (a possible branch jump), the step
    is halved, the known poses and inputs being interpolated linearly between the
    two positions (a homotopy that ends at the exact knowns).

    The work is bounded by a count: at most ``max_steps`` Newton corrections in all
    (default :data:`STEPS_PER_POSITION` per position plus :data:`STEPS_BASE`), each of
    at most :data:`CORRECTOR_ITERATIONS` iterations; the positions left when they are
    spent fail with a message that says so.  ``stop_at_loss``: the positions are one
    path, and those after the first one the continuation cannot reach are not tried
    (status ``MODE_LOST``; a walk along a path needs no more).  ``resume``: an earlier
    result; the first positions it shares with this track (the same inputs, poses and
    settings, its corrections within both budgets) are taken from it as they are (a
    track depends on its earlier positions only, so the result is the same).

    Returns
    -------
    TrackResult
        ``reason[n]`` is ``""`` when ok, else why position n failed.
    """
    Z = np.array(Z, float, copy=True)
    u = np.asarray(unknown, int)
    N = Z.shape[0]
    res = _Track(N, STEPS_PER_POSITION * N + STEPS_BASE if max_steps is None else int(max_steps))
    if start is not None:
        Z[0, u] = start
    Z_in, settings = Z.copy(), (float(singular_tol), int(max_halvings), float(tol), bool(stop_at_loss))
    known = np.setdiff1d(sys.involved, u)
    k0 = res.resume(resume, Z, inputs, settings)
    for n in range(k0, N):
        res.step(n, sys, Z, inputs, u, known, singular_tol, max_halvings, tol, stop_at_loss)
    memo = _Memo(inputs.copy(), Z_in, settings, res.max_steps, res.marks) if N <= MEMO_POSITIONS else None
    return TrackResult(Z, res.ok, res.reason, res.rel, res.iters, res.code, memo)


def _same(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per row: every entry equal, or NaN in both."""
    eq = (a == b) | (np.isnan(a) & np.isnan(b))
    return np.all(eq.reshape(eq.shape[0], -1), axis=1)


class _Track:
    """The per-position results of a :func:`track`, its state (the last two good
    positions, whether the assembly was lost) and its count of corrections."""

    def __init__(self, N: int, max_steps: int):
        self.ok = np.zeros(N, bool)
        self.reason = np.full(N, "", dtype=object)
        self.code = np.zeros(N, np.int8)
        self.rel = np.full(N, np.nan)
        self.marks = np.full((N, 5), -1, np.int64)
        self.iters = 0
        self.steps, self.max_steps, self.lost = 0, max_steps, False
        self.p1 = self.p2 = -1           # the last two good positions (−1: none)

    def resume(self, old: TrackResult | None, Z, inputs, settings) -> int:
        """Take the first positions ``old`` shares with this track; how many."""
        memo = None if old is None else old.memo
        if memo is None or memo.settings != settings:
            return 0
        L = min(len(inputs), len(memo.inputs))
        same = _same(inputs[:L], memo.inputs[:L]) & _same(Z[:L], memo.Z_in[:L])
        k = L if same.all() else int(np.argmin(same))
        k = int(np.searchsorted(memo.marks[:k, 3], min(memo.max_steps, self.max_steps)))   # within both budgets
        if k == 0:
            return 0
        Z[:k] = old.Z[:k]
        self.ok[:k], self.reason[:k], self.code[:k], self.rel[:k] = old.ok[:k], old.reason[:k], old.code[:k], old.rel_det[:k]
        self.marks[:k] = memo.marks[:k]
        self.p1, self.p2, lost, self.steps, self.iters = (int(v) for v in memo.marks[k - 1])
        self.lost = bool(lost)
        return k

    def step(self, n, sys, Z, inputs, u, known, singular_tol, max_halvings, tol, stop_at_loss) -> None:
        """Position ``n``: given up, failed upstream, first, or continued from the last good one."""
        if self.spent() or (stop_at_loss and self.lost):
            self.give_up(n, Z, u, stop_at_loss and self.lost)
        elif not np.all(np.isfinite(Z[n, known])):
            self.fail(n, Status.UPSTREAM, "upstream")
            Z[n, u] = np.nan
            self.p2 = -1
        else:
            zz = self.reach(n, sys, Z, inputs, u, known, max_halvings, tol)
            if zz is None:
                Z[n, u] = np.nan
                self.p2 = -1       # keep the last good position: the next one continues from it
                self.lost = True
            else:
                Z[n] = zz
                self.accept(n, sys, Z, u, singular_tol)
                self.p1, self.p2 = n, self.p1
        self.marks[n] = (self.p1, self.p2, self.lost, self.steps, self.iters)

    def reach(self, n, sys, Z, inputs, u, known, max_halvings, tol):
        """The poses at position ``n`` (None when it cannot be reached)."""
        if self.p1 < 0:
            return _first(sys, Z, n, inputs, u, tol, self)
        prev = (Z[self.p1].copy(), inputs[self.p1].copy())
        prev2 = None if self.p2 < 0 else (Z[self.p2].copy(), inputs[self.p2].copy())
        zz = _advance(sys, prev, prev2, Z[n], inputs[n], u, max_halvings, tol, known=known, budget=self)
        if zz is None:
            self.fail(n, Status.OUT_OF_REACH, "no assembly (continuation failed: out of reach, or a turning point)")
        return zz

    def spent(self) -> bool:
        return self.steps >= self.max_steps

    def count(self, iterations: int) -> None:
        self.steps += 1
        self.iters += iterations

    def fail(self, n: int, code: Status, text: str) -> None:
        self.code[n] = code
        self.reason[n] = text

    def give_up(self, n: int, Z: np.ndarray, u: np.ndarray, lost: bool) -> None:
        Z[n, u] = np.nan
        if lost:
            self.fail(n, Status.MODE_LOST, "not tried: the continuation lost the assembly earlier in the path")
        else:
            self.fail(n, Status.NOT_CONVERGED, f"no assembly (the continuation stopped: its {self.max_steps} "
                                                f"Newton corrections for {len(self.ok)} positions are spent)")

    def accept(self, n: int, sys, Z: np.ndarray, u: np.ndarray, singular_tol: float) -> None:
        """Position ``n`` assembled: ok unless its relative determinant is below ``singular_tol``."""
        J = sys.jacobian(Z[n:n + 1])[:, :, _cols(u)]
        self.rel[n] = relative_det(J)[0]
        self.ok[n] = self.rel[n] >= singular_tol
        if not self.ok[n]:
            self.fail(n, Status.SINGULAR, f"singular position (relative det {self.rel[n]:.1e})")


def _first(sys, Z, n, inputs, u, tol, res: _Track):
    """The first position of a track (or the first after a failure upstream of all
    positions so far): Newton from the guess in ``Z[n]`` or the previous position."""
    guess = Z[n:n + 1].copy()
    if n > 0 and np.all(np.isfinite(Z[n - 1, u])):
        guess[0, u] = Z[n - 1, u]
    Zs, conv, it = newton(sys, guess, inputs[n:n + 1], u, tol=tol)
    res.count(it)
    if conv[0]:
        return Zs[0]
    res.fail(n, Status.NOT_CONVERGED, "no assembly (Newton did not converge)")
    return None


def _euler_tangent(sys, Za, xa, Zn, xn, u, known):
    """First-order (implicit-function) predictor of the unknowns for the whole step:
    ``J_u dU = −(J_k dK + G dx)`` at the last good position ``Za``; None if singular."""
    cols = _cols(u)
    J = sys.jacobian(Za[None])[0]
    Ju = J[:, cols]
    dK = Zn[known] - Za[known]
    dK[:, 2] = (dK[:, 2] + np.pi) % (2 * np.pi) - np.pi
    rhs = J[:, _cols(known)] @ dK.ravel() if known.size else np.zeros(J.shape[0])
    rhs = rhs + sys.input_column(xa.shape[0]) @ (xn - xa)
    try:
        dU = np.linalg.solve(Ju, -rhs)
    except np.linalg.LinAlgError:
        return None
    return dU.reshape(len(u), 3)


def _advance(sys, prev, prev2, Zn, xn, u, max_halvings, tol=1e-13, *, known=None, budget=None):
    """One continuation step from ``prev`` to the target knowns ``Zn``/inputs ``xn``;
    None when it fails (``max_halvings`` halvings, or the corrections of ``budget``, a
    :class:`_Track`, spent).

    Predictor: the Euler tangent of the implicit function (``_euler_tangent``), which
    follows any direction of the step in the group's parameters (several drivers
    changing out of phase, known links moving); without ``known``, the secant through
    the two previous positions scaled by the ratio of the input steps."""
    Za, xa = prev
    Zn = Zn.copy()             # known angles: go the short way round (closed forms wrap θ)
    Zn[:, 2] = Za[:, 2] + (Zn[:, 2] - Za[:, 2] + np.pi) % (2 * np.pi) - np.pi
    tangent = _euler_tangent(sys, Za, xa, Zn, xn, u, known) if known is not None else None
    if tangent is None or not np.all(np.isfinite(tangent)):
        tangent = np.zeros_like(Za[u])
    if prev2 is not None and known is None:
        Zb, xb = prev2
        d_prev, d_next = xa - xb, xn - xa
        db2 = float(np.dot(d_prev, d_prev))
        if db2 > 0:          # secant scaled by the signed ratio of the input steps
            dU = Za[u] - Zb[u]
            dU[:, 2] = (dU[:, 2] + np.pi) % (2 * np.pi) - np.pi   # angles: the short way
            tangent = dU * (float(np.dot(d_next, d_prev)) / db2)
    scale = max(1.0, float(np.max(np.abs(Za[:, :2]))))
    t, h, cur = 0.0, 1.0, Za[u].copy()
    halvings = 0
    while t < 1.0:
        if budget is not None and budget.spent():
            return None
        t1 = min(1.0, t + h)
        Zt = Za + (Zn - Za) * t1
        xt = xa + (xn - xa) * t1
        guess = Zt.copy()
        pred = tangent * (t1 - t)
        guess[u] = cur + pred
        Zs, conv, it = newton(sys, guess[None], xt[None], u, tol=tol, maxiter=CORRECTOR_ITERATIONS)
        if budget is not None:
            budget.count(it)
        good = bool(conv[0])
        if good and prev2 is not None:
            corr = np.max(np.abs(Zs[0, u] - guess[u]))
            # jump guard: the corrector must stay small next to the predicted step
            # (plus 2 % of the size per unit step, for dwells where the step is ~0)
            if corr > 0.5 * np.max(np.abs(pred)) + (0.02 * (t1 - t) + 1e-9) * scale:
                good = False
        if good:
            tangent = (Zs[0, u] - cur) / (t1 - t)
            cur = Zs[0, u]
            t = t1
            h = min(1.0, 2.0 * h)
            prev2 = True
        else:
            halvings += 1
            if halvings > max_halvings:
                return None
            h *= 0.5
    out = Zn.copy()
    out[u] = cur
    return out


def rates(sys: ConstraintSystem, Z: np.ndarray, Zd: np.ndarray, input_rates: np.ndarray,
          unknown, Zdd: np.ndarray | None = None, input_acc: np.ndarray | None = None):
    """Velocities (and accelerations) of the unknown links from the linear systems.

    Parameters
    ----------
    Z : (N, n_links, 3) solved poses; Zd (and Zdd) hold the known links' rates.
    input_rates : (N, n_drivers); input_acc : (N, n_drivers) or None (zero).

    Returns
    -------
    Zd, Zdd (Zdd None when ``Zdd`` was None), rel_det (N,)
    """
    u = np.asarray(unknown, int)
    cols = _cols(u)
    N = Z.shape[0]
    J = sys.jacobian(Z)
    G = sys.input_column(input_rates.shape[1])
    known = np.setdiff1d(sys.involved, u)
    kcols = _cols(known) if known.size else np.zeros(0, int)
    Ju = J[:, :, cols]
    Jk = J[:, :, kcols]
    Zd = np.array(Zd, float, copy=True)
    Zd[:, u] = 0.0
    b = -np.einsum("nij,nj->ni", Jk, Zd.reshape(N, -1)[:, kcols]) - input_rates @ G.T
    with np.errstate(all="ignore"):
        v = np.linalg.solve(Ju, b[..., None])[..., 0]
    Zd[:, u] = v.reshape(N, len(u), 3)
    if Zdd is None:
        return Zd, None
    Zdd = np.array(Zdd, float, copy=True)
    Zdd[:, u] = 0.0
    acc = input_acc if input_acc is not None else np.zeros_like(input_rates)
    b = (-np.einsum("nij,nj->ni", Jk, Zdd.reshape(N, -1)[:, kcols]) - acc @ G.T - sys.gamma(Z, Zd))
    with np.errstate(all="ignore"):
        a = np.linalg.solve(Ju, b[..., None])[..., 0]
    Zdd[:, u] = a.reshape(N, len(u), 3)
    return Zd, Zdd


def jacobian_rates(step: GroupStep, R, input_rates: np.ndarray) -> None:
    """Rates of a step's links from its group's Jacobian (one linear system per
    position; any group), written into ``R`` (:class:`~kin.poses.PoseRates`)."""
    Rb = np.broadcast_to(input_rates, (R.Z.shape[0], len(input_rates)))
    R.Zd, R.Zdd = rates(step.st.system, R.Z, R.Zd, Rb, step.st.unknown, R.Zdd, None)


class NewtonStep(GroupStep):
    """Any step solved by Newton with continuation (:func:`track`) from the reference
    configuration; rates from the group's Jacobian.  A probe (a walk along one path)
    stops at the first position the continuation cannot reach: the walk looks no
    further, and every position past a limit would cost a continuation that fails."""

    batched = False          # solved design by design (kin.design falls back)
    solver = "newton"
    #: the last track (a memo: the next one along the same first positions resumes from
    #: it, with the same result; the walks and the check re-solve one path many times)
    _last: TrackResult | None = None

    def positions(self, G, X, factor=1.0, probe=False) -> Outcome:
        st = self.st
        u = list(st.unknown)
        Z = G.to_Z(np.setdiff1d(st.system.involved, u))
        Z[:, u, :2] = G.sp.origins[u]
        Z[:, u, 2] = 0.0
        tr = self._last = track(st.system, Z, X, u, singular_tol=SINGULAR, stop_at_loss=probe, resume=self._last)
        G.from_Z(tr.Z, u)
        why = {int(n): (int(tr.code[n]), tr.reason[n]) for n in np.flatnonzero(~tr.ok)}
        return Outcome(tr.ok, why, Probe(tr.ok.copy(), refined=True) if probe else None)

    rates = jacobian_rates
