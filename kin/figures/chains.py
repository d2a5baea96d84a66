"""Drawings of chains as in published atlases: SVG strings and matplotlib axes.

A **link** is drawn as a bar (two joints) or a shaded polygon through its joints
(three or more, in the cyclic order of a planar embedding); a **simple joint**
is a small open circle; a **multiple joint** (a pin on ``n' >= 3`` links) is a larger
filled red circle with a ring and its multiplicity ``j`` next to it, so it cannot be
mistaken for two joints drawn close together.

Layout (:func:`~kin.figures.layout.chain_layout`, re-exported here): the link
polygons of a planar chain are laid out as a straight-line planar drawing (Tutte's
barycentric embedding refined by crossing-free force-directed moves), so no two links
cross and no drawing collapses; non-planar chains use the Kamada–Kawai spring layout.

References
----------
.. [1] W. T. Tutte, "How to draw a graph", Proc. London Math. Soc. 13 (1963) 743–767.
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from .layout import ChainLayout, chain_layout, has_crossings

__all__ = ["atlas_chart_files", "ChainLayout", "chain_layout", "has_crossings", "chain_svg", "draw_chain",
           "existence_domain_chart", "invariant_merges", "invariant_merge_chart"]


def _link_polygon(layout: ChainLayout, joints: Sequence[Sequence[int]], link: int) -> list[tuple[float, float]]:
    if layout.polygons:
        return [layout.joints[a] for a in layout.polygons[link]]
    cx, cy = layout.links[link]
    pts = [layout.joints[a] for a, j in enumerate(joints) if link in j]
    return sorted(pts, key=lambda p: math.atan2(p[1] - cy, p[0] - cx))


_PALETTE = ["#4e79a7", "#59a14f", "#9c755f", "#76b7b2", "#edc948", "#b07aa1", "#ff9da7", "#bab0ac"]


def chain_svg(n: int, joints: Sequence[Sequence[int]], size: int = 180, title: str | None = None,
              layout: ChainLayout | None = None) -> str:
    """An ``<svg>`` element of the chain (links as bars/polygons, multiple joints in red).

    Examples
    --------
    >>> svg = chain_svg(4, [(0, 1), (1, 2), (2, 3), (3, 0)])
    >>> svg.startswith("<svg") and svg.count("<line") == 4
    True
    """
    lay = layout or chain_layout(n, joints)
    pad = 14
    s = size - 2 * pad

    def xy(p):
        return pad + p[0] * s, pad + (1 - p[1]) * s

    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{size}" height="{size}" '
           f'viewBox="0 0 {size} {size}" class="chain">']
    if title:
        out.append(f"<title>{_esc(title)}</title>")
    out.append(f'<rect width="{size}" height="{size}" fill="white"/>')
    for x in range(n):
        poly = _link_polygon(lay, joints, x)
        colour = _PALETTE[x % len(_PALETTE)]
        if len(poly) == 2:
            (x1, y1), (x2, y2) = xy(poly[0]), xy(poly[1])
            out.append(f'<line class="link" data-link="{x}" x1="{x1:.1f}" y1="{y1:.1f}" x2="{x2:.1f}" '
                       f'y2="{y2:.1f}" stroke="{colour}" stroke-width="5" stroke-linecap="round"/>')
        else:
            pts = " ".join(f"{a:.1f},{b:.1f}" for a, b in map(xy, poly))
            out.append(f'<polygon class="link" data-link="{x}" points="{pts}" fill="{colour}" '
                       f'fill-opacity="0.45" stroke="{colour}" stroke-width="3" stroke-linejoin="round"/>')
    for a, j in enumerate(joints):
        cx, cy = xy(lay.joints[a])
        if len(j) > 2:
            out.append(f'<circle cx="{cx:.1f}" cy="{cy:.1f}" r="7" fill="#e15759" stroke="black" stroke-width="1.5"/>')
            out.append(f'<circle cx="{cx:.1f}" cy="{cy:.1f}" r="10" fill="none" stroke="#e15759" stroke-width="1.5"/>')
            out.append(f'<text x="{cx + 10:.1f}" y="{cy - 9:.1f}" font-size="10" font-family="sans-serif" '
                       f'fill="#b00">{len(j) - 1}</text>')
        else:
            out.append(f'<circle cx="{cx:.1f}" cy="{cy:.1f}" r="4" fill="white" stroke="black" stroke-width="1.5"/>')
    out.append("</svg>")
    return "".join(out)


def _esc(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")


def draw_chain(ax, n: int, joints: Sequence[Sequence[int]], title: str | None = None,
               layout: ChainLayout | None = None):
    """Draw the chain on a matplotlib axes (same conventions as :func:`chain_svg`)."""
    from matplotlib.patches import Circle, Polygon

    lay = layout or chain_layout(n, joints)
    for x in range(n):
        poly = _link_polygon(lay, joints, x)
        colour = _PALETTE[x % len(_PALETTE)]
        if len(poly) == 2:
            ax.plot([poly[0][0], poly[1][0]], [poly[0][1], poly[1][1]], color=colour, lw=4,
                    solid_capstyle="round", zorder=1)
        else:
            ax.add_patch(Polygon(poly, closed=True, facecolor=colour, alpha=0.35, edgecolor=colour,
                                 lw=2.5, zorder=1))
    for a, j in enumerate(joints):
        cx, cy = lay.joints[a]
        if len(j) > 2:
            ax.add_patch(Circle((cx, cy), 0.035, facecolor="#e15759", edgecolor="black", zorder=3))
            ax.add_patch(Circle((cx, cy), 0.05, facecolor="none", edgecolor="#e15759", zorder=3))
            ax.text(cx + 0.05, cy + 0.05, str(len(j) - 1), color="#b00", fontsize=8, zorder=4)
        else:
            ax.add_patch(Circle((cx, cy), 0.02, facecolor="white", edgecolor="black", zorder=3))
    ax.set_xlim(-0.08, 1.08)
    ax.set_ylim(-0.08, 1.08)
    ax.set_aspect("equal")
    ax.axis("off")
    if title:
        ax.set_title(title, fontsize=8)
    return ax


# ---------------------------------------------------------------------- atlas charts
def existence_domain_chart(atlas, path, pairs=None, title: str | None = None) -> dict:
    """Pozhbelko & Kuts 2020 fig. 10 drawn from an atlas: the (V, j_max) cells that occur for each K.

    Every stored chain (or those of ``pairs`` = [(n, F), …]) adds its cell
    ``(V, j_max)`` to the set of its K; the chart draws the existence domain
    ``j <= K``, ``V <= 2(K − 1)`` of every K as a rectangle and the occupied cells as
    dots.  Returns ``{K: sorted cells}``.
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    cells = atlas.domain_cells(pairs)
    fig, ax = plt.subplots(figsize=(7, 5))
    colours = plt.cm.viridis(np.linspace(0, 0.9, max(len(cells), 1)))
    for c, K in zip(colours, sorted(cells)):
        ax.add_patch(Rectangle((-0.4, 0.6), 2 * (K - 1) + 0.8, K - 0.2, fill=False, ls="--",
                               edgecolor=c, lw=1.2))
        ax.text(2 * (K - 1) + 0.45, K + 0.45, f"K={K}", color=c, fontsize=9)
        off = (K - np.mean(sorted(cells))) * 0.07
        xs = [v + off for v, j in sorted(cells[K])]
        ys = [j + off for v, j in sorted(cells[K])]
        ax.scatter(xs, ys, color=c, s=36, label=f"K={K}: {len(cells[K])} cells", zorder=3)
    top = max(cells) if cells else 2
    ax.set_xlim(-0.8, 2 * (top - 1) + 1.8)
    ax.set_ylim(0.4, top + 1)
    from matplotlib.ticker import MaxNLocator
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("MJ factor V = Σ (j − 1) V_j")
    ax.set_ylabel("largest multiplicity j (1 = simple joints only)")
    ax.set_title(title or "Existence domain j ≤ K, V ≤ 2(K − 1) (Pozhbelko & Kuts 2020 fig. 10):\n"
                 "cells occupied by the atlas")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return {K: sorted(v) for K, v in cells.items()}


