"""The numba side of :class:`kin.tracer_batch.TracerBatch`: one tracer point of a few
designs at their own inputs, and its derivatives, in one compiled call.

The call makes, in order and on the same floats, what the batch's Python route made by
several calls: the designs' joint table (:meth:`kin.geometry.Geometry.gather`), their
numbers by each kind's compiled lowering (:func:`kin._kernel_nb.lower_designs`), the poses
(:func:`kin._kernel_nb.solve_designs`), the point carried by its host link
(:func:`kin.poses.carried`), and with the derivatives every step's velocity analogue
(:func:`kin._sensitivity_nb.sensitivities`) and the material point's derivative
(:func:`kin.sensitivity.material_derivative`): the same floats as
``solve_designs(...).point(name)`` and ``pose_sensitivity(...).point(name)``, bit for bit
(``tests/test_tracer_batch.py``).  A synthesis polish asks for it hundreds of times a run
at one to three designs and ten inputs, where the Python between those calls had cost
several times the calls themselves.

numba keys a cache on this file alone, and this file's code inlines the kernels it
calls: their files (and theirs, transitively) are registered as its sources
(:func:`_fresh_cache`, :func:`kin._jit_cache.depends_on`), so that an edit there rebuilds
its cache once.
"""
from __future__ import annotations

import numba
import numpy as np

from . import _kernel_nb, _sensitivity_nb
from ._jit_cache import depends_on
from ._scalar_nb import JIT as _JIT

__all__ = ["tracer_point"]


def _fresh_cache() -> None:
    """Register the kernels this file's code inlines as its cache's sources (theirs come
    with them: :func:`kin._kernel_nb._fresh_cache`)."""
    depends_on(__file__, [m.__file__ for m in (_kernel_nb, _sensitivity_nb)])


_fresh_cache()                             # before the decorators read the stamp


@numba.njit(**_JIT)
def _joint_table(at, axes, prow, pcx, pcy, arow, Uang, first, X):
    """:meth:`~kin.geometry.Geometry.gather`'s ``(P, U, O)`` of the designs ``X`` (D, p):
    the reference points ``at`` and guides ``axes`` (rows, 2) with rows ``prow`` read from
    the columns ``pcx``, ``pcy`` and guides ``arow`` from ``Uang`` (D, len(arow), 2)."""
    D, nr, nl = X.shape[0], at.shape[0], first.size
    P = np.empty((D, nr, 2))
    U = np.empty((D, nr, 2))
    O = np.empty((D, nl, 2))
    for d in range(D):
        for i in range(nr):
            P[d, i, 0], P[d, i, 1] = at[i, 0], at[i, 1]
            U[d, i, 0], U[d, i, 1] = axes[i, 0], axes[i, 1]
        for k in range(prow.size):
            P[d, prow[k], 0], P[d, prow[k], 1] = X[d, pcx[k]], X[d, pcy[k]]
        for k in range(arow.size):
            U[d, arow[k], 0], U[d, arow[k], 1] = Uang[d, k, 0], Uang[d, k, 1]
        for k in range(nl):
            O[d, k, 0], O[d, k, 1] = P[d, first[k], 0], P[d, first[k], 1]
    return P, U, O


