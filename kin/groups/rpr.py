"""Kind 3 dyad (RPR, coulisse): block 2 pivoted at a known pin A slides on guide
link 3 pivoted at a known pin C.

Vasechkin et al. 2017 [1]_, figure 3, eqs. (15)-(22).  ``A = C + s u + h n(u)`` with ``u`` the
guide direction of link 3 (seed: ``h = l2``, ``s = l3``, ``u = e(φ3)``).  Matrix
columns ``c1 = u``, ``c2 = perp(A-C) = s n(u) - h u``; ``det = s``.

Seed misprints: eq. (17), second line, prints ``l3 sinφ3 - l2 cosφ3``; correct is
``l3 sinφ3 + l2 cosφ3 = A_y - C_y``.  Eq. (22) prints
``b2 = ... + 2 V3 ω3 a11 + a11 ω3²``; correct is ``- 2 V3 ω3 a11 - a12 ω3²``.
The paper's ``arctan(l2/l3)`` must be ``atan2`` for the ``s < 0`` branch.

References
----------
.. [1] Vasechkin M.A., Matveeva E.V., Sidorenko A.S., Chertov E.D. Mathematical
   model of kinematic calculation of flat lever mechanisms. Vestnik VGUIT 79(2)
   (2017) 73-79. doi:10.20914/2310-1202-2017-2-73-79.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from multiloop.topo.assur import GroupKind

from .base import (branch_sign, put_off, put_rel, pair, square_curvature, margin_tol, REACH_RTOL, arctan2, carry,
                   cramer, dot, is_singular, num, place, place_along, sign_of, stack, xy, quiet)
from ..continuation import Probe
from ..poses import known_on, normal, unit
from ..result import Status
from .step import SINGULAR, AngleDef, GroupStep, Lowered, Outcome, dyad_outcome

__all__ = ["RPRPosition", "RPRRates", "rpr_position", "rpr_branch", "rpr_rates", "RPRStep", "rpr_place"]


class RPRPosition(NamedTuple):
    """Result of :func:`rpr_position`: guide direction ``u`` (..., 2), slide ``s``,
    ``ok``, ``det = s``."""

    u: np.ndarray
    s: np.ndarray
    ok: np.ndarray
    det: np.ndarray


class RPRRates(NamedTuple):
    """Result of :func:`rpr_rates` (acceleration fields ``None`` unless asked)."""

    sd: np.ndarray
    w3: np.ndarray
    sdd: np.ndarray | None
    e3: np.ndarray | None
    det: np.ndarray
    singular: np.ndarray


@quiet
def rpr_position(A, C, h=0.0, sign=1.0) -> RPRPosition:
    """Guide direction and slide of an RPR dyad, vectorised.

    Parameters
    ----------
    A, C : array_like, shape (..., 2)
        Pivot of the block (A) and of the guide link (C), both on known links.
    h : float or array_like
        Signed offset of A from the guide line through C, along ``n(u)``.
    sign : {+1, -1} or array_like
        Sign of the slide ``s = (A-C)·u`` (seed's assembly No. 1: ``s >= 0``).

    Returns
    -------
    RPRPosition
        ``u`` unit guide direction of link 3 (block 2 turns with it), ``s``, ``ok``,
        ``det = s``.

    Notes
    -----
    Vasechkin et al. 2017 eqs. (15)-(18) without trigonometry: with ``d = A - C``,
    ``s = sign·sqrt(|d|² - h²)`` and ``u = (s d - h perp(d))/|d|²``.
    """
    ax, ay = xy(A)
    cx, cy = xy(C)
    dx, dy = ax - cx, ay - cy
    d2 = dx * dx + dy * dy
    hs = np.square(h)
    q = d2 - hs
    with np.errstate(invalid="ignore", divide="ignore"):
        ok = (q >= -REACH_RTOL * d2) & (d2 > 0)
        s = np.sqrt(np.where(ok, np.maximum(q, 0.0), np.nan)) * sign
        ux = (s * dx + h * dy) / d2
        uy = (s * dy - h * dx) / d2
    ok = ok & np.isfinite(ux) & np.isfinite(uy)
    return RPRPosition(stack(ux, uy), s, ok, s)


def rpr_branch(A, C, u, strict=True):
    """Assembly sign ``sign((A-C)·u)`` of an RPR dyad in a reference configuration.

    Raises
    ------
    SingularityError
        If A sits at the foot of the perpendicular from C (``s = 0``).
    """
    ax, ay = xy(A)
    cx, cy = xy(C)
    ux, uy = xy(u)
    v = (ax - cx) * ux + (ay - cy) * uy
    return sign_of(v, np.hypot(ax - cx, ay - cy), "RPR dyad reference", strict)


@quiet
def rpr_rates(A, C, u, vA, vC, aA=None, aC=None) -> RPRRates:
    """Slide rate and angular velocity (and accelerations) of an RPR dyad.

    Parameters
    ----------
    A, C, u : array_like, shape (..., 2)
        Positions and the guide direction from :func:`rpr_position`.
    vA, vC : array_like, shape (..., 2)
        Velocities of the pivots; ``aA, aC`` optional accelerations.

    Returns
    -------
    RPRRates
        ``sd`` (slide rate), ``w3`` (angular velocity of links 2 and 3), ``sdd``,
        ``e3``, ``det = s`` and ``singular``.

    Notes
    -----
    Vasechkin et al. 2017 eqs. (19)-(22): ``sd u + w3 perp(A-C) = vA - vC``;
    ``sdd u + e3 perp(A-C) = aA - aC + w3²(A-C) - 2 sd w3 perp(u)``.
    """
    ax, ay = xy(A)
    cx, cy = xy(C)
    ux, uy = xy(u)
    rx, ry = ax - cx, ay - cy
    c2x, c2y = -ry, rx
    vax, vay = xy(vA)
    vcx, vcy = xy(vC)
    sd, w3, det = cramer(ux, uy, c2x, c2y, vax - vcx, vay - vcy)
    sing = is_singular(det, ux, uy, c2x, c2y)
    sdd = e3 = None
    if aA is not None and aC is not None:
        aax, aay = xy(aA)
        acx, acy = xy(aC)
        w3s = w3 * w3
        cor = 2.0 * sd * w3
        b1 = aax - acx + w3s * rx + cor * uy
        b2 = aay - acy + w3s * ry - cor * ux
        sdd, e3, _ = cramer(ux, uy, c2x, c2y, b1, b2)
    return RPRRates(sd, w3, sdd, e3, det, sing)


def rpr_place(ip, fp, X, W, F, T, C, S, PP, out) -> None:
    """RPR steps at every position for the compiled kernel (:mod:`kin.kernel`), as
    :meth:`RPRStep.positions` (Vasechkin et al. 2017, eqs. (15)-(18)).

    ``ip`` = (the guide's pivot link, the block's pivot link, guide, block); ``fp`` =
    (X, Y relative to their links, h, sign, the guide's unit reference direction, the
    guide's and the block's reference points relative to X and Y, singular threshold).
    """
    kx, ky, g, b = ip[0], ip[1], ip[2], ip[3]
    x0, x1, y0, y1, h, sign, dc, ds = fp[0], fp[1], fp[2], fp[3], fp[4], fp[5], fp[6], fp[7]
    ogx, ogy, obx, oby, thr = fp[8], fp[9], fp[10], fp[11], fp[12]
    rows = F.size > 1
    for n in range(X.shape[0]):
        xx, xy_ = carry(kx, n, T, C, S, x0, x1)
        yx, yy = carry(ky, n, T, C, S, y0, y1)
        dx, dy = yx - xx, yy - xy_
        d2 = dx * dx + dy * dy
        q = d2 - h * h
        ok = q >= -REACH_RTOL * d2 and d2 > 0
        s = np.sqrt(max(q, 0.0)) * (sign * (F[n] if rows else F[0])) if ok else np.nan
        ux = (s * dx + h * dy) / d2
        uy = (s * dy - h * dx) / d2
        ok = ok and np.isfinite(ux) and np.isfinite(uy)
        place_along(g, n, T, C, S, xx, xy_, ogx, ogy, ux, uy, dc, ds)
        place(b, n, T, C, S, yx, yy, obx, oby, C[g, n], S[g, n])
        T[g, 2, n] = T[b, 2, n] = arctan2(S[g, n], C[g, n])     # the block turns with the guide
        out[n] = 1 if not ok else (0 if abs(s) > thr else 2)
    PP[g] = PP[b] = 0


def rpr_lower(q, P, U, O, size, out) -> None:
    """:meth:`RPRStep.lower` of D designs for the compiled kernel: the same floats.
    ``q`` = (rows of X, Y and the P joint; kx, ky, the guide, the block)."""
    ix, iy, ii, kx, ky, g, b = q[0], q[1], q[2], q[3], q[4], q[5], q[6]
    for d in range(P.shape[0]):
        xx, xy_, yx, yy = P[d, ix, 0], P[d, ix, 1], P[d, iy, 0], P[d, iy, 1]
        ux, uy = U[d, ii, 0], U[d, ii, 1]
        hu = np.hypot(ux, uy)
        put_rel(out, d, 0, xx, xy_, O, kx)
        put_rel(out, d, 2, yx, yy, O, ky)
        out[d, 4] = -uy * (yx - xx) + ux * (yy - xy_)
        out[d, 5] = branch_sign((yx - xx) * ux + (yy - xy_) * uy, np.hypot(yx - xx, yy - xy_))
        out[d, 6], out[d, 7] = ux / hu, uy / hu
        put_off(out, d, 8, xx, xy_, O, g)
        put_off(out, d, 10, yx, yy, O, b)
        out[d, 12] = SINGULAR * size


class RPRStep(GroupStep):
    """An RPR dyad of a plan: the guide (the P joint's first link) pivoted at X, the
    block at Y; compiled once."""

    kind = GroupKind.RPR
    compiled = staticmethod(rpr_place)
    compiled_lower = staticmethod(rpr_lower)

    @classmethod
    def assembly_modes(cls, m, group) -> int:
        """Two: the block on either side of the guide's pivot."""
        return 2

    @staticmethod
    def _pivots(m, group) -> tuple[str, str]:
        """(the guide's pivot, the block's pivot)."""
        o1, inner, o2, l1, _ = group.layout
        guide = m.joint(inner).links[0]
        return (o1, o2) if guide == l1 else (o2, o1)

    @classmethod
    def monitored_angles(cls, m, group) -> tuple[AngleDef, ...]:
        """The pressure angle: the guide against the line from the guide's pivot to the
        block's pivot (Vasechkin et al. 2017, kind 3)."""
        inner = group.layout.inner
        return (AngleDef(inner, "pressure", cls._pivots(m, group), (inner, m.joint(inner).links[0])),)

    @classmethod
    def reference_margin(cls, m, group, at, axis) -> np.ndarray:
        """The slide over the pivot distance (|cos| of the guide against the pivots' line)."""
        gx, bx = cls._pivots(m, group)
        d = at(bx) - at(gx)
        return np.abs(np.sum(d * axis(group.layout.inner), 1)) / np.linalg.norm(d, axis=1)

    def __init__(self, mechanism, st, size: float, geo=None):
        super().__init__(mechanism, st, size, geo)
        lay = self.layout = self.group.layout
        self.guide = mechanism.joint(lay.inner).links[0]
        self.gx, self.bx = (lay.outer1, lay.outer2) if self.guide == lay.link1 else (lay.outer2, lay.outer1)
        self.block = lay.link2 if self.guide == lay.link1 else lay.link1
        self.X, self.Y = (self.at(j) for j in (self.gx, self.bx))
        self.kx, self.ky = known_on(self.group, self.gx), known_on(self.group, self.bx)
        self.u = self.axis(lay.inner)
        self.h = dot(normal(self.u), self.Y - self.X)
        self.sign = num(rpr_branch(self.Y, self.X, self.u, self.strict))

    def positions(self, G, X, factor=1.0, probe=False) -> Outcome:
        Xp, Yp = G.point(self.kx, self.X), G.point(self.ky, self.Y)
        rs = rpr_position(Yp, Xp, self.h, self.sign * factor)
        u, ok = rs.u, rs.ok
        why, pr = {}, None
        if probe:
            fs = Xp + rs.s[:, None] * u
            rel = Yp - Xp                                    # margin |XY|² − h², smooth where X meets Y
            d = np.hypot(rel[:, 0], rel[:, 1])
            pr = Probe(ok.copy(), 2.0 * np.abs(rs.s), np.stack([fs, Xp, Yp], axis=1), margin=d * d - self.h ** 2,
                       lip=rel[:, None], tol=margin_tol(Xp, Yp, abs(self.h), squared=True), lip_scale=d)
        if G.explain and not ok.all():
            dist = np.hypot(*(Yp - Xp).T)
            for n in np.flatnonzero(~ok):
                if np.isfinite(dist[n]):
                    why[int(n)] = (Status.OUT_OF_REACH, f"no assembly: |{self.gx}{self.bx}| = {dist[n]:.6g} < "
                                   f"offset {abs(self.h):.6g} (out of reach)")
        G.place_dir(self.guide, Xp, self.X, u, self.u)
        G.place_like(self.block, Yp, self.Y, self.guide)
        return dyad_outcome(ok, why, rs.det, self.size, False, pr, probe, G.explain)

    def lower(self, origins) -> Lowered | None:
        """Flat numbers of :func:`rpr_place`."""
        o = origins
        kx, ky, g, b = (self.link_index(x) for x in (self.kx, self.ky, self.guide, self.block))
        f = (*self.rel(o, kx, self.X), *self.rel(o, ky, self.Y), self.h, self.sign, *pair(unit(self.u)),
             *self.off(o, g, self.X), *self.off(o, b, self.Y), SINGULAR * self.size)
        return Lowered(GroupKind.RPR, (kx, ky, g, b), f)

    def margin_curvature(self, R) -> np.ndarray:
        """|d²margin/dx²| along the motion of ``R`` (margin ``|XY|² − h²``)."""
        Xp, vX, aX = R.point(self.kx, self.X)
        Yp, vY, aY = R.point(self.ky, self.Y)
        return square_curvature(Yp - Xp, vY - vX, aY - aX)

    def lower_indices(self, row) -> tuple[int, ...]:
        return (row(self.gx), row(self.bx), row(self.layout.inner),
                *(self.link_index(x) for x in (self.kx, self.ky, self.guide, self.block)))

    def rates(self, R, input_rates) -> None:
        Xp, vX, aX = R.point(self.kx, self.X)
        Yp, vY, aY = R.point(self.ky, self.Y)
        u = R.direction(self.guide, self.u)[0]
        r = rpr_rates(Yp, Xp, u, vY, vX, aY, aX)
        R.set(self.guide, Xp, vX, aX, r.w3, r.e3)
        R.set(self.block, Yp, vY, aY, r.w3, r.e3)
