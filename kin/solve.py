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
from dataclasses import dataclass, replace
from functools import cached_property
from types import MappingProxyType

import numpy as np

from multiloop.topo.assur import AssurPlan, DriverStep, decompose
from multiloop.topo.constraints import link_origins
from multiloop.topo.errors import (AssemblyError, InputError, SingularityError, SingularityWarning,
                         explain)
from multiloop.topo.model import JointKind, Mechanism
from multiloop.topo.recent import Recent

from . import kernel
from .continuation import Walk, walk
from .groups.newton import ConstraintSystem, relative_det
from .groups.registry import closed_form_step, newton_step, singular_hint
from .groups.step import SINGULAR
from .memo import cached, memo_of
from .motion import DriverMotion
from .poses import PoseRates, Poses, rates_of
from .result import MESSAGES, Status
from .rigid import transport
from .state import KinematicState

__all__ = ["solve", "solved_alone", "compile_plan", "plan_of", "SolvePlan", "StepPlan", "METHODS", "MAX_PATH",
           "motion_events", "check_finite_inputs", "held_text"]

#: the solvers of the groups (the first is the default): closed forms where a kind has one, or Newton
METHODS = ("auto", "closed_form", "newton")
_SINGULAR = SINGULAR       # relative determinant below which a position is singular


@dataclass(frozen=True, eq=False)
class StepPlan:
    """One compiled step: which links it solves and how."""

    step: object                      # DriverStep or AssurGroup
    system: ConstraintSystem
    unknown: tuple[int, ...]          # link indices
    solver: str                       # "driver", "dyad" (an actuated triangle too), "triad", "class4", "newton"
    label: str
    closed: object = None             # its closed-form step (kin.groups.step protocol), if any
    newton: object = None             # Newton with continuation: any step

    @cached_property
    def known(self) -> np.ndarray:
        """The links its equations involve that an earlier step solves (its inputs)."""
        return np.setdiff1d(self.system.involved, self.unknown)


@dataclass(frozen=True, eq=False)
class SolvePlan:
    """A mechanism's Assur plan compiled for the solvers (build once, reuse).

    Every field is set by :func:`compile_plan` and never changes (``origins`` is a
    read-only array).  Values derived on demand (the chart of the driver's motion, the
    kernel plan, the steps an output needs) are kept beside the plan by :mod:`kin.memo`.
    """

    mechanism: Mechanism
    assur: AssurPlan
    steps: tuple[StepPlan, ...]
    origins: np.ndarray               # (n_links, 2) link reference points
    joint_host: tuple[int, ...]       # link index carrying each joint's point
    joint_step: tuple[int, ...]       # step index solving that link (-1 frame)
    size: float                       # mechanism size (m), for tolerances
    point_host: tuple[int, ...] = ()
    origins_xy: tuple = ()            # the link reference points as Python floats (the pose store's)
    joint_offsets: tuple = ()         # each joint's point from its host link's reference point
    point_offsets: tuple = ()         # the same for each tracer point


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
    size = m.size
    Z0 = np.zeros((1, len(names), 3))
    Z0[0, :, :2] = origins
    for k, s in enumerate(ap.steps):
        sysm = ConstraintSystem.compile(m, s.constraints)
        links = (s.link,) if isinstance(s, DriverStep) else s.links
        unknown = tuple(idx[x] for x in links)
        label = f"driver {s.joint} (I{s.number})" if isinstance(s, DriverStep) else s.describe()
        # regularity at the reference configuration
        cols = (3 * np.asarray(unknown)[:, None] + np.arange(3)).ravel()
        rel = float(relative_det(sysm.jacobian(Z0)[0][:, cols]))      # the same at any scale and place
        if rel < _SINGULAR:
            hint = singular_hint(s) or "move a joint so that the group is not at a dead centre / toggle position"
            raise SingularityError(explain(
                f"mechanism '{m.name or ''}': {label}", expected="a regular group in the reference configuration",
                got=f"a singular one (relative determinant {rel:.1e})", hint=hint))
        st = StepPlan(s, sysm, unknown, "newton", label)
        closed = closed_form_step(m, st, size)
        # the solver's name is the closed-form step's (the registry's), else Newton's
        solver = "driver" if isinstance(s, DriverStep) else (closed.solver if closed is not None else "newton")
        steps.append(replace(st, solver=solver, closed=closed, newton=newton_step(m, st, size)))
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
    origins.flags.writeable = False
    return SolvePlan(m, ap, tuple(steps), origins, tuple(host), tuple(hstep), size, pts,
                     tuple(map(tuple, origins.tolist())), _offsets(m.joints, host, origins),
                     _offsets(m.points, pts, origins))


def _offsets(items, hosts, origins: np.ndarray) -> tuple:
    """Each item's point (``at``) from its host link's reference point, as Python floats."""
    r = np.array([j.at for j in items], float).reshape(-1, 2) - origins[list(hosts)]
    return tuple(map(tuple, r.tolist()))


# ---------------------------------------------------------------------------------
def _as_inputs(m: Mechanism, inputs) -> tuple[np.ndarray, bool]:
    """``inputs`` as an (N, n_drivers) array of floats and whether it was one position;
    their shape checked, not their values (:func:`_check_inputs`: the compiled
    route's kernel refuses a NaN or an infinity itself, and the general route checks)."""
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
    return x, single


def check_finite_inputs(m: Mechanism, x: np.ndarray, what: str = "inputs") -> None:
    """Refuse driver inputs ``x`` (..., n_drivers) with a NaN or an infinity, naming the
    first one's index and its driver."""
    if np.isfinite(x).all():
        return
    bad = np.argwhere(~np.isfinite(x))
    if bad.size:
        i = tuple(int(v) for v in bad[0])
        raise InputError(explain(f"{what}[{', '.join(map(str, i))}] (driver {m.drivers[i[-1]].joint!r})",
                                 expected="finite numbers", got=repr(float(x[i]))))


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

    G: "Poses"
    code: np.ndarray                  # (M,) int8 Status of the first failing group
    reason: dict                      # n -> text (the group's label and why)
    probes: dict                      # step index -> Probe (only when asked)
    direct: np.ndarray | None = None  # (M, n_joints + n_points, 2) from the kernel, valid while every code is 0


