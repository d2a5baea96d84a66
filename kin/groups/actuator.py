"""A linear actuator as a bar of driven length: the RRR closed form with one driven side.

A hydraulic cylinder or screw jack is two links (barrel and rod) on a driven prismatic
pair, each pinned once more.  The drive ``u_a · (p_b − p_a) = s`` translates the rod by
``s u`` along the barrel's guide ``u``, so in the frame of the actuator's half ``near``
(on the known pin A) the vector to its other pin B is ``d(s) = d₀ + σ s u₀`` (``σ = +1``
when ``near`` is the barrel, −1 when it is the rod): a bar of length ``L(s) = |d(s)|``,
``L₀ + s`` for a guide along the pins.  The group (the actuator and the link C–B) is
then the triangle A–B–C of Vasechkin et al. 2017 [1]_, eqs. (1)-(3), with ``l₂ = L(s)``:
two assembly modes, O(1) per position by :func:`~kin.groups.rrr.rrr_xy`.

Rates: ``B − A = R(θ) d(s)`` gives ``v_B = v_A + σ ṡ u + ω perp(B − A)`` and
``a_B = a_A + 2 ω σ ṡ perp(u) + ε perp(B − A) − ω² (B − A)`` (zero input acceleration,
``u`` the guide in the world): the RRR rates of eqs. (4)-(8) of [1]_ with the pin A's
velocity and acceleration shifted by the slide's relative and Coriolis terms.

References
----------
.. [1] Vasechkin M.A., Matveeva E.V., Sidorenko A.S., Chertov E.D. Mathematical
   model of kinematic calculation of flat lever mechanisms. Vestnik VGUIT 79(2)
   (2017) 73-79. doi:10.20914/2310-1202-2017-2-73-79.
"""
from __future__ import annotations

import numpy as np

from ..continuation import Probe
from ..poses import columns, known_on, unit
from ..result import Status
from ..rigid import perp
from multiloop.topo.assur import GroupKind

from .base import branch_sign, put_off, put_rel, pair, carry, length, margin_tol, num, place, place_along
from .rrr import rrr_branch, rrr_rates, rrr_xy, triangle_apex
from .step import SINGULAR, AngleDef, GroupStep, Lowered, Outcome, dyad_outcome

__all__ = ["ActuatorStep", "actuator_place"]


def _length_curvature(r, v):
    """|d²|r|/dt²| for ``r`` moving with velocity ``v`` and no acceleration (N, 2)."""
    n = np.sqrt(np.sum(r * r, axis=-1))
    rv = np.sum(r * v, axis=-1)
    return np.abs(np.sum(v * v, axis=-1) - rv * rv / (n * n)) / n


def actuator_place(ip, fp, X, W, F, T, C, S, PP, out) -> None:
    """Actuated triangles at every position for the compiled kernel (:mod:`kin.kernel`),
    as :meth:`ActuatorStep.positions` (Vasechkin et al. 2017, eqs. (1)-(3) with the
    driven side ``L(s)``).

    ``ip`` = (driver, known1, known2, near, far, link2); ``fp`` = (σ, d₀, u₀, A and C
    relative to their links, lc, sign, near's, far's and link2's reference points
    relative to A, B and C, the unit reference direction of C–B).
    """
    d, k1, k3, kn, kf, k2 = ip[0], ip[1], ip[2], ip[3], ip[4], ip[5]
    sigma, d0, d1, u0, u1, a0, a1, c0, c1, lc, sign = fp[0], fp[1], fp[2], fp[3], fp[4], fp[5], fp[6], fp[7], \
        fp[8], fp[9], fp[10]
    onx, ony, ofx, ofy, o2x, o2y, ec, es = fp[11], fp[12], fp[13], fp[14], fp[15], fp[16], fp[17], fp[18]
    rows = F.size > 1
    for n in range(X.shape[0]):
        s = sigma * X[n, d]
        dx, dy = d0 + s * u0, d1 + s * u1
        L = np.sqrt(dx * dx + dy * dy)
        ax, ay = carry(k1, n, T, C, S, a0, a1)
        cx, cy = carry(k3, n, T, C, S, c0, c1)
        bx, by, ok, det, exact = triangle_apex(ax, ay, cx, cy, L, lc, sign * (F[n] if rows else F[0]))
        rx, ry = bx - ax, by - ay
        inv = 1.0 / (L * L)
        c, sn = (dx * rx + dy * ry) * inv, (dx * ry - dy * rx) * inv
        place(kn, n, T, C, S, ax, ay, onx, ony, c, sn)
        place(kf, n, T, C, S, bx, by, ofx, ofy, c, sn)
        place_along(k2, n, T, C, S, cx, cy, o2x, o2y, bx - cx, by - cy, ec, es)
        out[n] = 1 if not ok else (0 if abs(det) > SINGULAR * (L * lc) else 2)
    PP[kn] = PP[kf] = PP[k2] = 1


