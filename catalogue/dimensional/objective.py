"""Objectives of the three synthesis tasks over whole populations, with penalties.

One :class:`Problem` wraps an :class:`~.evaluator.Evaluator` and a target.  Its
:meth:`Problem.batch` scores a population ``(P, n)`` in one evaluator call on a
grid of driver values: the grid is walked from the reference configuration in
both directions until a group fails to assemble (so every configuration used is
reached by continuous motion, with each dyad on its reference branch), and with
free timing the targets are matched to the curve in driver order by dynamic
programming (a monotone assignment: cost ``D[i, k] = d(i, k) + min_{k' <= k}
D[i-1, k']``).  :meth:`Problem.residuals` is the smooth form for the local polish:
the design plus one driver value per target.

Constraints are penalties added to the relative RMS error: full rotation of the
driver, a minimum transmission angle of every dyad (the definitions of
``multiloop check``: :func:`transmission_angles`), bounds on the link lengths and
on the ratio of the longest to the shortest.
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass

import numpy as np

from multiloop.kin import kernel
from multiloop.kin.check.angle_types import angle_type
from multiloop.kin.check.transmission import angle_specs, spec_value
from multiloop.kin.design import DesignPoses, with_cells
from multiloop.kin.groups.registry import reference_margin
from multiloop.kin.memo import cached
from multiloop.kin.rigid import perp, rotate
from multiloop.topo.errors import InputError, ParameterError, explain
from multiloop.topo.model import JointKind

from .evaluator import Evaluator, four_bar_roles
from .targets import FunctionTarget, MotionTarget, PathTarget

__all__ = ["Constraints", "Problem", "transmission_angles", "GRASHOF", "MODES", "DIRECTIONS", "grashof_margins"]

_FAIL = 1e3          # objective of a candidate that cannot reach the targets at all
_CELLS = 2_000_000   # population chunk of :meth:`Problem.batch`: candidates × targets × samples

GRASHOF = ("any", "crank-rocker", "double-crank")
MODES = ("any", "reference")
DIRECTIONS = ("any", "ccw", "cw")


@dataclass(frozen=True)
class Constraints:
    """Design constraints (penalties): see the module docstring."""

    full_rotation: bool = False
    min_transmission: float | None = None      # degrees
    length_bounds: tuple[float, float] | None = None
    max_ratio: float | None = None
    weight: float = 10.0
    grashof: str = "any"          # "crank-rocker", "double-crank" or "any" (four-bars)
    mode: str = "any"             # "reference": every dyad keeps the start's assembly branch
    direction: str = "any"        # "ccw", "cw" or "any": the driven link's sense through the targets

    def __post_init__(self):
        for name, allowed in (("grashof", GRASHOF), ("mode", MODES), ("direction", DIRECTIONS)):
            if getattr(self, name) not in allowed:
                raise ParameterError(explain(name, expected=" or ".join(allowed),
                                             got=repr(getattr(self, name))), name)
        mt = self.min_transmission
        if mt is not None and not (np.isfinite(mt) and 0 <= mt <= 90):
            raise ParameterError(explain("min_transmission", expected="an angle in [0, 90] degrees",
                                         got=str(mt), hint="a folded transmission angle is at most 90°"),
                                 "min_transmission")
        lb = self.length_bounds
        if lb is not None and not (len(lb) == 2 and np.all(np.isfinite(lb)) and 0 < lb[0] < lb[1]):
            raise ParameterError(explain("length_bounds", expected="two lengths 0 < LOW < HIGH (m)",
                                         got=str(tuple(lb))), "length_bounds")
        if self.max_ratio is not None and not (np.isfinite(self.max_ratio) and self.max_ratio >= 1):
            raise ParameterError(explain("max_ratio", expected="a number >= 1", got=str(self.max_ratio)), "max_ratio")

    @property
    def on_motion(self) -> bool:
        """Whether a constraint reads the whole motion (the driver grid), not the design
        or its targets alone: full rotation, a minimum transmission angle."""
        return bool(self.full_rotation or self.min_transmission)


def transmission_angles(ev: Evaluator, X: np.ndarray, st: DesignPoses) -> np.ndarray:
    """Smallest folded transmission angle (deg, in [0, 90]; 90 is ideal) over the groups,
    ``(P, N)``; ``inf`` when there is none.

    The definitions and formulas of ``multiloop check``, from the group-kind registry
    (:func:`multiloop.kin.check.transmission.angle_specs`, ``spec_value``): a triangle
    (RRR, or an actuated one), the angle μ at the inner pin between the lines to the
    outer pins, folded to ``min(μ, 180° − μ)``; RRP and RPR, 90° minus the pressure angle.
    Only the angles whose degenerate value is a reach limit of their group are included
    (:attr:`~multiloop.kin.check.angle_types.AngleType.reach_limit`; not a triad's),
    each folded by its type (``margin(a, a)``: the distance to its nearest degenerate value).
    """
    out = np.full(st.ok.shape, np.inf)
    for sp in angle_specs(ev.plan):
        t = angle_type(sp.quantity)
        if not t.reach_limit:
            continue
        a = spec_value(st, sp)
        out = np.fmin(out, t.margin(a, a))
    return out


#: how far (deg) above ``min_transmission`` the search and the polish hold the lowest
#: transmission angle they estimate (:func:`_lowest`), so that the exact one, which
#: ``multiloop check`` finds between the grid's samples, meets the threshold too
TRANSMISSION_MARGIN = 1e-3


def _lowest(f: np.ndarray, rotary: bool) -> np.ndarray:
    """The minimum ``(P,)`` of samples ``f`` ``(P, M)`` on the driver grid (``inf``: not
    reached), for a rotary grid refined by the parabola through the lowest sample and its
    two neighbours (cyclic when the whole turn is reached): the vertex, below the
    sample by ``(f₊ − f₋)² / 8(f₋ − 2f₀ + f₊)`` when the three are convex.  A sampled
    minimum misses the true one by O(h²); the parabola's by O(h³) where the angle is
    smooth, which it is near its minimum: the lowest of several groups' angles, and an
    angle folded at 90°, have corners only at peaks.  (At a V-shaped dip the vertex
    would lie between the true minimum and the lowest sample.)"""
    P, M = f.shape
    k = np.argmin(f, axis=1)
    rows = np.arange(P)
    f0 = f[rows, k]
    if not rotary or M < 3:
        return f0
    full = np.all(np.isfinite(f), axis=1)
    lo, hi = (k - 1) % M, (k + 1) % M
    inside = full | ((k > 0) & (k < M - 1))
    fl, fr = f[rows, lo], f[rows, hi]
    den = fl - 2.0 * f0 + fr
    good = inside & np.isfinite(fl) & np.isfinite(fr) & (den > 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        vertex = f0 - (fr - fl) ** 2 / (8.0 * den)
    return np.where(good, vertex, f0)


def _wrap(a):
    return (a + np.pi) % (2.0 * np.pi) - np.pi


#: the longest walk (:meth:`Problem.walk`) taken at the grid's spacing: the trackers'
#: short path, every mode at every input (twice their coarse stride)
SHORT_WALK = 64


class Problem:
    """The objective of one task (path, function or motion) on one evaluator.

    Parameters
    ----------
    ev : Evaluator
    target : PathTarget, FunctionTarget or MotionTarget
    constraints : Constraints
    grid : int
        Driver samples over one turn (R driver) or over ±2 mechanism sizes (P driver).
    """

    def __init__(self, ev: Evaluator, target, constraints: Constraints = Constraints(), grid: int = 96):
        self.ev, self.target, self.cons = ev, target, constraints
        m = ev.mechanism
        if len(m.drivers) != 1:
            raise InputError(explain(f"mechanism '{m.name or ''}'", expected="one driver", got=f"{len(m.drivers)}"))
        self.rotary = m.is_rotary(0)
        sp = ev.space
        self.nx = sp.size
        names, x0, lo, hi = list(sp.names), list(sp.x0), list(sp.lower), list(sp.upper)
        size = self.mech_size = m.size
        if isinstance(target, MotionTarget):
            lk = target.link
            if lk not in ev.links:
                raise InputError(explain(f"link {lk!r}", expected="a link of the start", got="an unknown name",
                                         hint=", ".join(m.link_names)))
            c = np.mean([j.at for j in m.joints if lk in j.links], axis=0)
            names += ["frame.x", "frame.y", "frame.angle"]
            x0 += [c[0], c[1], 0.0]
            xs = [n for n in sp.names if n.endswith(".x")]
            ys = [n for n in sp.names if n.endswith(".y")]
            lo += [min(sp.lower[sp.index(n)] for n in xs), min(sp.lower[sp.index(n)] for n in ys), -np.pi]
            hi += [max(sp.upper[sp.index(n)] for n in xs), max(sp.upper[sp.index(n)] for n in ys), np.pi]
        if isinstance(target, PathTarget) and target.shape_only:
            names += ["shape.log_scale", "shape.angle", "shape.dx", "shape.dy"]
            s = target.size
            x0 += [0.0, 0.0, 0.0, 0.0]
            lo += [np.log(0.25), -np.pi, -2 * s, -2 * s]
            hi += [np.log(4.0), np.pi, 2 * s, 2 * s]
        self.sense = ev.driver_sense()[0]
        self.timing_mode = target.timing_mode if isinstance(target, PathTarget) and target.timing is not None \
            else "reference"
        if self.timing_mode == "step":
            names += ["timing.offset"] + (["timing.sense"] if constraints.direction == "any" else [])
            x0 += [0.0, 0.5][:len(names) - len(x0)]
            reach = np.pi if self.rotary else 2.0 * size
            lo += [-reach, -1.0][:len(names) - len(lo)]
            hi += [reach, 1.0][:len(names) - len(hi)]
        self.names = tuple(names)
        self.x0, self.lower, self.upper = (np.array(v, float) for v in (x0, lo, hi))
        self.free_timing = isinstance(target, MotionTarget) or (
            isinstance(target, PathTarget) and target.timing is None)
        self.start_branches = ev.branches(self.x0[None, :self.nx])
        self.roles = four_bar_roles(m)
        if constraints.grashof != "any" and self.roles is None:
            raise ParameterError(explain(f"grashof {constraints.grashof!r}",
                                         expected="a four-bar start (four R joints, driven on the frame)",
                                         got=f"mechanism '{m.name or ''}' with {m.n_links} links",
                                         hint="leave 'grashof' at 'any'"), "grashof")
        self.M = int(grid)
        if self.rotary:
            self.delta = 2.0 * np.pi / self.M
            self.grid = self.delta * np.arange(self.M)
        else:
            half = self.M // 2
            self.delta = 2.0 * size / half
            self.grid = np.concatenate([self.delta * np.arange(half), -self.delta * np.arange(1, half + 1)])
        self._targets = self.target_values()           # (the target is immutable)
        self._fixed_targets: dict = {}                 # (targets_for's arrays by batch size)
        self._size = target.size if target.size > 0 else 1.0
        self.n_targets = len(self._targets)

    def grid_poses(self, X: np.ndarray, keep: bool = True) -> DesignPoses:
        """Designs ``X``'s poses on the driver grid, every sample as the motion from the
        reference reaches it.  A plan without a path-dependent step is solved at the grid's
        values in one call.  A path-dependent one (a triad's or class IV group's mode
        followed along the inputs) follows the grid as one path forward from the reference
        (a slider's forward half), and its samples behind the reference (past where a
        design stops short of a full turn; a slider's backward half) come from a path of
        their own backward from the reference (−δ, −2δ, …,
        :func:`multiloop.kin.design.with_cells`).  (As one path, those samples had
        inherited the forward path's loss: such a design's curve lost its arc behind the
        reference.)"""
        st = self.ev.poses(X, self.grid, keep=keep)
        if not self.ev.path_dependent:
            return st
        M = self.M
        fw = M if self.rotary else M // 2
        ok = st.ok[:, :fw]
        first = np.where(ok.all(axis=1), fw, np.argmin(ok, axis=1))        # (the forward path's first loss)
        lead = (M - 1 - first) if self.rotary else np.full(len(first), M - fw)
        rows = np.flatnonzero((first > 0) & (lead > 0))
        if not rows.size:
            return st
        back = self.ev.poses(X[rows], -self.delta * np.arange(int(lead[rows].max()) + 1))
        n = lead[rows]
        d = np.repeat(np.arange(rows.size), n)
        k = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n) + 1          # (1 .. lead: the input −kδ)
        return with_cells(st, (rows[d], M - k if self.rotary else fw + k - 1), back, (d, k))

    def init_motion_frame(self) -> None:
        """Motion generation: the frame on the link that meets pose 0 exactly at the
        best grid position of the start design (all grid positions scored in one call)."""
        t = self.target
        if not isinstance(t, MotionTarget):
            return
        X = self.x0[None, :self.nx]
        st = self.grid_poses(X)
        k = self.ev.links[t.link]
        th, tx, ty = st.th[k][0], st.tx[k][0], st.ty[k][0]
        good = np.isfinite(th)
        if not good.any():
            return
        p0 = t.poses[0]
        dx, dy = p0[0] - tx[good], p0[1] - ty[good]
        c, s = np.cos(th[good]), np.sin(th[good])
        Z = np.repeat(self.x0[None, :], int(good.sum()), axis=0)
        Z[:, self.nx] = c * dx + s * dy            # R(θ)ᵀ (p0 − t)
        Z[:, self.nx + 1] = -s * dx + c * dy
        Z[:, self.nx + 2] = _wrap(p0[2] - th[good])
        Z = np.clip(Z, self.lower, self.upper)
        self.x0 = Z[int(np.argmin(self.batch(Z)))]

    def init_offset(self) -> None:
        """Step timing: the start's ``timing.offset`` (and ``timing.sense``) at the best of
        the grid's driver values (both senses, one call)."""
        if self.timing_mode != "step":
            return
        Z = np.repeat(self.x0[None, :], 2 * self.M, axis=0)
        i = self.names.index("timing.offset")
        Z[:, i] = np.clip(_wrap(np.tile(self.grid, 2)) if self.rotary else np.tile(self.grid, 2),
                          self.lower[i], self.upper[i])
        if "timing.sense" in self.names:
            Z[self.M:, self.names.index("timing.sense")] = -0.5
        self.x0 = Z[int(np.argmin(self.batch(Z)))]

    def init_shape(self, n_angles: int = 24) -> None:
        """Shape-only paths: the similarity that puts the target's centroid and RMS radius
        on those of the start's curve, at the best of ``n_angles`` rotations (one call)."""
        t = self.target
        if not (isinstance(t, PathTarget) and t.shape_only):
            return
        Z0 = self.x0[None, :]
        st = self.grid_poses(Z0[:, :self.nx])
        F = self.features(Z0, st)[0][st.ok[0]]
        if len(F) < 3:
            return
        T = t.points
        c0 = T.mean(axis=0)
        s = np.sqrt(np.mean(np.sum((F - F.mean(0)) ** 2, 1)) / np.mean(np.sum((T - c0) ** 2, 1)))
        Z = np.repeat(self.x0[None, :], n_angles, axis=0)
        Z[:, self.nx] = np.log(s)
        Z[:, self.nx + 1] = np.linspace(-np.pi, np.pi, n_angles, endpoint=False)
        Z[:, self.nx + 2:self.nx + 4] = F.mean(0) - c0
        lo, hi = self.lower.copy(), self.upper.copy()
        lo[self.nx:], hi[self.nx:] = np.minimum(lo[self.nx:], Z.min(0)[self.nx:]), np.maximum(hi[self.nx:], Z.max(0)[self.nx:])
        self.lower, self.upper = lo, hi
        self.x0 = Z[int(np.argmin(self.batch(Z)))]

    # -- targets and features --------------------------------------------------
    def target_values(self) -> np.ndarray:
        t = self.target
        if isinstance(t, PathTarget):
            return t.points
        if isinstance(t, MotionTarget):
            return t.poses
        return t.outputs[:, None] - t.outputs[0]

    def timing(self) -> np.ndarray | None:
        t = self.target
        if isinstance(t, FunctionTarget):
            return t.inputs - t.inputs[0]
        if isinstance(t, PathTarget) and t.timing is not None:
            return t.timing
        return None

    def timing_for(self, Z: np.ndarray) -> np.ndarray | None:
        """Driver values from the reference ``(P, N)`` at which designs ``Z`` must meet
        the targets (prescribed timing), or None (free timing).

        ``reference``: the table's values; ``absolute``: the table's values less the
        design's own reference value (:meth:`~.evaluator.Evaluator.driver_zero`), the
        first wrapped to (-π, π] for an R driver and the rest following it by the
        table's differences; ``step``: the table's differences from the free offset
        ``timing.offset``, in the sense of ``direction`` (or of ``timing.sense``)."""
        tim = self.timing()
        if tim is None:
            return None
        P = Z.shape[0]
        if self.timing_mode == "reference":
            return np.broadcast_to(tim, (P, len(tim)))
        d = (tim - tim[0])[None, :]
        if self.timing_mode == "absolute":
            first = self.sense * (tim[0] - self.ev.driver_zero(Z[:, :self.nx]))
            first = _wrap(first) if self.rotary else first
            return first[:, None] + self.sense * d
        off = Z[:, self.names.index("timing.offset")][:, None]
        if "timing.sense" in self.names:
            sg = np.where(Z[:, self.names.index("timing.sense")] >= 0, 1.0, -1.0)[:, None]
        else:
            sg = -1.0 if self.cons.direction == "cw" else 1.0
        return off + self.sense * sg * d

    def walks(self) -> tuple[int, ...]:
        """Which walks of :meth:`orders` free timing may use: 0 forward (the driver value
        increasing), 1 backward; ``direction`` picks the one that turns the driven link
        counter-clockwise (``ccw``, or the slider forward) or clockwise."""
        if self.cons.direction == "any":
            return (0, 1)
        up = (self.cons.direction == "ccw") == (self.sense > 0)
        return (0,) if up else (1,)

    def targets_for(self, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Targets ``(P, N, c)`` (transformed for shape-only) and their size ``(P,)``."""
        T = self._targets
        P = Z.shape[0]
        t = self.target
        if isinstance(t, PathTarget) and t.shape_only:
            e = Z[:, self.nx:]
            s, a = np.exp(e[:, 0]), e[:, 1]
            c0 = T.mean(axis=0)
            d = T - c0
            cs, sn = np.cos(a)[:, None], np.sin(a)[:, None]
            x = s[:, None] * (cs * d[:, 0] - sn * d[:, 1]) + c0[0] + e[:, 2:3]
            y = s[:, None] * (sn * d[:, 0] + cs * d[:, 1]) + c0[1] + e[:, 3:4]
            return np.stack([x, y], axis=-1), s * t.size
        hit = self._fixed_targets.get(P)
        if hit is None:                     # (read-only views, the same for every batch of P designs)
            size = np.full(P, self._size)
            size.flags.writeable = False
            hit = self._fixed_targets[P] = (np.broadcast_to(T, (P,) + T.shape), size)
        return hit

    def features(self, Z: np.ndarray, st: DesignPoses) -> np.ndarray:
        """What is compared with the targets, ``(P, N, c)``, from poses ``st``."""
        ev, t = self.ev, self.target
        X = Z[:, :self.nx]
        if isinstance(t, PathTarget):
            k = ev.links[next(p.link for p in ev.mechanism.points if p.name == t.point)]
            return st.world(k, st.geometry.at(t.point)[:, 0])            # (the solve's designs: X)
        if isinstance(t, MotionTarget):
            k = ev.links[t.link]
            e = Z[:, self.nx:]
            xy = st.world(k, e[:, :2])
            return np.concatenate([xy, (st.th[k] + e[:, 2:3])[..., None]], axis=-1)
        j = ev.mechanism.joint(t.joint)
        ka, kb = ev.links[j.links[0]], ev.links[j.links[1]]
        if j.kind is JointKind.R:
            return (st.th[kb] - st.th[ka])[..., None]
        r = ev.at(X, j.name)
        ua = rotate(ev.axis(X, j.name)[:, None, :], st.th[ka])     # (the guide carried by its link)
        return np.sum((st.world(kb, r) - st.world(ka, r)) * ua, axis=-1)[..., None]

    def kept_features(self, Z: np.ndarray, st: DesignPoses) -> np.ndarray:
        """:meth:`features` kept beside the poses ``st`` (read-only): the polish asks for
        the residuals and then the Jacobian at the same point, whose poses the evaluator
        keeps (:meth:`~.evaluator.Evaluator.poses`)."""
        def compute(st, Z):
            F = self.features(Z, st)
            F.flags.writeable = False
            return F
        return cached(st, ("features", Z.shape, Z.tobytes()), compute, Z)

    def diff(self, F: np.ndarray, T: np.ndarray, size: np.ndarray) -> np.ndarray:
        """Relative differences of features ``F`` and targets ``T``, both ``(P, N, c)``
        (target by target; angles wrapped)."""
        D = F - T
        inv = (1.0 / size)[:, None, None]
        if isinstance(self.target, MotionTarget):
            return np.concatenate([D[..., :2] * inv, _wrap(D[..., 2:])], axis=-1)
        if isinstance(self.target, FunctionTarget) and self.ev.mechanism.joint(self.target.joint).kind.is_rotary:
            return _wrap(D) * inv
        return D * inv

    def sqdist(self, F: np.ndarray, T: np.ndarray, size: np.ndarray) -> np.ndarray:
        """Squared relative distances ``(P, N, K)`` of features ``F`` (P, K, c) to
        targets ``T`` (P, N, c), column by column (no (P, N, K, c) array)."""
        ang = self.angular
        c = F.shape[-1]
        inv = (1.0 / size)[:, None, None]
        out = None
        for j in range(c):
            d = F[:, None, :, j] - T[:, :, None, j]
            if ang and j == c - 1:
                d = _wrap(d)
                if c == 1:
                    d = d * inv
            else:
                d = d * inv
            out = d * d if out is None else out + d * d
        return out

    # -- the reachable curve ---------------------------------------------------
    def curve(self, ok: np.ndarray):
        """Order of the grid samples reached continuously from the reference.

        Returns ``idx`` (P, K) into the grid, ``valid`` (P, K), driver values
        ``phi`` (P, K) in driver order, and ``full`` (P,) (full rotation).
        """
        P = ok.shape[0]
        M = self.M
        if self.rotary:
            f = np.where(ok.all(1), M, np.argmin(ok, axis=1))
            rev = ok[:, :0:-1]
            b = np.where(rev.all(1), M - 1, np.argmin(rev, axis=1))
            b = np.where(f == M, 0, b)
            full = f == M
            K = 2 * M
            k = np.arange(K)[None, :]
            idx = np.where(full[:, None], k % M, (k - b[:, None]) % M)
            valid = full[:, None] | (k < (b + f)[:, None])
            phi = np.where(full[:, None], k, k - b[:, None]) * self.delta
            return idx, valid, phi, full
        half = M // 2
        fw, bw = ok[:, :half], ok[:, half:]
        f = np.where(fw.all(1), half, np.argmin(fw, axis=1))
        b = np.where(bw.all(1), half, np.argmin(bw, axis=1))
        K = M
        k = np.arange(K)[None, :]
        idx = np.where(k < b[:, None], half + (b[:, None] - 1 - k), k - b[:, None])
        valid = k < (b + f)[:, None]
        idx = np.where(valid, idx, 0)
        phi = (k - b[:, None]) * self.delta
        return idx, valid, phi, np.zeros(P, bool)

    # -- global objective ------------------------------------------------------
    def batch(self, Z: np.ndarray) -> np.ndarray:
        """Objective of a population ``Z`` ``(P, n)`` (lower is better), scored in
        chunks of at most ``_CELLS`` candidate × target × sample cells."""
        Z = np.atleast_2d(Z)
        step = max(1, _CELLS // ((self.M + self.n_targets) * max(self.n_targets, 1)))
        if Z.shape[0] > step:
            return np.concatenate([self._batch(Z[i:i + step]) for i in range(0, Z.shape[0], step)])
        return self._batch(Z)

    def _batch(self, Z: np.ndarray) -> np.ndarray:
        X = Z[:, :self.nx]
        tim = self.timing_for(Z)
        if tim is not None and self.ev.path_dependent:
            return self._prescribed_walk(Z, tim)
        if tim is not None and self.targets_only(tim):
            return self.score_at(Z, tim)
        M = self.M
        tracer = self._tracer() if tim is None and not self.cons.min_transmission else None
        if tracer is not None:              # (a path's curve straight from the design matrix: no pose store)
            st, (F, ok) = None, tracer.curve(X, self.grid)
        else:
            st = self.grid_poses(X, keep=False) if tim is None else \
                self.ev.poses(X, np.concatenate([np.broadcast_to(self.grid, (Z.shape[0], M)), tim], axis=1), keep=False)
            F, ok = self.features(Z, st), st.ok
        T, size = self.targets_for(Z)
        ok = ok[:, :M]
        if tim is None:
            full = ok.all(axis=1) if self.rotary else np.zeros(len(ok), bool)    # (as curve's)
            cost = self.free_costs(F[:, :M], T, size, ok, full)
        else:
            idx, valid, cphi, full = self.curve(ok)
            cost = np.sum(np.square(self.diff(F[:, M:], T, size)), axis=(1, 2))
            lo, hi = np.nanmin(np.where(valid, cphi, np.nan), 1), np.nanmax(np.where(valid, cphi, np.nan), 1)
            inside = full[:, None] | ((tim >= lo[:, None] - 1e-12) & (tim <= hi[:, None] + 1e-12))
            cost = np.where(inside.all(1), cost, np.inf)
        return self._score(cost, self.violation(X, st, full, ok))

    def _score(self, cost: np.ndarray, violation: np.ndarray) -> np.ndarray:
        """The objective ``(P,)`` from the targets' summed squared relative errors and the
        constraint violation: the RMS error plus the weighted violation, :data:`_FAIL`
        where either is not finite."""
        f = np.sqrt(cost / self.n_targets) + self.cons.weight * violation
        return np.where(np.isfinite(f), f, _FAIL)

    def targets_only(self, tim: np.ndarray) -> bool:
        """Whether prescribed timing's population is solved at the targets' driver values
        ``tim`` (P, N) alone (:meth:`score_at`): unless a constraint reads the whole
        motion (full rotation, transmission), for which the driver grid is solved anyway
        and its samples from the reference decide whether the motion reaches the targets."""
        return not self.cons.on_motion and bool(np.all(np.isfinite(tim)))

    def score_at(self, Z: np.ndarray, PHI: np.ndarray) -> np.ndarray:
        """The objective ``(P,)`` of designs ``Z`` each solved at its own driver values
        ``PHI`` (P, N) alone: the RMS of the relative residuals the polish minimises
        (:meth:`residuals_batch`) plus the weighted constraint violation (the grid's, only
        for a constraint read over the whole motion).  Prescribed timing's search
        (:meth:`targets_only`) and free timing's searched route
        (:class:`~.searched_timing.SearchedTiming`) score their candidates so; whether the
        motion reaches the targets continuously from the reference is decided for the
        chosen design by the certified walk (:func:`~.synthesise._certified`), not by a
        grid."""
        R = self.residuals_batch(Z, PHI)
        cost = np.einsum("pk,pk->p", R, R)
        if self.cons.on_motion:
            violation = self.penalty_batch(Z) / self.cons.weight
        else:
            violation = self.violation(Z[:, :self.nx], None, None)
        return self._score(cost, violation)

    def _prescribed_walk(self, Z: np.ndarray, tim: np.ndarray) -> np.ndarray:
        """:meth:`_batch` with prescribed timing on a path-dependent plan (a triad's or
        class IV group's mode is followed along the inputs): the targets solved along
        :meth:`walk` from the reference, on the mode the motion itself reaches (as the
        polish's residuals and the certified motion have them), and reached when every
        input of the walk assembles.  The grid is solved on its own, and only for a
        constraint that reads the whole motion.  (Solved after the grid as one path, the
        targets inherited the grid's end: a design that does not turn fully lost them all,
        and a first target far from the grid's last sample was a jump the tracker refuses.)"""
        X = Z[:, :self.nx]
        W, at = self.walk(tim)
        st = self.ev.poses(X, W, keep=False)
        T, size = self.targets_for(Z)
        F = self.features(Z, st)[:, at]
        cost = np.where(st.ok.all(axis=1), np.sum(np.square(self.diff(F, T, size)), axis=(1, 2)), np.inf)
        if self.cons.on_motion:
            st = self.grid_poses(X)
            return self._score(cost, self.violation(X, st, self.curve(st.ok[:, :self.M])[3]))
        return self._score(cost, self.violation(X, st, None))

    def free_costs(self, F: np.ndarray, T: np.ndarray, size: np.ndarray, ok: np.ndarray,
                   full: np.ndarray) -> np.ndarray:
        """Free timing: each candidate's smallest sum of squared relative distances of
        the targets ``T`` (P, N, c) to its grid features ``F`` (P, M, c), assigned in
        driver order along its allowed walks (:meth:`walks`) of the samples reached
        from the reference (``ok`` (P, M), ``full`` (P,) from :meth:`curve`), ``(P,)``.
        The compiled route (:mod:`._match_nb`) when the kernel is in use, else NumPy's;
        the two agree bit for bit."""
        nb = compiled_module("_match_nb")
        if nb is not None:
            out = np.empty(F.shape[0])
            walks = self.walks()
            nb.free_timing_costs(np.ascontiguousarray(F), np.ascontiguousarray(T), 1.0 / size,
                                 np.ascontiguousarray(ok), self.rotary, self.angular, 0 in walks, 1 in walks, out)
            return out
        d0 = self.sqdist(F, T[:, :1], size)[:, 0]
        (oidx, ovalid, _), _ = self.orders(ok, d0)
        Fo = np.take_along_axis(F, oidx[..., None], axis=1)
        d2f = np.where(ovalid[:, None, :], self.sqdist(Fo, T, size), np.inf)
        # backward walk: the forward one reversed (and, for a closed curve, shifted so that
        # it starts two samples past the sample nearest to the first target)
        rev = d2f[..., ::-1]
        d2b = np.where(full[:, None, None], np.roll(rev, 5, axis=2), rev)
        return np.min([_dp(d) for k, d in enumerate((d2f, d2b)) if k in self.walks()], axis=0)

    @property
    def angular(self) -> bool:
        """Whether the last feature is an angle (compared wrapped to (−π, π])."""
        return isinstance(self.target, MotionTarget) or (
            isinstance(self.target, FunctionTarget) and self.ev.mechanism.joint(self.target.joint).kind.is_rotary)

    @property
    def constrained(self) -> bool:
        """Whether any design constraint is set (the reference margin always counts)."""
        c = self.cons
        return bool(c.on_motion or c.length_bounds or c.max_ratio
                    or c.grashof != "any" or c.mode != "any")

    def penalty_batch(self, Z: np.ndarray) -> np.ndarray:
        """The constraint penalty of :meth:`batch` alone, ``(P,)``: the weighted
        violation over the driver grid walked from the reference."""
        X = np.atleast_2d(Z)[:, :self.nx]
        st = self.grid_poses(X)
        full = self.curve(st.ok[:, :self.M])[3]
        return self.cons.weight * self.violation(X, st, full)

    def reference_margin(self, X: np.ndarray) -> np.ndarray:
        """Smallest relative determinant of the groups in the reference configuration
        ``(P,)``, each kind's own (:func:`multiloop.kin.groups.registry.reference_margin`:
        |sin| of the angle between an RRR's links, |cos| between an RRP's link and guide,
        slide / pivot distance of an RPR).  Zero is a singular reference, which no
        solver accepts."""
        ev = self.ev
        geo = ev.geometry(X)
        out = np.ones(X.shape[0])
        for g in ev.plan.groups:
            r = reference_margin(ev.mechanism, g, lambda n: geo.at(n)[:, 0], lambda n: geo.axis(n)[:, 0])
            if r is not None:
                out = np.fmin(out, np.where(np.isfinite(r), r, 0.0))
        return out

    def violation(self, X: np.ndarray, st: DesignPoses | None, full: np.ndarray,
                  ok: np.ndarray | None = None) -> np.ndarray:
        """Sum of the relative constraint violations ``(P,)``; a reference configuration
        within 1e-3 of a singular one always counts.  ``ok`` (P, M) where the grid's
        samples assembled (default: the poses' ``st``; without poses no
        ``min_transmission``)."""
        c = self.cons
        v = np.maximum(0.0, 1e-3 - self.reference_margin(X)) / 1e-3
        if c.full_rotation:
            v += np.where(full, 0.0, 1.0 - np.mean((st.ok if ok is None else ok)[:, :self.M], axis=1))
        if c.min_transmission:
            mu = np.where(st.ok[:, :self.M], transmission_angles(self.ev, X, st)[:, :self.M], np.inf)
            mu = _lowest(mu, self.rotary)
            v += np.maximum(0.0, c.min_transmission + TRANSMISSION_MARGIN - mu) / c.min_transmission
        if c.length_bounds or c.max_ratio:
            L = self.lengths(X)
            if c.length_bounds:
                a, b = c.length_bounds
                v += np.sum(np.maximum(0.0, a - L) / a + np.maximum(0.0, L - b) / b, axis=1)
            if c.max_ratio:
                r = L.max(1) / np.maximum(L.min(1), 1e-300)
                v += np.maximum(0.0, r / c.max_ratio - 1.0)
        if c.grashof != "any":
            v += np.sum(grashof_margins(self, X), axis=1)
        if c.mode == "reference":
            v += np.sum(self.ev.branches(X) != self.start_branches, axis=1)
        return v

    def lengths(self, X: np.ndarray) -> np.ndarray:
        """Distances between the joints of each link ``(P, n_lengths)`` (the frame's too)."""
        m, geo = self.ev.mechanism, self.ev.geometry(X)
        out = []
        for lk in m.link_names:
            js = [j.name for j in m.joints_of(lk) if j.kind is JointKind.R]
            for a in range(len(js)):
                for b in range(a + 1, len(js)):
                    out.append(np.hypot(*(geo.at(js[a])[:, 0] - geo.at(js[b])[:, 0]).T))
        return np.stack(out, axis=1) if out else np.ones((X.shape[0], 1))

    # -- matching and local residuals ------------------------------------------
    def match(self, z: np.ndarray) -> np.ndarray:
        """Driver values ``(N,)`` at which design ``z`` best meets the targets, in order."""
        Z = z[None, :]
        tim = self.timing_for(Z)
        if tim is not None:
            return np.array(tim[0], float)
        st = self.grid_poses(Z[:, :self.nx])
        T, size = self.targets_for(Z)
        d2g = self.sqdist(self.features(Z, st), T, size)
        best = None
        for k, (oidx, ovalid, ophi) in enumerate(self.orders(st.ok, d2g[:, 0, :])):
            if k not in self.walks():
                continue
            d2 = np.where(ovalid[0][None, :], d2g[0][:, oidx[0]], np.inf)
            path, cost = _dp_path(d2)
            if best is None or cost < best[0]:
                best = (cost, ophi[0, path])
        return best[1]

    def orders(self, ok: np.ndarray, d0: np.ndarray):
        """The two ways (forward, backward) of walking the reachable grid in driver order:
        ``[(idx, valid, phi), ...]``, each ``(P, M)``.

        A fully rotating driver's curve is closed: it is cut one turn long, starting
        two samples before the sample nearest to the first target, so the targets
        are met within one turn (forward from the sample nearest the reference, that
        is from −2δ: a path-dependent plan's polish then walks to its targets from the
        reference, not a whole turn round to them).  Otherwise the reachable arc is walked from one
        end to the other.
        """
        idx, valid, phi, full = self.curve(ok)
        M = self.M
        idx, valid, phi = idx[:, :M], valid[:, :M], phi[:, :M]
        k = np.arange(M)[None, :]
        out = [(idx, valid, phi), (idx[:, ::-1], valid[:, ::-1], phi[:, ::-1])]
        if not full.any():
            return out
        k0 = np.argmin(np.where(ok, d0, np.inf), axis=1)[:, None]
        f = full[:, None]
        s = k0 - 2
        sr = (k0 + 2) % M
        fw = (np.where(f, (s + k) % M, idx), valid | f, np.where(f, (s + k) * self.delta, phi))
        bw = (np.where(f, (sr - k) % M, out[1][0]), out[1][1] | f,
              np.where(f, (sr - k) * self.delta, out[1][2]))
        return [fw, bw]

    def residuals(self, z: np.ndarray, phi: np.ndarray) -> np.ndarray:
        """Relative residuals ``(N·c,)`` of design ``z`` at driver values ``phi``."""
        return self.residuals_batch(z[None, :], np.asarray(phi, float)[None, :])[0]

    def residuals_batch(self, Z: np.ndarray, PHI: np.ndarray) -> np.ndarray:
        """Residuals ``(P, N·c)`` of designs ``Z`` (P, n), each at its own ``PHI`` (P, N).

        A plan with a path-dependent step (a triad's or class IV group's mode) is solved
        along :meth:`walk` from the reference to ``PHI``, so that its targets are met on
        the mode the motion itself reaches, as :func:`~.synthesise.synthesise` and the
        certified ``solve`` judge them, not on the mode nearest the reference's at the
        first target."""
        T, size = self.targets_for(Z)
        if not self.ev.path_dependent:
            tracer = self._tracer()
            F = tracer.solve(Z[:, :self.nx], PHI)[0] if tracer is not None else \
                self.kept_features(Z, self.ev.poses(Z[:, :self.nx], PHI))
            return self.diff(F, T, size).reshape(Z.shape[0], -1)
        W, at = self.walk(PHI)
        tracer = self._tracer(walked=True)
        F = tracer.solve(Z[:, :self.nx], W)[0] if tracer is not None else \
            self.kept_features(Z, self.ev.poses(Z[:, :self.nx], W))
        return self.diff(F[:, at], T, size).reshape(Z.shape[0], -1)

    @property
    def exact_jacobian(self) -> bool:
        """Whether :meth:`jacobian_batch` has the polish's Jacobian: every task (path,
        with any timing and shape-only too; motion; function) with no constraint but
        ``full_rotation``."""
        c = self.cons
        return not (c.min_transmission or c.length_bounds or c.max_ratio or c.grashof != "any" or c.mode != "any")

    def jacobian_batch(self, Z: np.ndarray, PHI: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The residuals ``(P, N·c)`` of :meth:`residuals_batch` (and the penalty, when
        constrained) and their exact Jacobian ``(P, N·c, n)`` by the problem's variables
        and, with free timing, each target's driver value (``n = len(names) + N``); only
        where :attr:`exact_jacobian`.

        The features' derivatives come from the poses' design sensitivities
        (:func:`multiloop.kin.sensitivity.pose_sensitivity`: every step's velocity
        analogue; :meth:`_feature_jacobian`), by a driver value the velocity analogue
        itself; a path-dependent plan is solved along its :meth:`walk` and differentiated
        at the targets' inputs.  The timing's variables move every target's driver value
        (``timing.offset`` by 1, an absolute timing by minus the design's own zero,
        :meth:`~.evaluator.Evaluator.driver_zero_gradient`); a shape-only target's
        similarity moves the target and its size."""
        P, N = PHI.shape
        X = Z[:, :self.nx]
        T, size = self.targets_for(Z)
        tracer = self._tracer(walked=True)
        if tracer is not None:
            W, at = self.walk(PHI) if self.ev.path_dependent else (PHI, np.arange(N))
            (F, dF), frame = tracer.solve(X, W, jacobian=True), None
        else:
            F, dF, frame, at = self._features_and_jacobian(Z, PHI)
        R = self.diff(F[:, at], T, size)
        c = R.shape[2]
        over = size[:, None, None, None]
        if isinstance(self.target, MotionTarget):
            over = np.broadcast_to(over, (P, 1, c, 1)).copy()
            over[:, :, 2] = 1.0                                               # (the angle: not over the size)
        dF, frame = dF[:, at] / over, None if frame is None else frame[:, at] / over
        J = np.zeros((P, N, c, len(self.names) + (N if self.free_timing else 0)))
        J[..., :self.nx] = dF[..., :self.nx]
        rate = dF[..., self.nx]                                               # (P, N, c) by each target's driver value
        if self.free_timing:
            J[:, np.arange(N), :, len(self.names) + np.arange(N)] = np.swapaxes(rate, 0, 1)   # (target i: its own)
        elif self.timing_mode == "absolute":
            J[..., :self.nx] -= self.sense * rate[..., None] * self.ev.driver_zero_gradient(X)[:, None, None, :]
        elif self.timing_mode == "step":
            J[..., self.names.index("timing.offset")] = rate
        if frame is not None:
            J[..., self.nx:self.nx + 3] = frame
        if isinstance(self.target, PathTarget) and self.target.shape_only:
            self._shape_columns(J, Z, T, R)
        R, J = R.reshape(P, -1), J.reshape(P, N * c, -1)
        if self.constrained:
            R = np.concatenate([R, self.penalty_batch(Z)[:, None]], axis=1)
            J = np.concatenate([J, self._penalty_gradient(X, J.shape[2])[:, None, :]], axis=1)
        return R, J

    def _tracer(self, walked: bool = False):
        """A path target's tracer point on the compiled kernels straight from the design
        matrix (:class:`multiloop.kin.tracer_batch.TracerBatch`: the same floats as the
        pose store's, without it) when populations run compiled and the plan has a
        compiled step and lowering for every step; else None.  A path-dependent plan's
        (a triad's followed mode) only for a caller that solves it along :meth:`walk`
        (``walked``: the polish's residuals and Jacobian), not on the grid's two paths
        (:meth:`grid_poses`) nor at the targets' own inputs."""
        if not (isinstance(self.target, PathTarget) and kernel.compiled_batches()) or \
                (self.ev.path_dependent and not walked):
            return None
        return cached(self, "tracer batch", _tracer_batch)[0]            # (the plan and names are fixed)

    def _features_and_jacobian(self, Z: np.ndarray, PHI: np.ndarray):
        """:meth:`features` ``F`` and their derivatives ``dF`` (:meth:`_feature_jacobian`,
        and the frame's) by the pose store and its sensitivities, along :meth:`walk` for a
        path-dependent plan, and the walk's columns ``at`` of the driver values ``PHI``."""
        from multiloop.kin.sensitivity import pose_sensitivity
        W, at = (PHI, np.arange(PHI.shape[1])) if not self.ev.path_dependent else self.walk(PHI)
        st = self.ev.poses(Z[:, :self.nx], W)
        with kernel.for_batches():
            sens = pose_sensitivity(st)
        F = self.kept_features(Z, st)
        return (F,) + self._feature_jacobian(Z, st, sens, F) + (at,)

    def _feature_jacobian(self, Z: np.ndarray, st: DesignPoses, sens, F: np.ndarray):
        """The derivatives ``(P, L, c, nx + 1)`` of :meth:`features` by the design and
        the driver value, and for a motion target by its frame ``(P, L, 3, 3)`` (else
        None): a path's tracer point; a motion's frame point ``R(θ) e + t`` on its link
        (moving with the link, and by ``R(θ)`` with the frame's offset) and the link's
        angle plus the frame's; a function's relative angle ``θ_b − θ_a`` (R output) or
        slide ``(p_b − p_a)·R(θ_a) u`` (P output)."""
        ev, t = self.ev, self.target
        X = Z[:, :self.nx]
        if isinstance(t, PathTarget):
            return sens.point(t.point), None
        if isinstance(t, MotionTarget):
            k = ev.links[t.link]
            xy = sens.material(k, Z[:, self.nx:self.nx + 2])
            th = sens.angle(t.link)[:, :, None, :]
            frame = np.zeros(F.shape[:2] + (3, 3))
            c, s = np.cos(st.th[k]), np.sin(st.th[k])
            frame[..., 0, 0], frame[..., 0, 1], frame[..., 1, 0], frame[..., 1, 1] = c, -s, s, c
            frame[..., 2, 2] = 1.0
            return np.concatenate([xy, th], axis=2), frame
        j = ev.mechanism.joint(t.joint)
        a, b = j.links[0], j.links[1]
        if j.kind is JointKind.R:
            return (sens.angle(b) - sens.angle(a))[:, :, None, :], None
        ka, kb = ev.links[a], ev.links[b]
        r = ev.at(X, j.name)
        ua = rotate(ev.axis(X, j.name)[:, None, :], st.th[ka])                  # (P, L, 2): the guide on its link
        gap = st.world(kb, r) - st.world(ka, r)
        dgap = sens.material(kb, r) - sens.material(ka, r)
        dua = perp(ua)[..., None] * sens.angle(a)[:, :, None, :]
        if f"{j.name}.angle" in ev.space.names:
            dua[..., ev.space.names.index(f"{j.name}.angle")] += perp(ua)       # (R(θ) perp(u) = perp(R(θ) u))
        return (np.einsum("plc,plcq->plq", ua, dgap) + np.einsum("plc,plcq->plq", gap, dua))[:, :, None, :], None

    def _shape_columns(self, J: np.ndarray, Z: np.ndarray, T: np.ndarray, R: np.ndarray) -> None:
        """A shape-only target's similarity columns of ``J`` (P, N, 2, n), in place: the
        target ``T = s Rot(a) (t − c₀) + c₀ + (dx, dy)`` and the size ``s L`` move the
        residuals ``(F − T)/(s L)`` by ``−(T − c₀ − d) /(s L) − R`` (log s),
        ``−perp(T − c₀ − d)/(s L)`` (a) and ``−e_x/(s L)``, ``−e_y/(s L)``."""
        e = Z[:, self.nx:self.nx + 4]
        inv = 1.0 / (np.exp(e[:, 0]) * self.target.size)[:, None, None]
        arm = T - self.target.points.mean(axis=0) - e[:, None, 2:4]
        k = self.nx
        J[..., k] = -arm * inv - R
        J[..., k + 1] = np.stack([arm[..., 1], -arm[..., 0]], axis=-1) * inv
        J[..., 0, k + 2] = -inv[..., 0]
        J[..., 1, k + 3] = -inv[..., 0]

    def _penalty_gradient(self, X: np.ndarray, n: int, h: float = 1e-7) -> np.ndarray:
        """The gradient ``(P, n)`` of :meth:`penalty_batch` where only ``full_rotation`` is
        set: its full-rotation term, the fraction of the grid that fails, is piecewise
        constant (its derivative zero wherever it has one), and the reference-margin
        hinge ``max(0, 1e-3 − m(X))/1e-3``, explicit in the design (no motion solved), is
        differenced forward by ``h`` of the mechanism's size where it is active."""
        out = np.zeros((X.shape[0], n))
        m0 = self.reference_margin(X)
        for p in np.flatnonzero(m0 < 1e-3):
            step = h * self.mech_size
            moved = X[p] + step * np.eye(self.nx)
            hinge = np.maximum(0.0, 1e-3 - self.reference_margin(moved)) / 1e-3
            out[p, :self.nx] = self.cons.weight * (hinge - max(0.0, 1e-3 - m0[p]) / 1e-3) / step
        return out

    def walk(self, PHI: np.ndarray, max_steps: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`_walk`, kept for the last few ``PHI`` (read-only): the polish asks for the
        residuals and then the Jacobian at the same driver values."""
        PHI = np.asarray(PHI, float)
        return cached(self, ("walk", PHI.shape, PHI.tobytes(), max_steps), lambda _, a: _frozen(self._walk(*a)),
                      (PHI, max_steps))

    def _walk(self, PHI: np.ndarray, max_steps: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Driver values ``W`` (P, L) that walk from the reference (0) through each design's
        ``PHI`` (P, N) in order by steps of at most the grid's spacing, and the columns
        ``at`` (N,) with ``W[:, at] == PHI``.  The designs share the number of steps of
        each stretch (the largest of the batch's); a stretch takes at most ``max_steps``
        (default two turns of the grid), beyond which its steps grow.  A walk longer
        than :data:`SHORT_WALK` inputs takes steps of up to three grid spacings to stay
        within it: the triad and class IV trackers compute every mode at every input of
        so short a path (:func:`multiloop.kin.groups.triad.track_designs`), which costs
        a fifth of a longer path's coarse following and its refinements, and they still
        never switch a mode silently (an ambiguous step loses the design)."""
        PHI = np.asarray(PHI, float)
        P, N = PHI.shape
        prev = np.concatenate([np.zeros((P, 1)), PHI[:, :-1]], axis=1)
        gap = PHI - prev
        span = np.max(np.abs(np.nan_to_num(gap, nan=0.0, posinf=0.0, neginf=0.0)), axis=0)
        cap = max_steps or 2 * self.M
        n = np.clip(np.ceil(span / self.delta - 1e-9), 1, cap).astype(int)
        room = SHORT_WALK - 1 - N                  # (inputs left for the steps between the targets)
        if room > 0 and n.sum() + 1 > SHORT_WALK:
            h = self.delta * min(3.0, max(1.0, float(np.sum(span)) / self.delta / room))
            n = np.clip(np.ceil(span / h - 1e-9), 1, cap).astype(int)
        which = np.repeat(np.arange(N), n)
        ends = np.cumsum(n)
        frac = (np.arange(ends[-1]) - np.repeat(ends - n, n) + 1) / np.repeat(n, n)
        W = prev[:, which] + gap[:, which] * frac
        W[:, ends - 1] = PHI                      # (exactly, not by a fraction of 1)
        return np.concatenate([np.zeros((P, 1)), W], axis=1), ends


def _tracer_batch(problem: Problem, _) -> tuple:
    """:meth:`Problem._tracer`'s batch, in a tuple (a memo keeps no None)."""
    from multiloop.kin.tracer_batch import TracerBatch
    return (TracerBatch.of(problem.ev.mechanism, tuple(problem.ev.space.names), problem.target.point),)


def _frozen(arrays: tuple) -> tuple:
    """``arrays`` made read-only (values kept in a memo)."""
    for a in arrays:
        a.flags.writeable = False
    return arrays


def grashof_margins(problem: Problem, X: np.ndarray) -> np.ndarray:
    """Violations ``(P, 2)`` of a four-bar's Grashof condition, relative to the mean
    link length: ``s + l − p − q`` (shortest plus longest against the other two;
    Grashof 1883) and the excess of the link that must be shortest over the
    shortest of the others (the crank for ``crank-rocker``, the frame for
    ``double-crank``).  Zero when the condition holds."""
    r, ev = problem.roles, problem.ev
    seg = lambda a, b: np.hypot(*(ev.at(X, r[a]) - ev.at(X, r[b])).T)  # noqa: E731
    L = np.stack([seg("O_in", "A"), seg("A", "B"), seg("B", "O_out"), seg("O_out", "O_in")], axis=1)
    mean = np.mean(L, axis=1)
    s, ln = L.min(1), L.max(1)
    g = np.maximum(0.0, 2.0 * (s + ln) - L.sum(1)) / mean
    k = 0 if problem.cons.grashof == "crank-rocker" else 3
    others = np.delete(L, k, axis=1).min(1)
    return np.stack([g, np.maximum(0.0, L[:, k] - others) / mean], axis=1)


def compiled_module(name: str):
    """This package's numba module ``name`` (``"_match_nb"``: free timing's matching,
    ``"_trust_nb"``: the polish's trust-region step) when populations run compiled
    (:func:`multiloop.kin.kernel.compiled_batches`), else None (the NumPy route)."""
    if not kernel.compiled_batches():
        return None
    hit = _COMPILED.get(name)
    if hit is None:
        hit = _COMPILED[name] = importlib.import_module(f".{name}", __package__)
    return hit


_COMPILED: dict = {}


def _dp(d2: np.ndarray) -> np.ndarray:
    """Cheapest monotone assignment cost of N targets to K ordered samples, ``(P,)``."""
    acc = d2[:, 0]
    for i in range(1, d2.shape[1]):
        acc = d2[:, i] + np.minimum.accumulate(acc, axis=1)
    return acc.min(axis=1)


def _dp_path(d2: np.ndarray) -> tuple[list[int], float]:
    """The assignment itself for one candidate ``d2`` (N, K): sample index per target."""
    N, K = d2.shape
    acc = d2[0].copy()
    back = []
    for i in range(1, N):
        arg = _prefix_argmin(acc)
        back.append(arg)
        acc = d2[i] + acc[arg]
    k = int(np.argmin(acc))
    cost = float(acc[k])
    path = [k]
    for arg in reversed(back):
        k = int(arg[k])
        path.append(k)
    return path[::-1], cost


def _prefix_argmin(a: np.ndarray) -> np.ndarray:
    """``out[k] = argmin(a[:k + 1])`` (first index of the running minimum)."""
    run = np.minimum.accumulate(a)
    is_new = np.concatenate([[True], run[1:] < run[:-1]])
    return np.maximum.accumulate(np.where(is_new, np.arange(len(a)), 0))
