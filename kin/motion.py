"""The motion of one driver: driver ``k`` moved from the reference, the others held there.

:class:`DriverMotion` is the one home of that idea.  It says which inputs move the
driver alone (:meth:`DriverMotion.inputs`, :meth:`DriverMotion.rates`), in which unit
(:attr:`DriverMotion.rotary`: rad, else m), and, once the certified walk of
:func:`kin.solve.motion_events` has followed it (a mechanism with one driver), how far
it goes: the ends ``lo`` ≤ input ≤ ``hi`` from the reference, whether it turns fully
(``period``), the groups that stop it (``limits``) and the change points met on the way
(``crossings``), none read off a grid.  The check (:mod:`kin.check`), the figures, the
sweeps of the forces and the page's driver slider ask it instead of building their own
input arrays.

Examples
--------
>>> from multiloop.catalogue.named import load_named
>>> from multiloop.kin.solve import motion_events
>>> m = load_named("four_bar")
>>> held = DriverMotion.held(m, 0)
>>> held.rotary, held.certified, held.inputs([0.0, 0.5]).tolist()
(True, False, [[0.0], [0.5]])
>>> motion = motion_events(m)
>>> motion.certified, motion.turns_fully, motion.period == 2 * np.pi
(True, True, True)
"""
from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from multiloop.topo.model import Mechanism

__all__ = ["DriverMotion"]

_NONE = MappingProxyType({})


@dataclass(frozen=True, eq=False)
class DriverMotion:
    """Driver ``k`` of ``mechanism`` moved from the reference, the others held there.

    Attributes
    ----------
    mechanism : Mechanism
    k : int
        The driver's index in ``mechanism.drivers``.
    lo, hi : float or None
        The certified ends of the motion from the reference (rad or m), ±inf when the
        driver turns without limit; None when no certified walk followed it (a mechanism
        with several drivers, or :meth:`held`).  An end absent from ``limits`` is not a
        limit: it is the end of the searched extent of a P driver.
    period : float or None
        2π or 4π when the driver turns fully (the motion repeats after it), else None.
    crossings : tuple of (float, str)
        The change points met: (input, label of the group whose two assembly branches meet).
    limits : mapping
        ``{"lo" | "hi": label of the group that stops the motion there}``.
    """

    mechanism: Mechanism
    k: int
    lo: float | None = None
    hi: float | None = None
    period: float | None = None
    crossings: tuple[tuple[float, str], ...] = ()
    limits: MappingProxyType = field(default_factory=lambda: _NONE)

    @classmethod
    def held(cls, mechanism: Mechanism, k: int = 0) -> "DriverMotion":
        """Driver ``k`` moved alone, without a certified range (no walk is run)."""
        return cls(mechanism, k)

    @property
    def joint(self) -> str:
        """The driver's joint."""
        return self.mechanism.drivers[self.k].joint

    @property
    def rotary(self) -> bool:
        """The driver turns (inputs in rad), else it slides (m): :meth:`Mechanism.is_rotary`."""
        return self.mechanism.is_rotary(self.k)

    @property
    def certified(self) -> bool:
        """A certified walk followed the motion (``lo``, ``hi``, ``period``, ``limits``
        and ``crossings`` are known)."""
        return self.lo is not None

    @property
    def turns_fully(self) -> bool:
        """The certified walk found a full turn without a limit (``period`` set)."""
        return self.period is not None

    @property
    def change_points(self) -> tuple[float, ...]:
        """The inputs of the crossings, in order."""
        return tuple(x for x, _ in self.crossings)

    def reaches(self, x) -> np.ndarray:
        """Whether the certified motion reaches each input ``x`` (rad or m from the
        reference): every input when the driver turns fully; else those in
        ``[lo, hi]``, an R input modulo 360° (320° is −40° when turning the other way
        reaches it), as :func:`kin.solve.solve` reduces them."""
        x = np.asarray(x, float)
        if not self.certified:
            raise ValueError("reaches() needs a certified motion (kin.solve.motion_events)")
        if self.turns_fully:
            return np.ones(x.shape, bool)
        if self.rotary:
            t = 2 * np.pi
            x = x + t * np.ceil((self.lo - x) / t)           # the turn of x at or above lo
        return (x >= self.lo) & (x <= self.hi)

    def holds_span(self, x, tol: float = 1e-9) -> bool:
        """Whether the span ``[min x, max x]`` lies in the motion (a full turn holds any
        span; else ``[lo, hi]``, to ``tol`` rad or m): the interval an open target's
        design moves over, continuously, without passing a limit."""
        x = np.asarray(x, float)
        if not self.certified:
            raise ValueError("holds_span() needs a certified motion (kin.solve.motion_events)")
        return self.turns_fully or bool(self.lo - tol <= x.min() and x.max() <= self.hi + tol)

    def inputs(self, x, at=None) -> np.ndarray:
        """Driver inputs ``(N, n_drivers)`` that move this driver through ``x`` (N values,
        rad or m from the reference) and hold every other driver at the reference, or at
        its value in ``at`` (n_drivers,) when given."""
        x = np.asarray(x, float).reshape(-1)
        n = len(self.mechanism.drivers)
        X = np.zeros((x.size, n)) if at is None else np.tile(np.asarray(at, float), (x.size, 1))
        X[:, self.k] = x
        return X

    def rates(self) -> np.ndarray:
        """Input rates ``(n_drivers,)``: this driver at unit rate, the others held."""
        r = np.zeros(len(self.mechanism.drivers))
        r[self.k] = 1.0
        return r
