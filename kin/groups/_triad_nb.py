"""The numba side of the batched triad tracker (:func:`kin.groups.triad.track_designs`):
all the modes at the coarse inputs (:func:`modes_many`), their predictions and following
(:func:`predict_modes`, :func:`follow_batch`), and the Taylor prediction, Newton polish
and acceptance of every other input (:func:`fill_fine`), compiled.

Imported only when the compiled route is wanted (:func:`kin.kernel.wanted`, passed down
by :mod:`kin.design` as the step's ``jit``); the NumPy functions of
:mod:`kin.groups.triad` stay the oracle and the route when the kernel is off.  The
prediction, polish, following and acceptance do the NumPy route's operations in the
same order, one design and one input at a time with scalars (no temporaries), so the
floats agree to rounding (NumPy's and libm's ``cos``/``sin`` may differ by an ulp) and
the tests give the same answers.  The prediction is the second-order Taylor step of the
triad's rates (the Cramer-rule system of Vasechkin et al. 2017, extended to the triad),
the polish Newton on its three closure equations (Hunt 1983 for the modes).  The
modes' polynomial is not the NumPy route's to the bit: its coefficients come from a
direct 16-point DFT (not NumPy's FFT), and its roots are not LAPACK's: the companion
matrix (already upper Hessenberg) is balanced (Parlett and Reinsch 1969) and reduced by
Francis's double-shift QR (EISPACK's ``hqr``, Wilkinson and Reinsch 1971), faster than a
LAPACK call per 6×6 matrix.  The roots differ from LAPACK's by rounding (a double
root's by the square root of it), and the Newton polish that follows takes both to the
same modes.
"""
from __future__ import annotations

import numba
import numpy as np

from . import triad_tables as _tables
from .._jit_cache import depends_on
from .._scalar_nb import JIT as _JIT
from .base import SINGULAR_RTOL as _RTOL, carry, place, place_along

__all__ = ["fill_fine", "modes_many", "predict_modes", "follow_batch", "companion_roots", "track_path",
           "triad_place", "class4_place"]


def _fresh_cache() -> None:
    """Register the tracker's constants (:mod:`kin.groups.triad_tables`) and the scalar
    helpers it calls (:mod:`kin.groups.base`) as its cache's sources (numba keys the
    cache on this file alone)."""
    from . import base
    depends_on(__file__, [_tables.__file__, base.__file__])


_fresh_cache()                             # before the decorators read the stamp
#: the tracker's tables and tolerances, constants of the compiled code
_Z16, _DFT, _GRID, _BASIS = _tables.Z16, _tables.DFT, _tables.GRID, _tables.BASIS
_ITERS, _ACCEPT, _STRIDE = _tables.NEWTON_ITERS, _tables.ACCEPT, _tables.STRIDE


@numba.njit(**_JIT)
def _solve3(a, b, c, d, e, f, g, h, i, r0, r1, r2, rtol):
    """One 3×3 system by the adjugate (``triad._solve3c``): the solution and ``singular``."""
    A_ = e * i - f * h
    B_ = f * g - d * i
    C_ = d * h - e * g
    det = a * A_ + b * B_ + c * C_
    inv = 1.0 / det
    x0 = (r0 * A_ + r1 * (c * h - b * i) + r2 * (b * f - c * e)) * inv
    x1 = (r0 * B_ + r1 * (a * i - c * g) + r2 * (c * d - a * f)) * inv
    x2 = (r0 * C_ + r1 * (b * g - a * h) + r2 * (a * e - b * d)) * inv
    scale = np.sqrt((a * a + b * b + c * c) * (d * d + e * e + f * f) * (g * g + h * h + i * i))
    return x0, x1, x2, not (abs(det) > rtol * scale)


@numba.njit(**_JIT)
def _maximum(a, b):
    """``np.maximum`` of two floats (a NaN propagates)."""
    return a if (a >= b or a != a) else b


@numba.njit(**_JIT)
def _predict(A0, P0, A1, l0, l1, out, w, rtol):
    """``triad._predict`` at one input: the points into ``out`` (3, 2); returns the
    rotation increment and ``singular``.  ``w`` (24,): work."""
    for i in range(3):
        dx = P0[i, 0] - A0[i, 0]
        dy = P0[i, 1] - A0[i, 1]
        rx = P0[i, 0] - P0[0, 0]
        ry = P0[i, 1] - P0[0, 1]
        vx = A1[i, 0] - A0[i, 0]
        vy = A1[i, 1] - A0[i, 1]
        vl = l1[i] - l0[i]
        w[8 * i], w[8 * i + 1], w[8 * i + 2], w[8 * i + 3] = dx, dy, rx, ry
        w[8 * i + 4], w[8 * i + 5], w[8 * i + 6] = vx, vy, vl
        w[8 * i + 7] = dx * vx + dy * vy + np.sqrt(dx * dx + dy * dy) * vl
    qx, qy, om, sing = _solve3(w[0], w[1], w[1] * w[2] - w[0] * w[3], w[8], w[9], w[9] * w[10] - w[8] * w[11],
                               w[16], w[17], w[17] * w[18] - w[16] * w[19], w[7], w[15], w[23], rtol)
    o2 = om * om
    for i in range(3):
        dx, dy, rx, ry, vx, vy, vl = w[8 * i], w[8 * i + 1], w[8 * i + 2], w[8 * i + 3], w[8 * i + 4], \
            w[8 * i + 5], w[8 * i + 6]
        ex = (qx - om * ry) - vx
        ey = (qy + om * rx) - vy
        w[8 * i + 7] = dx * (0.0 + o2 * rx) + dy * (0.0 + o2 * ry) - ex * ex - ey * ey + vl * vl
    ax, ay, eps, _ = _solve3(w[0], w[1], w[1] * w[2] - w[0] * w[3], w[8], w[9], w[9] * w[10] - w[8] * w[11],
                             w[16], w[17], w[17] * w[18] - w[16] * w[19], w[7], w[15], w[23], rtol)
    for i in range(3):
        rx, ry = w[8 * i + 2], w[8 * i + 3]
        out[i, 0] = (P0[i, 0] + (qx - om * ry)) + 0.5 * (ax - eps * ry - o2 * rx)
        out[i, 1] = (P0[i, 1] + (qy + om * rx)) + 0.5 * (ay + eps * rx - o2 * ry)
    return om + 0.5 * eps, sing


