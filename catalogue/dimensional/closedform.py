"""Exact four-bar syntheses: Freudenstein's function generator and Burmester's poses.

* **Freudenstein (1955)**: for a four-bar with frame ``d`` from O2 to O4 along the
  x-axis, crank ``a`` at angle φ, coupler ``b`` and rocker ``c`` at angle ψ (angles
  from the frame line), the loop closure gives
  ``K1 cos ψ − K2 cos φ + K3 = cos(φ − ψ)`` with ``K1 = d/a``, ``K2 = d/c``,
  ``K3 = (a² − b² + c² + d²)/(2ac)``: linear in K, so three precision pairs
  (φ_i, ψ_i) give the exact dimensions.
* **Burmester (1888)**: a point ``m`` of the moving body (a *circle point*) occupies
  positions ``m_i`` in the poses; through three poses every body point is a circle
  point, its fixed pivot (*centre point*) the circumcentre of ``m_1, m_2, m_3``.
  For four poses the circle points form a cubic (the circle-point curve): the four
  positions must be concyclic, ``det[|m_i|², x_i, y_i, 1] = 0``.  For five poses the
  circle points are the (at most four) common points of two such curves
  (Sandor & Erdman 1984, ch. 8).
"""
from __future__ import annotations

import numpy as np

from multiloop.topo.errors import InputError, explain
from multiloop.topo.model import Mechanism, MechanismBuilder

__all__ = ["freudenstein", "freudenstein_four_bar", "pose_positions", "centre_point",
           "burmester_four_bar", "circle_point_curve", "burmester_points", "concyclic"]


def freudenstein(phi, psi, d: float = 1.0) -> tuple[float, float, float]:
    """Crank ``a``, coupler ``b``, rocker ``c`` through three pairs (φ_i, ψ_i) (rad).

    Raises
    ------
    InputError
        Not exactly three pairs, a singular system, or no real coupler (b² < 0).
    """
    phi, psi = np.asarray(phi, float), np.asarray(psi, float)
    if phi.shape != (3,) or psi.shape != (3,):
        raise InputError(explain("Freudenstein", expected="three (φ, ψ) pairs", got=f"{phi.shape}"))
    A = np.column_stack([np.cos(psi), -np.cos(phi), np.ones(3)])
    if abs(np.linalg.det(A)) < 1e-12:
        raise InputError(explain("Freudenstein", expected="three independent precision pairs", got="a singular system"))
    K1, K2, K3 = np.linalg.solve(A, np.cos(phi - psi))
    a, c = d / K1, d / K2
    b2 = a * a + c * c + d * d - 2.0 * a * c * K3
    if b2 <= 0:
        raise InputError(explain("Freudenstein", expected="a real coupler length", got=f"b² = {b2:.3g}"))
    return float(a), float(np.sqrt(b2)), float(c)


def freudenstein_four_bar(phi, psi, d: float = 1.0, name: str = "freudenstein_four_bar") -> Mechanism:
    """The four-bar of :func:`freudenstein` in the configuration of the first pair.

    Frame O2 = (0, 0) to O4 = (d, 0); driver O2 (``crank`` w.r.t. ``frame``); the
    output joint O4 has links (``frame``, ``rocker``), so its relative rotation is
    the change of ψ.  Negative ``a`` or ``c`` mean the link points the other way
    (angle + π), as in the equation.
    """
    a, b, c = freudenstein(phi, psi, d)
    A = (a * np.cos(phi[0]), a * np.sin(phi[0]))
    B = (d + c * np.cos(psi[0]), c * np.sin(psi[0]))
    bd = MechanismBuilder(name=name)
    bd.add_link("frame", frame=True)
    for lk in ("crank", "coupler", "rocker"):
        bd.add_link(lk)
    bd.add_joint("O2", "R", ("frame", "crank"), at=(0.0, 0.0))
    bd.add_joint("A", "R", ("crank", "coupler"), at=A)
    bd.add_joint("B", "R", ("coupler", "rocker"), at=B)
    bd.add_joint("O4", "R", ("frame", "rocker"), at=(d, 0.0))
    bd.add_driver("O2")
    return bd.build()


def pose_positions(poses, m) -> np.ndarray:
    """Positions ``(N, 2)`` of body point ``m`` (given in pose 0's world position)."""
    P = np.asarray(poses, float)
    r = np.asarray(m, float) - P[0, :2]
    da = P[:, 2] - P[0, 2]
    c, s = np.cos(da), np.sin(da)
    return np.column_stack([P[:, 0] + c * r[0] - s * r[1], P[:, 1] + s * r[0] + c * r[1]])


def centre_point(p) -> np.ndarray:
    """Circumcentre of three points ``p`` (3, 2)."""
    p = np.asarray(p, float)
    (ax, ay), (bx, by), (cx, cy) = p
    dd = 2.0 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
    if abs(dd) < 1e-300:
        raise InputError(explain("circle point", expected="three non-collinear positions", got="collinear ones"))
    a2, b2, c2 = ax * ax + ay * ay, bx * bx + by * by, cx * cx + cy * cy
    return np.array([(a2 * (by - cy) + b2 * (cy - ay) + c2 * (ay - by)) / dd,
                     (a2 * (cx - bx) + b2 * (ax - cx) + c2 * (bx - ax)) / dd])


