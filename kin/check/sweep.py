"""One driver moved from the reference along its assembly branch, the others held.

:class:`Side` is the motion of one driver (a :class:`~multiloop.kin.motion.DriverMotion`,
which builds its inputs) in one direction (``+1`` or ``-1``) from the reference
configuration.  Every evaluation solves one continuous path from the
reference (the sampled grid up to the furthest point asked, with the asked points
inserted in order), so the tracked branch is the one continuous motion reaches.

The refinements are vectorised over all brackets of a side: one call of
:func:`multiloop.kin.solve.solve` per iteration evaluates every bracket at 32
interior points (a zoom search: bisection's sign test, or the smallest sample for an
extremum, applied to 32 points at once, so a bracket shrinks 16–33 times per solve).
The sign test needs no continuity, so it also refines a failure boundary.  Both stop
when the bracket is below ``XTOL`` (1e-10 rad, or 1e-10 of the mechanism's size for
a P driver).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from multiloop.kin.motion import DriverMotion
from multiloop.kin.solve import solve, solved_alone
from multiloop.topo.model import Mechanism

__all__ = ["Side", "XTOL"]

#: bracket width at which a refinement stops (rad, or fraction of the size for P drivers)
XTOL = 1e-10
#: a zoom whose samples are this many XTOL apart finishes by its model's step (the
#: secant's root, the parabola's vertex) and one window of ± XTOL around it
FINISH = 1e6
#: ... a kink's corner, whose lines are extrapolated, when they are this many XTOL apart
FINISH_KINK = 2e4
#: the model fits when the neighbouring samples' differences agree with it to this
MODEL_FIT = 0.1
#: a window's values within this of its smallest (relative, at least 1) agree to rounding
FLAT_ROUNDING = 1e-13
#: every 4th grid value (2° or 1 % of the size): the solver's own lead-in step
_STRIDE = 4


@dataclass(frozen=True)
class Side:
    """A driver's motion taken in direction ``sign`` from the reference, along ``grid``.

    Attributes
    ----------
    motion : DriverMotion
        The driver moved and the others held (its certified range, when known).
    plan : a compiled solve plan (reused by every call)
    sign : int
        +1 (increasing input) or -1.
    grid : ndarray
        Sampled input values ``0, sign·h, 2·sign·h, …`` (rad or m).
    """

    motion: DriverMotion
    plan: object
    sign: int
    grid: np.ndarray
    samples: int = 32
    stride: int = _STRIDE
    branch: object = None            # D(state) -> (N, q) signed dyad determinants
    signs: np.ndarray | None = None  # sign of D on the assembled grid
    cancel: object = None            # callable polled before every solve; it stops the check by raising
    each: bool = False               # refine bracket by bracket (tracked groups: see :meth:`_each`)

    @property
    def mechanism(self) -> Mechanism:
        return self.motion.mechanism

    @property
    def k(self) -> int:
        return self.motion.k

    @property
    def is_rotary(self) -> bool:
        return self.motion.rotary

    @property
    def xtol(self) -> float:
        return XTOL if self.is_rotary else XTOL * self.mechanism.size

    def inputs(self, x) -> np.ndarray:
        return self.motion.inputs(x)

    def solve(self, x, derivatives: bool = False, rows=None):
        """The solver's state along ``x`` (a path that must start at the reference); of
        its ``rows`` alone when given (``kin.solve.solve``'s ``rows``).  ``derivatives``:
        the velocities (the check reads no acceleration)."""
        if self.cancel is not None:
            self.cancel()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return solve(self.mechanism, self.motion.inputs(x), derivatives="velocities" if derivatives else False,
                         plan=self.plan, input_rates=self.motion.rates() if derivatives else None, rows=rows)

    def at(self, xs, derivatives: bool = False):
        """State along the grid up to max |xs| with ``xs`` inserted; rows of ``xs``.  A
        plan whose every input is solved on its own (:func:`kin.solve.solved_alone`: the
        branch of each from the chart) solves ``xs`` alone: the path's grid would change
        none of their values.

        Returns ``(state, rows)`` with ``state`` solved along the path and ``rows[i]``
        the row of ``xs[i]`` (the path's grid values guide the solver only: the state
        holds the rows of ``xs``, and its derivatives are computed there alone).
        """
        xs = np.asarray(xs, float).reshape(-1)
        far = np.max(np.abs(xs)) if xs.size else 0.0
        alone = solved_alone(self.plan)
        g = self.grid[:: self.stride]
        g = g[np.abs(g) < far] if not alone else g[:0]   # (each input on its own branch)
        path = np.concatenate([g, xs])
        order = np.argsort(np.abs(path), kind="stable")
        where = np.empty_like(order)
        where[order] = np.arange(order.size)
        if g.size:
            st = self.solve(path[order], derivatives, rows=where[g.size:])
            rows = np.arange(xs.size)
        else:
            st = self.solve(path[order], derivatives)
            rows = where
        if self.signs is not None and rows.size and not alone:     # (no path, no jump to guard)
            st = self._guard(st, rows, xs)
        return st, rows

    def _guard(self, st, rows, xs):
        """Rows whose dyad branches differ from the dense grid's around them are failed
        (a path-following plan's; a plan solved on its chart follows no path).

        The solver keeps each dyad's branch by prediction from the previous two path
        points; on a path with uneven steps (grid, then a tiny bracket) that prediction
        can pick the other branch of a near-toggle dyad.  A dyad's determinant changes
        sign only at a branch point, so a sign that differs from the grid's on both
        sides is such a jump, and the row is discarded (NaN).
        """
        n = self.signs.shape[0]
        h = abs(self.grid[1] - self.grid[0]) if self.grid.size > 1 else 0.0
        h = h if h > 0.0 else 1.0
        i = np.clip((np.abs(xs) / h).astype(int), 0, max(n - 2, 0))
        lo, hi = self.signs[i], self.signs[np.minimum(i + 1, n - 1)]
        got = np.sign(self.branch(st)[rows])
        bad = np.any((lo == hi) & (got != lo) & (got != 0) & np.isfinite(got), axis=1)
        if not bad.any():
            return st
        r = rows[bad]
        upd = {}
        for name in ("positions", "angles", "velocities", "accelerations", "omegas", "epsilons",
                     "point_positions", "point_velocities", "point_accelerations", "poses",
                     "pose_rates", "pose_accelerations"):
            a = getattr(st, name)
            if a is not None:
                a = a.copy()
                a[r] = np.nan
                upd[name] = a
        status = st.status.copy()
        status[r] = "branch jump of the solver on an uneven path (discarded)"
        return replace(st, status=status, **upd)

    def _sample(self, lo, hi, value, derivatives, ends: bool = False):
        """``value`` at ``samples`` equispaced interior points of every bracket: ``(x,
        v)``; with ``ends``, ``(x, value at lo, v)``."""
        t = np.arange(0, self.samples + 1) / (self.samples + 1)
        x = lo[:, None] + (hi - lo)[:, None] * t
        st, r = self.at(x.ravel(), derivatives)      # lo too: the path approaches gradually
        v = value(st, r.reshape(x.shape))
        return (x[:, 1:], v[:, 0], v[:, 1:]) if ends else (x[:, 1:], v[:, 1:])

    def bisect(self, lo, hi, value, derivatives: bool = False, xtol: float | None = None,
               smooth: bool = False):
        """Roots of sign changes, one per bracket, vectorised (zoom search).

        Each iteration samples ``samples`` interior points of every bracket in one solve
        and keeps the first sub-interval where the sign changes, so the bracket
        shrinks ``samples + 1`` times per solve (the sign test of bisection, applied to
        ``samples`` points at once).  A ``smooth`` quantity, once its samples are
        :data:`FINISH` × ``xtol`` apart and the four around the change lie on a line
        (:data:`MODEL_FIT`), is finished by the secant's root between the two that
        bracket it: the next solve samples ± ``xtol`` around it, and a sign change
        inside that window is the final bracket, as certain as any zoom step's (a window
        without one falls back to the zoom of the bracket it came from).

        Parameters
        ----------
        lo, hi : array_like (K,)
            Bracket ends (input values) with ``value`` of opposite sign.
        value : callable (state, rows) -> array of the shape of ``rows``
            The quantity of bracket i at ``state`` rows ``rows[i]``; NaN counts as
            the sign of ``hi`` (the failing side of a limit).
        xtol : float, optional
            Bracket width to stop at (default :attr:`xtol`).
        smooth : bool
            ``value`` is continuous with a simple root (not a step such as "assembled").

        Returns
        -------
        (lo, hi) : arrays (K,), the final brackets (width below ``xtol``).
        """
        lo = np.array(lo, float)
        hi = np.array(hi, float)
        if lo.size == 0:
            return lo, hi
        if self.each and lo.size > 1:
            parts = self._each(self.bisect, lo, hi, value, derivatives, smooth=smooth)
            return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])
        rows = np.arange(lo.size)
        tol = self.xtol if xtol is None else xtol
        M = self.samples
        s_lo = back = None          # sign at lo; the last model step's window (_Window), or None
        while np.max(np.abs(hi - lo)) > tol:
            if np.all(np.abs(hi - lo) <= 4 * np.spacing(np.maximum(np.abs(lo), np.abs(hi)))):
                break                            # as narrow as the floating point allows
            x, v0, v = self._sample(lo, hi, value, derivatives, ends=True)
            if s_lo is None:
                s_lo = np.sign(v0)
            same = (np.sign(v) == s_lo[:, None]) & np.isfinite(v)
            # first sample on the other side (or none: the root is in the last sub-interval)
            first = np.where(~same.all(axis=1), np.argmin(same, axis=1), M)
            new_lo = np.where(first > 0, x[rows, np.maximum(first - 1, 0)], lo)
            hi = np.where(first < M, x[rows, np.minimum(first, M - 1)], hi)
            lo = new_lo
            miss = np.zeros(lo.size, bool)
            if back is not None:                 # a window without its sign change: zoom on
                miss = back.replaced & ((np.sign(v0) != s_lo) | same.all(axis=1))
                lo, hi = back.fallback(miss, lo, hi)
            back = self._secant(lo, hi, x, v, first, tol, ~miss) if smooth else None
            if back is not None:
                lo, hi = back.lo, back.hi
        return lo, hi

    def _secant(self, lo, hi, x, v, first, tol, fresh):
        """The brackets (``fresh``: just zoomed, both ends samples ``x`` with finite
        values ``v`` of opposite sign) whose samples were :data:`FINISH` × ``tol``
        apart, replaced by the window ± ``tol`` around their secant root (a
        :class:`_Window`), or None."""
        M = self.samples
        rows = np.arange(lo.size)
        h = (x[:, -1] - x[:, 0]) / (M - 1)
        f0, f1 = v[rows, np.clip(first - 1, 0, M - 1)], v[rows, np.clip(first, 0, M - 1)]
        j = np.clip(first - 2, 0, M - 4)          # four samples around the change
        f = [v[rows, j + d] for d in range(4)]
        with np.errstate(all="ignore"):
            d = [f[k + 1] - f[k] for k in range(3)]
            straight = _fits(d[0], d[1]) & _fits(d[2], d[1])
            can = fresh & (np.abs(hi - lo) > tol) & (np.abs(h) <= FINISH * tol) & (first > 0) & (first < M) \
                & np.all(np.isfinite(f), axis=0) & (f0 * f1 < 0) & straight
            if not can.any():
                return None
            r = lo - f0 * (hi - lo) / (f1 - f0)
        return _Window.around(r, lo, hi, tol, can)

    def golden(self, a, b, value, derivatives: bool = False):
        """Minimum of ``value`` in each bracket ``[a_i, b_i]`` (zoom search).

        Each iteration samples ``samples`` interior points of every bracket in one solve
        and keeps the two sub-intervals around the smallest sample.  Once the samples
        are :data:`FINISH` × :attr:`xtol` apart, a bracket whose smallest sample and its
        four neighbours lie on a convex parabola (equal second differences,
        :data:`MODEL_FIT`: a kink fails it) is finished by the parabola's vertex: the
        next solve samples ± :attr:`xtol` around it, and keeps the two sub-intervals
        around its smallest sample when that is inside the window or the window's values
        agree to rounding (:data:`FLAT_ROUNDING`: the value is known, and no sampling
        places it better); else it falls back to the zoom of the bracket it came from.
        The vertex locates a smooth minimum to about ε|f| / (f'' h) (h the samples'
        spacing), closer than the values alone can (the arc is flat to rounding within
        about √(2ε|f| / f'')).  ``value`` as in :meth:`bisect`.  Returns the abscissae
        (K,).
        """
        a = np.array(a, float)
        b = np.array(b, float)
        if a.size == 0:
            return a
        if self.each and a.size > 1:
            return np.concatenate(self._each(self.golden, a, b, value, derivatives))
        rows = np.arange(a.size)
        M = self.samples
        back = None
        while np.max(np.abs(b - a)) > self.xtol:
            x, v = self._sample(a, b, value, derivatives)
            v = np.where(np.isfinite(v), v, np.inf)
            i = np.argmin(v, axis=1)
            xl = np.concatenate([a[:, None], x, b[:, None]], axis=1)
            a, b = xl[rows, i], xl[rows, i + 2]
            miss = np.zeros(a.size, bool)
            if back is not None:              # a window whose smallest sample is at its edge: zoom on
                vmin = v[rows, i]
                flat = np.all(v - vmin[:, None] <= FLAT_ROUNDING * np.maximum(np.abs(vmin), 1.0)[:, None], axis=1)
                miss = back.replaced & ((i == 0) | (i == M - 1)) & ~flat
                a, b = back.fallback(miss, a, b)
            back = self._vertex(a, b, x, v, i, ~miss)
            if back is not None:
                a, b = back.lo, back.hi
        return 0.5 * (a + b)

    def _vertex(self, a, b, x, v, i, fresh):
        """The brackets ``[a, b]`` (``fresh``: just zoomed around sample ``i``) where
        :meth:`golden` finishes, replaced by a window around the model's minimum: the
        vertex of the parabola through samples i − 1, i, i + 1 where the five samples
        around i lie on one (:data:`FINISH`), or the corner of two lines through three
        samples on each side of i where they lie on two (a kink: |g| where g crosses
        zero, an angle folded at 90°; :data:`FINISH_KINK`): a :class:`_Window`, or None."""
        M = self.samples
        rows = np.arange(a.size)
        h = (x[:, -1] - x[:, 0]) / (M - 1)
        f = {d: v[rows, np.clip(i + d, 0, M - 1)] for d in range(-3, 4)}
        with np.errstate(all="ignore"):
            den = f[-1] - 2.0 * f[0] + f[1]            # the second difference at i
            j = np.clip(i - 2, 0, M - 5)              # five samples around the smallest
            d5 = [v[rows, j + k - 1] - 2.0 * v[rows, j + k] + v[rows, j + k + 1] for k in (1, 2, 3)]
            arc = (i > 0) & (i < M - 1) & (den > 0) & _fits(d5[0], d5[1]) & _fits(d5[2], d5[1]) \
                & (np.abs(h) <= FINISH * self.xtol)
            left, right = f[-1] - f[-2], f[2] - f[1]         # slopes × h on either side
            kink = (i > 2) & (i < M - 3) & (left < 0) & (right > 0) & _fits(f[-2] - f[-3], left) \
                & _fits(f[3] - f[2], right) & (np.abs(h) <= FINISH_KINK * self.xtol) & ~arc
            ok = fresh & (np.abs(b - a) > self.xtol) & np.all(np.isfinite(list(f.values())), axis=0)
            arc, kink = arc & ok, kink & ok
            if not (arc.any() or kink.any()):
                return None
            xi = x[rows, i]
            xv = xi - h * (f[1] - f[-1]) / (2.0 * den)
            # the lines f[-1] + left·t and f[1] + right·(t − 2), t in samples from i − 1
            xk = xi + h * ((f[1] - f[-1] - 2.0 * right) / (left - right) - 1.0)
            c = np.where(arc, xv, xk)
            can = (arc | kink) & np.isfinite(c)
        return _Window.around(c, a, b, self.xtol, can)

    def _each(self, refine, lo, hi, value, derivatives, **options) -> list:
        """``refine`` (:meth:`bisect` or :meth:`golden`) on each bracket alone, in turn.

        Every solve follows the path from the reference; one through a single bracket
        shares all its positions before the bracket with the previous solve, which a
        tracked group's continuation resumes from (:func:`~multiloop.kin.groups.newton.track`)
        instead of following the whole path again past every other bracket.  ``value`` of
        bracket i is read with every row set to bracket i's rows."""
        K = lo.size
        out = []
        for i in range(K):
            def alone(st, r, i=i):
                return value(st, np.broadcast_to(r, (K,) + np.shape(r)[1:]))[i:i + 1]
            out.append(refine(lo[i:i + 1], hi[i:i + 1], alone, derivatives, **options))
        return out


def _fits(p, q) -> np.ndarray:
    """Whether the samples' differences ``p`` agree with the model's ``q`` (:data:`MODEL_FIT`)."""
    return np.abs(p - q) <= MODEL_FIT * np.abs(q)


class _Window(NamedTuple):
    """The brackets a zoom's model step replaced (``replaced``; the others as they were)
    by a window around its root or extreme: the new brackets ``(lo, hi)`` and, to fall
    back to, the ones before (``before_lo``, ``before_hi``)."""

    before_lo: np.ndarray
    before_hi: np.ndarray
    replaced: np.ndarray
    lo: np.ndarray
    hi: np.ndarray

    @classmethod
    def around(cls, c, lo, hi, half, replaced) -> "_Window":
        """``[c − half, c + half]`` within each bracket ``(lo, hi)``, in its orientation,
        where ``replaced``."""
        a, b = np.minimum(lo, hi), np.maximum(lo, hi)
        w_lo, w_hi = np.clip(c - half, a, b), np.clip(c + half, a, b)
        flip = hi < lo
        w_lo, w_hi = np.where(flip, w_hi, w_lo), np.where(flip, w_lo, w_hi)
        return cls(lo, hi, replaced, np.where(replaced, w_lo, lo), np.where(replaced, w_hi, hi))

    def fallback(self, miss, lo, hi):
        """``(lo, hi)`` with the brackets ``miss`` back to those before the window."""
        return np.where(miss, self.before_lo, lo), np.where(miss, self.before_hi, hi)
