"""The engine model: :class:`Cylinder` and :class:`EngineSpec` (geometry, masses,
speed, gas model; SI units).  Conventions: :mod:`kin.engine.analysis` and
docs/forces.md (Vasilenko et al. 2018).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from multiloop.topo.errors import InputError, explain

from .gas import IndicatorDiagram, PressureTable

__all__ = ["Cylinder", "EngineSpec", "MAX_LENGTH"]

#: largest engine length accepted (m): the limit of the commands' inputs, far beyond any
#: engine, and small enough that squares and volumes stay finite
MAX_LENGTH = 1e9


@dataclass(frozen=True, slots=True)
class Cylinder:
    """One cylinder: ``bank`` = axis angle γ (deg, CCW from x, towards the head);
    ``firing`` = Δ ∈ {0, 360}: the TDC (local crank angle 360 + Δ) that fires."""

    name: str
    bank: float
    firing: float = 0.0


@dataclass(frozen=True)
class EngineSpec:
    """A crank–slider engine with every cylinder's rod on one crank pin (SI units)."""

    crank_radius: float
    rod_length: float
    bore: float
    cylinders: tuple[Cylinder, ...]
    offset: float = 0.0
    rpm: float = 3000.0
    crank_acceleration: float = 0.0
    rod_mass: float = 0.0
    rod_cg: float = 0.0
    rod_inertia: float = 0.0
    piston_mass: float = 0.0
    crank_mass: float = 0.0
    crank_inertia: float = 0.0
    gravity: tuple[float, float] = (0.0, 0.0)
    gas: IndicatorDiagram | PressureTable | None = None
    name: str = "engine"
    description: str | None = None
    source: str | None = None

    @property
    def omega(self) -> float:
        """Crank speed (rad/s) = π n / 30."""
        return self.rpm * math.pi / 30.0

    @property
    def lam(self) -> float:
        """λ = r / l."""
        return self.crank_radius / self.rod_length

    @property
    def piston_area(self) -> float:
        return math.pi * self.bore ** 2 / 4.0

    @property
    def x_tdc(self) -> float:
        """Wrist-pin distance along the axis at TDC: ``sqrt((l + r)² − e²)``."""
        return math.sqrt((self.rod_length + self.crank_radius) ** 2 - self.offset ** 2)

    @property
    def x_bdc(self) -> float:
        return math.sqrt((self.rod_length - self.crank_radius) ** 2 - self.offset ** 2)

    @property
    def stroke(self) -> float:
        """Exact stroke (slightly more than 2r with an offset)."""
        return self.x_tdc - self.x_bdc

    @property
    def swept_volume(self) -> float:
        return self.piston_area * self.stroke

    @property
    def compression_ratio(self) -> float:
        cr = getattr(self.gas, "compression_ratio", None)
        return float(cr) if cr else 10.0

    @property
    def clearance_volume(self) -> float:
        return self.swept_volume / (self.compression_ratio - 1.0)

    @property
    def n_cylinders(self) -> int:
        return len(self.cylinders)

    def banks(self) -> np.ndarray:
        return np.radians([c.bank for c in self.cylinders])

    def validate(self) -> None:
        r, l, e = self.crank_radius, self.rod_length, self.offset
        for key in ("crank_radius", "rod_length", "bore"):
            if not 0 < getattr(self, key) <= MAX_LENGTH:
                raise InputError(explain(f"[engine] {key}", expected=f"a length > 0 and <= {MAX_LENGTH:g} (m)",
                                         got=repr(getattr(self, key))))
        if not abs(e) <= MAX_LENGTH:
            raise InputError(explain("[engine] offset", expected=f"|offset| <= {MAX_LENGTH:g} m", got=repr(e)))
        if not r + abs(e) < l:
            raise InputError(explain("[engine] rod_length", expected=f"> crank_radius + |offset| = {r + abs(e):g} m "
                                     "(the crank must turn fully)", got=repr(l)))
        if not 0.0 <= self.rod_cg <= 1.0:
            raise InputError(explain("[engine] rod_cg", expected="|AG|/l between 0 and 1 (from the crank pin)",
                                     got=repr(self.rod_cg)))
        if not self.rpm > 0:
            raise InputError(explain("[engine] rpm", expected="a speed > 0 (rev/min)", got=repr(self.rpm),
                                     hint="the crank turns counter-clockwise at rpm > 0"))
        for key in ("rod_mass", "rod_inertia", "piston_mass", "crank_mass", "crank_inertia"):
            if getattr(self, key) < 0:
                raise InputError(explain(f"[engine] {key}", expected="a value >= 0", got=repr(getattr(self, key))))
        if not self.cylinders:
            raise InputError(explain("[[cylinder]]", expected="at least one cylinder", got="none"))
        for c in self.cylinders:
            if c.firing not in (0.0, 360.0):
                raise InputError(explain(f"[[cylinder]] '{c.name}' firing", expected="0 or 360", got=repr(c.firing)))
        if self.gas is not None:
            self.gas.validate()
