"""Drawings for CAD: a solved mechanism as layered SVG and DXF (millimetres).

Both formats carry the same five layers, so a CAD user can hide or restyle each:

=========  =============================================================
``LINKS``  every moving link at the drawn position: a bar (two points) or a
           closed polygon through its joints and tracer points
``FRAME``  a triangle under every frame pivot, the guides of P joints
``PINS``   a circle at every R joint (a larger one for a multiple joint), a
           square at every P joint
``PATHS``  the path of every tracer point over the batch (closed for a full
           turn of an R driver)
``LABELS`` the joint and tracer point names
=========  =============================================================

:func:`cad_drawing` builds the geometry once (:class:`CadDrawing`);
:func:`mechanism_svg` writes it as SVG (one ``<g>`` per layer, with Inkscape layer
attributes), :func:`mechanism_dxf` as DXF R2010 through ``ezdxf`` (LWPOLYLINE,
CIRCLE, LINE and TEXT entities; ``$INSUNITS`` = millimetres).
"""
from __future__ import annotations

import io
from dataclasses import dataclass

import numpy as np

from multiloop.topo.model import JointKind

from ..state import KinematicState
from .geometry import extent, is_full_turn, link_outlines, path_pieces, slider_guide

__all__ = ["LAYERS", "CadDrawing", "cad_drawing", "mechanism_svg", "mechanism_dxf"]

#: layer name -> (DXF colour index, SVG colour)
LAYERS = {"LINKS": (5, "#1f77b4"), "FRAME": (8, "#555555"), "PINS": (1, "#000000"),
          "PATHS": (6, "#d62728"), "LABELS": (7, "#222222")}


