"""A synthesis run's limits (:class:`Budget`) and what the run has spent of them (:class:`Meter`).

Two limits, either or both:

* **evaluations**, the candidate designs the search and the polish score (every design
  of a population, every design of a finite-difference Jacobian).  A run under an
  evaluation budget is reproducible: every decision of the search (when to probe, how
  much each phase gets, when to stop) reads the count of evaluations, never the clock,
  so the same seed gives the same design, byte for byte, on a loaded machine or an idle
  one, with any number of BLAS threads;
* **seconds**, a wall-time cap: the run stops when it is reached, and so depends on the
  machine's load.

When neither is given, the run has :data:`DEFAULT_EVALUATIONS` evaluations (the synthesis
without a start has its own default) and no cap.  With both, the evaluations drive the
run and the seconds only stop it.  :data:`STOPS` are the reasons a run reports for
stopping.

A :class:`Meter` is the running count of one run or of one of its phases: a phase's
meter (:meth:`Meter.share`, :meth:`Meter.until`) passes what it spends on to the run's.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from multiloop.topo.errors import ParameterError, explain

__all__ = ["Budget", "Meter", "DEFAULT_EVALUATIONS", "MAX_EVALUATIONS", "MAX_SECONDS", "STOPS", "LIMITS"]

#: evaluations of a run with a start when neither limit is given (a four-bar: a few
#: seconds; a triad mechanism: about a minute)
DEFAULT_EVALUATIONS = 20_000
#: the largest evaluation budget accepted
MAX_EVALUATIONS = 10 ** 12
#: the longest wall-time cap accepted (s): a day
MAX_SECONDS = 86_400.0
#: why a run stopped: the error met ``tol``; the evaluations or the seconds ran out; the
#: search ended on its own (a local polish converged); every retrieved start was screened
#: (the synthesis without a start, with limits left)
STOPS = ("tolerance", "evaluations", "budget", "converged", "exhausted")
#: the stops that are a limit reached
LIMITS = ("evaluations", "budget")


def _evaluations(value, what: str) -> int | None:
    """``value`` as a whole number of evaluations in [1, :data:`MAX_EVALUATIONS`] (an
    integer, or its text), or None."""
    if value is None:
        return None
    n = None
    if isinstance(value, str):
        try:
            n = int(value.strip())
        except ValueError:
            n = None
    elif isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_)):
        n = int(value)
    if n is None or not 1 <= n <= MAX_EVALUATIONS:
        raise ParameterError(explain(what, expected=f"a whole number of evaluations from 1 to {MAX_EVALUATIONS:.0e}",
                                     got=repr(value)), what)
    return n


def _seconds(value, what: str) -> float | None:
    """``value`` as a number of seconds in (0, :data:`MAX_SECONDS`], or None."""
    if value is None:
        return None
    ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))
    if not ok or not math.isfinite(value) or not 0 < value <= MAX_SECONDS:
        raise ParameterError(explain(what, expected=f"a positive number of seconds, at most {MAX_SECONDS:g} (a day)",
                                     got=repr(value)), what)
    return float(value)


@dataclass(frozen=True, slots=True)
class Budget:
    """The limits of a synthesis run: ``evaluations`` (reproducible) and ``seconds`` (a
    wall-time cap); None is no limit."""

    evaluations: int | None = None
    seconds: float | None = None

    @classmethod
    def of(cls, evaluations=None, seconds=None, *, default: int | None = DEFAULT_EVALUATIONS) -> Budget:
        """The checked limits; ``default`` evaluations when neither is given.

        Parameters
        ----------
        evaluations : int or str, optional
            A whole number of evaluations in [1, :data:`MAX_EVALUATIONS`] (or its text).
        seconds : float, optional
            A positive, finite number of seconds.
        default : int or None
            The evaluations when neither is given (None: no limit is filled in).

        Raises
        ------
        ParameterError
            A limit out of range, not a number, or (evaluations) not a whole number; the
            message starts with the synthesisers' parameter, ``evaluations`` or ``budget``
            (the command line shows its flag in its place).

        Examples
        --------
        >>> Budget.of(5000)
        Budget(evaluations=5000, seconds=None)
        >>> Budget.of()
        Budget(evaluations=20000, seconds=None)
        >>> Budget.of(seconds=2.5)
        Budget(evaluations=None, seconds=2.5)
        """
        n, s = _evaluations(evaluations, "evaluations"), _seconds(seconds, "budget")
        if n is None and s is None and default is not None:
            n = default
        return cls(n, s)

    @property
    def is_reproducible(self) -> bool:
        """True when no wall-time cap can stop the run (its result is the seed's alone)."""
        return self.seconds is None and self.evaluations is not None

    def as_dict(self) -> dict:
        return {"evaluations": self.evaluations, "seconds": self.seconds}

    def keywords(self) -> dict:
        """The limits as the synthesisers' keywords (``evaluations=``, ``budget=``)."""
        return {"evaluations": self.evaluations, "budget": self.seconds}


class Meter:
    """What a run (or one phase of it) has spent: evaluations counted and seconds passed.

    ``evaluations`` is the phase's limit (``inf``: none), ``deadline`` a
    ``time.perf_counter()`` value (None: none); ``parent`` is the meter of the run the
    phase belongs to, which is charged too and whose limits bind the phase as well.

    :meth:`clock` is the phase's progress in the unit that drives the run: the
    evaluations spent when there is an evaluation limit, else the seconds passed.
    """

    def __init__(self, evaluations: float = math.inf, deadline: float | None = None, parent: Meter | None = None):
        self.evaluations, self.deadline, self.parent = float(evaluations), deadline, parent
        self.used = 0
        self.refused = False            # a charge was refused for want of evaluations
        self.t0 = time.perf_counter()

    @classmethod
    def start(cls, budget: Budget, deadline: float | None = None) -> Meter:
        """The meter of a run with ``budget``; ``deadline`` overrides the seconds' end."""
        if deadline is None and budget.seconds is not None:
            deadline = time.perf_counter() + budget.seconds
        return cls(math.inf if budget.evaluations is None else budget.evaluations, deadline)

    @property
    def counted(self) -> bool:
        """Whether evaluations drive this meter (a finite evaluation limit)."""
        return math.isfinite(self.evaluations)

    def spend(self, n: int) -> None:
        """Charge ``n`` evaluations (to the run too)."""
        self.used += int(n)
        if self.parent is not None:
            self.parent.spend(n)

    def left(self) -> float:
        """Evaluations left (``inf`` without a limit), the run's limit included."""
        own = self.evaluations - self.used
        return own if self.parent is None else min(own, self.parent.left())

    def affordable(self, n: int) -> int:
        """How many of ``n`` designs may still be evaluated."""
        left = self.left()
        return int(n) if left >= n else max(0, int(math.floor(left)))

    def take(self, n: int, whole: bool = False) -> int:
        """Charge as many of ``n`` evaluations as are left (with ``whole``, all or none)
        and return how many; a refusal is remembered (:meth:`stop` says ``"evaluations"``)."""
        k = self.affordable(n)
        if k < n:
            self.refused = True
            k = 0 if whole else k
        self.spend(k)
        return k

    def settle(self, n: int, refused: bool) -> None:
        """Charge ``n`` evaluations that a compiled loop spent within :meth:`left` (read
        before it ran); ``refused`` when it stopped for want of more (as :meth:`take`
        remembers a refusal)."""
        self.spend(n)
        self.refused = self.refused or refused

    def elapsed(self) -> float:
        return time.perf_counter() - self.t0

    def late(self) -> bool:
        """Past the deadline (this phase's or the run's)."""
        if self.deadline is not None and time.perf_counter() > self.deadline:
            return True
        return self.parent is not None and self.parent.late()

    def stop(self) -> str | None:
        """``"evaluations"`` when none is left (or a charge was refused), ``"budget"`` past
        the deadline, else None."""
        if self.refused or self.left() < 1:
            return "evaluations"
        return "budget" if self.late() else None

    def clock(self) -> float:
        """Progress in the unit that drives the run: evaluations spent, or seconds passed."""
        return float(self.used) if self.counted else self.elapsed()

    def span(self) -> float:
        """The phase's length in :meth:`clock`'s unit (``inf`` without a limit)."""
        if self.counted:
            return self.evaluations
        return math.inf if self.deadline is None else self.deadline - self.t0

    def fraction(self) -> float:
        """The share of the phase spent, in [0, 1]."""
        span = self.span()
        return 0.0 if not span > 0 or math.isinf(span) else min(self.clock() / span, 1.0)

    def share(self, fraction: float) -> Meter:
        """A phase with ``fraction`` of what is left: evaluations and seconds."""
        now = time.perf_counter()
        deadline = None if self.deadline is None else now + fraction * max(self.deadline - now, 0.0)
        return Meter(fraction * self.left(), deadline, self)

    def until(self, fraction: float, seconds_fraction: float | None = None) -> Meter:
        """A phase that ends when the run has spent ``fraction`` of its evaluations and
        ``seconds_fraction`` (default ``fraction``) of its seconds, counted from the start."""
        sf = fraction if seconds_fraction is None else seconds_fraction
        deadline = None if self.deadline is None else self.t0 + sf * (self.deadline - self.t0)
        return Meter(max(fraction * self.evaluations - self.used, 0.0), deadline, self)

    def scaled(self, fraction: float) -> Budget:
        """``fraction`` of this meter's whole limits."""
        return Budget(int(fraction * self.evaluations) if self.counted else None,
                      None if self.deadline is None else fraction * (self.deadline - self.t0))

    def portion(self, parts: int, least: Budget = Budget(), smallest: Budget = Budget(1, 0.0)) -> Budget | None:
        """The limits of one of ``parts`` equal parts of what is left, at least ``least``;
        None when a limit is below ``smallest``: too little to be worth a call."""
        n = s = None
        if self.counted:
            n = int(math.floor(max(self.left() / parts, least.evaluations or 0)))
            if n < max(smallest.evaluations or 1, 1):
                return None
        if self.deadline is not None:
            s = max((self.deadline - time.perf_counter()) / parts, least.seconds or 0.0)
            if s <= 0.0 or s < (smallest.seconds or 0.0):
                return None
        return Budget(n, s)

    def binding(self) -> str:
        """The limit nearer its end (of the ones set): ``"evaluations"`` or ``"budget"``."""
        if self.deadline is None:
            return "evaluations"
        if not self.counted:
            return "budget"
        time_left = (self.deadline - time.perf_counter()) / max(self.deadline - self.t0, 1e-300)
        return "evaluations" if self.left() / self.evaluations <= time_left else "budget"
