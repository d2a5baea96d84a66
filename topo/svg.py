"""A small pure-text SVG drawer of a planar linkage (notebook previews, no plotting library).

Links are drawn as bars (two joints) or light polygons (three or more, the convex hull
of their joints and points), pins as circles, sliders as squares on their guide line,
frame pins with a ground mark, tracer points as dots, and every joint and point with
its name.  Used by ``Mechanism._repr_svg_`` (the reference configuration) and by the
notebook views of solved motions, which pass other coordinates.

Examples
--------
>>> svg = linkage_svg({"crank": [(0, 0), (1, 0)]}, {"O": (0, 0), "A": (1, 0)}, frame_joints={"O"})
>>> svg.startswith("<svg") and ">O</text>" in svg
True
"""
from __future__ import annotations

import math
from html import escape
from typing import Mapping, Sequence

__all__ = ["linkage_svg", "polyline_svg", "mechanism_svg", "table_html", "bars_svg", "report_html"]

Point = tuple[float, float]


def _hull(pts: Sequence[Point]) -> list[Point]:
    """Convex hull (Andrew's monotone chain), counter-clockwise."""
    p = sorted(set((float(x), float(y)) for x, y in pts))
    if len(p) <= 2:
        return p

    def half(seq):
        out: list[Point] = []
        for q in seq:
            while len(out) >= 2 and ((out[-1][0] - out[-2][0]) * (q[1] - out[-2][1])
                                     - (out[-1][1] - out[-2][1]) * (q[0] - out[-2][0])) <= 0:
                out.pop()
            out.append(q)
        return out
    lower, upper = half(p), half(reversed(p))
    return lower[:-1] + upper[:-1]


class _Frame:
    """Maps model coordinates (y up) into an SVG box (y down) with a margin."""

    def __init__(self, pts: Sequence[Point], width: int, height: int, margin: int = 28):
        xs = [p[0] for p in pts] or [0.0]
        ys = [p[1] for p in pts] or [0.0]
        self.x0, self.y1 = min(xs), max(ys)
        span = max(max(xs) - self.x0, max(ys) - min(ys), 1e-12)
        self.s = min(width - 2 * margin, height - 2 * margin) / span
        self.m = margin

    def __call__(self, p: Point) -> tuple[float, float]:
        return (self.m + (p[0] - self.x0) * self.s, self.m + (self.y1 - p[1]) * self.s)


def _finite(p) -> bool:
    return p is not None and all(math.isfinite(float(v)) for v in p)