@numba.njit(**_JIT)
def _geom(A, bb, px, py, c, s, w):
    """The rotated ``b_i - b_1`` and the legs ``P_i - A_i`` into ``w`` (12,)."""
    for i in range(3):
        rbx = c * bb[i, 0] - s * bb[i, 1]
        rby = s * bb[i, 0] + c * bb[i, 1]
        w[4 * i], w[4 * i + 1] = rbx, rby
        w[4 * i + 2], w[4 * i + 3] = px + rbx - A[i, 0], py + rby - A[i, 1]


@numba.njit(**_JIT)
def _polish(A, bb, l, px, py, th, out, w, iters, tol, rtol):
    """``triad._polish`` at one input: the points into ``out`` (3, 2); returns the
    rotation and the relative residual.  ``w`` (24,): work."""
    lmax = _maximum(_maximum(l[0], l[1]), l[2])
    for _ in range(iters):
        _geom(A, bb, px, py, np.cos(th), np.sin(th), w)
        for i in range(3):
            dx, dy = w[4 * i + 2], w[4 * i + 3]
            w[12 + 4 * i], w[13 + 4 * i], w[14 + 4 * i] = dx, dy, dy * w[4 * i] - dx * w[4 * i + 1]
            w[15 + 4 * i] = -0.5 * (dx * dx + dy * dy - l[i] * l[i])
        ux, uy, ut, _ = _solve3(w[12], w[13], w[14], w[16], w[17], w[18], w[20], w[21], w[22],
                                w[15], w[19], w[23], rtol)
        if not (np.isfinite(ux) and np.isfinite(uy) and np.isfinite(ut)):
            break                              # (the NumPy route repeats the same state)
        px += ux
        py += uy
        th += ut
        if np.abs(ux) + np.abs(uy) + np.abs(ut) * lmax <= tol * lmax:
            break
    _geom(A, bb, px, py, np.cos(th), np.sin(th), w)
    res = -np.inf
    for i in range(3):
        res = _maximum(res, np.abs(np.sqrt(w[4 * i + 2] * w[4 * i + 2] + w[4 * i + 3] * w[4 * i + 3]) - l[i]))
        out[i, 0] = px + w[4 * i]
        out[i, 1] = py + w[4 * i + 1]
    return th, res / lmax


@numba.njit(**_JIT)
def _dist(X, Y):
    s = 0.0
    for i in range(3):
        for k in range(2):
            s += (X[i, k] - Y[i, k]) ** 2
    return np.sqrt(s)


@numba.njit(**_JIT)
def _wrap(a):
    return (a + np.pi) % (2.0 * np.pi) - np.pi


@numba.njit(**_JIT)
def fill_fine(A, bb, L, Pc, thc, sep, c, fine, kn, iters, tol, accept, rtol, Pd, thd, done):
    """Phase 2 of ``triad._fill`` for G designs: each fine input predicted from its
    nearest coarse input ``kn``, polished and accepted as the NumPy route does.

    ``A`` (G, N, 3, 2), ``bb`` (G, 3, 2), ``L`` (G, N, 3), ``Pc`` (G, nc, 3, 2), ``thc``
    and ``sep`` (G, nc), ``c`` (nc,) the coarse inputs, ``fine`` and ``kn`` (nf,) the
    other inputs and their nearest coarse point.  Writes ``Pd`` (G, N, 3, 2), ``thd``
    (G, N) and ``done`` (G,) (every fine input accepted; a design's rows stop at its
    first refusal).
    """
    Gn = A.shape[0]
    w = np.empty(24)
    Pp = np.empty((3, 2))
    for g in range(Gn):
        for k in range(c.shape[0]):
            Pd[g, c[k]] = Pc[g, k]
            thd[g, c[k]] = thc[g, k]
        done[g] = True
        for j in range(fine.shape[0]):
            f, k = fine[j], kn[j]
            dth, sing = _predict(A[g, c[k]], Pc[g, k], A[g, f], L[g, c[k]], L[g, f], Pp, w, rtol)
            th, res = _polish(A[g, f], bb[g], L[g, f], Pp[0, 0], Pp[0, 1], thc[g, k] + dth, Pd[g, f], w,
                              iters, tol, rtol)
            thd[g, f] = _wrap(th)
            if not (res <= accept and not sing and _dist(Pd[g, f], Pp) <= 0.25 * sep[g, k]
                    and _dist(Pd[g, f], Pc[g, k]) <= 0.5 * sep[g, k]):
                done[g] = False
                break


@numba.njit(**_JIT)
def predict_modes(A0, P0, A1, l0, l1, rtol, P, dth, sing):
    """``triad._predict`` of every mode at M inputs: ``P0`` (M, modes, 3, 2) the modes'
    points at inputs ``A0`` (M, 3, 2) (lengths ``l0`` (M, 3)), predicted at ``A1``, ``l1``;
    writes ``P`` (M, modes, 3, 2), ``dth`` and ``sing`` (M, modes)."""
    w = np.empty(24)
    for m in range(A0.shape[0]):
        for j in range(P0.shape[1]):
            dth[m, j], sing[m, j] = _predict(A0[m], P0[m, j], A1[m], l0[m], l1[m], P[m, j], w, rtol)


