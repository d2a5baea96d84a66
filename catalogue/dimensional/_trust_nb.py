"""The numba side of the batched polish's trust-region step
(:func:`.optimise._tr_steps`): K least-squares subproblems, each solved from its
Jacobian's SVD, in one compiled call.

Imported only when populations run compiled (:func:`multiloop.kin.kernel.compiled_batches`),
with the kernel's disk cache (``cache=True``).  Each design's step is the NumPy route's
(:func:`.optimise._tr_steps_numpy`, itself SciPy's ``solve_lsq_trust_region``: Moré 1977)
operation for operation, its sums in index order where NumPy's ``einsum`` may pair them
otherwise: the two agree to rounding (``tests/test_polish_batch.py``).  The NumPy route
took about 150 µs a call whatever K (some forty array operations of a few elements).
"""
from __future__ import annotations

import numba
import numpy as np

__all__ = ["tr_steps"]

_JIT = dict(cache=True, error_model="numpy", nogil=True)


@numba.njit(**_JIT)
def _phi(suf, s, al, radius):
    """The secular function ``|suf / (s² + al)| − radius`` and its derivative by ``al``."""
    sq, der = 0.0, 0.0
    for i in range(s.size):
        den = s[i] * s[i] + al
        v = suf[i] / den
        sq += v * v
        der += suf[i] ** 2 / den ** 3
    norm = np.sqrt(sq)
    return norm - radius, -der / norm


@numba.njit(**_JIT)
def tr_steps(W, s, Vt, R, radius, alpha):
    """The steps ``h`` (K, n) and Levenberg–Marquardt parameters of K problems
    ``|r + J h|`` within ``|h| <= radius`` (``J`` by its SVD ``W`` (K, m, r), ``s``
    (K, r), ``Vt`` (K, r, n)), warm-started from ``alpha`` (K,)."""
    K, m, r = W.shape
    n = Vt.shape[2]
    eps = np.finfo(np.float64).eps
    h = np.empty((K, n))
    out = np.empty(K)
    uf = np.empty(r)
    suf = np.empty(r)
    sk = np.empty(r)
    for k in range(K):
        for i in range(r):
            sk[i] = s[k, i]
            acc = 0.0
            for j in range(m):
                acc += W[k, j, i] * R[k, j]
            uf[i] = acc
            suf[i] = sk[i] * acc
        rad = radius[k]
        full = m >= n and sk[r - 1] > eps * m * sk[0]
        if full:
            gn2 = 0.0
            for j in range(n):
                acc = 0.0
                for i in range(r):
                    acc += Vt[k, i, j] * (uf[i] / sk[i])
                h[k, j] = -acc
                gn2 += acc * acc
            if np.sqrt(gn2) <= rad:
                out[k] = 0.0
                continue
        sq = 0.0
        for i in range(r):
            sq += suf[i] * suf[i]
        upper = np.sqrt(sq) / rad
        lower = 0.0
        if full:
            f0, d0 = _phi(suf, sk, 0.0, rad)
            lower = -f0 / d0
        al = alpha[k]
        if not full and al == 0.0:
            al = max(1e-3 * upper, np.sqrt(max(lower * upper, 0.0)))
        for _ in range(10):
            if al < lower or al > upper:
                al = max(1e-3 * upper, np.sqrt(max(lower * upper, 0.0)))
            f, d = _phi(suf, sk, al, rad)
            if f < 0:
                upper = al
            ratio = f / d
            lower = max(lower, al - ratio)
            al = al - (f + rad) * ratio / rad
            if abs(f) < 0.01 * rad:
                break
        h2 = 0.0
        for j in range(n):
            acc = 0.0
            for i in range(r):
                acc += Vt[k, i, j] * (suf[i] / (sk[i] * sk[i] + al))
            h[k, j] = -acc
            h2 += acc * acc
        scale = rad / np.sqrt(h2)
        for j in range(n):
            h[k, j] *= scale
        out[k] = al
    return h, out
