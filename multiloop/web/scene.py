"""What the workbench draws: a mechanism's links as index lists, and its motions solved once.

A :class:`Scene` holds the drawing of one mechanism (links as polygons over the joint and
tracer-point positions, in Assur-group colours) and one :class:`Sweep` per driver: that
driver moved over its whole range with the others at the reference, solved by one
vectorised :func:`multiloop.kin.solve.solve` call along a continuous path from the
reference (the motion ``multiloop check`` examines).  A slider move only indexes the
sweep, so a redraw costs no solving.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from multiloop.topo.model import JointKind, Mechanism

__all__ = ["Scene", "Sweep", "scene_of", "sweep_driver", "PALETTE", "R_FRAMES", "P_FRAMES"]

#: colours of the Assur groups in solving order (the driver links first, the frame grey)
PALETTE = ("#4e79a7", "#f28e2b", "#59a14f", "#e15759", "#76b7b2", "#edc948", "#b07aa1",
           "#ff9da7", "#9c755f", "#bab0ac")
R_FRAMES = 361          # frames of a full turn (1°)
P_FRAMES = 201          # frames over a limited range (each side ~100)
LIMIT_INSET = 1e-6      # relative inset of a limited motion's end frames from its limits


@dataclass(frozen=True)
class Sweep:
    """Driver ``k`` moved over its range, the others at the reference.

    ``x`` are the driver values in command-line units (deg for R, m for P, signed from
    the reference) in slider order; ``nodes`` (F, J + P, 2) the joint then tracer-point
    positions; ``ok`` (F,) whether each frame assembled; ``angles`` (F, S) the
    transmission / pressure angles (deg) of ``angle_names`` (:mod:`kin.check.transmission`).
    """

    k: int
    joint: str
    rotary: bool
    full_rotation: bool
    x: np.ndarray
    nodes: np.ndarray
    ok: np.ndarray
    angles: np.ndarray
    angle_names: tuple[str, ...]

    @property
    def unit(self) -> str:
        return "deg" if self.rotary else "m"

    @property
    def reference_index(self) -> int:
        return int(np.argmin(np.abs(self.x)))

    def api_inputs(self) -> np.ndarray:
        """(F, n_drivers) inputs of :func:`solve` (rad / m) of the frames."""
        return np.radians(self.x) if self.rotary else self.x.copy()


@dataclass(frozen=True)
class Scene:
    """The drawing of a mechanism: names, link outlines as node indices, colours."""

    mechanism: Mechanism
    node_names: tuple[str, ...]          # joints, then tracer points
    n_joints: int
    links: tuple[tuple[str, tuple[int, ...], str, str], ...]   # (name, node indices, colour, group label)
    joint_kind: tuple[str, ...]          # "R" / "P" / "frame" per joint
    multiplicity: tuple[int, ...]        # links meeting at each joint
    reference: np.ndarray                # (J + P, 2) the reference positions


def _group_colours(m: Mechanism) -> dict[str, tuple[str, str]]:
    """Link → (colour, label) by the step of the Assur plan that solves it."""
    from multiloop.topo.assur import AssurGroup, decompose    # here: this module loads without the solvers
    plan = decompose(m)
    out: dict[str, tuple[str, str]] = {}
    for i, step in enumerate(plan.steps):
        colour = PALETTE[i % len(PALETTE)]
        if isinstance(step, AssurGroup):
            for lk in step.links:
                out[lk] = (colour, step.label)
        else:
            out[step.link] = (colour, f"driver {step.joint}")
    return out


def scene_of(m: Mechanism) -> Scene:
    """The drawing of ``m`` at its reference configuration (no solving)."""
    names = tuple(m.joint_names) + tuple(p.name for p in m.points)
    ref = np.array([j.at if j.at is not None else (np.nan, np.nan) for j in m.joints]
                   + [p.at for p in m.points], float).reshape(-1, 2)
    on: dict[str, list[int]] = {lk: [] for lk in m.link_names}
    for i, j in enumerate(m.joints):
        for lk in j.links:
            on[lk].append(i)
    for k, p in enumerate(m.points):
        on[p.link].append(len(m.joints) + k)
    colours = _group_colours(m) if m.drivers else {}
    links = []
    for lk, idx in on.items():
        if lk == m.frame or len(idx) < 2:
            continue
        P = ref[idx]
        if len(idx) >= 3 and np.all(np.isfinite(P)):
            # the cyclic order about the centroid is kept by a rigid motion: sort once
            c = P.mean(axis=0)
            idx = [idx[i] for i in np.argsort(np.arctan2(P[:, 1] - c[1], P[:, 0] - c[0]))]
        colour, label = colours.get(lk, ("#555555", ""))
        links.append((lk, tuple(idx), colour, label))
    kinds = tuple("P" if j.kind is JointKind.P else "frame" if m.frame in j.links else "R" for j in m.joints)
    return Scene(m, names, len(m.joints), tuple(links), kinds, tuple(len(j.links) for j in m.joints), ref)


def _nodes(st) -> np.ndarray:
    P = st.point_positions if st.point_positions is not None else np.zeros((st.positions.shape[0], 0, 2))
    return np.concatenate([st.positions, P], axis=1)


def _solve(m: Mechanism, k: int, x: np.ndarray, cancel=None):
    """Driver ``k``'s inputs ``x`` (the others held) solved on the check's plan: the
    charts its walks build for the motion's limits serve the frames too (on a plan of
    their own they were walked twice: 50-100 ms of an excavator's re-check)."""
    from multiloop.kin.check.core import check_plan
    from multiloop.kin.motion import DriverMotion
    from multiloop.kin.solve import solve
    if cancel is not None:
        cancel()
    X = DriverMotion.held(m, k).inputs(x)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return solve(m, X, plan=check_plan(m))


