"""The numba side of the batched triad tracker (:func:`kin.groups.triad.track_designs`):
the Taylor prediction and Newton polish of every fine input, compiled.

Imported only when the compiled route is wanted (:func:`kin.kernel.wanted`, passed down
by :mod:`kin.design` as the step's ``jit``); the NumPy functions of
:mod:`kin.groups.triad` stay the oracle and the route when the kernel is off.  Each
function below does the NumPy route's operations in the same order, one design and one
input at a time with scalars (no temporaries), so the floats agree to rounding (NumPy's
and libm's ``cos``/``sin`` may differ by an ulp) and the acceptance tests give the same
answers.  The prediction is the second-order Taylor step of the triad's rates (the
Cramer-rule system of Vasechkin et al. 2017, extended to the triad), the polish Newton
on its three closure equations (Hunt 1983 for the modes).
"""
from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["fill_fine", "polish_many", "predict_many"]

_JIT = dict(cache=True, error_model="numpy", nogil=True)


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
def polish_many(A, bb, l, p, th, iters, tol, rtol, P, tho, res):
    """``triad._polish`` over K inputs: ``A`` and ``bb`` (K, 3, 2), ``l`` (K, 3), ``p``
    (K, 2), ``th`` (K,); writes ``P`` (K, 3, 2), ``tho`` and ``res`` (K,)."""
    w = np.empty(24)
    for k in range(A.shape[0]):
        tho[k], res[k] = _polish(A[k], bb[k], l[k], p[k, 0], p[k, 1], th[k], P[k], w, iters, tol, rtol)


@numba.njit(**_JIT)
def predict_many(A0, P0, A1, l0, l1, rtol, P, dth, sing):
    """``triad._predict`` over K inputs (arrays (K, 3, 2) and (K, 3)); writes ``P``
    (K, 3, 2), ``dth`` and ``sing`` (K,)."""
    w = np.empty(24)
    for k in range(A0.shape[0]):
        dth[k], sing[k] = _predict(A0[k], P0[k], A1[k], l0[k], l1[k], P[k], w, rtol)
