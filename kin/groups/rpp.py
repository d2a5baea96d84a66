"""Kind 5 dyad (RPP): link 2 pivoted at a known pin A slides along link 3, which
slides along a guide of a known link.  All angles are known; linear.

Vasechkin et al. 2017 [1]_, figure 5, eqs. (30)-(36).  ``Q = P + s1 u`` is link 3's point on
the known guide ``(P, u)``; link 2 slides along ``w = R(alpha) u`` (seed:
``β = φ3 + α``) with offset ``h``: ``A = Q + s2 w + h n(w)``.  Matrix columns
``u``, ``w``; ``det = cross(u, w) = sin(alpha)`` (alpha = 0, π is a design error).

Seed misprint: eq. (30) prints the offset as ``(-l2 sin β, -l2 cos β)``, which is
not a rotated vector; correct is ``+h n(β) = h(-sin β, cos β)``.

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

from .base import (put_off, put_rel, pair, SINGULAR_RTOL, carry, cramer, dot, is_singular, num, place_like, stack,
                   turned, xy, quiet)
from ..poses import angle_of, known_on, normal
from .step import GUIDES_HINT, PARALLEL_GUIDES, GroupStep, Lowered, Outcome, dyad_outcome

__all__ = ["RPPPosition", "RPPRates", "rpp_position", "rpp_rates", "RPPStep", "rpp_place"]


class RPPPosition(NamedTuple):
    """Result of :func:`rpp_position`: ``Q`` (..., 2), slides ``s1, s2``, ``ok``, ``det``."""

    Q: np.ndarray
    s1: np.ndarray
    s2: np.ndarray
    ok: np.ndarray
    det: np.ndarray


class RPPRates(NamedTuple):
    """Result of :func:`rpp_rates` (acceleration fields ``None`` unless asked)."""

    s1d: np.ndarray
    s2d: np.ndarray
    vQ: np.ndarray
    s1dd: np.ndarray | None
    s2dd: np.ndarray | None
    aQ: np.ndarray | None
    det: np.ndarray
    singular: np.ndarray


def _w(ux, uy, alpha):
    ca, sa = np.cos(alpha), np.sin(alpha)
    return ca * ux - sa * uy, sa * ux + ca * uy


@quiet
def rpp_position(A, P, u, alpha, h=0.0) -> RPPPosition:
    """Slides of an RPP dyad and link 3's point Q, vectorised.

    Parameters
    ----------
    A : array_like, shape (..., 2)
        Pivot of link 2 (on a known link).
    P, u : array_like, shape (..., 2)
        Point and unit direction of the known guide on which link 3 slides.
    alpha : float or array_like
        Angle from the known guide to link 3's own guide (constant).
    h : float or array_like
        Offset of A from link 3's guide along ``n(w)``.

    Returns
    -------
    RPPPosition
        ``Q = P + s1 u``, ``s1``, ``s2``, ``ok`` (False if ``sin(alpha) ≈ 0``),
        ``det = sin(alpha)``.

    Notes
    -----
    Vasechkin et al. 2017 eqs. (30)-(32) (offset corrected): ``s1 u + s2 w = A - P - h n(w)``.
    """
    ax, ay = xy(A)
    px, py = xy(P)
    ux, uy = xy(u)
    wx, wy = _w(ux, uy, alpha)
    s1, s2, det = cramer(ux, uy, wx, wy, ax - px + h * wy, ay - py - h * wx)
    ok = ~is_singular(det, ux, uy, wx, wy)
    s1 = np.where(ok, s1, np.nan)
    s2 = np.where(ok, s2, np.nan)
    Q = stack(px + s1 * ux, py + s1 * uy)
    return RPPPosition(Q, s1, s2, ok & np.all(np.isfinite(Q), axis=-1), det)


@quiet
def rpp_rates(A, Q, P, u, alpha, vA, vP, omega, aA=None, aP=None, eps=None) -> RPPRates:
    """Slide rates (and accelerations) of an RPP dyad and the motion of Q.

    Parameters
    ----------
    A, Q, P, u : array_like, shape (..., 2)
        Positions (Q from :func:`rpp_position`).
    alpha : float or array_like
        As in :func:`rpp_position`.
    vA, vP : array_like, shape (..., 2)
        Velocity of A and of P as a point of the guide link.
    omega : float or array_like
        Angular velocity of the guide link (links 2 and 3 share it).
    aA, aP, eps : optional
        Accelerations (all three, else only velocities).

    Returns
    -------
    RPPRates
        ``s1d, s2d, vQ``; ``s1dd, s2dd, aQ``; ``det = sin(alpha)``, ``singular``.

    Notes
    -----
    Vasechkin et al. 2017 eqs. (33)-(36) in vector form:
    ``s1d u + s2d w = vA - vP - ω perp(A-P)``;
    ``s1dd u + s2dd w = aA - aP - ε perp(A-P) + ω²(A-P) - 2ω(s1d perp(u) + s2d perp(w))``.
    """
    ax, ay = xy(A)
    qx, qy = xy(Q)
    px, py = xy(P)
    ux, uy = xy(u)
    wx, wy = _w(ux, uy, alpha)
    rx, ry = ax - px, ay - py
    rqx, rqy = qx - px, qy - py
    vax, vay = xy(vA)
    vpx, vpy = xy(vP)
    s1d, s2d, det = cramer(ux, uy, wx, wy, vax - vpx + omega * ry, vay - vpy - omega * rx)
    sing = is_singular(det, ux, uy, wx, wy)
    vQ = stack(vpx - omega * rqy + s1d * ux, vpy + omega * rqx + s1d * uy)
    s1dd = s2dd = aQ = None
    if aA is not None and aP is not None and eps is not None:
        aax, aay = xy(aA)
        apx, apy = xy(aP)
        o2 = np.square(omega)
        cx_ = s1d * uy + s2d * wy          # components of -perp(s1d u + s2d w)
        cy_ = s1d * ux + s2d * wx
        b1 = aax - apx + eps * ry + o2 * rx + 2.0 * omega * cx_
        b2 = aay - apy - eps * rx + o2 * ry - 2.0 * omega * cy_
        s1dd, s2dd, _ = cramer(ux, uy, wx, wy, b1, b2)
        k = 2.0 * omega * s1d
        aQ = stack(apx - eps * rqy - o2 * rqx - k * uy + s1dd * ux,
                   apy + eps * rqx - o2 * rqy + k * ux + s1dd * uy)
    return RPPRates(s1d, s2d, vQ, s1dd, s2dd, aQ, det, sing)


def rpp_place(ip, fp, X, W, F, T, C, S, PP, out) -> None:
    """RPP steps at every position for the compiled kernel (:mod:`kin.kernel`), as
    :meth:`RPPStep.positions` (Vasechkin et al. 2017, eqs. (30)-(32)).

    ``ip`` = (known1, the guide's link, link1, link2); ``fp`` = (A, Q relative to their
    links, u, cos α, sin α, h, link2's and link1's reference points relative to Q and A).
    """
    k1, kq, l1, l2 = ip[0], ip[1], ip[2], ip[3]
    a0, a1, q0, q1, v0, v1, ca, sa, h = fp[0], fp[1], fp[2], fp[3], fp[4], fp[5], fp[6], fp[7], fp[8]
    o2x, o2y, o1x, o1y = fp[9], fp[10], fp[11], fp[12]
    for n in range(X.shape[0]):
        ax, ay = carry(k1, n, T, C, S, a0, a1)
        px, py = carry(kq, n, T, C, S, q0, q1)
        ux, uy = turned(kq, n, C, S, v0, v1)
        wx, wy = ca * ux - sa * uy, sa * ux + ca * uy
        b1, b2 = ax - px + h * wy, ay - py - h * wx
        det = ux * wy - uy * wx
        ok = abs(det) > SINGULAR_RTOL * np.sqrt((ux * ux + uy * uy) * (wx * wx + wy * wy))
        s1 = (b1 * wy - b2 * wx) / det if ok else np.nan
        qx, qy = px + s1 * ux, py + s1 * uy
        ok = ok and np.isfinite(qx) and np.isfinite(qy)
        place_like(l2, kq, n, T, C, S, qx, qy, o2x, o2y, PP)
        place_like(l1, kq, n, T, C, S, ax, ay, o1x, o1y, PP)
        out[n] = 1 if not ok else (0 if abs(det) > PARALLEL_GUIDES else 2)
    PP[l1] = PP[l2] = PP[kq] = 0


def rpp_lower(q, P, U, O, size, out) -> None:
    """:meth:`RPPStep.lower` of D designs for the compiled kernel (the guides' angle by
    ``atan2``: NumPy's to an ulp). ``q`` = (rows of A, Q and the inner P joint; k1, kq,
    link1, link2)."""
    ia, iq, ii, k1, kq, l1, l2 = q[0], q[1], q[2], q[3], q[4], q[5], q[6]
    for d in range(P.shape[0]):
        ax, ay, qx, qy = P[d, ia, 0], P[d, ia, 1], P[d, iq, 0], P[d, iq, 1]
        ux, uy, wx, wy = U[d, iq, 0], U[d, iq, 1], U[d, ii, 0], U[d, ii, 1]
        alpha = np.arctan2(wy, wx) - np.arctan2(uy, ux)
        put_rel(out, d, 0, ax, ay, O, k1)
        put_rel(out, d, 2, qx, qy, O, kq)
        out[d, 4], out[d, 5], out[d, 6], out[d, 7] = ux, uy, np.cos(alpha), np.sin(alpha)
        out[d, 8] = -wy * (ax - qx) + wx * (ay - qy)
        put_off(out, d, 9, qx, qy, O, l2)
        put_off(out, d, 11, ax, ay, O, l1)


class RPPStep(GroupStep):
    """An RPP dyad of a plan: link1 pinned at outer1 and sliding in the block link2,
    which slides on the guide of the known link at outer2; compiled once."""

    kind = GroupKind.RPP
    compiled = staticmethod(rpp_place)
    compiled_lower = staticmethod(rpp_lower)
    singular_hint = GUIDES_HINT

    @classmethod
    def assembly_modes(cls, m, group) -> int:
        """One (linear: no reach limit, no angle to monitor)."""
        return 1

    def __init__(self, mechanism, st, size: float, geo=None):
        super().__init__(mechanism, st, size, geo)
        lay = self.layout = self.group.layout
        self.A, self.Q = (self.at(j) for j in (lay.outer1, lay.outer2))
        self.k1, self.kq = known_on(self.group, lay.outer1), known_on(self.group, lay.outer2)
        self.u = self.axis(lay.outer2)
        w = self.axis(lay.inner)
        self.alpha = num(angle_of(w) - angle_of(self.u))
        self.h = dot(normal(w), self.A - self.Q)

    def positions(self, G, X, factor=1.0, probe=False) -> Outcome:
        lay = self.layout
        A = G.point(self.k1, self.A)
        r = rpp_position(A, G.point(self.kq, self.Q), G.direction(self.kq, self.u), self.alpha, self.h)
        G.place_like(lay.link2, r.Q, self.Q, self.kq)
        G.place_like(lay.link1, A, self.A, self.kq)
        return dyad_outcome(r.ok, {}, r.det, 1.0, True, None, probe, G.explain)

    def lower(self, origins) -> Lowered | None:
        """Flat numbers of :func:`rpp_place`."""
        lay, o = self.layout, origins
        k1, kq, l1, l2 = (self.link_index(x) for x in (self.k1, self.kq, lay.link1, lay.link2))
        f = (*self.rel(o, k1, self.A), *self.rel(o, kq, self.Q), *pair(self.u),
             num(np.cos(self.alpha)), num(np.sin(self.alpha)), self.h,
             *self.off(o, l2, self.Q), *self.off(o, l1, self.A))
        return Lowered(GroupKind.RPP, (k1, kq, l1, l2), f)

    def lower_indices(self, row) -> tuple[int, ...]:
        lay = self.layout
        return (row(lay.outer1), row(lay.outer2), row(lay.inner),
                *(self.link_index(x) for x in (self.k1, self.kq, lay.link1, lay.link2)))

    def rates(self, R, input_rates) -> None:
        lay = self.layout
        A, vA, aA = R.point(self.k1, self.A)
        P, vP, aP = R.point(self.kq, self.Q)
        u, w, e = R.direction(self.kq, self.u)
        Q = R.point(lay.link2, self.Q)[0]
        r = rpp_rates(A, Q, P, u, self.alpha, vA, vP, w, aA, aP, e)
        R.set(lay.link2, Q, r.vQ, r.aQ, w, e)
        R.set(lay.link1, A, vA, aA, w, e)
