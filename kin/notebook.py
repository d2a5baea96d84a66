"""Notebook views of kinematic results: HTML tables with a small SVG plot and drawing.

``KinematicState._repr_html_`` and ``CheckReport._repr_html_`` call these; the
drawings are pure SVG text (:mod:`topo.svg`), so no plotting library is imported.

Examples
--------
>>> from multiloop.catalogue.named import load_named
>>> from multiloop.kin.solve import solve
>>> import numpy as np
>>> html = state_html(solve(load_named("four_bar"), np.linspace(0, 2 * np.pi, 13)))
>>> "<table>" in html and "<svg" in html
True
"""
from __future__ import annotations

import numpy as np

from multiloop.topo.svg import bars_svg, mechanism_svg, polyline_svg, table_html

__all__ = ["state_html", "state_svg", "check_html"]


def state_svg(state, k: int = 0, **kw) -> str:
    """Drawing of the mechanism at position ``k`` of a solved state, with tracer paths."""
    m = state.mechanism
    jxy = {n: tuple(state.positions[k, i]) for i, n in enumerate(m.joint_names)}
    names = list(state.point_names)
    pxy = {n: tuple(state.point_positions[k, i]) for i, n in enumerate(names)}
    paths = [[tuple(q) for q in state.point_positions[:, i]] for i in range(len(names))]
    return mechanism_svg(m, jxy, pxy, paths=paths, **kw)


def state_html(state) -> str:
    """Table (positions, status, driver range) + link angles against the input + drawing."""
    m = state.mechanism
    x = np.asarray(state.inputs, float)
    x0 = x[:, 0] if x.ndim == 2 else x
    ok = np.asarray(state.ok, bool)
    rows = {"mechanism": m.name, "positions": len(ok), "ok": int(ok.sum()),
            "drivers": ", ".join(d.joint for d in m.drivers),
            "first input": f"{x0.min():.4g} … {x0.max():.4g} (rad or m from the reference)"}
    ang = {lk: np.degrees(state.angles[:, i]) for i, lk in enumerate(m.link_names)
           if not m.link(lk).is_frame}
    plot = polyline_svg(x0, ang, xlabel="input (link angles, deg)")
    return table_html(rows, "kinematic state", plot + state_svg(state, 0, width=300, height=220))


def check_html(report) -> str:
    """Table of the design check's verdict and drivers + bars of the transmission ranges."""
    d = report.as_dict()
    rows = {"mechanism": d.get("mechanism"), "ok": d.get("ok"), "formula": d.get("formula"),
            "verdict": "; ".join(d.get("verdict") or []) or "no problem found"}
    for j, v in (d.get("drivers") or {}).items():
        rows[f"driver {j}"] = ("full rotation" if v.get("full_rotation")
                              else f"limits {v.get('limits')}")
    bars = {j: (v["min"], v["max"]) for j, v in (d.get("transmission") or {}).items()}
    return table_html(rows, "design check", bars_svg(bars, unit="deg") if bars else "")
