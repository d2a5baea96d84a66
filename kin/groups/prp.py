"""Kind 4 dyad (PRP): two sliders joined by a pin B, each sliding on a guide line
of a known link.  Linear: one solution, no branch.

Vasechkin et al. 2017 [1]_, figure 4, eqs. (23)-(29).  ``B = P1 + s1 u1 + h1 n(u1) = P2 + s2 u2
+ h2 n(u2)`` (seed: ``u1 = e(φ2)``, ``u2 = e(φ3)``, ``h1 = l2``, ``h2 = l3``,
``s1 = l1``, ``s2 = l4``).  Matrix columns ``c1 = u1``, ``c2 = -u2``;
``det = cross(u2, u1) = sin(φ2-φ3)``.

Seed misprints: the second right-hand sides of eqs. (25), (27), (29) lost their
signs; ours follow from the loop equation (docs/groups.md).

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

from .base import (put_off, put_rel, pair, SINGULAR_RTOL, carry, cramer, dot, is_singular, place_like, stack, turned,
                   xy, quiet)
from ..poses import known_on, normal
from .step import GUIDES_HINT, PARALLEL_GUIDES, GroupStep, Lowered, Outcome, dyad_outcome

__all__ = ["PRPPosition", "PRPRates", "prp_position", "prp_rates", "PRPStep", "prp_place"]


class PRPPosition(NamedTuple):
    """Result of :func:`prp_position`: ``B`` (..., 2), slides ``s1, s2``, ``ok``, ``det``."""

    B: np.ndarray
    s1: np.ndarray
    s2: np.ndarray
    ok: np.ndarray
    det: np.ndarray


class PRPRates(NamedTuple):
    """Result of :func:`prp_rates` (acceleration fields ``None`` unless asked)."""

    s1d: np.ndarray
    s2d: np.ndarray
    vB: np.ndarray
    s1dd: np.ndarray | None
    s2dd: np.ndarray | None
    aB: np.ndarray | None
    det: np.ndarray
    singular: np.ndarray


@quiet
def prp_position(P1, u1, h1, P2, u2, h2) -> PRPPosition:
    """Pin B of a PRP dyad: intersection of two offset guide lines, vectorised.

    Parameters
    ----------
    P1, u1, P2, u2 : array_like, shape (..., 2)
        Points and unit directions of the two guides (of known links).
    h1, h2 : float or array_like
        Offsets of B's tracks along ``n(u1)``, ``n(u2)``.

    Returns
    -------
    PRPPosition
        ``B``, ``s1``, ``s2``, ``ok`` (False for parallel guides, NaN there),
        ``det = cross(u2, u1)``.

    Notes
    -----
    Vasechkin et al. 2017 eqs. (23)-(25): ``s1 u1 - s2 u2 = P2 - P1 + h2 n(u2) - h1 n(u1)``.
    """
    p1x, p1y = xy(P1)
    u1x, u1y = xy(u1)
    p2x, p2y = xy(P2)
    u2x, u2y = xy(u2)
    q1x, q1y = p1x - h1 * u1y, p1y + h1 * u1x      # points of the two tracks
    q2x, q2y = p2x - h2 * u2y, p2y + h2 * u2x
    s1, s2, det = cramer(u1x, u1y, -u2x, -u2y, q2x - q1x, q2y - q1y)
    ok = ~is_singular(det, u1x, u1y, u2x, u2y)
    s1 = np.where(ok, s1, np.nan)
    s2 = np.where(ok, s2, np.nan)
    B = stack(q1x + s1 * u1x, q1y + s1 * u1y)
    return PRPPosition(B, s1, s2, ok & np.all(np.isfinite(B), axis=-1), det)


@quiet
def prp_rates(B, P1, u1, P2, u2, vP1, omega1, vP2, omega2,
              aP1=None, eps1=None, aP2=None, eps2=None) -> PRPRates:
    """Slide rates (and accelerations) of a PRP dyad and the motion of B.

    Parameters
    ----------
    B, P1, u1, P2, u2 : array_like, shape (..., 2)
        Positions (B from :func:`prp_position`).
    vP1, vP2 : array_like, shape (..., 2)
        Velocities of P1, P2 as points of their guide links.
    omega1, omega2 : float or array_like
        Angular velocities of the guide links.
    aP1, eps1, aP2, eps2 : optional
        Accelerations (all four, else only velocities).

    Returns
    -------
    PRPRates
        ``s1d, s2d, vB``; ``s1dd, s2dd, aB``; ``det = cross(u2, u1)``, ``singular``.

    Notes
    -----
    Vasechkin et al. 2017 eqs. (26)-(29):
    ``s1d u1 - s2d u2 = vP2 - vP1 + ω2 perp(B-P2) - ω1 perp(B-P1)``, and for the
    accelerations the difference of ``aPi + εi perp(B-Pi) - ωi²(B-Pi) + 2 ωi sid
    perp(ui)`` (i = 2 minus i = 1).
    """
    bx, by = xy(B)
    p1x, p1y = xy(P1)
    u1x, u1y = xy(u1)
    p2x, p2y = xy(P2)
    u2x, u2y = xy(u2)
    r1x, r1y = bx - p1x, by - p1y
    r2x, r2y = bx - p2x, by - p2y
    v1x, v1y = xy(vP1)
    v2x, v2y = xy(vP2)
    t1x, t1y = v1x - omega1 * r1y, v1y + omega1 * r1x   # guide-1 point at B
    t2x, t2y = v2x - omega2 * r2y, v2y + omega2 * r2x
    s1d, s2d, det = cramer(u1x, u1y, -u2x, -u2y, t2x - t1x, t2y - t1y)
    sing = is_singular(det, u1x, u1y, u2x, u2y)
    vB = stack(t1x + s1d * u1x, t1y + s1d * u1y)
    s1dd = s2dd = aB = None
    if aP1 is not None and eps1 is not None and aP2 is not None and eps2 is not None:
        a1x, a1y = xy(aP1)
        a2x, a2y = xy(aP2)
        o1s, o2s = np.square(omega1), np.square(omega2)
        k1, k2 = 2.0 * omega1 * s1d, 2.0 * omega2 * s2d
        g1x = a1x - eps1 * r1y - o1s * r1x - k1 * u1y
        g1y = a1y + eps1 * r1x - o1s * r1y + k1 * u1x
        g2x = a2x - eps2 * r2y - o2s * r2x - k2 * u2y
        g2y = a2y + eps2 * r2x - o2s * r2y + k2 * u2x
        s1dd, s2dd, _ = cramer(u1x, u1y, -u2x, -u2y, g2x - g1x, g2y - g1y)
        aB = stack(g1x + s1dd * u1x, g1y + s1dd * u1y)
    return PRPRates(s1d, s2d, vB, s1dd, s2dd, aB, det, sing)


def prp_place(ip, fp, X, W, F, T, C, S, PP, out) -> None:
    """PRP steps at every position for the compiled kernel (:mod:`kin.kernel`), as
    :meth:`PRPStep.positions` (Vasechkin et al. 2017, eqs. (23)-(25)).

    ``ip`` = (guide link 1, guide link 2, link1, link2); ``fp`` = (P1, u1, h1, P2, u2,
    h2 (points relative to their links), link1's and link2's reference points relative
    to B).
    """
    k1, k2, l1, l2 = ip[0], ip[1], ip[2], ip[3]
    p10, p11, v10, v11, h1, p20, p21, v20, v21, h2 = fp[0], fp[1], fp[2], fp[3], fp[4], fp[5], fp[6], fp[7], \
        fp[8], fp[9]
    o1x, o1y, o2x, o2y = fp[10], fp[11], fp[12], fp[13]
    for n in range(X.shape[0]):
        p1x, p1y = carry(k1, n, T, C, S, p10, p11)
        u1x, u1y = turned(k1, n, C, S, v10, v11)
        p2x, p2y = carry(k2, n, T, C, S, p20, p21)
        u2x, u2y = turned(k2, n, C, S, v20, v21)
        q1x, q1y = p1x - h1 * u1y, p1y + h1 * u1x
        bx, by = (p2x - h2 * u2y) - q1x, (p2y + h2 * u2x) - q1y
        det = u1x * -u2y - u1y * -u2x
        ok = abs(det) > SINGULAR_RTOL * np.sqrt((u1x * u1x + u1y * u1y) * (u2x * u2x + u2y * u2y))
        s1 = (bx * -u2y - by * -u2x) / det if ok else np.nan
        bx, by = q1x + s1 * u1x, q1y + s1 * u1y
        ok = ok and np.isfinite(bx) and np.isfinite(by)
        place_like(l1, k1, n, T, C, S, bx, by, o1x, o1y, PP)
        place_like(l2, k2, n, T, C, S, bx, by, o2x, o2y, PP)
        out[n] = 1 if not ok else (0 if abs(det) > PARALLEL_GUIDES else 2)
    PP[l1] = PP[l2] = PP[k1] = PP[k2] = 0


def prp_lower(q, P, U, O, size, out) -> None:
    """:meth:`PRPStep.lower` of D designs for the compiled kernel: the same floats.
    ``q`` = (rows of B, P1, P2; k1, k2, link1, link2)."""
    ib, i1, i2, k1, k2, l1, l2 = q[0], q[1], q[2], q[3], q[4], q[5], q[6]
    for d in range(P.shape[0]):
        bx, by = P[d, ib, 0], P[d, ib, 1]
        p1x, p1y, p2x, p2y = P[d, i1, 0], P[d, i1, 1], P[d, i2, 0], P[d, i2, 1]
        u1x, u1y, u2x, u2y = U[d, i1, 0], U[d, i1, 1], U[d, i2, 0], U[d, i2, 1]
        put_rel(out, d, 0, p1x, p1y, O, k1)
        out[d, 2], out[d, 3], out[d, 4] = u1x, u1y, -u1y * (bx - p1x) + u1x * (by - p1y)
        put_rel(out, d, 5, p2x, p2y, O, k2)
        out[d, 7], out[d, 8], out[d, 9] = u2x, u2y, -u2y * (bx - p2x) + u2x * (by - p2y)
        put_off(out, d, 10, bx, by, O, l1)
        put_off(out, d, 12, bx, by, O, l2)


class PRPStep(GroupStep):
    """A PRP dyad of a plan: two sliders pinned together at B, each on the guide of a
    known link; compiled once."""

    kind = GroupKind.PRP
    compiled = staticmethod(prp_place)
    compiled_lower = staticmethod(prp_lower)
    singular_hint = GUIDES_HINT

    @classmethod
    def assembly_modes(cls, m, group) -> int:
        """One (linear: no reach limit, no angle to monitor)."""
        return 1

    def __init__(self, mechanism, st, size: float, geo=None):
        super().__init__(mechanism, st, size, geo)
        lay = self.layout = self.group.layout
        at = self.at
        self.B, self.P1, self.P2 = at(lay.inner), at(lay.outer1), at(lay.outer2)
        self.k1, self.k2 = known_on(self.group, lay.outer1), known_on(self.group, lay.outer2)
        self.u1, self.u2 = self.axis(lay.outer1), self.axis(lay.outer2)
        self.h1 = dot(normal(self.u1), self.B - self.P1)
        self.h2 = dot(normal(self.u2), self.B - self.P2)

    def positions(self, G, X, factor=1.0, probe=False) -> Outcome:
        lay = self.layout
        r = prp_position(G.point(self.k1, self.P1), G.direction(self.k1, self.u1), self.h1,
                         G.point(self.k2, self.P2), G.direction(self.k2, self.u2), self.h2)
        G.place_like(lay.link1, r.B, self.B, self.k1)
        G.place_like(lay.link2, r.B, self.B, self.k2)
        return dyad_outcome(r.ok, {}, r.det, 1.0, True, None, probe, G.explain)

    def lower(self, origins) -> Lowered | None:
        """Flat numbers of :func:`prp_place`."""
        lay, o = self.layout, origins
        k1, k2, l1, l2 = (self.link_index(x) for x in (self.k1, self.k2, lay.link1, lay.link2))
        f = (*self.rel(o, k1, self.P1), *pair(self.u1), self.h1, *self.rel(o, k2, self.P2), *pair(self.u2),
             self.h2, *self.off(o, l1, self.B), *self.off(o, l2, self.B))
        return Lowered(GroupKind.PRP, (k1, k2, l1, l2), f)

    def lower_indices(self, row) -> tuple[int, ...]:
        lay = self.layout
        return (row(lay.inner), row(lay.outer1), row(lay.outer2),
                *(self.link_index(x) for x in (self.k1, self.k2, lay.link1, lay.link2)))

    def rates(self, R, input_rates) -> None:
        lay = self.layout
        P1, vP1, aP1 = R.point(self.k1, self.P1)
        P2, vP2, aP2 = R.point(self.k2, self.P2)
        u1, w1, e1 = R.direction(self.k1, self.u1)
        u2, w2, e2 = R.direction(self.k2, self.u2)
        B = R.point(lay.link1, self.B)[0]
        r = prp_rates(B, P1, u1, P2, u2, vP1, w1, vP2, w2, aP1, e1, aP2, e2)
        R.set(lay.link1, B, r.vB, r.aB, w1, e1)
        R.set(lay.link2, B, r.vB, r.aB, w2, e2)
