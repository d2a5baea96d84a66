"""The numba side of the batched polish on a tracer's path (:class:`.optimise._CompiledRegions`):
rounds of :class:`.optimise._TrustRegions`'s iteration with the residuals, the exact
Jacobian, its floored SVD, the proposal and the verdict in one compiled call.

A path target with free timing and no constraint (the common synthesis) has residuals
``(W − T) / size`` of the tracer point ``W`` at each design's own driver values and an
exact Jacobian from the same call (:func:`multiloop.kin._tracer_nb.tracer_point`); the
NumPy between those calls, a floored SVD per Jacobian and the step's bookkeeping had cost
some 250 µs an iteration of one design, several times the compiled work.  Here a call
runs up to ``rounds`` rounds of the same lockstep iteration (the same tests in the same
order as :meth:`.optimise._TrustRegions.iterate`, the step :func:`._trust_nb.tr_propose`,
the verdict :func:`._trust_nb.tr_accept`), charging its evaluations against ``avail``
as :func:`.optimise.polish_batch` charges the run's meter; the caller checks the meter's
clock between calls.  The singular values come from numba's LAPACK binding (SciPy's
``gesdd``) where the NumPy route called NumPy's: the two agree to rounding, not bit for bit.

numba keys a cache on this file alone: on import the compiled modules it calls are
registered as its sources (:func:`multiloop.kin._jit_cache.depends_on`).
"""
from __future__ import annotations

import numba
import numpy as np

from multiloop.kin import _tracer_nb
from multiloop.kin._jit_cache import depends_on
from multiloop.kin._scalar_nb import JIT as _JIT

from . import _trust_nb

__all__ = ["rounds"]

depends_on(__file__, [_tracer_nb.__file__, _trust_nb.__file__])    # (before the decorators read the stamp)
#: the helpers are inlined into :func:`rounds` (numba IR), so that the tracer's kernel tree,
#: which every compiled caller links and optimises again, is compiled into one caller only
_INLINE = dict(_JIT, inline="always")


@numba.njit(**_INLINE)
def _tracer(pa, tb, bl, first, at, pcols, host, E, acols, X, PHI, jac):
    """The tracer point ``W`` (D, N, 2) of designs ``X`` at their driver values ``PHI``
    (D, N) and its derivatives (:func:`~multiloop.kin._tracer_nb.tracer_point`; the guide
    angles' unit vectors from their columns ``acols`` as :meth:`TracerBatch._run` makes them)."""
    D, N = PHI.shape
    Uang = np.empty((D, acols.size, 2))
    for d in range(D):
        for k in range(acols.size):
            c, s = np.cos(X[d, acols[k]]), np.sin(X[d, acols[k]])
            r = np.hypot(c, s)
            Uang[d, k, 0], Uang[d, k, 1] = c / r, s / r
    inputs = np.ascontiguousarray(PHI).reshape((D, N, 1))
    W, dW, _ = _tracer_nb.tracer_point(pa[0], pa[1], pa[2], pa[3], pa[4], pa[5], pa[6], pa[7], pa[8],
                                       tb[0], tb[1], tb[2], tb[3], tb[4], tb[5], Uang, first, X, inputs, at, pcols,
                                       host, jac, bl[0], bl[1], bl[2], bl[3], bl[4], bl[5], bl[6], bl[7], bl[8], bl[9],
                                       bl[10], bl[11], bl[12], bl[13], bl[14], bl[15], E)
    return W, dW


@numba.njit(**_INLINE)
def _residuals(tr, U, origin, scale, nz, T, size, jac):
    """The residuals ``(K, 2N)`` at unit variables ``U`` (K, n) (a non-finite one 1.0, as
    the NumPy route has them) and with ``jac`` their Jacobian ``(K, 2N, n)`` in the unit
    variables (a non-finite entry 0.0)."""
    K, n = U.shape
    N = n - nz
    X = np.empty((K, nz))
    PHI = np.empty((K, N))
    for k in range(K):
        for j in range(n):
            w = origin[j] + U[k, j] * scale[j]
            if j < nz:
                X[k, j] = w
            else:
                PHI[k, j - nz] = w
    W, dW = _tracer(tr[0], tr[1], tr[2], tr[3], tr[4], tr[5], tr[6], tr[7], tr[8], X, PHI, jac)
    inv = 1.0 / size
    R = np.empty((K, 2 * N))
    J = np.zeros((K, 2 * N, n) if jac else (0, 0, 0))
    for k in range(K):
        for i in range(N):
            for c in range(2):
                row = 2 * i + c
                r = (W[k, i, c] - T[i, c]) * inv
                R[k, row] = r if np.isfinite(r) else 1.0
                if jac:
                    for j in range(nz):
                        v = dW[k, i, c, j] / size * scale[j]
                        J[k, row, j] = v if np.isfinite(v) else 0.0
                    v = dW[k, i, c, nz] / size * scale[nz + i]
                    J[k, row, nz + i] = v if np.isfinite(v) else 0.0
    return R, J