@numba.njit(**_JIT)
def _balance(a, n):
    """Balance ``a`` (1-based, n×n) by powers of 2 in place (Parlett and Reinsch 1969),
    as before a Hessenberg QR: the eigenvalues stay, their rounding errors shrink."""
    last = False
    while not last:
        last = True
        for i in range(1, n + 1):
            r = c = 0.0
            for j in range(1, n + 1):
                if j != i:
                    c += abs(a[j, i])
                    r += abs(a[i, j])
            if c != 0.0 and r != 0.0:
                g, f, s = r / 2.0, 1.0, c + r
                while c < g:
                    f *= 2.0
                    c *= 4.0
                g = r * 2.0
                while c > g:
                    f /= 2.0
                    c /= 4.0
                if (c + r) / f < 0.95 * s:
                    last = False
                    for j in range(1, n + 1):
                        a[i, j] *= 1.0 / f
                    for j in range(1, n + 1):
                        a[j, i] *= f


@numba.njit(**_JIT)
def _small_sub(a, nn, anorm):
    """The lowest ``l`` (1-based) of the active block of ``a`` whose subdiagonal entry
    is negligible (zeroed), 1 if none."""
    for l in range(nn, 1, -1):
        s = abs(a[l - 1, l - 1]) + abs(a[l, l])
        if s == 0.0:
            s = anorm
        if abs(a[l, l - 1]) + s == s:
            a[l, l - 1] = 0.0
            return l
    return 1


@numba.njit(**_JIT)
def _two(a, nn, t, wr, wi):
    """The two eigenvalues of the trailing 2×2 block ``nn - 1, nn`` into ``wr``, ``wi``."""
    x, y, w = a[nn, nn], a[nn - 1, nn - 1], a[nn, nn - 1] * a[nn - 1, nn]
    p = 0.5 * (y - x)
    q = p * p + w
    z = np.sqrt(abs(q))
    x += t
    if q >= 0.0:
        z = p + (z if p >= 0.0 else -z)
        wr[nn - 1] = wr[nn] = x + z
        if z != 0.0:
            wr[nn] = x - w / z
        wi[nn - 1] = wi[nn] = 0.0
    else:
        wr[nn - 1] = wr[nn] = x + p
        wi[nn] = z
        wi[nn - 1] = -z


@numba.njit(**_JIT)
def _shift_start(a, nn, l, x, y, w):
    """Francis's double shift (shifts from ``x``, ``y``, ``w``): the row ``m`` where the
    sweep starts, and its first Householder vector ``p, q, r``."""
    m = nn - 2
    while True:
        z = a[m, m]
        r = x - z
        s = y - z
        p = (r * s - w) / a[m + 1, m] + a[m, m + 1]
        q = a[m + 1, m + 1] - z - r - s
        r = a[m + 2, m + 1]
        s = abs(p) + abs(q) + abs(r)
        p /= s
        q /= s
        r /= s
        if m == l:
            break
        u = abs(a[m, m - 1]) * (abs(q) + abs(r))
        v = abs(p) * (abs(a[m - 1, m - 1]) + abs(z) + abs(a[m + 1, m + 1]))
        if u + v == v:
            break
        m -= 1
    return m, p, q, r


@numba.njit(**_JIT)
def _sweep(a, nn, l, m, p, q, r):
    """One implicit double-shift QR sweep over rows ``m..nn`` of the block ``l..nn``."""
    for i in range(m + 2, nn + 1):
        a[i, i - 2] = 0.0
        if i != m + 2:
            a[i, i - 3] = 0.0
    x = 0.0
    for k in range(m, nn):
        if k != m:
            p, q = a[k, k - 1], a[k + 1, k - 1]
            r = a[k + 2, k - 1] if k != nn - 1 else 0.0
            x = abs(p) + abs(q) + abs(r)
            if x != 0.0:
                p /= x
                q /= x
                r /= x
        s = np.sqrt(p * p + q * q + r * r)
        if p < 0.0:
            s = -s
        if s == 0.0:
            continue
        if k == m:
            if l != m:
                a[k, k - 1] = -a[k, k - 1]
        else:
            a[k, k - 1] = -s * x
        p += s
        x, y, z = p / s, q / s, r / s
        q /= p
        r /= p
        for j in range(k, nn + 1):
            p = a[k, j] + q * a[k + 1, j]
            if k != nn - 1:
                p += r * a[k + 2, j]
                a[k + 2, j] -= p * z
            a[k + 1, j] -= p * y
            a[k, j] -= p * x
        for i in range(l, min(nn, k + 3) + 1):
            p = x * a[i, k] + y * a[i, k + 1]
            if k != nn - 1:
                p += z * a[i, k + 2]
                a[i, k + 2] -= p * r
            a[i, k + 1] -= p * q
            a[i, k] -= p


