"""Closed-form starts for four-bars: Freudenstein (function) and Burmester (motion).

When the start mechanism is a four-bar (frame, crank, coupler, rocker; four R
joints), three of the precision positions (first, middle, last) give an exact
design by :mod:`.closedform`; it replaces the start design when it scores better.
"""
from __future__ import annotations

import numpy as np

from multiloop.topo.errors import InputError

from .closedform import centre_point, freudenstein, pose_positions
from .evaluator import four_bar_roles
from .objective import Problem
from .targets import FunctionTarget, MotionTarget

__all__ = ["four_bar_roles", "closed_form_start"]


def _set(problem: Problem, z: np.ndarray, joint: str, xy) -> None:
    for k, v in zip(("x", "y"), xy):
        i = problem.names.index(f"{joint}.{k}")
        z[i] = np.clip(v, problem.lower[i], problem.upper[i])


def closed_form_start(problem: Problem) -> tuple[np.ndarray, str] | None:
    """An exact three-position design for a four-bar start, or None."""
    m = problem.ev.mechanism
    r = four_bar_roles(m)
    t = problem.target
    if r is None:
        return None
    at = {j.name: np.asarray(j.at, float) for j in m.joints}
    z = problem.x0.copy()
    pick = [0, len(problem.target_values()) // 2, len(problem.target_values()) - 1]
    try:
        if isinstance(t, FunctionTarget) and t.joint == r["O_out"]:
            O, Q = at[r["O_in"]], at[r["O_out"]]
            beta = np.arctan2(*(Q - O)[::-1])
            d = float(np.hypot(*(Q - O)))
            phi0 = np.arctan2(*(at[r["A"]] - O)[::-1]) - beta
            psi0 = np.arctan2(*(at[r["B"]] - Q)[::-1]) - beta
            drv = m.drivers[0]
            sd = 1.0 if drv.links[1] == r["crank"] else -1.0
            so = 1.0 if m.joint(t.joint).links[1] == r["rocker"] else -1.0
            x, y = t.inputs[pick] - t.inputs[0], t.outputs[pick] - t.outputs[0]
            a, _, c = freudenstein(phi0 + sd * x, psi0 + so * y, d)
            e = lambda ang: np.array([np.cos(ang + beta), np.sin(ang + beta)])  # noqa: E731
            _set(problem, z, r["A"], O + a * e(phi0))
            _set(problem, z, r["B"], Q + c * e(psi0))
            return z, "Freudenstein three-point start"
        if isinstance(t, MotionTarget) and t.link == r["coupler"]:
            P = t.poses[pick]
            _set(problem, z, r["O_in"], centre_point(pose_positions(P, at[r["A"]])))
            _set(problem, z, r["O_out"], centre_point(pose_positions(P, at[r["B"]])))
            for k, v in zip(("frame.x", "frame.y", "frame.angle"), P[0]):
                z[problem.names.index(k)] = v
            return z, "Burmester three-pose start"
    except InputError:
        return None
    return None
