"""The working store of link poses that the group steps read and write.

:class:`Poses` holds, per link, the position of its reference point and its rotation
(with cos and sin) as contiguous arrays over the batch; a step reads the material points
of known links from it and places its own links.  :class:`PoseRates` does the same for
velocities and accelerations on the ``(N, n_links, 3)`` pose arrays.  Both take the
compiled plan (anything with ``mechanism`` and ``origins``, the links' reference
points).
"""
from __future__ import annotations

import numpy as np

from .rigid import move_point, rotate, transport

__all__ = ["Poses", "PoseRates", "unit", "normal", "angle_of", "known_on"]


def angle_of(v):
    """Direction angle of vectors ``(..., 2)``."""
    return np.arctan2(v[..., 1], v[..., 0])


def unit(v):
    """A 2-vector scaled to length 1."""
    v = np.asarray(v, float)
    return v / np.hypot(*v)


def normal(u):
    """The left normal ``(-u_y, u_x)`` of vectors ``(..., 2)``."""
    return np.stack([-u[..., 1], u[..., 0]], axis=-1)


def known_on(group, joint: str) -> str:
    """The known link that an Assur group's outer joint ``joint`` attaches to."""
    B = set(group.links)
    for c in group.constraints:
        if c.joint == joint and c.kind in ("R", "P"):
            if c.a not in B:
                return c.a
            if c.b not in B:
                return c.b
    raise KeyError(joint)  # pragma: no cover


