"""3-D picture of a six-strut platform: plate, struts coloured by force, screw axes.

Struts are drawn from the platform hinge to the base hinge, coloured on a
diverging map (red = tension, blue = compression, symmetric about 0 N).  The
instantaneous screw axis of the platform with strut ``i`` removed is a dashed line
through its axis point along its direction (label ``m_i``, pitch in the legend); a
pure translation is drawn as an arrow from the plate centroid.  Loads are arrows
ending at their points of application.  Uses the Agg backend (files only).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..spatial.platform import Platform, PlatformStatics, platform_statics
from .style import no_mathtext

__all__ = ["plot_platform"]


def _plate_outline(points: np.ndarray) -> np.ndarray:
    """Distinct platform hinges ordered by angle around their centroid in their best-fit plane."""
    pts = np.unique(np.round(points, 12), axis=0)
    c = pts.mean(axis=0)
    if len(pts) < 3:
        return pts
    _, _, vt = np.linalg.svd(pts - c)
    u, v = vt[0], vt[1]
    ang = np.arctan2((pts - c) @ v, (pts - c) @ u)
    return pts[np.argsort(ang)]


def _snap(x: float, scale: float) -> float:
    return 0.0 if abs(x) <= 1e-9 * max(scale, 1.0) else float(x)


def _draw_struts(ax, platform: Platform, st: PlatformStatics, P, B):
    """Plate, struts coloured by force (labelled) and hinges; returns (norm, cmap)."""
    import matplotlib
    from matplotlib import colors

    outline = _plate_outline(P)
    if len(outline) >= 3:
        from mpl_toolkits.mplot3d.art3d import Poly3DCollection

        ax.add_collection3d(Poly3DCollection([outline], facecolor="0.8", edgecolor="0.3", alpha=0.5))
    vmax = float(np.max(np.abs(st.forces))) or 1.0
    norm = colors.TwoSlopeNorm(vmin=-vmax, vcenter=0.0, vmax=vmax)
    cmap = matplotlib.colormaps["coolwarm"]
    for i, (p, b, s) in enumerate(zip(P, B, st.forces)):
        ax.plot(*np.column_stack([p, b]), color=cmap(norm(s)), lw=3)
        ax.text(*(0.5 * (p + b)), f" {platform.struts[i].name}: {_snap(s, vmax):.1f} N", fontsize=7)
    ax.scatter(*P.T, color="k", s=12)
    ax.scatter(*B.T, color="k", marker="^", s=18)
    return norm, cmap


def _draw_screws(ax, st: PlatformStatics, centre, span: float) -> None:
    """The screw axis of the platform with each strut removed (dashed), or an arrow for a
    pure translation."""
    half = 0.6 * span
    for i, tw in enumerate(st.twists):
        colour = f"C{i % 10}"
        d = tw.axis_direction
        if tw.is_infinite_pitch:
            ax.quiver(*centre, *(0.3 * span * d), color=colour, linestyle="--",
                      label=f"m{i + 1}: translation")
            continue
        a = tw.axis_point
        t0 = float(np.dot(centre - a, d))          # the stretch of the axis nearest the plate centre
        seg = np.array([a + (t0 - half) * d, a + (t0 + half) * d])
        ax.plot(*seg.T, color=colour, ls="--", lw=1.2, label=f"m{i + 1}: pitch {_snap(tw.pitch, span):.3g} m")


def _draw_loads(ax, platform: Platform, span: float) -> None:
    for load in platform.loads:
        f = np.asarray(load.force)
        n = np.linalg.norm(f)
        if n == 0:
            continue
        vec = 0.25 * span * f / n
        start = np.asarray(load.at) - vec
        ax.quiver(*start, *vec, color="darkgreen", arrow_length_ratio=0.2)
        ax.text(*start, f"{load.name} {n:.0f} N", fontsize=7, color="darkgreen")


def _frame_axes(ax, allpts, span: float, title: str) -> None:
    """Equal scales on the three axes around every point, labels and title."""
    lo = allpts.min(axis=0) - 0.1 * span
    hi = allpts.max(axis=0) + 0.1 * span
    mid = 0.5 * (lo + hi)
    r = 0.5 * float(np.max(hi - lo))
    ax.set_xlim(mid[0] - r, mid[0] + r)
    ax.set_ylim(mid[1] - r, mid[1] + r)
    ax.set_zlim(mid[2] - r, mid[2] + r)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, loc="upper left")


def plot_platform(platform: Platform, path: str | Path | None = None,
                  statics: PlatformStatics | None = None, ax=None):
    """Draw the platform; save to ``path`` (PNG, ...) when given.

    Parameters
    ----------
    platform : Platform
    path : str or Path, optional
        Output file; the figure is closed after saving.
    statics : PlatformStatics, optional
        Precomputed result (computed when omitted; singular sets raise
        :class:`~kin.platform.SingularStrutsError`).
    ax : mpl_toolkits.mplot3d.Axes3D, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib

    if ax is None:
        matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    from matplotlib import cm

    st = statics if statics is not None else platform_statics(platform)
    P, B = platform.platform_points, platform.base_points
    allpts = np.vstack([P, B])
    span = float(np.max(np.ptp(allpts, axis=0))) or 1.0
    if ax is None:
        fig = plt.figure(figsize=(9, 7.5))
        ax = fig.add_subplot(projection="3d")
    else:
        fig = ax.figure
    norm, cmap = _draw_struts(ax, platform, st, P, B)
    _draw_screws(ax, st, P.mean(axis=0), span)
    _draw_loads(ax, platform, span)
    sm = cm.ScalarMappable(norm=norm, cmap=cmap)
    sm.set_array([])
    fig.colorbar(sm, ax=ax, shrink=0.6, pad=0.1, label="strut force (N), tension +")
    _frame_axes(ax, allpts, span,
                f"{platform.name}\nstruts coloured by force; dashed: screw axes with strut i removed")
    no_mathtext(fig)
    if path is not None:
        fig.savefig(path, dpi=120)
        plt.close(fig)
    return fig
