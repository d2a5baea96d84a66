"""Kinematics of a whole mechanism: follow the Assur plan over arrays of inputs.

:func:`solve` is the entry point; :func:`compile_plan` turns an
:class:`~topo.assur.AssurPlan` into a frozen :class:`SolvePlan` once (each step's
equations compiled, structurally singular designs rejected), and the solver loops
over its steps.

Conventions
-----------
* ``inputs[:, k]`` is driver k's value: the rotation (rad) of the driver joint's
  ``links[1]`` relative to ``links[0]`` from the reference configuration, or the
  slide (m) for a P joint.  Input 0 is the reference configuration.
* Each group's **assembly branch** is the one of the reference configuration.
  The solver reaches the first requested input from the reference along a
  straight path (the *lead-in*, steps of at most 2° or 1 % of the mechanism's
  size) and then follows the inputs in the order given, by continuity.
* Dyads are solved in closed form over the whole batch at once (no loop per
  position) with the branch fixed; where the two branches of a dyad meet (a
  change point, e.g. a parallelogram's flat positions) the solver picks, position
  by position and only there, the candidate nearest to the linear prediction
  from the two previous positions, and says so in ``notes``.  Triads use the
  all-modes kernel for the start and the continuation tracker; any other group
  is solved by Newton with continuation (:mod:`kin.groups.newton`).
* Failures are results: a position where a group cannot be assembled or is
  singular is NaN, and ``status[n]`` names the group and the reason.  A single
  position (scalar input) that fails raises :class:`~topo.errors.AssemblyError`
  or :class:`~topo.errors.SingularityError`.
* Derivatives (``derivatives=True``) are time derivatives for ``input_rates``
  (default 1 rad/s or 1 m/s per driver, zero input acceleration): for one driver
  they are the analogues d/dφ and d²/dφ² of Vasechkin et al. 2017.  They come from one linear
  system per group (the group's Jacobian), never from finite differences.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from multiloop.topo.assur import AssurGroup, AssurPlan, DriverStep, decompose, link_origins
from multiloop.topo.errors import (AssemblyError, InputError, SingularityError, SingularityWarning,
                         explain)
from multiloop.topo.model import JointKind, Mechanism

from .groups.newton import ConstraintSystem, rates, track
from .state import KinematicState

__all__ = ["solve", "compile_plan", "SolvePlan", "StepPlan", "METHODS"]

METHODS = ("auto", "closed_form", "newton")
_SINGULAR = 1e-9          # relative determinant below which a position is singular
#: PRP/RPP: |det| = |sin(angle between the unit guides)| below which the guides count as
#: parallel; nearer than this the slider positions exceed 1e6 × the offsets (change point)
_PARALLEL_GUIDES = 1e-6


@dataclass(frozen=True, eq=False)
class StepPlan:
    """One compiled step: which links it solves and how."""

    step: object                      # DriverStep or AssurGroup
    system: ConstraintSystem
    unknown: tuple[int, ...]          # link indices
    solver: str                       # "driver", "dyad", "triad", "newton"
    label: str


@dataclass(frozen=True, eq=False)
class SolvePlan:
    """A mechanism's Assur plan compiled for the solvers (build once, reuse)."""

    mechanism: Mechanism
    assur: AssurPlan
    steps: tuple[StepPlan, ...]
    origins: np.ndarray               # (n_links, 2) link reference points
    joint_host: tuple[int, ...]       # link index carrying each joint's point
    joint_step: tuple[int, ...]       # step index solving that link (-1 frame)
    size: float                       # mechanism size (m), for tolerances
    point_host: tuple[int, ...] = ()
    extra: dict = field(default_factory=dict)


def compile_plan(mechanism: Mechanism, plan: AssurPlan | None = None) -> SolvePlan:
    """Compile the decomposition of ``mechanism`` for :func:`solve`.

    Raises
    ------
    InputError
        The mechanism has no geometry or no drivers.
    DecompositionError, MobilityError
        From :func:`topo.assur.decompose`.
    SingularityError
        A group is singular in the reference configuration, e.g. the parallel
        guides of a PRP dyad or an RPP dyad with α = 0 (a design error).
    """
    m = mechanism
    if not m.has_geometry:
        raise InputError(explain(f"mechanism '{m.name or ''}'", expected="geometry: 'at' on every joint and 'axis' on every P joint",
                                 got="a mechanism without geometry", hint="kinematics needs the reference configuration"))
    if not m.drivers:
        raise InputError(explain(f"mechanism '{m.name or ''}'", expected="at least one [[driver]]", got="none"))
    ap = plan if plan is not None else decompose(m)
    names = m.link_names
    idx = {x: i for i, x in enumerate(names)}
    org = link_origins(m)
    origins = np.array([org[x] for x in names])
    steps = []
    Z0 = np.zeros((1, len(names), 3))
    Z0[0, :, :2] = origins
    for k, s in enumerate(ap.steps):
        sysm = ConstraintSystem.compile(m, s.constraints)
        links = (s.link,) if isinstance(s, DriverStep) else s.links
        unknown = tuple(idx[x] for x in links)
        if isinstance(s, DriverStep):
            solver, label = "driver", f"driver {s.joint} (I{s.number})"
        else:
            solver = "dyad" if s.is_dyad else (
                "triad" if s.kind == "triad" else ("class4" if s.kind == "class IV" and s.layout else "newton"))
            label = s.describe()
        # regularity at the reference configuration
        cols = (3 * np.asarray(unknown)[:, None] + np.arange(3)).ravel()
        J = sysm.jacobian(Z0)[0][:, cols]
        norms = np.prod(np.linalg.norm(J, axis=0))
        rel = abs(np.linalg.det(J)) / norms if norms > 0 else 0.0
        if rel < _SINGULAR:
            hint = "parallel guides of a PRP dyad or α = 0 of an RPP dyad are structurally singular" \
                if isinstance(s, AssurGroup) and s.kind in ("PRP", "RPP") else \
                "move a joint so that the group is not at a dead centre / toggle position"
            raise SingularityError(explain(
                label, expected="a regular group in the reference configuration",
                got=f"a singular one (relative determinant {rel:.1e})", hint=hint))
        steps.append(StepPlan(s, sysm, unknown, solver, label))
    solved = dict(ap.solved_by)
    host, hstep = [], []
    for j in m.joints:
        if j.kind is JointKind.P:
            cand = [j.links[1]]
        else:
            cand = sorted(j.links, key=lambda x: solved.get(x, -1))
        host.append(idx[cand[0]])
        hstep.append(solved.get(cand[0], -1))
    pts = tuple(idx[p.link] for p in m.points)
    xy = np.array([j.at for j in m.joints], float)
    size = float(np.max(np.ptp(xy, axis=0))) if len(xy) > 1 else 1.0
    return SolvePlan(m, ap, tuple(steps), origins, tuple(host), tuple(hstep), max(size, 1e-12), pts)


