"""Exact roots and extrema of quantities along a driver's motion.

A *quantity* is a function ``Q(state) -> (N, q)`` of a solved state.  Roots are
bracketed by sign changes between consecutive assembled grid values and refined by
bisection; extrema are bracketed by grid values lower (higher) than both neighbours
and refined by golden-section search; the ends of a limited motion count as
candidates, evaluated at the refined limit.  All refinements stop at 1e-10 rad
(:data:`multiloop.kin.check.sweep.XTOL`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .motion import Motion

__all__ = ["Extreme", "roots", "extremes"]


@dataclass(frozen=True)
class Extreme:
    """Minimum and maximum of one quantity and the driver values where they occur."""

    min: float
    at_min: float
    max: float
    at_max: float


def _pick(Q, rows, cols):
    cols = np.asarray(cols)
    rows = np.asarray(rows)
    return Q[rows, cols.reshape(cols.shape + (1,) * (rows.ndim - 1))]


def roots(motion: Motion, Q, derivatives: bool = False, rel_tol: float = 1e-6) -> list[list[float]]:
    """Inputs (rad or m from the reference) where each column of ``Q`` changes sign.

    A refined root is kept only if ``|Q|`` there is below ``rel_tol`` times the
    column's typical size (a pole, where the quantity passes through infinity, is
    dropped).
    """
    out: list[list[float]] | None = None
    for seg in motion.segments:
        V = Q(seg.state)[: seg.n]
        if out is None:
            out = [[] for _ in range(V.shape[1])]
        if V.shape[1] == 0:
            continue
        scale = np.nanmedian(np.abs(V), axis=0) + 1e-300
        a, b = V[:-1], V[1:]
        hit = np.isfinite(a) & np.isfinite(b) & ((a * b < 0) | ((a == 0) & (b != 0)))
        i, c = np.nonzero(hit)
        if i.size == 0:
            continue
        x = seg.x
        lo, hi = seg.side.bisect(x[i], x[i + 1], lambda s, r: _pick(Q(s), r, c), derivatives, smooth=True)
        mid = 0.5 * (lo + hi)
        st, r = seg.side.at(mid, derivatives)
        val = np.abs(_pick(Q(st), r, c))
        for xm, cc, v in zip(mid, c, val):
            if v <= rel_tol * scale[cc]:
                out[cc].append(float(xm))
    return [_unique(xs, motion) for xs in (out or [])]


def _unique(xs, motion: Motion, tol: float = 1e-8) -> list[float]:
    """Roots of a full turn reduced to [0, 2π), duplicates (the overlap past 360°) merged."""
    if not (motion.rotary and motion.full_rotation):
        return sorted(xs)
    two = 2.0 * np.pi
    out: list[float] = []
    for x in sorted(float(np.mod(x, two)) for x in xs):
        if out and min(abs(x - out[-1]), two - abs(x - out[-1])) <= tol:
            continue
        if out and x > two - tol and out[0] < tol:
            continue
        out.append(x)
    return out


#: a column whose grid values differ by no more than this times its size (at least 1) is
#: constant to rounding: its grid's extremes are its extremes, and a zoom search would
#: only chase the rounding of its samples
FLAT = 1e-12


def _constant(V) -> np.ndarray:
    """Whether each column of ``V`` (N, q) is constant to :data:`FLAT` over its finite
    values (a quantity that the moved driver does not change: on a mechanism with
    several drivers, the angles of the parts another driver moves)."""
    ok = np.isfinite(V)
    hi = np.max(np.where(ok, V, -np.inf), axis=0, initial=-np.inf)
    lo = np.min(np.where(ok, V, np.inf), axis=0, initial=np.inf)
    size = np.maximum(np.maximum(np.abs(hi), np.abs(lo)), 1.0)
    return ~ok.any(axis=0) | (hi - lo <= FLAT * size)


def _candidates(seg, V, sign, live):
    """(lo, hi, col) brackets of interior grid minima of ``sign * V`` in the columns
    ``live`` (not those constant to rounding, :func:`_constant`)."""
    W = sign * V
    a, b, c = W[:-2], W[1:-1], W[2:]
    hit = np.isfinite(a) & np.isfinite(b) & np.isfinite(c) & (b <= a) & (b <= c) & ((b < a) | (b < c)) & live
    i, col = np.nonzero(hit)
    return seg.x[i], seg.x[i + 2], col


#: offsets at which a quantity is read beside a crossing (the crossing itself is singular)
_BESIDE = np.array([3e-9, 1e-7])


def _event_points(seg, events, ncol, beside=_BESIDE):
    """Inputs just beside each crossing of ``events`` on this segment's side, one row per
    column: a quantity's value at the crossing is its limit from either side."""
    empty = np.zeros(0), np.zeros(0, int), np.zeros(0)
    if not events:
        return empty
    xs, at = [], []
    for c in events:
        for x in (c, c - 2 * np.pi, c + 2 * np.pi) if seg.side.is_rotary else (c,):
            if seg.x.size and min(seg.x[0], seg.x[-1]) <= x <= max(seg.x[0], seg.x[-1]):
                xs += [x - beside, x + beside]
                at += [np.full(2 * beside.size, x)]
    if not xs:
        return empty
    xs, at = np.concatenate(xs), np.concatenate(at)
    return np.repeat(xs, ncol), np.tile(np.arange(ncol), xs.size), np.repeat(at, ncol)


