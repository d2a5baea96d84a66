"""The numba side of :mod:`kin.kernel`: every registered scalar step compiled, and the
one kernel that runs a lowered plan over a batch of positions.

Imported only by :func:`kin.kernel.load` (importing numba costs ~0.3 s).  The compiled
code is cached on disk (``cache=True``, numba's ``__pycache__/*.nbi``/``*.nbc`` beside
this file, or ``NUMBA_CACHE_DIR``).  numba keys the kernel's cache on *this* file
alone, so on import the files of the scalar steps, lowerings and helpers it compiles
(``kin/groups/*.py``), the registry and its adapters are registered as its sources
(:func:`_fresh_cache`, :func:`kin._jit_cache.depends_on`): after an edit there the cache
is rebuilt once.
"""
from __future__ import annotations

import inspect
import types

import numba
import numpy as np

from ._jit_cache import depends_on
from ._scalar_nb import JIT as _JIT
from .groups.base import SCALAR_HELPERS, SINCOS_MEDIUM, arctan2, sincos_medium
from .groups.registry import COMPILED, LOWERING, TRACKED
from .groups.step import Deferred

__all__ = ["solve_positions", "solve_motion", "solve_designs", "lower_designs", "finish_rows", "SLOTS"]


def _fresh_cache() -> None:
    """Register the files of the compiled steps, lowerings and helpers, the registry (its
    order is the kernel's dispatch) and its adapters as this file's cache's sources
    (numba's cache would otherwise keep the old code)."""
    from .groups import registry
    depends_on(__file__, {inspect.getsourcefile(_python(f)) for f in (*COMPILED.values(), *LOWERING.values(),
                                                                      *SCALAR_HELPERS)}
               | {registry.__file__} | {inspect.getsourcefile(a) for a in registry.BUILT_IN})


def _python(f):
    """The Python function of a registry entry (a :class:`~kin.groups.step.Deferred`
    one's compiled function's)."""
    return f.resolve().py_func if isinstance(f, Deferred) else f


def _compiled(f):
    """A registry entry compiled: a :class:`~kin.groups.step.Deferred` one is compiled in
    its own module already."""
    return f.resolve() if isinstance(f, Deferred) else numba.njit(**_JIT)(f)


_fresh_cache()                             # before the decorators read the stamp
#: the number of scalar steps the kernel dispatches on (the registry's order): 9 taken, so
#: three more kinds with a compiled step need no edit here
SLOTS = 12


def _unused(ip, fp, X, W, F, T, C, S, PP, out) -> None:  # pragma: no cover - a free slot
    out[:] = 1


if len(COMPILED) > SLOTS:  # pragma: no cover - a new kind needs a branch below
    raise ImportError(f"kin._kernel_nb dispatches on {SLOTS} compiled steps; the registry has {len(COMPILED)}")
_s0, _s1, _s2, _s3, _s4, _s5, _s6, _s7, _s8, _s9, _s10, _s11 = (
    _compiled(f) for f in (*COMPILED.values(), *(_unused,) * (SLOTS - len(COMPILED))))


def _no_lowering(q, P, U, O, size, out) -> None:  # pragma: no cover - a key without one
    out[:] = np.nan


_l0, _l1, _l2, _l3, _l4, _l5, _l6, _l7, _l8, _l9, _l10, _l11 = (
    numba.njit(**_JIT)(LOWERING.get(key, _no_lowering)) for key in (*COMPILED, *(None,) * (SLOTS - len(COMPILED))))


@numba.njit(**_JIT)
def _lower(c, q, P, U, O, size, out) -> None:
    """The lowering of the steps of code ``c`` for every design."""
    if c == 0:
        _l0(q, P, U, O, size, out)
    elif c == 1:
        _l1(q, P, U, O, size, out)
    elif c == 2:
        _l2(q, P, U, O, size, out)
    elif c == 3:
        _l3(q, P, U, O, size, out)
    elif c == 4:
        _l4(q, P, U, O, size, out)
    elif c == 5:
        _l5(q, P, U, O, size, out)
    elif c == 6:
        _l6(q, P, U, O, size, out)
    elif c == 7:
        _l7(q, P, U, O, size, out)
    elif c == 8:
        _l8(q, P, U, O, size, out)
    elif c == 9:
        _l9(q, P, U, O, size, out)
    elif c == 10:
        _l10(q, P, U, O, size, out)
    else:
        _l11(q, P, U, O, size, out)


