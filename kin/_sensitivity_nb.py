"""The numba side of the design sensitivities (:func:`kin.sensitivity.pose_sensitivity`):
every step's velocity analogue assembled and solved position by position, compiled.

Imported only when the compiled route is wanted (:func:`kin.kernel.wanted`); the NumPy
route of :mod:`kin.sensitivity` stays the oracle and the route when the kernel is off.
Per position and step it assembles the same rows as the NumPy route's ``_partials``
(pins, sliders, drivers; Nikravesh 1988, ch. 3-4) into a small dense system and solves
it by Gaussian elimination with partial pivoting (Golub and Van Loan 2013, alg. 3.4.1),
where the NumPy route calls LAPACK once per position: the two agree to rounding.
"""
from __future__ import annotations

import numba
import numpy as np

from ._scalar_nb import JIT as _JIT

__all__ = ["sensitivities"]


@numba.njit(inline="always", **_JIT)
def _put(J, R, out, cols, link, bb, r, p0, p1, p2):
    """Row ``r``'s partial ``(p0, p1, p2)`` by link ``link``'s pose: into the system
    when the step solves the link, else times its known derivatives into the right side."""
    c = cols[link]
    if c >= 0:
        J[r, c] += p0
        J[r, c + 1] += p1
        J[r, c + 2] += p2
    else:
        for j in range(R.shape[1]):
            R[r, j] -= p0 * out[link, bb, 0, j] + p1 * out[link, bb, 1, j] + p2 * out[link, bb, 2, j]


@numba.njit(inline="always", **_JIT)
def _eliminate(J, R, m) -> bool:
    """``J[:m, :m] x = R[:m]`` in place (x in ``R``); False at a zero or non-finite pivot."""
    q = R.shape[1]
    for k in range(m):
        p = k
        big = abs(J[k, k])
        for i in range(k + 1, m):
            if abs(J[i, k]) > big:
                big, p = abs(J[i, k]), i
        if not big > 0.0 or not np.isfinite(big):
            return False
        if p != k:
            for j in range(m):
                J[k, j], J[p, j] = J[p, j], J[k, j]
            for j in range(q):
                R[k, j], R[p, j] = R[p, j], R[k, j]
        inv = 1.0 / J[k, k]
        for i in range(k + 1, m):
            f = J[i, k] * inv
            if f != 0.0:
                for j in range(k + 1, m):
                    J[i, j] -= f * J[k, j]
                for j in range(q):
                    R[i, j] -= f * R[k, j]
    for k in range(m - 1, -1, -1):
        inv = 1.0 / J[k, k]
        for j in range(q):
            acc = R[k, j]
            for i in range(k + 1, m):
                acc -= J[k, i] * R[i, j]
            R[k, j] = acc * inv
    return True