def _grid_extremes(seg, V):
    """The grid's own smallest and largest value of every column (a column may have its
    extreme next to a singular sample, where no three finite samples bracket it)."""
    ok = np.isfinite(V)
    cols = np.flatnonzero(ok.any(axis=0))
    lo = np.nanargmin(np.where(ok[:, cols], V[:, cols], np.inf), axis=0)
    hi = np.nanargmax(np.where(ok[:, cols], V[:, cols], -np.inf), axis=0)
    return np.concatenate([seg.x[lo], seg.x[hi]]), np.concatenate([cols, cols])


def extremes(motion: Motion, Q, derivatives: bool = False, events=(), beside=_BESIDE) -> list[Extreme | None]:
    """Exact min and max of every column of ``Q`` over the reachable motion; ``events``
    are the crossings (inputs from the reference) found by the certified walk, where a
    quantity is read on both sides, ``beside`` from them (a rate loses about
    ε/δ² of its accuracy at δ from a crossing, so rates are read farther away)."""
    best: dict[int, list] = {}
    ncol = 0
    for seg in motion.segments:
        V = Q(seg.state)[: seg.n]
        ncol = V.shape[1]
        if ncol == 0:
            continue
        live = ~_constant(V)
        lo1, hi1, c1 = _candidates(seg, V, 1.0, live)
        lo2, hi2, c2 = _candidates(seg, V, -1.0, live)
        col = np.concatenate([c1, c2])
        sign = np.concatenate([np.ones(c1.size), -np.ones(c2.size)])
        sh = (-1,) + (1,)
        xs = seg.side.golden(np.concatenate([lo1, lo2]), np.concatenate([hi1, hi2]),
                             lambda s, r: sign.reshape(sh[: 1] + (1,) * (r.ndim - 1)) * _pick(Q(s), r, col),
                             derivatives)
        cand = list(zip(xs, col))
        xs = np.array([x for x, _ in cand], float)
        cols = np.array([c for _, c in cand], int)
        if seg.limit is not None:
            # the limit itself, approached geometrically (a Newton-tracked group only
            # reaches a turning point by ever smaller steps)
            d = seg.limit - seg.x[-1]
            ap = seg.limit - d * 2.0 ** -np.arange(1, 40)
            xs = np.concatenate([xs, np.repeat(np.append(ap, seg.limit), ncol)])
            cols = np.concatenate([cols, np.tile(np.arange(ncol), ap.size + 1)])
        # grid values too (guards a flat or monotone column without interior extremum)
        gx = np.repeat(seg.x[[0, -1]], ncol)
        gc = np.tile(np.arange(ncol), 2)
        ex, ec, eat = _event_points(seg, events, ncol, np.asarray(beside, float))
        mx, mc = _grid_extremes(seg, V)
        report = np.concatenate([xs, gx, eat, mx])      # a value beside a crossing is reported at it
        xs, cols = np.concatenate([xs, gx, ex, mx]), np.concatenate([cols, gc, ec, mc])
        ux, inv = np.unique(xs, return_inverse=True)
        st, r = seg.side.at(ux, derivatives)
        vals = _pick(Q(st), r[inv], cols)
        for x, c, v in zip(report, cols, vals):
            if np.isfinite(v):
                best.setdefault(int(c), []).append((float(v), float(x)))
    out: list[Extreme | None] = []
    for c in range(ncol):
        items = best.get(c)
        if not items:
            out.append(None)
            continue
        vmin, xmin = min(items)
        vmax, xmax = max(items)
        out.append(Extreme(vmin, xmin, vmax, xmax))
    return out