@dataclass(frozen=True, slots=True)
class CadDrawing:
    """Geometry of one drawing in millimetres (y up).

    Attributes
    ----------
    polylines : tuple of (layer, name, (k, 2) array, closed)
    circles : tuple of (layer, name, centre (2,), radius)
    texts : tuple of (layer, text, insertion point (2,), height)
    """

    polylines: tuple
    circles: tuple
    texts: tuple
    title: str

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower-left and upper-right corners around every entity (mm)."""
        pts = [p for _, _, p, _ in self.polylines] + [np.array([c - r, c + r]) for _, _, c, r in self.circles]
        pts += [np.array([p, p + [h * len(t) * 0.6, h]]) for _, t, p, h in self.texts]
        allp = np.vstack(pts) if pts else np.zeros((1, 2))
        return allp.min(axis=0), allp.max(axis=0)


def cad_drawing(state: KinematicState, index: int = 0) -> CadDrawing:
    """The layered geometry of ``state`` at position ``index`` (mm)."""
    m = state.mechanism
    size = 1000.0 * extent(state)
    pin = 0.015 * size
    polys, circles, texts = [], [], []
    for lk, P in link_outlines(state, index).items():
        polys.append(("LINKS", lk, 1000.0 * P, len(P) >= 3))
    for i, j in enumerate(m.joints):
        p = 1000.0 * state.positions[index, i]
        if not np.all(np.isfinite(p)):
            continue
        if j.kind is JointKind.P:
            guide = 1000.0 * slider_guide(state, index, i, 3 * pin / 1000.0 * 2)
            polys.append(("FRAME", f"{j.name} guide", guide, False))
            sq = p + pin * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]])
            polys.append(("PINS", j.name, sq, True))
        else:
            circles.append(("PINS", j.name, p, pin * (1.6 if j.is_multiple else 1.0)))
            if m.frame in j.links:
                tri = p + pin * np.array([[0, -1], [-2, -3.5], [2, -3.5]])
                polys.append(("FRAME", f"{j.name} pivot", tri, True))
        texts.append(("LABELS", j.name, p + [1.5 * pin, 1.5 * pin], 2 * pin))
    closed = is_full_turn(state)
    for k, name in enumerate(state.point_names):
        for piece in path_pieces(state.point_positions[:, k], closed):
            is_closed = closed and len(piece) > 1 and np.array_equal(piece[0], piece[-1])
            pts = 1000.0 * (piece[:-1] if is_closed else piece)
            polys.append(("PATHS", name, pts, is_closed))
        p = 1000.0 * state.point_positions[index, k]
        if np.all(np.isfinite(p)):
            texts.append(("LABELS", name, p + [1.5 * pin, -3 * pin], 2 * pin))
    return CadDrawing(tuple(polys), tuple(circles), tuple(texts), m.name or "mechanism")


def _esc(text: str) -> str:
    return (str(text).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
            .replace('"', "&quot;"))


def mechanism_svg(state: KinematicState, index: int = 0) -> str:
    """The drawing as SVG text: one ``<g id="LINKS">`` … per layer, millimetres, y up."""
    d = cad_drawing(state, index)
    lo, hi = d.bounds()
    pad = 0.05 * float(np.max(hi - lo) or 1.0)
    lo, hi = lo - pad, hi + pad
    w, h = hi - lo

    def xy(p):
        return f"{p[0]:.4f},{-p[1]:.4f}"
    out = ['<?xml version="1.0" encoding="UTF-8"?>\n',
           '<svg xmlns="http://www.w3.org/2000/svg" '
           'xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape" '
           f'width="{w:.3f}mm" height="{h:.3f}mm" viewBox="{lo[0]:.4f} {-hi[1]:.4f} {w:.4f} {h:.4f}">\n',
           f"<title>{_esc(d.title)}</title>\n"]
    stroke = 0.004 * float(max(w, h))
    for layer, (_, colour) in LAYERS.items():
        out.append(f'<g id="{layer}" inkscape:groupmode="layer" inkscape:label="{layer}" '
                   f'stroke="{colour}" fill="none" stroke-width="{stroke:.4f}">\n')
        for lay, name, P, closed in d.polylines:
            if lay == layer:
                tag = "polygon" if closed else "polyline"
                fill = ' fill="#1f77b4" fill-opacity="0.25"' if closed and layer == "LINKS" else ""
                out.append(f'<{tag} data-name="{_esc(name)}" points="{" ".join(xy(p) for p in P)}"{fill}/>\n')
        for lay, name, c, r in d.circles:
            if lay == layer:
                out.append(f'<circle data-name="{_esc(name)}" cx="{c[0]:.4f}" cy="{-c[1]:.4f}" r="{r:.4f}" '
                           'fill="white"/>\n')
        for lay, text, p, size in d.texts:
            if lay == layer:
                out.append(f'<text x="{p[0]:.4f}" y="{-p[1]:.4f}" font-size="{size:.4f}" stroke="none" '
                           f'fill="{colour}" font-family="sans-serif">{_esc(text)}</text>\n')
        out.append("</g>\n")
    out.append("</svg>\n")
    return "".join(out)


def mechanism_dxf(state: KinematicState, index: int = 0) -> bytes:
    """The drawing as DXF R2010 (``ezdxf``), millimetres; returns the file's bytes."""
    import ezdxf
    from ezdxf import units

    d = cad_drawing(state, index)
    doc = ezdxf.new("R2010", setup=False)
    doc.units = units.MM
    doc.header["$MEASUREMENT"] = 1
    for layer, (colour, _) in LAYERS.items():
        doc.layers.add(layer, color=colour)
    msp = doc.modelspace()
    for layer, _, P, closed in d.polylines:
        if len(P) == 2 and not closed:
            msp.add_line(tuple(P[0]), tuple(P[1]), dxfattribs={"layer": layer})
        else:
            msp.add_lwpolyline([tuple(p) for p in P], close=closed, dxfattribs={"layer": layer})
    for layer, _, c, r in d.circles:
        msp.add_circle(tuple(c), r, dxfattribs={"layer": layer})
    for layer, text, p, size in d.texts:
        msp.add_text(text, height=size, dxfattribs={"layer": layer, "insert": tuple(p)})
    buf = io.StringIO()
    doc.write(buf)
    return buf.getvalue().encode("utf-8")
