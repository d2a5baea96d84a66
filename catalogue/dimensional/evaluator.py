"""The design space of synthesis and its evaluator over the kinematic solver.

The design variables are the reference coordinates of every R joint (frame
pivots included), the guide angle of every prismatic joint, and the tracer
points asked for (:func:`kin.geometry.design_names`); every link length, offset
and pivot of the mechanism follows from them.  :meth:`Evaluator.poses` solves a
whole population × positions in one pass over the mechanism's compiled plan
(:func:`kin.design.solve_designs`: the same steps, kernels and branch signs as
:func:`kin.solve.solve`, every number an array over the designs), so a design
scores on exactly the positions that ``solve`` gives it.  Every group keeps the
assembly branch (mode) of the design's own reference configuration.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from multiloop.kin.design import (DesignPoses, branch_signs, design_mechanism, design_names, path_dependent_steps,
                                  solve_designs, unbatched_steps)
from multiloop.kin import kernel
from multiloop.kin.memo import cached
from multiloop.kin.rigid import perp
from multiloop.kin.geometry import Geometry
from multiloop.topo.assur import DriverStep, decompose
from multiloop.topo.errors import InputError, explain
from multiloop.topo.model import JointKind, Mechanism

__all__ = ["DesignSpace", "Evaluator", "design_space", "four_bar_roles"]


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
    names = list(design_names(m, points))
    pts = [p for p in m.points if p.name in set(points)]
    x0 = []
    for j in m.joints:
        x0 += [float(np.arctan2(j.axis[1], j.axis[0]))] if j.kind is JointKind.P else list(j.at)
    for p in pts:
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


#: how many of its last solves an :class:`Evaluator` keeps (a polish step's residuals at
#: the targets' inputs and its constraint penalty over the grid)
KEPT_SOLVES = 2


class Evaluator:
    """The parameterised solver of one mechanism (compile once, call many times): the
    design decoding of synthesis over :func:`kin.design.solve_designs`.

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
        self._cols = {n: i for i, n in enumerate(space.names)}
        self.deadline: float | None = None      # time.perf_counter() value, for per-design fallbacks
        self._last: list = []                    # [(key, DesignPoses)] of the last KEPT_SOLVES poses() calls
        self.slow = unbatched_steps(m)          # steps solved design by design
        self.path_dependent = bool(path_dependent_steps(m))     # (inputs must be walked to from the reference)

    # -- decoding --------------------------------------------------------------
    def geometry(self, X: np.ndarray) -> Geometry:
        """The geometry of designs ``X`` (every name's position and guide, each computed
        once)."""
        return Geometry(self.mechanism, self.space.names, np.atleast_2d(X))

    def at(self, X: np.ndarray, name: str) -> np.ndarray:
        """Reference position ``(P, 2)`` of joint or point ``name`` for designs ``X``."""
        return self.geometry(X).at(name)[:, 0]

    def axis(self, X: np.ndarray, name: str) -> np.ndarray:
        return self.geometry(X).axis(name)[:, 0]

    # -- solving ---------------------------------------------------------------
    def poses(self, X, phi, outputs=None, keep: bool = True) -> DesignPoses:
        """Solve designs ``X`` ``(P, n_var)`` at driver values ``phi`` ``(P, N)`` or ``(N,)``
        (:func:`kin.design.solve_designs`: each design on its reference branches).

        One driver only (the synthesis problems are single-input); ``phi`` is the
        driver value from the reference configuration (rad, or m for a P driver).
        The last :data:`KEPT_SOLVES` calls' poses are kept: the same designs at the same
        inputs (the polish asks for its Jacobian at the point whose residuals, and
        constraint penalty over the driver grid, it has just had) are not solved again.
        With ``keep`` False (a population, read at once) nothing is kept and the poses
        live in this thread's work arrays until its next such call
        (:func:`kin.design.solve_designs` with ``reuse``).
        """
        X = np.atleast_2d(np.asarray(X, float))
        phi = np.asarray(phi, float)
        if not keep:
            with kernel.for_batches():
                return solve_designs(self.mechanism, self.space.names, X, phi, outputs=outputs,
                                     deadline=self.deadline, reuse=True)
        key = (X.shape, X.tobytes(), phi.shape, phi.tobytes(), None if outputs is None else tuple(outputs),
               self.deadline, kernel.mode(), kernel.is_default())
        for k, st in self._last:
            if k == key:
                return st
        with kernel.for_batches():
            st = solve_designs(self.mechanism, self.space.names, X, phi, outputs=outputs, deadline=self.deadline)
        self._last = [(key, st)] + self._last[:KEPT_SOLVES - 1]
        return st

    def branches(self, X) -> np.ndarray:
        """Assembly branches ``(P, n_dyads)`` (±1, NaN on a boundary) of every RRR, RRP and
        RPR dyad in the reference configuration of designs ``X``: the signs the solver
        uses (:func:`kin.design.branch_signs`)."""
        X = np.atleast_2d(np.asarray(X, float))
        return branch_signs(self.mechanism, self.space.names, X)

    def driver_sense(self) -> tuple[float, str, str]:
        """``(sense, link, other)``: the driven ``link`` turns (slides) by ``sense`` × the
        driver value relative to ``other``."""
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
        j, q = self._driver_arm()
        d = self.at(X, q) - self.at(X, j.name)
        if j.kind is JointKind.R:
            return np.arctan2(d[:, 1], d[:, 0])
        return np.sum(d * self.axis(X, j.name), axis=-1)

    def driver_zero_gradient(self, X) -> np.ndarray:
        """The gradient ``(P, n_var)`` of :meth:`driver_zero` by the design variables: of
        the arm's angle ``atan2(d)``, ``perp(d)/|d|²`` on its two joints' columns; of a
        slide ``d·u``, ``u`` on them and ``d·perp(u)`` on the guide's angle."""
        X = np.atleast_2d(np.asarray(X, float))
        j, q = self._driver_arm()
        d = self.at(X, q) - self.at(X, j.name)
        out = np.zeros(X.shape)
        if j.kind is JointKind.R:
            w = perp(d) / np.sum(d * d, axis=1, keepdims=True)
        else:
            w = self.axis(X, j.name)
            if f"{j.name}.angle" in self._cols:
                out[:, self._cols[f"{j.name}.angle"]] = d[:, 1] * w[:, 0] - d[:, 0] * w[:, 1]
        for sign, name in ((1.0, q), (-1.0, j.name)):
            for i, axis in enumerate("xy"):
                c = self._cols.get(f"{name}.{axis}")
                if c is not None:
                    out[:, c] += sign * w[:, i]
        return out

    def _driver_arm(self):
        """The driver's joint and the driven link's next R joint (the arm :meth:`driver_zero` measures)."""
        m = self.mechanism
        j = m.joint(m.drivers[0].joint)
        _, link, _ = self.driver_sense()
        q = next((k.name for k in m.joints_of(link) if k.kind is JointKind.R and k.name != j.name), None)
        if q is None:
            raise InputError(explain(f"driven link {link!r}", expected="a second R joint to measure its position by",
                                     got="none"))
        return j, q

    # -- outputs ---------------------------------------------------------------
    def point(self, X, phi, name: str) -> tuple[np.ndarray, np.ndarray]:
        """World positions ``(P, N, 2)`` of tracer point or joint ``name`` and ``ok``."""
        st = self.poses(X, phi, outputs=[name])
        return st.point(name), st.ok

    def with_design(self, x) -> Mechanism:
        """The start mechanism with the dimensions of design ``x`` (names kept); the same
        object for the same numbers (kept in the evaluator's memo), so the certified
        walks of one design (its continuity, full rotation and transmission extremes,
        each asked by the selection and again by the report) share its plan's memo."""
        x = np.asarray(x, float)
        return cached(self, ("design", x.tobytes()), lambda ev, v: design_mechanism(
            Geometry(ev.mechanism, ev.space.names, np.frombuffer(v, float)[None, :]), 0), x.tobytes())


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
