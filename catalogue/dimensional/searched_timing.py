"""Free timing with the driver values among the global search's variables.

With free timing the targets' driver values are unknowns.  ``free_timing="matched"``
(:meth:`~.objective.Problem.batch`) solves each candidate on the whole driver grid,
walked from the reference, and matches the targets to that curve in driver order by
dynamic programming: the search's variables are the design's alone.
``free_timing="searched"`` (the default with a global search and no constraint on the
whole motion) makes the driver values
search variables instead, as Pyslvs's ``FPlanar`` and much of the literature since
Cabrera, Simon & Prado (2002) do: a candidate is solved at its own ``N`` target inputs
only, and scored by the same relative residuals the local polish minimises
(:meth:`~.objective.Problem.residuals_batch`).  A candidate then costs ``N`` positions
instead of the grid's ``M`` (96) and the matching, and the search has ``N + 2`` more
variables.

The driver values are encoded so that every point of the unit box meets the targets
in driver order, one way, within one turn (within the slider's ±2 sizes):

* ``timing.start`` — the first target's driver value from the reference (within a turn
  either way: a design short of a full turn may reach past ±π on one side),
* ``timing.span`` — the driver's travel from the first target to the last,
* ``timing.sense`` — which way (only when ``direction`` is ``"any"``: ≥ 0.5 forward),
* ``timing.step1`` … ``timing.step{N−1}`` — the steps' shares of the span.

Continuity is not scored by the search (no grid is solved): the chosen design's
continuity from the reference through its targets in order is decided by the
certified walk (:func:`~.synthesise._certified`), as for the matched route.
"""
from __future__ import annotations

import numpy as np

__all__ = ["FREE_TIMINGS", "SearchedTiming"]

#: what free timing's search varies: the design alone (the targets matched to its
#: curve on the driver grid) or the design and the targets' driver values
FREE_TIMINGS = ("matched", "searched")

_SHARE_FLOOR = 1e-6      # (every step a share of the span, even when all weights are 0)


class SearchedTiming:
    """The global search's view of a free-timing :class:`~.objective.Problem`: the
    design's variables followed by the timing's (module docstring); ``lower``,
    ``upper``, ``x0``, ``names`` and :meth:`batch` as the problem has them, and
    :meth:`split` back to the problem's designs and driver values."""

    def __init__(self, problem):
        self.problem = problem
        n = problem.n_targets
        # the first value within a turn of the reference either way (a design short of a full
        # turn may reach past ±π on one side), the travel within one turn; a slider's both
        # within the grid's ±2 sizes
        first, reach = (2.0 * np.pi, 2.0 * np.pi) if problem.rotary else (2.0 * problem.mech_size,
                                                                          4.0 * problem.mech_size)
        self.sensed = len(problem.walks()) == 2
        names = ["timing.start", "timing.span"] + (["timing.sense"] if self.sensed else []) + \
                [f"timing.step{i}" for i in range(1, n)]
        lo = [-first, 0.0] + ([0.0] if self.sensed else []) + [0.0] * (n - 1)
        hi = [first, reach] + ([1.0] if self.sensed else []) + [1.0] * (n - 1)
        self.nz = len(problem.names)
        self.names = tuple(problem.names) + tuple(names)
        self.lower = np.r_[problem.lower, lo]
        self.upper = np.r_[problem.upper, hi]
        self.x0 = np.r_[problem.x0, self.encode(problem.match(problem.x0))]
        self.forward = 1.0 if problem.walks() == (0,) else -1.0     # (one allowed walk: its sense)

    def encode(self, phi: np.ndarray) -> np.ndarray:
        """The timing variables of driver values ``phi`` ``(N,)`` met in driver order,
        clipped to their bounds."""
        phi = np.asarray(phi, float)
        steps = np.diff(phi)
        up = bool(np.sum(steps) >= 0.0)
        span = float(np.sum(np.abs(steps)))
        top = float(np.max(np.abs(steps))) if len(steps) else 0.0
        shares = np.abs(steps) / top if top > 0 else np.ones(len(steps))
        t = [phi[0], span] + ([1.0 if up else 0.0] if self.sensed else []) + list(shares)
        return np.clip(np.array(t, float), self.lower[self.nz:], self.upper[self.nz:])

    def split(self, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The problem's designs ``(P, n)`` and driver values ``(P, N)`` (from the
        reference, in target order) of search points ``Y`` ``(P, n + N + 1|2)``."""
        Y = np.atleast_2d(Y)
        Z, t = Y[:, :self.nz], Y[:, self.nz:]
        k = 3 if self.sensed else 2
        sense = np.where(t[:, 2] >= 0.5, 1.0, -1.0) if self.sensed else np.full(len(Y), self.forward)
        w = t[:, k:] + _SHARE_FLOOR
        cum = np.cumsum(w, axis=1) / np.sum(w, axis=1, keepdims=True)
        steps = np.concatenate([np.zeros((len(Y), 1)), cum], axis=1)
        return Z, t[:, :1] + (sense * t[:, 1])[:, None] * steps

    def batch(self, Y: np.ndarray) -> np.ndarray:
        """The objective of search points ``Y`` ``(P, n + …)``: each design scored at its
        own driver values (:meth:`~.objective.Problem.score_at`, as prescribed timing's
        search scores its candidates at the targets' values)."""
        return self.problem.score_at(*self.split(Y))
