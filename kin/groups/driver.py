"""The closed form of a one-link driver step: a link turned about, or slid along, a
known link by its input.

Input ``x`` of driver k is the rotation (rad) of the driver joint's ``links[1]``
relative to ``links[0]`` from the reference, or the slide (m) for a P joint; the
unknown link is either of the two (the other is known).  Velocities follow by rigid
motion: ω = ω_base ± ẋ (R), and for a slide the relative velocity ±ẋ u plus the
Coriolis term 2 ω ẋ perp(u).
"""
from __future__ import annotations

import numpy as np

from ..continuation import Probe
from ..rigid import perp
from .base import pair, angle, carry, place, put_off, put_rel
from .step import GroupStep, Lowered, Outcome, trig_row

__all__ = ["DriverStepSolver", "is_closed_form", "turn_place", "slide_place", "turn_lower", "slide_lower"]


def is_closed_form(group) -> bool:
    """Whether a driver step is one pin with the drive (R) or one slider (P)."""
    cons = group.constraints
    drive = [c for c in cons if c.kind.startswith("drive")]
    pins = [c for c in cons if c.kind == "R"]
    sliders = [c for c in cons if c.kind == "P"]
    if len(drive) != 1:
        return False
    if drive[0].kind == "drive_R":
        return len(pins) == 1 and not sliders
    return len(sliders) == 1 and not pins and {drive[0].a, drive[0].b} == {sliders[0].a, sliders[0].b}


def turn_place(ip, fp, X, W, F, T, C, S, PP, out) -> None:
    """A turning driver at every position for the compiled kernel (:mod:`kin.kernel`).

    ``ip`` = (driver, the known link of the joint, the link carrying the pin, the driven
    link, whether the known link is the frame, the row of cos(sign × input) in ``W``);
    ``fp`` = (sign, the pin relative to its link's reference point, the driven link's
    reference point relative to the pin).  On the frame the angle is ``sign × input``
    and its cos and sin come from ``W``; else the known link's angle is added.
    """
    d, o, h, k, frame, r = ip[0], ip[1], ip[2], ip[3], ip[4] != 0, ip[5]
    sign, rx, ry, ox, oy = fp[0], fp[1], fp[2], fp[3], fp[4]
    for n in range(X.shape[0]):
        if frame:
            th = sign * X[n, d]
            c, s = W[r, n], W[r + 1, n]
        else:
            th = angle(o, n, T, C, S, PP) + sign * X[n, d]
            c, s = np.cos(th), np.sin(th)
        px, py = carry(h, n, T, C, S, rx, ry)
        place(k, n, T, C, S, px, py, ox, oy, c, s)
        T[k, 2, n] = th
        out[n] = 0 if np.isfinite(c) else 1
    PP[k] = 0
    if not frame:
        PP[o] = 0                         # its angle row computed above


def slide_place(ip, fp, X, W, F, T, C, S, PP, out) -> None:
    """A sliding driver at every position for the compiled kernel (:mod:`kin.kernel`).

    ``ip`` = (driver, the guide's link, the driven link); ``fp`` = (sign, the joint
    relative to the guide's reference point, the guide's direction, the driven link's
    reference point relative to the joint).  The driven link turns with the guide.
    """
    d, o, k = ip[0], ip[1], ip[2]
    sign, rx, ry, ux, uy, ox, oy = fp[0], fp[1], fp[2], fp[3], fp[4], fp[5], fp[6]
    for n in range(X.shape[0]):
        c, s = C[o, n], S[o, n]
        t = sign * X[n, d]
        px, py = carry(o, n, T, C, S, rx, ry)
        px, py = px + t * (c * ux - s * uy), py + t * (s * ux + c * uy)
        th = angle(o, n, T, C, S, PP)
        place(k, n, T, C, S, px, py, ox, oy, c, s)
        T[k, 2, n] = th
        out[n] = 0 if np.isfinite(c) else 1
    PP[k] = PP[o] = 0


def turn_lower(q, P, U, O, size, out) -> None:
    """:meth:`DriverStepSolver.lower` of a turning driver for D designs (the compiled
    kernel's lowering): ``q`` = (the pin's row, the link carrying it, the driven link,
    the sign)."""
    r, h, k = q[0], q[1], q[2]
    for d in range(P.shape[0]):
        out[d, 0] = float(q[3])
        put_rel(out, d, 1, P[d, r, 0], P[d, r, 1], O, h)
        put_off(out, d, 3, P[d, r, 0], P[d, r, 1], O, k)