# ---------------------------------------------------------------------------------
def _as_inputs(m: Mechanism, inputs) -> tuple[np.ndarray, bool]:
    x = np.asarray(inputs, float)
    nd = len(m.drivers)
    single = x.ndim == 0 or (x.ndim == 1 and nd > 1 and x.shape[0] == nd)
    if x.ndim == 0:
        x = x.reshape(1, 1)
    elif x.ndim == 1:
        x = x.reshape(1, nd) if single else x.reshape(-1, 1)
    if x.ndim != 2 or x.shape[1] != nd:
        raise InputError(explain("inputs", expected=f"shape (N,) for one driver or (N, {nd}) for {nd} drivers",
                                 got=f"shape {np.shape(inputs)}"))
    if not np.all(np.isfinite(x)):
        raise InputError(explain("inputs", expected="finite numbers", got="NaN or infinity"))
    return x, single


def _lead_in(plan: SolvePlan, x0: np.ndarray) -> np.ndarray:
    m = plan.mechanism
    lim = np.array([np.radians(2.0) if m.joint(d.joint).kind is JointKind.R else 0.01 * plan.size
                    for d in m.drivers])
    n = int(np.ceil(np.max(np.abs(x0) / lim))) if np.any(x0 != 0) else 0
    if n == 0:
        return np.zeros((0, len(lim)))
    t = np.arange(n)[:, None] / n
    return t * x0[None, :]


def solve(mechanism: Mechanism, inputs, *, derivatives: bool = False, input_rates=None,
          only=None, plan=None, method: str = "auto") -> KinematicState:
    """Positions (and velocities, accelerations) of a mechanism over a batch of inputs.

    Parameters
    ----------
    mechanism : Mechanism
        With geometry, a frame and drivers.
    inputs : float or array_like, shape (N,) or (N, n_drivers)
        Driver values (rad for R drivers, m for P drivers) from the reference.
    derivatives : bool
        Also velocities and accelerations (for ``input_rates``, zero input
        acceleration): the analogues d/dφ, d²/dφ² for one driver at unit rate.
    input_rates : array_like (n_drivers,), optional
        Input speeds (default 1 for every driver).
    only : iterable of str, optional
        Names of joints, tracer points or links wanted: only the groups upstream
        of them are solved (the other entries stay NaN).
    plan : AssurPlan or SolvePlan, optional
        A precompiled plan (see :func:`compile_plan`).
    method : {"auto", "closed_form", "newton"}
        ``auto``/``closed_form``: closed-form dyads, triad kernel, Newton for the
        rest; ``newton``: every group by Newton with continuation.

    Returns
    -------
    KinematicState

    Raises
    ------
    AssemblyError, SingularityError
        Only for a single-position query (scalar input) that fails.
    InputError
        Bad shapes, unknown names in ``only``, unknown method.

    Examples
    --------
    >>> from multiloop.topo.model import MechanismBuilder
    >>> b = MechanismBuilder()
    >>> b.add_link("ground", frame=True)
    >>> for n, lk, at in [("O", ("ground", "crank"), (0, 0)), ("A", ("crank", "rod"), (1, 0)),
    ...                   ("B", ("rod", "rocker"), (3, 2)), ("C", ("rocker", "ground"), (4, 0))]:
    ...     b.add_joint(n, "R", lk, at=at)
    >>> b.add_driver("O")
    >>> st = solve(b.build(), [0.0, np.pi / 2])
    >>> np.round(st.positions[1, 1], 12).tolist()
    [0.0, 1.0]
    """
    if method not in METHODS:
        raise InputError(explain("method", expected=" or ".join(repr(x) for x in METHODS), got=repr(method)))
    m = mechanism
    sp = plan if isinstance(plan, SolvePlan) else compile_plan(m, plan)
    X, single = _as_inputs(m, inputs)
    nd = X.shape[1]
    lead = _lead_in(sp, X[0])
    XX = np.vstack([lead, X]) if lead.size else X
    L = lead.shape[0]
    M = XX.shape[0]
    # which steps
    needed = list(range(len(sp.steps)))
    if only is not None:
        needed = _needed_steps(sp, only)
    G = _Poses(sp, M)
    reason: dict[int, str] = {}
    has_reason = np.zeros(M, bool)
    notes: list[str] = []
    branches = []
    kernels = _kernels() if method != "newton" else None
    for k in needed:
        st = sp.steps[k]
        u = list(st.unknown)
        known = np.setdiff1d(st.system.involved, u)
        upstream_bad = ~G.finite(known)
        if st.solver == "driver" and _driver_closed_form(st):
            okk, why = _solve_driver(sp, st, G, XX)
        elif st.solver in ("dyad", "triad", "class4") and kernels and st.step.kind in kernels:
            okk, why, note = kernels[st.step.kind](sp, st, G, XX)
            notes += note
        else:
            Z = G.to_Z(known)
            Z[:, u, :2] = sp.origins[u]
            Z[:, u, 2] = 0.0
            tr = track(st.system, Z, XX, u, singular_tol=_SINGULAR)
            G.from_Z(tr.Z, u)
            okk, why = tr.ok, tr.reason
        idx = np.flatnonzero(~okk & ~upstream_bad & ~has_reason)
        for n in idx:
            w = why.get(int(n)) if isinstance(why, dict) else why[n]
            reason[int(n)] = f"{st.label}: {w or 'no assembly (out of reach)'}"
        has_reason[idx] = True
        G.invalidate(u, ~okk)
        branches.append((st.label, "reference"))
    # drop the lead-in
    if L and has_reason[:L].any():
        first = int(np.flatnonzero(has_reason[:L])[0])
        notes.append(f"the path from the reference configuration to the first input failed at "
                     f"{_fmt_input(m, lead[first])}: {reason[first]}")
    G.unset_to_nan()
    if L:
        G = G.tail(L)
    N = M - L
    failed = np.flatnonzero(has_reason[L:])
    status = np.empty(N, dtype=object)
    status.fill("ok")                       # (np.full with an object is ~30x slower)
    for n in failed:
        status[n] = reason[int(n) + L]
    solved_links = [i for s in needed for i in sp.steps[s].unknown]
    finite = G.finite(solved_links)
    okm = ~has_reason[L:]
    status[okm & ~finite] = "failed upstream"
    okm &= finite
    failed = np.flatnonzero(~okm)
    Z = G.to_Z()
    # derivatives
    Zd = Zdd = None
    rates_in = None
    if derivatives:
        rates_in = np.ones(nd) if input_rates is None else np.asarray(input_rates, float).reshape(nd)
        Zd = np.zeros_like(Z)
        Zdd = np.zeros_like(Z)
        R = np.broadcast_to(rates_in, (N, nd))
        for k in needed:
            st = sp.steps[k]
            if st.solver == "dyad" and kernels and st.step.kind in kernels:
                _dyad_rates(sp, st, Z, Zd, Zdd)       # closed form (one 2×2 system)
            elif st.solver == "driver" and _driver_closed_form(st):
                _driver_rates(sp, st, Z, Zd, Zdd, rates_in)
            else:
                Zd, Zdd = rates(st.system, Z, Zd, R, st.unknown, Zdd, None)
        unsolved = [k for k in range(m.n_links) if k not in set(solved_links) and m.link_names[k] != m.frame]
        Zd[:, unsolved] = np.nan
        Zdd[:, unsolved] = np.nan
        bad = ~okm
        Zd[bad] = np.nan
        Zdd[bad] = np.nan
    state = _state(sp, X, G, Z, Zd, Zdd, status, rates_in, tuple(branches), tuple(notes))
    if single and status[0] != "ok":
        msg = f"input {_fmt_input(m, X[0])}: {status[0]}"
        if "singular position" in status[0]:
            raise SingularityError(msg)
        raise AssemblyError(msg)
    if not single and failed.size and any(("singular position" in s) for s in status[failed]):
        warnings.warn("singular positions met: marked in status", SingularityWarning, stacklevel=2)
    return state