@numba.njit(**_INLINE)
def _factor(J, Wsv, s, Vt, k, floor):
    """Row ``k`` of the SVD ``Wsv``, ``s``, ``Vt`` of Jacobian ``J`` (m, n), its singular
    values raised to ``floor`` of the largest (:func:`.optimise._svd`)."""
    u, sv, vt = np.linalg.svd(np.ascontiguousarray(J), full_matrices=False)
    Wsv[k] = u
    low = floor * sv[0]
    for i in range(sv.size):
        s[k, i] = max(sv[i], low)
    Vt[k] = vt


@numba.njit(**_INLINE)
def _flat(J, R) -> bool:
    """Whether the gradient ``Jᵀ R`` is below 1e-15 everywhere (SciPy's ``gtol`` test)."""
    m, n = J.shape
    top = 0.0
    for j in range(n):
        g = 0.0
        for i in range(m):
            g += J[i, j] * R[i]
        top = max(top, abs(g))
    return top < 1e-15


@numba.njit(**_INLINE)
def _sq(R):
    out = np.empty(R.shape[0])
    for k in range(R.shape[0]):
        acc = 0.0
        for i in range(R.shape[1]):
            acc += R[k, i] * R[k, i]
        out[k] = acc
    return out


@numba.njit(**_JIT)
def rounds(tr, origin, scale, nz, T, size, lo, hi, U, R, J, Wsv, s, Vt, F, radius, alpha, active, nfev, best_u,
           best_f, max_nfev, rounding, floor, avail, cost, most):
    """Up to ``most`` rounds of the iteration over the ``active`` designs, the state
    arrays updated in place, charging one evaluation a residual and ``cost`` a Jacobian
    against ``avail``.  Returns the evaluations charged and whether a charge was refused
    (the iteration is over: :meth:`.optimise._TrustRegions.iterate` breaks there too).
    ``most`` 0 starts the iteration instead: the residuals, Jacobians, squared norms and
    floored SVDs at the starts ``U``, and ``active`` cleared where the gradient is flat
    (nothing charged: the caller charged the first Jacobians)."""
    used = 0.0
    n = U.shape[1]
    if most == 0:
        R0, J0 = _residuals(tr, U, origin, scale, nz, T, size, True)
        R[:] = R0
        J[:] = J0
        F[:] = _sq(R0)
        for k in range(U.shape[0]):
            _factor(J0[k], Wsv, s, Vt, k, floor)
            if _flat(J0[k], R0[k]):
                active[k] = False
        return used, False
    for _ in range(most):
        a = np.flatnonzero(active)
        Ka = a.size
        if Ka == 0:
            break
        Wa, sa, Vta, Ra, Ja = Wsv[a], s[a], Vt[a], R[a], J[a]
        Ua, Fa, rad, alp = U[a], F[a], radius[a], alpha[a]
        h, al, pred = _trust_nb.tr_propose(Wa, sa, Vta, Ra, Ja, rad, alp)
        for q in range(Ka):
            alpha[a[q]] = al[q]
        if avail - used < Ka:
            return used, True
        used += Ka
        Un = Ua + h
        Rn, _ = _residuals(tr, Un, origin, scale, nz, T, size, False)
        Fn = _sq(Rn)
        for q in range(Ka):
            k = a[q]
            nfev[k] += 1
            inside = True
            for j in range(n):
                if not (lo[j] <= Un[q, j] <= hi[j]):
                    inside = False
            if inside and Fn[q] < best_f[k]:
                best_u[k] = Un[q]
                best_f[k] = Fn[q]
        nr, na, done = _trust_nb.tr_accept(Fa, Fn, pred, h, Ua, rad, al)
        for q in range(Ka):
            radius[a[q]], alpha[a[q]] = nr[q], na[q]
        ok = np.flatnonzero(Fa - Fn > 0)
        if ok.size:
            if avail - used < ok.size * cost:
                for q in ok:
                    U[a[q]] = Un[q]
                return used, True
            used += ok.size * cost
            Rj, Jj = _residuals(tr, Un[ok], origin, scale, nz, T, size, True)
            for p in range(ok.size):
                k = a[ok[p]]
                U[k], R[k], J[k], F[k] = Un[ok[p]], Rj[p], Jj[p], Fn[ok[p]]
                _factor(Jj[p], Wsv, s, Vt, k, floor)
                if _flat(Jj[p], Rj[p]):
                    active[k] = False
        for q in range(Ka):
            if done[q]:
                active[a[q]] = False
        for k in range(U.shape[0]):
            active[k] = active[k] and nfev[k] < max_nfev and F[k] > rounding
    return used, False