def _angles(m: Mechanism, states) -> tuple[np.ndarray, tuple[str, ...]]:
    from multiloop.kin.check.transmission import angle_specs, angle_values
    from multiloop.topo.assur import decompose

    specs = angle_specs(decompose(m))
    names = tuple(f"{sp.quantity} {sp.joint}" for sp in specs)
    return [angle_values(st, specs) for st in states], names


def sweep_driver(m: Mechanism, k: int, cancel=None) -> Sweep:
    """The motion of driver ``k`` (others at the reference) as slider frames: a full turn
    in :data:`R_FRAMES` frames, or a limited motion in :data:`P_FRAMES` frames from limit
    to limit, half on each side of the reference (all of them on one side when the
    reference is at the other limit).  The limits are those of :func:`kin.check.check`
    (its certified walk, :func:`kin.check.driver_angles`), not read off a grid; the
    frames depend on the mechanism alone.  ``cancel()`` is called before every solve (it
    stops the sweep by raising)."""
    from multiloop.kin.check import driver_angles

    joint = m.drivers[k].joint
    rotary = m.is_rotary(k)
    if rotary:
        x = np.linspace(0.0, 2 * np.pi, R_FRAMES)
        st = _solve(m, k, x, cancel)
        if st.ok.all():
            (a,), names = _angles(m, [st])
            return Sweep(k, joint, True, True, np.degrees(x), _nodes(st), np.asarray(st.ok, bool), a, names)
    if cancel is not None:
        cancel()
    motion = driver_angles(m, k)
    if motion.full_rotation:          # a full turn through a singular position: one turn, its failures marked
        hi, lo = 2 * np.pi, 0.0
    else:
        # the end frames a millionth of the way inside: at an assembly limit two branches
        # of a group meet, and the solver reports the positions within ~1e-7 of it as
        # singular (the excavators' cylinders)
        hi = max((v for v in motion.limits if v > 0), default=0.0) * (1 - LIMIT_INSET)
        lo = min((v for v in motion.limits if v < 0), default=0.0) * (1 - LIMIT_INSET)
    both = hi > 0 and lo < 0
    n_fwd = P_FRAMES // 2 if both else (P_FRAMES - 1 if hi > 0 else 0)
    n_bwd = P_FRAMES // 2 if both else (P_FRAMES - 1 if lo < 0 else 0)
    fwd, bwd = np.linspace(0.0, hi, n_fwd + 1), np.linspace(0.0, lo, n_bwd + 1)
    sf, sb = _solve(m, k, fwd, cancel), _solve(m, k, bwd, cancel)
    (af, ab), names = _angles(m, [sf, sb])
    x = np.concatenate([bwd[:0:-1], fwd])
    nodes = np.concatenate([_nodes(sb)[:0:-1], _nodes(sf)])
    ok = np.concatenate([np.asarray(sb.ok, bool)[:0:-1], np.asarray(sf.ok, bool)])
    return Sweep(k, joint, rotary, motion.full_rotation, np.degrees(x) if rotary else x, nodes, ok,
                 np.concatenate([ab[:0:-1], af]), names)
