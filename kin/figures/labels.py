"""Label placement by offset search: names never overlap each other or any marker.

For every anchor (a joint or a tracer point) the candidates are the 16 compass
directions at six distances from the marker (2 to 48 pt), nearest first; a label
placed beyond 10 pt gets a thin leader line to its marker.  A candidate is
refused when its text box (measured by the renderer, padded by 2 px) overlaps an
already placed label, any marker's box, or leaves the axes; among the others the one
crossing the fewest drawn segments (links, guides) is taken, nearest first.  If every
candidate is refused, the one with the fewest collisions is used.  This is the
fixed-position model of label placement (Christensen, Marks & Shieber 1995), solved
greedily in anchor order.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["place_labels", "boxes_overlap"]

_DIRS = [(math.cos(a), math.sin(a)) for a in np.radians([45, 135, 315, 225, 90, 270, 0, 180,
                                                          22.5, 157.5, 337.5, 202.5, 67.5, 112.5,
                                                          292.5, 247.5])]


def boxes_overlap(a, b) -> bool:
    """Two boxes ``(x0, y0, x1, y1)`` share interior points."""
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def _segment_hits_box(p, q, box) -> bool:
    """Liang–Barsky clipping: the segment pq meets the box."""
    t0, t1 = 0.0, 1.0
    d = (q[0] - p[0], q[1] - p[1])
    for pk, qk in ((-d[0], p[0] - box[0]), (d[0], box[2] - p[0]), (-d[1], p[1] - box[1]), (d[1], box[3] - p[1])):
        if pk == 0:
            if qk < 0:
                return False
            continue
        t = qk / pk
        if pk < 0:
            t0 = max(t0, t)
        else:
            t1 = min(t1, t)
        if t0 > t1:
            return False
    return True


def place_labels(ax, anchors, texts, radii_pt, fontsize: float = 9, segments=()) -> list[tuple[float, float]]:
    """Offsets (points) of the centres of ``texts`` from their ``anchors`` (data coords).

    Parameters
    ----------
    ax : matplotlib Axes
        Limits and aspect must be final.
    anchors : (k, 2) array
        Label anchors in data coordinates (the markers' centres).
    texts : sequence of str
    radii_pt : sequence of float
        Marker half-size of each anchor in points (also used as its obstacle box).
    segments : (s, 2, 2) array, optional
        Drawn segments in data coordinates (a soft obstacle).
    """
    from matplotlib.font_manager import FontProperties

    fig = ax.figure
    ax.apply_aspect()
    renderer = fig.canvas.get_renderer()
    px = fig.dpi / 72.0
    A = ax.transData.transform(np.asarray(anchors, float).reshape(-1, 2))
    S = [ax.transData.transform(np.asarray(s, float)) for s in segments]
    frame = ax.get_window_extent(renderer)
    markers = [(a[0] - r * px, a[1] - r * px, a[0] + r * px, a[1] + r * px) for a, r in zip(A, radii_pt)]
    prop = FontProperties(size=fontsize)
    placed: list[tuple] = []
    out = []
    for k, (a, text) in enumerate(zip(A, texts)):
        w, h, _ = renderer.get_text_width_height_descent(str(text), prop, ismath=False)
        w, h = w + 4, h + 4
        best = None
        for ring, gap in enumerate((2.0, 6.0, 12.0, 20.0, 32.0, 48.0)):
            for di, (cx, cy) in enumerate(_DIRS):
                # the box touches the marker's box from direction (cx, cy), ``gap`` pt away
                r = radii_pt[k] * px + gap * px
                c = (a[0] + cx * (r + w / 2), a[1] + cy * (r + h / 2))
                box = (c[0] - w / 2, c[1] - h / 2, c[0] + w / 2, c[1] + h / 2)
                hard = sum(boxes_overlap(box, b) for b in placed) + sum(boxes_overlap(box, m) for m in markers)
                hard += not (frame.x0 <= box[0] and box[2] <= frame.x1 and frame.y0 <= box[1] and box[3] <= frame.y1)
                soft = sum(_segment_hits_box(s[0], s[1], box) for s in S)
                score = (hard, ring > 2, soft, ring, di)
                if best is None or score < best[0]:
                    best = (score, c, box)
        placed.append(best[2])
        out.append(((best[1][0] - a[0]) / px, (best[1][1] - a[1]) / px))
    return out
