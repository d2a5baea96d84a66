"""The numba side of the batched polish's trust-region step
(:func:`.optimise._tr_propose`, :func:`.optimise._tr_accept`): K least-squares subproblems, each solved from its
Jacobian's SVD, in one compiled call.

Imported only when populations run compiled (:func:`multiloop.kin.kernel.compiled_batches`),
with the kernel's disk cache (``cache=True``).  Each design's step is the NumPy route's
(:func:`.optimise._tr_steps`, itself SciPy's ``solve_lsq_trust_region``: Moré 1977)
operation for operation, its sums in index order where NumPy's ``einsum`` may pair them
otherwise: the two agree to rounding (``tests/test_polish_batch.py``).  The NumPy route
took about 150 µs a call whatever K (some forty array operations of a few elements).
"""
from __future__ import annotations

import numba
import numpy as np

from multiloop.kin._scalar_nb import JIT as _JIT

__all__ = ["tr_steps", "tr_propose", "tr_accept"]


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


@numba.njit(**_JIT)
def tr_propose(W, s, Vt, R, J, radius, alpha):
    """:func:`tr_steps`'s steps and parameters, and each step's predicted reduction
    ``|r|² − |r + J h|² = −(2 r·Jh + |Jh|²)`` (``J`` (K, m, n))."""
    h, al = tr_steps(W, s, Vt, R, radius, alpha)
    K, m, n = J.shape
    pred = np.empty(K)
    for k in range(K):
        rj, jj = 0.0, 0.0
        for i in range(m):
            jh = 0.0
            for j in range(n):
                jh += J[k, i, j] * h[k, j]
            rj += R[k, i] * jh
            jj += jh * jh
        pred[k] = -(2.0 * rj + jj)
    return h, al, pred


@numba.njit(**_JIT)
def tr_accept(F, Fn, pred, h, U, radius, alpha):
    """SciPy ``trf``'s verdict on K steps (:func:`.optimise._tr_accept`, the same tests in
    the same order): the new radii, parameters and whether each design has stopped."""
    K, n = h.shape
    new_r = np.empty(K)
    new_a = np.empty(K)
    done = np.empty(K, np.bool_)
    for k in range(K):
        gain = F[k] - Fn[k]
        p = pred[k]
        if p > 0:
            rho = gain / p
        elif p == 0 and gain == 0:
            rho = 1.0
        else:
            rho = 0.0
        sh, su = 0.0, 0.0
        for j in range(n):
            sh += h[k, j] * h[k, j]
            su += U[k, j] * U[k, j]
        step = np.sqrt(sh)
        r = radius[k]
        if rho < 0.25:
            nr = 0.25 * step
        elif rho > 0.75 and step > 0.95 * r:
            nr = 2.0 * r
        else:
            nr = r
        d = (gain < 1e-15 * F[k] and rho > 0.25) or step < 1e-15 * (1e-15 + np.sqrt(su))
        done[k] = d
        new_r[k] = r if d else nr
        new_a[k] = alpha[k] if d else alpha[k] * r / (nr if nr > 0 else 1.0)
    return new_r, new_a, done
