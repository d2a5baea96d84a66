"""Kind 1 dyad (RRR): two binary links A–B and C–B on known pins A and C.

Vasechkin et al. 2017 [1]_, figure 1, eqs. (1)-(8).  Position by the law of cosines, velocity
and acceleration from one 2×2 system (Cramer) with the paper's matrix

    a11 = -l2 sinφ2, a12 = l3 sinφ3, a21 = l2 cosφ2, a22 = -l3 cosφ3,

i.e. columns ``c1 = perp(B-A)``, ``c2 = -perp(B-C)`` and
``det = l2 l3 sin(φ2-φ3) = cross(B-C, B-A)``.

Seed misprints (see ``docs/groups.md``): the printed ``B_y = A_y + B_x1 sinα -
B_y1 cosα`` must read ``+ B_y1 cosα``; the printed acceleration right-hand side
``b2 = a_Cy - a_Ay + a11 ω2² + a12 ω3²`` must read ``- a11 ω2² - a12 ω3²`` (the
printed one disagrees with finite differences; tested).

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

from .base import (branch_sign, put_off, put_rel, square_curvature, margin_tol, REACH_RTOL, carry, cramer, is_singular,
                   length, num, pair, place, scalar, sign_of, stack, xy, quiet)
from ..continuation import Probe
from ..poses import columns, known_on, unit
from ..result import Status
from .step import SINGULAR, AngleDef, GroupStep, Lowered, Outcome, dyad_outcome

__all__ = ["RRRPosition", "RRRRates", "rrr_position", "rrr_branch", "rrr_rates", "RRRStep", "rrr_place",
           "triangle_apex", "link_turn"]


class RRRPosition(NamedTuple):
    """Result of :func:`rrr_position`: ``B`` (..., 2), ``ok`` (...), ``det`` (...)."""

    B: np.ndarray
    ok: np.ndarray
    det: np.ndarray


class RRRRates(NamedTuple):
    """Result of :func:`rrr_rates` (acceleration fields ``None`` unless asked)."""

    w2: np.ndarray
    w3: np.ndarray
    vB: np.ndarray
    e2: np.ndarray | None
    e3: np.ndarray | None
    aB: np.ndarray | None
    det: np.ndarray
    singular: np.ndarray


@quiet
def rrr_position(A, C, l2, l3, sign=1.0) -> RRRPosition:
    """Position of the inner pin B of an RRR dyad, vectorised.

    Parameters
    ----------
    A, C : array_like, shape (..., 2)
        Outer pins (on known links).
    l2, l3 : float or array_like
        Lengths |AB| and |CB|.
    sign : {+1, -1} or array_like
        Assembly branch: +1 puts B to the left of directed A→C
        (``cross(C-A, B-A) > 0``, Vasechkin et al. 2017's "assembly No. 1"); read it from the
        reference configuration with :func:`rrr_branch`.

    Returns
    -------
    RRRPosition
        ``B`` (..., 2) (NaN where out of reach), ``ok`` (...) bool,
        ``det = cross(B-C, B-A)`` (... ) (``det < 0`` on branch +1).

    Notes
    -----
    Vasechkin et al. 2017 eqs. (1)-(3), written without trigonometry:
    ``t = (l2² + d² - l3²)/(2d²)``, ``k = sign·sqrt(l2²/d² - t²)``,
    ``B = A + t (C-A) + k perp(C-A)``.  A distance beyond reach by at most
    1e-12 (relative) is clamped to the tangent position.  O(1) per position.

    Examples
    --------
    >>> rrr_position([0., 0.], [2., 0.], 1.0, 1.0).B
    array([1., 0.])
    """
    ax, ay = xy(A)
    cx, cy = xy(C)
    bx, by, ok, det, _ = rrr_xy(ax, ay, cx, cy, l2, l3, sign)
    return RRRPosition(stack(bx, by), ok, det)


def rrr_xy(ax, ay, cx, cy, l2, l3, sign=1.0):
    """:func:`rrr_position` on components: ``bx, by, ok, det, exact``.

    ``exact`` is True when no position was clamped to the tangent, so that
    ``|B - A| = l2`` and ``|B - C| = l3`` hold to rounding (a caller may then divide
    by the lengths instead of normalising); else the mask of the unclamped positions.
    ``det = cross(B-C, B-A)`` is ``-k d²``
    (with ``B - A = t d + k perp(d)``, ``B - C = (t-1) d + k perp(d)``); a NaN pin or
    ``A = C`` gives ``ok = False``.
    """
    dx = cx - ax
    dy = cy - ay
    d2 = dx * dx + dy * dy
    l2s = np.square(l2)                      # (NumPy scalars: no ZeroDivisionError below)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d2
        r = l2s * inv                        # l2²/d², and t = (l2² + d² - l3²)/(2d²)
        t = 0.5 + (0.5 * (l2s - np.square(l3))) * inv
        q = r - t * t
        neg = q < 0.0
        if neg.any():                        # clamped to the tangent, or out of reach
            exact = ~neg
            ok = q >= -REACH_RTOL * r        # False where q is NaN (A = C, NaN pins)
            k = np.sqrt(np.maximum(q, 0.0)) * sign
            if not ok.all():
                k = np.where(ok, k, np.nan)
        else:                                # every position in reach (or NaN)
            exact = True
            k = np.sqrt(q)
            ok = k == k
            k = k * sign
    bx = ax + t * dx - k * dy
    by = ay + t * dy + k * dx
    return bx, by, ok, -(k * d2), exact


def rrr_branch(A, C, B, strict=True):
    """Assembly sign of an RRR dyad in a (reference) configuration.

    Returns ``sign(cross(C-A, B-A))`` as ±1 (float array of the batch shape).

    Raises
    ------
    SingularityError
        If A, B, C are collinear (relative tolerance 1e-8): the branch is undefined.
    """
    ax, ay = xy(A)
    cx, cy = xy(C)
    bx, by = xy(B)
    v = (cx - ax) * (by - ay) - (cy - ay) * (bx - ax)
    scale = np.hypot(cx - ax, cy - ay) * np.hypot(bx - ax, by - ay)
    return sign_of(v, scale, "RRR dyad reference", strict)


@quiet
def rrr_rates(A, C, B, vA, vC, aA=None, aC=None) -> RRRRates:
    """Angular velocities/accelerations of an RRR dyad and those of B.

    Parameters
    ----------
    A, C, B : array_like, shape (..., 2)
        Positions (B from :func:`rrr_position`).
    vA, vC : array_like, shape (..., 2)
        Velocities of the outer pins.
    aA, aC : array_like, shape (..., 2), optional
        Accelerations of the outer pins; if both given, accelerations are solved.

    Returns
    -------
    RRRRates
        ``w2, w3`` angular velocities of links A–B and C–B, ``vB``; ``e2, e3, aB``
        (or ``None``); ``det`` of the paper's matrix and the ``singular`` mask.

    Notes
    -----
    Vasechkin et al. 2017 eqs. (4)-(8), one matrix for both systems:
    ``w2 perp(B-A) - w3 perp(B-C) = vC - vA`` and
    ``e2 perp(B-A) - e3 perp(B-C) = aC - aA + w2²(B-A) - w3²(B-C)``.
    The seed prints the second component of the latter with ``+a11 ω2² + a12 ω3²``;
    the correct signs are ``-a11 ω2² - a12 ω3²``.
    """
    ax, ay = xy(A)
    cx, cy = xy(C)
    bx, by = xy(B)
    rax, ray = bx - ax, by - ay          # B - A = l2 e(φ2)
    rcx, rcy = bx - cx, by - cy          # B - C = l3 e(φ3)
    c1x, c1y = -ray, rax                 # a11, a21
    c2x, c2y = rcy, -rcx                 # a12, a22
    vax, vay = xy(vA)
    vcx, vcy = xy(vC)
    w2, w3, det = cramer(c1x, c1y, c2x, c2y, vcx - vax, vcy - vay)
    vB = stack(vax + w2 * c1x, vay + w2 * c1y)
    sing = is_singular(det, c1x, c1y, c2x, c2y)
    e2 = e3 = aB = None
    if aA is not None and aC is not None:
        aax, aay = xy(aA)
        acx, acy = xy(aC)
        w2s, w3s = w2 * w2, w3 * w3
        b1 = acx - aax + w2s * rax - w3s * rcx
        b2 = acy - aay + w2s * ray - w3s * rcy
        e2, e3, _ = cramer(c1x, c1y, c2x, c2y, b1, b2)
        aB = stack(aax + e2 * c1x - w2s * rax, aay + e2 * c1y - w2s * ray)
    return RRRRates(w2, w3, vB, e2, e3, aB, det, sing)


def _rotation(dx, dy, rot, d_ref, exact):
    """(c, s) of the rotation taking the reference direction to ``(dx, dy)``: by the
    compiled ``rot`` (direction / length) where ``exact``, else normalised, position by
    position (as :meth:`~kin.poses.Poses.place_rot` and ``place_dir_xy``)."""
    cr, sr = rot
    c, s = dx * cr + dy * sr, dy * cr - dx * sr
    at = np.nonzero(~exact)                      # the clamped positions only: normalised
    ex, ey = dx[at], dy[at]
    inv = 1.0 / np.sqrt(ex * ex + ey * ey)
    ux, uy = (np.broadcast_to(v, dx.shape)[at] for v in pair(unit(d_ref)))
    nx, ny = ex * inv, ey * inv
    c[at], s[at] = nx * ux + ny * uy, ny * ux - nx * uy
    return c, s


@scalar
def triangle_apex(ax, ay, cx, cy, l2, l3, sign):
    """:func:`rrr_xy` at one position (scalars, compiled by :mod:`kin.kernel`): ``bx, by,
    ok, det, exact``; the same operations in the same order, so the same floats."""
    dx = cx - ax
    dy = cy - ay
    d2 = dx * dx + dy * dy
    l2s = l2 * l2
    inv = 1.0 / d2
    r = l2s * inv
    t = 0.5 + (0.5 * (l2s - l3 * l3)) * inv
    q = r - t * t
    exact = not q < 0.0
    if exact:
        k = np.sqrt(q)
        ok = k == k
        k = k * sign
    else:
        ok = q >= -REACH_RTOL * r
        k = 0.0 * sign if ok else np.nan
    return ax + t * dx - k * dy, ay + t * dy + k * dx, ok, -(k * d2), exact


def rrr_place(ip, fp, X, W, F, T, C, S, PP, out) -> None:
    """RRR steps at every position for the compiled kernel (:mod:`kin.kernel`), as
    :meth:`RRRStep.positions` (Vasechkin et al. 2017, eqs. (1)-(3)): reads the known
    links' poses from the pose store ``T`` (n_links, 3, M), ``C``, ``S`` (n_links, M),
    writes its two links (their angles pending) and each position's
    :class:`~kin.result.Status` into ``out`` (0, out of reach, singular); ``F`` the
    branch factor (one, or one per position).

    ``ip`` = (known1, known2, link1, link2); ``fp`` = (A and C relative to their known
    links' reference points, la, lc, sign, rot1, rot2, unit B−A, unit B−C, link1's and
    link2's reference points relative to their placing points, from_B1, from_B2,
    singular threshold).
    """
    k1, k2, l1, l2 = ip[0], ip[1], ip[2], ip[3]
    a0, a1, c0, c1, la, lc, sign = fp[0], fp[1], fp[2], fp[3], fp[4], fp[5], fp[6]
    r1c, r1s, r2c, r2s, u1c, u1s, u2c, u2s = fp[7], fp[8], fp[9], fp[10], fp[11], fp[12], fp[13], fp[14]
    o1x, o1y, o2x, o2y, at_b1, at_b2, thr = fp[15], fp[16], fp[17], fp[18], fp[19] != 0.0, fp[20] != 0.0, fp[21]
    rows = F.size > 1
    for n in range(X.shape[0]):
        ax, ay = carry(k1, n, T, C, S, a0, a1)
        cx, cy = carry(k2, n, T, C, S, c0, c1)
        bx, by, ok, det, exact = triangle_apex(ax, ay, cx, cy, la, lc, sign * (F[n] if rows else F[0]))
        c, s = link_turn(bx - ax, by - ay, exact, r1c, r1s, u1c, u1s)
        place(l1, n, T, C, S, bx if at_b1 else ax, by if at_b1 else ay, o1x, o1y, c, s)
        c, s = link_turn(bx - cx, by - cy, exact, r2c, r2s, u2c, u2s)
        place(l2, n, T, C, S, bx if at_b2 else cx, by if at_b2 else cy, o2x, o2y, c, s)
        out[n] = 1 if not ok else (0 if abs(det) > thr else 2)
    PP[l1] = PP[l2] = 1


def rrr_lower(q, P, U, O, size, out) -> None:
    """:meth:`RRRStep.lower` of D designs for the compiled kernel: the same floats.
    ``q`` = (rows of A, B, C; known1, known2, link1, link2)."""
    ia, ib, ic, k1, k2, l1, l2 = q[0], q[1], q[2], q[3], q[4], q[5], q[6]
    D = P.shape[0]
    at_b1 = at_b2 = True                    # a link placed from B (its reference point is B in every design)
    for d in range(D):
        at_b1 = at_b1 and O[d, l1, 0] == P[d, ib, 0] and O[d, l1, 1] == P[d, ib, 1]
        at_b2 = at_b2 and O[d, l2, 0] == P[d, ib, 0] and O[d, l2, 1] == P[d, ib, 1]
    for d in range(D):
        ax, ay, bx, by, cx, cy = P[d, ia, 0], P[d, ia, 1], P[d, ib, 0], P[d, ib, 1], P[d, ic, 0], P[d, ic, 1]
        la, lc = np.hypot(bx - ax, by - ay), np.hypot(bx - cx, by - cy)
        sign = branch_sign((cx - ax) * (by - ay) - (cy - ay) * (bx - ax),
                           np.hypot(cx - ax, cy - ay) * np.hypot(bx - ax, by - ay))
        d1x, d1y = (bx - ax) / la, (by - ay) / la
        d2x, d2y = (bx - cx) / lc, (by - cy) / lc
        h1, h2 = np.hypot(d1x, d1y), np.hypot(d2x, d2y)
        put_rel(out, d, 0, ax, ay, O, k1)
        put_rel(out, d, 2, cx, cy, O, k2)
        out[d, 4], out[d, 5], out[d, 6] = la, lc, sign
        out[d, 7], out[d, 8], out[d, 9], out[d, 10] = d1x / la, d1y / la, d2x / lc, d2y / lc
        out[d, 11], out[d, 12], out[d, 13], out[d, 14] = d1x / h1, d1y / h1, d2x / h2, d2y / h2
        put_off(out, d, 15, bx if at_b1 else ax, by if at_b1 else ay, O, l1)
        put_off(out, d, 17, bx if at_b2 else cx, by if at_b2 else cy, O, l2)
        out[d, 19], out[d, 20], out[d, 21] = 1.0 if at_b1 else 0.0, 1.0 if at_b2 else 0.0, SINGULAR * (la * lc)


@scalar
def link_turn(dx, dy, exact, rc, rs, uc, us):
    """(c, s) of a link of known length whose side is ``(dx, dy)``: by the compiled
    rotation ``(rc, rs)`` (reference direction / length) where the length holds
    (``exact``), else normalised against the unit reference ``(uc, us)``
    (:func:`_rotation`)."""
    if exact:
        return dx * rc + dy * rs, dy * rc - dx * rs
    inv = 1.0 / np.sqrt(dx * dx + dy * dy)
    nx, ny = dx * inv, dy * inv
    return nx * uc + ny * us, ny * uc - nx * us


class RRRStep(GroupStep):
    """An RRR dyad of a plan: lengths, branch sign and reference directions compiled
    once; positions by :func:`rrr_position`, rates by :func:`rrr_rates`."""

    kind = GroupKind.RRR
    compiled = staticmethod(rrr_place)
    compiled_lower = staticmethod(rrr_lower)

    @classmethod
    def assembly_modes(cls, m, group) -> int:
        """Two: a triangle with a reach limit (its two signs of the closed form)."""
        return 2

    @classmethod
    def monitored_angles(cls, m, group) -> tuple[AngleDef, ...]:
        """The transmission angle at the inner pin B of the triangle A-B-C: the angle
        between BA and BC (Vasechkin et al. 2017, kind 1)."""
        lay = group.layout
        return (AngleDef(lay.inner, "transmission", (lay.outer1, lay.inner, lay.outer2)),)

    @classmethod
    def reference_margin(cls, m, group, at, axis) -> np.ndarray:
        """|sin| of the angle between the dyad's links at the reference."""
        o1, inner, o2, _, _ = group.layout
        u, w = at(inner) - at(o1), at(inner) - at(o2)
        r = np.abs(u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0])
        return r / (np.linalg.norm(u, axis=1) * np.linalg.norm(w, axis=1))

    def __init__(self, mechanism, st, size: float, geo=None):
        super().__init__(mechanism, st, size, geo)
        lay = self.layout = self.group.layout
        self.known1, self.known2 = known_on(self.group, lay.outer1), known_on(self.group, lay.outer2)
        self.A, self.B, self.C = (self.at(j) for j in (lay.outer1, lay.inner, lay.outer2))
        self.la, self.lc = length(self.B - self.A), length(self.B - self.C)
        self.sign = num(rrr_branch(self.A, self.C, self.B, self.strict))
        self.dir1, self.dir2 = unit(self.B - self.A), unit(self.B - self.C)
        self.rot1 = pair(self.dir1 / np.asarray(self.la)[..., None])
        self.rot2 = pair(self.dir2 / np.asarray(self.lc)[..., None])
        names = mechanism.link_names
        self.k1, self.k2, self.l1, self.l2 = (names.index(x) for x in (self.known1, self.known2, lay.link1, lay.link2))
        # a link whose reference point is B is placed from B
        origins = self.geo.origins()
        self.from_B1, self.from_B2 = (bool(np.all(origins[k] == self.B)) for k in (self.l1, self.l2))

    def positions(self, G, X, factor=1.0, probe=False) -> Outcome:
        lay, la, lc = self.layout, self.la, self.lc
        ax, ay = G.point_xy(self.k1, self.A)
        cx, cy = G.point_xy(self.k2, self.C)
        bx, by, ok, det, exact = rrr_xy(ax, ay, cx, cy, la, lc, self.sign * factor)
        why, pr = {}, None
        if probe or (G.explain and not ok.all()):
            A, C, B = (columns(u, v, G.M) for u, v in ((ax, ay), (cx, cy), (bx, by)))
            AC = C - A
            d = np.sqrt(AC[:, 0] * AC[:, 0] + AC[:, 1] * AC[:, 1])
        if probe:
            gap = 2.0 * np.abs(AC[:, 0] * (B[:, 1] - A[:, 1]) - AC[:, 1] * (B[:, 0] - A[:, 0])) / d
            # in squares (smooth where A meets C, the change point of a kite)
            d2 = d * d
            margin = np.minimum((la + lc) ** 2 - d2, d2 - (la - lc) ** 2)
            pr = Probe(ok.copy(), gap, np.stack([B, A, C], axis=1), margin=margin, lip=AC[:, None],
                       tol=margin_tol(A, C, la + lc, squared=True), lip_scale=d)
        for n in (np.flatnonzero(~ok) if G.explain else ()):
            if np.isfinite(d[n]):
                rel = f"> {la:.6g} + {lc:.6g}" if d[n] > la + lc else f"< |{la:.6g} − {lc:.6g}|"
                why[int(n)] = (Status.OUT_OF_REACH,
                               f"no assembly: |{lay.outer1}{lay.outer2}| = {d[n]:.6g} {rel} (out of reach)")
        at1 = (bx, by, self.B) if self.from_B1 else (ax, ay, self.A)
        at2 = (bx, by, self.B) if self.from_B2 else (cx, cy, self.C)
        if exact is True:                  # |B - A| = la, |B - C| = lc: no normalising
            G.place_rot(self.l1, *at1, bx - ax, by - ay, *self.rot1)
            G.place_rot(self.l2, *at2, bx - cx, by - cy, *self.rot2)
        else:                              # per position: clamped ones normalised
            G.place_k(self.l1, *at1, *_rotation(bx - ax, by - ay, self.rot1, self.dir1, exact))
            G.place_k(self.l2, *at2, *_rotation(bx - cx, by - cy, self.rot2, self.dir2, exact))
        G.keep_point(self.l1, self.B, bx, by)
        G.keep_point(self.l2, self.B, bx, by)
        return dyad_outcome(ok, why, det, la * lc, False, pr, probe, G.explain)

    def lower(self, origins) -> Lowered | None:
        """Flat numbers of :func:`rrr_place`."""
        o = origins
        at1, at2 = (self.B if self.from_B1 else self.A), (self.B if self.from_B2 else self.C)
        f = (*self.rel(o, self.k1, self.A), *self.rel(o, self.k2, self.C), self.la, self.lc, self.sign,
             *self.rot1, *self.rot2, *pair(unit(self.dir1)), *pair(unit(self.dir2)),
             *self.off(o, self.l1, at1), *self.off(o, self.l2, at2),
             float(self.from_B1), float(self.from_B2), SINGULAR * (self.la * self.lc))
        return Lowered(GroupKind.RRR, (self.k1, self.k2, self.l1, self.l2), f)

    def lower_indices(self, row) -> tuple[int, ...]:
        lay = self.layout
        return (row(lay.outer1), row(lay.inner), row(lay.outer2), self.k1, self.k2, self.l1, self.l2)

    def margin_curvature(self, R) -> np.ndarray:
        """|d²margin/dx²| along the motion of ``R`` (the reach margin of the probe is
        ±|C − A|² plus a constant)."""
        A, vA, aA = R.point(self.known1, self.A)
        C, vC, aC = R.point(self.known2, self.C)
        return square_curvature(C - A, vC - vA, aC - aA)

    def rates(self, R, input_rates) -> None:
        lay = self.layout
        A, vA, aA = R.point(self.known1, self.A)
        C, vC, aC = R.point(self.known2, self.C)
        r = rrr_rates(A, C, R.point(lay.link1, self.B)[0], vA, vC, aA, aC)
        R.set(lay.link1, A, vA, aA, r.w2, r.e2)
        R.set(lay.link2, C, vC, aC, r.w3, r.e3)