def _fmt_input(m: Mechanism, x) -> str:
    parts = []
    for d, v in zip(m.drivers, np.atleast_1d(x)):
        if m.joint(d.joint).kind is JointKind.R:
            parts.append(f"{d.joint} = {np.degrees(v):.6g}°")
        else:
            parts.append(f"{d.joint} = {v:.6g} m")
    return ", ".join(parts)


def _needed_steps(sp: SolvePlan, only) -> list[int]:
    m = sp.mechanism
    if isinstance(only, str):
        only = [only]
    want = []
    jn, pn, ln = set(m.joint_names), {p.name: p for p in m.points}, set(m.link_names)
    for name in only:
        if name in jn:
            want.append(sp.joint_step[m.joint_names.index(name)])
        elif name in pn:
            want.append(sp.assur.step_of(pn[name].link))
        elif name in ln:
            want.append(sp.assur.step_of(name))
        else:
            raise InputError(explain(f"only = {name!r}", expected="a joint, tracer point or link name",
                                     got="an unknown name",
                                     hint=f"joints: {', '.join(m.joint_names)}"))
    return list(sp.assur.upstream([w for w in want if w >= 0]))


def _driver_closed_form(st: StepPlan) -> bool:
    cons = st.step.constraints
    drive = [c for c in cons if c.kind.startswith("drive")]
    pins = [c for c in cons if c.kind == "R"]
    sliders = [c for c in cons if c.kind == "P"]
    if len(drive) != 1:
        return False
    if drive[0].kind == "drive_R":
        return len(pins) == 1 and not sliders
    return len(sliders) == 1 and not pins and {drive[0].a, drive[0].b} == {sliders[0].a, sliders[0].b}


def _solve_driver(sp: SolvePlan, st: StepPlan, G: "_Poses", X: np.ndarray):
    """Closed form for a one-link driver step (rotation about / slide along a known link)."""
    m = sp.mechanism
    cons = st.step.constraints
    L = st.unknown[0]
    names = m.link_names
    d = next(c for c in cons if c.kind.startswith("drive"))
    lk = names[L]
    if d.kind == "drive_R":
        p = next(c for c in cons if c.kind == "R")
        other = d.a if d.b == lk else d.b
        sgn = 1.0 if d.b == lk else -1.0
        th = G.th[names.index(other)] + sgn * X[:, d.driver]
        host = p.a if p.b == lk else p.b
        r = np.asarray(m.joint(p.joint).at, float)
        G.place_cs(lk, G.point(host, r), r, np.cos(th), np.sin(th), th)
    else:
        jt = m.joint(d.joint)
        r = np.asarray(jt.at, float)
        u = _unit(jt.axis)
        if d.b == lk:       # the slider is the unknown
            k = names.index(d.a)
            P = G.point(d.a, r) + X[:, [d.driver]] * G.direction(d.a, u)
        else:               # the guide is the unknown: the known slider sits at -s on it
            k = names.index(d.b)
            P = G.point(d.b, r) - X[:, [d.driver]] * G.direction(d.b, u)
        G.place_cs(lk, P, r, G.c[k], G.s[k], G.th[k])
    return np.isfinite(G.th[L]), {}


