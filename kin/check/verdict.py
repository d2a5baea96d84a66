"""The verdict: the problems a check found, each with its value and where."""
from __future__ import annotations

import numpy as np

__all__ = ["verdict", "fmt_input", "fmt_span", "usable_text"]


def fmt_input(dc, x: float) -> str:
    """Driver value as text: ``O2 = 123.456789°`` or ``S = 0.012 m``."""
    return f"{dc.joint} = {dc.value(x):.6f}°" if dc.rotary else f"{dc.joint} = {x:.6g} m"


def fmt_span(dc, pair) -> str:
    """``[low, high]`` signed from the reference, in degrees (R) or metres (P)."""
    lo, hi = (float(np.degrees(x)) if dc.rotary else float(x) for x in pair)
    return f"[{lo:.6g}, {hi:.6g}] {'deg' if dc.rotary else 'm'}"


def usable_text(dc) -> str | None:
    """The usable range of a driver with a ``range`` and which bound binds at each end."""
    if dc.driver_range is None or dc.usable is None:
        return None
    why = {"range": "its range", "assembly": "the assembly limit"}
    return (f"usable range {fmt_span(dc, dc.usable)} (its range {fmt_span(dc, dc.driver_range)} "
            f"∩ the assembly limits): low end set by {why[dc.bound_at('low')]}, "
            f"high end by {why[dc.bound_at('high')]}")


def _motion(dc) -> list[str]:
    out = []
    if dc.driver_range is not None:
        cut = [e for e in ("low", "high") if dc.bound_at(e) == "assembly"]
        if cut:
            out.append(f"driver {dc.joint}: the assembly limits cut its range "
                       f"{fmt_span(dc, dc.driver_range)} at the {' and '.join(cut)} end "
                       f"(usable {fmt_span(dc, dc.usable)})")
    elif dc.rotary and not dc.full_rotation and dc.limits:
        lim = " and ".join(fmt_input(dc, x) for x in dc.limits)
        out.append(f"driver {dc.joint} does not turn fully: motion stops at {lim} "
                   f"(range {np.degrees(min(dc.limits)):.6f}° … {np.degrees(max(dc.limits)):+.6f}° "
                   f"from the reference)")
    elif not dc.rotary and dc.limits:
        out.append(f"driver {dc.joint} stroke is limited: motion stops at "
                   + " and ".join(f"{x:+.6g} m" for x in dc.limits) + " from the reference")
    if dc.rotary and dc.full_rotation and not dc.periodic:
        out.append(f"driver {dc.joint}: after one full turn the mechanism is not back in the "
                   "reference configuration (a group changed assembly mode)")
    for x, g in dc.branch_points:
        out.append(f"branch point (change point) of {g} at {fmt_input(dc, x)}: the assembly "
                   "is ambiguous there")
    for x in dc.unreachable:
        out.append(f"circuit defect: {fmt_input(dc, x)} cannot be reached from the reference "
                   "without disassembly")
    return out


def _angles(dc, thr: float) -> list[str]:
    out = []
    for a in dc.angles:
        e = a.extreme
        if e is None or not a.flagged(thr) or e.max - e.min <= 1e-9 * max(1.0, abs(e.max)):
            continue     # (an angle this driver does not change is judged under the driver that does)
        if a.quantity == "pressure":
            out.append(f"pressure angle at {a.joint} reaches {e.max:.3f}° at {fmt_input(dc, e.at_max)} "
                       f"(above {90 - thr:g}°) in {a.group}")
            continue
        name = "transmission angle" if a.quantity == "transmission" else "triad transmission angle"
        if e.min < thr:
            out.append(f"{name} at {a.joint} falls to {e.min:.3f}° at {fmt_input(dc, e.at_min)} "
                       f"(below {thr:g}°) in {a.group}")
        if e.max > 180.0 - thr and a.quantity == "transmission":
            out.append(f"{name} at {a.joint} rises to {e.max:.3f}° at {fmt_input(dc, e.at_max)} "
                       f"(above {180 - thr:g}°) in {a.group}")
    return out


def verdict(rep) -> tuple[str, ...]:
    """Problems of a :class:`CheckReport`, one line each (empty: no problem found)."""
    out: list[str] = []
    for dc in rep.drivers:
        out += _motion(dc)
        out += _angles(dc, rep.min_transmission)
    return tuple(out)