class Poses:
    """Working store of link poses: per link, contiguous arrays over the batch.

    ``x[k], y[k]`` position of link k's reference point, ``th[k]`` its rotation,
    ``c[k], s[k]`` = cos, sin of it (kept to avoid recomputing trigonometry).
    Arrays are stored by reference (no copies); a link never solved is ``None``.
    """

    def __init__(self, sp, M: int):
        self.sp, self.m, self.M = sp, sp.mechanism, M
        nl = self.m.n_links
        self.idx = {x: i for i, x in enumerate(self.m.link_names)}
        self.x = [None] * nl
        self.y = [None] * nl
        self.th = [None] * nl
        self.c = [None] * nl
        self.s = [None] * nl
        self.frame_k = f = self.idx[self.m.frame]
        z = np.zeros(M)
        self.x[f], self.y[f], self.th[f], self.c[f], self.s[f] = z, z, z, np.ones(M), z

    def finite(self, links) -> np.ndarray:
        out = np.ones(self.M, bool)
        for k in links:
            out &= np.isfinite(self.th[k]) if self.th[k] is not None else False
        return out

    def unset_to_nan(self) -> None:
        """Links never solved (``only=``) become NaN."""
        nan = np.full(self.M, np.nan)
        for k in range(self.m.n_links):
            if self.th[k] is None:
                self.x[k] = self.y[k] = self.th[k] = self.c[k] = self.s[k] = nan

    def take(self, rows: np.ndarray) -> "Poses":
        """The poses at the given rows only."""
        out = object.__new__(Poses)
        out.sp, out.m, out.M, out.idx, out.frame_k = self.sp, self.m, len(rows), self.idx, self.frame_k
        for name in ("x", "y", "th", "c", "s"):
            setattr(out, name, [None if a is None else a[rows] for a in getattr(self, name)])
        return out

    # -- reading -------------------------------------------------------------------
    def at(self, joint: str) -> np.ndarray:
        return np.asarray(self.m.joint(joint).at, float)

    def axis(self, joint: str) -> np.ndarray:
        return unit(self.m.joint(joint).axis)

    def point_k(self, k: int, r) -> np.ndarray:
        if k == self.frame_k:
            return np.broadcast_to(np.asarray(r, float), (self.M, 2))
        out = np.empty((self.M, 2))
        self.write_point(k, np.asarray(r, float) - self.sp.origins[k], out[:, 0], out[:, 1])
        return out

    def write_point(self, k: int, r_local, out_x, out_y) -> None:
        """Write into ``out_x, out_y`` (M,) the material point of link k at ``r_local``
        from the link's reference point: a point on the frame is constant, the reference
        point itself is the pose (no arithmetic), any other is rigidly carried."""
        rx, ry = r_local
        if k == self.frame_k:
            out_x[...], out_y[...] = rx, ry
        elif rx == 0.0 and ry == 0.0:
            out_x[...], out_y[...] = self.x[k], self.y[k]
        else:
            c, s = self.c[k], self.s[k]
            out_x[...] = self.x[k] + c * rx - s * ry
            out_y[...] = self.y[k] + s * rx + c * ry

    def point(self, link: str, r) -> np.ndarray:
        return self.point_k(self.idx[link], r)

    def direction(self, link: str, v) -> np.ndarray:
        k = self.idx[link]
        vx, vy = v
        out = np.empty((self.M, 2))
        out[:, 0] = self.c[k] * vx - self.s[k] * vy
        out[:, 1] = self.s[k] * vx + self.c[k] * vy
        return out

    def theta(self, link: str) -> np.ndarray:
        return self.th[self.idx[link]]

    # -- writing -------------------------------------------------------------------
    def place_cs(self, link: str, P, r_ref, c, s, th) -> None:
        """Pose of ``link`` whose material point at ``r_ref`` is at ``P``, rotated (c, s)."""
        k = self.idx[link]
        dx, dy = self.sp.origins[k] - np.asarray(r_ref, float)
        self.c[k], self.s[k], self.th[k] = c, s, th
        if dx == 0.0 and dy == 0.0:
            self.x[k], self.y[k] = P[:, 0], P[:, 1]
        else:
            self.x[k] = P[:, 0] + c * dx - s * dy
            self.y[k] = P[:, 1] + s * dx + c * dy

    def place_dir(self, link: str, P, r_ref, d, d_ref) -> None:
        """As :meth:`place_cs`, the rotation taking direction ``d_ref`` to ``d`` (N, 2)."""
        cr, sr = unit(d_ref)
        dx, dy = d[:, 0], d[:, 1]
        inv = 1.0 / np.sqrt(dx * dx + dy * dy)
        ca, sa = d[:, 0] * inv, d[:, 1] * inv
        c, s = ca * cr + sa * sr, sa * cr - ca * sr
        self.place_cs(link, P, r_ref, c, s, np.arctan2(s, c))

    def place_like(self, link: str, P, r_ref, other: str) -> None:
        k = self.idx[other]
        self.place_cs(link, P, r_ref, self.c[k], self.s[k], self.th[k])

    def invalidate(self, links, bad) -> None:
        if np.any(bad):
            for k in links:
                for name in ("x", "y", "th", "c", "s"):
                    arr = getattr(self, name)
                    arr[k] = np.where(bad, np.nan, arr[k])

    # -- conversion to / from the (M, n_links, 3) pose array --------------------------
    def to_Z(self, links=None) -> np.ndarray:
        """The ``(M, n_links, 3)`` pose array, stored link-major (a transposed view of
        ``(n_links, 3, M)``: each link's arrays are copied contiguously)."""
        nl = self.m.n_links
        ks = range(nl) if links is None else list(links) + [self.frame_k]
        T = np.empty((nl, 3, self.M)) if links is None else np.full((nl, 3, self.M), np.nan)
        for k in ks:
            T[k, 0], T[k, 1], T[k, 2] = self.x[k], self.y[k], self.th[k]
        return T.transpose(2, 0, 1)

    def from_Z(self, Z, links) -> None:
        for k in links:
            self.x[k], self.y[k], self.th[k] = Z[:, k, 0].copy(), Z[:, k, 1].copy(), Z[:, k, 2].copy()
            self.c[k], self.s[k] = np.cos(self.th[k]), np.sin(self.th[k])


class PoseRates:
    """Velocities/accelerations of material points from the pose arrays Z, Zd, Zdd."""

    def __init__(self, sp, Z, Zd, Zdd):
        self.sp, self.Z, self.Zd, self.Zdd = sp, Z, Zd, Zdd
        self.idx = {x: i for i, x in enumerate(sp.mechanism.link_names)}

    def point(self, link: str, r):
        """Position, velocity, acceleration of ``link``'s material point at reference ``r``."""
        k = self.idx[link]
        return move_point(self.Z[:, k, :2], self.Z[:, k, 2], np.asarray(r, float) - self.sp.origins[k],
                          self.Zd[:, k, :2], self.Zd[:, k, 2], self.Zdd[:, k, :2], self.Zdd[:, k, 2])

    def direction(self, link: str, v):
        k = self.idx[link]
        return rotate(v, self.Z[:, k, 2]), self.Zd[:, k, 2], self.Zdd[:, k, 2]

    def set(self, link: str, P, vP, aP, w, e) -> None:
        """Rates of ``link`` from those of its point at P and its ω, ε."""
        k = self.idx[link]
        self.Zd[:, k, :2], self.Zdd[:, k, :2] = transport(self.Z[:, k, :2] - P, vP, aP, w, e)
        self.Zd[:, k, 2] = w
        self.Zdd[:, k, 2] = e
