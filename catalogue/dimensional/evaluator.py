"""A mechanism's Assur plan compiled once into a batched, parameterised evaluator.

The design variables are the reference coordinates of every R joint (frame
pivots included), the guide angle of every prismatic joint, and the tracer
points asked for; every link length, offset and pivot of the mechanism follows
from them.  :meth:`Evaluator.poses` solves a whole population ×
positions in one vectorised pass over the plan: each dyad is one call of its
closed-form kernel of :mod:`multiloop.kin.groups` (Vasechkin et al. 2017,
eqs. 1-18) with the dimensions as arrays of shape ``(population, 1)``; a triad
is one call of the triad tracker per candidate (vectorised over positions).
Plans with other groups (PRP, RPP, class IV, larger groups) take a slow path:
:func:`multiloop.kin.solve.solve` once per candidate.

Link poses are kept as maps from reference coordinates to the plane,
``world = R(θ) r + t``, so a candidate's reference configuration is its own
identity pose.  Every dyad keeps the assembly branch of its reference
configuration (sign read per candidate), so a motion that stays assembled never
changes branch.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from multiloop.topo.assur import AssurGroup, DriverStep, GroupKind, decompose
from multiloop.topo.errors import InputError, explain
from multiloop.topo.model import JointKind, Mechanism

__all__ = ["DesignSpace", "Evaluator", "Poses", "design_space", "four_bar_roles"]

_CLOSED = (GroupKind.RRR, GroupKind.RRP, GroupKind.RPR)


@dataclass(frozen=True)
class DesignSpace:
    """Names, start values and bounds of the design variables.

    ``names`` are ``"J.x"``, ``"J.y"`` for an R joint or tracer point and
    ``"J.angle"`` (rad) for the guide direction of a P joint.  A P joint's point
    is not a variable: the slider's track runs through the slider's own joints
    parallel to the guide, so moving the joint's reference point along the guide's
    normal changes no motion (a variable that never reaches the solver).
    """

    names: tuple[str, ...]
    x0: np.ndarray
    lower: np.ndarray
    upper: np.ndarray

    @property
    def size(self) -> int:
        return len(self.names)

    def index(self, name: str) -> int:
        return self.names.index(name)


def design_space(m: Mechanism, points=(), *, margin: float = 1.0, region=None,
                 bounds: dict | None = None) -> DesignSpace:
    """Every joint coordinate, P-joint guide and the given tracer points of ``m``.

    Bounds: the box around the start's joints (and ``region``, an (n, 2) array such
    as the target) widened by ``margin`` × its size, angles ±π around the start;
    ``bounds`` overrides any variable by name with ``(low, high)``.
    """
    names, x0 = [], []
    pts = [p for p in m.points if p.name in set(points)]
    for j in m.joints:
        if j.kind is JointKind.P:
            names += [f"{j.name}.angle"]
            x0 += [float(np.arctan2(j.axis[1], j.axis[0]))]
        else:
            names += [f"{j.name}.x", f"{j.name}.y"]
            x0 += list(j.at)
    for p in pts:
        names += [f"{p.name}.x", f"{p.name}.y"]
        x0 += list(p.at)
    xy = np.array([j.at for j in m.joints] + [p.at for p in pts], float)
    if region is not None:
        xy = np.vstack([xy, np.asarray(region, float)])
    lo_box, hi_box = xy.min(axis=0), xy.max(axis=0)
    size = float(np.max(hi_box - lo_box)) or 1.0
    lo_box, hi_box = lo_box - margin * size, hi_box + margin * size
    x0 = np.array(x0, float)
    lo, hi = np.empty_like(x0), np.empty_like(x0)
    for i, n in enumerate(names):
        kind = n.rsplit(".", 1)[1]
        if kind == "angle":
            lo[i], hi[i] = x0[i] - np.pi, x0[i] + np.pi
        else:
            k = 0 if kind == "x" else 1
            lo[i], hi[i] = lo_box[k], hi_box[k]
    for n, (a, b) in (bounds or {}).items():
        if n not in names:
            raise InputError(explain(f"bounds[{n!r}]", expected="a design variable name",
                                     got="an unknown name", hint=", ".join(names)))
        if not a < b:
            raise InputError(explain(f"bounds[{n!r}]", expected="low < high", got=f"({a}, {b})"))
        i = names.index(n)
        lo[i], hi[i] = a, b
    x0 = np.clip(x0, lo, hi)
    return DesignSpace(tuple(names), x0, lo, hi)


@dataclass(frozen=True)
class Poses:
    """Link poses of a population over positions: ``th``, ``tx``, ``ty`` are
    ``(n_links, P, N)``; ``ok`` is ``(P, N)`` (every group assembled)."""

    th: np.ndarray
    tx: np.ndarray
    ty: np.ndarray
    ok: np.ndarray

    def world(self, k: int, r: np.ndarray) -> np.ndarray:
        """The material point of link ``k`` at reference ``r`` ``(P, 2)``: ``(P, N, 2)``."""
        c, s = np.cos(self.th[k]), np.sin(self.th[k])
        rx, ry = r[:, 0:1], r[:, 1:2]
        return np.stack([c * rx - s * ry + self.tx[k], s * rx + c * ry + self.ty[k]], axis=-1)


def _ang(v):
    return np.arctan2(v[..., 1], v[..., 0])


def _nrm(u):
    return np.stack([-u[..., 1], u[..., 0]], axis=-1)


class Evaluator:
    """The parameterised solver of one mechanism (compile once, call many times).

    Parameters
    ----------
    mechanism : Mechanism
        The start: its topology, drivers and decomposition are kept.
    space : DesignSpace
        From :func:`design_space` on the same mechanism.
    """

    def __init__(self, mechanism: Mechanism, space: DesignSpace):
        m = self.mechanism = mechanism
        self.space = space
        self.plan = decompose(m)
        self.links = {x: i for i, x in enumerate(m.link_names)}
        self.frame = self.links[m.frame]
        self.slow = [s.kind_name for s in self.plan.steps
                     if isinstance(s, AssurGroup) and s.kind not in _CLOSED + (GroupKind.TRIAD,)]
        self._cols = {n: i for i, n in enumerate(space.names)}
        self.deadline: float | None = None      # time.perf_counter() value; see _per_candidate

    # -- decoding --------------------------------------------------------------
    def at(self, X: np.ndarray, name: str) -> np.ndarray:
        """Reference position ``(P, 2)`` of joint or point ``name`` for designs ``X``."""
        c = self._cols
        if f"{name}.x" in c:
            return X[:, [c[f"{name}.x"], c[f"{name}.y"]]]
        j = self.mechanism.joint(name)
        if j.kind is JointKind.P:
            return np.broadcast_to(np.asarray(j.at, float), (X.shape[0], 2))
        raise KeyError(name)

    def axis(self, X: np.ndarray, name: str) -> np.ndarray:
        a = X[:, self._cols[f"{name}.angle"]]
        return np.stack([np.cos(a), np.sin(a)], axis=-1)

    # -- solving ---------------------------------------------------------------
    def poses(self, X, phi) -> Poses:
        """Solve designs ``X`` ``(P, n_var)`` at driver values ``phi`` ``(P, N)`` or ``(N,)``.

        One driver only (the synthesis problems are single-input); ``phi`` is the
        driver value from the reference configuration (rad, or m for a P driver).
        """
        X = np.atleast_2d(np.asarray(X, float))
        P = X.shape[0]
        phi = np.broadcast_to(np.asarray(phi, float), (P, np.shape(phi)[-1]))
        if self.slow:
            return self._per_candidate(X, phi)
        N = phi.shape[1]
        nl = len(self.links)
        th = np.full((nl, P, N), np.nan)
        tx, ty = th.copy(), th.copy()
        th[self.frame] = tx[self.frame] = ty[self.frame] = 0.0
        st = Poses(th, tx, ty, np.ones((P, N), bool))
        for step in self.plan.steps:
            if isinstance(step, DriverStep):
                self._driver(step, X, phi, st)
            elif step.kind is GroupKind.TRIAD:
                self._triad(step, X, st)
            else:
                getattr(self, "_" + step.kind.lower())(step, X, st)
        ok = np.all(np.isfinite(th), axis=0)
        return Poses(th, tx, ty, ok)

    def _per_candidate(self, X, phi) -> Poses:
        """Slow path for groups without a batched kernel (PRP, RPP, class IV, larger
        groups): :func:`kin.solve.solve` once per candidate, poses converted.

        Past ``self.deadline`` (a ``time.perf_counter()`` value, when set) the
        remaining candidates are not solved and count as failures (``ok`` False),
        so that one population cannot overrun the time budget."""
        import time
        import warnings

        from multiloop.kin.solve import compile_plan, solve
        from multiloop.topo.errors import LinkageError
        P, N = phi.shape
        th = np.full((len(self.links), P, N), np.nan)
        tx, ty = th.copy(), th.copy()
        ok = np.zeros((P, N), bool)
        for p in range(P):
            if self.deadline is not None and time.perf_counter() > self.deadline:
                break
            try:
                mp = self.with_design(X[p])
                sp = compile_plan(mp)
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    st = solve(mp, phi[p], plan=sp)
            except LinkageError:
                continue
            Z = st.poses                                      # (N, n_links, 3): origin + angle
            good = np.asarray(st.status == "ok")
            c, s = np.cos(Z[:, :, 2]), np.sin(Z[:, :, 2])
            o = sp.origins
            th[:, p] = np.where(good, Z[:, :, 2].T, np.nan)
            tx[:, p] = np.where(good, (Z[:, :, 0] - (c * o[:, 0] - s * o[:, 1])).T, np.nan)
            ty[:, p] = np.where(good, (Z[:, :, 1] - (s * o[:, 0] + c * o[:, 1])).T, np.nan)
            ok[p] = good
        return Poses(th, tx, ty, ok)

    def _place(self, st: Poses, link: str, theta, anchor_world, anchor_ref) -> None:
        k = self.links[link]
        c, s = np.cos(theta), np.sin(theta)
        rx, ry = anchor_ref[:, 0:1], anchor_ref[:, 1:2]
        st.th[k] = theta
        st.tx[k] = anchor_world[..., 0] - (c * rx - s * ry)
        st.ty[k] = anchor_world[..., 1] - (s * rx + c * ry)

    def _known(self, step, joint: str) -> str:
        unknown = set(step.links) if isinstance(step, AssurGroup) else {step.link}
        for c in step.constraints:
            if c.joint == joint and (c.a in unknown) != (c.b in unknown):
                return c.a if c.b in unknown else c.b
        raise KeyError(joint)   # pragma: no cover - the decomposition guarantees one

    def _driver(self, step: DriverStep, X, phi, st: Poses) -> None:
        d = next(c for c in step.constraints if c.kind.startswith("drive"))
        lk = step.link
        other = d.a if d.b == lk else d.b
        sgn = 1.0 if d.b == lk else -1.0
        ko = self.links[other]
        if d.kind == "drive_R":
            p = next(c for c in step.constraints if c.kind == "R")
            host = p.a if p.b == lk else p.b
            r = self.at(X, p.joint)
            self._place(st, lk, st.th[ko] + sgn * phi, st.world(self.links[host], r), r)
        else:
            r = self.at(X, d.joint)
            u = self.axis(X, d.joint)
            c, s = np.cos(st.th[ko]), np.sin(st.th[ko])
            uw = np.stack([c * u[:, 0:1] - s * u[:, 1:2], s * u[:, 0:1] + c * u[:, 1:2]], axis=-1)
            W = st.world(ko, r) + sgn * phi[..., None] * uw
            self._place(st, lk, st.th[ko], W, r)

    def branch(self, g: AssurGroup, X) -> np.ndarray:
        """Assembly branch ``(P, 1)`` (±1) of dyad ``g`` in the reference configuration
        of designs ``X``: the side of the inner pin (RRR), the sense of the link along
        the guide (RRP, RPR)."""
        o1, inner, o2, l1, l2 = g.layout
        if g.kind is GroupKind.RRR:
            AC, AB = self.at(X, o2) - self.at(X, o1), self.at(X, inner) - self.at(X, o1)
            v = AC[:, 0] * AB[:, 1] - AC[:, 1] * AB[:, 0]
        elif g.kind is GroupKind.RRP:
            v = np.sum((self.at(X, inner) - self.at(X, o1)) * self.axis(X, o2), axis=-1)
        else:
            gx, bx = (o1, o2) if self.mechanism.joint(inner).links[0] == l1 else (o2, o1)
            v = np.sum((self.at(X, bx) - self.at(X, gx)) * self.axis(X, inner), axis=-1)
        return np.where(v >= 0, 1.0, -1.0)[:, None]

    def branches(self, X) -> np.ndarray:
        """Branches ``(P, n_dyads)`` of every RRR, RRP and RPR dyad (see :meth:`branch`)."""
        X = np.atleast_2d(np.asarray(X, float))
        cols = [self.branch(g, X) for g in self.plan.groups if g.kind in _CLOSED]
        return np.concatenate(cols, axis=1) if cols else np.ones((X.shape[0], 0))

    def driver_sense(self) -> tuple[float, str, str]:
        """``(sense, link, other)``: the driven ``link`` turns (slides) by ``sense`` × the
        driver value relative to ``other`` (see :meth:`_driver`)."""
        step = next(s for s in self.plan.steps if isinstance(s, DriverStep))
        d = next(c for c in step.constraints if c.kind.startswith("drive"))
        return (1.0 if d.b == step.link else -1.0), step.link, (d.a if d.b == step.link else d.b)

    def driver_zero(self, X) -> np.ndarray:
        """The driver's absolute value ``(P,)`` in the reference configuration of designs
        ``X``, for a driver on the frame: an R driver's link angle from the x-axis (the
        line from the driver's pin to the link's next R joint), a P driver's slider
        position along the guide from the guide's point (the joint's reference point)
        to the slider's first R joint."""
        X = np.atleast_2d(np.asarray(X, float))
        m = self.mechanism
        j = m.joint(m.drivers[0].joint)
        _, link, _ = self.driver_sense()
        q = next((k.name for k in m.joints_of(link) if k.kind is JointKind.R and k.name != j.name), None)
        if q is None:
            raise InputError(explain(f"driven link {link!r}", expected="a second R joint to measure its position by",
                                     got="none"))
        d = self.at(X, q) - self.at(X, j.name)
        if j.kind is JointKind.R:
            return np.arctan2(d[:, 1], d[:, 0])
        return np.sum(d * self.axis(X, j.name), axis=-1)

    def _rrr(self, g: AssurGroup, X, st: Poses) -> None:
        from multiloop.kin.groups import rrr_position
        o1, inner, o2, l1, l2 = g.layout
        Ar, Br, Cr = self.at(X, o1), self.at(X, inner), self.at(X, o2)
        A = st.world(self.links[self._known(g, o1)], Ar)
        C = st.world(self.links[self._known(g, o2)], Cr)
        la = np.hypot(*(Br - Ar).T)[:, None]
        lc = np.hypot(*(Br - Cr).T)[:, None]
        sgn = self.branch(g, X)
        B = rrr_position(A, C, la, lc, sgn).B
        self._place(st, l1, _ang(B - A) - _ang(Br - Ar)[:, None], A, Ar)
        self._place(st, l2, _ang(B - C) - _ang(Br - Cr)[:, None], C, Cr)

    def _rrp(self, g: AssurGroup, X, st: Poses) -> None:
        from multiloop.kin.groups import rrp_position
        o1, inner, o2, l1, l2 = g.layout
        Ar, Br, Pr = self.at(X, o1), self.at(X, inner), self.at(X, o2)
        ur = self.axis(X, o2)
        kp = self.links[self._known(g, o2)]
        h = np.sum(_nrm(ur) * (Br - Pr), axis=-1)[:, None]
        A = st.world(self.links[self._known(g, o1)], Ar)
        Pw = st.world(kp, Pr)
        c, s = np.cos(st.th[kp]), np.sin(st.th[kp])
        u = np.stack([c * ur[:, 0:1] - s * ur[:, 1:2], s * ur[:, 0:1] + c * ur[:, 1:2]], axis=-1)
        la = np.hypot(*(Br - Ar).T)[:, None]
        sgn = self.branch(g, X)
        B = rrp_position(A, Pw, u, la, h, sgn).B
        self._place(st, l1, _ang(B - A) - _ang(Br - Ar)[:, None], A, Ar)
        self._place(st, l2, st.th[kp], B, Br)

    def _rpr(self, g: AssurGroup, X, st: Poses) -> None:
        from multiloop.kin.groups import rpr_position
        o1, inner, o2, l1, l2 = g.layout
        guide = self.mechanism.joint(inner).links[0]
        gx, bx = (o1, o2) if guide == l1 else (o2, o1)
        block = l2 if guide == l1 else l1
        Xr, Yr = self.at(X, gx), self.at(X, bx)
        ur = self.axis(X, inner)
        h = np.sum(_nrm(ur) * (Yr - Xr), axis=-1)[:, None]
        Xw = st.world(self.links[self._known(g, gx)], Xr)
        Yw = st.world(self.links[self._known(g, bx)], Yr)
        sgn = self.branch(g, X)
        u = rpr_position(Yw, Xw, h, sgn).u
        theta = _ang(u) - _ang(ur)[:, None]
        self._place(st, guide, theta, Xw, Xr)
        self._place(st, block, theta, Yw, Yr)

    def _triad(self, g: AssurGroup, X, st: Poses) -> None:
        """Triad: the all-modes tracker, one call per candidate over its positions."""
        from multiloop.kin.groups import triad_track
        tern, bins, outs, inns = g.layout
        Ar = np.stack([self.at(X, o) for o in outs], axis=1)           # (P, 3, 2)
        b = np.stack([self.at(X, i) for i in inns], axis=1)
        A = np.stack([st.world(self.links[self._known(g, o)], Ar[:, i]) for i, o in enumerate(outs)],
                     axis=2)                                            # (P, N, 3, 2)
        P, N = A.shape[:2]
        Pw = np.full((P, N, 3, 2), np.nan)
        th = np.full((P, N), np.nan)
        for p in range(P):
            good = np.all(np.isfinite(A[p].reshape(N, -1)), axis=1)
            n = int(np.argmin(good)) if not good.all() else N   # track the leading good run
            if n == 0:
                continue
            r = triad_track(A[p, :n], b[p], np.hypot(*(b[p] - Ar[p]).T), b[p])
            okp = r.ok
            Pw[p, :n][okp], th[p, :n][okp] = r.P[okp], r.theta[okp]
        self._place(st, tern, th, Pw[:, :, 0], b[:, 0])
        for i, lk in enumerate(bins):
            self._place(st, lk, _ang(Pw[:, :, i] - A[:, :, i]) - _ang(b[:, i] - Ar[:, i])[:, None],
                        A[:, :, i], Ar[:, i])

    # -- outputs ---------------------------------------------------------------
    def point(self, X, phi, name: str) -> tuple[np.ndarray, np.ndarray]:
        """World positions ``(P, N, 2)`` of tracer point or joint ``name`` and ``ok``."""
        st = self.poses(X, phi)
        X = np.atleast_2d(np.asarray(X, float))
        m = self.mechanism
        pts = {p.name: p for p in m.points}
        if name in pts:
            k = self.links[pts[name].link]
        else:
            j = m.joint(name)
            k = self.links[j.links[1] if j.kind is JointKind.P else j.links[0]]
        return st.world(k, self.at(X, name)), st.ok

    def with_design(self, x) -> Mechanism:
        """The start mechanism with the dimensions of design ``x`` (names kept)."""
        from dataclasses import replace
        X = np.asarray(x, float)[None, :]
        m = self.mechanism
        joints = []
        for j in m.joints:
            at = tuple(float(v) for v in self.at(X, j.name)[0])
            axis = tuple(float(v) for v in self.axis(X, j.name)[0]) if j.kind is JointKind.P else j.axis
            joints.append(replace(j, at=at, axis=axis))
        pts = [replace(p, at=tuple(float(v) for v in self.at(X, p.name)[0]))
               if f"{p.name}.x" in self._cols else p for p in m.points]
        return replace(m, joints=tuple(joints), points=tuple(pts))


def four_bar_roles(m) -> dict | None:
    """Joint and link roles of a driven four-bar, or None: ``O_in, A, B, O_out, crank,
    coupler, rocker``."""
    if m.n_links != 4 or m.n_joints != 4 or any(j.kind is not JointKind.R or j.is_multiple for j in m.joints):
        return None
    fr = m.frame
    d = m.joint(m.drivers[0].joint)
    if fr not in d.links:
        return None
    crank = next(x for x in d.links if x != fr)
    o_out = next((j for j in m.joints if fr in j.links and j.name != d.name), None)
    if o_out is None:
        return None
    rocker = next(x for x in o_out.links if x != fr)
    coupler = next((x for x in m.link_names if x not in (fr, crank, rocker)), None)
    A = next((j for j in m.joints if set(j.links) == {crank, coupler}), None)
    B = next((j for j in m.joints if set(j.links) == {coupler, rocker}), None)
    if coupler is None or A is None or B is None:
        return None
    return dict(O_in=d.name, A=A.name, B=B.name, O_out=o_out.name, crank=crank, coupler=coupler,
                rocker=rocker)