@numba.njit(**_JIT)
def lower_designs(codes, q, steps, P, U, O, size, out) -> None:
    """The numbers ``out`` (D, n_steps, width) of D designs for the steps ``steps``,
    each step lowered by its kind's compiled lowering (:data:`~kin.groups.registry.LOWERING`)
    from the joints' reference points ``P``, guides ``U`` (D, rows, 2) and the links'
    reference points ``O`` (D, n_links, 2); ``q`` (n_steps, width) the steps' rows and
    links."""
    for i in range(steps.size):
        k = steps[i]
        _lower(codes[k], q[k], P, U, O, size, out[:, k])


@numba.njit(**_JIT)
def _step(c, ip, fp, X, W, F, T, C, S, PP, out) -> None:
    """The steps of code ``c`` (its index in the registry) at every position."""
    if c == 0:
        _s0(ip, fp, X, W, F, T, C, S, PP, out)
    elif c == 1:
        _s1(ip, fp, X, W, F, T, C, S, PP, out)
    elif c == 2:
        _s2(ip, fp, X, W, F, T, C, S, PP, out)
    elif c == 3:
        _s3(ip, fp, X, W, F, T, C, S, PP, out)
    elif c == 4:
        _s4(ip, fp, X, W, F, T, C, S, PP, out)
    elif c == 5:
        _s5(ip, fp, X, W, F, T, C, S, PP, out)
    elif c == 6:
        _s6(ip, fp, X, W, F, T, C, S, PP, out)
    elif c == 7:
        _s7(ip, fp, X, W, F, T, C, S, PP, out)
    elif c == 8:
        _s8(ip, fp, X, W, F, T, C, S, PP, out)
    elif c == 9:
        _s9(ip, fp, X, W, F, T, C, S, PP, out)
    elif c == 10:
        _s10(ip, fp, X, W, F, T, C, S, PP, out)
    else:
        _s11(ip, fp, X, W, F, T, C, S, PP, out)


@numba.njit(**_JIT)
def solve_positions(codes, ints, floats, unknown, steps, X, W, F, T, C, S, fail, pend, hosts, offs, P) -> int:
    """Solve the steps ``steps`` of a lowered plan at every row of ``X`` (M, n_drivers),
    step by step, each over all positions (its kind's loop: no dispatch per position).

    Writes the steps' links into the pose store ``T`` (n_links, 3, M) (x, y, θ of each
    link's reference point; the frame's row set by the caller) with their cos and sin
    ``C``, ``S`` (n_links, M), ``fail`` (M,): the status of the first failing step (0
    where every step assembles), and ``pend`` (n_links,): 1 for the links whose angle
    row comes from their cos and sin (:func:`finish_rows` computes it, as the NumPy path's
    pending rows).  ``W``
    holds the cos and sin the steps asked for, ``F`` (n_steps, 1 or M) each step's
    branch factor.  A failing step's links are NaN at that position, and so are the
    links of the steps after it that read them, as in the NumPy path.  Then
    :func:`finish_rows` (the derived angle rows, the points ``P`` of ``hosts``).
    Returns the number of rows that failed.
    """
    failed = _plain_steps(codes, ints, floats, unknown, steps, X, W, F, T, C, S, fail, pend)
    finish_rows(T, C, S, pend, np.ones(T.shape[0], np.int8), hosts, offs, np.ones(hosts.size, np.int8), P)
    return failed


@numba.njit(**_JIT)
def _steps(codes, ints, floats, unknown, steps, X, W, F, T, C, S, fail, pend) -> int:
    """The step loop of :func:`solve_positions` (without its finish)."""
    out = np.empty(X.shape[0], np.int8)
    failed = 0
    for i in range(steps.size):
        k = steps[i]
        _step(codes[k], ints[k], floats[k], X, W, F[k], T, C, S, pend, out)
        for n in range(X.shape[0]):
            if out[n] != 0:
                if fail[n] == 0:
                    fail[n] = out[n]
                    failed += 1
                for j in range(unknown.shape[1]):
                    u = unknown[k, j]
                    if u >= 0:
                        T[u, 0, n] = T[u, 1, n] = T[u, 2, n] = C[u, n] = S[u, n] = np.nan
    return failed




