"""The numba side of :mod:`kin.kernel`: every registered scalar step compiled, and the
one kernel that runs a lowered plan over a batch of positions.

Imported only by :func:`kin.kernel.load` (importing numba costs ~0.3 s).  The compiled
code is cached on disk (``cache=True``, numba's ``__pycache__/*.nbi``/``*.nbc`` beside
this file, or ``NUMBA_CACHE_DIR``); numba keys the kernel's cache on *this* file's
timestamp, so after editing a kind's scalar function (``kin/groups/*.py``) clear the
cache or touch this file.
"""
from __future__ import annotations

import numba
import numpy as np
from numba.extending import register_jitable

from .groups.base import SCALAR_HELPERS
from .groups.registry import COMPILED

__all__ = ["solve_positions", "SLOTS"]

#: the number of scalar steps the kernel dispatches on (the registry's order)
SLOTS = 8
_JIT = dict(cache=True, error_model="numpy", nogil=True)
#: the steps are inlined into the kernel at numba's IR level (no call, no reference counting
#: per step); the helpers they call stay functions (LLVM inlines them): inlining those at the
#: IR level too gave wrong results with numba 0.68 (a step's locals clobbered, the
#: kernel-vs-NumPy tests caught it)
_INLINE = dict(_JIT, inline="always")


def _unused(ip, fp, X, n, W, factor, T, C, S, PP) -> int:  # pragma: no cover - a free slot
    return 1


for _helper in SCALAR_HELPERS:            # helpers the scalar steps call
    register_jitable(**_JIT)(_helper)
if len(COMPILED) > SLOTS:  # pragma: no cover - a new kind needs a branch below
    raise ImportError(f"kin._kernel_nb dispatches on {SLOTS} compiled steps; the registry has {len(COMPILED)}")
_s0, _s1, _s2, _s3, _s4, _s5, _s6, _s7 = (numba.njit(**_INLINE)(f) for f in
                                          (*COMPILED.values(), *(_unused,) * (SLOTS - len(COMPILED))))


@numba.njit(**_INLINE)
def _failed(st, k, n, unknown, T, C, S, fail) -> None:
    """Step k failed at position n with status ``st``: its links are NaN there, and the
    position's status is the first failure's."""
    if fail[n] == 0:
        fail[n] = st
    for j in range(unknown.shape[1]):
        u = unknown[k, j]
        if u >= 0:
            T[u, 0, n] = T[u, 1, n] = T[u, 2, n] = C[u, n] = S[u, n] = np.nan


@numba.njit(**_JIT)
def solve_positions(codes, ints, floats, unknown, steps, X, W, F, T, C, S, fail, pend):
    """Solve the steps ``steps`` of a lowered plan at every row of ``X`` (M, n_drivers),
    step by step, each over all positions (one loop per kind: no dispatch per position).

    Writes the steps' links into the pose store ``T`` (n_links, 3, M) (x, y, θ of each
    link's reference point; the frame's row set by the caller) with their cos and sin
    ``C``, ``S`` (n_links, M), ``fail`` (M,): the status of the first failing step (0
    where every step assembles), and ``pend`` (n_links,): 1 for the links whose angle
    row is left to the caller (``arctan2(S, C)``, as the NumPy path computes it).  ``W``
    holds the cos and sin the steps asked for, ``F`` (n_steps, 1 or M) each step's
    branch factor.  A failing step's links are NaN at that position, and so are the
    links of the steps after it that read them, as in the NumPy path.
    """
    M = X.shape[0]
    for i in range(steps.size):
        k = steps[i]
        c, ip, fp, f = codes[k], ints[k], floats[k], F[k]
        w = f.size > 1
        if c == 0:
            for n in range(M):
                st = _s0(ip, fp, X, n, W, f[n] if w else f[0], T, C, S, pend)
                if st != 0:
                    _failed(st, k, n, unknown, T, C, S, fail)
        elif c == 1:
            for n in range(M):
                st = _s1(ip, fp, X, n, W, f[n] if w else f[0], T, C, S, pend)
                if st != 0:
                    _failed(st, k, n, unknown, T, C, S, fail)
        elif c == 2:
            for n in range(M):
                st = _s2(ip, fp, X, n, W, f[n] if w else f[0], T, C, S, pend)
                if st != 0:
                    _failed(st, k, n, unknown, T, C, S, fail)
        elif c == 3:
            for n in range(M):
                st = _s3(ip, fp, X, n, W, f[n] if w else f[0], T, C, S, pend)
                if st != 0:
                    _failed(st, k, n, unknown, T, C, S, fail)
        elif c == 4:
            for n in range(M):
                st = _s4(ip, fp, X, n, W, f[n] if w else f[0], T, C, S, pend)
                if st != 0:
                    _failed(st, k, n, unknown, T, C, S, fail)
        elif c == 5:
            for n in range(M):
                st = _s5(ip, fp, X, n, W, f[n] if w else f[0], T, C, S, pend)
                if st != 0:
                    _failed(st, k, n, unknown, T, C, S, fail)
        elif c == 6:
            for n in range(M):
                st = _s6(ip, fp, X, n, W, f[n] if w else f[0], T, C, S, pend)
                if st != 0:
                    _failed(st, k, n, unknown, T, C, S, fail)
        else:
            for n in range(M):
                st = _s7(ip, fp, X, n, W, f[n] if w else f[0], T, C, S, pend)
                if st != 0:
                    _failed(st, k, n, unknown, T, C, S, fail)