@numba.njit(**_JIT)
def _hqr(a, n, wr, wi):
    """The eigenvalues of the upper Hessenberg ``a`` (1-based, n×n, destroyed) into
    ``wr``, ``wi`` (1-based) by Francis's double-shift QR (EISPACK's ``hqr``, Wilkinson
    and Reinsch 1971); False if an eigenvalue took more than 60 sweeps."""
    anorm = 0.0
    for i in range(1, n + 1):
        for j in range(max(i - 1, 1), n + 1):
            anorm += abs(a[i, j])
    nn, t = n, 0.0
    while nn >= 1:
        its = 0
        while True:
            l = _small_sub(a, nn, anorm)
            x = a[nn, nn]
            if l == nn:                                # one real eigenvalue
                wr[nn], wi[nn] = x + t, 0.0
                nn -= 1
                break
            if l == nn - 1:                            # a 2×2 block
                _two(a, nn, t, wr, wi)
                nn -= 2
                break
            if its == 60:
                return False
            y, w = a[nn - 1, nn - 1], a[nn, nn - 1] * a[nn - 1, nn]
            if its == 10 or its == 20:                 # exceptional shift
                t += x
                for i in range(1, nn + 1):
                    a[i, i] -= x
                s = abs(a[nn, nn - 1]) + abs(a[nn - 1, nn - 2])
                x = y = 0.75 * s
                w = -0.4375 * s * s
            its += 1
            m, p, q, r = _shift_start(a, nn, l, x, y, w)
            _sweep(a, nn, l, m, p, q, r)
    return True


@numba.njit(**_JIT)
def companion_roots(comp, good, re, im):
    """The eigenvalues of the 6×6 companion matrices ``comp`` (K, 6, 6) (upper Hessenberg),
    balanced then by :func:`_hqr`, into ``re``, ``im`` (K, 6); 10 where not ``good`` (as
    the NumPy route's stand-in matrix), NaN where the QR does not converge."""
    a = np.zeros((7, 7))
    wr, wi = np.empty(7), np.empty(7)
    for k in range(comp.shape[0]):
        if not good[k]:
            re[k, :] = 10.0
            im[k, :] = 0.0
            continue
        for i in range(6):
            for j in range(6):
                a[i + 1, j + 1] = comp[k, i, j]
        _balance(a, 6)
        if _hqr(a, 6, wr, wi):
            re[k, :] = wr[1:]
            im[k, :] = wi[1:]
        else:
            re[k, :] = np.nan
            im[k, :] = np.nan


@numba.njit(**_JIT)
def _gap(X, a, Y, b):
    """``triad._dist`` of ``X[a]`` and ``Y[b]`` (points (k, 2)), summed as NumPy does."""
    s = 0.0
    for c in range(X.shape[1]):
        for x in range(2):
            s += (X[a, c, x] - Y[b, c, x]) ** 2
    return np.sqrt(s)


@numba.njit(**_JIT)
def _next_mode(P, valid, pred, i, a, ratio):
    """``follow_modes_batch``'s step of one path from mode ``a`` at position ``i``: the
    matched mode at ``i + 1``, or -1."""
    M = valid.shape[1]
    d1, d2, k1 = np.inf, np.inf, -1
    for b in range(M):
        d = _gap(pred[i], a, P[i + 1], b) if valid[i + 1, b] else np.inf
        if d != d:
            d = np.inf
        if d < d1 or k1 < 0:
            d1, d2, k1 = d, d1 if k1 >= 0 else d2, b
        elif d < d2:
            d2 = d
    sep = np.inf
    for b in range(M):
        if b != a and valid[i, a] and valid[i, b]:
            q = _gap(P[i], a, P[i], b)
            if q < sep:
                sep = q
    step = _gap(P[i], a, P[i + 1], k1)
    ok = np.isfinite(d1) and d1 <= ratio * d2 and step <= ratio * sep and d1 <= ratio * sep
    return k1 if ok and valid[i, a] else -1


@numba.njit(**_JIT)
def follow_batch(P, valid, pred, start, ratio, idx, status):
    """``triad.follow_modes_batch`` along D paths: ``P`` (D, N, M, k, 2), ``valid`` (D, N,
    M), ``pred`` (D, N-1, M, k, 2), ``start`` (D,); writes ``idx`` and ``status`` (D, N),
    the candidates scored only along each path's followed mode."""
    for d in range(P.shape[0]):
        idx[d, :] = -1
        status[d, :] = 3
        status[d, 0] = 0
        idx[d, 0] = start[d]
        j = start[d]
        for i in range(P.shape[1] - 1):
            if j < 0:
                break
            j = _next_mode(P[d], valid[d], pred[d], i, j, ratio)
            if j < 0:
                status[d, i + 1] = 2
            else:
                idx[d, i + 1] = j
                status[d, i + 1] = 0


@numba.njit(**_JIT)
def _k0(bc, a, l, i):
    """The part of ``triad._linear_terms``'s ``k`` (leg ``i + 1``) that does not depend on
    ``z`` (the same operations in the same order)."""
    return l[i + 1] ** 2 - l[0] ** 2 - abs(bc[i]) ** 2 - abs(a[i]) ** 2


@numba.njit(**_JIT)
def _linear(z, bc, a, kc, i):
    """``triad._linear_terms`` for the leg ``i + 1`` (0 or 1): ``w`` and ``k`` (``kc``:
    :func:`_k0` of both legs)."""
    w = z * bc[i] - a[i]
    k = kc[i] + 2.0 * (z * bc[i] * np.conj(a[i])).real
    return w, k


