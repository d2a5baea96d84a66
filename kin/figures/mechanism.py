"""Figures of a solved motion (matplotlib, Agg backend; nothing shown on screen).

* :func:`plot_mechanism` — the mechanism at one position (default: the first, the
  reference when the inputs start at 0): links as bars / polygons through their
  joints, the frame's pivots hatched, slider guides drawn, joint names, and the
  paths of every tracer point (and of the joints, faintly) over the whole batch;
* :func:`plot_analogues` — the analogues against the input: ω = dθ/dφ and
  ε = d²θ/dφ² of every moving link, and the speed |v| and acceleration |a| of the
  tracer points (or of the joints when there is none);
* :func:`animate` — one cycle as a GIF (matplotlib's ``PillowWriter``);
* :func:`iter_solve_figures` — the two figures of ``multiloop solve --plot``.

All functions take a :class:`~kin.state.KinematicState` and return the figure
(or write the file), so they can be used from the API and from the CLI.
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Polygon  # noqa: E402

from multiloop.topo.model import JointKind  # noqa: E402

from ..state import KinematicState  # noqa: E402
from .geometry import extent, is_full_turn, link_outlines, path_pieces, slider_guide  # noqa: E402
from .labels import place_labels  # noqa: E402
from .style import no_mathtext  # noqa: E402

__all__ = ["plot_mechanism", "plot_analogues", "animate", "input_axis", "iter_solve_figures"]

_COLORS = plt.rcParams["axes.prop_cycle"].by_key()["color"]


def input_axis(state: KinematicState) -> tuple[np.ndarray, str]:
    """The first driver's values for plotting: degrees for R, metres for P."""
    m = state.mechanism
    d = m.drivers[0]
    if m.is_rotary(d):
        return np.degrees(state.inputs[:, 0]), f"input {d.joint} (deg)"
    return state.inputs[:, 0], f"input {d.joint} (m)"


def _bounds(state: KinematicState) -> tuple[np.ndarray, np.ndarray]:
    pts = [state.positions.reshape(-1, 2)]
    if state.point_positions is not None:
        pts.append(state.point_positions.reshape(-1, 2))
    allp = np.concatenate(pts)
    allp = allp[np.all(np.isfinite(allp), axis=1)]
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    pad = 0.08 * max(hi - lo) + 1e-9
    return lo - pad, hi + pad


def _markers(state: KinematicState, n: int) -> list[tuple]:
    """``(name, position, marker, size pt, face colour, text colour)`` of every visible joint and point."""
    m = state.mechanism
    out = []
    for i, j in enumerate(m.joints):
        p = state.positions[n, i]
        if not np.all(np.isfinite(p)):
            continue
        if j.kind is JointKind.P:
            out.append((j.name, p, "s", 9, "w", "k"))
        elif m.frame in j.links:
            out.append((j.name, p, "^", 9, "gold" if j.is_multiple else "w", "k"))
        else:
            out.append((j.name, p, "o", 6, "gold" if j.is_multiple else "w", "k"))
    for k, name in enumerate(state.point_names):
        p = state.point_positions[n, k]
        if np.all(np.isfinite(p)):
            out.append((name, p, "x", 8, "crimson", "crimson"))
    return out


def _draw(ax, state: KinematicState, n: int) -> tuple[list, list]:
    """Links, guides and markers at position ``n``; returns the artists and the drawn segments."""
    m = state.mechanism
    art, segs = [], []
    outlines = link_outlines(state, n)
    for k, lk in enumerate(m.link_names):
        if lk not in outlines:
            continue
        P, c = outlines[lk], _COLORS[k % len(_COLORS)]
        if len(P) >= 3:
            art.append(ax.add_patch(Polygon(P, closed=True, alpha=0.35, color=c, lw=2)))
            segs += [(P[i], P[(i + 1) % len(P)]) for i in range(len(P))]
        else:
            art += ax.plot(P[:, 0], P[:, 1], "-", color=c, lw=3, solid_capstyle="round")
            segs.append((P[0], P[1]))
    half = 0.12 * extent(state)
    for i, j in enumerate(m.joints):
        if j.kind is JointKind.P and np.all(np.isfinite(state.positions[n, i])):
            seg = slider_guide(state, n, i, half)
            art += ax.plot(seg[:, 0], seg[:, 1], "k-", lw=1)
            segs.append((seg[0], seg[1]))
    for name, p, marker, size, face, _ in _markers(state, n):
        if marker == "x":
            art += ax.plot([p[0]], [p[1]], "x", color=face, ms=size)
        else:
            art += ax.plot([p[0]], [p[1]], marker, ms=size, mfc=face, mec="k")
    return art, segs


def _names(ax, state: KinematicState, n: int, segs) -> list:
    """Joint and point names placed by :func:`~kin.figures.labels.place_labels`."""
    marks = _markers(state, n)
    if not marks:
        return []
    offsets = place_labels(ax, [mk[1] for mk in marks], [mk[0] for mk in marks],
                           [0.5 * mk[3] + 1 for mk in marks], fontsize=9, segments=segs)
    out = []
    for (name, p, _, size, _, colour), off in zip(marks, offsets):
        far = np.hypot(*off) > 0.5 * size + 18
        out.append(ax.annotate(name, p, textcoords="offset points", xytext=off, fontsize=9, color=colour,
                               ha="center", va="center", annotation_clip=False,
                               arrowprops=dict(arrowstyle="-", lw=0.4, color="0.5", shrinkA=0,
                                               shrinkB=0.5 * size) if far else None))
    return out


