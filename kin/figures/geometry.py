"""Drawing geometry of a solved mechanism, shared by the plots and the CAD exporters.

Nothing here imports matplotlib: the functions return NumPy arrays in metres.

* :func:`link_outlines` — every moving link as the ordered outline through its joints
  (and tracer points): two points for a bar, a convex-ordered polygon for a plate;
* :func:`slider_guide` — the guide segment of a P joint at a position;
* :func:`is_full_turn` — whether the batch is one whole turn of a single R driver, so
  that paths are drawn closed;
* :func:`path_pieces` — a path over the batch split at non-finite positions (closed
  when the batch is a full turn without failures).
"""
from __future__ import annotations

import numpy as np

from multiloop.topo.model import JointKind

from ..state import KinematicState

__all__ = ["link_outlines", "slider_guide", "extent", "is_full_turn", "path_pieces"]


def link_outlines(state: KinematicState, n: int) -> dict[str, np.ndarray]:
    """Outline of every moving link at position ``n``: ``{link: (k, 2)}``, k ≥ 2.

    A link with three or more points is ordered by angle about its centroid, so the
    polygon is simple (convex hull order for convex plates).  Links with a
    non-finite point are left out.
    """
    m = state.mechanism
    pts: dict[str, list] = {lk: [] for lk in m.link_names}
    for i, j in enumerate(m.joints):
        for lk in j.links:
            pts[lk].append(state.positions[n, i])
    if state.point_positions is not None:
        for k, name in enumerate(state.point_names):
            lk = next(pt.link for pt in m.points if pt.name == name)
            pts[lk].append(state.point_positions[n, k])
    out = {}
    for lk, v in pts.items():
        P = np.array(v, float).reshape(-1, 2)
        if lk == m.frame or len(P) < 2 or not np.all(np.isfinite(P)):
            continue
        if len(P) >= 3:
            c = P.mean(axis=0)
            P = P[np.argsort(np.arctan2(P[:, 1] - c[1], P[:, 0] - c[0]))]
        out[lk] = P
    return out


def extent(state: KinematicState) -> float:
    """The largest side of the box around every finite joint and tracer position (m)."""
    pts = [state.positions.reshape(-1, 2)]
    if state.point_positions is not None:
        pts.append(state.point_positions.reshape(-1, 2))
    allp = np.concatenate(pts)
    allp = allp[np.all(np.isfinite(allp), axis=1)]
    return float(np.max(np.ptp(allp, axis=0))) if len(allp) else 1.0


def slider_guide(state: KinematicState, n: int, joint: int, half_length: float) -> np.ndarray:
    """The guide of P joint ``joint`` at position ``n``: a (2, 2) segment centred on it.

    The slide direction is the joint's axis turned with its first link.
    """
    m = state.mechanism
    j = m.joints[joint]
    if j.kind is not JointKind.P:
        raise ValueError(f"joint {j.name!r} is not a P joint")
    th = state.angles[n, m.link_names.index(j.links[0])]
    u = np.asarray(j.axis, float) / np.hypot(*j.axis)
    u = np.array([np.cos(th) * u[0] - np.sin(th) * u[1], np.sin(th) * u[0] + np.cos(th) * u[1]])
    p = state.positions[n, joint]
    return np.array([p - half_length * u, p + half_length * u])


def is_full_turn(state: KinematicState, rtol: float = 1e-6) -> bool:
    """One R driver swept over a whole turn in equal steps (the next step would repeat the first)."""
    m = state.mechanism
    if len(m.drivers) != 1 or not m.is_rotary(0):
        return False
    x = np.asarray(state.inputs[:, 0], float)
    if len(x) < 3:
        return False
    step = np.diff(x)
    if not np.allclose(step, step[0], rtol=1e-6, atol=1e-12) or step[0] == 0:
        return False
    return bool(abs(abs(step[0]) * len(x) - 2 * np.pi) <= rtol * 2 * np.pi)


def path_pieces(path: np.ndarray, closed: bool) -> list[np.ndarray]:
    """Split a (N, 2) path at non-finite rows; close it when ``closed`` and all rows are finite."""
    ok = np.all(np.isfinite(path), axis=1)
    if closed and ok.all():
        return [np.vstack([path, path[:1]])]
    pieces, start = [], None
    for i, good in enumerate(np.append(ok, False)):
        if good and start is None:
            start = i
        elif not good and start is not None:
            if i - start >= 2:
                pieces.append(path[start:i])
            start = None
    return pieces