@numba.njit(**_JIT)
def _shifted_poly(bc, a, l, Z, E, GRID, BASIS, q):
    """``triad._poly_coefficients`` and the shift of ``_unit_circle_roots`` at one
    position: the real polynomial in ``t`` (ascending) into ``q`` (7,); returns ``σ``.
    ``Z`` (16,) the unit circle's samples, ``E`` (7, 16) the DFT's rows (z³ .. z⁻³),
    ``GRID`` and ``BASIS`` the NumPy route's tables."""
    F = np.empty(16)
    kc = (_k0(bc, a, l, 0), _k0(bc, a, l, 1))
    for n in range(16):
        w0, k0 = _linear(Z[n], bc, a, kc, 0)
        w1, k1 = _linear(Z[n], bc, a, kc, 1)
        D = w0.real * w1.imag - w0.imag * w1.real
        Nx = 0.5 * (k0 * w1.imag - k1 * w0.imag)
        Ny = 0.5 * (w0.real * k1 - w1.real * k0)
        F[n] = Nx * Nx + Ny * Ny - l[0] ** 2 * D * D
    coef = np.zeros(7, np.complex128)
    for m in range(7):
        for n in range(16):
            coef[m] += F[n] * E[m, n]
        coef[m] /= 16.0
    best, kmax = -1.0, 0
    for n in range(16):
        s = 0.0
        for m in range(7):
            s += (coef[m] * GRID[m, n]).real
        if abs(s) > best:
            best, kmax = abs(s), n
    sigma = 2 * np.pi * kmax / 16 - np.pi
    for m in range(7):
        coef[m] *= np.exp(1j * (sigma * (3 - m)))
    for p in range(7):
        q[p] = 0.0
        for m in range(7):
            q[p] += (coef[m] * BASIS[m, p]).real
    return sigma


@numba.njit(**_JIT)
def _roots(q, a, wr, wi):
    """The roots of the real polynomial ``q`` (ascending, degree 6) by its companion
    matrix (:func:`_hqr`, balanced) into ``wr``, ``wi`` (1-based); False if ``q`` is not
    usable (a non-finite coefficient, a zero leading one) or the QR does not converge."""
    lead = q[6]
    if not (np.isfinite(lead) and abs(lead) > 0):
        return False
    a[:, :] = 0.0
    for j in range(6):
        a[1, j + 1] = -q[5 - j] / lead
        if not np.isfinite(a[1, j + 1]):
            return False
    for i in range(1, 6):
        a[i + 1, i] = 1.0
    _balance(a, 6)
    return _hqr(a, 6, wr, wi)


@numba.njit(**_JIT)
def _start_point(A, bc, a, l, th):
    """``triad._position_from_angle``: P1 from the two linear equations at ``th`` (each
    coordinate A1's where it is not finite)."""
    z = np.exp(1j * th)
    kc = (_k0(bc, a, l, 0), _k0(bc, a, l, 1))
    w0, k0 = _linear(z, bc, a, kc, 0)
    w1, k1 = _linear(z, bc, a, kc, 1)
    D = w0.real * w1.imag - w0.imag * w1.real
    x = 0.5 * (k0 * w1.imag - k1 * w0.imag) / D + A[0, 0]
    y = 0.5 * (w0.real * k1 - w1.real * k0) / D + A[0, 1]
    return (x if np.isfinite(x) else A[0, 0]), (y if np.isfinite(y) else A[0, 1])


@numba.njit(**_JIT)
def _merge_sort(Pk, thk, valid, scale, P, th):
    """``triad_modes``'s last steps at one position: a candidate that repeats an earlier
    one (within 1e-7 of ``scale``) dropped, the rest sorted by angle into ``P`` (6, 3, 2)
    and ``th`` (6,), NaN-padded."""
    keep = np.zeros(6, np.bool_)
    for j in range(6):
        keep[j] = valid[j]
        for i in range(j):
            dP = (abs(Pk[j, 0, 0] - Pk[i, 0, 0]) + abs(Pk[j, 0, 1] - Pk[i, 0, 1])
                  + abs(_wrap(thk[j] - thk[i])) * scale)
            if valid[j] and valid[i] and dP <= 1e-7 * scale:
                keep[j] = False
    P[:] = np.nan
    th[:] = np.nan
    n = 0
    for j in range(6):
        if not keep[j]:
            continue
        r = n                                  # insertion by angle
        while r > 0 and th[r - 1] > thk[j]:
            th[r] = th[r - 1]
            P[r] = P[r - 1]
            r -= 1
        th[r] = thk[j]
        P[r] = Pk[j]
        n += 1


@numba.njit(**_JIT)
def modes_many(A, bb, l, Z, E, GRID, BASIS, iters, tol, accept, rtol, P, th):
    """``triad.triad_modes``'s points and angles at K positions: ``A``, ``bb`` (K, 3, 2),
    ``l`` (K, 3); writes ``P`` (K, 6, 3, 2) and ``th`` (K, 6) (sorted by angle,
    NaN-padded).  The polynomial's coefficients come from a direct 16-point DFT and its
    roots from :func:`_roots` (rounding apart from NumPy's FFT and LAPACK), each root near
    the unit circle polished by the NumPy route's Newton (:func:`_polish`)."""
    work = _modes_work()
    for k in range(A.shape[0]):
        _modes_at(A[k], bb[k], l[k], Z, E, GRID, BASIS, iters, tol, accept, rtol, P[k], th[k], work)


@numba.njit(**_JIT)
def _modes_work():
    """:func:`_modes_at`'s work arrays."""
    return (np.empty(7), np.zeros((7, 7)), np.empty(7), np.empty(7), np.empty(24), np.empty((6, 3, 2)),
            np.empty(6), np.empty(6, np.bool_), np.empty(2, np.complex128), np.empty(2, np.complex128))


