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

from multiloop.topo.assur import AssurGroup, AssurPlan, DriverStep, GroupKind, decompose
from multiloop.topo.constraints import link_origins
from multiloop.topo.errors import (AssemblyError, InputError, SingularityError, SingularityWarning,
                         explain)
from multiloop.topo.model import JointKind, Mechanism

from .continuation import Probe, Walk, walk
from .groups.newton import ConstraintSystem, rates, track
from .result import MESSAGES, Status
from .rigid import move_point, perp, rotate, transport
from .state import KinematicState

__all__ = ["solve", "compile_plan", "plan_of", "SolvePlan", "StepPlan", "METHODS", "MAX_PATH"]

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
                "triad" if s.kind is GroupKind.TRIAD else
                ("class4" if s.kind is GroupKind.CLASS_IV and s.layout else "newton"))
            label = s.describe()
        # regularity at the reference configuration
        cols = (3 * np.asarray(unknown)[:, None] + np.arange(3)).ravel()
        J = sysm.jacobian(Z0)[0][:, cols]
        norms = np.prod(np.linalg.norm(J, axis=0))
        rel = abs(np.linalg.det(J)) / norms if norms > 0 else 0.0
        if rel < _SINGULAR:
            hint = "parallel guides of a PRP dyad or α = 0 of an RPP dyad are structurally singular" \
                if isinstance(s, AssurGroup) and s.kind in (GroupKind.PRP, GroupKind.RPP) else \
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


#: largest number of samples of a path (lead-in and fill-ins included) before it is refused
MAX_PATH = 1_000_000
#: largest step of the path followed by the tracked route (2°, or 2 % of the size)
_PATH_STEP = np.radians(2.0)
#: P-driver inputs beyond this multiple of the mechanism's size are refused
MAX_SLIDE = 1000.0
#: a position this near (scaled input) to a crossing of the branches is singular
_AT_CROSSING = 1e-9


@dataclass
class _Run:
    """Everything solved at a batch of inputs: poses, per-position codes and reasons."""

    G: "_Poses"
    code: np.ndarray                  # (M,) int8 Status of the first failing group
    reason: dict                      # n -> text (the group's label and why)
    probes: dict                      # step index -> Probe (only when asked)


def _run(sp: SolvePlan, X: np.ndarray, steps, signs: dict, kernels, probe: bool = False) -> _Run:
    """Solve the steps ``steps`` at the inputs ``X`` (M, n_drivers), the closed-form dyads
    on the branch ``reference sign × signs[k]`` (default 1)."""
    M = X.shape[0]
    G = _Poses(sp, M)
    code = np.zeros(M, np.int8)
    reason: dict[int, str] = {}
    probes = {}
    for k in steps:
        st = sp.steps[k]
        u = list(st.unknown)
        up = G.finite(np.setdiff1d(st.system.involved, u)) if probe else None
        if st.solver == "driver" and _driver_closed_form(st):
            okk, why = _solve_driver(sp, st, G, X)
            pr = Probe(okk) if probe else None
        elif st.solver in ("dyad", "triad", "class4") and kernels and st.step.kind in kernels:
            okk, why, pr = kernels[st.step.kind](sp, st, G, X, signs.get(k, 1.0), probe)
        else:
            known = np.setdiff1d(st.system.involved, u)
            Z = G.to_Z(known)
            Z[:, u, :2] = sp.origins[u]
            Z[:, u, 2] = 0.0
            tr = track(st.system, Z, X, u, singular_tol=_SINGULAR)
            G.from_Z(tr.Z, u)
            okk = tr.ok
            why = {int(n): (int(tr.code[n]), tr.reason[n]) for n in np.flatnonzero(~okk)}
            pr = Probe(okk.copy()) if probe else None
        if probe:
            probes[k] = Probe(pr.ok, pr.gap, pr.pts, up)
        for n in np.flatnonzero(~okk & (code == 0)):
            c, w = why.get(int(n), (Status.OUT_OF_REACH, "no assembly (out of reach)"))
            if c == Status.UPSTREAM:
                continue
            code[n] = c
            reason[int(n)] = f"{st.label}: {w}"
        G.invalidate(u, ~okk)
    return _Run(G, code, reason, probes)


def _scale(sp: SolvePlan) -> np.ndarray:
    """Input units per scaled unit: 1 (rad) for R drivers, the size (m) for P drivers."""
    m = sp.mechanism
    return np.array([1.0 if m.joint(d.joint).kind is JointKind.R else sp.size for d in m.drivers])


def _fill(nodes: np.ndarray, max_step: float) -> tuple[np.ndarray, np.ndarray]:
    """The polyline through ``nodes`` (K, d) sampled with steps ≤ ``max_step``; returns the
    samples and the index of each node among them."""
    d = np.sqrt(np.sum(np.square(np.diff(nodes, axis=0)), axis=1))
    k = np.maximum(np.ceil(d / max_step), 1).astype(np.int64)
    k[d == 0] = 1
    total = int(k.sum()) + 1
    if total > MAX_PATH:
        raise InputError(explain("inputs", expected=f"a path from the reference of at most {MAX_PATH} steps of "
                                 f"{np.degrees(max_step):.3g}° (R) or {max_step:g} × size (P)",
                                 got=f"{total} steps", hint="give inputs nearer to the reference "
                                 "(R inputs modulo 360°) or fewer positions"))
    seg = np.repeat(np.arange(len(k)), k)
    frac = (np.arange(total - 1) - np.repeat(np.cumsum(k) - k, k)) / np.repeat(k, k)
    out = np.empty((total, nodes.shape[1]))
    out[:-1] = nodes[seg] + frac[:, None] * (nodes[seg + 1] - nodes[seg])
    out[-1] = nodes[-1]
    idx = np.concatenate([[0], np.cumsum(k)])
    return out, idx