def _rotate(v, th):
    v = np.asarray(v, float)
    c, s = np.cos(th), np.sin(th)
    if v.ndim == 1:
        return np.stack([c * v[0] - s * v[1], s * v[0] + c * v[1]], axis=-1)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


def _material(Z, k, r_local):
    """Position of the material point ``c_k + r_local`` of link k, shape (N, 2)."""
    return Z[:, k, :2] + _rotate(r_local, Z[:, k, 2])


def _state(sp: SolvePlan, X, G: "_Poses", Z, Zd, Zdd, status, rates_in, branches, notes) -> KinematicState:
    m = sp.mechanism
    N = G.M
    pos = np.empty((N, m.n_joints, 2))
    for i, j in enumerate(m.joints):
        pos[:, i] = G.point_k(sp.joint_host[i], np.asarray(j.at, float))
    vel = acc = om = ep = None
    if Zd is not None:
        host = np.asarray(sp.joint_host)
        rr = pos - Z[:, host, :2]
        w = Zd[:, host, 2][..., None]
        perp = np.stack([-rr[..., 1], rr[..., 0]], axis=-1)
        vel = Zd[:, host, :2] + w * perp
        e = Zdd[:, host, 2][..., None]
        acc = Zdd[:, host, :2] + e * perp - w * w * rr
        om, ep = Zd[:, :, 2].copy(), Zdd[:, :, 2].copy()
    ppos = pvel = pacc = None
    if m.points:
        ph = np.asarray(sp.point_host)
        ppos = np.empty((N, len(m.points), 2))
        for i, p in enumerate(m.points):
            ppos[:, i] = G.point_k(ph[i], np.asarray(p.at, float))
        if Zd is not None:
            pr = ppos - Z[:, ph, :2]
            w = Zd[:, ph, 2][..., None]
            perp = np.stack([-pr[..., 1], pr[..., 0]], axis=-1)
            pvel = Zd[:, ph, :2] + w * perp
            pacc = Zdd[:, ph, :2] + Zdd[:, ph, 2][..., None] * perp - w * w * pr
    return KinematicState(m, X, pos, np.stack(G.th, axis=1), status, vel, acc, om, ep,
                          rates_in, branches, point_names=tuple(p.name for p in m.points),
                          point_positions=ppos, point_velocities=pvel, point_accelerations=pacc,
                          notes=notes, poses=Z, pose_rates=Zd, pose_accelerations=Zdd)


def _kernels():
    """Closed-form group solvers, or None when :mod:`kin.groups` is not importable."""
    try:
        import multiloop.kin.groups as K
    except ImportError:  # pragma: no cover - the kernels are part of the package
        return None
    need = {"RRR": "rrr_position", "RRP": "rrp_position", "RPR": "rpr_position",
            "PRP": "prp_position", "RPP": "rpp_position", "triad": "triad_track",
            "class IV": "class4_track"}
    special = {"triad": _closed_triad, "class IV": _closed_class4}
    out = {k: special.get(k, _closed_dyad) for k, fn in need.items() if hasattr(K, fn)}
    return out


# ---------------------------------------------------------------------------------
# closed-form adapters: body poses  <->  point-form kernels of kin.groups
def _angle(v):
    return np.arctan2(v[..., 1], v[..., 0])


def _unit(v):
    v = np.asarray(v, float)
    return v / np.hypot(*v)


def _nrm(u):
    return np.stack([-u[..., 1], u[..., 0]], axis=-1)


