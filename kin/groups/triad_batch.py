"""The triad tracker of :func:`kin.groups.triad.triad_track`, run for D designs at once.

The arithmetic is the single-design tracker's, with a leading design axis: all modes at
the coarse inputs (every ``stride``-th, one batched companion eigenproblem per design and
coarse input), mode following between them (:func:`~kin.groups.triad.follow_modes_batch`),
then every other input Newton-polished from a Taylor prediction off its nearest coarse
input, accepted only well inside its mode's basin.  A design whose path needs more — a
coarse loss, a refused interval, a non-finite known pin — is handed to the single-design
tracker itself, so every design gets the result it gets alone (Hunt 1983 for the
degree-6 polynomial of the triad's modes).

References
----------
.. [1] Hunt K.H. Structural kinematics of in-parallel-actuated robot-arms. ASME J. Mech.
   Transm. Autom. Des. 105 (1983) 705-712.
"""
from __future__ import annotations

import numpy as np

from .base import quiet
from .triad import (_ACCEPT, MAX_MODES, _dist, _polish, _predict, _track, _wrap, follow_modes_batch,
                    triad_modes)

__all__ = ["track_designs"]


def _coarse(N: int, stride: int) -> np.ndarray:
    c = np.arange(0, N, stride)
    return c if c[-1] == N - 1 else np.append(c, N - 1)


def _coarse_follow(A, b, l, start):
    """All modes at each design's inputs ``A`` (D, n, 3, 2) and the mode followed from the
    one nearest ``start`` (D, 3, 2): modes, ``idx`` and ``status`` (D, n)."""
    Dn, n = A.shape[:2]
    bn = np.broadcast_to(b[:, None], (Dn, n, 3, 2)).reshape(-1, 3, 2)
    m = triad_modes(A.reshape(-1, 3, 2), bn, l.reshape(-1, 3))
    P = m.P.reshape(Dn, n, MAX_MODES, 3, 2)
    th = m.theta.reshape(Dn, n, MAX_MODES)
    valid = np.isfinite(th)
    d0 = np.where(valid[:, 0], _dist(P[:, 0], start[:, None]), np.inf)
    d0 = np.where(np.isnan(d0), np.inf, d0)
    j0 = np.where(np.isfinite(d0).any(axis=1), np.argmin(d0, axis=1), -1)
    Pi = np.where(valid[:, :-1, :, None, None], P[:, :-1], A[:, :-1, None])
    rep = lambda a: np.repeat(a[:, :, None], MAX_MODES, axis=2).reshape(-1, *a.shape[2:])  # noqa: E731
    pred = _predict(rep(A[:, :-1]), Pi.reshape(-1, 3, 2), rep(A[:, 1:]), rep(l[:, :-1]),
                    rep(l[:, 1:]))[0].reshape(Dn, n - 1, MAX_MODES, 3, 2)
    idx, status = follow_modes_batch(P, valid, pred, j0)
    return P, th, idx, status


@quiet
def track_designs(A, b, l, start, *, stride=32):
    """Follow each design's mode along its inputs, as :func:`~kin.groups.triad.triad_track`.

    Parameters
    ----------
    A : ndarray, shape (D, N, 3, 2)
        The outer pins of each design along the inputs.
    b : ndarray, shape (D, 3, 2)
        Each design's P1..P3 in its reference configuration.
    l : ndarray, shape (D, 3) or (D, N, 3)
        Each design's binary lengths (per input for a reduction, e.g. class IV's).
    start : ndarray, shape (D, 3, 2)
        Points near the wanted mode at ``A[:, 0]``.

    Returns
    -------
    P : ndarray (D, N, 3, 2), theta : ndarray (D, N), status : ndarray (D, N) int
        As :class:`~kin.groups.triad.TriadTrack` (0 ok, 1 no assembly, 2 lost, 3 after).
    """
    Dn, N = A.shape[:2]
    L = np.broadcast_to(l[:, None] if l.ndim == 2 else l, (Dn, N, 3))
    P = np.full((Dn, N, 3, 2), np.nan)
    th = np.full((Dn, N), np.nan)
    status = np.full((Dn, N), 3)
    finite = np.all(np.isfinite(A.reshape(Dn, -1)), axis=1)
    alone = ~finite
    if N > 2 * stride and finite.any():
        rows = np.flatnonzero(finite)
        k, Pd, thd = _fill(A[rows], b[rows], L[rows], start[rows], stride)
        P[rows[k]], th[rows[k]], status[rows[k]] = Pd, thd, 0
        alone[rows] = True
        alone[rows[k]] = False
    else:
        alone[:] = True
    for d in np.flatnonzero(alone):               # the single-design tracker, as alone
        if finite[d]:
            P[d], th[d], status[d] = _track(A[d], b[d], L[d], start[d], stride)
    return P, th, status


def _fill(A, b, L, start, stride):
    """Phases 1 and 2 of the tracker for designs whose coarse inputs all follow and whose
    every other input is accepted: their rows, ``P`` and ``theta`` (the rest are not done)."""
    Dn, N = A.shape[:2]
    c = _coarse(N, stride)
    Pm, thm, ic, sc = _coarse_follow(A[:, c], b, L[:, c], start)
    good = np.all(ic >= 0, axis=1)
    if not good.any():
        return np.zeros(0, int), np.zeros((0, N, 3, 2)), np.zeros((0, N))
    g = np.flatnonzero(good)
    A, b, L, ic = A[g], b[g], L[g], ic[g]
    ar = np.arange(len(c))
    Pc = Pm[g][:, ar][np.arange(len(g))[:, None], ar, ic]            # (G, nc, 3, 2)
    thc = thm[g][np.arange(len(g))[:, None], ar, ic]
    other = np.isfinite(thm[g]) & (np.arange(MAX_MODES) != ic[..., None])
    sep = np.min(np.where(other, np.nan_to_num(_dist(Pm[g], Pc[:, :, None]), nan=np.inf), np.inf), axis=-1)
    fine = np.setdiff1d(np.arange(N), c, assume_unique=True)
    left = np.searchsorted(c, fine, side="right") - 1
    right = np.minimum(left + 1, len(c) - 1)
    kn = np.where(fine - c[left] <= c[right] - fine, left, right)
    Pp, dth, sing = _predict(A[:, c[kn]], Pc[:, kn], A[:, fine], L[:, c[kn]], L[:, fine])
    bb = (b - b[:, :1])[:, None]
    Pf, thf, res = _polish(A[:, fine], bb, L[:, fine], Pp[..., 0, :], thc[:, kn] + dth)
    acc = ((res <= _ACCEPT) & ~sing & (_dist(Pf, Pp) <= 0.25 * sep[:, kn])
           & (_dist(Pf, Pc[:, kn]) <= 0.5 * sep[:, kn]))
    done = acc.all(axis=1)
    Pd = np.empty((len(g), N, 3, 2))
    thd = np.empty((len(g), N))
    Pd[:, c], thd[:, c] = Pc, thc
    Pd[:, fine], thd[:, fine] = Pf, _wrap(thf)
    return g[done], Pd[done], thd[done]