@numba.njit(**_JIT)
def sensitivities(X, Y, C, S, N, kind, la, lb, row, alpha, drive, Ea, Eb, rho_a, rho_b, u0,
                  step_lo, step_hi, neq, col_of, unknown, ok, out):
    """Fill ``out`` (n_links, B, 3, q) (the frame's rows zero, the rest NaN on entry) with
    every solved link's derivatives at the positions ``ok``.

    Poses ``X, Y, C, S`` (n_links, B) (position of the link's reference point, cos and
    sin of its rotation); ``N`` positions per design.  Blocks ``k`` (every step's
    constraints in order): ``kind`` 0 pin, 1 slider, 2 rotary driver, 3 slide driver;
    links ``la``, ``lb``; first row ``row``; ``alpha``, ``drive`` columns (or -1);
    ``Ea``, ``Eb`` (nb, 2, q) the offsets' selections; per design ``rho_a``, ``rho_b``,
    ``u0`` (nb, D, 2).  Steps ``s``: blocks ``step_lo[s]:step_hi[s]``, ``neq[s]``
    equations, ``col_of[s, link]`` the link's first column in the step (-1: known),
    ``unknown[s]`` its links (-1 padded).
    """
    B = X.shape[1]
    q = out.shape[3]
    mmax = 0
    for s in range(len(neq)):
        mmax = max(mmax, neq[s])
    J = np.empty((mmax, mmax))
    R = np.empty((mmax, q))
    for bb in range(B):
        if not ok[bb]:
            continue
        d = bb // N
        for s in range(len(neq)):
            m = neq[s]
            J[:m, :m] = 0.0
            R[:m] = 0.0
            cols = col_of[s]
            for k in range(step_lo[s], step_hi[s]):
                a, b, r0 = la[k], lb[k], row[k]
                ca, sa, cb, sb = C[a, bb], S[a, bb], C[b, bb], S[b, bb]
                rax = ca * rho_a[k, d, 0] - sa * rho_a[k, d, 1]
                ray = sa * rho_a[k, d, 0] + ca * rho_a[k, d, 1]
                rbx = cb * rho_b[k, d, 0] - sb * rho_b[k, d, 1]
                rby = sb * rho_b[k, d, 0] + cb * rho_b[k, d, 1]
                kd = kind[k]
                if kd == 0:                                   # pin: X_a + R_a ρ_a − X_b − R_b ρ_b
                    _put(J, R, out, cols, a, bb, r0, 1.0, 0.0, -ray)
                    _put(J, R, out, cols, a, bb, r0 + 1, 0.0, 1.0, rax)
                    _put(J, R, out, cols, b, bb, r0, -1.0, 0.0, rby)
                    _put(J, R, out, cols, b, bb, r0 + 1, 0.0, -1.0, -rbx)
                    for j in range(q):
                        R[r0, j] -= (ca * Ea[k, 0, j] - sa * Ea[k, 1, j]) - (cb * Eb[k, 0, j] - sb * Eb[k, 1, j])
                        R[r0 + 1, j] -= (sa * Ea[k, 0, j] + ca * Ea[k, 1, j]) - (sb * Eb[k, 0, j] + cb * Eb[k, 1, j])
                    continue
                if kd == 2:                                   # θ_b − θ_a − φ
                    _put(J, R, out, cols, a, bb, r0, 0.0, 0.0, -1.0)
                    _put(J, R, out, cols, b, bb, r0, 0.0, 0.0, 1.0)
                    R[r0, drive[k]] += 1.0
                    continue
                ux = ca * u0[k, d, 0] - sa * u0[k, d, 1]
                uy = sa * u0[k, d, 0] + ca * u0[k, d, 1]
                if kd == 1:                                   # the line: w = n, ∂w/∂α = −u
                    _put(J, R, out, cols, a, bb, r0, 0.0, 0.0, -1.0)
                    _put(J, R, out, cols, b, bb, r0, 0.0, 0.0, 1.0)
                    wx, wy, dwx, dwy, rl = -uy, ux, -ux, -uy, r0 + 1
                else:                                         # the slide: w = u, ∂w/∂α = n
                    wx, wy, dwx, dwy, rl = ux, uy, -uy, ux, r0
                dx = X[b, bb] + rbx - X[a, bb] - rax
                dy = Y[b, bb] + rby - Y[a, bb] - ray
                _put(J, R, out, cols, a, bb, rl, -wx, -wy, (-wy * dx + wx * dy) - (-wx * ray + wy * rax))
                _put(J, R, out, cols, b, bb, rl, wx, wy, -wx * rby + wy * rbx)
                for j in range(q):
                    ex = (cb * Eb[k, 0, j] - sb * Eb[k, 1, j]) - (ca * Ea[k, 0, j] - sa * Ea[k, 1, j])
                    ey = (sb * Eb[k, 0, j] + cb * Eb[k, 1, j]) - (sa * Ea[k, 0, j] + ca * Ea[k, 1, j])
                    R[rl, j] -= wx * ex + wy * ey
                if alpha[k] >= 0:
                    R[rl, alpha[k]] -= dwx * dx + dwy * dy
                if kd == 3:
                    R[rl, drive[k]] += 1.0
            good = _eliminate(J, R, m)
            for i in range(unknown.shape[1]):
                lk = unknown[s, i]
                if lk < 0:
                    break
                for c in range(3):
                    for j in range(q):
                        out[lk, bb, c, j] = R[3 * i + c, j] if good else np.nan