class _Poses:
    """Working store of link poses: per link, contiguous arrays over the batch.

    ``x[k], y[k]`` position of link k's reference point, ``th[k]`` its rotation,
    ``c[k], s[k]`` = cos, sin of it (kept to avoid recomputing trigonometry).
    Arrays are stored by reference (no copies); a link never solved is ``None``.
    """

    def __init__(self, sp: SolvePlan, M: int):
        self.sp, self.m, self.M = sp, sp.mechanism, M
        nl = self.m.n_links
        self.idx = {x: i for i, x in enumerate(self.m.link_names)}
        self.x = [None] * nl
        self.y = [None] * nl
        self.th = [None] * nl
        self.c = [None] * nl
        self.s = [None] * nl
        self.frame_k = f = self.idx[self.m.frame]
        z = np.zeros(M)
        self.x[f], self.y[f], self.th[f], self.c[f], self.s[f] = z, z, z, np.ones(M), z

    def finite(self, links) -> np.ndarray:
        out = np.ones(self.M, bool)
        for k in links:
            out &= np.isfinite(self.th[k]) if self.th[k] is not None else False
        return out

    def unset_to_nan(self) -> None:
        """Links never solved (``only=``) become NaN."""
        nan = np.full(self.M, np.nan)
        for k in range(self.m.n_links):
            if self.th[k] is None:
                self.x[k] = self.y[k] = self.th[k] = self.c[k] = self.s[k] = nan

    def tail(self, L: int) -> "_Poses":
        out = object.__new__(_Poses)
        out.sp, out.m, out.M, out.idx, out.frame_k = self.sp, self.m, self.M - L, self.idx, self.frame_k
        for name in ("x", "y", "th", "c", "s"):
            setattr(out, name, [a[L:] for a in getattr(self, name)])
        return out

    # -- reading -------------------------------------------------------------------
    def at(self, joint: str) -> np.ndarray:
        return np.asarray(self.m.joint(joint).at, float)

    def axis(self, joint: str) -> np.ndarray:
        return _unit(self.m.joint(joint).axis)

    def point_k(self, k: int, r) -> np.ndarray:
        if k == self.frame_k:
            return np.broadcast_to(np.asarray(r, float), (self.M, 2))
        rx, ry = np.asarray(r, float) - self.sp.origins[k]
        c, s = self.c[k], self.s[k]
        out = np.empty((self.M, 2))
        out[:, 0] = self.x[k] + c * rx - s * ry
        out[:, 1] = self.y[k] + s * rx + c * ry
        return out

    def point(self, link: str, r) -> np.ndarray:
        return self.point_k(self.idx[link], r)

    def direction(self, link: str, v) -> np.ndarray:
        k = self.idx[link]
        vx, vy = v
        out = np.empty((self.M, 2))
        out[:, 0] = self.c[k] * vx - self.s[k] * vy
        out[:, 1] = self.s[k] * vx + self.c[k] * vy
        return out

    def theta(self, link: str) -> np.ndarray:
        return self.th[self.idx[link]]

    # -- writing -------------------------------------------------------------------
    def place_cs(self, link: str, P, r_ref, c, s, th) -> None:
        """Pose of ``link`` whose material point at ``r_ref`` is at ``P``, rotated (c, s)."""
        k = self.idx[link]
        dx, dy = self.sp.origins[k] - np.asarray(r_ref, float)
        self.c[k], self.s[k], self.th[k] = c, s, th
        if dx == 0.0 and dy == 0.0:
            self.x[k], self.y[k] = P[:, 0], P[:, 1]
        else:
            self.x[k] = P[:, 0] + c * dx - s * dy
            self.y[k] = P[:, 1] + s * dx + c * dy

    def place_dir(self, link: str, P, r_ref, d, d_ref) -> None:
        """As :meth:`place_cs`, the rotation taking direction ``d_ref`` to ``d`` (N, 2)."""
        cr, sr = _unit(d_ref)
        dx, dy = d[:, 0], d[:, 1]
        inv = 1.0 / np.sqrt(dx * dx + dy * dy)
        ca, sa = d[:, 0] * inv, d[:, 1] * inv
        c, s = ca * cr + sa * sr, sa * cr - ca * sr
        self.place_cs(link, P, r_ref, c, s, np.arctan2(s, c))

    def place_like(self, link: str, P, r_ref, other: str) -> None:
        k = self.idx[other]
        self.place_cs(link, P, r_ref, self.c[k], self.s[k], self.th[k])

    def invalidate(self, links, bad) -> None:
        if np.any(bad):
            for k in links:
                for name in ("x", "y", "th", "c", "s"):
                    arr = getattr(self, name)
                    arr[k] = np.where(bad, np.nan, arr[k])

    # -- conversion to / from the (M, n_links, 3) pose array --------------------------
    def to_Z(self, links=None) -> np.ndarray:
        nl = self.m.n_links
        ks = range(nl) if links is None else list(links) + [self.frame_k]
        Z = np.empty((self.M, nl, 3)) if links is None else np.full((self.M, nl, 3), np.nan)
        for k in ks:
            Z[:, k, 0], Z[:, k, 1], Z[:, k, 2] = self.x[k], self.y[k], self.th[k]
        return Z

    def from_Z(self, Z, links) -> None:
        for k in links:
            self.x[k], self.y[k], self.th[k] = Z[:, k, 0].copy(), Z[:, k, 1].copy(), Z[:, k, 2].copy()
            self.c[k], self.s[k] = np.cos(self.th[k]), np.sin(self.th[k])


def _known_on(st: StepPlan, joint: str) -> str:
    """The known link that a group's outer joint attaches to."""
    B = set(st.step.links)
    for c in st.step.constraints:
        if c.joint == joint and c.kind in ("R", "P"):
            if c.a not in B:
                return c.a
            if c.b not in B:
                return c.b
    raise KeyError(joint)  # pragma: no cover


def _choose_branch(cand_s, gap, sgn0, reach_ok, scale, alternate):
    """Branch sign per position: ``sgn0`` except after a crossing kept by prediction.

    ``cand_s`` (N, k) is a signature of the reference branch's solution and
    ``gap`` (N,) the distance between the two branches' signatures.  Where the
    branches come closer than the local motion, the candidate nearest to the
    linear prediction from the two previous positions is taken (a change is only
    accepted when the next position assembles: a true crossing, not a turning
    point).  ``alternate()`` returns the other branch's signatures (N, k); it is
    called only when such positions exist.
    Returns (signs (N,), event indices where the branch changed, alternates or None).
    """
    N = cand_s.shape[0]
    signs = np.full(N, float(sgn0))
    if N < 3:
        return signs, [], None
    mot = np.sqrt(np.sum(np.square(cand_s[1:] - cand_s[:-1]), axis=-1))
    local = np.empty(N)
    local[0], local[-1] = mot[0], mot[-1]
    np.fmax(mot[:-1], mot[1:], out=local[1:-1])
    near = (gap <= 3.0 * local) | (gap <= 1e-9 * scale)
    if not near[2:].any():
        return signs, [], None
    near[1:] |= near[:-1].copy()          # and the position right after a near-merge
    ev = np.flatnonzero(near)
    ev = ev[ev >= 2]
    cand_o = alternate()
    flips = []
    for n in ev:
        cur = np.where(signs[:, None] == sgn0, cand_s, cand_o)
        if not (np.all(np.isfinite(cur[n - 2:n])) and reach_ok[n]):
            continue
        pred = 2 * cur[n - 1] - cur[n - 2]
        here, other = cur[n], np.where(signs[n] == sgn0, cand_o[n], cand_s[n])
        if np.linalg.norm(other - pred) < np.linalg.norm(here - pred) and \
                n + 1 < N and reach_ok[n + 1]:
            signs[n:] *= -1.0
            flips.append(int(n))
    return signs, flips, cand_o


