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
from .step import GroupStep, Outcome

__all__ = ["DriverStepSolver", "is_closed_form"]


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
            self.r = self.at(p.joint)
            self.u = None
        else:
            self.r, self.u = self.at(d.joint), self.axis(d.joint)

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

    def rates(self, R, input_rates) -> None:
        rate = input_rates[self.drive.driver]
        ko = R.idx[self.other]
        if self.u is None:
            P, vP, aP = R.point(self.host, self.r)
            R.set(self.link, P, vP, aP, R.Zd[:, ko, 2] + self.sign * rate, R.Zdd[:, ko, 2].copy())
            return
        P, vP, aP = R.point(self.other, self.r)      # the known link's point at the joint
        u, w, e = R.direction(self.other, self.u)
        Q = R.point(self.link, self.r)[0]              # the unknown link's point: Q = P ± s u
        rel = Q - P
        w2 = w[:, None]
        vQ = vP + w2 * perp(rel) + self.sign * rate * u
        aQ = aP + e[:, None] * perp(rel) - w2 * w2 * rel + 2.0 * w2 * self.sign * rate * perp(u)
        R.set(self.link, Q, vQ, aQ, w, e)
