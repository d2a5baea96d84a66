"""The working store of link poses that the group steps read and write.

:class:`Poses` holds, per link, the position of its reference point and its rotation
(with cos and sin) as contiguous arrays over the batch; a step reads the material points
of known links from it and places its own links.  :class:`PoseRates` does the same for
velocities and accelerations on the ``(N, n_links, 3)`` pose arrays.  Both take the
compiled plan (anything with ``mechanism`` and ``origins_xy``, the links' reference
points as Python floats, or for a plan bound to a batch of designs (:mod:`kin.design`)
arrays ``(D, 1)``).
"""
from __future__ import annotations

import math

import numpy as np

from .rigid import move_point, rotate, transport

__all__ = ["Poses", "PoseRates", "rates_of", "unit", "normal", "columns", "angle_of", "known_on"]


def angle_of(v):
    """Direction angle of vectors ``(..., 2)``."""
    return np.arctan2(v[..., 1], v[..., 0])


def unit(v):
    """2-vectors ``(..., 2)`` scaled to length 1."""
    v = np.asarray(v, float)
    return v / np.hypot(v[..., 0], v[..., 1])[..., None]


def carried(x, y, c, s, rx, ry):
    """The components of a link's material point at ``(rx, ry)`` from the link's reference
    point ``(x, y)``, the link rotated by ``(c, s)`` (arrays broadcast)."""
    return x + (c * rx - s * ry), y + (s * rx + c * ry)


def columns(x, y, M) -> np.ndarray:
    """An ``(*shape, 2)`` array of the components ``x, y`` (arrays of the batch shape,
    or broadcastable); ``M`` is the batch size or shape."""
    out = np.empty((*np.atleast_1d(M), 2))
    out[..., 0], out[..., 1] = x, y
    return out


def _zero(a) -> bool:
    """Whether an offset (a float, or an array over designs) is zero everywhere (an
    array's own ``any``: ``np.any``'s wrapper costs twice as much)."""
    if isinstance(a, float):
        return a == 0.0
    return not (a.any() if isinstance(a, np.ndarray) else np.any(a))


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


def _at_rows(a, rows: np.ndarray):
    """A batch's array at ``rows`` (a value common to the batch as it is)."""
    return a[rows] if np.ndim(a) else a