def _closed_dyad(sp: SolvePlan, st: StepPlan, G: _Poses, X: np.ndarray):
    import multiloop.kin.groups as K
    g: AssurGroup = st.step
    o1, inner, o2, l1, l2 = g.layout
    m = sp.mechanism
    kind = g.kind
    why: dict[int, str] = {}
    notes: list[str] = []
    scale = sp.size
    if kind == "RRR":
        Aref, Bref, Cref = G.at(o1), G.at(inner), G.at(o2)
        A = G.point(_known_on(st, o1), Aref)
        C = G.point(_known_on(st, o2), Cref)
        la, lc = np.hypot(*(Bref - Aref)), np.hypot(*(Bref - Cref))
        sgn0 = float(K.rrr_branch(Aref, Cref, Bref))
        rs = K.rrr_position(A, C, la, lc, sgn0)
        AC = C - A
        d = np.sqrt(AC[:, 0] * AC[:, 0] + AC[:, 1] * AC[:, 1])
        gap = 2.0 * np.abs(AC[:, 0] * (rs.B[:, 1] - A[:, 1]) - AC[:, 1] * (rs.B[:, 0] - A[:, 0])) / d
        signs, flips, alt = _choose_branch(rs.B, gap, sgn0, rs.ok, scale,
                                           lambda: K.rrr_position(A, C, la, lc, -sgn0).B)
        B = rs.B if not flips else np.where((signs == sgn0)[:, None], rs.B, alt)
        ok = rs.ok.copy()
        for n in np.flatnonzero(~ok):
            if np.isfinite(d[n]):
                why[n] = (f"no assembly: |{o1}{o2}| = {d[n]:.6g} > {la:.6g} + {lc:.6g} (out of reach)"
                          if d[n] > la + lc else
                          f"no assembly: |{o1}{o2}| = {d[n]:.6g} < |{la:.6g} − {lc:.6g}| (out of reach)")
        G.place_dir(l1, A, Aref, B - A, Bref - Aref)
        G.place_dir(l2, C, Cref, B - C, Bref - Cref)
        det, rdet = rs.det, la * lc
    elif kind == "RRP":
        Aref, Bref, Pref = G.at(o1), G.at(inner), G.at(o2)
        kp = _known_on(st, o2)
        u_ref = G.axis(o2)
        h = float(_nrm(u_ref) @ (Bref - Pref))
        A = G.point(_known_on(st, o1), Aref)
        P, u = G.point(kp, Pref), G.direction(kp, u_ref)
        la = np.hypot(*(Bref - Aref))
        sgn0 = float(K.rrp_branch(Aref, Bref, u_ref))
        rs = K.rrp_position(A, P, u, la, h, sgn0)
        gap = 2.0 * np.abs(np.sum((rs.B - A) * u, axis=-1))
        signs, flips, alt = _choose_branch(rs.B, gap, sgn0, rs.ok, scale,
                                           lambda: K.rrp_position(A, P, u, la, h, -sgn0).B)
        B = rs.B if not flips else np.where((signs == sgn0)[:, None], rs.B, alt)
        ok = rs.ok.copy()
        dist = np.abs(np.sum((A - P) * _nrm(u), axis=-1) - h)
        for n in np.flatnonzero(~ok):
            if np.isfinite(dist[n]):
                why[n] = (f"no assembly: {o1} is {dist[n]:.6g} from the track of {inner}, "
                          f"longer than {l1} ({la:.6g}) (out of reach)")
        G.place_dir(l1, A, Aref, B - A, Bref - Aref)
        G.place_like(l2, B, Bref, kp)
        det, rdet = rs.det, la
    elif kind == "RPR":
        # guide = the link of the P joint listed first; it is pivoted at X, the block at Y
        jp = m.joint(inner)
        guide = jp.links[0]
        gx, bx = (o1, o2) if guide == l1 else (o2, o1)      # guide pivot joint, block pivot joint
        Xref, Yref = G.at(gx), G.at(bx)
        u_ref = G.axis(inner)
        h = float(_nrm(u_ref) @ (Yref - Xref))
        Xp = G.point(_known_on(st, gx), Xref)
        Yp = G.point(_known_on(st, bx), Yref)
        sgn0 = float(K.rpr_branch(Yref, Xref, u_ref))
        rs = K.rpr_position(Yp, Xp, h, sgn0)
        fs = Xp + rs.s[:, None] * rs.u
        ro = []

        def _alt():
            ro.append(K.rpr_position(Yp, Xp, h, -sgn0))
            return Xp + ro[0].s[:, None] * ro[0].u
        signs, flips, _ = _choose_branch(fs, 2.0 * np.abs(rs.s), sgn0, rs.ok, scale, _alt)
        u = rs.u if not flips else np.where((signs == sgn0)[:, None], rs.u, ro[0].u)
        ok = rs.ok.copy()
        dist = np.hypot(*(Yp - Xp).T)
        for n in np.flatnonzero(~ok):
            if np.isfinite(dist[n]):
                why[n] = f"no assembly: |{gx}{bx}| = {dist[n]:.6g} < offset {abs(h):.6g} (out of reach)"
        blk = l2 if guide == l1 else l1
        G.place_dir(guide, Xp, Xref, u, u_ref)
        G.place_like(blk, Yp, Yref, guide)
        det, rdet = (rs.det if not flips else np.where(signs == sgn0, rs.det, ro[0].det)), scale
    elif kind == "PRP":
        Bref = G.at(inner)
        k1, k2 = _known_on(st, o1), _known_on(st, o2)
        u1r, u2r = G.axis(o1), G.axis(o2)
        h1 = float(_nrm(u1r) @ (Bref - G.at(o1)))
        h2 = float(_nrm(u2r) @ (Bref - G.at(o2)))
        r = K.prp_position(G.point(k1, G.at(o1)), G.direction(k1, u1r), h1,
                           G.point(k2, G.at(o2)), G.direction(k2, u2r), h2)
        B, ok, flips = r.B, r.ok.copy(), []
        G.place_like(l1, B, Bref, k1)
        G.place_like(l2, B, Bref, k2)
        det, rdet = r.det, 1.0
    elif kind == "RPP":
        Aref, Qref = G.at(o1), G.at(o2)
        kq = _known_on(st, o2)
        u_ref, w_ref = G.axis(o2), G.axis(inner)
        alpha = float(_angle(w_ref) - _angle(u_ref))
        h = float(_nrm(w_ref) @ (Aref - Qref))
        A = G.point(_known_on(st, o1), Aref)
        r = K.rpp_position(A, G.point(kq, Qref), G.direction(kq, u_ref), alpha, h)
        ok, flips = r.ok.copy(), []
        G.place_like(l2, r.Q, Qref, kq)
        G.place_like(l1, A, Aref, kq)
        det, rdet = r.det, 1.0
    else:  # pragma: no cover
        raise ValueError(kind)
    tol = _PARALLEL_GUIDES if kind in ("PRP", "RPP") else _SINGULAR
    sing = ok & ~(np.abs(det) > tol * rdet)
    for n in np.flatnonzero(sing):
        why[n] = f"singular position (dyad determinant {det[n]:.2e}: links or guides aligned)"
    ok &= ~sing
    for n in flips:
        notes.append(f"{st.label}: two assembly branches cross near position {n}; "
                     f"kept the continuous branch by prediction (assembly index changes there)")
    return ok, why, notes


