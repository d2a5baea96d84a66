"""Many designs of one mechanism solved in one pass over its compiled plan.

The plan's topology is compiled once (:func:`kin.solve.plan_of`); :func:`solve_designs`
binds its steps to a design matrix ``(D, p)`` (:class:`~kin.geometry.Geometry`, columns
named by :func:`~kin.geometry.design_names`) and runs each step once for every design and
input: the dyads' closed forms (Vasechkin et al. 2017, eqs. 1-18) broadcast the designs'
numbers ``(D, 1)`` over the inputs, and the triad and class IV steps compute every
assembly mode of every design at every input with one polynomial kernel and follow the
reference's mode along the inputs (:func:`kin.groups.triad.follow_modes_batch`); designs
within a hair of the first (a finite-difference Jacobian's rows) are Newton-polished from
the first one's poses instead, where that stays well inside its mode.  A step
with no batched form (Newton's) makes the plan fall back to :func:`kin.solve.solve` per
design.

Semantics: every design is solved at the given inputs, in order, on the assembly branch
of its own reference configuration (the branch sign of each dyad, the mode of each
triad); a design whose reference sits on a branch boundary fails (NaN).  There is no
lead-in and no change of branch at a crossing: the inputs should start at the reference
(input 0) and be dense enough to follow a triad's mode, as a synthesis grid is.  A dyad
mechanism gives the same bits as :func:`kin.solve.solve` of each design alone.

References
----------
.. [1] Vasechkin M.A., Matveeva E.V., Sidorenko A.S., Chertov E.D. Mathematical
   model of kinematic calculation of flat lever mechanisms. Vestnik VGUIT 79(2)
   (2017) 73-79. doi:10.20914/2310-1202-2017-2-73-79.
"""
from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, replace

import numpy as np

from multiloop.topo.errors import InputError, LinkageError, explain
from multiloop.topo.model import JointKind, Mechanism

from .geometry import Geometry, design_names
from . import kernel
from .poses import Poses
from .solve import SolvePlan, check_finite_inputs, needed_steps, plan_of, solve

__all__ = ["DesignPoses", "solve_designs", "with_cells", "design_names", "design_mechanism", "branch_signs",
           "unbatched_steps", "compiled_batch"]


@dataclass(frozen=True, eq=False)
class _BoundPlan:
    """What the pose store reads from a plan: the links' reference points ``origins`` (one
    design; None for a batch) and ``origins_xy``, the same as Python floats (one design)
    or per-design arrays ``(D, 1)`` (a batch)."""

    mechanism: Mechanism
    origins: np.ndarray | None
    origins_xy: tuple


@dataclass(frozen=True, eq=False)
class DesignPoses:
    """Link poses of D designs at N inputs.

    ``ok`` ``(D, N)``: every asked-for step assembled; ``th`` ``(n_links, D, N)`` the links'
    rotations from the reference; :meth:`point` and :meth:`world` give material points.
    """

    plan: SolvePlan
    geometry: Geometry
    store: Poses
    ok: np.ndarray

    @property
    def th(self) -> np.ndarray:
        self.store.angles()
        return self.store.T[:, 2]

    def _translation(self, i: int) -> np.ndarray:
        """``t`` of the map ``world = R(θ) r + t`` of every link (rows x or y), from the
        store's positions and the cos and sin it keeps."""
        G = self.store
        out = np.empty(G.T.shape[:1] + G.T.shape[2:])
        for k, (ox, oy) in enumerate(G.org):
            c, s = G.c[k], G.s[k]
            out[k] = G.T[k, i] - ((c * ox - s * oy) if i == 0 else (s * ox + c * oy))
        return out

    @property
    def tx(self) -> np.ndarray:
        return self._translation(0)

    @property
    def ty(self) -> np.ndarray:
        return self._translation(1)

    def world(self, k: int, r) -> np.ndarray:
        """Link k's material point at reference position ``r`` ``(D, 2)`` (or ``(2,)``):
        ``(D, N, 2)``, carried as :func:`kin.solve.solve` carries joints."""
        G = self.store
        r = np.broadcast_to(np.asarray(r, float), (G.shape[0], 2))[:, None, :]
        x, y = G.point_xy(k, r)
        out = np.empty((*G.shape, 2))
        out[..., 0], out[..., 1] = x, y
        return out

    def angle(self, link: str) -> np.ndarray:
        """Link ``link``'s rotation from the reference ``(D, N)``."""
        return self.th[self.plan.mechanism.link_names.index(link)]

    def axis(self, joint: str) -> np.ndarray:
        """P joint ``joint``'s guide in each design's reference ``(D, 1, 2)``."""
        return self.geometry.axis(joint)

    def host(self, name: str) -> int:
        """The index of the link that carries joint or tracer point ``name`` in
        :func:`kin.solve.solve`."""
        m, sp = self.plan.mechanism, self.plan
        names = [p.name for p in m.points]
        return sp.point_host[names.index(name)] if name in names else sp.joint_host[m.joint_names.index(name)]

    def point(self, name: str) -> np.ndarray:
        """Joint or tracer point ``name`` ``(D, N, 2)``, on the link that carries it in
        :func:`kin.solve.solve`."""
        return self.world(self.host(name), self.geometry.at(name)[:, 0])


