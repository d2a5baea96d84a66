"""One tracer point of a few designs at their own inputs, and its exact derivatives,
straight from the design matrix in one compiled call.

A synthesis polish asks, hundreds of times a run, for one tracer point of one to three
designs at ten inputs and for its derivatives by the design variables and the input, and
free timing's population for the curve of every candidate on the driver grid.
:func:`~kin.design.solve_designs` and :func:`~kin.sensitivity.pose_sensitivity` answer
with the whole pose store and its objects (:class:`~kin.poses.Poses`,
:class:`~kin.design.DesignPoses`, per-link rows and views), whose Python costs several
times the compiled work at that size.  :class:`TracerBatch` keeps the plan's arrays and
makes one call (:func:`kin._tracer_nb.tracer_point`) that does what those routes do, in
their order: the designs' joint table (:meth:`~kin.geometry.Geometry.gather`), each
kind's compiled lowering, the design kernel, the point carried by its link
(:meth:`~kin.poses.Poses.carry`), and with the derivatives the compiled sensitivities and
the material point's derivative (:func:`~kin.sensitivity.material_derivative`): the same
floats as ``solve_designs(...).point(name)`` and ``pose_sensitivity(...).point(name)``
(one design at ten inputs with its derivatives: 27 µs against the pose store's 252 µs,
``benchmarks/bench_designs.py`` ``synthesis_parts``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import kernel
from .design import compiled_batch
from .geometry import joint_tables, origin_joint
from .memo import cached
from .poses import unit
from .sensitivity import offset_columns, sensitivity_plan
from .solve import SolvePlan, plan_of

__all__ = ["TracerBatch"]


@dataclass(frozen=True, eq=False)
class TracerBatch:
    """Tracer point (or joint) ``point`` of designs of ``plan``'s mechanism whose columns
    are ``names``, on the compiled route (:meth:`of`): :meth:`solve`."""

    plan: SolvePlan
    names: tuple[str, ...]
    point: str
    host: int                       # the link that carries the point in ``kin.solve.solve``
    E: np.ndarray                   # ∂(point − host's reference point)/∂(design, input) (2, q)
    plan_args: tuple                # the kernel plan's arrays (:func:`kin._tracer_nb.tracer_point`)
    table: tuple                    # the joint table's template (:meth:`kin.geometry.Geometry.gather`)
    first: np.ndarray               # each link's reference joint's row
    blocks: tuple                   # the sensitivity blocks (:func:`kin.sensitivity.sensitivity_plan`)
    at: np.ndarray                  # the point's own reference position, where no column moves it
    pcols: np.ndarray               # the point's x and y columns (-1: none)
    angle_cols: tuple               # the guide angles' columns, in the table's order

    @classmethod
    def of(cls, mechanism, names, point: str) -> "TracerBatch | None":
        """The batch of ``point`` for designs with columns ``names``, kept on the plan;
        None when it has no compiled route: no numba, a step without a compiled step or
        lowering (a Newton group's) or whose kind declares no batched form (its designs
        are solved one by one, as :func:`~kin.design.solve_designs` solves them), more
        than one driver, or a point on the frame."""
        sp = plan_of(mechanism)
        if kernel.load() is None or len(mechanism.drivers) != 1:
            return None
        kp = kernel.kernel_plan(sp)
        every = range(len(sp.steps))
        if not compiled_batch(sp, kp, every):
            return None
        tb = cached(sp, ("tracer batch", tuple(names), point), _make, (tuple(names), point))
        return None if tb.host == kp.frame else tb

    def solve(self, designs: np.ndarray, inputs: np.ndarray, jacobian: bool = False):
        """The point ``W`` ``(D, N, 2)`` of designs ``designs`` ``(D, p)`` at their inputs
        ``inputs`` ``(D, N)``, NaN where a design does not assemble, and with ``jacobian``
        its derivatives ``(D, N, 2, p + 1)`` by the design columns and the input (else
        None): one compiled call (:func:`kin._tracer_nb.tracer_point`)."""
        W, dW, _ = self._run(designs, np.asarray(inputs, float)[..., None], jacobian)
        return W, (dW if jacobian else None)

    def curve(self, designs: np.ndarray, inputs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The point ``W`` ``(D, N, 2)`` of designs ``designs`` ``(D, p)`` at the same
        inputs ``inputs`` ``(N,)`` (their cos and sin computed once), and ``ok`` ``(D, N)``
        where every link assembled (``solve_designs(...).ok``)."""
        W, _, ok = self._run(designs, np.asarray(inputs, float).reshape(1, -1, 1), False)
        return W, ok

    def compiled_parts(self) -> tuple:
        """What a compiled caller of :func:`kin._tracer_nb.tracer_point` passes besides the
        designs and inputs: the plan's arrays, the joint table's template, the sensitivity
        blocks, each link's reference joint's row, the point's reference and columns, its
        host link, its offset columns and the guide angles' columns (int64)."""
        return (self.plan_args, self.table, self.blocks, self.first, self.at, self.pcols, int(self.host), self.E,
                np.array(self.angle_cols, np.int64))

    def _run(self, designs, inputs3: np.ndarray, jacobian: bool):
        X = _writable(designs)
        inputs3 = _writable(inputs3)
        Uang = np.empty((len(X), len(self.angle_cols), 2))
        for k, c in enumerate(self.angle_cols):             # (NumPy's cos, sin and hypot, as gather's)
            Uang[:, k] = unit(np.stack([np.cos(X[:, c]), np.sin(X[:, c])], axis=-1))
        return _tracer_kernel().tracer_point(*self.plan_args, *self.table, Uang, self.first, X, inputs3, self.at,
                                             self.pcols, self.host, bool(jacobian), *self.blocks, self.E)


