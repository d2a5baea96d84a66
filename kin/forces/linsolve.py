"""Batched small linear solves for the kinetostatic blocks.

Two routes, cross-checked in the tests:

* :func:`solve_batched` — dense ``(N, m, m)`` matrices through one batched LAPACK
  ``gesv`` (partial pivoting) and a determinant;
* :func:`solve_sparse` — the same system given as a sparse ``m × m`` table of entries,
  each ``None`` (structural zero), a Python float (constant over the batch) or an
  ``(N,)`` array.  Gaussian elimination runs over the *table* once per call (Python
  loops over at most m² entries, never over positions); every arithmetic operation
  acts on whole ``(N,)`` arrays, structural zeros and constants cost nothing.  The
  pivot row of each column is chosen once for the batch (a constant entry first,
  else the largest in mean magnitude); a position whose pivot is below
  ``THRESHOLD`` times the largest entry of its column (threshold partial pivoting,
  Golub & Van Loan 2013, §3.4) is re-solved by :func:`solve_batched`, so the result
  is as stable as LAPACK's.

Both return the absolute determinant of the column-scaled matrix (unit column norms;
between 0 and 1 by Hadamard's inequality), the singularity measure of the blocks.
"""
from __future__ import annotations

import numpy as np

__all__ = ["SING_TOL", "THRESHOLD", "solve_batched", "solve_sparse", "dense"]

#: a block whose column-scaled |det| is at most this is singular
SING_TOL = 1e-10
#: threshold of the static pivot relative to its column (else the LAPACK fallback)
THRESHOLD = 0.1