def _recompiled(fn, name: str, **swap):
    """The compiled function ``fn`` of this module compiled once more as ``name``, the
    globals ``swap`` replaced (its own cache entry, the same source)."""
    py = types.FunctionType(fn.py_func.__code__, {**fn.py_func.__globals__, **swap}, name)
    py.__qualname__ = name
    return numba.njit(**_JIT)(py)


#: :func:`_step` and :func:`_steps` without the tracked steps (a triad's or class IV group's
#: whole tracker, which ``solve``'s kernels never run: :data:`~kin.groups.registry.TRACKED`),
#: for :func:`solve_positions` and :func:`solve_motion`, whose compile then does not link
#: and optimise the trackers' code again
_free = numba.njit(**_JIT)(_unused)
_plain_step = _recompiled(_step, "_plain_step", **{f"_s{i}": _free for i, key in enumerate(COMPILED) if key in TRACKED})
_plain_steps = _recompiled(_steps, "_plain_steps", _step=_plain_step)


@numba.njit(**_JIT)
def _trig_table(trig, X, W, simd) -> None:
    """The table ``W``: cos and sin of ``sign × input`` for each (driver, sign) row of
    ``trig`` at every row of ``X`` (M, n_drivers): libm's, as NumPy's (the design
    batches, whose poses are the NumPy path's bit for bit), or with ``simd`` fdlibm's
    in SIMD registers (:func:`_sincos_row`: within 1 ulp of libm's; the lean route of
    ``solve``, which agrees with the NumPy path to rounding)."""
    for t in range(trig.shape[0]):
        d, r = trig[t, 0], 4 * trig[t, 0] + (2 if trig[t, 1] < 0 else 0)
        sign = 1.0 if trig[t, 1] > 0 else -1.0
        if simd:
            x = X.ravel() if X.shape[1] == 1 else np.ascontiguousarray(X[:, d])
            _sincos_row(x, sign, W[r], W[r + 1])
            continue
        for n in range(X.shape[0]):
            a = sign * X[n, d]
            W[r, n] = np.cos(a)
            W[r + 1, n] = np.sin(a)


@numba.njit(**_JIT)
def _sincos_row(x, sign, c, s) -> None:
    """``c``, ``s`` = cos and sin of ``sign × x`` (1-D, contiguous) by
    :func:`~kin.groups.base.sincos_medium` (a SIMD loop: no branch nor call), then
    libm's beyond its range (and for NaN)."""
    for n in range(x.size):
        c[n], s[n] = sincos_medium(sign * x[n])
    for n in range(x.size):
        if not abs(x[n]) <= SINCOS_MEDIUM:
            c[n], s[n] = np.cos(sign * x[n]), np.sin(sign * x[n])


@numba.njit(**_JIT)
def _frame_rows(frame, T, C, S) -> None:
    """The frame's pose (zero) and its cos and sin (1, 0) at every position."""
    for n in range(T.shape[2]):
        T[frame, 0, n] = T[frame, 1, n] = T[frame, 2, n] = 0.0
        C[frame, n] = 1.0
        S[frame, n] = 0.0


@numba.njit(**_JIT)
def solve_motion(codes, ints, floats, unknown, trig, frame, X, W, C, S, T, fail, pend, want_links, hosts, offs,
                 want_points, P):
    """Every step of a lowered plan at every row of ``X`` (M, n_drivers) on the
    reference branch, in one call (the per-call work of :func:`solve_positions`'s
    caller done here): the table ``W`` (4 n_drivers, M) of cos and sin of ``sign ×
    input`` for each (driver, sign) row of ``trig`` (K, 2) (fdlibm's in SIMD registers,
    within 1 ulp of NumPy's: :func:`_trig_table`), the frame's pose and cos and
    sin rows in ``C``, ``S`` (n_links, M: the caller's work arrays, reused between calls
    so that a large batch touches no fresh page), and the factors.  ``T`` (n_links, 3, M), ``fail`` (M,) zeros, ``pend`` (n_links,)
    zeros and ``P`` as :func:`solve_positions`; only the derived angle rows of
    ``want_links`` and the points of ``want_points`` (int8 masks) are computed, the
    others NaN (what ``outputs=`` leaves out).  Returns the number of failed rows (an
    array returned would be boxed with its dtype unpickled on every call), or -1 without
    solving when an input is not finite (the caller's checks then name it)."""
    for n in range(X.shape[0]):
        for d in range(X.shape[1]):
            if not np.isfinite(X[n, d]):
                return -1
    _trig_table(trig, X, W, True)
    _frame_rows(frame, T, C, S)
    failed = _plain_steps(codes, ints, floats, unknown, np.arange(codes.shape[0]), X, W,
                    np.ones((codes.shape[0], 1)), T, C, S, fail, pend)
    finish_rows(T, C, S, pend, want_links, hosts, offs, want_points, P)
    return failed