def actuator_lower(q, P, U, O, size, out) -> None:
    """:meth:`ActuatorStep.lower` of D designs for the compiled kernel: the same floats.
    ``q`` = (rows of A, B, C and the slide; known1, known2, near, far, link2; the slide's
    sense σ as ±1)."""
    ia, ib, ic, isl, k1, k3, kn, kf, k2 = q[0], q[1], q[2], q[3], q[4], q[5], q[6], q[7], q[8]
    for d in range(P.shape[0]):
        ax, ay, bx, by, cx, cy = P[d, ia, 0], P[d, ia, 1], P[d, ib, 0], P[d, ib, 1], P[d, ic, 0], P[d, ic, 1]
        lc = np.hypot(bx - cx, by - cy)
        d2x, d2y = (bx - cx) / lc, (by - cy) / lc
        h2 = np.hypot(d2x, d2y)
        out[d, 0], out[d, 1], out[d, 2] = float(q[9]), bx - ax, by - ay
        out[d, 3], out[d, 4] = U[d, isl, 0], U[d, isl, 1]
        put_rel(out, d, 5, ax, ay, O, k1)
        put_rel(out, d, 7, cx, cy, O, k3)
        out[d, 9] = lc
        out[d, 10] = branch_sign((cx - ax) * (by - ay) - (cy - ay) * (bx - ax),
                                 np.hypot(cx - ax, cy - ay) * np.hypot(bx - ax, by - ay))
        put_off(out, d, 11, ax, ay, O, kn)
        put_off(out, d, 13, bx, by, O, kf)
        put_off(out, d, 15, cx, cy, O, k2)
        out[d, 17], out[d, 18] = d2x / h2, d2y / h2