def _make(sp: SolvePlan, arg) -> TracerBatch:
    names, point = arg
    m = sp.mechanism
    points = [p.name for p in m.points]
    host = sp.point_host[points.index(point)] if point in points else sp.joint_host[m.joint_names.index(point)]
    q = len(names) + 1
    cols = {n: i for i, n in enumerate(names)}
    E = offset_columns(cols, point, origin_joint(m, m.link_names[host]), q)
    kp = kernel.kernel_plan(sp)
    tab = joint_tables(sp, m, names)
    plan_args = (kp.codes, kp.ints, kp.floats.shape[1], kp.rows, kp.unknown, kernel.every_step(kp), kp.trig,
                 kp.frame, float(sp.size))
    table = (tab.at, tab.axes, tab.rows, tab.cx, tab.cy, np.array([i for i, _ in tab.angles], np.int64))
    f = sensitivity_plan(sp, names).flat
    blocks = (f["kind"], f["la"], f["lb"], f["row"], f["alpha"], f["drive"], f["Ea"], f["Eb"], *f["rows"],
              f["step_lo"], f["step_hi"], f["neq"], f["col_of"], f["unknown"])
    at = np.asarray(m.joint(point).at if point not in points else m.points[points.index(point)].at, float)
    pcols = np.array([cols.get(f"{point}.x", -1), cols.get(f"{point}.y", -1)], np.int64)
    for a in (E, at, pcols):
        a.flags.writeable = False
    return TracerBatch(sp, names, point, host, E, plan_args, table, tab.first, blocks, at, pcols,
                       tuple(c for _, c in tab.angles))


def _writable(a) -> np.ndarray:
    """``a`` as a C-contiguous, writable float array (numba compiles read-only arrays as
    another type: one signature for every call)."""
    a = np.ascontiguousarray(a, float)
    return a if a.flags.writeable else a.copy()


def _tracer_kernel():
    """:mod:`kin._tracer_nb`, imported on first use (with numba)."""
    if not _KERNEL:
        from . import _tracer_nb
        _KERNEL.append(_tracer_nb)
    return _KERNEL[0]


_KERNEL: list = []
