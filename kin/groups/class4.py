"""Class IV order 2 group: two ternary links T1 (outer pin O1, inner joints J1,
J2) and T2 (outer pin O2, inner joints J3, J4) closed into a quadrilateral by
the binaries J1–J3 and J2–J4.

Both this group and the class III triad come from the 5-link Baranov truss
(docs/groups.md): seen from T1, the pair of known pins O1–O2
acts as a third binary link of length |O1O2|, T1's joints (J1, J2, O1) are the
triad's fixed anchors and T2 (J3, J4, O2) is its ternary.  So all modes come from
the triad's degree-6 polynomial (:func:`kin.groups.triad.triad_modes`), and are
then rotated into place by the direction of O1→O2.  Velocities and
accelerations come from one 2×2 system in (θ̇1, θ̇2) solved by Cramer's rule as
in Vasechkin et al. 2017 [1]_.

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

from .base import cramer, is_singular, num, put_off, put_rel, quiet
from .triad import MAX_MODES, _as_batch, _kernel, _rot, _track, _wrap, track_designs, triad_modes
from ..continuation import Probe
from ..kernel_mode import chooses
from ..poses import known_on
from ..result import Status
from .newton import jacobian_rates
from .step import Deferred, GroupStep, Lowered, Outcome
from .triad import TRACK_STATUS

__all__ = ["Class4Modes", "Class4Track", "Class4Rates", "class4_modes",
           "class4_track", "class4_rates", "class4_points", "Class4Step"]


class Class4Modes(NamedTuple):
    """All real modes: ``J`` (N, 6, 4, 2), ``theta`` (N, 6, 2), ``n_modes`` (N,),
    ``residual`` (N, 6), ``det`` (N, 6); NaN-padded."""

    J: np.ndarray
    theta: np.ndarray
    n_modes: np.ndarray
    residual: np.ndarray
    det: np.ndarray


class Class4Track(NamedTuple):
    """One mode followed along the batch: ``J`` (N, 4, 2), ``theta`` (N, 2),
    ``ok``, ``det``, ``status`` (as :class:`kin.groups.triad.TriadTrack`)."""

    J: np.ndarray
    theta: np.ndarray
    ok: np.ndarray
    det: np.ndarray
    status: np.ndarray


class Class4Rates(NamedTuple):
    """Rates of the class IV group (acceleration fields ``None`` unless asked)."""

    omega: np.ndarray
    vJ: np.ndarray
    eps: np.ndarray | None
    aJ: np.ndarray | None
    w_bin: np.ndarray
    e_bin: np.ndarray | None
    det: np.ndarray
    singular: np.ndarray


def class4_points(O, r, theta):
    """Joints J1..J4 ``(..., 4, 2)`` from outer pins ``O`` (..., 2, 2), local
    vectors ``r`` (4, 2) and rotations ``theta`` (..., 2)."""
    O = np.asarray(O, dtype=float)
    r = np.asarray(r, dtype=float)
    theta = np.asarray(theta, dtype=float)
    c, s = np.cos(theta), np.sin(theta)
    J12 = O[..., :1, :] + _rot(c[..., 0, None], s[..., 0, None], r[..., :2, :])
    J34 = O[..., 1:, :] + _rot(c[..., 1, None], s[..., 1, None], r[..., 2:, :])
    return np.concatenate([J12, J34], axis=-2)


def _residual(J, m):
    d = np.linalg.norm(J[..., 2:, :] - J[..., :2, :], axis=-1)
    return np.max(np.abs(d - m), axis=-1) / np.max(m)


@quiet
def _triad_reduction(O: np.ndarray, r: np.ndarray, m: np.ndarray):
    """The class IV group seen as a triad in T1's frame: the frame pivots O1O2 become a
    third binary of length |O1O2|.  Returns (e = O2 − O1, L = |e|, anchors (N, 3, 2),
    b (3, 2), lengths (N, 3))."""
    N = O.shape[0]
    e = O[:, 1] - O[:, 0]
    L = np.hypot(e[:, 0], e[:, 1])
    anchors = np.broadcast_to(np.stack([r[0], r[1], np.zeros(2)]), (N, 3, 2))
    b = np.stack([r[2], r[3], np.zeros(2)])
    ll = np.stack([np.full(N, m[0]), np.full(N, m[1]), L], axis=-1)
    return e, L, anchors, b, ll


def class4_modes(O, r, m) -> Class4Modes:
    """All real assembly modes of a class IV order 2 group, vectorised.

    Parameters
    ----------
    O : array_like, shape (N, 2, 2) or (2, 2)
        Outer pins O1 (of T1) and O2 (of T2).
    r : array_like, shape (4, 2)
        ``J1 - O1``, ``J2 - O1``, ``J3 - O2``, ``J4 - O2`` in the reference.
    m : array_like, shape (2,)
        Lengths |J1J3| and |J2J4|.

    Returns
    -------
    Class4Modes
        ``J`` (N, 6, 4, 2), ``theta`` (N, 6, 2) rotations of T1, T2 from the
        reference, ``n_modes``, ``residual`` (max relative length error),
        ``det`` (N, 6) of the 2×2 rate system.  NaN-padded, at most 6 modes.
    """
    O, single = _as_batch(O, (2, 2))
    r = np.asarray(r, dtype=float)
    m = np.asarray(m, dtype=float)
    N = O.shape[0]
    e, L, anchors, b, ll = _triad_reduction(O, r, m)
    t = triad_modes(anchors, b, ll)
    O2l = t.P[..., 2, :]                                  # O2 in T1's frame
    th1 = np.arctan2(e[:, None, 1], e[:, None, 0]) - np.arctan2(O2l[..., 1], O2l[..., 0])
    th1 = _wrap(th1)
    th2 = _wrap(th1 + t.theta)
    theta = np.stack([th1, th2], axis=-1)
    J = class4_points(O[:, None], r, theta)
    res = np.where(np.isfinite(t.theta), np.maximum(_residual(J, m), t.residual), np.nan)
    rt = class4_rates(np.repeat(O[:, None], MAX_MODES, 1).reshape(-1, 2, 2),
                      np.nan_to_num(J).reshape(-1, 4, 2), np.zeros((N * MAX_MODES, 2, 2)))
    det = np.where(np.isfinite(t.theta), rt.det.reshape(N, MAX_MODES), np.nan)
    out = Class4Modes(J, theta, t.n_modes, res, det)
    return Class4Modes(*(v[0] for v in out)) if single else out


@quiet
def class4_rates(O, J, vO, aO=None) -> Class4Rates:
    """Angular velocities (and accelerations) of T1, T2 from one 2×2 system.

    Parameters
    ----------
    O : array_like, shape (N, 2, 2) or (2, 2)
        Outer pins; ``J`` (N, 4, 2) the joints of a solved mode.
    vO, aO : array_like, shape like ``O``
        Velocities (and optional accelerations) of the outer pins.

    Returns
    -------
    Class4Rates
        ``omega`` (N, 2), ``vJ`` (N, 4, 2), ``eps``, ``aJ``; ``w_bin`` / ``e_bin``
        (N, 2) of the binaries J1→J3 and J2→J4; ``det``, ``singular``.

    Notes
    -----
    With ``g_k = J_k - O_(k)`` and ``e = J1 - J3``, ``f = J2 - J4``:
    ``θ̇1 e·perp(g1) - θ̇2 e·perp(g3) = e·(Ȯ2 - Ȯ1)`` and the same with
    ``(f, g2, g4)``; accelerations: same matrix, right-hand side
    ``e·(Ö2 - Ö1 + θ̇1² g1 - θ̇2² g3) - |ė|²``.
    """
    O, single = _as_batch(O, (2, 2))
    J = np.asarray(J, dtype=float).reshape(O.shape[:-2] + (4, 2))
    vO = np.asarray(vO, dtype=float).reshape(O.shape)
    g = J - np.repeat(O, 2, axis=-2)                      # g1, g2 (O1) g3, g4 (O2)
    pg = np.stack([-g[..., 1], g[..., 0]], axis=-1)
    e = J[..., :2, :] - J[..., 2:, :]                     # (e, f)
    dot = lambda a, c: a[..., 0] * c[..., 0] + a[..., 1] * c[..., 1]  # noqa: E731
    c1 = dot(e, pg[..., :2, :])                           # (N, 2) rows
    c2 = -dot(e, pg[..., 2:, :])
    dv = vO[..., 1, :] - vO[..., 0, :]
    bv = dot(e, dv[..., None, :])
    w1, w2, det = cramer(c1[..., 0], c1[..., 1], c2[..., 0], c2[..., 1], bv[..., 0], bv[..., 1])
    omega = np.stack([w1, w2], axis=-1)
    wk = np.repeat(omega, 2, axis=-1)[..., None]
    vJ = np.repeat(vO, 2, axis=-2) + wk * pg
    de = vJ[..., :2, :] - vJ[..., 2:, :]
    ee = dot(e, e)
    w_bin = (e[..., 0] * de[..., 1] - e[..., 1] * de[..., 0]) / ee
    sing = is_singular(det, c1[..., 0], c1[..., 1], c2[..., 0], c2[..., 1])
    eps = aJ = e_bin = None
    if aO is not None:
        aO = np.asarray(aO, dtype=float).reshape(O.shape)
        base = np.repeat(aO, 2, axis=-2) - wk ** 2 * g   # J-acceleration without ε
        ba = -dot(e, base[..., :2, :] - base[..., 2:, :]) - dot(de, de)
        e1, e2, _ = cramer(c1[..., 0], c1[..., 1], c2[..., 0], c2[..., 1], ba[..., 0], ba[..., 1])
        eps = np.stack([e1, e2], axis=-1)
        aJ = base + np.repeat(eps, 2, axis=-1)[..., None] * pg
        dd = aJ[..., :2, :] - aJ[..., 2:, :]
        e_bin = (e[..., 0] * dd[..., 1] - e[..., 1] * dd[..., 0]) / ee
    out = Class4Rates(omega, vJ, eps, aJ, w_bin, e_bin, det, sing)
    if single:
        out = Class4Rates(*(None if v is None else v[0] for v in out))
    return out


@quiet
def class4_track(O, r, m, start, *, stride=32, jit=False) -> Class4Track:
    """Follow one assembly mode of a class IV group along a batch of positions.

    Parameters
    ----------
    O : array_like, shape (N, 2, 2)
        Outer pins along the motion.
    r, m : as in :func:`class4_modes`.
    start : array_like, shape (2,)
        Rotations (θ1, θ2) near the wanted mode at ``O[0]`` (``(0, 0)`` = the
        reference configuration).
    stride, jit : optional
        As in :func:`kin.groups.triad.triad_track`.

    Returns
    -------
    Class4Track
        ``J`` (N, 4, 2), ``theta`` (N, 2), ``ok``, ``det``, ``status``
        (0 ok, 1 no assembly, 2 lost/ambiguous here, 3 after a loss).

    Notes
    -----
    The group is tracked as its triad reduction (T1's frame, third binary of
    length |O1O2| whose rate enters the predictor), with the same guards as
    :func:`kin.groups.triad.triad_track`: never a silent mode switch.
    """
    O = np.asarray(O, dtype=float)
    r = np.asarray(r, dtype=float)
    m = np.asarray(m, dtype=float)
    N = O.shape[0]
    e, L, anchors, b, ll = _triad_reduction(O, r, m)
    th0 = np.asarray(start, dtype=float)
    J0 = class4_points(O[0], r, th0)
    loc = np.stack([J0[2], J0[3], O[0, 1]]) - O[0, 0]
    c, s_ = np.cos(-th0[0]), np.sin(-th0[0])
    loc = _rot(c, s_, loc)
    P, phi, status = _track(np.ascontiguousarray(anchors), b, ll, loc, stride, _kernel() if jit else None)
    ok = status == 0
    th1 = _wrap(np.arctan2(e[:, 1], e[:, 0]) - np.arctan2(P[:, 2, 1], P[:, 2, 0]))
    theta = np.stack([th1, _wrap(th1 + phi)], axis=-1)
    theta[~ok] = np.nan
    J = class4_points(O, r, theta)
    det = np.full(N, np.nan)
    if ok.any():
        det[ok] = class4_rates(O[ok], J[ok], np.zeros_like(O[ok])).det
    return Class4Track(J, theta, ok, det, status)


def class4_lower(q, P, U, O, size, out) -> None:
    """:meth:`Class4Step.lower` of D designs for the compiled kernel: the same floats.
    ``q`` = (rows of O1, O2, J1..J4; the known links of O1, O2, the ternaries 1, 2, the
    binaries 1, 2)."""
    for d in range(P.shape[0]):
        o1x, o1y, o2x, o2y = P[d, q[0], 0], P[d, q[0], 1], P[d, q[1], 0], P[d, q[1], 1]
        put_rel(out, d, 0, o1x, o1y, O, q[6])
        put_rel(out, d, 2, o2x, o2y, O, q[7])
        for k in range(4):
            jx, jy = P[d, q[2 + k], 0], P[d, q[2 + k], 1]
            out[d, 4 + 2 * k], out[d, 5 + 2 * k] = (jx - o1x, jy - o1y) if k < 2 else (jx - o2x, jy - o2y)
        out[d, 14], out[d, 15] = o1x, o1y
        put_off(out, d, 16, o1x, o1y, O, q[8])
        put_off(out, d, 18, o2x, o2y, O, q[9])
        for i in range(2):
            ax, ay, bx, by = P[d, q[2 + i], 0], P[d, q[2 + i], 1], P[d, q[4 + i], 0], P[d, q[4 + i], 1]
            h = np.hypot(bx - ax, by - ay)
            out[d, 12 + i] = h
            put_off(out, d, 20 + 2 * i, ax, ay, O, q[10 + i])
            out[d, 24 + 2 * i], out[d, 25 + 2 * i] = (bx - ax) / h, (by - ay) / h


class Class4Step(GroupStep):
    """A class IV order-2 group of a plan, tracked in the mode of the reference
    (:func:`class4_track`); rates from the group's Jacobian.  Batches of designs run
    its tracker compiled, each design along its own inputs
    (:func:`kin.groups._triad_nb.class4_place`)."""

    solver = "class4"

    kind = GroupKind.CLASS_IV
    compiled = Deferred(f"{__package__}._triad_nb", "class4_place")
    compiled_lower = staticmethod(class4_lower)
    tracked = True

    @classmethod
    def assembly_modes(cls, m, group) -> int:
        """The real assembly modes at the reference (all-modes kernel, Hunt 1983)."""
        at, lay = {j.name: np.asarray(j.at, float) for j in m.joints}, group.layout
        O = np.array([at[lay.outer1], at[lay.outer2]])
        J = np.array([at[j] for j in (lay.j11, lay.j12, lay.j21, lay.j22)])
        r = J - O[[0, 0, 1, 1]]
        ll = np.array([np.hypot(*(J[2] - J[0])), np.hypot(*(J[3] - J[1]))])
        return int(class4_modes(O, r, ll).n_modes)

    def __init__(self, mechanism, st, size: float, geo=None):
        super().__init__(mechanism, st, size, geo)
        lay = self.layout = self.group.layout
        at = self.at
        self.O = np.stack([at(lay.outer1), at(lay.outer2)], axis=-2)     # (2, 2), or (D, 1, 2, 2)
        self.J = np.stack([at(j) for j in (lay.j11, lay.j12, lay.j21, lay.j22)], axis=-2)
        self.r = self.J - self.O[..., [0, 0, 1, 1], :]
        v = self.J[..., 2:, :] - self.J[..., :2, :]
        self.lengths = np.hypot(v[..., 0], v[..., 1])
        self.known = (known_on(self.group, lay.outer1), known_on(self.group, lay.outer2))

    def positions(self, G, X, factor=1.0, probe=False) -> Outcome:
        if not G.reasons:
            return self._designs(G)
        N, Oref = G.M, self.O
        O = np.stack([G.point(self.known[0], Oref[0]), G.point(self.known[1], Oref[1])], axis=1)
        good = np.all(np.isfinite(O.reshape(N, -1)), axis=1)
        J, th, ok = np.full((N, 4, 2), np.nan), np.full((N, 2), np.nan), np.zeros(N, bool)
        why: dict[int, tuple] = {}
        if good.any():
            idx = np.flatnonzero(good)
            o = Oref[0]                      # solved about the reference pivot: translation-invariant
            res = class4_track(O[idx] - o, self.r, self.lengths, np.zeros(2), jit=chooses(N))
            J[idx], th[idx], ok[idx] = res.J + o, res.theta, res.ok
            for k in np.flatnonzero(~res.ok):
                why[int(idx[k])] = TRACK_STATUS.get(int(res.status[k]), (Status.MODE_LOST, "class IV mode lost"))
        self._place(G, O, J, th)
        return Outcome(ok, why, Probe(ok.copy()) if probe else None)

    def _place(self, G, O, J, th) -> None:
        lay, Oref, Jref = self.layout, self.O, self.J
        for i, t in enumerate((lay.ternary1, lay.ternary2)):
            G.place_cs(t, O[..., i, :], Oref[..., i, :], np.cos(th[..., i]), np.sin(th[..., i]), th[..., i])
        for b, i, j in ((lay.binary1, 0, 2), (lay.binary2, 1, 3)):
            G.place_dir(b, J[..., i, :], Jref[..., i, :], J[..., j, :] - J[..., i, :], Jref[..., j, :] - Jref[..., i, :])

    def _designs(self, G) -> Outcome:
        """D designs at N inputs: the triad reduction of :func:`class4_track` tracked for all
        designs at once (:func:`~kin.groups.triad.track_designs`), as alone."""
        Oref, r = self.O, self.r
        O = np.stack([G.point(k, Oref[..., i, :]) for i, k in enumerate(self.known)], axis=-2)   # (D, N, 2, 2)
        o = Oref[:, :, :1]                   # (D, 1, 1, 2): about the reference pivot, as alone
        Od = O - o
        e = Od[..., 1, :] - Od[..., 0, :]
        L = np.hypot(e[..., 0], e[..., 1])
        Dn, N = L.shape
        if N == 0:                           # (no input: nothing to follow)
            return Outcome(np.zeros((Dn, 0), bool), {}, None)
        zero = np.zeros((Dn, 1, 2))
        anchors = np.broadcast_to(np.stack([r[:, 0, 0], r[:, 0, 1], zero[:, 0]], axis=1)[:, None], (Dn, N, 3, 2))
        b = np.stack([r[:, 0, 2], r[:, 0, 3], zero[:, 0]], axis=1)
        m = self.lengths[:, 0]
        ll = np.stack([np.broadcast_to(m[:, :1], (Dn, N)), np.broadcast_to(m[:, 1:], (Dn, N)), L], axis=-1)
        J0 = class4_points(Od[:, 0], r[:, 0], np.zeros((Dn, 2)))
        loc = np.stack([J0[:, 2], J0[:, 3], Od[:, 0, 1]], axis=1) - Od[:, 0, :1]
        P, phi, status = track_designs(np.ascontiguousarray(anchors), b, ll, _rot(1.0, 0.0, loc), jit=self.jit)
        ok = status == 0
        th1 = _wrap(np.arctan2(e[..., 1], e[..., 0]) - np.arctan2(P[..., 2, 1], P[..., 2, 0]))
        theta = np.stack([th1, _wrap(th1 + phi)], axis=-1)
        theta[~ok] = np.nan
        J = class4_points(Od, r, theta) + o
        self._place(G, O, J, theta)
        return Outcome(ok, {}, None)

    rates = jacobian_rates

    def lower(self, origins) -> Lowered | None:
        """Flat numbers of :func:`kin.groups._triad_nb.class4_place` (:func:`class4_lower`'s
        layout): O1 and O2 relative to their known links, ``r`` (J1 − O1, J2 − O1,
        J3 − O2, J4 − O2), the binaries' lengths, O1 (the tracker's origin), each
        ternary's reference point from its outer pin, each binary's from J1 or J2, and
        the binaries' unit directions."""
        o, lay, Oref, J = origins, self.layout, self.O, self.J
        v = J[..., 2:, :] - J[..., :2, :]
        u = v / self.lengths[..., None]
        f = [*self.rel(o, self.link_index(self.known[0]), Oref[..., 0, :]),
             *self.rel(o, self.link_index(self.known[1]), Oref[..., 1, :]),
             *(num(x) for k in range(4) for x in (self.r[..., k, 0], self.r[..., k, 1])),
             *(num(self.lengths[..., i]) for i in range(2)), num(Oref[..., 0, 0]), num(Oref[..., 0, 1]),
             *self.off(o, self.link_index(lay.ternary1), Oref[..., 0, :]),
             *self.off(o, self.link_index(lay.ternary2), Oref[..., 1, :]),
             *self.off(o, self.link_index(lay.binary1), J[..., 0, :]),
             *self.off(o, self.link_index(lay.binary2), J[..., 1, :]),
             *(num(x) for i in range(2) for x in (u[..., i, 0], u[..., i, 1]))]
        return Lowered(self.kind, self._links(), tuple(f))

    def lower_indices(self, row) -> tuple[int, ...]:
        lay = self.layout
        return (*(row(j) for j in (lay.outer1, lay.outer2, lay.j11, lay.j12, lay.j21, lay.j22)), *self._links())

    def _links(self) -> tuple[int, ...]:
        """The links the compiled step reads and places: O1's and O2's known links, the
        ternaries, the binaries."""
        lay = self.layout
        return tuple(self.link_index(k) for k in (*self.known, lay.ternary1, lay.ternary2, lay.binary1, lay.binary2))
