"""The verdict: the problems a check found, each with its value and where.

Every number is written through a ``units`` value (the command line's, :data:`SI`, by
default: degrees and metres); a caller that shows other units (the web page's mm / in
and rad) passes its own, with the two methods of :class:`SIUnits`.

>>> class MmRad(SIUnits):
...     def shown(self, value, unit):
...         return float(value) * (1000.0 if unit == "m" else 0.017453292519943295)
...     def label(self, unit):
...         return "mm" if unit == "m" else "rad"
>>> quantity(40.0, "deg", ".3f"), quantity(40.0, "deg", ".3f", MmRad())
('40.000°', '0.698 rad')
>>> quantity(0.012, "m", ".6g", MmRad())
'12 mm'
"""
from __future__ import annotations

import numpy as np

from .angle_types import angle_type

__all__ = ["verdict", "fmt_input", "fmt_span", "usable_text", "quantity", "SIUnits", "SI"]


class SIUnits:
    """The command line's units: a value in ``"deg"`` or ``"m"`` is shown as it is."""

    def shown(self, value: float, unit: str) -> float:
        """``value`` (in ``unit``, ``"deg"`` or ``"m"``) in the units shown."""
        return float(value)

    def label(self, unit: str) -> str:
        """The name of the unit shown for a quantity in ``unit``."""
        return unit


#: the default units of every text: degrees and metres
SI = SIUnits()


def quantity(value: float, unit: str, spec: str, units=SI) -> str:
    """``value`` (in ``unit``: ``"deg"`` or ``"m"``) in ``units`` with its unit, formatted
    by ``spec``: ``40.000°`` (degrees), ``0.698 rad``, ``0.012 m``."""
    label = units.label(unit)
    return f"{units.shown(value, unit):{spec}}" + ("°" if label == "deg" else f" {label}")


def fmt_input(dc, x: float, units=SI) -> str:
    """Driver value as text: ``O2 = 123.456789°`` or ``S = 0.012 m``."""
    return f"{dc.joint} = " + (quantity(dc.value(x), "deg", ".6f", units) if dc.rotary
                               else quantity(x, "m", ".6g", units))


def fmt_span(dc, pair, units=SI) -> str:
    """``[low, high]`` signed from the reference, in degrees (R) or metres (P)."""
    unit = "deg" if dc.rotary else "m"
    lo, hi = (units.shown(float(np.degrees(x)) if dc.rotary else float(x), unit) for x in pair)
    return f"[{lo:.6g}, {hi:.6g}] {units.label(unit)}"


def usable_text(dc, units=SI) -> str | None:
    """The usable range of a driver with a ``range`` and which bound binds at each end."""
    if dc.driver_range is None or dc.usable is None:
        return None
    why = {"range": "its range", "assembly": "the assembly limit"}
    return (f"usable range {fmt_span(dc, dc.usable, units)} (its range {fmt_span(dc, dc.driver_range, units)} "
            f"∩ the assembly limits): low end set by {why[dc.bound_at('low')]}, "
            f"high end by {why[dc.bound_at('high')]}")


def _motion(dc, u) -> list[str]:
    out = []
    if dc.driver_range is not None:
        cut = [e for e in ("low", "high") if dc.bound_at(e) == "assembly"]
        if cut:
            out.append(f"driver {dc.joint}: the assembly limits cut its range "
                       f"{fmt_span(dc, dc.driver_range, u)} at the {' and '.join(cut)} end "
                       f"(usable {fmt_span(dc, dc.usable, u)})")
    elif dc.rotary and not dc.full_rotation and dc.limits:
        lim = " and ".join(fmt_input(dc, x, u) for x in dc.limits)
        lo, hi = (quantity(np.degrees(f(dc.limits)), "deg", s, u) for f, s in ((min, ".6f"), (max, "+.6f")))
        out.append(f"driver {dc.joint} does not turn fully: motion stops at {lim} "
                   f"(range {lo} … {hi} from the reference)")
    elif not dc.rotary and dc.limits:
        out.append(f"driver {dc.joint} stroke is limited: motion stops at "
                   + " and ".join(quantity(x, "m", "+.6g", u) for x in dc.limits) + " from the reference")
    if dc.rotary and dc.full_rotation and not dc.periodic:
        out.append(f"driver {dc.joint}: after one full turn the mechanism is not back in the "
                   "reference configuration (a group changed assembly mode)")
    for x, g in dc.branch_points:
        out.append(f"branch point (change point) of {g} at {fmt_input(dc, x, u)}: the assembly "
                   "is ambiguous there")
    for x in dc.unreachable:
        out.append(f"circuit defect: {fmt_input(dc, x, u)} cannot be reached from the reference "
                   "without disassembly")
    return out


def _angles(dc, thr: float, u) -> list[str]:
    out = []

    def deg(v, spec=".3f"):
        return quantity(v, "deg", spec, u)
    for a in dc.angles:
        e = a.extreme
        if e is None or not a.flagged(thr) or e.max - e.min <= 1e-9 * max(1.0, abs(e.max)):
            continue     # (an angle this driver does not change is judged under the driver that does)
        t = angle_type(a.quantity)
        for d in t.degenerate:
            if t.low(d) and e.min < d + thr:
                out.append(f"{t.label} at {a.joint} falls to {deg(e.min)} at {fmt_input(dc, e.at_min, u)} "
                           f"(below {deg(d + thr, 'g')}) in {a.group}")
            elif not t.low(d) and e.max > d - thr:
                out.append(f"{t.label} at {a.joint} {t.rises} {deg(e.max)} at {fmt_input(dc, e.at_max, u)} "
                           f"(above {deg(d - thr, 'g')}) in {a.group}")
    return out


def verdict(rep, units=SI) -> tuple[str, ...]:
    """Problems of a :class:`CheckReport`, one line each (empty: no problem found).

    Parameters
    ----------
    rep : CheckReport
        The report (its drivers and its threshold).
    units : SIUnits, optional
        The units its numbers are written in (default :data:`SI`: degrees and metres,
        the report's own ``verdict`` lines).

    Returns
    -------
    tuple of str
    """
    out: list[str] = []
    for dc in rep.drivers:
        out += _motion(dc, units)
        out += _angles(dc, rep.min_transmission, units)
    return tuple(out)