def solve_batched(A: np.ndarray, b: np.ndarray, check: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Solve ``A x = b`` for a batch: ``A (N, m, m)``, ``b (N, m)``.

    Columns are scaled to unit norm; ``absdet`` is the absolute determinant of the
    scaled matrix, a scale-free singularity measure.  Rows with ``absdet <= 1e-10`` (or
    non-finite entries) are not solved and come back as NaN; the others go through one
    batched LAPACK ``gesv`` call (``numpy.linalg.solve``).

    With ``check=False`` the determinant is skipped (``absdet`` is all NaN) unless the
    batch contains an exactly singular matrix, when the checked path is taken.

    Returns
    -------
    x : ndarray (N, m)
    absdet : ndarray (N,)
    """
    A = np.asarray(A, float)
    N, m, _ = A.shape
    if m == 0:
        return np.zeros((N, 0)), np.ones(N)
    norms = np.sqrt(np.einsum("nij,nij->nj", A, A))
    norms = np.where(norms > 0, norms, 1.0)
    As = A / norms[:, None, :]
    if not check:
        try:
            x = np.linalg.solve(As, b[..., None])[..., 0] / norms
            return x, np.full(N, np.nan)
        except np.linalg.LinAlgError:
            pass
    with np.errstate(invalid="ignore"):
        det = np.abs(np.linalg.det(As))                   # NaN for non-finite rows
    good = (det > SING_TOL) & np.isfinite(b).all(axis=1)
    det = np.where(np.isfinite(det), det, 0.0)
    if not good.all():
        As[~good] = np.eye(m)
    bb = np.where(good[:, None], b, 0.0)
    x = np.linalg.solve(As, bb[..., None])[..., 0] / norms
    x[~good] = np.nan
    return x, det


def dense(entries: list[list], N: int, rows=None) -> np.ndarray:
    """The ``(N, m, m)`` matrix of a sparse entry table (``rows``: a subset of positions)."""
    m = len(entries)
    n = N if rows is None else int(np.count_nonzero(rows)) if rows.dtype == bool else len(rows)
    A = np.zeros((n, m, m))
    for i, row in enumerate(entries):
        for j, e in enumerate(row):
            if e is None:
                continue
            A[:, i, j] = e if np.ndim(e) == 0 or rows is None else e[rows]
    return A


def _sub(a, f, b):
    """``a − f b`` with ``None`` as zero."""
    if b is None or f is None:
        return a
    fb = f * b
    return -fb if a is None else a - fb


def _pick(entries, cand: list[int], k: int) -> int:
    consts = [i for i in cand if np.ndim(entries[i][k]) == 0]
    if consts:
        return max(consts, key=lambda i: abs(entries[i][k]))
    return max(cand, key=lambda i: float(np.nanmean(np.abs(entries[i][k]))))


def _eliminate(E: list[list], b: list, N: int):
    """Forward elimination in place on ``E`` and ``b`` (copies of the caller's); returns
    pivot rows and the mask of positions whose static pivot failed the threshold test,
    or None when the table is structurally singular."""
    m = len(E)
    free = list(range(m))
    order = []
    weak = np.zeros(N, bool)
    for k in range(m):
        cand = [i for i in free if E[i][k] is not None]
        if not cand:
            return None
        p = _pick(E, cand, k)
        piv = E[p][k]
        others = [i for i in cand if i != p]
        if np.ndim(piv) == 0 and piv == 0.0:
            return None
        if others and (np.ndim(piv) or any(np.ndim(E[i][k]) for i in others)):
            big = np.abs(E[others[0]][k])
            for i in others[1:]:
                big = np.maximum(big, np.abs(E[i][k]))
            weak |= ~(np.abs(piv) >= THRESHOLD * big)
        for i in others:
            f = E[i][k] / piv
            for j in range(k + 1, m):
                E[i][j] = _sub(E[i][j], f, E[p][j])
            b[i] = _sub(b[i], f, b[p])
            E[i][k] = None
        free.remove(p)
        order.append(p)
    return order, weak


def _back(E: list[list], b: list, order: list[int], N: int) -> np.ndarray:
    """Back substitution; returns x as (m, N) (one contiguous row per unknown)."""
    m = len(E)
    x = np.empty((m, N))
    for k in range(m - 1, -1, -1):
        p = order[k]
        acc = b[p]
        for j in range(k + 1, m):
            if E[p][j] is not None:
                acc = acc - E[p][j] * x[j]
        np.divide(acc, E[p][k], out=x[k])
    return x


def _dense_rhs(rhs: list, N: int) -> np.ndarray:
    return np.stack([np.broadcast_to(np.asarray(r, float), (N,)) for r in rhs], axis=-1)


def solve_sparse(entries: list[list], rhs: list, N: int, check: bool = True,
                 transposed: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Solve a batch of ``m × m`` systems given as a sparse entry table.

    Parameters
    ----------
    entries : list of m lists of m entries
        ``None``, a float, or an ``(N,)`` array; not modified.
    rhs : list of m ``(N,)`` arrays (or floats)
    N : int
        Batch size.
    check : bool
        As in :func:`solve_batched` (``False``: near-singular positions are not marked).
    transposed : bool
        Return ``x`` as ``(m, N)`` (contiguous per unknown) instead of ``(N, m)``.

    Returns
    -------
    x : ndarray (N, m)
        NaN where the system is singular (column-scaled |det| ≤ ``SING_TOL``).
    absdet : ndarray (N,)
        Column-scaled absolute determinant.

    Examples
    --------
    >>> a = np.array([2.0, 0.0])
    >>> x, det = solve_sparse([[1.0, a], [None, 4.0]], [np.ones(2), np.ones(2)], 2)
    >>> x.tolist()
    [[0.5, 0.25], [1.0, 0.25]]
    """
    m = len(entries)
    if m == 0:
        return (np.zeros((0, N)) if transposed else np.zeros((N, 0))), np.ones(N)
    E = [list(r) for r in entries]
    b = list(rhs)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        out = _eliminate(E, b, N)
        if out is None:
            x, det = solve_batched(dense(entries, N), _dense_rhs(rhs, N), check)
            return (np.ascontiguousarray(x.T) if transposed else x), det
        order, weak = out
        x = _back(E, b, order, N)
        det = np.ones(N)
        for k, p in enumerate(order):
            col = [row[k] for row in entries if row[k] is not None]
            nrm = np.sqrt(sum(c * c for c in col))
            det = det * (np.abs(E[p][k]) / np.where(nrm > 0, nrm, 1.0))
    redo = weak | ~np.isfinite(det)
    for xk in x:
        redo |= ~np.isfinite(xk)
    if check:
        redo |= ~(det > SING_TOL)
    if redo.any():
        rows = np.flatnonzero(redo)
        xr, dr = solve_batched(dense(entries, N, rows), _dense_rhs(rhs, N)[rows], check)
        x[:, rows], det[rows] = xr.T, dr
    return (x if transposed else np.ascontiguousarray(x.T)), det