def linkage_svg(links: Mapping[str, Sequence[Point]], joints: Mapping[str, Point], *,
                frame_joints=(), sliders: Mapping[str, Point] | None = None,
                points: Mapping[str, Point] | None = None, paths: Sequence[Sequence[Point]] = (),
                title: str | None = None, width: int = 360, height: int = 280) -> str:
    """An SVG string of a linkage at given coordinates.

    Parameters
    ----------
    links : mapping link name → the points on it (joints and tracer points)
    joints : mapping joint name → position (pins and sliders)
    frame_joints : names of the joints on the frame (drawn with a ground mark)
    sliders : mapping slider joint name → guide direction (unit vector), optional
    points : mapping tracer point name → position, optional
    paths : polylines drawn thin under the linkage (e.g. tracer paths)
    """
    sliders, points = dict(sliders or {}), dict(points or {})
    allp = [p for p in list(joints.values()) + list(points.values()) if _finite(p)]
    allp += [q for path in paths for q in path if _finite(q)]
    f = _Frame(allp, width, height)
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
           f'viewBox="0 0 {width} {height}" font-family="sans-serif" font-size="11">']
    if title:
        out.append(f'<title>{escape(title)}</title>')
    for path in paths:
        pts = " ".join("%.1f,%.1f" % f(q) for q in path if _finite(q))
        out.append(f'<polyline points="{pts}" fill="none" stroke="#9ab" stroke-width="1"/>')
    for name, pts in links.items():
        good = [q for q in pts if _finite(q)]
        hull = _hull(good)
        if len(hull) >= 3:
            poly = " ".join("%.1f,%.1f" % f(q) for q in hull)
            out.append(f'<polygon points="{poly}" fill="#cde" fill-opacity="0.6" stroke="#357" '
                       f'stroke-width="2"><title>{escape(name)}</title></polygon>')
        elif len(hull) == 2:
            (x1, y1), (x2, y2) = f(hull[0]), f(hull[1])
            out.append(f'<line x1="{x1:.1f}" y1="{y1:.1f}" x2="{x2:.1f}" y2="{y2:.1f}" stroke="#357" '
                       f'stroke-width="3" stroke-linecap="round"><title>{escape(name)}</title></line>')
    for name, p in joints.items():
        if not _finite(p):
            continue
        x, y = f(p)
        if name in frame_joints:
            out.append(f'<path d="M{x:.1f},{y:.1f} l-7,11 h14 z" fill="#888"/>')
        if name in sliders:
            ux, uy = sliders[name]
            out.append(f'<line x1="{x - 30 * ux:.1f}" y1="{y + 30 * uy:.1f}" x2="{x + 30 * ux:.1f}" '
                       f'y2="{y - 30 * uy:.1f}" stroke="#888" stroke-dasharray="4 3"/>')
            out.append(f'<rect x="{x - 6:.1f}" y="{y - 6:.1f}" width="12" height="12" fill="#fff" stroke="#333"/>')
        else:
            out.append(f'<circle cx="{x:.1f}" cy="{y:.1f}" r="4" fill="#fff" stroke="#333" stroke-width="1.5"/>')
        out.append(f'<text x="{x + 7:.1f}" y="{y - 7:.1f}">{escape(name)}</text>')
    for name, p in points.items():
        if _finite(p):
            x, y = f(p)
            out.append(f'<circle cx="{x:.1f}" cy="{y:.1f}" r="3" fill="#c33"/>'
                       f'<text x="{x + 6:.1f}" y="{y + 13:.1f}" fill="#c33">{escape(name)}</text>')
    out.append("</svg>")
    return "\n".join(out)


def polyline_svg(x: Sequence[float], ys: Mapping[str, Sequence[float]], *, xlabel: str = "",
                 width: int = 320, height: int = 160) -> str:
    """A small line plot (one polyline per series) as SVG text, with the ranges written."""
    colours = ["#357", "#c33", "#393", "#a6c", "#d80", "#0aa"]
    vals = [float(v) for s in ys.values() for v in s if math.isfinite(float(v))] or [0.0]
    xs = [float(v) for v in x] or [0.0]
    lo, hi = min(vals), max(vals)
    hi = hi if hi > lo else lo + 1.0
    x0, x1 = min(xs), max(xs) if max(xs) > min(xs) else min(xs) + 1.0
    m = 24

    def px(a, b):
        return m + (a - x0) / (x1 - x0) * (width - 2 * m), height - m - (b - lo) / (hi - lo) * (height - 2 * m)
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" font-size="10" '
           f'font-family="sans-serif"><rect x="{m}" y="{m}" width="{width - 2 * m}" height="{height - 2 * m}" '
           f'fill="none" stroke="#ccc"/>']
    for k, (name, s) in enumerate(ys.items()):
        pts = " ".join("%.1f,%.1f" % px(a, float(b)) for a, b in zip(xs, s) if math.isfinite(float(b)))
        c = colours[k % len(colours)]
        out.append(f'<polyline points="{pts}" fill="none" stroke="{c}" stroke-width="1.5"/>'
                   f'<text x="{m + 4 + 70 * k}" y="{m - 6}" fill="{c}">{escape(name)}</text>')
    out.append(f'<text x="{m}" y="{height - 6}">{x0:.4g} … {x1:.4g} {escape(xlabel)}</text>'
               f'<text x="{width - m}" y="{m - 6}" text-anchor="end">{lo:.4g} … {hi:.4g}</text></svg>')
    return "".join(out)


