"""Class III triad: a ternary link P1P2P3 held by three binary links A_i–P_i on
known pins A_i.  All real assembly modes, mode tracking, and rates.

Position problem (docs/groups.md): unknown pose of the ternary,
``p = P1``, rotation ``θ``, with ``P_i = p + R(θ)(b_i - b_1)``:

    |p + R(θ)(b_i - b_1) - A_i|² = l_i²,   i = 1, 2, 3.

Subtracting the first equation from the other two gives two equations linear in
``p``; Cramer's rule and substitution into the first give a Laurent polynomial
``F(z)`` in ``z = e^{iθ}`` of degree -3..3, so ``z³F(z)`` has degree 6 (at most 6
real modes, Hunt 1983).  Its coefficients are read exactly by a 16-point DFT of
``F`` on the unit circle.  ``F`` is real on the circle, so ``θ = σ + 2 atan t``
turns it into a real degree-6 polynomial in ``t``, whose real roots (eigenvalues
of its companion matrix, batched over positions) are the real modes; each is
polished by Newton on the three original equations and accepted if its
residual is ≤ 1e-9 (relative).  Along a motion, :func:`triad_track` follows one
mode by guarded continuity.

Vasechkin et al. 2017 [1]_ treats dyads only; this group extends its Cramer-rule approach
(velocities and accelerations by one linear system with the same matrix).

References
----------
.. [1] Vasechkin M.A., Matveeva E.V., Sidorenko A.S., Chertov E.D. Mathematical
   model of kinematic calculation of flat lever mechanisms. Vestnik VGUIT 79(2)
   (2017) 73-79. doi:10.20914/2310-1202-2017-2-73-79.
.. [2] Hunt K.H. Structural kinematics of in-parallel-actuated robot arms.
   ASME J. Mech. Transm. Autom. Des. 105(4) (1983) 705-712.
"""
from __future__ import annotations

import functools

from typing import NamedTuple

import numpy as np

from multiloop.topo.assur import GroupKind

from .base import SINGULAR_RTOL, num, put_off, put_rel, quiet
from ..continuation import Probe
from ..kernel_mode import chooses
from ..poses import known_on
from ..result import Status
from .newton import jacobian_rates
from .step import AngleDef, Deferred, GroupStep, Lowered, Outcome
from .triad_tables import ACCEPT, BASIS, DFT, GRID, NEWTON_ITERS, ON_CIRCLE, STRIDE, Z16

__all__ = ["TriadModes", "TriadTrack", "TriadRates", "triad_modes", "triad_track",
           "triad_rates", "follow_modes", "follow_modes_batch", "track_designs", "MAX_MODES", "TriadStep"]

#: maximum number of real assembly modes of a triad / class IV group.
MAX_MODES = 6


class TriadModes(NamedTuple):
    """All real modes: ``P`` (N, 6, 3, 2), ``theta`` (N, 6), ``n_modes`` (N,),
    ``residual`` (N, 6), ``det`` (N, 6); NaN-padded beyond ``n_modes``."""

    P: np.ndarray
    theta: np.ndarray
    n_modes: np.ndarray
    residual: np.ndarray
    det: np.ndarray


class TriadTrack(NamedTuple):
    """One mode followed along the batch: ``P`` (N, 3, 2), ``theta`` (N,), ``ok``,
    ``det`` (N,), ``status`` (N,) int (0 ok, 1 no assembly, 2 mode lost or
    ambiguous here, 3 after a loss)."""

    P: np.ndarray
    theta: np.ndarray
    ok: np.ndarray
    det: np.ndarray
    status: np.ndarray


class TriadRates(NamedTuple):
    """Rates of a triad (acceleration fields ``None`` unless asked)."""

    vP: np.ndarray
    omega: np.ndarray
    aP: np.ndarray | None
    eps: np.ndarray | None
    w_bin: np.ndarray
    e_bin: np.ndarray | None
    det: np.ndarray
    singular: np.ndarray


# --------------------------------------------------------------------------- helpers
def _rot(c, s, v):
    """Rotate ``v`` (..., 2) by the angle with cosine ``c`` and sine ``s`` (...)."""
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


def _solve3c(m, r):
    """Solve stacked 3×3 systems by the adjugate, component-wise (no exception and
    no warning when singular).  ``m``: 3×3 nested lists of arrays, ``r``: 3 arrays;
    returns the 3 solution arrays, ``det`` and ``singular`` (``|det| <=
    SINGULAR_RTOL · product of the row norms``)."""
    (a, b, c), (d, e, f), (g, h, i) = m
    A_ = e * i - f * h
    B_ = f * g - d * i
    C_ = d * h - e * g
    det = a * A_ + b * B_ + c * C_
    r0, r1, r2 = r
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        x0 = (r0 * A_ + r1 * (c * h - b * i) + r2 * (b * f - c * e)) * inv
        x1 = (r0 * B_ + r1 * (a * i - c * g) + r2 * (c * d - a * f)) * inv
        x2 = (r0 * C_ + r1 * (b * g - a * h) + r2 * (a * e - b * d)) * inv
    scale = np.sqrt((a * a + b * b + c * c) * (d * d + e * e + f * f)
                    * (g * g + h * h + i * i))
    return [x0, x1, x2], det, ~(np.abs(det) > SINGULAR_RTOL * scale)


def _as_batch(A, last):
    A = np.asarray(A, dtype=float)
    if A.shape[-len(last):] != last:
        raise ValueError(f"expected shape (N, {', '.join(map(str, last))}) or "
                         f"{last}, got {A.shape}")
    single = A.ndim == len(last)
    return (A[None] if single else A), single


def _det(A, P):
    """Determinant of the triad's rate matrix, (..., 3, 2) -> (...)."""
    m = [[P[..., i, 0] - A[..., i, 0], P[..., i, 1] - A[..., i, 1],
          (P[..., i, 1] - A[..., i, 1]) * (P[..., i, 0] - P[..., 0, 0])
          - (P[..., i, 0] - A[..., i, 0]) * (P[..., i, 1] - P[..., 0, 1])] for i in range(3)]
    return _solve3c(m, [0.0, 0.0, 0.0])[1]


def _polish(A, bb, l, p, th, iters=NEWTON_ITERS, tol=1e-12):
    """Newton on the three closure equations, vectorised over any batch shape.

    ``A`` (..., 3, 2), ``bb`` (3, 2) or broadcastable (..., 3, 2) = b - b_1, ``l``
    (..., 3); ``p`` (..., 2), ``th`` (...).  Component arithmetic; a position stops
    once its correction is below ``tol`` (relative to max l), so that each position's
    result does not depend on the others in the batch.  Returns ``P`` (..., 3, 2),
    ``th`` and the relative ``residual`` max_i |‖P_i - A_i‖ - l_i| / max_i l_i.
    """
    shape = np.broadcast_shapes(A.shape[:-2], l.shape[:-1], p.shape[:-1], th.shape)
    Ax = [np.broadcast_to(A[..., i, 0], shape) for i in range(3)]
    Ay = [np.broadcast_to(A[..., i, 1], shape) for i in range(3)]
    L = [np.broadcast_to(l[..., i], shape) for i in range(3)]
    lmax = np.maximum(np.maximum(L[0], L[1]), L[2])
    px = np.broadcast_to(p[..., 0], shape).copy()
    py = np.broadcast_to(p[..., 1], shape).copy()
    th = np.broadcast_to(th, shape).copy()

    def geom(px, py, th):
        c, s = np.cos(th), np.sin(th)
        rbx = [c * bb[..., i, 0] - s * bb[..., i, 1] for i in range(3)]
        rby = [s * bb[..., i, 0] + c * bb[..., i, 1] for i in range(3)]
        dx = [px + rbx[i] - Ax[i] for i in range(3)]
        dy = [py + rby[i] - Ay[i] for i in range(3)]
        return rbx, rby, dx, dy

    active = np.ones(shape, bool)
    for _ in range(iters):
        rbx, rby, dx, dy = geom(px, py, th)
        m = [[dx[i], dy[i], dy[i] * rbx[i] - dx[i] * rby[i]] for i in range(3)]
        f = [-0.5 * (dx[i] * dx[i] + dy[i] * dy[i] - L[i] * L[i]) for i in range(3)]
        (ux, uy, ut), _, _ = _solve3c(m, f)
        ok = active & np.isfinite(ux) & np.isfinite(uy) & np.isfinite(ut)
        px += np.where(ok, ux, 0.0)
        py += np.where(ok, uy, 0.0)
        th += np.where(ok, ut, 0.0)
        active &= ~(np.abs(ux) + np.abs(uy) + np.abs(ut) * lmax <= tol * lmax)
        if not active.any():
            break
    rbx, rby, dx, dy = geom(px, py, th)
    res = np.maximum.reduce([np.abs(np.sqrt(dx[i] * dx[i] + dy[i] * dy[i]) - L[i])
                             for i in range(3)]) / lmax
    P = np.stack([np.stack([px + rbx[i], py + rby[i]], axis=-1) for i in range(3)], axis=-2)
    return P, th, res