class Poses:
    """Working store of link poses: one preallocated ``(n_links, 3, *shape)`` array.

    ``store`` (optional) is the array to use, e.g. a transposed view of an ``(M, n_links,
    3)`` pose array that the compiled kernel writes.  ``shape`` is ``(M,)`` for one design at M inputs, or ``(D, N)`` for D designs at N
    inputs each (a plan bound to designs by :mod:`kin.design`: the reference points of
    the links and of the steps are then arrays ``(D, 1)`` that broadcast over inputs).

    ``T[k] = (x, y, th)`` over the batch: the position of link k's reference point
    and its rotation; ``x[k], y[k], th[k]`` are views of those rows once link k is
    placed (``None`` before), ``c[k], s[k]`` its cos and sin (kept to avoid recomputing
    trigonometry; stored by reference).  A rotation given by (c, s) only gets its angle
    row on first use (:meth:`angle`; ``arctan2`` is the most expensive operation of a
    dyad).  Material points computed while solving are kept per link (``points[k]``)
    so the joints' positions reuse them.
    """

    def __init__(self, sp, M, store=None):
        self.shape = (M,) if isinstance(M, int) else tuple(int(v) for v in M)
        self.sp, self.m, self.M = sp, sp.mechanism, M if isinstance(M, int) else math.prod(self.shape)
        self.reasons = len(self.shape) == 1          # one design (per-position failure texts)
        self.explain = self.reasons                  # the failures' texts are written
        nl = self.m.n_links
        self.idx = {x: i for i, x in enumerate(self.m.link_names)}
        self.T = np.empty((nl, 3, *self.shape)) if store is None else store
        self.x = [None] * nl
        self.y = [None] * nl
        self.th = [None] * nl
        self.c = [None] * nl
        self.s = [None] * nl
        self.points = [{} for _ in range(nl)]
        self.pending = set()                          # links whose angle row is not computed yet
        self.derived = set()                          # links whose angle row the kernel derived from (c, s)
        self.org = sp.origins_xy
        self.frame_k = f = self.idx[self.m.frame]
        self.T[f] = 0.0
        self.x[f], self.y[f], self.th[f] = self.T[f]
        self.c[f], self.s[f] = np.ones(self.shape), np.zeros(self.shape)

    def finite(self, links) -> np.ndarray:
        out = np.ones(self.shape, bool)
        for k in links:
            out &= np.isfinite(self.c[k]) if self.th[k] is not None else False
        return out

    def unset_to_nan(self) -> None:
        """Links never solved (``only=``) become NaN."""
        nan = None
        for k in range(self.m.n_links):
            if self.th[k] is None:
                nan = np.full(self.shape, np.nan) if nan is None else nan
                self.T[k] = np.nan
                self.x[k], self.y[k], self.th[k] = self.T[k]
                self.c[k] = self.s[k] = nan

    def take(self, rows: np.ndarray) -> "Poses":
        """The poses at the given rows only."""
        self.angles()
        out = object.__new__(Poses)
        out.sp, out.m, out.M, out.idx, out.frame_k, out.org = self.sp, self.m, len(rows), self.idx, self.frame_k, self.org
        out.shape, out.reasons, out.pending, out.derived = (len(rows),), self.reasons, set(), set(self.derived)
        out.explain = self.explain
        out.T = self.T[:, :, rows]
        out.x, out.y, out.th = ([None if a is None else out.T[k, i] for k, a in enumerate(getattr(self, name))]
                                for i, name in enumerate(("x", "y", "th")))
        out.c, out.s = ([None if a is None else a[rows] for a in getattr(self, name)] for name in ("c", "s"))
        # the points computed while solving, at these rows (not computed again: the same values)
        out.points = [{key: (_at_rows(px, rows), _at_rows(py, rows)) for key, (px, py) in kept.items()}
                      for kept in self.points]
        return out

    # -- reading -------------------------------------------------------------------
    def at(self, joint: str) -> np.ndarray:
        return np.asarray(self.m.joint(joint).at, float)

    def axis(self, joint: str) -> np.ndarray:
        return unit(self.m.joint(joint).axis)

    def point_k(self, k: int, r) -> np.ndarray:
        if k == self.frame_k:
            return np.broadcast_to(np.asarray(r, float), (*self.shape, 2))
        return columns(*self.point_xy(k, r), self.shape)

    def _local(self, k: int, r) -> tuple:
        """Reference position ``r`` relative to link k's reference point (the key of
        ``points[k]``); for designs, arrays ``(D, 1)`` (the key is then their bytes)."""
        if self.reasons:
            return float(r[0]) - self.org[k][0], float(r[1]) - self.org[k][1]
        return r[..., 0] - self.org[k][0], r[..., 1] - self.org[k][1]

    def point_xy(self, k: int, r):
        """Components ``(x, y)`` of link k's material point at the reference position
        ``r`` (:meth:`carry` of its offset from the link's reference point)."""
        return self.carry(k, *self._local(k, r))

    def carry(self, k: int, rx: float, ry: float):
        """The material point of link k at ``(rx, ry)`` from the link's reference point:
        floats on the frame (whose reference point is the origin), the pose's rows at the
        reference point, a point met while solving as kept, else rigidly carried (and
        kept in ``points[k]``)."""
        if k == self.frame_k:
            return rx, ry
        if self.reasons:                   # one design: float offsets
            if rx == 0.0 and ry == 0.0:
                return self.x[k], self.y[k]
            key = (rx, ry)
        elif _zero(rx) and _zero(ry):
            return self.x[k], self.y[k]
        else:
            key = _key(rx, ry)
        hit = self.points[k].get(key)
        if hit is None:
            hit = self.points[k][key] = carried(self.x[k], self.y[k], self.c[k], self.s[k], rx, ry)
        return hit

    def keep_point(self, k: int, r, px, py) -> None:
        """Record that link k's material point at the reference position ``r`` is at
        ``(px, py)`` (solved there directly): :meth:`carry` then reuses it until the link
        is placed again or invalidated."""
        self.points[k][_key(*self._local(k, r))] = (px, py)

    def point(self, link: str, r) -> np.ndarray:
        return self.point_k(self.idx[link], r)

    def direction(self, link: str, v) -> np.ndarray:
        k = self.idx[link]
        vx, vy = v[..., 0], v[..., 1]
        out = np.empty((*self.shape, 2))
        out[..., 0] = self.c[k] * vx - self.s[k] * vy
        out[..., 1] = self.s[k] * vx + self.c[k] * vy
        return out

    def theta(self, link: str) -> np.ndarray:
        return self.angle(self.idx[link])

    def angle(self, k: int) -> np.ndarray:
        """Link k's rotation row (computed from its cos and sin on first use)."""
        if k in self.pending:
            self.pending.discard(k)
            np.arctan2(self.s[k], self.c[k], out=self.T[k, 2])
        return self.th[k]

    def angles(self) -> None:
        """Compute every pending angle row."""
        for k in list(self.pending):
            self.angle(k)

    # -- writing -------------------------------------------------------------------
    def place_k(self, k: int, px, py, r_ref, c, s, th=None) -> None:
        """Pose of link k whose material point at ``r_ref`` is at ``(px, py)`` (arrays
        (M,) or floats), rotated by (c, s); the angle ``th`` is ``arctan2(s, c)`` unless
        given."""
        T = self.T[k]
        dx, dy = self._local(k, r_ref)
        dx, dy = -dx, -dy
        if (dx == 0.0 and dy == 0.0) if self.reasons else (_zero(dx) and _zero(dy)):
            T[0], T[1] = px, py
        else:
            np.add(px, c * dx - s * dy, out=T[0])
            np.add(py, s * dx + c * dy, out=T[1])
        if th is None:
            self.pending.add(k)
        else:
            self.pending.discard(k)
            T[2] = th
        self.x[k], self.y[k], self.th[k] = T
        self.c[k], self.s[k] = c, s
        self.points[k] = {}

    def place_cs(self, link: str, P, r_ref, c, s, th) -> None:
        """Pose of ``link`` whose material point at ``r_ref`` is at ``P`` (M, 2), rotated (c, s)."""
        self.place_k(self.idx[link], P[..., 0], P[..., 1], r_ref, c, s, th)

    def place_rot(self, k: int, px, py, r_ref, dx, dy, cr: float, sr: float) -> None:
        """As :meth:`place_k`, rotated by ``(dx cr + dy sr, dy cr − dx sr)``: the rotation
        taking the unit direction ``(cr, sr) · L`` to ``(dx, dy)`` when ``|(dx, dy)| = L``
        (a link of known length L, the reference direction divided by L once)."""
        self.place_k(k, px, py, r_ref, dx * cr + dy * sr, dy * cr - dx * sr)

    def place_dir_xy(self, k: int, px, py, r_ref, dx, dy, d_ref) -> None:
        """As :meth:`place_k`, the rotation taking direction ``d_ref`` to ``(dx, dy)``."""
        inv = 1.0 / np.sqrt(dx * dx + dy * dy)
        u = unit(d_ref)
        if u.ndim == 1:
            self.place_rot(k, px, py, r_ref, dx * inv, dy * inv, *u.tolist())
        else:
            self.place_rot(k, px, py, r_ref, dx * inv, dy * inv, u[..., 0], u[..., 1])

    def place_dir(self, link: str, P, r_ref, d, d_ref) -> None:
        """As :meth:`place_cs`, the rotation taking direction ``d_ref`` to ``d`` (N, 2)."""
        self.place_dir_xy(self.idx[link], P[..., 0], P[..., 1], r_ref, d[..., 0], d[..., 1], d_ref)

    def place_like(self, link: str, P, r_ref, other: str) -> None:
        k = self.idx[other]
        self.place_cs(link, P, r_ref, self.c[k], self.s[k], self.angle(k))

    def invalidate(self, links, bad) -> None:
        if np.any(bad):                 # (a pending angle row follows its NaN cos and sin)
            for k in links:
                if self.th[k] is not None:
                    self.T[k][:, bad] = np.nan
                    self.c[k], self.s[k] = np.where(bad, np.nan, self.c[k]), np.where(bad, np.nan, self.s[k])
                    self.points[k] = {key: (np.where(bad, np.nan, px), np.where(bad, np.nan, py))
                                      for key, (px, py) in self.points[k].items()}

    def adopt(self, links, C, S, derived=()) -> None:
        """Links ``links`` placed by the compiled kernel (:mod:`kin.kernel`): their rows of
        ``T`` are written; their cos and sin are the rows of ``C``, ``S``.  The angle rows
        of the links in ``derived`` came from their cos and sin (``arctan2``), as
        :meth:`angle` computes a pending row: a caller that computes only the angles
        asked for treats them as pending."""
        for k in links:
            self.pending.discard(k)
            self.x[k], self.y[k], self.th[k] = self.T[k]
            self.c[k], self.s[k] = C[k], S[k]
            self.points[k] = {}
        self.derived.update(int(k) for k in derived if k in set(links))

    def keep_rows(self, C, S) -> None:
        """Record that every link's cos and sin are the rows of ``C``, ``S`` (n_links,
        *shape) (the compiled kernel's arrays, adopted whole): :meth:`stacked_rows` then
        gives them without stacking, as long as no row was replaced since."""
        self._rows = (C, S, tuple(self.c), tuple(self.s))

    def stacked_rows(self):
        """Every link's cos and sin as two arrays ``(n_links, *shape)``: the kernel's own
        when :meth:`keep_rows` recorded them and no link's rows changed since, else None."""
        kept = getattr(self, "_rows", None)
        if kept is None or any(a is not b for a, b in zip(kept[2], self.c)) or \
                any(a is not b for a, b in zip(kept[3], self.s)):
            return None
        return kept[0], kept[1]

    # -- conversion to / from the (M, n_links, 3) pose array --------------------------
    def to_Z(self, links=None) -> np.ndarray:
        """The ``(M, n_links, 3)`` pose array: with ``links`` None (every link placed),
        the store itself as a transposed view of ``(n_links, 3, M)``; else a copy with
        only ``links`` and the frame (the others NaN)."""
        self.angles()
        if links is None:
            return np.moveaxis(self.T, (0, 1), (-2, -1))
        T = np.full(self.T.shape, np.nan)
        for k in list(links) + [self.frame_k]:
            T[k] = self.T[k]
        return np.moveaxis(T, (0, 1), (-2, -1))

    def from_T(self, T) -> None:
        """Every link's pose from a ``(n_links, 3, *shape)`` array (NaN where unsolved)."""
        self.T[...] = T
        self.pending.clear()
        for k in range(self.m.n_links):
            self.x[k], self.y[k], self.th[k] = self.T[k]
            self.c[k], self.s[k] = np.cos(self.th[k]), np.sin(self.th[k])
            self.points[k] = {}

    def from_Z(self, Z, links) -> None:
        for k in links:
            self.pending.discard(k)
            th = Z[:, k, 2]
            c, s = np.cos(th), np.sin(th)
            self.T[k, 0], self.T[k, 1], self.T[k, 2] = Z[:, k, 0], Z[:, k, 1], th
            self.x[k], self.y[k], self.th[k] = self.T[k]
            self.c[k], self.s[k] = c, s
            self.points[k] = {}