def plot_mechanism(state: KinematicState, index: int = 0, ax=None, title: str | None = None):
    """The mechanism at position ``index`` with joint names and tracer paths.

    Returns
    -------
    matplotlib.figure.Figure
    """
    m = state.mechanism
    if ax is None:
        fig, ax = plt.subplots(figsize=(7, 6), dpi=110)
    else:
        fig = ax.figure
    closed = is_full_turn(state)
    for i in range(len(m.joints)):
        for piece in path_pieces(state.positions[:, i], closed):
            ax.plot(piece[:, 0], piece[:, 1], "-", color="0.8", lw=0.8, zorder=0)
    for k in range(len(state.point_names)):
        for piece in path_pieces(state.point_positions[:, k], closed):
            ax.plot(piece[:, 0], piece[:, 1], "--", color="crimson", lw=1.2, zorder=0)
    _, segs = _draw(ax, state, index)
    lo, hi = _bounds(state)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    _names(ax, state, index, segs)
    ax.grid(True, lw=0.3)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    bad = int(np.count_nonzero(~state.ok))
    ax.set_title(title or f"{m.name or 'mechanism'}: position {index}"
                 + (f" ({bad} positions failed)" if bad else ""))
    return no_mathtext(fig)


def plot_analogues(state: KinematicState):
    """ω, ε of the moving links and |v|, |a| of tracer points against the input.

    Raises
    ------
    ValueError
        The state has no derivatives (solve with ``derivatives=True``).
    """
    if state.omegas is None:
        raise ValueError("the state has no derivatives: solve with derivatives=True")
    m = state.mechanism
    x, label = input_axis(state)
    fig, axs = plt.subplots(2, 2, figsize=(11, 7), dpi=110, sharex=True)
    for k, lk in enumerate(m.link_names):
        if lk == m.frame or np.all(np.abs(np.nan_to_num(state.omegas[:, k])) < 1e-14):
            continue
        axs[0, 0].plot(x, state.omegas[:, k], label=lk)
        axs[1, 0].plot(x, state.epsilons[:, k], label=lk)
    if state.point_positions is not None and state.point_velocities is not None:
        names, V, A = state.point_names, state.point_velocities, state.point_accelerations
    else:
        names, V, A = state.mechanism.joint_names, state.velocities, state.accelerations
    for k, name in enumerate(names):
        axs[0, 1].plot(x, np.hypot(V[:, k, 0], V[:, k, 1]), label=name)
        axs[1, 1].plot(x, np.hypot(A[:, k, 0], A[:, k, 1]), label=name)
    axs[0, 0].set_ylabel("ω = dθ/dφ (–)")
    axs[1, 0].set_ylabel("ε = d²θ/dφ² (–)")
    axs[0, 1].set_ylabel("|dr/dφ| (m)")
    axs[1, 1].set_ylabel("|d²r/dφ²| (m)")
    for a in axs.ravel():
        a.grid(True, lw=0.3)
        a.legend(fontsize=7, ncol=2)
    for a in axs[1]:
        a.set_xlabel(label)
    fig.suptitle(f"{m.name or 'mechanism'}: analogues (driver at unit rate)")
    no_mathtext(fig)
    fig.tight_layout()
    return fig


def iter_solve_figures(state: KinematicState, path):
    """``(path, figure)`` pairs, each figure made when asked for: the mechanism at its
    first regular position (not a degenerate one) with its paths as ``path``, and the
    analogues as ``<stem>_analogues<suffix>`` (``.png`` when ``path`` has no suffix)."""
    p = Path(path)
    shown = np.flatnonzero(state.ok)
    yield p, plot_mechanism(state, int(shown[0]) if shown.size else 0)
    yield p.with_name(p.stem + "_analogues" + (p.suffix or ".png")), plot_analogues(state)


def animate(state: KinematicState, path, fps: int = 20, max_frames: int = 120) -> None:
    """Write one cycle (the batch) as a GIF with ``PillowWriter``."""
    from matplotlib.animation import PillowWriter

    fig, ax = plt.subplots(figsize=(6, 5), dpi=80)
    lo, hi = _bounds(state)
    frames = np.unique(np.linspace(0, state.n_positions - 1, min(max_frames, state.n_positions)).astype(int))
    writer = PillowWriter(fps=fps)
    closed = is_full_turn(state)
    with writer.saving(fig, str(path), dpi=80):
        for n in frames:
            ax.clear()
            for k in range(len(state.point_names)):
                for piece in path_pieces(state.point_positions[:, k], closed):
                    ax.plot(piece[:, 0], piece[:, 1], "--", color="crimson", lw=1)
            _draw(ax, state, int(n))
            ax.set_xlim(lo[0], hi[0])
            ax.set_ylim(lo[1], hi[1])
            ax.set_aspect("equal")
            ax.set_title(f"{state.mechanism.name or ''}  input {input_axis(state)[0][n]:.4g}  {state.status[n][:40]}",
                         fontsize=9)
            no_mathtext(fig)
            writer.grab_frame()
    plt.close(fig)
