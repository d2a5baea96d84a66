"""The numba side of free-timing matching (:meth:`.objective.Problem.batch`): the
reachable curve of each candidate, its driver-ordered walks and the monotone
assignment of the targets to the walk's samples, for a whole population in one call.

Imported only when the compiled kernel is in use (:func:`multiloop.kin.kernel.wanted`),
with the kernel's disk cache (``cache=True``).  Each operation is the NumPy route's
(:meth:`.objective.Problem.curve`, :meth:`~.objective.Problem.orders`,
:meth:`~.objective.Problem.sqdist`, ``_dp``) in the same order, so the costs agree
with it bit for bit; ``tests/test_synthesis_kernel.py`` compares both.
"""
from __future__ import annotations

import numba
import numpy as np

from multiloop.kin._scalar_nb import JIT as _JIT

__all__ = ["free_timing_costs"]


@numba.njit(**_JIT)
def _sqd(f, t, inv, ang):
    """Squared relative distance of a feature ``f`` (c,) to a target ``t`` (c,)
    (:meth:`~.objective.Problem.sqdist`: the last column an angle, wrapped, when ``ang``)."""
    c = f.size
    out = 0.0
    for j in range(c):
        d = f[j] - t[j]
        if ang and j == c - 1:
            d = (d + np.pi) % (2.0 * np.pi) - np.pi
            if c == 1:
                d = d * inv
        else:
            d = d * inv
        out = d * d if j == 0 else out + d * d
    return out


@numba.njit(**_JIT)
def _distances(Fp, Tp, idx, valid, inv, ang, fx, fy, d2):
    """``d2[i, k]``: the squared relative distance of target i to the walk's sample k
    (``inf`` where the sample is not reached).  A path's features are first gathered in
    walk order (``fx``, ``fy``; ``inf`` where not reached, whose distance is then ``inf``
    too), so that the rows are computed in straight, vectorised loops."""
    N, M, c = Tp.shape[0], idx.size, Fp.shape[1]
    if c == 2 and not ang:                 # a path: the common case, written out
        for k in range(M):
            if valid[k]:
                fx[k], fy[k] = Fp[idx[k], 0], Fp[idx[k], 1]
            else:
                fx[k], fy[k] = np.inf, np.inf
        for i in range(N):
            tx, ty = Tp[i, 0], Tp[i, 1]
            row = d2[i]
            for k in range(M):
                dx = (fx[k] - tx) * inv
                dy = (fy[k] - ty) * inv
                row[k] = dx * dx + dy * dy
        return
    for i in range(N):
        for k in range(M):
            d2[i, k] = _sqd(Fp[idx[k]], Tp[i], inv, ang) if valid[k] else np.inf


@numba.njit(**_JIT)
def _leading(ok, p, start, stop, step):
    """How many of ``ok[p, start], ok[p, start + step], …`` (before ``stop``) are true
    before the first false one."""
    n = 0
    for k in range(start, stop, step):
        if not ok[p, k]:
            break
        n += 1
    return n


@numba.njit(**_JIT)
def _assign(d2, cols, acc):
    """Cheapest monotone assignment of the targets (rows of ``d2``) to the samples taken
    in the column order ``cols`` (``_dp``: acc = d2[0]; acc = d2[i] + running min, the
    running minimum taken in the same pass)."""
    N, M = d2.shape
    for k in range(M):
        acc[k] = d2[0, cols[k]]
    for i in range(1, N):
        m = acc[0]
        for k in range(M):
            a = acc[k]
            m = a if a < m else m
            acc[k] = d2[i, cols[k]] + m
    best = acc[0]
    for k in range(1, M):
        best = acc[k] if acc[k] < best else best
    return best


@numba.njit(**_JIT)
def _assign_both(d2, back, accf, accb):
    """:func:`_assign` of the forward walk (the columns in order) and of the backward one
    (columns ``back``) in one pass: two independent running minima per cell, so that
    neither waits on the other's (the pass is bound by the minimum's latency)."""
    N, M = d2.shape
    for k in range(M):
        accf[k] = d2[0, k]
        accb[k] = d2[0, back[k]]
    for i in range(1, N):
        mf, mb = accf[0], accb[0]
        row = d2[i]
        for k in range(M):
            a = accf[k]
            mf = a if a < mf else mf
            accf[k] = row[k] + mf
            b = accb[k]
            mb = b if b < mb else mb
            accb[k] = row[back[k]] + mb
    bf, bb = accf[0], accb[0]
    for k in range(1, M):
        bf = accf[k] if accf[k] < bf else bf
        bb = accb[k] if accb[k] < bb else bb
    return bf, bb


@numba.njit(**_JIT)
def free_timing_costs(F, T, inv, ok, rotary, ang, forward, backward, out):
    """Free-timing cost of each candidate: ``out[p]`` = the smallest sum of squared
    relative distances (``inv[p]`` = 1 / target size) of the targets ``T[p]`` (N, c) to
    the features ``F[p]`` (M, c) of the grid samples reached continuously from the
    reference (``ok[p]`` (M,)), assigned in driver order along the forward walk and/or
    (``backward``) the backward one; ``inf`` when no sample is reached.
    ``rotary``: the grid is one turn (else half forward, half backward from the
    reference)."""
    P, M, N = F.shape[0], F.shape[1], T.shape[1]
    idx = np.empty(M, np.int64)
    valid = np.empty(M, np.bool_)
    d2 = np.empty((N, M))
    acc, accb = np.empty(M), np.empty(M)
    fx, fy = np.empty(M), np.empty(M)
    ahead, back = np.arange(M), np.empty(M, np.int64)
    for p in range(P):
        full = False
        if rotary:
            f = _leading(ok, p, 0, M, 1)
            full = f == M
            b = 0 if full else _leading(ok, p, M - 1, 0, -1)
            if full:
                k0, best = 0, np.inf
                for k in range(M):
                    v = _sqd(F[p, k], T[p, 0], inv[p], ang)
                    if ok[p, k] and v < best:
                        k0, best = k, v
                s = (k0 - 2) % M
                for k in range(M):
                    idx[k] = (s + k) % M
                    valid[k] = True
            else:
                for k in range(M):
                    idx[k] = (k - b) % M
                    valid[k] = k < b + f
        else:
            half = M // 2
            f = _leading(ok, p, 0, half, 1)
            b = _leading(ok, p, half, M, 1)
            for k in range(M):
                valid[k] = k < b + f
                idx[k] = (half + (b - 1 - k) if k < b else k - b) if valid[k] else 0
        _distances(F[p], T[p], idx, valid, inv[p], ang, fx, fy, d2)
        c0 = 4 if full else M - 1    # the backward walk: the forward one reversed (a closed curve's shifted by 5)
        for k in range(M):
            back[k] = c0 - k if k <= c0 else c0 - k + M
        if forward and backward:
            cf, cb = _assign_both(d2, back, acc, accb)
            out[p] = min(cf, cb)
        elif forward:
            out[p] = _assign(d2, ahead, acc)
        elif backward:
            out[p] = _assign(d2, back, acc)
        else:
            out[p] = np.inf