@numba.njit(**_JIT)
def tracer_point(codes, ints, width, qrows, unknown, steps, trig, frame, size,
                 at, axes, prow, pcx, pcy, arow, Uang, first, X, inputs, point, pcols, host, jac,
                 kind, la, lb, brow, alpha, drive, Ea, Eb, jr, oa, ob, step_lo, step_hi, neq, col_of, sunknown, E):
    """The point ``W`` (D, N, 2) of designs ``X`` (D, p) at their inputs ``inputs``
    (D, N, 1) (or (1, N, 1), shared), NaN where a design does not assemble, with ``jac``
    its derivatives ``dW`` (D, N, 2, q) by the design columns and the input (else an empty
    array), and ``ok`` (D, N) where every link assembled.

    The plan (:class:`kin.kernel.KernelPlan`): ``codes``, ``ints``, the numbers' ``width``,
    the lowering's rows ``qrows``, ``unknown``, the ``steps`` to run, ``trig``, ``frame``
    and the mechanism's ``size``; the joint table's template (:func:`_joint_table`); the
    point's fixed reference ``point`` (2,) or its columns ``pcols`` (-1: fixed), carried by
    link ``host``; the sensitivity blocks (:func:`kin.sensitivity.sensitivity_plan`: the
    ``kind`` … ``sunknown`` of :func:`kin._sensitivity_nb.sensitivities`, the blocks'
    joint and origin rows ``jr``, ``oa``, ``ob``) and the point's offset columns ``E`` (2, q).
    """
    D, N = X.shape[0], inputs.shape[1]
    nl, ns = first.size, codes.shape[0]
    P, U, O = _joint_table(at, axes, prow, pcx, pcy, arow, Uang, first, X)
    numbers = np.full((D, ns, width), np.nan)
    _kernel_nb.lower_designs(codes, qrows, steps, P, U, O, size, numbers)
    T = np.empty((nl, 3, D, N))
    C = np.empty((nl, D, N))
    S = np.empty((nl, D, N))
    T[frame] = 0.0
    _kernel_nb.solve_designs(codes, ints, numbers, unknown, steps, trig, frame, inputs, np.empty((4, N)),
                             np.empty((nl, 3, N)), np.empty((nl, N)), np.empty((nl, N)), np.zeros(N, np.int8),
                             np.zeros(nl, np.int8), T, C, S)
    C[frame] = 1.0
    S[frame] = 0.0
    r = np.empty((D, 2))
    for d in range(D):
        for a in range(2):
            ref = X[d, pcols[a]] if pcols[a] >= 0 else point[a]
            r[d, a] = ref - O[d, host, a]
    W = np.empty((D, N, 2))
    for d in range(D):
        rx, ry = r[d, 0], r[d, 1]
        for n in range(N):
            c, s = C[host, d, n], S[host, d, n]
            W[d, n, 0] = T[host, 0, d, n] + (c * rx - s * ry)
            W[d, n, 1] = T[host, 1, d, n] + (s * rx + c * ry)
    B = D * N
    Cf, Sf = C.reshape(nl, B), S.reshape(nl, B)
    ok = np.ones(B, np.bool_)
    for b in range(B):
        for k in range(nl):
            if not np.isfinite(Cf[k, b]):
                ok[b] = False
    q = E.shape[1]
    if not jac:
        return W, np.empty((0, 0, 2, q)), ok.reshape(D, N)
    dW = _point_derivatives(T, Cf, Sf, P, U, r, ok, host, frame, N, kind, la, lb, brow, alpha, drive, Ea, Eb, jr, oa,
                            ob, step_lo, step_hi, neq, col_of, sunknown, E)
    return W, dW, ok.reshape(D, N)


@numba.njit(**_JIT)
def _point_derivatives(T, Cf, Sf, P, U, r, ok, host, frame, N, kind, la, lb, brow, alpha, drive, Ea, Eb, jr, oa, ob,
                       step_lo, step_hi, neq, col_of, sunknown, E):
    """:func:`tracer_point`'s derivatives ``dW`` (D, N, 2, q): every step's velocity
    analogue (:func:`kin._sensitivity_nb.sensitivities`) on the poses ``T`` (n_links, 3, D,
    N) and their cos and sin ``Cf``, ``Sf`` (n_links, D·N), the blocks' offsets and guides
    read from the joint table ``P``, ``U``, then the material point at ``r`` (D, 2) from
    link ``host``'s reference point (:func:`kin.sensitivity.material_derivative`)."""
    nl, D = T.shape[0], T.shape[2]
    B = D * N
    q = E.shape[1]
    Xf = np.empty((nl, B))
    Yf = np.empty((nl, B))
    for k in range(nl):
        for d in range(D):
            for n in range(N):
                Xf[k, d * N + n] = T[k, 0, d, n]
                Yf[k, d * N + n] = T[k, 1, d, n]
    nb = jr.size
    rho_a = np.empty((nb, D, 2))
    rho_b = np.empty((nb, D, 2))
    u0 = np.empty((nb, D, 2))
    for i in range(nb):
        for d in range(D):
            for a in range(2):
                rho_a[i, d, a] = P[d, jr[i], a] - P[d, oa[i], a]
                rho_b[i, d, a] = P[d, jr[i], a] - P[d, ob[i], a]
                u0[i, d, a] = U[d, jr[i], a]
    dZ = np.full((nl, B, 3, q), np.nan)
    dZ[frame] = 0.0
    _sensitivity_nb.sensitivities(Xf, Yf, Cf, Sf, N, kind, la, lb, brow, alpha, drive, Ea, Eb, rho_a, rho_b, u0,
                                  step_lo, step_hi, neq, col_of, sunknown, ok, dZ)
    dW = np.empty((D, N, 2, q))
    for d in range(D):
        rx, ry = r[d, 0], r[d, 1]
        for n in range(N):
            b = d * N + n
            c, s = Cf[host, b], Sf[host, b]
            ax = c * rx - s * ry                       # R(θ) r, then its left normal (−ay, ax)
            ay = s * rx + c * ry
            for j in range(q):
                dt = dZ[host, b, 2, j]
                dW[d, n, 0, j] = dZ[host, b, 0, j] + -ay * dt + (c * E[0, j] - s * E[1, j])
                dW[d, n, 1, j] = dZ[host, b, 1, j] + ax * dt + (s * E[0, j] + c * E[1, j])
    return dW
