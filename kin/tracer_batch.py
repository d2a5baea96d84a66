"""One tracer point of a few designs at their own inputs, and its exact derivatives,
straight from the design matrix by the compiled kernels.

A synthesis polish asks, hundreds of times a run, for one tracer point of one to three
designs at ten inputs and for its derivatives by the design variables and the input.
:func:`~kin.design.solve_designs` and :func:`~kin.sensitivity.pose_sensitivity` answer
with the whole pose store and its objects (:class:`~kin.poses.Poses`,
:class:`~kin.design.DesignPoses`, per-link rows and views), whose Python costs several
times the compiled calls at that size (one design at ten inputs: the point 105 µs by the
pose store, 48 µs here; with its derivatives 197 µs and 129 µs, in one measurement).
:class:`TracerBatch` makes the same calls on flat arrays: the designs' joint table
(:meth:`~kin.geometry.Geometry.gather`), their numbers by each kind's compiled lowering
(:func:`~kin.kernel.lower_designs`), the poses by the design kernel
(:func:`~kin.kernel.run_designs`), the velocity analogue by the compiled sensitivities
(:func:`~kin.sensitivity.compiled_sensitivities`), and carries the point as the pose
store does (:meth:`~kin.poses.Poses.carry`, :func:`~kin.sensitivity.material_derivative`):
the same floats as ``solve_designs(...).point(name)`` and
``pose_sensitivity(...).point(name)``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import kernel
from .geometry import Geometry, origin_joint
from .memo import cached
from .poses import carried
from .sensitivity import compiled_sensitivities, material_derivative, offset_columns, sensitivity_plan
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

    @classmethod
    def of(cls, mechanism, names, point: str) -> "TracerBatch | None":
        """The batch of ``point`` for designs with columns ``names``, kept on the plan;
        None when it has no compiled route: no numba, a step without a compiled step or
        lowering (a triad's, Newton's), more than one driver, or a point on the frame."""
        sp = plan_of(mechanism)
        if kernel.load() is None or len(mechanism.drivers) != 1:
            return None
        kp = kernel.kernel_plan(sp)
        every = range(len(sp.steps))
        if not (kp.covers(every) and kp.lowered(every)):
            return None
        tb = cached(sp, ("tracer batch", tuple(names), point), _make, (tuple(names), point))
        return None if tb.host == kp.frame else tb

    def solve(self, designs: np.ndarray, inputs: np.ndarray, jacobian: bool = False):
        """The point ``W`` ``(D, N, 2)`` of designs ``designs`` ``(D, p)`` at their inputs
        ``inputs`` ``(D, N)``, NaN where a design does not assemble, and with ``jacobian``
        its derivatives ``(D, N, 2, p + 1)`` by the design columns and the input (else
        None)."""
        sp, m = self.plan, self.plan.mechanism
        kp = kernel.kernel_plan(sp)
        geo = Geometry(m, self.names, designs)
        table = geo.gather(sp)
        every = range(len(sp.steps))
        D, N = inputs.shape
        nl, f, h = m.n_links, kp.frame, self.host
        T = np.empty((nl, 3, D, N))
        T[f] = 0.0
        C, S, _ = kernel.run_designs(kp, kernel.lower_designs(sp, kp, geo, every), inputs[..., None], every, T)
        C[f], S[f] = 1.0, 0.0
        r = geo.at(self.point)[:, 0] - table[2][:, h]                   # (as Poses.carry: from its reference point)
        W = np.stack(carried(T[h, 0], T[h, 1], C[h], S[h], r[:, :1], r[:, 1:]), axis=-1)
        if not jacobian:
            return W, None
        q = len(self.names) + 1
        ok = np.all(np.isfinite(C), axis=0).reshape(-1)
        dZ = np.full((nl, D * N, 3, q), np.nan)
        dZ[f] = 0.0
        nb = _sensitivity_kernel()
        flat = lambda a: a.reshape(nl, -1)                  # noqa: E731
        compiled_sensitivities(nb, sensitivity_plan(sp, self.names),
                               (flat(T[:, 0]), flat(T[:, 1]), flat(C), flat(S)), N, table, ok, dZ)
        return W, material_derivative(dZ[h], flat(C)[h], flat(S)[h], r, self.E).reshape(D, N, 2, q)


def _make(sp: SolvePlan, arg) -> TracerBatch:
    names, point = arg
    m = sp.mechanism
    points = [p.name for p in m.points]
    host = sp.point_host[points.index(point)] if point in points else sp.joint_host[m.joint_names.index(point)]
    q = len(names) + 1
    cols = {n: i for i, n in enumerate(names)}
    E = offset_columns(cols, point, origin_joint(m, m.link_names[host]), q)
    E.flags.writeable = False
    return TracerBatch(sp, names, point, host, E)


def _sensitivity_kernel():
    from . import _sensitivity_nb
    return _sensitivity_nb
