"""Instant centres of every pair of links, from the solved velocity field.

Link k moves with the planar twist (ω_k, v_k0), v_k0 the velocity of the point of
link k at the origin, so a point P of link k has ``v = v_k0 + ω_k ẑ × P``.  The
instant centre of links i, j is the point with the same velocity on both:
``(ω_j − ω_i) ẑ × P = −(v_j0 − v_i0)``, i.e. in homogeneous coordinates
``h_ij = (−Δv_y, Δv_x, Δω)``; ``Δω = 0`` puts it at infinity, in the direction
normal to the relative velocity (a slider on a straight guide).  Kennedy's theorem
(Kennedy 1886): the three centres of any three links are collinear.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["InstantCentre", "instant_centres"]


@dataclass(frozen=True)
class InstantCentre:
    """Centre of links ``a``, ``b``: ``point`` (m), or ``None`` with ``direction``
    (unit vector towards it) when it is at infinity.  ``homogeneous`` = (x·w, y·w, w)."""

    a: str
    b: str
    point: tuple[float, float] | None
    direction: tuple[float, float] | None
    homogeneous: tuple[float, float, float]

    def as_dict(self) -> dict:
        d = {"links": [self.a, self.b], "at_infinity": self.point is None}
        if self.point is not None:
            d["x"], d["y"] = self.point
        else:
            d["direction"] = list(self.direction)
        return d


def _twists(state, row: int) -> np.ndarray:
    """(n_links, 3): (−v0_y, v0_x, ω) of every link at ``row``; the frame is zero."""
    Z = state.poses[row]
    Zd = state.pose_rates[row]
    w = Zd[:, 2]
    v0 = Zd[:, :2] - w[:, None] * np.stack([-Z[:, 1], Z[:, 0]], axis=-1)
    t = np.stack([-v0[:, 1], v0[:, 0], w], axis=-1)
    frame = state.mechanism.frame
    if frame is not None:
        t[state.link_index(frame)] = 0.0
    return t


def instant_centres(state, row: int = 0, rel_tol: float = 1e-9) -> tuple[InstantCentre, ...]:
    """All ``n(n−1)/2`` instant centres at position ``row`` of a state solved with
    ``derivatives=True``."""
    m = state.mechanism
    t = _twists(state, row)
    size = max(float(np.nanmax(np.abs(state.positions[row]))), 1e-12)
    out = []
    names = m.link_names
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            h = t[j] - t[i]
            w = h[2]
            if abs(w) > rel_tol * max(np.hypot(h[0], h[1]) / size, 1e-300):
                p, d = (float(h[0] / w), float(h[1] / w)), None
            else:
                n = np.hypot(h[0], h[1])
                p, d = None, ((float(h[0] / n), float(h[1] / n)) if n > 0 else (1.0, 0.0))
            out.append(InstantCentre(names[i], names[j], p, d, tuple(float(x) for x in h)))
    return tuple(out)