@numba.njit(**_JIT)
def _modes_at(A, bb, l, Z, E, GRID, BASIS, iters, tol, accept, rtol, P, th, work):
    """:func:`modes_many` at one position: ``A``, ``bb`` (3, 2), ``l`` (3,); writes ``P``
    (6, 3, 2) and ``th`` (6,); ``work`` from :func:`_modes_work`."""
    q, a, wr, wi, w, Pk, thk, valid, bc, av = work
    for i in range(2):
        bc[i] = bb[i + 1, 0] + 1j * bb[i + 1, 1]
        av[i] = (A[i + 1, 0] - A[0, 0]) + 1j * (A[i + 1, 1] - A[0, 1])
    sigma = _shifted_poly(bc, av, l, Z, E, GRID, BASIS, q)
    ok = _roots(q, a, wr, wi)
    for j in range(6):
        t = wr[j + 1]
        valid[j] = ok and abs(wi[j + 1]) < 0.5 * 1e-3 * (1.0 + (t * t + wi[j + 1] * wi[j + 1]))
        if valid[j]:
            px, py = _start_point(A, bc, av, l, sigma + 2.0 * np.arctan(t))
            thj, res = _polish(A, bb, l, px, py, sigma + 2.0 * np.arctan(t), Pk[j], w, iters, tol, rtol)
            thk[j] = _wrap(thj)
            valid[j] = res <= accept
    scale = max(l[0], max(l[1], l[2]))
    _merge_sort(Pk, thk, valid, scale, P, th)


# --------------------------------------------------------------------------- one path
# :func:`kin.groups.triad.triad_track`'s tracker along one design's path, compiled whole:
# the plan kernel's step for a triad in a batch of designs (:func:`triad_place`).


@numba.njit(**_JIT)
def _follow(A, bb, l, start, P, th, idx, status):
    """``triad._full_follow``'s compiled route on a path of K inputs: the mode nearest
    ``start`` (3, 2) at the first input followed (:func:`_next_mode`): ``idx``, ``status``
    (K,) (all 1 when the first input has no mode), and every mode ``P`` (K, 6, 3, 2),
    ``th`` (K, 6) (:func:`_modes_at`) of the inputs reached (NaN after a loss: the
    following is causal, so they are never read)."""
    K = A.shape[0]
    work = _modes_work()
    P[:] = np.nan
    th[:] = np.nan
    _modes_at(A[0], bb, l[0], _Z16, _DFT, _GRID, _BASIS, _ITERS, 1e-12, _ACCEPT, _RTOL, P[0], th[0], work)
    valid = np.zeros((K, 6), np.bool_)
    valid[0] = np.isfinite(th[0])
    j, best = -1, np.inf
    for m in range(6):
        if valid[0, m]:
            d = _dist(P[0, m], start)
            if d < best:                           # (NaN: never)
                j, best = m, d
    idx[:] = -1
    status[:] = 3
    if j < 0:
        status[:] = 1
        return
    pred = np.empty((K, 6, 3, 2))                  # (only the followed mode's: the others are never read)
    w = np.empty(24)
    status[0], idx[0] = 0, j
    for i in range(K - 1):                         # (the modes of an input only once it is reached)
        _modes_at(A[i + 1], bb, l[i + 1], _Z16, _DFT, _GRID, _BASIS, _ITERS, 1e-12, _ACCEPT, _RTOL, P[i + 1],
                  th[i + 1], work)
        valid[i + 1] = np.isfinite(th[i + 1])
        _predict(A[i], P[i, j], A[i + 1], l[i], l[i + 1], pred[i, j], w, _RTOL)
        j = _next_mode(P, valid, pred, i, j, 0.5)
        if j < 0:
            status[i + 1] = 2
            break
        idx[i + 1], status[i + 1] = j, 0


@numba.njit(**_JIT)
def _take(Pm, thm, idx, lo, P, th):
    """The followed mode ``idx`` of each input (from ``Pm``, ``thm``) into ``P``, ``th``
    from input ``lo`` on (where it was followed)."""
    for r in range(idx.size):
        if idx[r] >= 0:
            P[lo + r] = Pm[r, idx[r]]
            th[lo + r] = thm[r, idx[r]]


@numba.njit(**_JIT)
def _separation(Pm, thm, j, Pc):
    """``triad._separation`` at one input: the followed pose ``Pc`` (mode ``j``)'s distance
    to the nearest other mode (``inf``: alone)."""
    sep = np.inf
    for m in range(6):
        if m != j and np.isfinite(thm[m]):
            d = _dist(Pm[m], Pc)
            if d < sep:
                sep = d
    return sep