def _walk_on(sp: SolvePlan, kernels, P_scaled: np.ndarray) -> Walk:
    """:func:`kin.continuation.walk` of the whole mechanism along ``P_scaled``."""
    scale = _scale(sp)
    steps = list(range(len(sp.steps)))
    groups = [k for k in steps if sp.steps[k].solver != "driver"]

    def evaluate(Xs, signs):
        return _run(sp, Xs * scale, steps, signs, kernels, probe=True).probes
    return walk(evaluate, P_scaled, groups)


@dataclass(frozen=True)
class _Chart:
    """The motion of a one-driver mechanism of closed-form groups, from the reference.

    ``lo`` ≤ input ≤ ``hi`` is reachable (±inf when periodic); ``period`` is 2π or 4π
    for an R driver that turns without limit; ``flips[k]`` are the inputs (sorted) where
    group k's sign flips (crossings kept by the tangent rule); ``crossings`` (x, k) every
    crossing met; ``limits`` maps ``"lo"``/``"hi"`` to the step index stopping there.
    """

    lo: float
    hi: float
    period: float | None
    flips: dict
    crossings: tuple
    limits: dict
    is_r: bool

    def covers(self, x: np.ndarray) -> bool:
        return self.is_r or (x.size == 0 or (self.lo_req <= x.min() and x.max() <= self.hi_req))

    def reduce(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Chart coordinate of each input and whether the motion reaches it."""
        if self.period is not None:
            return np.mod(x, self.period), np.ones(x.shape, bool)
        if self.is_r:
            t = 2 * np.pi
            xr = x + t * np.ceil((self.lo - x) / t)
            with np.errstate(invalid="ignore"):
                reach = xr <= self.hi
            return np.where(reach, xr, x), reach
        return x, (x >= self.lo) & (x <= self.hi)

    def factor(self, k: int, xr: np.ndarray):
        """Sign factor of group k at chart coordinates ``xr`` (1.0 when it never flips)."""
        f = self.flips.get(k, ())
        if not f:
            return 1.0
        f = np.asarray(f)
        pos, neg = f[f > 0], f[f < 0]
        n = np.searchsorted(pos, xr, side="left") + (neg.size - np.searchsorted(neg, xr, side="right"))
        return np.where(n % 2 == 0, 1.0, -1.0)


def _walk_dir(sp: SolvePlan, kernels, extent: float, sign: float) -> Walk:
    n = int(np.ceil(extent / 0.02)) + 1
    return _walk_on(sp, kernels, sign * np.linspace(0.0, extent, n)[:, None])


def _build_chart(sp: SolvePlan, kernels, lo_req: float, hi_req: float) -> _Chart:
    """Walk up and down from the reference (one driver; scaled inputs)."""
    is_r = sp.mechanism.joint(sp.mechanism.drivers[0].joint).kind is JointKind.R
    scale = _scale(sp)[0]
    flips: dict = {}
    crossings, limits = [], {}
    ext_up = 2 * np.pi if is_r else max(hi_req / scale, 0.0)
    up = _walk_dir(sp, kernels, ext_up, 1.0) if ext_up > 0 else None
    period = None
    if is_r and up.block is None:
        odd = [k for k, f in up.flips.items() if len(f) % 2]
        if odd:
            up = _walk_dir(sp, kernels, 4 * np.pi, 1.0)
            odd = [k for k, f in up.flips.items() if len(f) % 2]
        period = (2 * np.pi if len(up.s) and up.s[-1] < 3 * np.pi else 4 * np.pi) if not odd else None
    hi = np.inf if period else (up.block[0] * scale if up is not None and up.block else
                                (up.s[-1] * scale if up is not None else 0.0))
    if up is not None:
        if up.block:
            limits["hi"] = up.block[2]
        for k, f in up.flips.items():
            flips.setdefault(k, []).extend(x * scale for x in f)
        crossings += [(x * scale, k) for x, k in up.crossings]
    lo = -np.inf if period else 0.0
    ext_dn = 2 * np.pi if is_r else max(-lo_req / scale, 0.0)
    if not period and ext_dn > 0:
        dn = _walk_dir(sp, kernels, ext_dn, -1.0)
        lo = -(dn.block[0] if dn.block else dn.s[-1]) * scale
        if dn.block:
            limits["lo"] = dn.block[2]
        for k, f in dn.flips.items():
            flips.setdefault(k, []).extend(-x * scale for x in f)
        crossings += [(-x * scale, k) for x, k in dn.crossings]
    ch = _Chart(lo, hi, period, {k: tuple(sorted(f)) for k, f in flips.items()},
                tuple(sorted(crossings)), limits, is_r)
    object.__setattr__(ch, "lo_req", lo_req if not is_r else -np.inf)
    object.__setattr__(ch, "hi_req", hi_req if not is_r else np.inf)
    return ch


def _chart(sp: SolvePlan, kernels, x: np.ndarray) -> _Chart:
    """The cached chart of ``sp`` covering the inputs ``x`` (built on first use)."""
    ch = sp.extra.get("chart")
    if ch is not None and ch.covers(x):
        return ch
    if not ch or ch.is_r:
        lo_req, hi_req = min(0.0, float(x.min(initial=0.0))), max(0.0, float(x.max(initial=0.0)))
    else:
        lo_req = min(ch.lo_req, float(x.min(initial=0.0)))
        hi_req = max(ch.hi_req, float(x.max(initial=0.0)))
    ch = _build_chart(sp, kernels, lo_req, hi_req)
    sp.extra["chart"] = ch
    return ch


def _fmt_x(sp: SolvePlan, k: int, v: float) -> str:
    m = sp.mechanism
    if m.joint(m.drivers[k].joint).kind is JointKind.R:
        return f"{np.degrees(v):.6g}°"
    return f"{v:.6g} m"


def _chartable(sp: SolvePlan, kernels) -> bool:
    if len(sp.mechanism.drivers) != 1 or not kernels:
        return False
    return all((st.solver == "driver" and _driver_closed_form(st)) or
               (st.solver == "dyad" and st.step.kind in kernels) for st in sp.steps)


def _mark_unreachable(sp, ch: _Chart, run: _Run, X, bad, kernels) -> None:
    """Rows the motion does not reach: ``other circuit`` where they assemble on the
    reference's signs, else ``unreachable: limit of …``."""
    idx = np.flatnonzero(bad)
    sub = _run(sp, X[idx], range(len(sp.steps)), {}, kernels)
    for j, n in enumerate(idx):
        x = float(X[n, 0])
        if sub.code[j] == Status.OK:
            run.code[n] = Status.OTHER_CIRCUIT
            run.reason[int(n)] = (f"other circuit: assembles at {_fmt_x(sp, 0, x)}, but no motion from the "
                                  f"reference reaches it (the motion stops at {_fmt_x(sp, 0, ch.lo)} "
                                  f"and {_fmt_x(sp, 0, ch.hi)})")
            continue
        side = _nearer_limit(ch, x)
        k = ch.limits.get(side)
        where = ch.hi if side == "hi" else ch.lo
        label = sp.steps[k].label if k is not None else "the mechanism"
        run.code[n] = Status.LIMIT
        run.reason[int(n)] = f"{label}: unreachable: limit at {_fmt_x(sp, 0, where)} (out of reach beyond it)"
    run.G.invalidate(range(sp.mechanism.n_links), bad)


def _nearer_limit(ch: _Chart, x: float) -> str:
    """``"hi"`` or ``"lo"``: the limit the input lies beyond (the nearer one, for R modulo 2π)."""
    if "lo" not in ch.limits or "hi" not in ch.limits:
        return "hi" if "hi" in ch.limits else "lo"
    up, dn = x - ch.hi, ch.lo - x
    if ch.is_r:
        up, dn = up % (2 * np.pi), dn % (2 * np.pi)
    return "hi" if up <= dn else "lo"


def _crossing_notes(sp, crossings, xs: np.ndarray, ok: np.ndarray, flips: dict, period=None) -> list[str]:
    """Notes for the crossings that the path between consecutive output rows passes."""
    notes = []
    for c, k in crossings:
        if period is not None:
            w = np.floor((xs - c) / period)
            hit = np.flatnonzero(np.diff(w) != 0)
        else:
            lo, hi = np.minimum(xs[:-1], xs[1:]), np.maximum(xs[:-1], xs[1:])
            hit = np.flatnonzero((lo < c) & (c < hi))
        flipped = c in flips.get(k, ())
        for n in hit:                  # xs[0] is the reference: xs[n] → xs[n+1] is row n−1 → row n
            if len(notes) >= 20:
                return notes + ["… more crossings not listed"]
            where = "the reference" if n == 0 else f"row {n - 1}"
            notes.append(f"{sp.steps[k].label}: its two assembly branches meet at input {_fmt_x(sp, 0, c)} "
                         f"(between {where} and row {n}); the motion keeps the mode of the reference"
                         f"{' (the sign of the assembly branch changes there)' if flipped else ''}")
    return notes


def _mark_crossings(sp, run: _Run, xr, reach, crossings, scale) -> None:
    for c, k in crossings:
        near = np.flatnonzero(reach & (np.abs(xr - c) <= _AT_CROSSING * scale))
        for n in near:
            run.code[n] = Status.SINGULAR
            run.reason[int(n)] = (f"{sp.steps[k].label}: singular position (its assembly branches meet "
                                  f"at {_fmt_x(sp, 0, c)})")
        run.G.invalidate(range(sp.mechanism.n_links), np.isin(np.arange(len(xr)), near))


def _solve_chart(sp: SolvePlan, X, needed, kernels) -> tuple[_Run, list]:
    """One driver, closed-form groups: the cached chart gives each input's branch."""
    x = X[:, 0]
    ch = _chart(sp, kernels, x)
    xr, reach = ch.reduce(x)
    signs = {k: ch.factor(k, xr) for k in ch.flips if ch.flips[k]}
    run = _run(sp, X, needed, signs, kernels)
    if not reach.all():
        _mark_unreachable(sp, ch, run, X, ~reach, kernels)
    notes = []
    if ch.crossings:
        _mark_crossings(sp, run, xr, reach, ch.crossings, _scale(sp)[0])
        xs = np.concatenate([[0.0], x if ch.period else xr])
        notes = _crossing_notes(sp, ch.crossings, xs, reach, ch.flips, ch.period)
    return run, notes


def _solve_path(sp: SolvePlan, X, needed, kernels) -> tuple[_Run, list]:
    """Any plan: follow the path reference → inputs[0] → inputs[1] … with certified steps."""
    from .continuation import path_parameter, sign_factor
    scale = _scale(sp)
    nodes = np.vstack([np.zeros((1, X.shape[1])), X / scale])
    P, idx = _fill(nodes, _PATH_STEP)
    steps = list(range(len(sp.steps)))
    groups = [k for k in steps if sp.steps[k].solver != "driver"]
    last = {}

    def evaluate(Xs, signs):
        last["run"] = _run(sp, Xs * scale, steps, signs, kernels, probe=True)
        last["n"] = Xs.shape[0]
        return last["run"].probes
    w = walk(evaluate, P, groups, refine_limits=False)
    s_nodes = path_parameter(P)
    s = w.s
    if only_all(sp, needed) and last.get("n") == len(s) and w.block is None:
        run = last["run"]                  # the walk's last round is the answer
    else:
        Xs = np.stack([np.interp(s, s_nodes, P[:, j]) for j in range(P.shape[1])], axis=1) * scale
        signs = {k: sign_factor(f, s) for k, f in w.flips.items() if f}
        run = _run(sp, Xs, needed, signs, kernels)
    rows = np.minimum(np.searchsorted(s, s_nodes[idx[1:]]), len(s) - 1)
    run = _take(run, rows)
    sn = s_nodes[idx[1:]]
    notes = []
    if w.block is not None:
        s_b, _, k = w.block
        xb = np.array([np.interp(s_b, s_nodes, P[:, j]) for j in range(P.shape[1])]) * scale
        where = ", ".join(_fmt_x(sp, j, v) for j, v in enumerate(xb))
        past = np.flatnonzero(sn > s_b)
        for n in past:
            run.code[n] = Status.LIMIT
            run.reason[int(n)] = f"{sp.steps[k].label}: unreachable: limit at {where} (out of reach beyond it)"
        run.G.invalidate(range(sp.mechanism.n_links), sn > s_b)
        if past.size:
            notes.append(f"the motion from the reference stops at the limit of {sp.steps[k].label} at "
                         f"{where}; rows {int(past[0])}… lie beyond it")
    for c, k in w.crossings:
        near = np.flatnonzero(np.abs(sn - c) <= 10 * _AT_CROSSING)
        for n in near:
            run.code[n] = Status.SINGULAR
            run.reason[int(n)] = f"{sp.steps[k].label}: singular position (its assembly branches meet here)"
        run.G.invalidate(range(sp.mechanism.n_links), np.isin(np.arange(len(sn)), near))
        after = np.flatnonzero(sn > c)
        if after.size:
            n = int(after[0])
            notes.append(f"{sp.steps[k].label}: its two assembly branches meet between "
                         f"{'the reference' if n == 0 else f'row {n - 1}'} and row {n}; the motion keeps "
                         f"the mode of the reference")
    return run, notes


def only_all(sp: SolvePlan, needed) -> bool:
    return len(needed) == len(sp.steps)


def _take(run: _Run, rows: np.ndarray) -> _Run:
    reason = {i: run.reason[int(r)] for i, r in enumerate(rows) if int(r) in run.reason}
    return _Run(run.G.take(rows), run.code[rows].copy(), reason, {})


def solve(mechanism: Mechanism, inputs, *, derivatives: bool = False, input_rates=None,
          only=None, plan=None, method: str = "auto", assemble: bool = False) -> KinematicState:
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
        A precompiled plan (default: the one cached on the mechanism).
    method : {"auto", "closed_form", "newton"}
        ``auto``/``closed_form``: closed-form dyads, triad kernel, Newton for the
        rest; ``newton``: every group by Newton with continuation.
    assemble : bool
        Solve every input independently, each dyad on the branch sign of the
        reference (no continuation: positions on other circuits come back ``ok``).
        Never the default.

    Returns
    -------
    KinematicState

    Raises
    ------
    AssemblyError, SingularityError
        Only for a single-position query (scalar input) that fails.
    InputError
        Bad shapes, unknown names in ``only``, unknown method, runaway inputs.

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
    sp = plan_of(m, plan)
    X, single = _as_inputs(m, inputs)
    _check_range(sp, X)
    needed = list(range(len(sp.steps))) if only is None else _needed_steps(sp, only)
    kernels = _kernels() if method != "newton" else None
    if assemble:
        run, notes = _run(sp, X, needed, {}, kernels), []
    elif _chartable(sp, kernels):
        run, notes = _solve_chart(sp, X, needed, kernels)
    else:
        run, notes = _solve_path(sp, X, needed, kernels)
    return _finish(sp, X, run, needed, notes, single, derivatives, input_rates, kernels)


def _check_range(sp: SolvePlan, X: np.ndarray) -> None:
    m = sp.mechanism
    for k, d in enumerate(m.drivers):
        if m.joint(d.joint).kind is JointKind.P and np.any(np.abs(X[:, k]) > MAX_SLIDE * sp.size):
            raise InputError(explain(f"input of the P driver {d.joint}",
                                     expected=f"a slide of at most {MAX_SLIDE:g} × the mechanism's size "
                                              f"({MAX_SLIDE * sp.size:.6g} m)",
                                     got=f"{np.max(np.abs(X[:, k])):.6g} m"))


def plan_of(mechanism: Mechanism, plan=None) -> SolvePlan:
    """The compiled plan: ``plan`` if given, else the one cached for ``mechanism``
    (compiled on first use and kept for the last 64 mechanisms, by identity; a
    mechanism is frozen, so its plan stays valid)."""
    if isinstance(plan, SolvePlan):
        return plan
    if plan is not None:
        return compile_plan(mechanism, plan)
    hit = _PLANS.get(id(mechanism))
    if hit is not None and hit[0] is mechanism:
        return hit[1]
    sp = compile_plan(mechanism)
    if len(_PLANS) >= _PLANS_KEPT:
        del _PLANS[next(iter(_PLANS))]
    _PLANS[id(mechanism)] = (mechanism, sp)      # holds the mechanism: its id stays unique
    return sp


#: compiled plans of the last mechanisms solved, by identity (Mechanism is frozen)
_PLANS: dict = {}
_PLANS_KEPT = 64


def _finish(sp, X, run: _Run, needed, notes, single, derivatives, input_rates, kernels) -> KinematicState:
    """Statuses, NaN for unsolved links, derivatives and the frozen state."""
    m = sp.mechanism
    G = run.G
    G.unset_to_nan()
    N = X.shape[0]
    code = run.code
    solved_links = [i for s in needed for i in sp.steps[s].unknown]
    finite = G.finite(solved_links)
    code[(code == 0) & ~finite] = Status.UPSTREAM
    okm = code == 0
    status = np.empty(N, dtype=object)
    status.fill("ok")                       # (np.full with an object is ~30x slower)
    for n in np.flatnonzero(~okm):
        status[n] = run.reason.get(int(n), MESSAGES[Status(int(code[n]))])
    Z = G.to_Z()
    Zd = Zdd = rates_in = None
    if derivatives:
        rates_in, Zd, Zdd = _derivatives(sp, Z, needed, okm, input_rates, kernels, solved_links)
    state = _state(sp, X, G, Z, Zd, Zdd, status, rates_in, tuple(notes), code)
    if single and code[0] != 0:
        msg = f"input {_fmt_input(m, X[0])}: {status[0]}"
        if code[0] == Status.SINGULAR:
            raise SingularityError(msg)
        raise AssemblyError(msg)
    if not single and np.any(code == Status.SINGULAR):
        warnings.warn("singular positions met: marked in status", SingularityWarning, stacklevel=3)
    return state


def _derivatives(sp, Z, needed, okm, input_rates, kernels, solved_links):
    m = sp.mechanism
    N = Z.shape[0]
    nd = len(m.drivers)
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
    solved = set(solved_links)
    unsolved = [k for k in range(m.n_links) if k not in solved and m.link_names[k] != m.frame]
    Zd[:, unsolved] = np.nan
    Zdd[:, unsolved] = np.nan
    Zd[~okm] = np.nan
    Zdd[~okm] = np.nan
    return rates_in, Zd, Zdd


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


def _state(sp: SolvePlan, X, G: "_Poses", Z, Zd, Zdd, status, rates_in, notes, code) -> KinematicState:
    m = sp.mechanism
    pos = _points(sp, G, sp.joint_host, "joints")
    vel = acc = om = ep = None
    if Zd is not None:
        host = np.asarray(sp.joint_host)
        vel, acc = transport(pos - Z[:, host, :2], Zd[:, host, :2], Zdd[:, host, :2], Zd[:, host, 2], Zdd[:, host, 2])
        om, ep = Zd[:, :, 2].copy(), Zdd[:, :, 2].copy()
    ppos = pvel = pacc = None
    if m.points:
        ph = np.asarray(sp.point_host)
        ppos = _points(sp, G, sp.point_host, "points")
        if Zd is not None:
            pvel, pacc = transport(ppos - Z[:, ph, :2], Zd[:, ph, :2], Zdd[:, ph, :2], Zd[:, ph, 2], Zdd[:, ph, 2])
    return KinematicState(m, X, pos, np.stack(G.th, axis=1), status, vel, acc, om, ep,
                          rates_in, point_names=tuple(p.name for p in m.points),
                          point_positions=ppos, point_velocities=pvel, point_accelerations=pacc,
                          notes=notes, poses=Z, pose_rates=Zd, pose_accelerations=Zdd, codes=code)


def _points(sp: SolvePlan, G: "_Poses", hosts, which: str) -> np.ndarray:
    """Positions ``(N, n, 2)`` of the joints' (or tracer points') material points, each
    carried by its host link's pose (one vectorised rigid transport for all of them)."""
    key = ("points", which)
    hit = sp.extra.get(key)
    if hit is None:
        items = sp.mechanism.joints if which == "joints" else sp.mechanism.points
        h = tuple(hosts)
        r = np.array([j.at for j in items], float).reshape(-1, 2) - sp.origins[list(h)]
        hit = sp.extra[key] = (h, r)
    h, r = hit
    col = lambda arrs: np.stack([np.broadcast_to(arrs[k], (G.M,)) for k in h], axis=1)  # noqa: E731
    c, s = col(G.c), col(G.s)
    out = np.empty((G.M, len(h), 2))
    out[..., 0] = col(G.x) + c * r[:, 0] - s * r[:, 1]
    out[..., 1] = col(G.y) + s * r[:, 0] + c * r[:, 1]
    return out


def _kernels():
    """Closed-form group solvers, or None when :mod:`kin.groups` is not importable."""
    try:
        import multiloop.kin.groups as K
    except ImportError:  # pragma: no cover - the kernels are part of the package
        return None
    need = {GroupKind.RRR: "rrr_position", GroupKind.RRP: "rrp_position", GroupKind.RPR: "rpr_position",
            GroupKind.PRP: "prp_position", GroupKind.RPP: "rpp_position", GroupKind.TRIAD: "triad_track",
            GroupKind.CLASS_IV: "class4_track"}
    special = {GroupKind.TRIAD: _closed_triad, GroupKind.CLASS_IV: _closed_class4}
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

    def take(self, rows: np.ndarray) -> "_Poses":
        """The poses at the given rows only."""
        out = object.__new__(_Poses)
        out.sp, out.m, out.M, out.idx, out.frame_k = self.sp, self.m, len(rows), self.idx, self.frame_k
        for name in ("x", "y", "th", "c", "s"):
            setattr(out, name, [None if a is None else a[rows] for a in getattr(self, name)])
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


@dataclass(frozen=True)
class _RRRConstants:
    """What an RRR step needs from its reference configuration, computed once per plan."""

    known1: str
    known2: str
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    la: float
    lc: float
    sign: float
    dir1: np.ndarray
    dir2: np.ndarray


def _rrr_constants(sp: SolvePlan, st: StepPlan) -> _RRRConstants:
    key = ("RRR", id(st))
    hit = sp.extra.get(key)
    if hit is None:
        import multiloop.kin.groups as K
        o1, inner, o2, _l1, _l2 = st.step.layout
        m = sp.mechanism
        A, B, C = (np.asarray(m.joint(j).at, float) for j in (o1, inner, o2))
        la, lc = float(np.hypot(*(B - A))), float(np.hypot(*(B - C)))
        hit = _RRRConstants(_known_on(st, o1), _known_on(st, o2), A, B, C, la, lc,
                            float(K.rrr_branch(A, C, B)), _unit(B - A), _unit(B - C))
        sp.extra[key] = hit
    return hit


def _closed_dyad(sp: SolvePlan, st: StepPlan, G: _Poses, X: np.ndarray, factor=1.0, probe=False):
    """A dyad in closed form on the branch ``sign of the reference × factor``.

    Returns ``(ok, why, probe)``: ``why[n] = (Status, text)`` for the failed
    positions, ``probe`` a :class:`~kin.continuation.Probe` when asked.
    """
    import multiloop.kin.groups as K
    g: AssurGroup = st.step
    o1, inner, o2, l1, l2 = g.layout
    m = sp.mechanism
    kind = g.kind
    why: dict[int, tuple] = {}
    pr = None
    scale = sp.size
    if kind is GroupKind.RRR:
        c = _rrr_constants(sp, st)
        Aref, Bref, Cref, la, lc = c.A, c.B, c.C, c.la, c.lc
        A = G.point(c.known1, Aref)
        C = G.point(c.known2, Cref)
        rs = K.rrr_position(A, C, la, lc, c.sign * factor)
        B = rs.B
        ok = rs.ok
        if probe or not ok.all():
            AC = C - A
            d = np.sqrt(AC[:, 0] * AC[:, 0] + AC[:, 1] * AC[:, 1])
        if probe:
            gap = 2.0 * np.abs(AC[:, 0] * (B[:, 1] - A[:, 1]) - AC[:, 1] * (B[:, 0] - A[:, 0])) / d
            pr = Probe(ok.copy(), gap, np.stack([B, A, C], axis=1))
        for n in np.flatnonzero(~ok):
            if np.isfinite(d[n]):
                why[int(n)] = (Status.OUT_OF_REACH,
                               f"no assembly: |{o1}{o2}| = {d[n]:.6g} > {la:.6g} + {lc:.6g} (out of reach)"
                               if d[n] > la + lc else
                               f"no assembly: |{o1}{o2}| = {d[n]:.6g} < |{la:.6g} − {lc:.6g}| (out of reach)")
        G.place_dir(l1, A, Aref, B - A, c.dir1)
        G.place_dir(l2, C, Cref, B - C, c.dir2)
        det, rdet = rs.det, la * lc
    elif kind is GroupKind.RRP:
        Aref, Bref, Pref = G.at(o1), G.at(inner), G.at(o2)
        kp = _known_on(st, o2)
        u_ref = G.axis(o2)
        h = float(_nrm(u_ref) @ (Bref - Pref))
        A = G.point(_known_on(st, o1), Aref)
        P, u = G.point(kp, Pref), G.direction(kp, u_ref)
        la = np.hypot(*(Bref - Aref))
        sgn0 = float(K.rrp_branch(Aref, Bref, u_ref))
        rs = K.rrp_position(A, P, u, la, h, sgn0 * factor)
        B = rs.B
        ok = rs.ok.copy()
        if probe:
            gap = 2.0 * np.abs(np.sum((B - A) * u, axis=-1))
            pr = Probe(ok.copy(), gap, np.stack([B, A, P], axis=1))
        dist = np.abs(np.sum((A - P) * _nrm(u), axis=-1) - h)
        for n in np.flatnonzero(~ok):
            if np.isfinite(dist[n]):
                why[int(n)] = (Status.OUT_OF_REACH, f"no assembly: {o1} is {dist[n]:.6g} from the track of "
                               f"{inner}, longer than {l1} ({la:.6g}) (out of reach)")
        G.place_dir(l1, A, Aref, B - A, Bref - Aref)
        G.place_like(l2, B, Bref, kp)
        det, rdet = rs.det, la
    elif kind is GroupKind.RPR:
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
        rs = K.rpr_position(Yp, Xp, h, sgn0 * factor)
        u = rs.u
        ok = rs.ok.copy()
        if probe:
            fs = Xp + rs.s[:, None] * u
            pr = Probe(ok.copy(), 2.0 * np.abs(rs.s), np.stack([fs, Xp, Yp], axis=1))
        dist = np.hypot(*(Yp - Xp).T)
        for n in np.flatnonzero(~ok):
            if np.isfinite(dist[n]):
                why[int(n)] = (Status.OUT_OF_REACH,
                               f"no assembly: |{gx}{bx}| = {dist[n]:.6g} < offset {abs(h):.6g} (out of reach)")
        blk = l2 if guide == l1 else l1
        G.place_dir(guide, Xp, Xref, u, u_ref)
        G.place_like(blk, Yp, Yref, guide)
        det, rdet = rs.det, scale
    elif kind is GroupKind.PRP:
        Bref = G.at(inner)
        k1, k2 = _known_on(st, o1), _known_on(st, o2)
        u1r, u2r = G.axis(o1), G.axis(o2)
        h1 = float(_nrm(u1r) @ (Bref - G.at(o1)))
        h2 = float(_nrm(u2r) @ (Bref - G.at(o2)))
        r = K.prp_position(G.point(k1, G.at(o1)), G.direction(k1, u1r), h1,
                           G.point(k2, G.at(o2)), G.direction(k2, u2r), h2)
        B, ok = r.B, r.ok.copy()
        G.place_like(l1, B, Bref, k1)
        G.place_like(l2, B, Bref, k2)
        det, rdet = r.det, 1.0
    elif kind is GroupKind.RPP:
        Aref, Qref = G.at(o1), G.at(o2)
        kq = _known_on(st, o2)
        u_ref, w_ref = G.axis(o2), G.axis(inner)
        alpha = float(_angle(w_ref) - _angle(u_ref))
        h = float(_nrm(w_ref) @ (Aref - Qref))
        A = G.point(_known_on(st, o1), Aref)
        r = K.rpp_position(A, G.point(kq, Qref), G.direction(kq, u_ref), alpha, h)
        ok = r.ok.copy()
        G.place_like(l2, r.Q, Qref, kq)
        G.place_like(l1, A, Aref, kq)
        det, rdet = r.det, 1.0
    else:  # pragma: no cover
        raise ValueError(kind)
    for n in np.flatnonzero(~ok):
        why.setdefault(int(n), (Status.OUT_OF_REACH, "no assembly (out of reach)"))
    tol = _PARALLEL_GUIDES if kind in (GroupKind.PRP, GroupKind.RPP) else _SINGULAR
    sing = ok & ~(np.abs(det) > tol * rdet)
    for n in np.flatnonzero(sing):
        why[int(n)] = (Status.SINGULAR, f"singular position (dyad determinant {det[n]:.2e}: links or guides aligned)")
    if pr is None and probe:       # PRP, RPP: one assembly; parallel guides are a pole, not a limit
        pr = Probe(ok.copy())
    ok &= ~sing
    return ok, why, pr


_TRIAD_STATUS = {1: (Status.OUT_OF_REACH, "no assembly (out of reach)"),
                 2: (Status.SINGULAR, "assembly modes collide / ambiguous step (triad singular or turning point)"),
                 3: (Status.MODE_LOST, "mode lost earlier in the path")}


def _closed_triad(sp: SolvePlan, st: StepPlan, G: _Poses, X: np.ndarray, factor=1.0, probe=False):
    import multiloop.kin.groups as K
    g: AssurGroup = st.step
    tern, bins, outs, inns = g.layout.ternary, g.layout.binaries, g.layout.outers, g.layout.inners
    Aref = np.array([G.at(o) for o in outs])
    b = np.array([G.at(i) for i in inns])
    lengths = np.hypot(*(b - Aref).T)
    A = np.stack([G.point(_known_on(st, o), G.at(o)) for o in outs], axis=1)
    N = G.M
    good = np.all(np.isfinite(A.reshape(N, -1)), axis=1)
    P = np.full((N, 3, 2), np.nan)
    th = np.full(N, np.nan)
    ok = np.zeros(N, bool)
    why: dict[int, tuple] = {}
    if good.any():
        idx = np.flatnonzero(good)
        r = K.triad_track(A[idx], b, lengths, b)
        P[idx], th[idx], ok[idx] = r.P, r.theta, r.ok
        for k, n in enumerate(idx):
            if not r.ok[k]:
                why[int(n)] = _TRIAD_STATUS.get(int(r.status[k]), (Status.MODE_LOST, "triad mode lost"))
    G.place_cs(tern, P[:, 0], b[0], np.cos(th), np.sin(th), th)
    for i, (lk, o) in enumerate(zip(bins, outs)):
        G.place_dir(lk, A[:, i], Aref[i], P[:, i] - A[:, i], b[i] - Aref[i])
    return ok, why, (Probe(ok.copy()) if probe else None)


def _closed_class4(sp: SolvePlan, st: StepPlan, G: _Poses, X: np.ndarray, factor=1.0, probe=False):
    """Class IV order 2 group by the kernel's tracker (mode of the reference)."""
    import multiloop.kin.groups as K
    lay = st.step.layout
    t1, t2, b0, b1, o1, o2 = lay.ternary1, lay.ternary2, lay.binary1, lay.binary2, lay.outer1, lay.outer2
    Oref = np.array([G.at(o1), G.at(o2)])
    Jref = np.array([G.at(j) for j in (lay.j11, lay.j12, lay.j21, lay.j22)])
    r = Jref - Oref[[0, 0, 1, 1]]
    lengths = np.array([np.hypot(*(Jref[2] - Jref[0])), np.hypot(*(Jref[3] - Jref[1]))])
    O = np.stack([G.point(_known_on(st, o1), Oref[0]), G.point(_known_on(st, o2), Oref[1])], axis=1)
    N = G.M
    good = np.all(np.isfinite(O.reshape(N, -1)), axis=1)
    J = np.full((N, 4, 2), np.nan)
    th = np.full((N, 2), np.nan)
    ok = np.zeros(N, bool)
    why: dict[int, tuple] = {}
    if good.any():
        idx = np.flatnonzero(good)
        res = K.class4_track(O[idx], r, lengths, np.zeros(2))
        J[idx], th[idx], ok[idx] = res.J, res.theta, res.ok
        for k, n in enumerate(idx):
            if not res.ok[k]:
                why[int(n)] = _TRIAD_STATUS.get(int(res.status[k]), (Status.MODE_LOST, "class IV mode lost"))
    G.place_cs(t1, O[:, 0], Oref[0], np.cos(th[:, 0]), np.sin(th[:, 0]), th[:, 0])
    G.place_cs(t2, O[:, 1], Oref[1], np.cos(th[:, 1]), np.sin(th[:, 1]), th[:, 1])
    G.place_dir(b0, J[:, 0], Jref[0], J[:, 2] - J[:, 0], Jref[2] - Jref[0])
    G.place_dir(b1, J[:, 1], Jref[1], J[:, 3] - J[:, 1], Jref[3] - Jref[1])
    return ok, why, (Probe(ok.copy()) if probe else None)


# ---------------------------------------------------------------------------------
# closed-form rates of dyads (kernels' Cramer 2×2 systems) on the pose arrays
class _Rates:
    """Velocities/accelerations of material points from the pose arrays Z, Zd, Zdd."""

    def __init__(self, sp: SolvePlan, Z, Zd, Zdd):
        self.sp, self.Z, self.Zd, self.Zdd = sp, Z, Zd, Zdd
        self.idx = {x: i for i, x in enumerate(sp.mechanism.link_names)}

    def point(self, link: str, r):
        """Position, velocity, acceleration of ``link``'s material point at reference ``r``."""
        k = self.idx[link]
        return move_point(self.Z[:, k, :2], self.Z[:, k, 2], np.asarray(r, float) - self.sp.origins[k],
                          self.Zd[:, k, :2], self.Zd[:, k, 2], self.Zdd[:, k, :2], self.Zdd[:, k, 2])

    def direction(self, link: str, v):
        k = self.idx[link]
        return rotate(v, self.Z[:, k, 2]), self.Zd[:, k, 2], self.Zdd[:, k, 2]

    def set(self, link: str, P, vP, aP, w, e) -> None:
        """Rates of ``link`` from those of its point at P and its ω, ε."""
        k = self.idx[link]
        self.Zd[:, k, :2], self.Zdd[:, k, :2] = transport(self.Z[:, k, :2] - P, vP, aP, w, e)
        self.Zd[:, k, 2] = w
        self.Zdd[:, k, 2] = e


def _dyad_rates(sp: SolvePlan, st: StepPlan, Z, Zd, Zdd) -> None:
    import multiloop.kin.groups as K
    g: AssurGroup = st.step
    o1, inner, o2, l1, l2 = g.layout
    m = sp.mechanism
    R = _Rates(sp, Z, Zd, Zdd)

    def at(j):
        return np.asarray(m.joint(j).at, float)

    if g.kind is GroupKind.RRR:
        A, vA, aA = R.point(_known_on(st, o1), at(o1))
        C, vC, aC = R.point(_known_on(st, o2), at(o2))
        B = R.point(l1, at(inner))[0]
        r = K.rrr_rates(A, C, B, vA, vC, aA, aC)
        R.set(l1, A, vA, aA, r.w2, r.e2)
        R.set(l2, C, vC, aC, r.w3, r.e3)
    elif g.kind is GroupKind.RRP:
        kp = _known_on(st, o2)
        A, vA, aA = R.point(_known_on(st, o1), at(o1))
        P, vP, aP = R.point(kp, at(o2))
        u, w, e = R.direction(kp, _unit(m.joint(o2).axis))
        B = R.point(l1, at(inner))[0]
        r = K.rrp_rates(A, B, P, u, vA, vP, w, aA, aP, e)
        R.set(l1, A, vA, aA, r.w2, r.e2)
        R.set(l2, B, r.vB, r.aB, w, e)
    elif g.kind is GroupKind.RPR:
        guide = m.joint(inner).links[0]
        gx, bx = (o1, o2) if guide == l1 else (o2, o1)
        blk = l2 if guide == l1 else l1
        Xp, vX, aX = R.point(_known_on(st, gx), at(gx))
        Yp, vY, aY = R.point(_known_on(st, bx), at(bx))
        u = rotate(_unit(m.joint(inner).axis), Z[:, R.idx[guide], 2])
        r = K.rpr_rates(Yp, Xp, u, vY, vX, aY, aX)
        R.set(guide, Xp, vX, aX, r.w3, r.e3)
        R.set(blk, Yp, vY, aY, r.w3, r.e3)
    elif g.kind is GroupKind.PRP:
        k1, k2 = _known_on(st, o1), _known_on(st, o2)
        P1, vP1, aP1 = R.point(k1, at(o1))
        P2, vP2, aP2 = R.point(k2, at(o2))
        u1, w1, e1 = R.direction(k1, _unit(m.joint(o1).axis))
        u2, w2, e2 = R.direction(k2, _unit(m.joint(o2).axis))
        B = R.point(l1, at(inner))[0]
        r = K.prp_rates(B, P1, u1, P2, u2, vP1, w1, vP2, w2, aP1, e1, aP2, e2)
        R.set(l1, B, r.vB, r.aB, w1, e1)
        R.set(l2, B, r.vB, r.aB, w2, e2)
    elif g.kind is GroupKind.RPP:
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
        vQ = vP + w2 * perp(rel) + sgn * rate * u
        aQ = aP + e[:, None] * perp(rel) - w2 * w2 * rel + 2.0 * w2 * sgn * rate * perp(u)
        R.set(lk, Q, vQ, aQ, w, e)