_TRIAD_STATUS = {1: "no assembly (out of reach)", 2: "assembly modes collide / ambiguous step "
                 "(triad singular or turning point)", 3: "mode lost earlier in the batch"}


def _closed_triad(sp: SolvePlan, st: StepPlan, G: _Poses, X: np.ndarray):
    import multiloop.kin.groups as K
    g: AssurGroup = st.step
    tern, bins, outs, inns = g.layout
    Aref = np.array([G.at(o) for o in outs])
    b = np.array([G.at(i) for i in inns])
    lengths = np.hypot(*(b - Aref).T)
    A = np.stack([G.point(_known_on(st, o), G.at(o)) for o in outs], axis=1)
    N = G.M
    good = np.all(np.isfinite(A.reshape(N, -1)), axis=1)
    P = np.full((N, 3, 2), np.nan)
    th = np.full(N, np.nan)
    ok = np.zeros(N, bool)
    why: dict[int, str] = {}
    if good.any():
        idx = np.flatnonzero(good)
        r = K.triad_track(A[idx], b, lengths, b)
        P[idx], th[idx], ok[idx] = r.P, r.theta, r.ok
        for k, n in enumerate(idx):
            if not r.ok[k]:
                why[n] = _TRIAD_STATUS.get(int(r.status[k]), f"triad status {int(r.status[k])}")
    G.place_cs(tern, P[:, 0], b[0], np.cos(th), np.sin(th), th)
    for i, (lk, o) in enumerate(zip(bins, outs)):
        G.place_dir(lk, A[:, i], Aref[i], P[:, i] - A[:, i], b[i] - Aref[i])
    return ok, why, []


def _closed_class4(sp: SolvePlan, st: StepPlan, G: _Poses, X: np.ndarray):
    """Class IV order 2 group by the kernel's tracker (mode of the reference)."""
    import multiloop.kin.groups as K
    t1, t2, b0, b1, o1, o2, j1, j2, j3, j4 = st.step.layout
    Oref = np.array([G.at(o1), G.at(o2)])
    Jref = np.array([G.at(j) for j in (j1, j2, j3, j4)])
    r = Jref - Oref[[0, 0, 1, 1]]
    lengths = np.array([np.hypot(*(Jref[2] - Jref[0])), np.hypot(*(Jref[3] - Jref[1]))])
    O = np.stack([G.point(_known_on(st, o1), Oref[0]), G.point(_known_on(st, o2), Oref[1])], axis=1)
    N = G.M
    good = np.all(np.isfinite(O.reshape(N, -1)), axis=1)
    J = np.full((N, 4, 2), np.nan)
    th = np.full((N, 2), np.nan)
    ok = np.zeros(N, bool)
    why: dict[int, str] = {}
    if good.any():
        idx = np.flatnonzero(good)
        res = K.class4_track(O[idx], r, lengths, np.zeros(2))
        J[idx], th[idx], ok[idx] = res.J, res.theta, res.ok
        for k, n in enumerate(idx):
            if not res.ok[k]:
                why[n] = _TRIAD_STATUS.get(int(res.status[k]), f"class IV status {int(res.status[k])}")
    G.place_cs(t1, O[:, 0], Oref[0], np.cos(th[:, 0]), np.sin(th[:, 0]), th[:, 0])
    G.place_cs(t2, O[:, 1], Oref[1], np.cos(th[:, 1]), np.sin(th[:, 1]), th[:, 1])
    G.place_dir(b0, J[:, 0], Jref[0], J[:, 2] - J[:, 0], Jref[2] - Jref[0])
    G.place_dir(b1, J[:, 1], Jref[1], J[:, 3] - J[:, 1], Jref[3] - Jref[1])
    return ok, why, []


# ---------------------------------------------------------------------------------
# closed-form rates of dyads (kernels' Cramer 2×2 systems) on the pose arrays
def _perp2(v):
    return np.stack([-v[..., 1], v[..., 0]], axis=-1)


class _Rates:
    """Velocities/accelerations of material points from the pose arrays Z, Zd, Zdd."""

    def __init__(self, sp: SolvePlan, Z, Zd, Zdd):
        self.sp, self.Z, self.Zd, self.Zdd = sp, Z, Zd, Zdd
        self.idx = {x: i for i, x in enumerate(sp.mechanism.link_names)}

    def point(self, link: str, r):
        """Position, velocity, acceleration of ``link``'s material point at reference ``r``."""
        k = self.idx[link]
        rho = _rotate(np.asarray(r, float) - self.sp.origins[k], self.Z[:, k, 2])
        w, e = self.Zd[:, k, 2][:, None], self.Zdd[:, k, 2][:, None]
        pr = _perp2(rho)
        return (self.Z[:, k, :2] + rho, self.Zd[:, k, :2] + w * pr,
                self.Zdd[:, k, :2] + e * pr - w * w * rho)

    def direction(self, link: str, v):
        k = self.idx[link]
        return _rotate(v, self.Z[:, k, 2]), self.Zd[:, k, 2], self.Zdd[:, k, 2]

    def set(self, link: str, P, vP, aP, w, e) -> None:
        """Rates of ``link`` from those of its point at P and its ω, ε."""
        k = self.idx[link]
        rho = self.Z[:, k, :2] - P
        pr = _perp2(rho)
        w2, e2 = np.asarray(w)[:, None], np.asarray(e)[:, None]
        self.Zd[:, k, :2] = vP + w2 * pr
        self.Zd[:, k, 2] = w
        self.Zdd[:, k, :2] = aP + e2 * pr - w2 * w2 * rho
        self.Zdd[:, k, 2] = e