def design_mechanism(geometry: Geometry, d: int) -> Mechanism:
    """Design ``d`` of a batch as a mechanism (names, topology and drivers kept)."""
    m = geometry.mechanism
    joints = []
    for j in m.joints:
        at = tuple(float(v) for v in geometry.at(j.name)[d, 0])
        if j.kind is JointKind.P:
            a = tuple(float(v) for v in _raw_axis(geometry, j.name, d))
            joints.append(replace(j, at=at, axis=a))
        else:
            joints.append(replace(j, at=at))
    pts = [replace(p, at=tuple(float(v) for v in geometry.at(p.name)[d, 0])) for p in m.points]
    return replace(m, joints=tuple(joints), points=tuple(pts))


def _raw_axis(geometry: Geometry, joint: str, d: int):
    """A P joint's axis as written to a file: (cos, sin) of its design angle, or the
    mechanism's own."""
    col = geometry.cols.get(f"{joint}.angle")
    if col is None:
        return geometry.mechanism.joint(joint).axis
    a = geometry.X[d, col]
    return np.cos(a), np.sin(a)


def _as_design_inputs(m: Mechanism, inputs, D: int) -> np.ndarray:
    """Inputs ``(N,)``/``(N, nd)`` shared by the designs, or ``(D, N)``/``(D, N, nd)``
    per design, as an array ending in the driver axis."""
    x = np.asarray(inputs, float)
    nd = len(m.drivers)
    if nd == 1 and (x.ndim == 1 or (x.ndim == 2 and x.shape[0] == D and x.shape[1] != 1)):
        x = x[..., None]
    ok = x.ndim in (2, 3) and x.shape[-1] == nd and (x.ndim == 2 or x.shape[0] == D)
    if not ok:
        raise InputError(explain("inputs", expected=f"finite values of shape (N,{' ' + str(nd) if nd > 1 else ''}) "
                                 f"or (D, N{', ' + str(nd) if nd > 1 else ''}) with D = {D}",
                                 got=f"shape {np.shape(inputs)}"))
    check_finite_inputs(m, x)
    return x