@numba.njit(**_JIT)
def solve_designs(codes, ints, floats, unknown, steps, trig, frame, X, W, Tw, Cw, Sw, failw, pend, T, C, S):
    """The steps ``steps`` of a plan lowered for D designs (``floats`` (D, n_steps,
    width): each design's numbers) at the inputs ``X`` (D, N, n_drivers) of each design
    (or (1, N, n_drivers) shared by all: their cos and sin computed once),
    on each design's reference branch: design by design, each step over the design's N
    inputs (as :func:`solve_motion`, in the work arrays ``W``, ``Tw`` (n_links, 3, N),
    ``Cw``, ``Sw`` (n_links, N), ``failw`` (N,)), the poses copied into the pose store
    ``T`` (n_links, 3, D, N) and the cos and sin into ``C``, ``S`` (n_links, D, N).  A
    failing step's links are NaN at that input.  ``pend`` (n_links,) is set to 1 for the
    links whose angle rows are left to be derived from their cos and sin (not computed
    here).  Returns the number of failed (design, input) cells."""
    D, N = floats.shape[0], X.shape[1]
    F = np.ones((codes.shape[0], 1))
    failed = 0
    for d in range(D):
        Xd = X[d if X.shape[0] > 1 else 0]
        if d == 0 or X.shape[0] > 1:
            _trig_table(trig, Xd, W, False)
        _frame_rows(frame, Tw, Cw, Sw)
        failw[:] = 0
        pend[:] = 0
        failed += _steps(codes, ints, floats[d], unknown, steps, Xd, W, F, Tw, Cw, Sw, failw, pend)
        for i in range(steps.size):
            for j in range(unknown.shape[1]):
                k = unknown[steps[i], j]
                if k >= 0:
                    for n in range(N):
                        T[k, 0, d, n] = Tw[k, 0, n]
                        T[k, 1, d, n] = Tw[k, 1, n]
                        T[k, 2, d, n] = Tw[k, 2, n]
                        C[k, d, n] = Cw[k, n]
                        S[k, d, n] = Sw[k, n]
    return failed


@numba.njit(**_JIT)
def finish_rows(T, C, S, pend, want_links, hosts, offs, want_points, P):
    """After the steps: the angle rows of the pending links (``arctan2(S, C)``,
    fdlibm's: within 1 ulp of NumPy's and faster than the libm call) and the points
    ``P`` (n_points, 2, M) of the joints and tracer points, each carried by its host
    link ``hosts[i]`` from the offset ``offs[i]`` (:meth:`kin.poses.Poses.carry`); a
    pending link outside ``want_links`` and a point outside ``want_points`` (int8 masks)
    are NaN instead (not computed)."""
    M = T.shape[2]
    for k in range(T.shape[0]):
        if pend[k] and want_links[k]:
            for n in range(M):
                T[k, 2, n] = arctan2(S[k, n], C[k, n])
        elif pend[k]:
            for n in range(M):
                T[k, 2, n] = np.nan
    for i in range(hosts.size):
        h, ox, oy = hosts[i], offs[i, 0], offs[i, 1]
        if not want_points[i]:
            for n in range(M):
                P[i, 0, n] = P[i, 1, n] = np.nan
            continue
        for n in range(M):
            P[i, 0, n] = T[h, 0, n] + (C[h, n] * ox - S[h, n] * oy)
            P[i, 1, n] = T[h, 1, n] + (S[h, n] * ox + C[h, n] * oy)