def _flat(a, shape):
    """``a`` broadcast to ``shape``, C-contiguous floats for the compiled tracker: a
    read-only view where ``a`` already is so (what ``np.broadcast_to`` then gives, a
    tenth of its cost; the same compiled signature), else a copy."""
    if isinstance(a, np.ndarray) and a.shape == shape and a.dtype == np.float64 and a.flags.c_contiguous:
        view = a.view()
        view.flags.writeable = False
        return view
    return np.ascontiguousarray(np.broadcast_to(a, shape), float)


def _predict_modes(nb, A0, P0, A1, l0, l1):
    """:func:`_predict`'s points for every mode ``P0`` (D, n, modes, 3, 2) at inputs ``A0``
    (D, n, 3, 2), lengths ``l0`` (D, n, 3), predicted at ``A1``, ``l1``, by
    :func:`kin.groups._triad_nb.predict_modes`: ``(D·n, modes, 3, 2)``."""
    M = A0.shape[0] * A0.shape[1]
    P0 = _flat(P0, P0.shape).reshape(M, *P0.shape[2:])
    P, dth, sing = np.empty(P0.shape), np.empty(P0.shape[:2]), np.empty(P0.shape[:2], bool)
    nb.predict_modes(_flat(A0, A0.shape).reshape(M, 3, 2), P0, _flat(A1, A1.shape).reshape(M, 3, 2),
                     _flat(l0, l0.shape).reshape(M, 3), _flat(l1, l1.shape).reshape(M, 3), SINGULAR_RTOL, P, dth, sing)
    return P


def _modes_nb(nb, A, bb, l):
    """The points and angles of :func:`triad_modes` at K positions (``bb = b - b_1`` per
    position) by :func:`kin.groups._triad_nb.modes_many`."""
    K = A.shape[0]
    P, th = np.empty((K, MAX_MODES, 3, 2)), np.empty((K, MAX_MODES))
    nb.modes_many(_flat(A, (K, 3, 2)), _flat(bb, (K, 3, 2)), _flat(l, (K, 3)), Z16, DFT, GRID, BASIS,
                  NEWTON_ITERS, 1e-12, ACCEPT, SINGULAR_RTOL, P, th)
    return P, th


def _wrap(a):
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def _linear_terms(z, bc, a, l):
    """``w_i = z b_i - a_i`` and ``k_i`` of the two linear equations (i = 2, 3)."""
    w = z[..., None] * bc - a
    k = (l[..., 1:] ** 2 - l[..., :1] ** 2 - np.abs(bc) ** 2 - np.abs(a) ** 2
         + 2.0 * (z[..., None] * bc * np.conj(a)).real)
    return w, k


def _poly_coefficients(A, bb, l):
    """Coefficients (N, 7), highest first, of ``z³F(z)`` (degree 6), with
    ``F = N_x² + N_y² - l_1² D²`` (docs/groups.md), read exactly
    by a 16-point DFT on the unit circle; also ``b_i``, ``a_i`` as complex."""
    bc = bb[..., 1:, 0] + 1j * bb[..., 1:, 1]                           # (2,) or (N, 2)
    a = (A[:, 1:, 0] - A[:, :1, 0]) + 1j * (A[:, 1:, 1] - A[:, :1, 1])   # (N, 2)
    z = np.exp(2j * np.pi * np.arange(16) / 16)                          # (16,)
    w, k = _linear_terms(z[None, :], bc[..., None, :] if bc.ndim == 2 else bc,
                         a[:, None, :], l[:, None, :])                    # (N, 16, 2)
    wr, wi = w.real, w.imag
    D = wr[..., 0] * wi[..., 1] - wi[..., 0] * wr[..., 1]
    Nx = 0.5 * (k[..., 0] * wi[..., 1] - k[..., 1] * wi[..., 0])
    Ny = 0.5 * (wr[..., 0] * k[..., 1] - wr[..., 1] * k[..., 0])
    F = Nx * Nx + Ny * Ny - l[:, None, 0] ** 2 * D * D
    c = np.fft.fft(F, axis=-1) / 16.0                    # c[j] = coefficient of z^j
    return np.stack([c[:, j % 16] for j in range(3, -4, -1)], axis=-1), bc, a


