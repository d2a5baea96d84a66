"""The readable text form of a :class:`CheckReport`."""
from __future__ import annotations

from .verdict import fmt_input, usable_text

__all__ = ["format_report"]


def _driver(dc, thr: float) -> list[str]:
    L = [f"driver {dc.joint} ({'R, degrees' if dc.rotary else 'P, metres'} from the reference)"]
    if dc.full_rotation:
        L.append("  range of motion: full rotation" + ("" if dc.periodic else
                                                     " (not periodic in one turn)"))
    elif dc.limits:
        L.append("  range of motion: limited; stops at " + ", ".join(fmt_input(dc, x) for x in dc.limits))
        for s in dc.limit_groups:
            L.append(f"    beyond the limit: {s}")
        if usable_text(dc):
            L.append(f"  {usable_text(dc)}")
    else:
        L.append("  range of motion: no limit within the swept stroke")
    for x, g in dc.branch_points:
        L.append(f"  branch point: {g} at {fmt_input(dc, x)}")
    for lk, xs in dc.dead_centres:
        where = ", ".join(fmt_input(dc, x) for x in xs) or "none (no velocity reversal)"
        L.append(f"  dead centres of {lk}: {where}")
    for a in dc.angles:
        e = a.extreme
        if e is None:
            continue
        flag = "   <-- flagged" if a.flagged(thr) else ""
        L.append(f"  {a.quantity} angle at {a.joint}: min {e.min:.3f}° at {fmt_input(dc, e.at_min)}, "
                 f"max {e.max:.3f}° at {fmt_input(dc, e.at_max)}{flag}")
    if dc.output is not None:
        import numpy as np
        r = np.abs(dc.ratio[np.isfinite(dc.ratio)])
        e = dc.ratio_extreme
        if r.size and e is not None:
            top = (f"unbounded (at the limit {', '.join(fmt_input(dc, x) for x in dc.ratio_unbounded_at)})"
                   if dc.ratio_unbounded_at else f"{e.max:.4g} at {fmt_input(dc, e.at_max)}")
            L.append(f"  velocity ratio {dc.output}/{dc.joint} ({dc.output_unit}): |max| {top}, "
                     f"|min| {e.min:.4g} at {fmt_input(dc, e.at_min)}; mechanical advantage = 1/ratio")
    return L


def _workspace(ws) -> list[str]:
    """The workspace section (``--workspace POINT``)."""
    if ws is None:
        return []
    def at(v):
        return ", ".join(f"{x:.6g}" for x in ws.user(v))
    return [f"workspace of {ws.point} over the usable ranges (driver values in deg / m from the reference):",
            f"  x from {ws.x[0]:.6g} m (at {at(ws.x_at[0])}) to {ws.x[1]:.6g} m (at {at(ws.x_at[1])})",
            f"  y from {ws.y[0]:.6g} m (at {at(ws.y_at[0])}) to {ws.y[1]:.6g} m (at {at(ws.y_at[1])})",
            f"  area {ws.area:.6g} m², boundary polygon of {len(ws.boundary)} vertices (--json)"
            + ("" if ws.exact else " (the outline of the samples"
               + (f": {ws.reason})" if ws.reason else ")"))] + (
            ["  boundary arcs, in order (each set by):"] + [f"    {lab}" for lab in ws.arc_labels()]
            if ws.exact else [])


def format_report(rep) -> str:
    """Text report: header, each driver, circuits, Grashof loops, verdict."""
    L = [f"design check of {rep.mechanism}: {rep.formula}",
         f"threshold: transmission angle {rep.min_transmission:g}° (pressure angle {90 - rep.min_transmission:g}°)", ""]
    for dc in rep.drivers:
        L += _driver(dc, rep.min_transmission) + [""]
    L.append("assembly modes at the reference (modes / reachable by continuous motion):")
    for c in rep.circuits:
        L.append(f"  {c.group}: {c.modes if c.modes is not None else '?'} / "
                 f"{c.reachable if c.reachable is not None else '?'}: {c.note}")
    if rep.grashof:
        L.append("four-bar loops (Grashof):")
        for g in rep.grashof:
            ls = ", ".join(f"{lk} {x * 1000:.4g} mm" for lk, x in zip(g.links, g.lengths))
            L.append(f"  {'-'.join(g.links)}: {g.cls} (fixed {g.fixed}; {ls})")
    fin = sum(c.point is not None for c in rep.instant_centres)
    L.append(f"instant centres: {len(rep.instant_centres)} pairs at input "
             f"{[round(x, 6) for x in rep.instant_centres_at]} ({fin} finite, "
             f"{len(rep.instant_centres) - fin} at infinity)")
    L += _workspace(rep.workspace)
    L.append("")
    if rep.verdict:
        L.append(f"verdict: {len(rep.verdict)} problem(s)")
        L += [f"  - {v}" for v in rep.verdict]
    else:
        L.append("verdict: no problem found")
    return "\n".join(L) + "\n"