def burmester_four_bar(poses, m1, m2, name: str = "burmester_four_bar") -> Mechanism:
    """Four-bar guiding a body through three poses (x, y, angle rad) exactly.

    ``m1``, ``m2`` are the moving pivots (circle points) in pose 0's world
    position; the fixed pivots are their centre points.  The coupler carries the
    tracer point ``C`` at the pose origin; the reference configuration is pose 0.
    """
    P = np.asarray(poses, float)[:3]
    O1 = centre_point(pose_positions(P, m1))
    O2 = centre_point(pose_positions(P, m2))
    bd = MechanismBuilder(name=name)
    bd.add_link("frame", frame=True)
    for lk in ("crank", "coupler", "rocker"):
        bd.add_link(lk)
    bd.add_joint("O1", "R", ("frame", "crank"), at=tuple(O1))
    bd.add_joint("A", "R", ("crank", "coupler"), at=tuple(map(float, m1)))
    bd.add_joint("B", "R", ("coupler", "rocker"), at=tuple(map(float, m2)))
    bd.add_joint("O2", "R", ("rocker", "frame"), at=tuple(O2))
    bd.add_driver("O1")
    bd.add_point("C", "coupler", tuple(P[0, :2]))
    return bd.build()


def concyclic(p) -> np.ndarray:
    """``det[|p_i|², x_i, y_i, 1]`` of four points ``(..., 4, 2)``: zero when concyclic."""
    p = np.asarray(p, float)
    M = np.concatenate([np.sum(p * p, -1, keepdims=True), p, np.ones(p.shape[:-1] + (1,))], -1)
    return np.linalg.det(M)


def circle_point_curve(poses, box, n: int = 200) -> np.ndarray:
    """Points of the circle-point curve of four poses inside ``box`` ((x0, y0), (x1, y1)).

    On each of ``n`` horizontal lines of the box the concyclicity determinant is a
    polynomial of degree at most 4 in x (fitted exactly from five samples); its
    real roots in the box are circle points.  Returns ``(K, 2)``.
    """
    P = np.asarray(poses, float)[:4]
    (x0, y0), (x1, y1) = box
    xs = np.linspace(x0, x1, 5)
    out = []
    for y in np.linspace(y0, y1, n):
        v = [concyclic(pose_positions(P, (x, y))) for x in xs]
        coef = np.polyfit(xs - x0, v, 4)
        for r in np.roots(coef):
            if abs(r.imag) < 1e-9 * (x1 - x0) and 0.0 <= r.real <= x1 - x0:
                out.append((_refine(P, x0 + r.real, y, 1e-7 * (x1 - x0)), y))
    return np.array(out).reshape(-1, 2)


def _refine(P, x: float, y: float, h: float) -> float:
    """Newton on the concyclicity determinant along the line (a few steps)."""
    for _ in range(6):
        f = concyclic(pose_positions(P, (x, y)))
        df = (concyclic(pose_positions(P, (x + h, y))) - f) / h
        if df == 0 or not np.isfinite(df):
            break
        step = f / df
        x -= step
        if abs(step) < 1e-15 * max(1.0, abs(x)):
            break
    return float(x)


def burmester_points(poses, box, n: int = 24) -> np.ndarray:
    """Circle points of five poses in ``box``: the common points of the circle-point
    curves of poses (0, 1, 2, 3) and (0, 1, 2, 4), by Newton from an ``n × n`` grid.

    The poles (points that do not move between two poses) are common to both
    curves but guide nothing; they are left out."""
    P = np.asarray(poses, float)
    if P.shape[0] != 5:
        raise InputError(explain("Burmester points", expected="five poses", got=f"{P.shape[0]}"))
    (x0, y0), (x1, y1) = box
    scale = max(x1 - x0, y1 - y0)

    def F(m):
        return np.array([concyclic(pose_positions(P[[0, 1, 2, 3]], m)),
                         concyclic(pose_positions(P[[0, 1, 2, 4]], m))])
    sols: list[np.ndarray] = []
    grid = [(gx, gy) for gx in np.linspace(x0, x1, n) for gy in np.linspace(y0, y1, n)]
    typ = float(np.median([np.max(np.abs(F(np.array(g)))) for g in grid])) or 1.0
    for gx, gy in grid:
        m = np.array([gx, gy])
        for _ in range(50):
            f = F(m)
            h = 1e-7 * scale
            J = np.column_stack([(F(m + (h, 0)) - f) / h, (F(m + (0, h)) - f) / h])
            try:
                step = np.linalg.solve(J, f)
            except np.linalg.LinAlgError:
                break
            m = m - step
            if not np.all(np.isfinite(m)) or np.hypot(*step) < 1e-14 * scale:
                break
        inside = x0 <= m[0] <= x1 and y0 <= m[1] <= y1
        X = pose_positions(P, m)
        pole = min(np.hypot(*(X[i] - X[j])) for i in range(5) for j in range(i)) < 1e-8 * scale
        if inside and not pole and np.all(np.abs(F(m)) <= 1e-10 * typ) and \
                all(np.hypot(*(m - s)) > 1e-5 * scale for s in sols):
            sols.append(m)
    return np.array(sols).reshape(-1, 2)