class ActuatorStep(GroupStep):
    """A triangle with a linear actuator as one side (:class:`~topo.assur.ActuatorLayout`),
    compiled once: the actuator's guide, the branch sign, the third side's length."""

    kind = GroupKind.ACTUATED
    compiled = staticmethod(actuator_place)
    compiled_lower = staticmethod(actuator_lower)

    @classmethod
    def assembly_modes(cls, m, group) -> int:
        """Two: a triangle with a reach limit (its two signs of the closed form)."""
        return 2

    @classmethod
    def monitored_angles(cls, m, group) -> tuple[AngleDef, ...]:
        """The transmission angle at the inner pin B of the triangle A-B-C: the angle
        between BA and BC (Vasechkin et al. 2017, kind 1);
        for a cylinder A-B, the angle between the actuator's axis and the lever C-B it drives."""
        lay = group.layout
        return (AngleDef(lay.inner, "transmission", (lay.outer1, lay.inner, lay.outer2)),)

    def __init__(self, mechanism, st, size: float, geo=None):
        super().__init__(mechanism, st, size, geo)
        lay = self.layout = self.group.layout
        self.known1, self.known2 = known_on(self.group, lay.outer1), known_on(self.group, lay.outer2)
        self.A, self.B, self.C = (self.at(j) for j in (lay.outer1, lay.inner, lay.outer2))
        jt = mechanism.joint(lay.slide)
        self.sigma = 1.0 if jt.links[0] == lay.near else -1.0     # near = barrel (guide host)
        self.u0 = self.axis(lay.slide)                           # the guide, in near's frame at the reference
        self.d0 = self.B - self.A
        self.lc = length(self.B - self.C)
        self.sign = num(rrr_branch(self.A, self.C, self.B, self.strict))
        self.dir2 = unit(self.B - self.C)
        self.kn, self.kf, self.k2 = (mechanism.link_names.index(x) for x in (lay.near, lay.far, lay.link2))
        self.k1, self.k3 = (mechanism.link_names.index(x) for x in (self.known1, self.known2))

    def _side(self, X):
        """The actuator side ``d(s)`` in near's reference frame (components) and its length."""
        s = self.sigma * X[..., self.layout.driver]
        dx = self.d0[..., 0] + s * self.u0[..., 0]
        dy = self.d0[..., 1] + s * self.u0[..., 1]
        return dx, dy, np.sqrt(dx * dx + dy * dy)

    def positions(self, G, X, factor=1.0, probe=False) -> Outcome:
        lc = self.lc
        dx, dy, L = self._side(X)
        ax, ay = G.point_xy(self.k1, self.A)
        cx, cy = G.point_xy(self.k3, self.C)
        bx, by, ok, det, _ = rrr_xy(ax, ay, cx, cy, L, lc, self.sign * factor)
        why, pr = {}, None
        if probe or (G.explain and not ok.all()):
            pr = self._probe(G, (ax, ay), (cx, cy), (bx, by), L, ok, why, probe)
        # the actuator's halves turn by the rotation taking d(s) to B − A (|d| = |B − A| = L)
        rx, ry = bx - ax, by - ay
        with np.errstate(divide="ignore"):      # L = 0: a cylinder of no length (failed row)
            inv = 1.0 / (L * L)
        c = (dx * rx + dy * ry) * inv
        s = (dx * ry - dy * rx) * inv
        G.place_k(self.kn, ax, ay, self.A, c, s)
        G.place_k(self.kf, bx, by, self.B, c, s)
        G.place_dir_xy(self.k2, cx, cy, self.C, bx - cx, by - cy, self.dir2)
        G.keep_point(self.kf, self.B, bx, by)
        G.keep_point(self.k2, self.B, bx, by)
        return dyad_outcome(ok, why, det, L * lc, False, pr, probe, G.explain)

    def lower(self, origins) -> Lowered | None:
        """Flat numbers of :func:`actuator_place`."""
        o = origins
        f = (self.sigma, *pair(self.d0), *pair(self.u0), *self.rel(o, self.k1, self.A),
             *self.rel(o, self.k3, self.C), self.lc, self.sign, *self.off(o, self.kn, self.A),
             *self.off(o, self.kf, self.B), *self.off(o, self.k2, self.C), *pair(unit(self.dir2)))
        return Lowered(GroupKind.ACTUATED, (self.layout.driver, self.k1, self.k3, self.kn, self.kf, self.k2), f)

    def _probe(self, G, a, c, b, L, ok, why: dict, probe: bool):
        """Reasons of the failed positions (into ``why``) and, when asked, the Probe: the
        margin in m, 1-Lipschitz in |C − A| and in L (the lip's two rows)."""
        lay, lc = self.layout, self.lc
        A, C, B = (columns(p, q, G.M) for p, q in (a, c, b))
        AC = C - A
        dd = np.sqrt(AC[:, 0] * AC[:, 0] + AC[:, 1] * AC[:, 1])
        for n in (np.flatnonzero(~ok) if G.explain else ()):
            if np.isfinite(dd[n]):
                rel = f"> {L[n]:.6g} + {lc:.6g}" if dd[n] > L[n] + lc else f"< |{L[n]:.6g} − {lc:.6g}|"
                why[int(n)] = (Status.OUT_OF_REACH, f"no assembly: |{lay.outer1}{lay.outer2}| = {dd[n]:.6g} "
                                                    f"{rel} (actuator {lay.slide}: out of reach)")
        if not probe:
            return None
        gap = 2.0 * np.abs(AC[:, 0] * (B[:, 1] - A[:, 1]) - AC[:, 1] * (B[:, 0] - A[:, 0])) / dd
        margin = np.minimum(L + lc - dd, dd - np.abs(L - lc))
        lip = np.stack([AC, np.stack([L, np.zeros_like(L)], axis=1)], axis=1)
        return Probe(ok.copy(), gap, np.stack([B, A, C], axis=1), margin=margin, lip=lip,
                     tol=margin_tol(A, C, L + lc))

    def _guide(self, R, input_rates):
        """σ ṡ u in the world (N, 2), from the near half's turn."""
        u = R.direction(self.layout.near, self.u0)[0]
        return self.sigma * float(input_rates[self.layout.driver]) * u

    def margin_curvature(self, R) -> np.ndarray:
        """A bound on |d²margin/dx²| along the motion of ``R``: |d''| + |L''| (the probe's
        margin is ``min(L + l₃ − d, d − |L − l₃|)`` with ``d = |C − A|``)."""
        A, vA, aA = R.point(self.known1, self.A)
        C, vC, aC = R.point(self.known2, self.C)
        r, v, a = C - A, vC - vA, aC - aA
        n = np.sqrt(np.sum(r * r, axis=-1))
        rv = np.sum(r * v, axis=-1)
        d2 = (np.sum(v * v, axis=-1) + np.sum(r * a, axis=-1)) / n - rv * rv / n ** 3
        B = R.point(self.layout.far, self.B)[0]
        g = self._guide(R, np.ones(len(self.mechanism.drivers)))
        return np.abs(d2) + _length_curvature(B - A, g)

    def lower_indices(self, row) -> tuple[int, ...]:
        lay = self.layout
        return (row(lay.outer1), row(lay.inner), row(lay.outer2), row(lay.slide),
                self.k1, self.k3, self.kn, self.kf, self.k2, int(self.sigma))

    def rates(self, R, input_rates) -> None:
        lay = self.layout
        A, vA, aA = R.point(self.known1, self.A)
        C, vC, aC = R.point(self.known2, self.C)
        B = R.point(lay.far, self.B)[0]
        g = self._guide(R, input_rates)
        vA1 = vA + g                                  # B − A = R(θ) d(s): the slide moves B
        r = rrr_rates(A, C, B, vA1, vC)
        if aA is not None:                            # Coriolis term of the slide
            r = rrr_rates(A, C, B, vA1, vC, aA + 2.0 * r.w2[:, None] * perp(g), aC)
        R.set(lay.near, A, vA, aA, r.w2, r.e2)
        R.set(lay.far, B, r.vB, r.aB, r.w2, r.e2)
        R.set(lay.link2, C, vC, aC, r.w3, r.e3)
