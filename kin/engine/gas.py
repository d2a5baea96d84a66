"""Cylinder-pressure models of a four-stroke engine: an indicator diagram and a table.

The cycle angle ψ of one cylinder runs over ``[0, 720)`` degrees (docs/forces.md): 0–180 intake, 180–360 compression, firing top dead centre
(TDC) at 360, 360–540 power (expansion), 540–720 exhaust.

Indicator-diagram model (:class:`IndicatorDiagram`)
---------------------------------------------------
An idealised Otto diagram (heat added at constant volume at the firing TDC), all
pressures **absolute**, SI units (Pa, m^3):

=============  ======================================================================
phase          pressure
=============  ======================================================================
intake         ``p = p_a`` (``intake_pressure``)
compression    ``p = p_a (V_180 / V)^n1`` (polytropic, ``n_compression``)
power          ``p = p_z (V_360 / V)^n2`` (``peak_pressure`` p_z, ``n_expansion``)
exhaust        ``p = p_r`` (``exhaust_pressure``)
=============  ======================================================================

``V_180`` and ``V_360`` are the cylinder volumes at ψ = 180 and 360 (bottom and top
dead centre of an in-line cylinder; with an offset cylinder the curve stays a function
of the volume and the cycle work below stays exact).  The cylinder volume is
``V = V_c + A_p (x_TDC − x)`` with the clearance volume ``V_c = V_s / (ε − 1)`` from
the compression ratio ``ε`` and the swept volume ``V_s = A_p · stroke``.

The seed program (Vasilenko et al. 2018) takes only the "maximum cylinder
pressure"; it does not say how the curve is built, so this model is ours and is stated
in full here.  Any measured curve can replace it through :class:`PressureTable`.

The force on the piston is ``F_g = −(p − p_cc) A_p u`` (``u`` the cylinder axis towards
the head, ``p_cc`` the crankcase pressure; a constant ``p_cc`` does no work over a cycle).

Indicated work ``W = ∮ p dV`` in closed form: :meth:`IndicatorDiagram.indicated_work`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from multiloop.topo.errors import InputError, explain

__all__ = ["IndicatorDiagram", "PressureTable", "polytropic_work", "STROKES"]

#: Names of the four strokes, in cycle order (each 180 deg of ψ).
STROKES = ("intake", "compression", "power", "exhaust")


def polytropic_work(p0: float, v0, n: float, v1):
    """``∫_{v0}^{v1} p0 (v0/V)^n dV`` (J), exact; ``n = 1`` is the isothermal case."""
    v0 = np.asarray(v0, float)
    v1 = np.asarray(v1, float)
    if abs(n - 1.0) < 1e-12:
        return p0 * v0 * np.log(v1 / v0)
    return p0 * v0 ** n * (v1 ** (1.0 - n) - v0 ** (1.0 - n)) / (1.0 - n)


@dataclass(frozen=True, slots=True)
class IndicatorDiagram:
    """Idealised four-stroke indicator diagram (see the module docstring).

    Parameters
    ----------
    compression_ratio : float
        ``ε = (V_s + V_c) / V_c`` (> 1).
    peak_pressure : float
        Absolute pressure at the start of expansion, Pa (Vasilenko et al. 2018: "maximum pressure").
    n_compression, n_expansion : float
        Polytropic exponents (defaults 1.35 and 1.25, typical spark-ignition values).
    intake_pressure, exhaust_pressure, crankcase_pressure : float
        Absolute, Pa (defaults 0.09, 0.11 and 0.1 MPa).
    """

    compression_ratio: float
    peak_pressure: float
    n_compression: float = 1.35
    n_expansion: float = 1.25
    intake_pressure: float = 0.09e6
    exhaust_pressure: float = 0.11e6
    crankcase_pressure: float = 0.1e6

    def validate(self, where: str = "[gas]") -> None:
        """Raise :class:`InputError` naming the key at fault."""
        if not self.compression_ratio > 1.0:
            raise InputError(explain(f"{where} compression_ratio", expected="a number > 1",
                                     got=repr(self.compression_ratio)))
        for key in ("n_compression", "n_expansion"):
            if not getattr(self, key) > 0.0:
                raise InputError(explain(f"{where} {key}", expected="a positive exponent",
                                         got=repr(getattr(self, key))))
        for key in ("intake_pressure", "exhaust_pressure", "crankcase_pressure", "peak_pressure"):
            if not getattr(self, key) >= 0.0:
                raise InputError(explain(f"{where} {key}", expected="an absolute pressure >= 0 (Pa)",
                                         got=repr(getattr(self, key))))
        try:
            p_c = self.intake_pressure * self.compression_ratio ** self.n_compression
        except OverflowError:
            raise InputError(explain(f"{where} compression_ratio and n_compression",
                                     expected="an end-of-compression pressure p·ε^n within the float range",
                                     got=f"ε = {self.compression_ratio:g}, n = {self.n_compression:g}")) from None
        if self.peak_pressure < p_c:
            raise InputError(explain(
                f"{where} peak_pressure",
                expected=f"at least the end-of-compression pressure {p_c:.6g} Pa",
                got=repr(self.peak_pressure), hint="pressures are absolute, in Pa"))

    def pressure(self, psi_deg, volume, v180: float, v360: float) -> np.ndarray:
        """Absolute cylinder pressure (Pa) at cycle angles ``psi_deg`` (any shape).

        ``volume`` has the shape of ``psi_deg``; ``v180``/``v360`` are the volumes at
        ψ = 180 and 360 deg.
        """
        psi = np.mod(np.asarray(psi_deg, float), 720.0)
        v = np.asarray(volume, float)
        p = np.full(np.broadcast(psi, v).shape, self.exhaust_pressure)
        p = np.where(psi < 540.0, self.peak_pressure * (v360 / v) ** self.n_expansion, p)
        p = np.where(psi < 360.0, self.intake_pressure * (v180 / v) ** self.n_compression, p)
        p = np.where(psi < 180.0, self.intake_pressure, p)
        return p

    def indicated_work(self, v0: float, v180: float, v360: float, v540: float) -> float:
        """``∮ p dV`` over one cycle (J), exact for this diagram.

        ``v0 … v540`` are the cylinder volumes at ψ = 0, 180, 360, 540 deg (ψ = 720 has
        the volume of ψ = 0).
        """
        w = self.intake_pressure * (v180 - v0)
        w += polytropic_work(self.intake_pressure, v180, self.n_compression, v360)
        w += polytropic_work(self.peak_pressure, v360, self.n_expansion, v540)
        w += self.exhaust_pressure * (v0 - v540)
        return float(w)


@dataclass(frozen=True, slots=True)
class PressureTable:
    """A user pressure curve: rows ``(ψ_deg, p_Pa)`` (absolute), linear interpolation,
    periodic over 720 deg.  ``crankcase_pressure`` as in :class:`IndicatorDiagram`."""

    rows: tuple[tuple[float, float], ...]
    crankcase_pressure: float = 0.1e6

    def validate(self, where: str = "[gas]") -> None:
        if len(self.rows) < 2:
            raise InputError(explain(f"{where} table", expected="at least 2 rows [psi_deg, p_Pa]",
                                     got=f"{len(self.rows)}"))
        psi = [r[0] for r in self.rows]
        if any(b <= a for a, b in zip(psi, psi[1:])):
            raise InputError(explain(f"{where} table", expected="strictly increasing cycle angles",
                                     got=repr(psi[:8])))
        if psi[-1] - psi[0] > 720.0:
            raise InputError(explain(f"{where} table", expected="cycle angles spanning at most 720 deg",
                                     got=f"{psi[0]}..{psi[-1]}"))

    def pressure(self, psi_deg, volume=None, v180=None, v360=None) -> np.ndarray:
        psi = np.mod(np.asarray(psi_deg, float), 720.0)
        xs = np.array([r[0] for r in self.rows], float)
        ps = np.array([r[1] for r in self.rows], float)
        return np.interp(psi, xs, ps, period=720.0)

    def indicated_work(self, *args) -> float:  # pragma: no cover - computed numerically by engine
        return math.nan