@numba.njit(**_JIT)
def track_path(A, b, l, start, stride, P, th, status):
    """``triad._track`` (:func:`kin.groups.triad.triad_track`'s tracker) compiled: one mode
    of a triad (inner joints ``b`` (3, 2) in its reference) followed along the anchors
    ``A`` (N, 3, 2) from the one nearest ``start`` (3, 2) at ``A[0]``, legs ``l`` (N, 3)
    (per input: class IV's reduction's third leg varies); writes ``P`` (N, 3, 2),
    ``th`` and ``status`` (N,) (0 ok, 1 no assembly, 2 lost here, 3 after).  All modes at
    every ``stride``-th input, each other input predicted from its nearest such one and
    Newton-polished, accepted only well inside its mode's basin (else its interval is
    followed at full resolution), the same steps, modes and statuses as the NumPy route
    (the floats to rounding)."""
    N = A.shape[0]
    bb = b - b[0]
    P[:] = np.nan
    th[:] = np.nan
    status[:] = 3
    if N == 0:
        return
    if stride <= 1 or N <= 2 * stride:
        Pm, thm, idx = np.empty((N, 6, 3, 2)), np.empty((N, 6)), np.empty(N, np.int64)
        _follow(A, bb, l, start, Pm, thm, idx, status)
        _take(Pm, thm, idx, 0, P, th)
        return
    nc = (N - 1) // stride + (1 if (N - 1) % stride else 0) + 1
    c = np.empty(nc, np.int64)                    # (``triad._coarse``: every stride-th input and the last)
    for k in range(nc):
        c[k] = min(k * stride, N - 1)
    Pm, thm, ic, sc = np.empty((nc, 6, 3, 2)), np.empty((nc, 6)), np.empty(nc, np.int64), np.empty(nc, np.int64)
    _follow(A[c], bb, l[c], start, Pm, thm, ic, sc)
    if ic[0] < 0:
        status[:] = 1
        return
    kmax = 0
    while kmax + 1 < nc and ic[kmax + 1] >= 0:
        kmax += 1
    Pc, thc, sep = np.empty((kmax + 1, 3, 2)), np.empty(kmax + 1), np.empty(kmax + 1)
    for k in range(kmax + 1):
        Pc[k], thc[k] = Pm[k, ic[k]], thm[k, ic[k]]
        sep[k] = _separation(Pm[k], thm[k], ic[k], Pc[k])
        P[c[k]], th[c[k]], status[c[k]] = Pc[k], thc[k], 0
    bad = np.zeros(nc, np.bool_)
    w, Pp = np.empty(24), np.empty((3, 2))
    for f in range(c[kmax]):
        left = f // stride
        if f == c[left]:
            continue
        k = left if f - c[left] <= c[left + 1] - f else left + 1
        dth, sing = _predict(A[c[k]], Pc[k], A[f], l[c[k]], l[f], Pp, w, _RTOL)
        Pf = np.empty((3, 2))
        thf, res = _polish(A[f], bb, l[f], Pp[0, 0], Pp[0, 1], thc[k] + dth, Pf, w, _ITERS, 1e-12, _RTOL)
        if res <= _ACCEPT and not sing and _dist(Pf, Pp) <= 0.25 * sep[k] and _dist(Pf, Pc[k]) <= 0.5 * sep[k]:
            P[f], th[f], status[f] = Pf, _wrap(thf), 0
        else:
            bad[left] = True
    if kmax < nc - 1:
        bad[kmax] = True
    _refine(A, b, bb, l, c, kmax, bad, Pc, P, th, status)
    _first_failure(P, th, status)


@numba.njit(**_JIT)
def _refine(A, b, bb, l, c, kmax, bad, Pc, P, th, status):
    """``triad._refine``: the refused intervals ``bad`` (and the tail after ``c[kmax]``)
    followed at full resolution, in place; a loss inside one, or arriving in another mode
    than the coarse point's, loses the rest."""
    N, lmax = A.shape[0], np.max(l)
    for k in range(c.size):
        if not bad[k]:
            continue
        lo = c[k]
        hi = N - 1 if k >= kmax else c[k + 1]
        if status[lo] != 0:
            break
        n = hi - lo + 1
        Pm, thm, idx, st = np.empty((n, 6, 3, 2)), np.empty((n, 6)), np.empty(n, np.int64), np.empty(n, np.int64)
        _follow(A[lo:hi + 1], bb, l[lo:hi + 1], P[lo].copy(), Pm, thm, idx, st)
        _take(Pm, thm, idx, lo, P, th)
        status[lo:hi + 1] = st
        last = idx[n - 1] >= 0
        if not (last and k < kmax and _dist(P[hi], Pc[k + 1]) <= 1e-9 * lmax):
            P[hi + 1:] = np.nan
            th[hi + 1:] = np.nan
            status[hi + 1:] = 3
            if last and k < kmax:                 # reached another mode: refuse it
                status[hi] = 2
                P[hi] = np.nan
                th[hi] = np.nan
            break


@numba.njit(**_JIT)
def _first_failure(P, th, status):
    """``triad._first_failure_final``: after the first failed input every later one is lost."""
    for i in range(status.size):
        if status[i] != 0:
            if status[i] != 1:
                status[i] = 2
            status[i + 1:] = 3
            P[i:] = np.nan
            th[i:] = np.nan
            return


@numba.njit(**_JIT)
def _known_pins(k, ip, fp, N, T, C, S, ox, oy):
    """The group's first ``k`` outer pins at every input, each carried by its known link
    ``ip[i]`` from its offset ``fp[2i:2i+2]``: ``(N, k, 2)`` as they are and about
    ``(ox, oy)``, and whether all are finite."""
    Pa, Pd = np.empty((N, k, 2)), np.empty((N, k, 2))
    finite = True
    for n in range(N):
        for i in range(k):
            x, y = carry(ip[i], n, T, C, S, fp[2 * i], fp[2 * i + 1])
            Pa[n, i, 0], Pa[n, i, 1] = x, y
            Pd[n, i, 0], Pd[n, i, 1] = x - ox, y - oy
            finite = finite and np.isfinite(x) and np.isfinite(y)
    return Pa, Pd, finite


