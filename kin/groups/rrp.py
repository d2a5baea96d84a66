"""Kind 2 dyad (RRP): link 2 = A–B on a known pin A; B (a pin of slider link 3)
moves along a guide line fixed in a known link.

Vasechkin et al. 2017 [1]_, figure 2, eqs. (9)-(14).  The guide is ``(P, u)`` of the known
link, the track of B is ``P + s u + h n(u)`` (seed: ``h = l3``, ``s = l4``).
Matrix columns ``c1 = l2 n(φ2) = perp(B-A)``, ``c2 = -u``;
``det = (B-A)·u = l2 cos(φ2-φ3)``.

Seed misprints: eq. (12) prints ``a12 = l3 sinφ3, a22 = -l3 cosφ3`` (copied from
kind 1); correct are ``a12 = -cosφ3, a22 = -sinφ3``.  The acceleration right-hand
side (14) is unreadable; ours is derived from the loop equation (vector form of
docs/groups.md) and checked against finite differences.

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

from .base import (branch_sign, put_off, put_rel, pair, margin_tol, REACH_RTOL, carry, cramer, dot, is_singular,
                   length, num, place_along, place_like, sign_of, stack, turned, xy, quiet)
from ..continuation import Probe
from ..poses import known_on, normal, unit
from ..result import Status
from .step import SINGULAR, AngleDef, GroupStep, Lowered, Outcome, dyad_outcome

__all__ = ["RRPPosition", "RRPRates", "rrp_position", "rrp_branch", "rrp_rates", "RRPStep", "rrp_place"]


class RRPPosition(NamedTuple):
    """Result of :func:`rrp_position`: ``B`` (..., 2), slide ``s``, ``ok``, ``det``."""

    B: np.ndarray
    s: np.ndarray
    ok: np.ndarray
    det: np.ndarray


class RRPRates(NamedTuple):
    """Result of :func:`rrp_rates` (acceleration fields ``None`` unless asked)."""

    w2: np.ndarray
    sd: np.ndarray
    vB: np.ndarray
    e2: np.ndarray | None
    sdd: np.ndarray | None
    aB: np.ndarray | None
    det: np.ndarray
    singular: np.ndarray


@quiet
def rrp_position(A, P, u, l2, h=0.0, sign=1.0) -> RRPPosition:
    """Position of B of an RRP dyad, vectorised.

    Parameters
    ----------
    A : array_like, shape (..., 2)
        Outer pin of link 2 (on a known link).
    P, u : array_like, shape (..., 2)
        A point and the unit direction of the guide line (both of the known guide
        link, current position).
    l2 : float or array_like
        Length |AB|.
    h : float or array_like
        Signed offset of B's track from the line along ``n(u)``.
    sign : {+1, -1} or array_like
        +1: ``(B-A)·u > 0`` (seed's assembly No. 1, ``s = A_x1 + x2``); read it
        with :func:`rrp_branch`.

    Returns
    -------
    RRPPosition
        ``B``, ``s`` (slide along ``u`` from P), ``ok``, ``det = (B-A)·u``
        (``sign(det) == sign``).

    Notes
    -----
    Vasechkin et al. 2017 eqs. (9)-(11): ``A_x1 = (A-P)·u``, ``A_y1 = (A-P)·n(u)``,
    ``x2 = sqrt(l2² - (h - A_y1)²)``, ``s = A_x1 ± x2``.
    """
    ax, ay = xy(A)
    px, py = xy(P)
    ux, uy = xy(u)
    rx, ry = ax - px, ay - py
    ax1 = rx * ux + ry * uy
    ay1 = ry * ux - rx * uy
    l2s = np.square(l2)
    dy = h - ay1
    q = l2s - dy * dy
    with np.errstate(invalid="ignore"):
        ok = q >= -REACH_RTOL * l2s
        x2 = np.sqrt(np.where(ok, np.maximum(q, 0.0), np.nan)) * sign
    s = ax1 + x2
    bx = px + s * ux - h * uy
    by = py + s * uy + h * ux
    ok = ok & np.isfinite(bx) & np.isfinite(by)
    return RRPPosition(stack(bx, by), s, ok, x2)


def rrp_branch(A, B, u, strict=True):
    """Assembly sign ``sign((B-A)·u)`` of an RRP dyad in a reference configuration.

    Raises
    ------
    SingularityError
        If link A–B is perpendicular to the guide (relative tolerance 1e-8).
    """
    ax, ay = xy(A)
    bx, by = xy(B)
    ux, uy = xy(u)
    v = (bx - ax) * ux + (by - ay) * uy
    return sign_of(v, np.hypot(bx - ax, by - ay), "RRP dyad reference", strict)


@quiet
def rrp_rates(A, B, P, u, vA, vP, omega, aA=None, aP=None, eps=None) -> RRPRates:
    """Velocities/accelerations of an RRP dyad.

    Parameters
    ----------
    A, B, P, u : array_like, shape (..., 2)
        Positions (B from :func:`rrp_position`), guide point and direction.
    vA, vP : array_like, shape (..., 2)
        Velocity of A and of P as a point of the guide link.
    omega : float or array_like
        Angular velocity of the guide link.
    aA, aP, eps : optional
        Accelerations (all three, else only velocities are solved).

    Returns
    -------
    RRPRates
        ``w2`` (link A–B), ``sd`` (slide rate along u, relative to the guide), ``vB``;
        ``e2, sdd, aB``; ``det = (B-A)·u`` and ``singular``.

    Notes
    -----
    Vasechkin et al. 2017 eqs. (12)-(14) with corrected a12, a22:
    ``w2 perp(B-A) - sd u = vP - vA + omega perp(B-P)``;
    ``e2 perp(B-A) - sdd u = aP - aA + eps perp(B-P) - omega²(B-P)
    + 2 omega sd perp(u) + w2²(B-A)``.
    """
    ax, ay = xy(A)
    bx, by = xy(B)
    px, py = xy(P)
    ux, uy = xy(u)
    rax, ray = bx - ax, by - ay
    rpx, rpy = bx - px, by - py
    c1x, c1y = -ray, rax
    c2x, c2y = -ux, -uy
    vax, vay = xy(vA)
    vpx, vpy = xy(vP)
    w2, sd, det = cramer(c1x, c1y, c2x, c2y,
                         vpx - vax - omega * rpy, vpy - vay + omega * rpx)
    vB = stack(vax + w2 * c1x, vay + w2 * c1y)
    sing = is_singular(det, c1x, c1y, c2x, c2y)
    e2 = sdd = aB = None
    if aA is not None and aP is not None and eps is not None:
        aax, aay = xy(aA)
        apx, apy = xy(aP)
        om2 = np.square(omega)
        w2s = w2 * w2
        cor = 2.0 * omega * sd
        b1 = apx - aax - eps * rpy - om2 * rpx - cor * uy + w2s * rax
        b2 = apy - aay + eps * rpx - om2 * rpy + cor * ux + w2s * ray
        e2, sdd, _ = cramer(c1x, c1y, c2x, c2y, b1, b2)
        aB = stack(aax + e2 * c1x - w2s * rax, aay + e2 * c1y - w2s * ray)
    return RRPRates(w2, sd, vB, e2, sdd, aB, det, sing)


def rrp_place(ip, fp, X, W, F, T, C, S, PP, out) -> None:
    """RRP steps at every position for the compiled kernel (:mod:`kin.kernel`), as
    :meth:`RRPStep.positions` (Vasechkin et al. 2017, eqs. (9)-(11)).

    ``ip`` = (known1, the guide's link, link1, link2); ``fp`` = (A, P relative to their
    links, u, h, l2, sign, unit B−A, link1's and link2's reference points relative to A
    and B, singular threshold).
    """
    k1, kp, l1, l2 = ip[0], ip[1], ip[2], ip[3]
    a0, a1, p0, p1, u0, u1, h, la, sign = fp[0], fp[1], fp[2], fp[3], fp[4], fp[5], fp[6], fp[7], fp[8]
    dc, ds, o1x, o1y, o2x, o2y, thr = fp[9], fp[10], fp[11], fp[12], fp[13], fp[14], fp[15]
    rows = F.size > 1
    l2s = la * la
    for n in range(X.shape[0]):
        ax, ay = carry(k1, n, T, C, S, a0, a1)
        px, py = carry(kp, n, T, C, S, p0, p1)
        ux, uy = turned(kp, n, C, S, u0, u1)
        rx, ry = ax - px, ay - py
        dy = h - (ry * ux - rx * uy)
        q = l2s - dy * dy
        ok = q >= -REACH_RTOL * l2s
        x2 = np.sqrt(max(q, 0.0)) * (sign * (F[n] if rows else F[0])) if ok else np.nan
        s = (rx * ux + ry * uy) + x2
        bx = px + s * ux - h * uy
        by = py + s * uy + h * ux
        ok = ok and np.isfinite(bx) and np.isfinite(by)
        place_along(l1, n, T, C, S, ax, ay, o1x, o1y, bx - ax, by - ay, dc, ds)
        place_like(l2, kp, n, T, C, S, bx, by, o2x, o2y, PP)
        out[n] = 1 if not ok else (0 if abs(x2) > thr else 2)
    PP[l1], PP[l2], PP[kp] = 1, 0, 0


def rrp_lower(q, P, U, O, size, out) -> None:
    """:meth:`RRPStep.lower` of D designs for the compiled kernel: the same floats.
    ``q`` = (rows of A, B, P; known1, the guide's link, link1, link2)."""
    ia, ib, ip, k1, kp, l1, l2 = q[0], q[1], q[2], q[3], q[4], q[5], q[6]
    for d in range(P.shape[0]):
        ax, ay, bx, by, px, py = P[d, ia, 0], P[d, ia, 1], P[d, ib, 0], P[d, ib, 1], P[d, ip, 0], P[d, ip, 1]
        ux, uy = U[d, ip, 0], U[d, ip, 1]
        la = np.hypot(bx - ax, by - ay)
        put_rel(out, d, 0, ax, ay, O, k1)
        put_rel(out, d, 2, px, py, O, kp)
        out[d, 4], out[d, 5], out[d, 6] = ux, uy, -uy * (bx - px) + ux * (by - py)
        out[d, 7], out[d, 8] = la, branch_sign((bx - ax) * ux + (by - ay) * uy, np.hypot(bx - ax, by - ay))
        out[d, 9], out[d, 10] = (bx - ax) / la, (by - ay) / la
        put_off(out, d, 11, ax, ay, O, l1)
        put_off(out, d, 13, bx, by, O, l2)
        out[d, 15] = SINGULAR * la


class RRPStep(GroupStep):
    """An RRP dyad of a plan (link1 pinned at outer1 and at the slider's pin, the slider
    link2 on the guide of the known link at outer2): compiled once."""

    kind = GroupKind.RRP
    compiled = staticmethod(rrp_place)
    compiled_lower = staticmethod(rrp_lower)

    @classmethod
    def assembly_modes(cls, m, group) -> int:
        """Two: the rod reaches the guide on either side."""
        return 2

    @classmethod
    def monitored_angles(cls, m, group) -> tuple[AngleDef, ...]:
        """The pressure angle: the rod outer1-inner against the guide of the slider's P
        joint outer2 (Vasechkin et al. 2017, kind 2)."""
        o1, inner, o2, _, _ = group.layout
        return (AngleDef(inner, "pressure", (o1, inner), (o2, m.joint(o2).links[0])),)

    @classmethod
    def reference_margin(cls, m, group, at, axis) -> np.ndarray:
        """|cos| of the angle between the rod and the guide at the reference."""
        o1, inner, o2, _, _ = group.layout
        u = at(inner) - at(o1)
        return np.abs(np.sum(u * axis(o2), 1)) / np.linalg.norm(u, axis=1)

    def __init__(self, mechanism, st, size: float, geo=None):
        super().__init__(mechanism, st, size, geo)
        lay = self.layout = self.group.layout
        at = self.at
        self.A, self.B, self.P = at(lay.outer1), at(lay.inner), at(lay.outer2)
        self.known1, self.kp = known_on(self.group, lay.outer1), known_on(self.group, lay.outer2)
        self.u = self.axis(lay.outer2)
        self.h = dot(normal(self.u), self.B - self.P)
        self.la = length(self.B - self.A)
        self.sign = num(rrp_branch(self.A, self.B, self.u, self.strict))

    def positions(self, G, X, factor=1.0, probe=False) -> Outcome:
        lay = self.layout
        A = G.point(self.known1, self.A)
        P, u = G.point(self.kp, self.P), G.direction(self.kp, self.u)
        rs = rrp_position(A, P, u, self.la, self.h, self.sign * factor)
        B, ok = rs.B, rs.ok
        why, pr = {}, None
        if probe:
            gap = 2.0 * np.abs(np.sum((B - A) * u, axis=-1))
            # A in the guide's frame: its distance from the track changes no faster than it
            loc = np.stack([np.sum((A - P) * u, axis=-1), np.sum((A - P) * normal(u), axis=-1)], axis=-1)
            margin = self.la - np.abs(loc[:, 1] - self.h)
            pr = Probe(ok.copy(), gap, np.stack([B, A, P], axis=1), margin=margin, lip=loc[:, None],
                       tol=margin_tol(A, P, self.la + abs(self.h)))
        if G.explain and not ok.all():
            dist = np.abs(np.sum((A - P) * normal(u), axis=-1) - self.h)
            for n in np.flatnonzero(~ok):
                if np.isfinite(dist[n]):
                    why[int(n)] = (Status.OUT_OF_REACH, f"no assembly: {lay.outer1} is {dist[n]:.6g} from the track of "
                                   f"{lay.inner}, longer than {lay.link1} ({self.la:.6g}) (out of reach)")
        G.place_dir(lay.link1, A, self.A, B - A, self.B - self.A)
        G.place_like(lay.link2, B, self.B, self.kp)
        return dyad_outcome(ok, why, rs.det, self.la, False, pr, probe, G.explain)

    def lower(self, origins) -> Lowered | None:
        """Flat numbers of :func:`rrp_place`."""
        lay, o = self.layout, origins
        k1, kp, l1, l2 = (self.link_index(x) for x in (self.known1, self.kp, lay.link1, lay.link2))
        f = (*self.rel(o, k1, self.A), *self.rel(o, kp, self.P), *pair(self.u), self.h, self.la, self.sign,
             *pair(unit(self.B - self.A)), *self.off(o, l1, self.A), *self.off(o, l2, self.B),
             SINGULAR * self.la)
        return Lowered(GroupKind.RRP, (k1, kp, l1, l2), f)

    def margin_curvature(self, R) -> np.ndarray:
        """|d²margin/dx²| along the motion of ``R``: the margin is ``l − |y − h|`` with
        ``y = (A − P)·n`` the distance of A from the guide line (n = e_z × u, ṅ = −ω u)."""
        A, vA, aA = R.point(self.known1, self.A)
        P, vP, aP = R.point(self.kp, self.P)
        u, w, e = R.direction(self.kp, self.u)
        n = normal(u)
        r, vr, ar = A - P, vA - vP, aA - aP
        w2 = w[:, None]
        ydd = (np.sum(ar * n, axis=-1) - 2.0 * w * np.sum(vr * u, axis=-1)
               - np.sum(r * (e[:, None] * u + w2 * w2 * n), axis=-1))
        return np.abs(ydd)

    def lower_indices(self, row) -> tuple[int, ...]:
        lay = self.layout
        return (row(lay.outer1), row(lay.inner), row(lay.outer2),
                *(self.link_index(x) for x in (self.known1, self.kp, lay.link1, lay.link2)))

    def rates(self, R, input_rates) -> None:
        lay = self.layout
        A, vA, aA = R.point(self.known1, self.A)
        P, vP, aP = R.point(self.kp, self.P)
        u, w, e = R.direction(self.kp, self.u)
        B = R.point(lay.link1, self.B)[0]
        r = rrp_rates(A, B, P, u, vA, vP, w, aA, aP, e)
        R.set(lay.link1, A, vA, aA, r.w2, r.e2)
        R.set(lay.link2, B, r.vB, r.aB, w, e)