def solve_designs(mechanism: Mechanism, names, designs, inputs, *, outputs=None, plan=None,
                  deadline: float | None = None, reuse: bool = False) -> DesignPoses:
    """Solve D designs of ``mechanism`` at N inputs in one pass over its plan.

    Parameters
    ----------
    mechanism : Mechanism
        The topology, drivers and decomposition (and the values the designs do not name).
    names : sequence of str
        Columns of ``designs`` (:func:`design_names`).
    designs : ndarray, shape (D, p)
    inputs : ndarray, shape (N,) or (N, n_drivers), or (D, N[, n_drivers]) per design
        Driver values from each design's reference (rad for R, m for P drivers).
    outputs : sequence of str, optional
        Joints, tracer points or links wanted: only the steps they need are solved (the
        other links stay NaN).  Default: every step.
    plan : SolvePlan, optional
        The compiled plan of ``mechanism`` (default: the cached one).
    deadline : float, optional
        A ``time.perf_counter()`` value: past it the design-by-design fallback leaves
        the remaining designs unsolved (failed), so that a population cannot overrun a
        time budget.
    reuse : bool
        On the compiled route, the pose store and its cos and sin rows are this thread's
        work arrays (:func:`kin.kernel.design_work`): the result is valid only until the
        thread's next call with ``reuse`` (for a caller that reads the poses at once and
        keeps nothing of them, a population's objective).

    Returns
    -------
    DesignPoses
    """
    sp = plan_of(mechanism, plan)
    geo = Geometry(mechanism, tuple(names), designs)
    geo.gather(sp)                               # (every joint and link origin in a few array operations)
    X = _as_design_inputs(mechanism, inputs, geo.D)
    shape = (geo.D, X.shape[-2])
    steps = list(range(len(sp.steps))) if outputs is None else needed_steps(sp, outputs)
    kp = kernel.kernel_plan(sp) if kernel.wanted(shape[0] * shape[1]) else None
    if kp is not None and compiled_batch(sp, kp, steps):
        floats = kernel.lower_designs(sp, kp, geo, steps)           # (no step bound in Python)
        store = kernel.design_work("poses", (mechanism.n_links, 3) + shape) if reuse else None
        G = _batch_store(geo, shape, store)
        return _compiled(sp, geo, G, kp, floats, steps, X, reuse)
    bound = [_bind(sp.steps[k], mechanism, sp.size, geo) for k in steps]
    if any(b is None for b in bound):
        return _per_design(sp, geo, X, shape, outputs, deadline)
    G = _batch_store(geo, shape)
    if kp is not None and kp.covers(steps, tracked=True):
        return _compiled(sp, geo, G, kp, kernel.design_floats(kp, bound, steps, geo.origins(), geo.D), steps, X)
    for k, step in zip(steps, bound):
        step.jit = kp is not None                # a triad's compiled tracker, say
        okk = step.positions(G, X).ok
        G.invalidate(sp.steps[k].unknown, ~okk)
    G.unset_to_nan()
    ok = G.finite([i for k in steps for i in sp.steps[k].unknown])
    return DesignPoses(sp, geo, G, ok)


def compiled_batch(sp: SolvePlan, kp, steps) -> bool:
    """Whether a batch of designs runs the steps ``steps`` of plan ``sp`` compiled straight
    from the design matrix (kernel plan ``kp``): every step has a compiled step (a tracked
    one too) and a compiled lowering, and its kind a batched form (a kind may declare it
    has none: its designs are then solved one by one, the compiled kernel's steps too).
    :func:`solve_designs` and :class:`~kin.tracer_batch.TracerBatch` decide by it."""
    return (kp.covers(steps, tracked=True) and kp.lowered(steps)
            and all(sp.steps[k].closed is None or type(sp.steps[k].closed).batched for k in steps))


def _batch_store(geo: Geometry, shape: tuple, store=None) -> Poses:
    """An empty pose store ``shape`` (D, N) for the designs of ``geo`` (their links'
    reference points per design; ``store``: the array to use, else a new one)."""
    return Poses(_BoundPlan(geo.mechanism, None, geo.origins_xy()), shape, store)


def with_cells(st: DesignPoses, at: tuple, src: DesignPoses, src_at: tuple) -> DesignPoses:
    """Poses ``st`` with the (design, input) cells ``at`` (two index arrays) replaced by
    the cells ``src_at`` of ``src``, poses of the same plan (those designs solved along
    another path of inputs: a path-dependent step's poses depend on the inputs before
    them).  A new store: every link's rows, its cos and sin from its angle row."""
    G, S = st.store, src.store
    G.angles()
    S.angles()
    T = G.T.copy()
    T[:, :, at[0], at[1]] = S.T[:, :, src_at[0], src_at[1]]
    ok = st.ok.copy()
    ok[at] = src.ok[src_at]
    out = _batch_store(st.geometry, G.shape)
    out.from_T(T)
    return DesignPoses(st.plan, st.geometry, out, ok)


def _compiled(sp: SolvePlan, geo: Geometry, G: Poses, kp, floats, steps, X, reuse: bool = False) -> DesignPoses:
    """The designs by the compiled kernel (:func:`kin.kernel.run_designs`) from their
    numbers ``floats`` (:func:`kin.kernel.lower_designs`, or the bound steps'
    :func:`kin.kernel.design_floats`): the same steps on the same branches as the NumPy
    route, equal to it to rounding."""
    X = X[None] if X.ndim == 2 else X                 # (inputs shared by the designs)
    links = [i for k in steps for i in sp.steps[k].unknown]
    C, S, pend = kernel.run_designs(kp, floats, X, steps, G.T, scratch=reuse)
    C[G.frame_k], S[G.frame_k] = 1.0, 0.0              # (the frame's rows: the store's own values)
    G.adopt(links + [G.frame_k], C, S)
    placed = set(links)
    G.pending.update(int(k) for k in pend if k in placed)
    G.unset_to_nan()
    if len(placed) == G.m.n_links - 1:                  # (every link's rows are the kernel's)
        G.keep_rows(C, S)
    return DesignPoses(sp, geo, G, G.finite(links))