def mechanism_svg(m, joint_xy: Mapping[str, Point] | None = None,
                  point_xy: Mapping[str, Point] | None = None, paths=(), **kw) -> str:
    """SVG of a mechanism: at its reference, or at the given joint / point coordinates.

    ``m`` is a :class:`~multiloop.topo.model.Mechanism` (duck-typed, so this module
    does not import the model).  A bare chain (no positions) gives a note instead.
    """
    if not m.has_geometry:
        return (f'<svg xmlns="http://www.w3.org/2000/svg" width="360" height="40" font-size="12">'
                f'<text x="8" y="24">{escape(m.name or "chain")}: {m.n_links} links, {m.n_joints} joints '
                f'(no positions to draw)</text></svg>')
    jxy = dict(joint_xy) if joint_xy is not None else {j.name: j.at for j in m.joints}
    pxy = dict(point_xy) if point_xy is not None else {p.name: p.at for p in m.points}
    links = {lk.name: [jxy[j.name] for j in m.joints if lk.name in j.links]
             + [pxy[p.name] for p in m.points if p.link == lk.name]
             for lk in m.links if not lk.is_frame}
    sliders = {j.name: j.axis for j in m.joints if j.kind.value == "P" and joint_xy is None}
    sliders.update({j.name: (1.0, 0.0) for j in m.joints if j.kind.value == "P" and j.name not in sliders})
    frame = {j.name for j in m.joints if m.frame in j.links}
    return linkage_svg(links, jxy, frame_joints=frame, sliders=sliders, points=pxy, paths=paths,
                       title=m.name, **kw)


def table_html(rows: Mapping[str, object], title: str = "", figure: str = "") -> str:
    """An HTML table of ``name → value`` rows, with an optional SVG figure beside it."""
    body = "".join(f"<tr><th style='text-align:left'>{escape(str(k))}</th>"
                   f"<td style='text-align:left'>{escape(str(v))}</td></tr>" for k, v in rows.items())
    head = f"<b>{escape(title)}</b>" if title else ""
    return (f"<div>{head}<div style='display:flex;gap:16px;align-items:flex-start'>"
            f"<table>{body}</table><div>{figure}</div></div></div>")


def bars_svg(values: Mapping[str, tuple[float, float]], *, unit: str = "", width: int = 300) -> str:
    """Horizontal range bars ``name: lo … hi`` (a count is the range ``0 … n``) as SVG text."""
    items = [(k, float(a), float(b)) for k, (a, b) in values.items()
             if math.isfinite(float(a)) and math.isfinite(float(b))]
    top = max([b for _, _, b in items] + [1e-12])
    h = 18 * len(items) + 8
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{h}" font-size="10" '
           f'font-family="sans-serif">']
    for i, (k, a, b) in enumerate(items):
        x0, x1 = 70 + a / top * (width - 150), 70 + b / top * (width - 150)
        out.append(f'<text x="2" y="{18 * i + 16}">{escape(k)}</text><rect x="{x0:.1f}" y="{18 * i + 6}" '
                   f'width="{max(x1 - x0, 2):.1f}" height="12" fill="#579"/><text x="{x1 + 4:.1f}" '
                   f'y="{18 * i + 16}">{a:.4g} … {b:.4g} {escape(unit)}</text>')
    out.append("</svg>")
    return "".join(out)


def report_html(report) -> str:
    """Notebook view of a structural report: its numbers and bars of [LA] and [MJA]."""
    d = report.as_dict()
    rows = {k: d[k] for k in ("name", "n", "p", "LA", "MJA", "V", "K", "F", "N", "rc", "La", "code",
                              "planar", "degenerate", "fractionated") if k in d}
    counts = {f"n{i + 2}": (0, v) for i, v in enumerate(d["LA"])}
    counts.update({f"V{i + 2}": (0, v) for i, v in enumerate(d["MJA"])})
    return table_html(rows, "structural report", bars_svg(counts))