def _position_from_angle(A, bc, a, l, th):
    """P1 from the two linear equations at rotation ``th`` (Cramer); A1 where
    the 2×2 system is singular."""
    w, k = _linear_terms(np.exp(1j * th), bc, a, l)
    wr, wi = w.real, w.imag
    D = wr[..., 0] * wi[..., 1] - wi[..., 0] * wr[..., 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        x = 0.5 * (k[..., 0] * wi[..., 1] - k[..., 1] * wi[..., 0]) / D
        y = 0.5 * (wr[..., 0] * k[..., 1] - wr[..., 1] * k[..., 0]) / D
    p = np.stack([x, y], axis=-1) + A[..., 0, :]
    return np.where(np.isfinite(p), p, A[..., 0, :])


def _unit_circle_roots(coef):
    """Angles of the roots of ``z³F(z)`` on the unit circle (the real modes).

    ``F`` is real on the circle, so with ``θ = σ + ψ`` and ``t = tan(ψ/2)`` the
    equation becomes a *real* degree-6 polynomial in ``t`` (real companion
    eigenproblem, cheaper than the complex one).  ``σ`` is chosen per position so
    that ``ψ = π`` (``t = ∞``) falls on the largest of the 16 samples of ``F``: the
    leading coefficient is then that sample and no root escapes to infinity.
    Returns candidate angles (N, 6), the candidate mask (roots within ~1e-3 of
    the circle) and the per-position ``good`` mask.
    """
    N = coef.shape[0]
    samples = (coef @ GRID).real                        # F at 2πk/16
    kmax = np.argmax(np.abs(samples), axis=-1)
    sigma = 2 * np.pi * kmax / 16 - np.pi
    shifted = coef * np.exp(1j * np.outer(sigma, np.arange(3, -4, -1)))
    q = (shifted @ BASIS).real                          # ascending in t, (N, 7)
    lead = q[:, 6]
    good = np.isfinite(q).all(axis=-1) & (np.abs(lead) > 0)
    comp = np.zeros((N, 6, 6))
    with np.errstate(divide="ignore", invalid="ignore"):
        comp[:, 0, :] = -q[:, 5::-1] / lead[:, None]
    comp[:, np.arange(1, 6), np.arange(5)] = 1.0
    good &= np.isfinite(comp).all(axis=(1, 2))
    comp[~good] = np.eye(6) * 10.0
    t = np.linalg.eigvals(comp)                          # (N, 6) complex
    cand = np.abs(t.imag) < 0.5 * ON_CIRCLE * (1.0 + np.abs(t) ** 2)
    th0 = sigma[:, None] + 2.0 * np.arctan(t.real)
    return th0, cand & good[:, None], good


# --------------------------------------------------------------------------- modes
@quiet
def triad_modes(A, b, l) -> TriadModes:
    """All real assembly modes of a class III triad, vectorised over positions.

    Parameters
    ----------
    A : array_like, shape (N, 3, 2) or (3, 2)
        Outer pins A1, A2, A3 (on known links).
    b : array_like, shape (3, 2) or (N, 3, 2)
        P1, P2, P3 in the reference configuration (or any rigid copy), per position
        when given with the batch axis.
    l : array_like, shape (3,) or (N, 3)
        Lengths |A_i P_i|.

    Returns
    -------
    TriadModes
        ``P`` (N, 6, 3, 2), ``theta`` (N, 6) (rotation from ``b``, in (-π, π]),
        ``n_modes`` (N,), ``residual`` (N, 6) (max |‖P_i - A_i‖ - l_i| / max l),
        ``det`` (N, 6) of the rate system (its sign does not label a mode).
        Modes are sorted by ``theta``; padding is NaN.  Without a batch axis the
        leading N is dropped.

    Notes
    -----
    Degree-6 polynomial (docs/groups.md) made real by the
    tangent half-angle substitution, batched real companion eigenvalues (O(N)
    LAPACK calls of size 6), Newton polish of the near-real roots only,
    duplicates merged.
    Degenerate cases (the linear 2×2 system singular at a mode, i.e. the
    ternary's two difference vectors parallel there) may lose that mode.

    Examples
    --------
    >>> A = [[0.250191, 0.794428], [0.551371, -0.549586], [-0.399667, 0.747107]]
    >>> b = [[0, 0], [-0.989469, 0.642457], [0.594139, -0.06413]]
    >>> int(triad_modes(A, b, [0.593942, 0.561953, 0.53133]).n_modes)
    6
    """
    A, single = _as_batch(A, (3, 2))
    b = np.asarray(b, dtype=float)
    l = np.broadcast_to(np.asarray(l, dtype=float), A.shape[:-1])
    N = A.shape[0]
    bb = b - b[..., :1, :]
    coef, bc, a = _poly_coefficients(A, bb, l)
    th0, cand, good = _unit_circle_roots(coef)
    ri, ki = np.nonzero(cand)                            # polish the candidates only
    per = bb.ndim == 3                                   # a reference per position
    p0 = _position_from_angle(A[ri], bc[ri] if per else bc, a[ri], l[ri], th0[ri, ki])
    Pk, thk, resk = _polish(A[ri], bb[ri] if per else bb, l[ri], p0, th0[ri, ki])
    P = np.full((N, MAX_MODES, 3, 2), np.nan)
    th = np.full((N, MAX_MODES), np.nan)
    res = np.full((N, MAX_MODES), np.inf)
    P[ri, ki], th[ri, ki], res[ri, ki] = Pk, _wrap(thk), resk
    valid = cand & good[:, None] & (res <= ACCEPT)
    # merge duplicates (same pose reached from two roots)
    scale = np.max(l, axis=-1)[:, None, None]
    p1 = P[:, :, 0, :]
    dP = (np.abs(p1[:, :, None, 0] - p1[:, None, :, 0]) + np.abs(p1[:, :, None, 1] - p1[:, None, :, 1])
          + np.abs(_wrap(th[:, :, None] - th[:, None, :])) * scale)
    same = (dP <= 1e-7 * scale) & valid[:, :, None] & valid[:, None, :]
    earlier = np.tril(np.ones((6, 6), dtype=bool), -1)   # [j, i]: i < j
    dup = np.any(same & earlier[None], axis=-1)
    valid &= ~dup
    key = np.where(valid, th, np.inf)
    order = np.argsort(key, axis=-1)
    valid = np.take_along_axis(valid, order, axis=-1)
    th = np.where(valid, np.take_along_axis(th, order, axis=-1), np.nan)
    res = np.where(valid, np.take_along_axis(res, order, axis=-1), np.nan)
    P = np.where(valid[..., None, None],
                 np.take_along_axis(P, order[..., None, None], axis=1), np.nan)
    det = _det(A[:, None], P)
    out = TriadModes(P, th, valid.sum(axis=-1), res, det)
    return TriadModes(*(v[0] for v in out)) if single else out


# --------------------------------------------------------------------------- rates
@quiet
def triad_rates(A, P, vA, aA=None, *, vl=None) -> TriadRates:
    """Velocities (and accelerations) of a triad from its 3×3 linear system.

    Parameters
    ----------
    A, P : array_like, shape (N, 3, 2) or (3, 2)
        Outer pins and the ternary's joints P1..P3 (a solved mode).
    vA : array_like, same shape
        Velocities of the outer pins.
    aA : array_like, optional
        Their accelerations.
    vl : array_like, shape (N, 3), optional
        Rates of change of the binary lengths (zero for a real triad; used by the
        class IV reduction, whose third "binary" is the distance O1–O2).  Their
        second derivatives are taken as zero.

    Returns
    -------
    TriadRates
        ``vP`` (N, 3, 2), ``omega`` (N,) of the ternary, ``aP``, ``eps``; angular
        velocities ``w_bin`` / accelerations ``e_bin`` (N, 3) of the binaries A_i→P_i;
        ``det`` and ``singular`` (the three binary lines concurrent or parallel).

    Notes
    -----
    Rows ``(d_i, d_i · perp(P_i - P_1))`` with ``d_i = P_i - A_i``; unknowns
    ``(ṗ, θ̇)``; right-hand sides ``d_i·Ȧ_i`` and
    ``d_i·(Ä_i + θ̇²(P_i - P_1)) - |ḋ_i|²`` (differentiated ``d_i·ḋ_i = 0``).
    """
    A, single = _as_batch(A, (3, 2))
    P = np.asarray(P, dtype=float).reshape(A.shape)
    vA = np.asarray(vA, dtype=float).reshape(A.shape)
    R = range(3)
    dx = [P[..., i, 0] - A[..., i, 0] for i in R]
    dy = [P[..., i, 1] - A[..., i, 1] for i in R]
    rx = [P[..., i, 0] - P[..., 0, 0] for i in R]
    ry = [P[..., i, 1] - P[..., 0, 1] for i in R]
    m = [[dx[i], dy[i], dy[i] * rx[i] - dx[i] * ry[i]] for i in R]
    d2 = [dx[i] * dx[i] + dy[i] * dy[i] for i in R]
    rv = [dx[i] * vA[..., i, 0] + dy[i] * vA[..., i, 1] for i in R]
    if vl is not None:
        vl = np.asarray(vl, dtype=float)
        rv = [rv[i] + np.sqrt(d2[i]) * vl[..., i] for i in R]
    (qx, qy, om), det, sing = _solve3c(m, rv)
    vx = [qx - om * ry[i] for i in R]
    vy = [qy + om * rx[i] for i in R]
    ex = [vx[i] - vA[..., i, 0] for i in R]
    ey = [vy[i] - vA[..., i, 1] for i in R]
    w_bin = np.stack([(dx[i] * ey[i] - dy[i] * ex[i]) / d2[i] for i in R], axis=-1)
    vP = np.stack([np.stack([vx[i], vy[i]], axis=-1) for i in R], axis=-2)
    aP = eps = e_bin = None
    if aA is not None:
        aA = np.asarray(aA, dtype=float).reshape(A.shape)
        o2 = om * om
        ra = [dx[i] * (aA[..., i, 0] + o2 * rx[i]) + dy[i] * (aA[..., i, 1] + o2 * ry[i])
              - ex[i] * ex[i] - ey[i] * ey[i] for i in R]
        if vl is not None:
            ra = [ra[i] + vl[..., i] * vl[..., i] for i in R]
        (ax_, ay_, eps), _, _ = _solve3c(m, ra)
        gx = [ax_ - eps * ry[i] - o2 * rx[i] for i in R]
        gy = [ay_ + eps * rx[i] - o2 * ry[i] for i in R]
        aP = np.stack([np.stack([gx[i], gy[i]], axis=-1) for i in R], axis=-2)
        e_bin = np.stack([(dx[i] * (gy[i] - aA[..., i, 1]) - dy[i] * (gx[i] - aA[..., i, 0]))
                          / d2[i] for i in R], axis=-1)
    out = TriadRates(vP, om, aP, eps, w_bin, e_bin, det, sing)
    if single:
        out = TriadRates(*(None if v is None else v[0] for v in out))
    return out


# --------------------------------------------------------------------------- tracking
def _dist(X, Y):
    """Euclidean distance over all joint coordinates: (..., k, 2) -> (...)."""
    return np.sqrt(np.sum(np.square(X - Y), axis=(-2, -1)))


def follow_modes(P, valid, pred, start, sep_ratio=0.5):
    """Follow one mode through per-position mode lists by predicted continuity.

    Parameters
    ----------
    P : ndarray, shape (N, M, k, 2)
        Points of every mode at every position (NaN where invalid).
    valid : ndarray of bool, shape (N, M)
    pred : ndarray, shape (N-1, M, k, 2)
        Prediction at position i+1 of each mode of position i.
    start : int
        Mode index at position 0.
    sep_ratio : float
        The matched mode must be closer to the prediction than ``sep_ratio``
        times the next candidate, and both the prediction error and the raw step
        shorter than ``sep_ratio`` times the distance from the mode to the
        nearest other mode at i (else: mode collision / ambiguous step).

    Returns
    -------
    idx : ndarray of int (N,)  (-1 after a loss)
    status : ndarray of int (N,)  (0 ok, 2 lost/ambiguous here, 3 after)
    """
    idx, status = follow_modes_batch(P[None], valid[None], pred[None], np.array([start]), sep_ratio)
    return idx[0], status[0]


def follow_modes_batch(P, valid, pred, start, sep_ratio=0.5):
    """:func:`follow_modes` along D paths at once (the same arithmetic for each path):
    ``P`` (D, N, M, k, 2), ``valid`` (D, N, M), ``pred`` (D, N-1, M, k, 2), ``start``
    (D,) int; returns ``idx`` and ``status`` (D, N)."""
    Dn, N, Mm = valid.shape
    idx = np.full((Dn, N), -1)
    status = np.full((Dn, N), 3)
    status[:, 0] = 0
    idx[:, 0] = start
    if N == 1:
        return idx, status
    D = np.zeros((Dn, N - 1, Mm, Mm))
    S = np.zeros((Dn, N - 1, Mm, Mm))
    Q = np.zeros((Dn, N, Mm, Mm))
    for c in range(P.shape[3]):
        for x in range(2):
            D += np.square(pred[:, :, :, None, c, x] - P[:, 1:, None, :, c, x])
            S += np.square(P[:, :-1, :, None, c, x] - P[:, 1:, None, :, c, x])
            Q += np.square(P[:, :, :, None, c, x] - P[:, :, None, :, c, x])
    with np.errstate(invalid="ignore"):
        D = np.sqrt(np.where(valid[:, 1:, None, :], D, np.inf))
        D = np.where(np.isnan(D), np.inf, D)
        S = np.sqrt(S)
        Q = np.sqrt(np.where(valid[:, :, None, :] & valid[:, :, :, None], Q, np.inf))
    Q[:, :, np.arange(Mm), np.arange(Mm)] = np.inf
    Q = np.where(np.isnan(Q), np.inf, Q)
    sep = Q.min(axis=-1)                                        # (D, N, M)
    srt = np.sort(D, axis=-1)
    k1 = np.argmin(D, axis=-1)
    d1, d2 = srt[..., 0], srt[..., 1]
    step = np.take_along_axis(S, k1[..., None], axis=-1)[..., 0]
    ok = (np.isfinite(d1) & (d1 <= sep_ratio * d2)
          & (step <= sep_ratio * sep[:, :-1]) & (d1 <= sep_ratio * sep[:, :-1]))
    nxt = np.where(ok & valid[:, :-1], k1, -1)
    rows = np.arange(Dn)
    j = np.asarray(start).copy()
    alive = j >= 0
    for i in range(N - 1):
        j = np.where(alive, nxt[rows, i, np.maximum(j, 0)], -1)
        status[alive & (j < 0), i + 1] = 2
        alive &= j >= 0
        idx[alive, i + 1] = j[alive]
        status[alive, i + 1] = 0
    return idx, status


def _nearest(P0, valid0, start):
    d = np.where(valid0, _dist(P0, start), np.inf)
    d = np.where(np.isnan(d), np.inf, d)
    return int(np.argmin(d)) if np.isfinite(d).any() else -1


def _predict(A0, P0, A1, l0=None, l1=None):
    """Second-order Taylor prediction of the pose at (A1, l1) from (A0, P0, l0),
    along the straight segment; returns points and rotation increment."""
    vl = None if l0 is None else (l1 - l0)
    r = triad_rates(A0, P0, A1 - A0, np.zeros_like(A0), vl=vl)
    return P0 + r.vP + 0.5 * r.aP, r.omega + 0.5 * r.eps, r.singular


def _full_follow(A, bb, l, P_start, nb=None):
    """All modes at every position of a short path, then :func:`follow_modes`
    from the mode nearest ``P_start`` at A[0].  Returns the modes (``P``, ``theta``),
    idx, status.  With ``nb`` (:func:`_kernel`) the modes, the predictions and the
    following run compiled (:func:`_coarse_follow`'s route: the same statuses)."""
    if nb is not None:
        P, th, idx, status = _coarse_follow(A[None], bb[None], l[None], np.asarray(P_start)[None], nb)
        if idx[0, 0] < 0:
            return _Modes(P[0], th[0]), np.full(A.shape[0], -1), np.ones(A.shape[0], int)
        return _Modes(P[0], th[0]), idx[0], status[0]
    m = triad_modes(A, bb, l)
    valid = np.isfinite(m.theta)
    j0 = _nearest(m.P[0], valid[0], P_start)
    n = A.shape[0]
    if j0 < 0:
        return m, np.full(n, -1), np.ones(n, int)
    if n > 1:
        Pi = np.where(valid[:-1, :, None, None], m.P[:-1], A[:-1, None])
        A0 = np.repeat(A[:-1, None], MAX_MODES, axis=1)
        A1 = np.repeat(A[1:, None], MAX_MODES, axis=1)
        l0 = np.repeat(l[:-1, None], MAX_MODES, axis=1)
        l1 = np.repeat(l[1:, None], MAX_MODES, axis=1)
        pred = _predict(A0.reshape(-1, 3, 2), Pi.reshape(-1, 3, 2), A1.reshape(-1, 3, 2),
                        l0.reshape(-1, 3), l1.reshape(-1, 3))[0].reshape(n - 1, MAX_MODES, 3, 2)
    else:
        pred = np.zeros((0, MAX_MODES, 3, 2))
    idx, status = follow_modes(m.P, valid, pred, j0)
    return m, idx, status


class _Modes(NamedTuple):
    """The modes of :func:`_full_follow`'s compiled route: ``P`` (n, MAX_MODES, 3, 2) and
    ``theta`` (n, MAX_MODES), NaN where a mode does not exist."""

    P: np.ndarray
    theta: np.ndarray


def _refine(A, b, l, c, kmax, todo, Pc, P, th, status, nb=None) -> None:
    """Phase 3 of :func:`_track`: follow the refused coarse intervals ``todo`` (and the
    tail after ``c[kmax]``) at full resolution, in place; a loss inside an interval, or
    arriving in another mode than the coarse point's, loses the rest."""
    N = A.shape[0]
    for k in todo:
        lo = c[k]
        hi = N - 1 if k >= kmax else c[k + 1]
        if status[lo] != 0:
            break                                      # lost before this interval
        m, idx, st = _full_follow(A[lo:hi + 1], b, l[lo:hi + 1], P[lo], nb)
        ok = idx >= 0
        rows = np.flatnonzero(ok)
        P[lo + rows] = m.P[rows, idx[ok]]
        th[lo + rows] = m.theta[rows, idx[ok]]
        status[lo:hi + 1] = st
        consistent = ok[-1] and k < kmax and _dist(P[hi], Pc[k + 1]) <= 1e-9 * np.max(l)
        if not consistent:                             # lost inside: the rest is lost
            P[hi + 1:] = np.nan
            th[hi + 1:] = np.nan
            status[hi + 1:] = 3
            if ok[-1] and k < kmax:                    # reached another mode: refuse it
                status[hi] = 2
                P[hi] = np.nan
                th[hi] = np.nan
            break


def _first_failure_final(P, th, status) -> None:
    """After the first failed position every later one is lost (in place)."""
    lost = np.flatnonzero(status != 0)
    if lost.size:
        i = lost[0]
        if status[i] != 1:
            status[i] = 2
        status[i + 1:] = 3
        P[i:] = np.nan
        th[i:] = np.nan


def _nearest_coarse(c, fine, last):
    """For inputs ``fine`` between the coarse inputs ``c`` (none after ``c[last]``;
    ``last`` a number or one per input): the index of each one's nearest coarse input."""
    left = np.searchsorted(c, fine, side="right") - 1          # c[left] < fine < c[left+1]
    right = np.minimum(left + 1, last)
    return np.where(fine - c[left] <= c[right] - fine, left, right)


def _from_coarse(A0, P0, th0, sep0, A1, l0, l1, bb):
    """Poses at inputs ``A1`` (lengths ``l1``) from their nearest coarse input's (``A0``,
    ``P0``, ``th0``, ``l0``; ``sep0`` its distance to the nearest other mode): the Taylor
    prediction Newton-polished, and whether each is accepted — converged, not singular,
    and within a quarter of ``sep0`` of the prediction and half of it of the coarse pose
    (well inside the followed mode's basin).  ``P``, ``theta`` and the acceptance."""
    Pp, dth, sing = _predict(A0, P0, A1, l0, l1)
    Pf, thf, res = _polish(A1, bb, l1, Pp[..., 0, :], th0 + dth)
    acc = (res <= ACCEPT) & ~sing & (_dist(Pf, Pp) <= 0.25 * sep0) & (_dist(Pf, P0) <= 0.5 * sep0)
    return Pf, thf, acc


def _separation(Pm, thm, Pc, ic):
    """The followed mode's distance to the nearest other mode at each coarse input: all
    modes ``Pm`` (..., MAX_MODES, 3, 2) with angles ``thm`` (NaN: none), the followed
    pose ``Pc`` (..., 3, 2) and its index ``ic`` (...); ``inf`` where it is alone."""
    other = np.isfinite(thm) & (np.arange(MAX_MODES) != ic[..., None])
    return np.min(np.where(other, np.nan_to_num(_dist(Pm, Pc[..., None, :, :]), nan=np.inf), np.inf), axis=-1)


def _track(A, b, l, start, stride, nb=None):
    """Mode tracking with per-position lengths ``l`` (N, 3); see :func:`triad_track`.
    With ``nb`` (:func:`_kernel`) its all-modes phases run compiled."""
    N = A.shape[0]
    bb = b - b[0]
    P = np.full((N, 3, 2), np.nan)
    th = np.full(N, np.nan)
    status = np.full(N, 3)
    if stride <= 1 or N <= 2 * stride:
        m, idx, st = _full_follow(A, b, l, start, nb)
        ok = idx >= 0
        P[ok] = m.P[np.flatnonzero(ok), idx[ok]]
        th[ok] = m.theta[np.flatnonzero(ok), idx[ok]]
        return P, th, st
    c = _coarse(N, stride)
    # 1. coarse all-modes + following
    mc, ic, sc = _full_follow(A[c], b, l[c], start, nb)
    if ic[0] < 0:
        return P, th, np.ones(N, int)
    good_c = ic >= 0
    kmax = int(np.flatnonzero(good_c)[-1])           # last good coarse point
    kk = np.flatnonzero(good_c)
    Pc = mc.P[kk, ic[kk]]
    thc = mc.theta[kk, ic[kk]]
    sep = _separation(mc.P[kk], mc.theta[kk], Pc, ic[kk])
    P[c[kk]] = Pc
    th[c[kk]] = thc
    status[c[kk]] = 0
    # 2. fill in between good coarse points: Taylor from the nearest coarse point
    end = c[kmax]
    fine = np.setdiff1d(np.arange(end + 1), c[kk], assume_unique=True)
    bad_int = np.zeros(len(c), bool)                  # interval k: c[k]..c[k+1]
    if fine.size:
        kn = _nearest_coarse(c, fine, kmax)
        Pf, thf, acc = _from_coarse(A[c[kn]], Pc[kn], thc[kn], sep[kn], A[fine], l[c[kn]], l[fine], bb)
        P[fine[acc]] = Pf[acc]
        th[fine[acc]] = _wrap(thf[acc])
        status[fine[acc]] = 0
        bad_int[np.searchsorted(c, fine[~acc], side="right") - 1] = True
    # 3. refine refused intervals (and the tail after a coarse loss) at full resolution
    todo = [k for k in np.flatnonzero(bad_int)]
    if kmax < len(c) - 1:
        todo.append(kmax)                              # c[kmax] .. N-1
    _refine(A, b, l, c, kmax, sorted(set(todo)), Pc, P, th, status, nb)
    _first_failure_final(P, th, status)
    return P, th, status


@quiet
def triad_track(A, b, l, start, *, stride=STRIDE, jit=False) -> TriadTrack:
    """Follow one assembly mode of a triad along a batch of anchor positions.

    Parameters
    ----------
    A : array_like, shape (N, 3, 2)
        Outer pins along the motion (consecutive rows = consecutive positions).
    b, l : as in :func:`triad_modes` (``l`` may be (N, 3)).
    start : array_like, shape (3, 2)
        P1..P3 near the wanted mode at ``A[0]`` (e.g. the reference configuration).
    stride : int, optional
        All modes are computed every ``stride`` positions; positions in between
        are Newton-polished from a Taylor prediction and accepted only if they
        stay well inside their mode's basin (else that interval is redone at
        full resolution).  ``stride=1``: all modes at every position.
    jit : bool, optional
        Run the all-modes phases (the modes at the coarse positions and their
        following, and any interval redone at full resolution) compiled, by
        :mod:`kin.groups._triad_nb`, when numba is installed: the same modes and
        statuses, the floats to rounding (as :func:`track_designs`).

    Returns
    -------
    TriadTrack
        ``P`` (N, 3, 2), ``theta`` (N,), ``ok`` (N,), ``det`` (N,), ``status`` (N,):
        0 ok, 1 no assembly at the start, 2 lost here (modes collide at a turning
        point, or the step is ambiguous), 3 after a loss.

    Notes
    -----
    Each mode at position i is predicted at the next (sampled) position by a
    second-order Taylor step along the straight segment of the anchors
    (:func:`triad_rates` with ``vA = ΔA``, ``aA = 0``), then matched to the
    nearest mode there (:func:`follow_modes`).  A match is refused when it is
    not clearly nearer than the next candidate or when the step is not small
    against the distance to the nearest other mode, so the mode is never
    switched silently; after a loss ``ok`` stays False.  Cost: one companion
    eigenproblem per ``stride`` positions plus a vectorised Newton polish.
    """
    A = np.asarray(A, dtype=float)
    b = np.asarray(b, dtype=float)
    l = np.broadcast_to(np.asarray(l, dtype=float), A.shape[:-1])
    P, th, status = _track(A, b, l, np.asarray(start, dtype=float), stride, _kernel() if jit else None)
    ok = status == 0
    det = np.full(A.shape[0], np.nan)
    if ok.any():
        det[ok] = _det(A[ok], P[ok])
    return TriadTrack(P, th, ok, det, status)


# --------------------------------------------------------------------------- over designs
# The tracker above, run for D designs at once: all modes at the coarse inputs (one
# batched companion eigenproblem per design and coarse input), mode following between
# them (follow_modes_batch), then every other input Newton-polished from a Taylor
# prediction off its nearest coarse input, accepted only well inside its mode's basin.
# A design whose path needs more (a coarse loss, a refused interval, a non-finite known
# pin) is handed to the single-design tracker itself: every design gets its result alone.
@functools.lru_cache(maxsize=64)
def _coarse(N: int, stride: int) -> np.ndarray:
    """The coarse inputs of a path of N inputs: every ``stride``-th and the last
    (read-only, kept: every design batch of the same grid asks for them)."""
    c = np.arange(0, N, stride)
    c = c if c[-1] == N - 1 else np.append(c, N - 1)
    c.flags.writeable = False
    return c


@functools.lru_cache(maxsize=64)
def _fine(N: int, stride: int) -> tuple[np.ndarray, np.ndarray]:
    """The other inputs of :func:`_coarse`'s path and each one's nearest coarse input
    (:func:`_nearest_coarse`), read-only and kept."""
    c = _coarse(N, stride)
    fine = np.setdiff1d(np.arange(N), c, assume_unique=True)
    kn = _nearest_coarse(c, fine, len(c) - 1)
    fine.flags.writeable = kn.flags.writeable = False
    return fine, kn


def _coarse_follow(A, b, l, start, nb=None):
    """All modes at each design's inputs ``A`` (D, n, 3, 2) and the mode followed from the
    one nearest ``start`` (D, 3, 2): modes, ``idx`` and ``status`` (D, n).  With ``nb``
    (:func:`_kernel`) the modes, the predictions and the following run compiled."""
    Dn, n = A.shape[:2]
    bn = np.broadcast_to(b[:, None], (Dn, n, 3, 2)).reshape(-1, 3, 2)
    if nb is None:
        m = triad_modes(A.reshape(-1, 3, 2), bn, l.reshape(-1, 3))
        P, th = m.P, m.theta
    else:
        P, th = _modes_nb(nb, A.reshape(-1, 3, 2), bn - bn[:, :1], l.reshape(-1, 3))
    P = P.reshape(Dn, n, MAX_MODES, 3, 2)
    th = th.reshape(Dn, n, MAX_MODES)
    valid = np.isfinite(th)
    d0 = np.where(valid[:, 0], _dist(P[:, 0], start[:, None]), np.inf)
    d0 = np.where(np.isnan(d0), np.inf, d0)
    j0 = np.where(np.isfinite(d0).any(axis=1), np.argmin(d0, axis=1), -1)
    Pi = np.where(valid[:, :-1, :, None, None], P[:, :-1], A[:, :-1, None])
    if nb is None:
        rep = lambda a: np.repeat(a[:, :, None], MAX_MODES, axis=2).reshape(-1, *a.shape[2:])  # noqa: E731
        pred = _predict(rep(A[:, :-1]), Pi.reshape(-1, 3, 2), rep(A[:, 1:]), rep(l[:, :-1]), rep(l[:, 1:]))[0]
    else:                                         # (every mode of an input predicted from its one copy)
        pred = _predict_modes(nb, A[:, :-1], Pi, A[:, 1:], l[:, :-1], l[:, 1:])
    pred = pred.reshape(Dn, n - 1, MAX_MODES, 3, 2)
    if nb is None:
        idx, status = follow_modes_batch(P, valid, pred, j0)
    else:                                         # kin.groups._triad_nb.follow_batch
        idx, status = np.empty(valid.shape[:2], np.int64), np.empty(valid.shape[:2], np.int64)
        nb.follow_batch(np.ascontiguousarray(P), np.ascontiguousarray(valid), np.ascontiguousarray(pred),
                        np.ascontiguousarray(j0, np.int64), 0.5, idx, status)
    return P, th, idx, status


@quiet
def track_designs(A, b, l, start, *, stride=STRIDE, jit=False):
    """Follow each design's mode along its inputs, as :func:`~kin.groups.triad.triad_track`.

    Parameters
    ----------
    A : ndarray, shape (D, N, 3, 2)
        The outer pins of each design along the inputs.
    b : ndarray, shape (D, 3, 2)
        Each design's P1..P3 in its reference configuration.
    l : ndarray, shape (D, 3) or (D, N, 3)
        Each design's binary lengths (per input for a reduction, e.g. class IV's).
    start : ndarray, shape (D, 3, 2)
        Points near the wanted mode at ``A[:, 0]``.
    jit : bool, optional
        Run the tracker's two batched phases (all modes at the coarse inputs and their
        following; the prediction, polish and acceptance of every other input) compiled,
        by :mod:`kin.groups._triad_nb`, when numba is installed: the same modes and
        statuses, the floats to rounding (its polynomial's DFT and companion QR are its
        own, the Newton polish after them the NumPy route's).

    Returns
    -------
    P : ndarray (D, N, 3, 2), theta : ndarray (D, N), status : ndarray (D, N) int
        As :class:`~kin.groups.triad.TriadTrack` (0 ok, 1 no assembly, 2 lost, 3 after).

    Notes
    -----
    Designs within :data:`NEAR` of the first one (the rows of a finite-difference
    Jacobian, which perturb one design) are not tracked on their own: each is
    Newton-polished at every input from the first design's pose there, and kept when
    every input converges well inside the first design's mode (within a quarter of the
    distance to its nearest other mode, from all its modes at every input), which is
    the mode the tracker would follow (:func:`_near_first`); any other is tracked.
    """
    Dn, N = A.shape[:2]
    if N == 0:                                    # (no input: nothing to follow)
        return np.zeros((Dn, 0, 3, 2)), np.zeros((Dn, 0)), np.zeros((Dn, 0), int)
    L = np.broadcast_to(l[:, None] if l.ndim == 2 else l, (Dn, N, 3))
    nb = _kernel() if jit else None
    near = _near_rows(A, b, L, start)
    if near.size == 0:
        return _track_all(A, b, L, start, stride, nb)
    rest = np.setdiff1d(np.arange(Dn), near)
    P = np.full((Dn, N, 3, 2), np.nan)
    th = np.full((Dn, N), np.nan)
    status = np.full((Dn, N), 3)
    P[rest], th[rest], status[rest] = _track_all(A[rest], b[rest], L[rest], start[rest], stride, nb)
    kept, Pn, thn = _near_first(A[near], b[near], L[near], (A[0], b[0], L[0]), (P[0], th[0], status[0]), nb)
    P[near[kept]], th[near[kept]], status[near[kept]] = Pn, thn, 0
    left = near[~kept]
    if left.size:
        P[left], th[left], status[left] = _track_all(A[left], b[left], L[left], start[left], stride, nb)
    return P, th, status


#: how near another design's pins, pivots, lengths and start must be to the first one's
#: (the largest coordinate difference, relative to the first design's longest leg) for it
#: to be solved from the first one's poses (:func:`track_designs`)
NEAR = 1e-5


def _near_rows(A, b, L, start) -> np.ndarray:
    """The rows after the first whose inputs are within :data:`NEAR` of the first's."""
    Dn = A.shape[0]
    if Dn < 3:
        return np.zeros(0, int)
    dev = np.max(np.abs(A - A[:1]).reshape(Dn, -1), axis=1)
    for a in (b, L, start):
        dev = np.maximum(dev, np.max(np.abs(a - a[:1]).reshape(Dn, -1), axis=1))
    ok = dev <= NEAR * float(np.max(L[0]))        # (NaN: not near)
    ok[0] = False
    return np.flatnonzero(ok)


def _near_first(A, b, L, first, tracked, nb):
    """Designs near a ``first`` one (its ``A``, ``b``, ``L``) whose every input tracked
    (``tracked``: its ``P``, ``theta`` and status), each Newton-polished at every input
    from the first one's pose: the rows kept (every input converged, within a quarter of
    the first one's separation from its nearest other mode there), their ``P`` and
    ``theta``."""
    K, N = A.shape[:2]
    (A0, b0, L0), (P0, th0, s0) = first, tracked
    none = np.zeros(K, bool), np.zeros((0, N, 3, 2)), np.zeros((0, N))
    if (s0 != 0).any():
        return none
    if nb is None:
        m = triad_modes(A0, np.broadcast_to(b0, (N, 3, 2)), L0)
        Pm, thm = m.P, m.theta
    else:
        Pm, thm = _modes_nb(nb, A0, np.broadcast_to(b0 - b0[:1], (N, 3, 2)), L0)
    d = np.where(np.isfinite(thm), np.nan_to_num(_dist(Pm, P0[:, None]), nan=np.inf), np.inf)   # (N, modes)
    own = np.argmin(d, axis=1)
    if not np.all(d[np.arange(N), own] <= 1e-6 * np.max(L0)):    # its pose is not among the modes found
        return none
    d[np.arange(N), own] = np.inf
    sep = np.min(d, axis=1)                                                          # (N,)
    bb = b - b[:, :1]
    Pf, thf, res = _polish(A, bb[:, None], L, np.broadcast_to(P0[:, 0], (K, N, 2)), np.broadcast_to(th0, (K, N)))
    kept = np.all((res <= ACCEPT) & (_dist(Pf, P0) <= 0.25 * sep), axis=1)
    return kept, Pf[kept], _wrap(thf[kept])


def _track_all(A, b, L, start, stride, nb):
    """:func:`track_designs` of every design by the tracker (batched where it can be)."""
    Dn, N = A.shape[:2]
    finite = np.all(np.isfinite(A.reshape(Dn, -1)), axis=1)
    step = stride if N > 2 * stride else 1        # a short path: all modes at every input
    if finite.all():                              # (no copies of the designs' arrays)
        k, Pd, thd = _fill(A, b, L, start, step, nb)
        if k.size == Dn:                          # every design filled: the common case
            return Pd, thd, np.zeros((Dn, N), int)
    P = np.full((Dn, N, 3, 2), np.nan)
    th = np.full((Dn, N), np.nan)
    status = np.full((Dn, N), 3)
    alone = ~finite
    if finite.any():
        rows = np.flatnonzero(finite)
        if rows.size < Dn:
            k, Pd, thd = _fill(A[rows], b[rows], L[rows], start[rows], step, nb)
        P[rows[k]], th[rows[k]], status[rows[k]] = Pd, thd, 0
        alone[rows] = True
        alone[rows[k]] = False
    rest = np.flatnonzero(alone & finite)
    if rest.size and step > 1:                    # (designs lost on the way: their prefix, batched)
        done, Pd, thd, sd = _track_partial(A[rest], b[rest], L[rest], start[rest], step, nb)
        P[rest[done]], th[rest[done]], status[rest[done]] = Pd, thd, sd
        alone[rest[done]] = False
    for d in np.flatnonzero(alone):               # the single-design tracker, as alone
        if finite[d]:
            P[d], th[d], status[d] = _track(A[d], b[d], L[d], start[d], stride, nb)
    return P, th, status


def _track_partial(A, b, L, start, stride, nb):
    """:func:`_track` for many designs at once where it does the same steps for each: a
    design whose mode is lost at a coarse input (or that does not assemble at the
    reference), every other input before it accepted from its Taylor prediction; the
    rest of its inputs followed at full resolution from its last good coarse input, as
    :func:`_refine` follows that tail (:func:`_partial_tail`).  Returns the designs
    done, and their ``P``,
    ``theta`` and statuses; any other design (an input refused before the loss, or no
    loss at all) is left to :func:`_track`."""
    Dn, N = A.shape[:2]
    c = _coarse(N, stride)
    nc = len(c)
    Pm, thm, ic, _ = _coarse_follow(A[:, c], b, L[:, c], start, nb)
    good = ic >= 0
    kmax = good.sum(axis=1) - 1                   # (the last good coarse input, when they lead)
    done = (kmax < nc - 1) & np.all(good == (np.arange(nc) <= kmax[:, None]), axis=1)
    P = np.full((Dn, N, 3, 2), np.nan)
    th = np.full((Dn, N), np.nan)
    status = np.full((Dn, N), 3)
    status[done & (kmax < 0)] = 1                 # (no assembly at the reference)
    live = np.flatnonzero(done & (kmax >= 0))
    if live.size:
        ok = _partial_prefix(A[live], b[live], L[live], c, kmax[live], Pm[live], thm[live], ic[live],
                             P[live], th[live], status[live])
        done[live[~ok[0]]] = False
        P[live], th[live], status[live] = ok[1:]
        _partial_tail(A, b, L, c, kmax, live[ok[0]], P, th, status, nb)
        _first_failures(P, th, status, live[ok[0]])
    return done, P[done], th[done], status[done]


def _partial_prefix(A, b, L, c, kmax, Pm, thm, ic, P, th, status):
    """Phases 1 and 2 of :func:`_track` for designs lost after their coarse input
    ``c[kmax]``: the coarse points and every input before ``c[kmax]`` from its nearest
    coarse point (Taylor, Newton, the acceptance tests), in :func:`_track`'s NumPy route.
    Returns whether each design had every such input accepted, and ``P``, ``theta`` and
    the statuses so far."""
    G, nc = ic.shape
    ar = np.arange(nc)
    kk = ar[None, :] <= kmax[:, None]                                       # (G, nc) good coarse points
    icc = np.where(kk, ic, 0)
    Pc = Pm[np.arange(G)[:, None], ar, icc]                                # (G, nc, 3, 2)
    thc = thm[np.arange(G)[:, None], ar, icc]
    sep = _separation(Pm, thm, Pc, icc)
    g, k = np.nonzero(kk)
    P[g, c[k]], th[g, c[k]], status[g, c[k]] = Pc[g, k], thc[g, k], 0
    end = c[kmax]                                                           # (G,)
    fine = np.setdiff1d(np.arange(int(end.max()) + 1), c, assume_unique=True)
    dd, ff = np.nonzero(fine[None, :] <= end[:, None])
    ff = fine[ff]
    accepted = np.ones(G, bool)
    if ff.size:
        kn = _nearest_coarse(c, ff, kmax[dd])
        Pf, thf, acc = _from_coarse(A[dd, c[kn]], Pc[dd, kn], thc[dd, kn], sep[dd, kn], A[dd, ff], L[dd, c[kn]],
                                    L[dd, ff], (b - b[:, :1])[dd])
        accepted = ~np.isin(np.arange(G), dd[~acc])
        P[dd[acc], ff[acc]] = Pf[acc]
        th[dd[acc], ff[acc]] = _wrap(thf[acc])
        status[dd[acc], ff[acc]] = 0
    return accepted, P, th, status


def _partial_tail(A, b, L, c, kmax, rows, P, th, status, nb, chunk: int = 8):
    """:func:`_refine`'s tail for designs ``rows`` at once, in place: every input from
    ``c[kmax]`` to the last followed at full resolution from the pose there, ``chunk``
    inputs at a time for the designs still followed (a design's mode is almost always
    lost within the first chunk: all modes at every later input would be spent on
    nothing).  Following is causal, and a chunk starts from the pose its predecessor
    ended on, the mode itself, so the chunks give the single pass's modes and
    statuses; the designs' chunks are padded with their last input to one length."""
    N = A.shape[1]
    cur = c[kmax[rows]].copy()
    first = np.ones(len(rows), bool)
    live = np.arange(len(rows))
    while live.size:
        d = rows[live]
        lo = cur[live]
        n = np.minimum(lo + chunk, N - 1) - lo + 1
        j = np.minimum(lo[:, None] + np.arange(int(n.max()))[None, :], N - 1)
        Pt, tht, idx, st = _coarse_follow(A[d[:, None], j], b[d], L[d[:, None], j], P[d, lo], nb)
        started = idx[:, 0] >= 0                   # (else the start has no mode: nothing reached)
        lost = np.flatnonzero(~started & first[live])
        if lost.size:
            status[d[lost]] = np.where(np.arange(N)[None, :] >= lo[lost, None], 1, status[d[lost]])
        inside = started[:, None] & (np.arange(j.shape[1])[None, :] < n[:, None])     # (each one's chunk)
        g, k = np.nonzero(inside & (idx >= 0))
        P[d[g], lo[g] + k] = Pt[g, k, idx[g, k]]
        th[d[g], lo[g] + k] = tht[g, k, idx[g, k]]
        g, k = np.nonzero(inside)
        status[d[g], lo[g] + k] = st[g, k]
        on = started & (idx[np.arange(len(live)), n - 1] >= 0) & (lo + n < N)
        first[live] = False
        cur[live] = lo + n - 1
        live = live[on]


def _first_failures(P, th, status, rows) -> None:
    """:func:`_first_failure_final` of designs ``rows``, in place."""
    for d in rows:
        _first_failure_final(P[d], th[d], status[d])


def _kernel():
    """The compiled tracker (:mod:`kin.groups._triad_nb`), or None without numba."""
    try:
        from . import _triad_nb
    except (ImportError, RuntimeError):        # no numba, or no writable cache directory
        return None
    return _triad_nb


def _fill(A, b, L, start, stride, nb=None):
    """Phases 1 and 2 of the tracker for designs whose coarse inputs all follow and whose
    every other input is accepted: their rows, ``P`` and ``theta`` (the rest are not done).
    With ``nb`` (:func:`_kernel`) both phases run compiled."""
    Dn, N = A.shape[:2]
    c = _coarse(N, stride)
    Pm, thm, ic, sc = _coarse_follow(A[:, c], b, L[:, c], start, nb)
    good = np.all(ic >= 0, axis=1)
    if not good.any():
        return np.zeros(0, int), np.zeros((0, N, 3, 2)), np.zeros((0, N))
    g = np.flatnonzero(good)
    if g.size < Dn:
        A, b, L, ic = A[g], b[g], L[g], ic[g]
    ar = np.arange(len(c))
    Pc = Pm[g][:, ar][np.arange(len(g))[:, None], ar, ic]            # (G, nc, 3, 2)
    thc = thm[g][np.arange(len(g))[:, None], ar, ic]
    fine, kn = _fine(N, stride)
    if not fine.size:                             # (a short path: every input's modes already followed)
        return g, Pc, thc
    sep = _separation(Pm[g], thm[g], Pc, ic)
    if nb is not None:
        return _fill_compiled(nb, g, A, b - b[:, :1], L, (c, fine, kn), Pc, thc, sep)
    Pf, thf, acc = _from_coarse(A[:, c[kn]], Pc[:, kn], thc[:, kn], sep[:, kn], A[:, fine], L[:, c[kn]],
                                L[:, fine], (b - b[:, :1])[:, None])
    done = acc.all(axis=1)
    Pd = np.empty((len(g), N, 3, 2))
    thd = np.empty((len(g), N))
    Pd[:, c], thd[:, c] = Pc, thc
    Pd[:, fine], thd[:, fine] = Pf, _wrap(thf)
    return (g, Pd, thd) if done.all() else (g[done], Pd[done], thd[done])


def _fill_compiled(nb, g, A, bb, L, cfk, Pc, thc, sep):
    """Phase 2 of :func:`_fill` by :func:`kin.groups._triad_nb.fill_fine`."""
    Gn, N = A.shape[:2]
    Pd, thd, done = np.empty((Gn, N, 3, 2)), np.empty((Gn, N)), np.empty(Gn, bool)
    # (the indices copied: the kept read-only ones would be another compiled signature)
    f, i = (lambda a: np.ascontiguousarray(a, float)), (lambda a: np.array(a, np.int64))  # noqa: E731
    nb.fill_fine(f(A), f(bb), f(L), f(Pc), f(thc), f(sep), *map(i, cfk), NEWTON_ITERS, 1e-12, ACCEPT,
                 SINGULAR_RTOL, Pd, thd, done)
    return (g, Pd, thd) if done.all() else (g[done], Pd[done], thd[done])


#: triad/class IV tracker codes -> (Status, reason)
TRACK_STATUS = {1: (Status.OUT_OF_REACH, "no assembly (out of reach)"),
                2: (Status.SINGULAR, "assembly modes collide / ambiguous step (triad singular or turning point)"),
                3: (Status.MODE_LOST, "mode lost earlier in the path")}


def triad_lower(q, P, U, O, size, out) -> None:
    """:meth:`TriadStep.lower` of D designs for the compiled kernel: the same floats.
    ``q`` = (rows of the outer joints A1..A3, of the inner joints b1..b3; the known
    links of A1..A3, the ternary, the binaries 1..3)."""
    for d in range(P.shape[0]):
        ox, oy = P[d, q[0], 0], P[d, q[0], 1]
        for i in range(3):
            ax, ay, bx, by = P[d, q[i], 0], P[d, q[i], 1], P[d, q[3 + i], 0], P[d, q[3 + i], 1]
            h = np.hypot(bx - ax, by - ay)
            put_rel(out, d, 2 * i, ax, ay, O, q[6 + i])
            out[d, 6 + 2 * i], out[d, 7 + 2 * i] = bx - ox, by - oy
            out[d, 12 + i] = h
            put_off(out, d, 15 + 2 * i, ax, ay, O, q[10 + i])
            out[d, 21 + 2 * i], out[d, 22 + 2 * i] = (bx - ax) / h, (by - ay) / h
        out[d, 27], out[d, 28] = ox, oy
        put_off(out, d, 29, P[d, q[3], 0], P[d, q[3], 1], O, q[9])


class TriadStep(GroupStep):
    """A class III triad of a plan, tracked in the mode of the reference
    (:func:`triad_track`); rates from the group's Jacobian.  Batches of designs run
    its tracker compiled, each design along its own inputs
    (:func:`kin.groups._triad_nb.triad_place`)."""

    solver = "triad"

    kind = GroupKind.TRIAD
    compiled = Deferred(f"{__package__}._triad_nb", "triad_place")
    compiled_lower = staticmethod(triad_lower)
    tracked = True

    @classmethod
    def assembly_modes(cls, m, group) -> int:
        """The real assembly modes at the reference (all-modes kernel, Hunt 1983)."""
        at, lay = {j.name: np.asarray(j.at, float) for j in m.joints}, group.layout
        A = np.array([at[o] for o in lay.outers])
        b = np.array([at[i] for i in lay.inners])
        return int(triad_modes(A, b, np.hypot(*(b - A).T)).n_modes)

    @classmethod
    def monitored_angles(cls, m, group) -> tuple[AngleDef, ...]:
        """One angle at each inner joint (legs i, j, k in turn): the leg against the line
        to the instant centre of the other two legs (Hunt 1983)."""
        outs, inns = group.layout.outers, group.layout.inners
        return tuple(AngleDef(inns[i], "triad", (outs[i], inns[i], outs[(i + 1) % 3], inns[(i + 1) % 3],
                                                 outs[(i + 2) % 3], inns[(i + 2) % 3])) for i in range(3))

    def __init__(self, mechanism, st, size: float, geo=None):
        super().__init__(mechanism, st, size, geo)
        lay = self.layout = self.group.layout
        at = self.at
        self.A = np.stack([at(o) for o in lay.outers], axis=-2)     # (3, 2), or (D, 1, 3, 2) for designs
        self.b = np.stack([at(i) for i in lay.inners], axis=-2)
        v = self.b - self.A
        self.lengths = np.hypot(v[..., 0], v[..., 1])
        self.known = [known_on(self.group, o) for o in lay.outers]

    def positions(self, G, X, factor=1.0, probe=False) -> Outcome:
        if not G.reasons:
            return self._designs(G)
        N = G.M
        A = np.stack([G.point(k, a) for k, a in zip(self.known, self.A)], axis=1)
        good = np.all(np.isfinite(A.reshape(N, -1)), axis=1)
        P, th, ok = np.full((N, 3, 2), np.nan), np.full(N, np.nan), np.zeros(N, bool)
        why: dict[int, tuple] = {}
        if good.any():
            idx = np.flatnonzero(good)
            o = self.A[0]                    # solved about the reference anchor: translation-invariant
            r = triad_track(A[idx] - o, self.b - o, self.lengths, self.b - o, jit=chooses(N))
            P[idx], th[idx], ok[idx] = r.P + o, r.theta, r.ok
            for k in np.flatnonzero(~r.ok):
                why[int(idx[k])] = TRACK_STATUS.get(int(r.status[k]), (Status.MODE_LOST, "triad mode lost"))
        self._place(G, A, P, th)
        return Outcome(ok, why, Probe(ok.copy()) if probe else None)

    def _place(self, G, A, P, th) -> None:
        lay = self.layout
        G.place_cs(lay.ternary, P[..., 0, :], self.b[..., 0, :], np.cos(th), np.sin(th), th)
        for i, lk in enumerate(lay.binaries):
            G.place_dir(lk, A[..., i, :], self.A[..., i, :], P[..., i, :] - A[..., i, :],
                        self.b[..., i, :] - self.A[..., i, :])

    def _designs(self, G) -> Outcome:
        """D designs at N inputs (``G.shape``), each tracked as alone
        (:func:`~kin.groups.triad.track_designs`)."""
        A = np.stack([G.point(k, self.A[..., i, :]) for i, k in enumerate(self.known)], axis=-2)  # (D, N, 3, 2)
        o = self.A[:, :, :1]                 # (D, 1, 1, 2): about the reference anchor, as alone
        b = (self.b - o)[:, 0]
        P, th, status = track_designs(A - o, b, self.lengths[:, 0], b, jit=self.jit)
        self._place(G, A, P + o, th)
        return Outcome(status == 0, {}, None)

    rates = jacobian_rates

    def lower(self, origins) -> Lowered | None:
        """Flat numbers of :func:`kin.groups._triad_nb.triad_place` (:func:`triad_lower`'s
        layout): each outer joint relative to its known link, each inner joint relative
        to the first outer one (the tracker's origin), the legs' lengths, each binary's
        reference point from its outer joint, the legs' unit directions, the origin and
        the ternary's reference point from its first inner joint."""
        o = origins
        lay, A, b = self.layout, self.A, self.b
        v = b - A
        u = v / self.lengths[..., None]
        f = [*(x for i in range(3) for x in self.rel(o, self.link_index(self.known[i]), A[..., i, :])),
             *(num(x) for i in range(3) for x in (b[..., i, 0] - A[..., 0, 0], b[..., i, 1] - A[..., 0, 1])),
             *(num(self.lengths[..., i]) for i in range(3)),
             *(x for i in range(3) for x in self.off(o, self.link_index(lay.binaries[i]), A[..., i, :])),
             *(num(x) for i in range(3) for x in (u[..., i, 0], u[..., i, 1])),
             num(A[..., 0, 0]), num(A[..., 0, 1]), *self.off(o, self.link_index(lay.ternary), b[..., 0, :])]
        return Lowered(self.kind, self._links(), tuple(f))

    def lower_indices(self, row) -> tuple[int, ...]:
        lay = self.layout
        return (*(row(j) for j in lay.outers), *(row(j) for j in lay.inners), *self._links())

    def _links(self) -> tuple[int, ...]:
        """The links the compiled step reads and places: the outer joints' known links,
        the ternary, the binaries."""
        lay = self.layout
        return tuple(self.link_index(k) for k in (*self.known, lay.ternary, *lay.binaries))