@numba.njit(**_JIT)
def triad_place(ip, fp, X, W, F, T, C, S, PP, out) -> None:
    """A triad step of the plan kernel (:mod:`kin.kernel`) along one design's N inputs,
    as :meth:`kin.groups.triad.TriadStep.positions` gives a batch of designs: the outer
    joints carried by their known links from the pose store ``T``, ``C``, ``S``, the mode
    of the reference followed (:func:`track_path`, about the first outer joint's
    reference point), the ternary placed from its first inner joint with the followed
    rotation (its angle row set) and each binary from its outer joint along its leg (its
    angle pending, ``PP``); ``out`` each input's status (0 ok, 1 no assembly, 2 lost
    here, 3 after).  An input whose known pins are not finite loses the whole path, as
    the NumPy route does (:func:`kin.groups.triad.track_designs`).

    ``ip`` = (known links of A1..A3, the ternary, binaries 1..3); ``fp`` =
    (:func:`kin.groups.triad.triad_lower`'s layout)."""
    N = X.shape[0]
    ox, oy = fp[27], fp[28]
    Aa, A, finite = _known_pins(3, ip, fp, N, T, C, S, ox, oy)
    for i in range(4, 7):
        PP[ip[i]] = 1
    if not finite:
        out[:] = 3
        return
    b, l = np.empty((3, 2)), np.empty((N, 3))
    for i in range(3):
        b[i, 0], b[i, 1] = fp[6 + 2 * i], fp[7 + 2 * i]
        for n in range(N):
            l[n, i] = fp[12 + i]
    P, th, status = np.empty((N, 3, 2)), np.empty(N), np.empty(N, np.int64)
    track_path(A, b, l, b, _STRIDE, P, th, status)
    k = ip[3]
    for n in range(N):
        out[n] = status[n]
        if status[n] != 0:
            continue
        c, s = np.cos(th[n]), np.sin(th[n])
        place(k, n, T, C, S, P[n, 0, 0] + ox, P[n, 0, 1] + oy, fp[29], fp[30], c, s)
        T[k, 2, n] = th[n]
        for i in range(3):
            px, py = P[n, i, 0] + ox, P[n, i, 1] + oy
            place_along(ip[4 + i], n, T, C, S, Aa[n, i, 0], Aa[n, i, 1], fp[15 + 2 * i], fp[16 + 2 * i],
                        px - Aa[n, i, 0], py - Aa[n, i, 1], fp[21 + 2 * i], fp[22 + 2 * i])


@numba.njit(**_JIT)
def class4_place(ip, fp, X, W, F, T, C, S, PP, out) -> None:
    """A class IV group's step of the plan kernel along one design's N inputs, as
    :meth:`kin.groups.class4.Class4Step.positions` gives a batch of designs: the outer
    pins O1, O2 carried by their known links, the group's triad reduction in T1's frame
    (anchors J1 − O1, J2 − O1 and O1, legs |J1J3|, |J2J4| and |O1O2| along the inputs)
    followed from the reference (:func:`track_path`), the rotations θ1 (of the line O1O2
    against the reduction's) and θ2 = θ1 + φ, the ternaries placed at their outer pins
    (their angle rows set) and the binaries from J1, J2 toward J3, J4 (pending, ``PP``);
    ``out`` each input's status, the whole path lost where a known pin is not finite.

    ``ip`` = (known links of O1, O2; ternaries 1, 2; binaries 1, 2); ``fp`` =
    (:func:`kin.groups.class4.class4_lower`'s layout)."""
    N = X.shape[0]
    if N == 0:                             # (no input: nothing to follow)
        return
    ox, oy = fp[14], fp[15]
    Oa, Od, finite = _known_pins(2, ip, fp, N, T, C, S, ox, oy)
    PP[ip[4]] = PP[ip[5]] = 1
    if not finite:
        out[:] = 3
        return
    r = np.empty((4, 2))
    for k in range(4):
        r[k, 0], r[k, 1] = fp[4 + 2 * k], fp[5 + 2 * k]
    A, b, l, start = np.zeros((N, 3, 2)), np.zeros((3, 2)), np.empty((N, 3)), np.empty((3, 2))
    for n in range(N):
        A[n, 0], A[n, 1] = r[0], r[1]
        ex, ey = Od[n, 1, 0] - Od[n, 0, 0], Od[n, 1, 1] - Od[n, 0, 1]
        l[n, 0], l[n, 1], l[n, 2] = fp[12], fp[13], np.hypot(ex, ey)
    b[0], b[1] = r[2], r[3]
    for k in range(2):                     # (J3, J4 of the reference pose at the first input, then O2, about O1)
        start[k, 0] = (Od[0, 1, 0] + r[2 + k, 0]) - Od[0, 0, 0]
        start[k, 1] = (Od[0, 1, 1] + r[2 + k, 1]) - Od[0, 0, 1]
    start[2, 0], start[2, 1] = Od[0, 1, 0] - Od[0, 0, 0], Od[0, 1, 1] - Od[0, 0, 1]
    P, phi, status = np.empty((N, 3, 2)), np.empty(N), np.empty(N, np.int64)
    track_path(A, b, l, start, _STRIDE, P, phi, status)
    J = np.empty((4, 2))
    for n in range(N):
        out[n] = status[n]
        if status[n] != 0:
            continue
        ex, ey = Od[n, 1, 0] - Od[n, 0, 0], Od[n, 1, 1] - Od[n, 0, 1]
        th1 = _wrap(np.arctan2(ey, ex) - np.arctan2(P[n, 2, 1], P[n, 2, 0]))
        th2 = _wrap(th1 + phi[n])
        for i, th in ((0, th1), (1, th2)):
            c, s = np.cos(th), np.sin(th)
            for k in (2 * i, 2 * i + 1):   # (class4_points)
                J[k, 0] = Od[n, i, 0] + (c * r[k, 0] - s * r[k, 1]) + ox
                J[k, 1] = Od[n, i, 1] + (s * r[k, 0] + c * r[k, 1]) + oy
            t = ip[2 + i]
            place(t, n, T, C, S, Oa[n, i, 0], Oa[n, i, 1], fp[16 + 2 * i], fp[17 + 2 * i], c, s)
            T[t, 2, n] = th
        for i in range(2):
            place_along(ip[4 + i], n, T, C, S, J[i, 0], J[i, 1], fp[20 + 2 * i], fp[21 + 2 * i],
                        J[i + 2, 0] - J[i, 0], J[i + 2, 1] - J[i, 1], fp[24 + 2 * i], fp[25 + 2 * i])