def invariant_merges(atlas, n: int, F: int) -> dict[str, tuple[int, int, int]]:
    """How often the paper's invariants merge non-isomorphic chains of (n, F).

    For each signature level — [LA]; [LA]+[MJA]; +[La]; +MJ link sets (the link
    degrees on every multiple joint) — returns ``(chains, classes, merged)``: the
    number of chains, of distinct signatures, and of chains that share their
    signature with at least one non-isomorphic chain.
    """
    from collections import Counter

    rows = atlas.signatures(n, F)
    sigs: dict[str, list] = {"[LA]": [], "+[MJA]": [], "+[La]": [], "+MJ link sets": []}
    for LA, MJA, La, js in rows:
        deg = Counter(x for j in js for x in j)
        mj = tuple(sorted(tuple(sorted(deg[x] for x in j)) for j in js if len(j) > 2))
        sigs["[LA]"].append(LA)
        sigs["+[MJA]"].append((LA, MJA))
        sigs["+[La]"].append((LA, MJA, La))
        sigs["+MJ link sets"].append((LA, MJA, La, mj))
    out = {}
    for level, keys in sigs.items():
        c = Counter(keys)
        out[level] = (len(keys), len(c), sum(v for v in c.values() if v > 1))
    return out


def invariant_merge_chart(atlas, path, pairs=None) -> dict:
    """Bar chart of the share of chains merged by each signature level, per (n, F)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if pairs is None:
        pairs = atlas.sizes_with_loops(4)
    data = {pr: invariant_merges(atlas, *pr) for pr in pairs}
    levels = ["[LA]", "+[MJA]", "+[La]", "+MJ link sets"]
    fig, ax = plt.subplots(figsize=(max(6, 1.2 * len(pairs) + 2), 4.5))
    width = 0.8 / len(levels)
    for k, level in enumerate(levels):
        ys = [100.0 * data[pr][level][2] / max(data[pr][level][0], 1) for pr in pairs]
        xs = np.arange(len(pairs)) + (k - 1.5) * width
        ax.bar(xs, ys, width, label=level)
    ax.set_xticks(np.arange(len(pairs)))
    ax.set_xticklabels([f"n={n} F={F}\n({data[(n, F)]['[LA]'][0]})" for n, F in pairs], fontsize=8)
    ax.set_ylabel("% of chains sharing the signature\nwith a non-isomorphic chain")
    ax.set_title("Pozhbelko & Kuts 2020 invariants are not sufficient: wrong merges per signature level")
    ax.legend(fontsize=8)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return data


def atlas_chart_files(atlas) -> dict[str, bytes]:
    """The atlas's two charts as PNG bytes by file name (``multiloop atlas --charts``):
    :func:`existence_domain_chart` and :func:`invariant_merge_chart`."""
    import io
    out = {}
    for name, chart in (("atlas_existence_domain.png", existence_domain_chart),
                        ("atlas_invariant_merges.png", invariant_merge_chart)):
        buf = io.BytesIO()
        chart(atlas, buf)
        out[name] = buf.getvalue()
    return out