def _run(sp: SolvePlan, X: np.ndarray, steps, signs: dict, kernels, probe: bool = False,
         explain: bool = True) -> _Run:
    """Solve the steps ``steps`` at the inputs ``X`` (M, n_drivers), the closed-form dyads
    on the branch ``reference sign × signs[k]`` (default 1): by the compiled kernel when
    it covers them (:mod:`kin.kernel`), else by the NumPy path (:func:`_numpy_run`).
    ``explain=False``: the failures' texts are not written (a walk reads its probes alone)."""
    if kernels and not probe:
        run = _compiled_run(sp, X, steps, signs, kernels)
        if run is not None:
            return run
    return _numpy_run(sp, X, steps, signs, kernels, probe, explain)


def _compiled_run(sp: SolvePlan, X: np.ndarray, steps, signs: dict, kernels) -> _Run | None:
    """:func:`_run` by the compiled kernel, or None when it is not wanted for this batch
    (:func:`kin.kernel.wanted`) or a step has no compiled form.  The rows that fail are
    solved again by the NumPy path, which gives their statuses and reasons."""
    if not kernel.wanted(X.shape[0]):
        return None
    kp = kernel.kernel_plan(sp)
    if not kp.covers(steps):
        return None
    G = Poses(sp, X.shape[0])
    kr = kernel.run_positions(kp, X, steps, signs, G.T, points=only_all(sp, steps))
    C, S, fail = kr.C, kr.S, kr.fail
    links = [i for k in steps for i in sp.steps[k].unknown]
    G.adopt(links, C, S, kr.derived)
    if not kr.failed:
        return _Run(G, fail, {}, {}, kr.points)
    bad = np.flatnonzero(fail)
    sub = _numpy_run(sp, X[bad], steps, {k: v[bad] if np.ndim(v) else v for k, v in signs.items()}, kernels)
    sub.G.angles()
    for k in links:
        G.T[k][:, bad] = sub.G.T[k]
        C[k, bad], S[k, bad] = sub.G.c[k], sub.G.s[k]
    fail[bad] = sub.code
    return _Run(G, fail, {int(bad[i]): text for i, text in sub.reason.items()}, {})


def _numpy_run(sp: SolvePlan, X: np.ndarray, steps, signs: dict, kernels, probe: bool = False,
               explain: bool = True) -> _Run:
    """:func:`_run` by the NumPy kernels of the steps (each vectorised over the batch):
    the compiled kernel's oracle, and the solver of every step it does not cover."""
    M = X.shape[0]
    G = Poses(sp, M)
    G.explain = G.explain and explain
    code = np.zeros(M, np.int8)
    reason: dict[int, str] = {}
    probes = {}
    for k in steps:
        st = sp.steps[k]
        up = G.finite(st.known) if probe else None
        okk, why, pr = _step(st, kernels).positions(G, X, signs.get(k, 1.0), probe)
        if probe:
            probes[k] = replace(pr, up=up)
        if okk.all():
            continue
        for n in np.flatnonzero(~okk & (code == 0)):
            c, w = why.get(int(n), (Status.OUT_OF_REACH, "no assembly (out of reach)"))
            if c == Status.UPSTREAM:
                continue
            code[n] = c
            reason[int(n)] = f"{st.label}: {w}"
        G.invalidate(st.unknown, ~okk)
    return _Run(G, code, reason, probes)


def _scale(sp: SolvePlan) -> np.ndarray:
    """Input units per scaled unit: 1 (rad) for R drivers, the size (m) for P drivers."""
    m = sp.mechanism
    return np.array([1.0 if m.is_rotary(d) else sp.size for d in m.drivers])


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


def _with_curvatures(sp: SolvePlan, run: _Run, kernels, scale: np.ndarray) -> dict:
    """The probes of ``run`` with each dyad's |d²margin/ds²| (s: the scaled input of a
    one-driver mechanism; the second derivative along a line does not depend on its
    direction).  Mechanisms with several drivers keep their probes as they are."""
    probes = run.probes
    curved = [k for k, pr in probes.items() if pr.margin is not None
              and hasattr(_step(sp.steps[k], kernels), "margin_curvature")]
    if len(sp.mechanism.drivers) != 1 or not curved:
        return probes
    Z = run.G.to_Z()
    R = PoseRates(sp, Z, np.zeros_like(Z), np.zeros_like(Z))
    with np.errstate(all="ignore"):
        for k in range(max(curved) + 1):
            _step(sp.steps[k], kernels).rates(R, np.ones(1))
        return {**probes, **{k: replace(probes[k], curv=_step(sp.steps[k], kernels).margin_curvature(R)
                                        * scale[0] ** 2) for k in curved}}


def _walk_on(sp: SolvePlan, kernels, P_scaled: np.ndarray) -> Walk:
    """:func:`kin.continuation.walk` of the whole mechanism along ``P_scaled``."""
    scale = _scale(sp)
    steps = list(range(len(sp.steps)))
    groups = [k for k in steps if sp.steps[k].solver != "driver"]

    def evaluate(Xs, signs):
        return _with_curvatures(sp, _run(sp, Xs * scale, steps, signs, kernels, probe=True, explain=False),
                                kernels, scale)
    return walk(evaluate, P_scaled, groups)