def _bind(st, mechanism, size, geo):
    """Plan step ``st`` compiled for the designs of ``geo``, or None (no batched form)."""
    closed = st.closed
    if closed is None or not type(closed).batched:
        return None
    return type(closed)(mechanism, st, size, geo)


def unbatched_steps(mechanism: Mechanism, plan=None) -> list[str]:
    """Labels of the plan's steps with no batched form (their plan is solved design by
    design): Newton's groups, a triad or class IV group."""
    sp = plan_of(mechanism, plan)
    return [st.label for st in sp.steps if st.closed is None or not type(st.closed).batched]


def path_dependent_steps(mechanism: Mechanism, plan=None) -> list[str]:
    """Labels of the plan's steps whose solution at an input depends on the inputs before
    it (a triad's or class IV group's followed mode, Newton's previous solution): a
    design must reach its inputs from the reference by steps no larger than a synthesis
    grid's to be solved on the motion's own mode.  A dyad's branch is fixed by its sign."""
    sp = plan_of(mechanism, plan)
    return [st.label for st in sp.steps if st.solver not in ("driver", "dyad")]


def branch_signs(mechanism: Mechanism, names, designs, plan=None) -> np.ndarray:
    """The assembly sign ``(D, n)`` (±1, NaN on a branch boundary) of every dyad step with
    one (RRR, RRP, RPR, actuated), in plan order, that :func:`solve_designs` gives each
    design: read from its reference configuration by the step itself."""
    sp = plan_of(mechanism, plan)
    geo = Geometry(mechanism, tuple(names), designs)
    cols = []
    for st in sp.steps:
        step = _bind(st, mechanism, sp.size, geo)
        if step is not None and hasattr(step, "sign") and st.solver == "dyad":
            cols.append(np.broadcast_to(step.sign, (geo.D, 1)))
    return np.concatenate(cols, axis=1) if cols else np.ones((geo.D, 0))


def _one_design(sp: SolvePlan, md: Mechanism, steps, X) -> np.ndarray:
    """Poses ``(n_links, 3, N)`` of one design ``md`` by the plan's closed-form steps."""
    geo = Geometry(md)
    origins = geo.origins()
    G = Poses(_BoundPlan(md, origins, tuple(map(tuple, np.asarray(origins, float).tolist()))), X.shape[0])
    for k in steps:
        st = sp.steps[k]
        okk = type(st.closed)(md, st, sp.size, geo).positions(G, X).ok
        G.invalidate(st.unknown, ~okk)
    G.unset_to_nan()
    G.angles()
    return G.T


def _per_design(sp: SolvePlan, geo: Geometry, X, shape, outputs, deadline) -> DesignPoses:
    """The fallback for plans with a step that has no batched form: each design alone
    (no design after ``deadline``)."""
    G = _batch_store(geo, shape)
    T = np.full(G.T.shape, np.nan)
    steps = list(range(len(sp.steps))) if outputs is None else needed_steps(sp, outputs)
    closed = all(sp.steps[k].closed is not None for k in steps)
    for d in range(shape[0]):
        if deadline is not None and time.perf_counter() > deadline:
            break
        Xd = X if X.ndim == 2 else X[d]
        try:
            md = design_mechanism(geo, d)
            if closed:                 # the closed-form steps along the inputs, as in the batch
                T[:, :, d] = _one_design(sp, md, steps, Xd)
                continue
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                st = solve(md, Xd, only=outputs)
        except LinkageError:
            continue
        good = np.asarray(st.status == "ok")
        T[:, :, d] = np.where(good, np.moveaxis(st.poses, 0, -1), np.nan)
    G.from_T(T)
    return DesignPoses(sp, geo, G, np.all(np.isfinite(T[:, 2]), axis=0))