def _dyad_rates(sp: SolvePlan, st: StepPlan, Z, Zd, Zdd) -> None:
    import multiloop.kin.groups as K
    g: AssurGroup = st.step
    o1, inner, o2, l1, l2 = g.layout
    m = sp.mechanism
    R = _Rates(sp, Z, Zd, Zdd)

    def at(j):
        return np.asarray(m.joint(j).at, float)

    if g.kind == "RRR":
        A, vA, aA = R.point(_known_on(st, o1), at(o1))
        C, vC, aC = R.point(_known_on(st, o2), at(o2))
        B = R.point(l1, at(inner))[0]
        r = K.rrr_rates(A, C, B, vA, vC, aA, aC)
        R.set(l1, A, vA, aA, r.w2, r.e2)
        R.set(l2, C, vC, aC, r.w3, r.e3)
    elif g.kind == "RRP":
        kp = _known_on(st, o2)
        A, vA, aA = R.point(_known_on(st, o1), at(o1))
        P, vP, aP = R.point(kp, at(o2))
        u, w, e = R.direction(kp, _unit(m.joint(o2).axis))
        B = R.point(l1, at(inner))[0]
        r = K.rrp_rates(A, B, P, u, vA, vP, w, aA, aP, e)
        R.set(l1, A, vA, aA, r.w2, r.e2)
        R.set(l2, B, r.vB, r.aB, w, e)
    elif g.kind == "RPR":
        guide = m.joint(inner).links[0]
        gx, bx = (o1, o2) if guide == l1 else (o2, o1)
        blk = l2 if guide == l1 else l1
        Xp, vX, aX = R.point(_known_on(st, gx), at(gx))
        Yp, vY, aY = R.point(_known_on(st, bx), at(bx))
        u = _rotate(_unit(m.joint(inner).axis), Z[:, R.idx[guide], 2])
        r = K.rpr_rates(Yp, Xp, u, vY, vX, aY, aX)
        R.set(guide, Xp, vX, aX, r.w3, r.e3)
        R.set(blk, Yp, vY, aY, r.w3, r.e3)
    elif g.kind == "PRP":
        k1, k2 = _known_on(st, o1), _known_on(st, o2)
        P1, vP1, aP1 = R.point(k1, at(o1))
        P2, vP2, aP2 = R.point(k2, at(o2))
        u1, w1, e1 = R.direction(k1, _unit(m.joint(o1).axis))
        u2, w2, e2 = R.direction(k2, _unit(m.joint(o2).axis))
        B = R.point(l1, at(inner))[0]
        r = K.prp_rates(B, P1, u1, P2, u2, vP1, w1, vP2, w2, aP1, e1, aP2, e2)
        R.set(l1, B, r.vB, r.aB, w1, e1)
        R.set(l2, B, r.vB, r.aB, w2, e2)
    elif g.kind == "RPP":
        kq = _known_on(st, o2)
        alpha = float(_angle(_unit(m.joint(inner).axis)) - _angle(_unit(m.joint(o2).axis)))
        A, vA, aA = R.point(_known_on(st, o1), at(o1))
        P, vP, aP = R.point(kq, at(o2))
        u, w, e = R.direction(kq, _unit(m.joint(o2).axis))
        Q = R.point(l2, at(o2))[0]
        r = K.rpp_rates(A, Q, P, u, alpha, vA, vP, w, aA, aP, e)
        R.set(l2, Q, r.vQ, r.aQ, w, e)
        R.set(l1, A, vA, aA, w, e)
    else:  # pragma: no cover
        raise ValueError(g.kind)


def _driver_rates(sp: SolvePlan, st: StepPlan, Z, Zd, Zdd, rates_in) -> None:
    """Rates of a one-link driver step: ω = ω_base ± rate (R) or the base's (P)."""
    m = sp.mechanism
    cons = st.step.constraints
    lk = m.link_names[st.unknown[0]]
    d = next(c for c in cons if c.kind.startswith("drive"))
    R = _Rates(sp, Z, Zd, Zdd)
    rate = rates_in[d.driver]
    if d.kind == "drive_R":
        p = next(c for c in cons if c.kind == "R")
        other = d.a if d.b == lk else d.b
        sgn = 1.0 if d.b == lk else -1.0
        host = p.a if p.b == lk else p.b
        P, vP, aP = R.point(host, m.joint(p.joint).at)
        ko = R.idx[other]
        R.set(lk, P, vP, aP, Zd[:, ko, 2] + sgn * rate, Zdd[:, ko, 2].copy())
    else:
        jt = m.joint(d.joint)
        other = d.a if d.b == lk else d.b
        sgn = 1.0 if d.b == lk else -1.0
        P, vP, aP = R.point(other, jt.at)          # the known link's point at the joint
        u, w, e = R.direction(other, _unit(jt.axis))
        # the unknown link's material point at the joint sits at Q = P ± s u
        Q = R.point(lk, jt.at)[0]
        rel = Q - P
        w2 = w[:, None]
        vQ = vP + w2 * _perp2(rel) + sgn * rate * u
        aQ = aP + e[:, None] * _perp2(rel) - w2 * w2 * rel + 2.0 * w2 * sgn * rate * _perp2(u)
        R.set(lk, Q, vQ, aQ, w, e)