def _key(rx, ry):
    """A hashable key of an offset: the floats, or the bytes of per-design arrays."""
    return (rx, ry) if isinstance(rx, float) else (rx.tobytes(), ry.tobytes())


def rates_of(D, k):
    """Link (or links) ``k``'s point rates and angular rates ``(D[:, k, :2], D[:, k, 2])``
    of the pose rates ``D`` (N, n_links, 3); ``(None, None)`` when ``D`` is None (the
    accelerations of a velocities-only solve)."""
    return (None, None) if D is None else (D[:, k, :2], D[:, k, 2])


class PoseRates:
    """Velocities/accelerations of material points from the pose arrays Z, Zd, Zdd
    (``Zdd`` None: velocities only, every acceleration returned is None)."""

    def __init__(self, sp, Z, Zd, Zdd):
        self.sp, self.Z, self.Zd, self.Zdd = sp, Z, Zd, Zdd
        self.idx = {x: i for i, x in enumerate(sp.mechanism.link_names)}

    def point(self, link: str, r):
        """Position, velocity, acceleration of ``link``'s material point at reference ``r``."""
        k = self.idx[link]
        return move_point(self.Z[:, k, :2], self.Z[:, k, 2], np.asarray(r, float) - self.sp.origins[k],
                          *rates_of(self.Zd, k), *rates_of(self.Zdd, k))

    def direction(self, link: str, v):
        k = self.idx[link]
        return rotate(v, self.Z[:, k, 2]), self.Zd[:, k, 2], rates_of(self.Zdd, k)[1]

    def set(self, link: str, P, vP, aP, w, e) -> None:
        """Rates of ``link`` from those of its point at P and its ω, ε."""
        k = self.idx[link]
        v, a = transport(self.Z[:, k, :2] - P, vP, aP, w, e)
        self.Zd[:, k, :2], self.Zd[:, k, 2] = v, w
        if self.Zdd is not None:
            self.Zdd[:, k, :2], self.Zdd[:, k, 2] = a, e