@dataclass(frozen=True)
class _Chart:
    """The motion of driver ``k`` from the reference (the only driver, or one of several
    moved while the others are held at the reference).

    ``lo`` ≤ input ≤ ``hi`` is reachable (±inf when periodic); ``period`` is 2π or 4π
    for an R driver that turns without limit; ``flips[k]`` are the inputs (sorted) where
    group k's sign flips (crossings kept by the tangent rule); ``crossings`` (x, k) every
    crossing met; ``limits`` maps ``"lo"``/``"hi"`` to the step index stopping there.
    """

    lo: float
    hi: float
    period: float | None
    flips: MappingProxyType
    crossings: tuple
    limits: MappingProxyType
    is_r: bool
    lo_req: float                     # the P driver's inputs the chart was built for (±inf: R)
    hi_req: float
    k: int = 0                        # the driver moved

    @property
    def one_branch(self) -> bool:
        """Every input is reached on the reference branch of every group: a full turn
        with no sign flip and no crossing (no input needs reducing to the chart)."""
        return self.period is not None and not self.crossings and not any(self.flips.values())

    def covers(self, x: np.ndarray) -> bool:
        return self.is_r or (x.size == 0 or (self.lo_req <= x.min() and x.max() <= self.hi_req))

    def reduce(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Chart coordinate of each input and whether the motion reaches it."""
        if self.period is not None:
            return np.mod(x, self.period), np.ones(x.shape, bool)
        if self.is_r:                 # inside the range as it is, else the nearest turn into it
            t = 2 * np.pi
            inside = (x >= self.lo) & (x <= self.hi)
            up = x + t * np.ceil((self.lo - x) / t)
            dn = x - t * np.ceil((x - self.hi) / t)
            up_ok, dn_ok = up <= self.hi, dn >= self.lo
            pick = np.where(up_ok & (~dn_ok | (np.abs(up - x) <= np.abs(dn - x))), up, dn)
            reach = inside | up_ok | dn_ok
            return np.where(inside, x, np.where(reach, pick, x)), reach
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


def _walk_dir(sp: SolvePlan, kernels, extent: float, sign: float, k: int = 0) -> Walk:
    """The walk of driver ``k`` from the reference to ``sign × extent`` (scaled), kept
    with the plan: a chart widened on its other side walks only that side again."""
    def walked(sp, _):
        n = int(np.ceil(extent / 0.02)) + 1
        return _walk_on(sp, kernels, DriverMotion.held(sp.mechanism, k).inputs(sign * np.linspace(0.0, extent, n)))
    return cached(sp, ("walk", k, sign, extent, bool(kernels)), walked)


def _walked(walk, scale: float, asked: float, is_r: bool) -> float:
    """How far an unblocked walk went (input units): a slide's walk reaches the extent
    asked for, exactly (``asked / scale * scale`` may fall an ulp short of it)."""
    return walk.s[-1] * scale if is_r else max(walk.s[-1] * scale, asked)


def _build_chart(sp: SolvePlan, kernels, lo_req: float, hi_req: float, d: int = 0) -> _Chart:
    """Walk driver ``d`` up and down from the reference (the others held; scaled inputs)."""
    is_r = sp.mechanism.is_rotary(d)
    scale = _scale(sp)[d]
    flips: dict = {}
    crossings, limits = [], {}
    ext_up = 2 * np.pi if is_r else max(hi_req / scale, 0.0)
    up = _walk_dir(sp, kernels, ext_up, 1.0, d) if ext_up > 0 else None
    period = None
    if is_r and up.block is None:
        odd = [k for k, f in up.flips.items() if len(f) % 2]
        if odd:
            up = _walk_dir(sp, kernels, 4 * np.pi, 1.0, d)
            odd = [k for k, f in up.flips.items() if len(f) % 2]
        period = (2 * np.pi if len(up.s) and up.s[-1] < 3 * np.pi else 4 * np.pi) if not odd else None
    hi = np.inf if period else (up.block[0] * scale if up is not None and up.block else
                                (_walked(up, scale, hi_req, is_r) if up is not None else 0.0))
    if up is not None:
        if up.block:
            limits["hi"] = up.block[2]
        for k, f in up.flips.items():
            flips.setdefault(k, []).extend(x * scale for x in f)
        crossings += [(x * scale, k) for x, k in up.crossings]
    lo = -np.inf if period else 0.0
    ext_dn = 2 * np.pi if is_r else max(-lo_req / scale, 0.0)
    if not period and ext_dn > 0:
        dn = _walk_dir(sp, kernels, ext_dn, -1.0, d)
        lo = -dn.block[0] * scale if dn.block else -_walked(dn, scale, -lo_req, is_r)
        if dn.block:
            limits["lo"] = dn.block[2]
        for k, f in dn.flips.items():
            flips.setdefault(k, []).extend(-x * scale for x in f)
        crossings += [(-x * scale, k) for x, k in dn.crossings]
    return _Chart(lo, hi, period, MappingProxyType({k: tuple(sorted(f)) for k, f in flips.items()}),
                  tuple(sorted(crossings)), MappingProxyType(limits), is_r,
                  lo_req if not is_r else -np.inf, hi_req if not is_r else np.inf, d)


def _chart(sp: SolvePlan, kernels, x: np.ndarray, k: int = 0) -> _Chart:
    """The cached chart of driver ``k`` of ``sp`` covering its inputs ``x`` (built on
    first use; one per driver of a mechanism with several)."""
    memo = memo_of(sp)
    key = "chart" if len(sp.mechanism.drivers) == 1 else ("chart", k)
    ch = memo.get(key)
    if ch is not None and ch.covers(x):
        return ch
    if not ch or ch.is_r:
        lo_req, hi_req = min(0.0, float(x.min(initial=0.0))), max(0.0, float(x.max(initial=0.0)))
    else:
        lo_req = min(ch.lo_req, float(x.min(initial=0.0)))
        hi_req = max(ch.hi_req, float(x.max(initial=0.0)))
    ch = memo[key] = _build_chart(sp, kernels, lo_req, hi_req, k)
    return ch


def motion_events(mechanism: Mechanism, plan=None, extent: float | tuple[float, float] | None = None,
                  k: int | None = None) -> DriverMotion | None:
    """The certified motion of a one-driver mechanism, or of its driver ``k`` moved with
    the others held at the reference (:class:`~kin.motion.DriverMotion`): its ends,
    whether it turns fully, every crossing and the groups at its limits, found by the
    certified walk (:mod:`kin.continuation`), none read off a grid.  ``extent`` (m)
    bounds the search of a P driver: ± a length (default: the mechanism's size), or the
    pair (low, high) of its inputs (a driver's ``range``).  None for a mechanism with
    several drivers when ``k`` is not given."""
    sp = plan_of(mechanism, plan)
    if k is None and len(sp.mechanism.drivers) != 1:
        return None
    k = 0 if k is None else k
    span = sp.size if extent is None else extent
    ends = np.array([min(span[0], 0.0), max(span[1], 0.0)] if np.ndim(span) else [-float(span), float(span)])
    ch = _chart(sp, True, ends, k)
    return DriverMotion(sp.mechanism, k, ch.lo, ch.hi, ch.period,
                        tuple((c, sp.steps[k].label) for c, k in ch.crossings),
                        MappingProxyType({side: sp.steps[k].label for side, k in ch.limits.items()}))


def _fmt_x(sp: SolvePlan, k: int, v: float) -> str:
    m = sp.mechanism
    if m.is_rotary(k):
        return f"{np.degrees(v):.6g}°"
    return f"{v:.6g} m"


def _chartable(sp: SolvePlan, kernels) -> bool:
    if not kernels:
        return False
    return all(st.solver in ("driver", "dyad") and st.closed is not None for st in sp.steps)


def solved_alone(plan) -> bool:
    """Whether :func:`solve` solves each input of a batch that moves one driver (the
    others held at the reference) on its own: a plan of drivers and closed-form dyads,
    whose branch at an input the driver's chart gives (no path is followed to it, so the
    other inputs of the batch change none of its values)."""
    return isinstance(plan, SolvePlan) and _chartable(plan, True)


def _moving_driver(X: np.ndarray) -> int | None:
    """The driver whose input moves in ``X`` (M, n_drivers): the only one, or the one
    column of several that is not all at the reference (the others held, as a check
    moves each driver in turn); None when none or several move."""
    if X.shape[1] == 1:
        return 0
    moving = np.flatnonzero(np.any(X != 0.0, axis=0))
    return int(moving[0]) if moving.size == 1 else None


def _mark_unreachable(sp, ch: _Chart, run: _Run, X, bad, kernels) -> None:
    """Rows the motion does not reach: ``other circuit`` where they assemble on the
    reference's signs, else ``unreachable: limit of …``."""
    idx = np.flatnonzero(bad)
    sub = _run(sp, X[idx], range(len(sp.steps)), {}, kernels)
    for j, n in enumerate(idx):
        x = float(X[n, ch.k])
        if sub.code[j] == Status.OK:
            run.code[n] = Status.OTHER_CIRCUIT
            run.reason[int(n)] = (f"other circuit: assembles at {held_text(sp, ch.k, x)}, but no motion from the "
                                  f"reference reaches it (the motion stops at {held_text(sp, ch.k, ch.lo)} "
                                  f"and {held_text(sp, ch.k, ch.hi)})")
            continue
        side = _nearer_limit(ch, x)
        k = ch.limits.get(side)
        where = ch.hi if side == "hi" else ch.lo
        label = sp.steps[k].label if k is not None else "the mechanism"
        run.code[n] = Status.LIMIT
        run.reason[int(n)] = f"{label}: unreachable: limit at {held_text(sp, ch.k, where)} (out of reach beyond it)"
    run.G.invalidate(range(sp.mechanism.n_links), bad)


def _nearer_limit(ch: _Chart, x: float) -> str:
    """``"hi"`` or ``"lo"``: the limit the input lies beyond (the nearer one, for R modulo 2π)."""
    if "lo" not in ch.limits or "hi" not in ch.limits:
        return "hi" if "hi" in ch.limits else "lo"
    if not ch.is_r:                          # a slide lies beyond the end it has passed
        return "hi" if x > ch.hi else "lo"
    up, dn = x - ch.hi, ch.lo - x
    if ch.is_r:
        up, dn = up % (2 * np.pi), dn % (2 * np.pi)
    return "hi" if up <= dn else "lo"


def _crossing_notes(sp, crossings, xs: np.ndarray, ok: np.ndarray, flips: dict, period=None, d: int = 0) -> list[str]:
    """Notes for the crossings that the path between consecutive output rows passes."""
    notes = []
    for c, k in crossings:
        if period is not None:         # the chart's crossing c recurs at c + w·period
            w = np.floor((xs - c) / period)
            hit = np.flatnonzero(np.diff(w) != 0)
            at = c + period * np.maximum(w[:-1], w[1:])
        else:
            lo, hi = np.minimum(xs[:-1], xs[1:]), np.maximum(xs[:-1], xs[1:])
            hit = np.flatnonzero((lo < c) & (c < hi))
            at = np.full(len(xs) - 1, c)
        flipped = c in flips.get(k, ())
        for n in hit:                  # xs[0] is the reference: xs[n] → xs[n+1] is row n−1 → row n
            if len(notes) >= 20:
                return notes + ["… more crossings not listed"]
            where = "the reference" if n == 0 else f"row {n - 1}"
            notes.append(f"{sp.steps[k].label}: its two assembly branches meet at input {held_text(sp, d, at[n])} "
                         f"(between {where} and row {n}); the motion keeps the mode of the reference"
                         f"{' (the sign of the assembly branch changes there)' if flipped else ''}")
    return notes


def _mark_crossings(sp, run: _Run, xr, reach, crossings, scale, d: int = 0) -> None:
    for c, k in crossings:
        near = np.flatnonzero(reach & (np.abs(xr - c) <= _AT_CROSSING * scale))
        for n in near:
            run.code[n] = Status.SINGULAR
            run.reason[int(n)] = (f"{sp.steps[k].label}: singular position (its assembly branches meet "
                                  f"at {held_text(sp, d, c)})")
        run.G.invalidate(range(sp.mechanism.n_links), np.isin(np.arange(len(xr)), near))


def _solve_chart(sp: SolvePlan, X, needed, kernels, k: int = 0) -> tuple[_Run, list]:
    """One driver moving (``k``, the others held), closed-form groups: the cached chart
    of its motion gives each input's branch."""
    x = X[:, k]
    ch = _chart(sp, kernels, x, k)
    if ch.one_branch:
        return _run(sp, X, needed, {}, kernels), []
    xr, reach = ch.reduce(x)
    signs = {k: ch.factor(k, xr) for k in ch.flips if ch.flips[k]}
    run = _run(sp, X, needed, signs, kernels)
    if not reach.all():
        _mark_unreachable(sp, ch, run, X, ~reach, kernels)
    notes = []
    if ch.crossings:
        _mark_crossings(sp, run, xr, reach, ch.crossings, _scale(sp)[k], k)
        xs = np.concatenate([[0.0], x if ch.period else xr])
        notes = _crossing_notes(sp, ch.crossings, xs, reach, ch.flips, ch.period, k)
    return run, notes


def _solve_ranged(sp: SolvePlan, X, needed, kernels) -> tuple[_Run, list]:
    """One driver with tracked groups (triads, class IV, Newton): the cached chart gives
    the certified motion range; inputs outside it are marked with the limit, the others
    are reached by one continuous path from the reference (:func:`_solve_monotone`)."""
    x = X[:, 0]
    ch = _chart(sp, kernels, x)
    xr, reach = ch.reduce(x)
    rows = np.flatnonzero(reach)
    if rows.size:
        sub, notes = _solve_monotone(sp, ch, xr[rows], needed, kernels)
    else:
        sub, notes = _run(sp, np.zeros((1, 1)), needed, {}, kernels), None
    if notes is None and ch.crossings:
        notes = _crossing_notes(sp, ch.crossings, np.concatenate([[0.0], x if ch.period else xr]), reach,
                                ch.flips, ch.period)
    where = np.zeros(len(x), int)
    where[rows] = np.arange(rows.size)
    run = _take(sub, where)
    _turn_drivers(sp, run, np.where(reach, x - xr, 0.0))
    if reach.all():
        return run, notes or []
    run.code[~reach] = 0
    for n in np.flatnonzero(~reach):
        run.reason.pop(int(n), None)
    _mark_unreachable(sp, ch, run, X, ~reach, kernels)
    return run, notes or []


def _solve_monotone(sp: SolvePlan, ch: _Chart, xr: np.ndarray, needed, kernels) -> tuple[_Run, list | None]:
    """The chart coordinates ``xr`` (inside the certified motion) reached by one path that
    visits them sorted: from the reference down through the negative ones, then up
    through the others.  Within the chart a pose depends only on its coordinate (the
    motion is one interval, or one period, without a limit inside), so the order the
    inputs were asked in changes only the path's length: a batch that jumps back and
    forth near the limits would approach them once per jump, and the walk re-evaluates
    its whole path each round.  Notes: None (the chart's crossings name the rows in the
    order asked), or the walk's own when it stopped short of the chart (rounding at a
    limit), from the path in the order asked."""
    u, inverse = np.unique(xr, return_inverse=True)
    order = np.concatenate([np.flatnonzero(u < 0)[::-1], np.flatnonzero(u >= 0)])
    sub = _along_chart(sp, ch, u[order, None], needed, kernels)
    if sub is None:
        sub, _ = _solve_path(sp, u[order, None], needed, kernels)
        if np.any(sub.code == Status.LIMIT):
            return _solve_path(sp, xr[:, None], needed, kernels)
    rank = np.empty(len(order), int)
    rank[order] = np.arange(len(order))
    return _take(sub, rank[inverse]), None


def _along_chart(sp: SolvePlan, ch: _Chart, X: np.ndarray, needed, kernels) -> _Run | None:
    """The chart coordinates ``X`` (K, 1) reached by one path from the reference through
    them in order, sampled as :func:`_solve_path` samples it, solved in one pass with every
    group on its reference branch: the chart's certified walk found no crossing on the
    motion (so no group changes branch) and no limit inside it, which is what the walk
    along the path would certify again; a tracked group follows its mode along the
    samples (its tracker refuses an ambiguous step).  The same samples, branches and
    arithmetic as the walk's single round.  None when the chart has a crossing or a row
    fails (the walk along the path, :func:`_solve_path`, then decides)."""
    if ch.crossings:
        return None
    scale = _scale(sp)
    P, idx = _fill(np.vstack([np.zeros((1, X.shape[1])), X / scale]), _PATH_STEP)
    run = _run(sp, P * scale, needed, {}, kernels)
    if np.any(run.code != 0):
        return None
    return _take(run, idx[1:])


def _turn_drivers(sp: SolvePlan, run: _Run, turns: np.ndarray) -> None:
    """Add whole turns ``turns`` (input − its chart coordinate) to the angles of the
    driven links, so that a pose solved at the chart coordinate reports the input asked."""
    if not np.any(turns):
        return
    m = sp.mechanism
    names = m.link_names
    turned = {names[k] for st in sp.steps if st.solver == "driver" for k in st.unknown}
    grow = True                          # links on a P joint with a turned link turn with it
    while grow:
        grow = False
        for j in m.joints:
            if j.kind is JointKind.P and (set(j.links) & turned) and not set(j.links) <= turned \
                    and m.frame not in j.links:
                turned |= set(j.links)
                grow = True
    for k in (names.index(x) for x in turned):
        if run.G.th[k] is not None:
            run.G.angle(k)
            run.G.T[k, 2] += turns


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
        return _with_curvatures(sp, last["run"], kernels, scale)
    # method="newton": its tracker decides; a Newton group's limit is not zoomed (its
    # continuation refined its steps; rows need only the samples on either side of it; a
    # one-driver motion's chart has it exactly); a triad's is
    w = walk(evaluate, P, groups, refine_limits=kernels, zoom_tracked=False)
    s_nodes = path_parameter(P)
    s = w.s
    if only_all(sp, needed) and last.get("n") == len(s) and w.block is None \
            and not np.any(last["run"].code == Status.MODE_LOST):
        run = last["run"]                  # the walk's last round is the answer (no probe stopped early)
    else:
        Xs = np.stack([np.interp(s, s_nodes, P[:, j]) for j in range(P.shape[1])], axis=1) * scale
        signs = {k: sign_factor(f, s) for k, f in w.flips.items() if f}
        run = _run(sp, Xs, needed, signs, kernels)
    rows = np.minimum(np.searchsorted(s, s_nodes[idx[1:]]), len(s) - 1)
    run = _take(run, rows)
    sn = s_nodes[idx[1:]]
    notes = []
    if w.block is not None:
        s_b, s_f, k = w.block
        place = f"at {_fmt_path(sp, P, s_nodes, scale, s_b)}"
        if s_f - s_b > 1e-9:                 # a Newton group's limit: between two samples
            place = f"between {place[3:]} and {_fmt_path(sp, P, s_nodes, scale, s_f)}"
        past = np.flatnonzero(sn > s_b)
        for n in past:
            run.code[n] = Status.LIMIT
            run.reason[int(n)] = f"{sp.steps[k].label}: unreachable: limit {place} (out of reach beyond it)"
        run.G.invalidate(range(sp.mechanism.n_links), sn > s_b)
        if past.size:
            notes.append(f"the motion from the reference stops at the limit of {sp.steps[k].label} {place}; "
                         f"rows {int(past[0])}… lie beyond it")
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


def _fmt_path(sp: SolvePlan, P: np.ndarray, s_nodes: np.ndarray, scale: np.ndarray, s: float) -> str:
    """The inputs at parameter ``s`` of the path ``P`` (scaled), as text; with several
    drivers each is named (``boom_slide = 0 m, stick_slide = 0.825 m``)."""
    return _fmt_inputs(sp, np.array([np.interp(s, s_nodes, P[:, j]) for j in range(P.shape[1])]) * scale)


def _fmt_inputs(sp: SolvePlan, x) -> str:
    """The inputs ``x`` (n_drivers,) as text; with several drivers each is named."""
    if len(x) == 1:
        return _fmt_x(sp, 0, x[0])
    return ", ".join(f"{d.joint} = {_fmt_x(sp, j, v)}" for j, (d, v) in enumerate(zip(sp.mechanism.drivers, x)))


def held_text(sp: SolvePlan, k: int, x: float) -> str:
    """Driver ``k`` at ``x`` with the others at the reference, as text (:func:`_fmt_inputs`)."""
    return _fmt_inputs(sp, DriverMotion.held(sp.mechanism, k).inputs(x)[0])


def only_all(sp: SolvePlan, needed) -> bool:
    return len(needed) == len(sp.steps)


def _take(run: _Run, rows: np.ndarray) -> _Run:
    reason = {}
    if run.reason:                          # (only the failed rows are visited)
        hit = np.flatnonzero(np.isin(rows, np.fromiter(run.reason, np.int64, len(run.reason))))
        reason = {int(i): run.reason[int(rows[i])] for i in hit}
    return _Run(run.G.take(rows), run.code[rows].copy(), reason, {}, None if run.direct is None else run.direct[rows])


def solve(mechanism: Mechanism, inputs, *, derivatives: bool | str = False, input_rates=None,
          only=None, outputs=None, plan=None, method: str = "auto", assemble: bool = False,
          rows=None) -> KinematicState:
    """Positions (and velocities, accelerations) of a mechanism over a batch of inputs.

    Parameters
    ----------
    mechanism : Mechanism
        With geometry, a frame and drivers.
    inputs : float or array_like, shape (N,) or (N, n_drivers)
        Driver values (rad for R drivers, m for P drivers) from the reference.
    derivatives : bool or "velocities"
        Also velocities and accelerations (for ``input_rates``, zero input acceleration:
        d/dφ, d²/dφ² for one driver at unit rate); ``"velocities"``: those alone.
    input_rates : array_like (n_drivers,), optional
        Input speeds (default 1 for every driver).
    only : iterable of str, optional
        Names of joints, tracer points or links wanted: only the groups upstream
        of them are solved (the other entries stay NaN).
    outputs : iterable of str, optional
        The only results wanted: positions of these joints and tracer points, angles of
        these links.  Only the groups they need are solved (as ``only``), and nothing
        else is computed: the other positions, the other links' angles and pose angles
        stay NaN (statuses are always given; derivatives only when asked).
    plan : AssurPlan or SolvePlan, optional
        A precompiled plan (default: the one cached on the mechanism).
    method : {"auto", "closed_form", "newton"}
        ``auto``/``closed_form``: closed-form dyads, triad kernel, Newton for the
        rest; ``newton``: every group by Newton with continuation.
    assemble : bool
        Solve every input independently, each dyad on the branch sign of the
        reference (no continuation: positions on other circuits come back ``ok``).
        Never the default.
    rows : array_like of int, optional
        The rows of ``inputs`` wanted: the batch is solved as one path (the poses and
        statuses of these rows are the whole batch's), the rest is computed at them alone.

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
    m, sp = mechanism, plan_of(mechanism, plan)
    X, single = _as_inputs(m, inputs)
    wanted = (*([only] if isinstance(only, str) else (only or ())),
              *([outputs] if isinstance(outputs, str) else (outputs or ())))
    needed = list(range(len(sp.steps))) if not wanted else cached(sp, ("needed", wanted), needed_steps, wanted)
    select = None if outputs is None else cached(sp, ("select", wanted), _selection, outputs)
    keep = None if rows is None else _rows_of(rows, X.shape[0])
    if not (assemble or derivatives or method == "newton" or keep is not None) and len(needed) == len(sp.steps) \
            and (state := _compiled_motion(sp, X, select)) is not None:
        return state                        # the compiled plan alone (its inputs finite and in range)
    _check_inputs(sp, X)
    kernels = method != "newton"            # closed forms allowed
    run, notes = _solve_batch(sp, X, needed, kernels, assemble)
    _mark_out_of_range(sp, X, run)
    if keep is not None:
        run, X, single = _take(run, keep), X[keep], False
    return _finish(sp, X, run, needed, notes, single, derivatives, input_rates, kernels, select)


def _solve_batch(sp: SolvePlan, X: np.ndarray, needed, kernels: bool, assemble: bool) -> tuple[_Run, list]:
    """The route a batch takes: each input alone (``assemble``), on the chart of the one
    driver it moves, along the certified motion of a single driver, or by the walk along
    the path through the inputs."""
    if assemble:
        return _run(sp, X, needed, {}, kernels), []
    if _chartable(sp, kernels) and (k := _moving_driver(X)) is not None:
        return _solve_chart(sp, X, needed, kernels, k)
    if len(sp.mechanism.drivers) == 1 and kernels:
        return _solve_ranged(sp, X, needed, kernels)
    return _solve_path(sp, X, needed, kernels)


def _rows_of(rows, n: int) -> np.ndarray:
    """``rows`` (``solve(..., rows=)``) as row indices of a batch of ``n`` inputs."""
    r = np.asarray(rows)
    if r.ndim != 1 or not r.size or r.dtype.kind not in "iu" or r.min() < 0 or r.max() >= n:
        raise InputError(explain("rows", expected=f"a list of row indices of the {n} inputs (0 … {n - 1})",
                                 got=repr(rows) if r.size <= 8 else f"{r.size} values from {r.min()} to {r.max()}"))
    return r.astype(np.int64)


def _compiled_motion(sp: SolvePlan, X: np.ndarray, select=None) -> KinematicState | None:
    """The whole answer from the compiled kernel alone, or None (the general path then
    decides): one driver without a ``range`` whose cached chart puts every input on the
    reference branch (a full turn, no flip, no crossing), every step compiled, and every
    row assembled, its inputs finite (else the general path names the fault; a P
    driver's slides are checked first, :func:`_check_inputs`).  The state is the one :func:`_solve_chart` and :func:`_finish` give
    then (with ``select``, the outputs asked for: the other points NaN, and the angles
    computed from cos and sin NaN unless asked), without the pose store's bookkeeping."""
    m = sp.mechanism
    ch = memo_of(sp).get("chart")
    if ch is None or not ch.one_branch or len(m.drivers) != 1 or m.drivers[0].range is not None \
            or not kernel.wanted(X.shape[0]):
        return None
    call = cached(sp, ("motion", select), _motion_call, select)
    if call is None:
        return None
    kp, want_links, want_points, names, rotary = call
    if not rotary:
        _check_inputs(sp, X)                # a slide: the general route's checks (the kernel's is finiteness)
    M, nj = X.shape[0], m.n_joints
    T = np.empty((m.n_links, 3, M))
    P = np.empty((kp.hosts.size, 2, M))
    fail = np.zeros(M, np.int8)
    Xc = X if X.flags.c_contiguous and X.flags.writeable else np.array(X)   # (one compiled signature)
    if kernel.run_motion(kp, Xc, T, P, fail, np.zeros(m.n_links, np.int8), want_links, want_points):
        return None
    for a in (T, P, fail):                   # fresh arrays: frozen in place, and given as views only
        a.flags.writeable = False            # (the views cannot be made writable again)
    Z, Q = T.transpose(2, 0, 1), P.transpose(2, 0, 1)
    return KinematicState.frozen_from(mechanism=m, inputs=X, positions=Q[:, :nj], angles=Z[:, :, 2],
                                      status=_all_ok(M), point_names=names,
                                      point_positions=Q[:, nj:] if names else None, poses=Z, codes=fail[:])


def _motion_call(sp: SolvePlan, select):
    """What :func:`_compiled_motion` passes on every call for ``outputs=`` ``select``,
    looked up once: the lowered plan, the wanted rows' masks, the tracer points' names
    and whether the driver turns (a P driver's slides are checked by :func:`_check_inputs`);
    None when a step is not compiled."""
    kp = kernel.kernel_plan(sp)
    if not kp.complete:
        return None
    m = sp.mechanism
    return (kp, *_wanted_rows(sp, select), tuple(p.name for p in m.points), m.is_rotary(m.drivers[0]))


def _all_ok(M: int) -> np.ndarray:
    """A read-only (M,) status array of ``"ok"``, shared by the states of M rows (read
    only all the way down: no view of it can be made writable)."""
    hit = _ALL_OK.get(M)
    if hit is None:
        base = np.empty(M, dtype=object)
        base.fill("ok")
        base.flags.writeable = False     # (an array that owns its data could be made writable again)
        hit = base.view()
        if M <= 1 << 16:                 # the last 16 batch sizes kept (a bounded cache)
            if len(_ALL_OK) >= 16:
                del _ALL_OK[next(iter(_ALL_OK))]
            _ALL_OK[M] = hit
    return hit


_ALL_OK: dict = {}


def _wanted_rows(sp: SolvePlan, select) -> tuple[np.ndarray, np.ndarray]:
    """The int8 masks of the links whose derived angle and of the joints and tracer
    points (the kernel's points: joints, then tracer points) that ``outputs=`` asks for
    (``select``: the selection's indices, None: everything); the others are left NaN,
    as :func:`_finish` leaves them."""
    m = sp.mechanism
    nj, n = m.n_joints, m.n_joints + len(m.points)
    if select is None:
        links, points = np.ones(m.n_links, np.int8), np.ones(n, np.int8)
    else:
        joints, pts, chosen = select
        links, points = np.zeros(m.n_links, np.int8), np.zeros(n, np.int8)
        links[list(chosen)] = 1
        points[[*joints, *(nj + i for i in pts)]] = 1
    links.flags.writeable = points.flags.writeable = False
    return links, points


def _mark_out_of_range(sp: SolvePlan, X: np.ndarray, run: _Run) -> None:
    """Inputs outside a driver's ``range`` are failed positions (status ``out of range``);
    the path through them was solved as usual, so the motion on either side is unchanged.
    A value within 1e-12 of the size (P) or 1e-12 rad (R) of an end, or within a few units
    in the last place of it (an end read in degrees and converted twice), is inside."""
    m = sp.mechanism
    for k, d in enumerate(m.drivers):
        if d.range is None:
            continue
        rotary = m.is_rotary(d)
        tol = 1e-12 * (1.0 if rotary else sp.size) + 4 * np.spacing(np.abs(np.asarray(d.range, float)))
        out = (X[:, k] < d.range[0] - tol[0]) | (X[:, k] > d.range[1] + tol[1])
        if not out.any():
            continue
        lo, hi = np.degrees(d.range) if rotary else d.range
        text = (f"out of range: {'angular range' if rotary else 'stroke'} of {d.joint} is "
                f"[{lo:.6g}, {hi:.6g}] {'deg' if rotary else 'm'}")
        for n in np.flatnonzero(out & (run.code == 0)):
            run.reason[int(n)] = text
        run.code[out & (run.code == 0)] = Status.OUT_OF_RANGE
        run.G.invalidate(range(m.n_links), out)


def _check_inputs(sp: SolvePlan, X: np.ndarray) -> None:
    """Refuse a NaN or an infinity (:func:`check_finite_inputs`), then a runaway slide of
    a P driver."""
    m = sp.mechanism
    check_finite_inputs(m, X)
    for k, d in enumerate(m.drivers):
        if not m.is_rotary(d) and np.any(np.abs(X[:, k]) > MAX_SLIDE * sp.size):
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
    return _PLANS.get(mechanism, lambda: compile_plan(mechanism))


#: compiled plans of the last 64 mechanisms solved, by identity (Mechanism is frozen)
_PLANS = Recent(64)


def _selection(sp: SolvePlan, outputs) -> tuple:
    """Indices of the joints, tracer points and links named in ``outputs``."""
    m = sp.mechanism
    names = {outputs} if isinstance(outputs, str) else set(outputs)
    return (tuple(i for i, n in enumerate(m.joint_names) if n in names),
            tuple(i for i, p in enumerate(m.points) if p.name in names),
            tuple(i for i, n in enumerate(m.link_names) if n in names))


def _finish(sp, X, run: _Run, needed, notes, single, derivatives, input_rates, kernels,
            select=None) -> KinematicState:
    """Statuses, NaN for unsolved links, derivatives and the frozen state."""
    m = sp.mechanism
    G = run.G
    G.unset_to_nan()
    N = X.shape[0]
    code = run.code
    solved_links = [i for s in needed for i in sp.steps[s].unknown]
    lost = ~G.finite(solved_links)
    all_ok = not (lost.any() or code.any())
    if not all_ok:
        code[(code == 0) & lost] = Status.UPSTREAM
    okm = code == 0
    status = np.empty(N, dtype=object)
    status.fill("ok")                       # (np.full with an object is ~30x slower)
    if not all_ok:
        for n in np.flatnonzero(~okm):
            status[n] = run.reason.get(int(n), MESSAGES[Status(int(code[n]))])
    if select is not None and not derivatives:       # only the links' angles asked for
        for k in list(G.pending | G.derived):
            if k in select[2]:
                G.angle(k)
            else:
                G.pending.discard(k)
                G.T[k, 2] = np.nan
    Z = G.to_Z()
    Zd = Zdd = rates_in = None
    if derivatives:
        rates_in, Zd, Zdd = _derivatives(sp, Z, needed, okm, input_rates, kernels, solved_links,
                                         derivatives != "velocities")
    direct = run.direct if all_ok and select is None else None      # the kernel's points, still valid
    state = _state(sp, X, G, Z, Zd, Zdd, status, rates_in, tuple(notes), code, select, direct)
    if single and code[0] != 0:
        msg = f"input {_fmt_input(m, X[0])}: {status[0]}"
        if code[0] == Status.SINGULAR:
            raise SingularityError(msg)
        raise AssemblyError(msg)
    if not single and not all_ok and np.any(code == Status.SINGULAR):
        warnings.warn("singular positions met: marked in status", SingularityWarning, stacklevel=3)
    return state


def _derivatives(sp, Z, needed, okm, input_rates, kernels, solved_links, accelerations: bool = True):
    """Pose rates (and accelerations, unless ``accelerations`` is False: ``Zdd`` None)."""
    m = sp.mechanism
    nd = len(m.drivers)
    rates_in = np.ones(nd) if input_rates is None else np.asarray(input_rates, float).reshape(nd)
    R = PoseRates(sp, Z, np.zeros_like(Z), np.zeros_like(Z) if accelerations else None)
    for k in needed:
        _step(sp.steps[k], kernels).rates(R, rates_in)
    solved = set(solved_links)
    unsolved = [k for k in range(m.n_links) if k not in solved and m.link_names[k] != m.frame]
    for D in (R.Zd, R.Zdd):
        if D is not None:
            D[:, unsolved] = np.nan
            D[~okm] = np.nan
    return rates_in, R.Zd, R.Zdd


def _fmt_input(m: Mechanism, x) -> str:
    parts = []
    for d, v in zip(m.drivers, np.atleast_1d(x)):
        if m.is_rotary(d):
            parts.append(f"{d.joint} = {np.degrees(v):.6g}°")
        else:
            parts.append(f"{d.joint} = {v:.6g} m")
    return ", ".join(parts)


def needed_steps(sp: SolvePlan, only) -> list[int]:
    """The steps (in plan order) that the joints, tracer points or links named in
    ``only`` need: their own and every step upstream of them."""
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


def _state(sp: SolvePlan, X, G: "Poses", Z, Zd, Zdd, status, rates_in, notes, code,
           select=None, direct=None) -> KinematicState:
    m = sp.mechanism
    nj = m.n_joints
    pos = _points(sp, G, "joints", None if select is None else select[0]) \
        if direct is None else direct[:, :nj]
    vel = acc = om = ep = None
    if Zd is not None:
        host = np.asarray(sp.joint_host)
        (v0, w0), (a0, e0) = rates_of(Zd, host), rates_of(Zdd, host)
        vel, acc = transport(pos - Z[:, host, :2], v0, a0, w0, e0)
        om, ep = Zd[:, :, 2].copy(), None if Zdd is None else Zdd[:, :, 2].copy()
    ppos = pvel = pacc = None
    if m.points:
        ph = np.asarray(sp.point_host)
        ppos = _points(sp, G, "points", None if select is None else select[1]) \
            if direct is None else direct[:, nj:]
        if Zd is not None:
            (v0, w0), (a0, e0) = rates_of(Zd, ph), rates_of(Zdd, ph)
            pvel, pacc = transport(ppos - Z[:, ph, :2], v0, a0, w0, e0)
    return KinematicState(m, X, pos, Z[:, :, 2], status, vel, acc, om, ep,
                          rates_in, point_names=tuple(p.name for p in m.points),
                          point_positions=ppos, point_velocities=pvel, point_accelerations=pacc,
                          notes=notes, poses=Z, pose_rates=Zd, pose_accelerations=Zdd, codes=code)


def _points(sp: SolvePlan, G: "Poses", which: str, chosen=None) -> np.ndarray:
    """Positions ``(N, n, 2)`` of the joints' (or tracer points') material points, each
    carried by its host link's pose (:meth:`Poses.carry`), written point-major into one
    array and returned transposed."""
    h, r = (sp.joint_host, sp.joint_offsets) if which == "joints" else (sp.point_host, sp.point_offsets)
    if chosen is None:
        out = np.empty((len(h), 2, G.M))
        chosen = range(len(h))
    else:                                  # only the chosen points: the others NaN
        out = np.full((len(h), 2, G.M), np.nan)
    for i in chosen:
        out[i, 0], out[i, 1] = G.carry(h[i], *r[i])
    return out.transpose(2, 0, 1)


def _step(st: StepPlan, closed: bool):
    """The compiled step that solves ``st``: its closed form where it has one and closed
    forms are allowed (a one-link driver's always), else Newton."""
    if st.closed is not None and (closed or st.solver == "driver"):
        return st.closed
    return st.newton