def slide_lower(q, P, U, O, size, out) -> None:
    """:meth:`DriverStepSolver.lower` of a sliding driver for D designs: ``q`` = (the
    joint's row, the guide's link, the driven link, the sign)."""
    r, o, k = q[0], q[1], q[2]
    for d in range(P.shape[0]):
        out[d, 0] = float(q[3])
        put_rel(out, d, 1, P[d, r, 0], P[d, r, 1], O, o)
        out[d, 3], out[d, 4] = U[d, r, 0], U[d, r, 1]
        put_off(out, d, 5, P[d, r, 0], P[d, r, 1], O, k)


class DriverStepSolver(GroupStep):
    """A one-link driver step (see :func:`is_closed_form`), compiled once."""

    def __init__(self, mechanism, st, size: float, geo=None):
        super().__init__(mechanism, st, size, geo)
        cons = self.group.constraints
        self.link = lk = mechanism.link_names[st.unknown[0]]
        d = self.drive = next(c for c in cons if c.kind.startswith("drive"))
        self.other = d.a if d.b == lk else d.b        # the known link of the driver joint
        self.sign = 1.0 if d.b == lk else -1.0
        if d.kind == "drive_R":
            p = next(c for c in cons if c.kind == "R")
            self.host = p.a if p.b == lk else p.b      # the known link carrying the pin
            self.joint = p.joint
            self.r = self.at(p.joint)
            self.u = None
        else:
            self.joint, self.host = d.joint, self.other    # (the guide's link carries the joint)
            self.r, self.u = self.at(d.joint), self.axis(d.joint)
        self.compiled_lower = turn_lower if self.u is None else slide_lower

    def positions(self, G, X, factor=1.0, probe=False) -> Outcome:
        x = X[..., self.drive.driver]
        if self.u is None:
            ko = G.idx[self.other]
            th = (x if self.sign > 0 else -x) if ko == G.frame_k else G.angle(ko) + self.sign * x
            G.place_k(G.idx[self.link], *G.point_xy(G.idx[self.host], self.r), self.r, np.cos(th), np.sin(th), th)
        else:          # the unknown slider sits at +s on the known guide (or the guide at −s)
            k = G.idx[self.other]
            P = G.point(self.other, self.r) + (self.sign * x)[..., None] * G.direction(self.other, self.u)
            G.place_cs(self.link, P, self.r, G.c[k], G.s[k], G.angle(k))
        ok = G.finite([G.idx[self.link]])
        return Outcome(ok, {}, Probe(ok) if probe else None)

    def lower(self, origins) -> Lowered | None:
        """Flat numbers of :func:`turn_place` or :func:`slide_place`."""
        k, o = self.link_index(self.link), self.link_index(self.other)
        r = self.r
        if self.u is None:
            h = self.link_index(self.host)
            d, frame = self.drive.driver, o == self.link_index(self.mechanism.frame)
            return Lowered("drive_R", (d, o, h, k, int(frame), trig_row(d, self.sign)),
                           (self.sign, *self.rel(origins, h, r), *self.off(origins, k, r)),
                           ((d, self.sign),) if frame else ())
        return Lowered("drive_P", (self.drive.driver, o, k),
                       (self.sign, *self.rel(origins, o, r), *pair(self.u), *self.off(origins, k, r)))

    def lower_indices(self, row) -> tuple[int, ...]:
        return (row(self.joint), self.link_index(self.host), self.link_index(self.link), int(self.sign))

    def rates(self, R, input_rates) -> None:
        rate = input_rates[self.drive.driver]
        ko = R.idx[self.other]
        if self.u is None:
            P, vP, aP = R.point(self.host, self.r)
            R.set(self.link, P, vP, aP, R.Zd[:, ko, 2] + self.sign * rate,
                  None if R.Zdd is None else R.Zdd[:, ko, 2].copy())
            return
        P, vP, aP = R.point(self.other, self.r)      # the known link's point at the joint
        u, w, e = R.direction(self.other, self.u)
        Q = R.point(self.link, self.r)[0]              # the unknown link's point: Q = P ± s u
        rel = Q - P
        w2 = w[:, None]
        vQ = vP + w2 * perp(rel) + self.sign * rate * u
        aQ = None if aP is None else aP + e[:, None] * perp(rel) - w2 * w2 * rel + 2.0 * w2 * self.sign * rate * perp(u)
        R.set(self.link, Q, vQ, aQ, w, e)
