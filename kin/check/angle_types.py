"""The types of monitored angle, one frozen object each, and their registry.

A group kind's adapter declares its monitored angles by the name of their type
(:class:`kin.groups.step.AngleDef` ``quantity``); every fact of a type is asked here,
through :func:`angle_type`, and no other module decides anything by the name:

* ``name``: the name written in the JSON and the text report;
* ``label``: the name of the angle in the verdict's sentences;
* ``span``: the range of its values (degrees); ``ideal``: its best value;
* ``degenerate``: the values it takes where its group's Jacobian determinant vanishes
  (the toggle), which are also the values flagged: a degenerate value below ``ideal``
  flags the minimum, one above flags the maximum;
* ``summary`` and ``summary_keys``: its table in the check's JSON;
* ``reach_limit``: whether the degenerate value is a reach limit of the group, whose
  signed determinant (:meth:`AngleType.signed_det`) guards the check's motion;
* :meth:`AngleType.value`: its value over a view (``point(joint)`` (…, 2),
  ``angle(link)`` (…,) and ``axis(joint)`` (2,) or (…, 2)).

The three types of the library (definitions of :mod:`kin.check.transmission`):

* :class:`Transmission`: the angle at the inner pin B of a triangle A–B–C (an RRR dyad
  or an actuated triangle), in [0°, 180°]; 90° is ideal, 0° and 180° are the toggle
  (Alt 1932; the dyad's determinant l₂l₃ sin(φ₂ − φ₃) vanishes there, Vasechkin et
  al. 2017, kind 1).
* :class:`Pressure`: the angle between the line X–Y and a guide, in [0°, 90°]; 0° is
  ideal, 90° the toggle of an RRP or RPR dyad (Vasechkin et al. 2017, kinds 2 and 3).
* :class:`Triad`: at an inner joint Pᵢ of a triad, the angle between the line of leg
  PᵢAᵢ and the line from Pᵢ to the intersection of the other two legs' lines, in
  [0°, 90°]; 90° is ideal, 0° is the triad's singularity (the three leg lines
  concurrent or parallel, Hunt 1983), and only the minimum is flagged.

A new type is one subclass of :class:`AngleType` here and one line in
:data:`BUILT_IN` (or :func:`register` at run time), then an adapter that declares it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["AngleType", "Transmission", "Pressure", "Triad", "BUILT_IN", "ANGLE_TYPES", "angle_type",
           "register", "unsigned_angle", "line_angle", "guide_of"]


def unsigned_angle(u, w):
    """Unsigned angle between vectors (…, 2), degrees in [0, 180]."""
    cr = u[..., 0] * w[..., 1] - u[..., 1] * w[..., 0]
    dt = u[..., 0] * w[..., 0] + u[..., 1] * w[..., 1]
    return np.degrees(np.abs(np.arctan2(cr, dt)))


def line_angle(u, w):
    """Angle between two lines (…, 2), degrees in [0, 90]."""
    a = unsigned_angle(u, w)
    return np.minimum(a, 180.0 - a)


def guide_of(view, guide):
    """Unit direction (…, 2) in the world of the guide ``guide`` = (P joint, guide link)."""
    pj, link = guide
    ax = view.axis(pj)
    th = view.angle(link)
    c, s = np.cos(th), np.sin(th)
    return np.stack([c * ax[..., 0] - s * ax[..., 1], s * ax[..., 0] + c * ax[..., 1]], axis=-1)


@dataclass(frozen=True)
class AngleType:
    """One type of monitored angle: its every fact (see the module's list).

    Attributes
    ----------
    name : str
        The name in the JSON and the text report (``AngleDef.quantity``).
    label : str
        The angle's name in the verdict's sentences.
    span : tuple of float
        (lowest, highest) value, degrees.
    ideal : float
        The best value, degrees.
    degenerate : tuple of float
        The values at a singular point of the group, degrees: the exact value reported
        there, and the extremes flagged (one below ``ideal`` flags the minimum, one
        above the maximum).
    rises : str
        The verb of a verdict on a flagged maximum.
    summary : str
        The key of the type's table in the check's JSON (joint: extremes over drivers).
    summary_keys : tuple of str
        The keys kept in that table's entries, of ``min``, ``max``, ``quantity``, ``driver``.
    reach_limit : bool
        Whether a degenerate value is a reach limit of the group: then
        :meth:`signed_det` is the normalised determinant that guards the motion.
    """

    name: str = ""
    label: str = ""
    span: tuple[float, float] = (0.0, 180.0)
    ideal: float = 90.0
    degenerate: tuple[float, ...] = ()
    rises: str = "rises to"
    summary: str = ""
    summary_keys: tuple[str, ...] = ("min", "max", "quantity", "driver")
    reach_limit: bool = False

    def value(self, view, spec) -> np.ndarray:
        """The angle in degrees over a view's batch, from ``spec.points`` and ``spec.guide``."""
        raise NotImplementedError

    def signed_det(self, view, spec) -> np.ndarray:
        """The group's normalised signed determinant over a view's batch (zero: singular);
        only for a type with ``reach_limit``."""
        raise NotImplementedError

    def low(self, d: float) -> bool:
        """Whether the degenerate value ``d`` is approached by the minimum."""
        return d < self.ideal

    def flagged(self, lo: float, hi: float, threshold: float) -> bool:
        """Whether extremes ``lo``, ``hi`` come within ``threshold`` (deg) of a degenerate value."""
        return any(lo < d + threshold if self.low(d) else hi > d - threshold for d in self.degenerate)

    def margin(self, lo, hi):
        """The least distance (deg) of extremes ``lo``, ``hi`` (numbers or arrays) to a
        degenerate value (``inf`` for a type without one): ``margin(a, a)`` folds one
        angle so that 0 is singular."""
        out = np.inf
        for d in self.degenerate:
            out = np.minimum(out, lo - d if self.low(d) else d - hi)
        return out

    def plot_lines(self, threshold: float) -> tuple[float, ...]:
        """The threshold lines the check's figure draws for this type (deg)."""
        return (threshold,)


@dataclass(frozen=True)
class Transmission(AngleType):
    """The transmission angle μ at B of a triangle A–B–C (``points`` = (A, B, C)): the
    angle between BA and BC in [0°, 180°] (Alt 1932)."""

    name: str = "transmission"
    label: str = "transmission angle"
    degenerate: tuple[float, ...] = (0.0, 180.0)
    summary: str = "transmission"
    summary_keys: tuple[str, ...] = ("min", "max")
    reach_limit: bool = True

    def value(self, view, spec) -> np.ndarray:
        A, B, C = (view.point(n) for n in spec.points)
        return unsigned_angle(A - B, C - B)

    def signed_det(self, view, spec) -> np.ndarray:
        """sin μ, signed."""
        A, B, C = (view.point(n) for n in spec.points)
        u, v = A - B, C - B
        return (u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]) / (
            np.hypot(u[..., 0], u[..., 1]) * np.hypot(v[..., 0], v[..., 1]))

    def plot_lines(self, threshold: float) -> tuple[float, ...]:
        return (threshold, 180 - threshold)


@dataclass(frozen=True)
class Pressure(AngleType):
    """The pressure angle α between the line X–Y (``points`` = (X, Y)) and the guide
    ``guide`` = (P joint, guide link), in [0°, 90°] (Vasechkin et al. 2017)."""

    name: str = "pressure"
    label: str = "pressure angle"
    span: tuple[float, float] = (0.0, 90.0)
    ideal: float = 0.0
    degenerate: tuple[float, ...] = (90.0,)
    rises: str = "reaches"
    summary: str = "pressure_angles"
    reach_limit: bool = True

    def value(self, view, spec) -> np.ndarray:
        X, Y = (view.point(n) for n in spec.points)
        return line_angle(Y - X, guide_of(view, spec.guide))

    def signed_det(self, view, spec) -> np.ndarray:
        """cos of the angle between X→Y and the guide, signed."""
        X, Y = (view.point(n) for n in spec.points)
        d = Y - X
        return np.sum(d * guide_of(view, spec.guide), axis=-1) / np.hypot(d[..., 0], d[..., 1])


def _triad(view, names):
    """The unfolded angle at Pᵢ (``names`` = (Aᵢ, Pᵢ, Aⱼ, Pⱼ, Aₖ, Pₖ)), degrees in [0, 180]."""
    Ai, Pi, Aj, Pj, Ak, Pk = (view.point(n) for n in names)
    # homogeneous lines through (A, P): l = (A,1) × (P,1); intersection I = lj × lk
    def line(A, Q):
        return np.cross(np.concatenate([A, np.ones_like(A[..., :1])], -1),
                        np.concatenate([Q, np.ones_like(Q[..., :1])], -1))
    inter = np.cross(line(Aj, Pj), line(Ak, Pk))
    w = inter[..., 2:3]
    scale = np.maximum(np.abs(inter[..., :2]).max(axis=-1, keepdims=True), 1e-300)
    finite = np.abs(w) > 1e-12 * scale
    # at infinity the line from Pi to I is parallel to the (parallel) legs j, k
    to_i = np.where(finite, inter[..., :2] / np.where(finite, w, 1.0) - Pi, Pj - Aj)
    return unsigned_angle(Ai - Pi, to_i)


@dataclass(frozen=True)
class Triad(AngleType):
    """A triad's angle at inner joint Pᵢ (``points`` = (Aᵢ, Pᵢ, Aⱼ, Pⱼ, Aₖ, Pₖ)): the line
    angle between leg PᵢAᵢ and the line from Pᵢ to the intersection of legs j and k, in
    [0°, 90°]; 0° where the three leg lines are concurrent or parallel (Hunt 1983,
    "Structural kinematics of in-parallel-actuated robot-arms", J. Mech. Transm. Autom.
    Des. 105(4) 705-712)."""

    name: str = "triad"
    label: str = "triad transmission angle"
    span: tuple[float, float] = (0.0, 90.0)
    degenerate: tuple[float, ...] = (0.0,)
    summary: str = "triad_transmission"

    def value(self, view, spec) -> np.ndarray:
        a = _triad(view, spec.points)
        return np.minimum(a, 180.0 - a)


#: the library's types, in the order of their tables in the check's JSON
BUILT_IN: tuple[AngleType, ...] = (Transmission(), Pressure(), Triad())
#: every registered type by name (:func:`register` adds one)
ANGLE_TYPES: dict[str, AngleType] = {t.name: t for t in BUILT_IN}


def angle_type(name: str) -> AngleType:
    """The registered type of monitored angle called ``name``."""
    try:
        return ANGLE_TYPES[name]
    except KeyError:
        raise KeyError(f"no monitored angle type {name!r}; registered: {', '.join(ANGLE_TYPES)}") from None


def register(t: AngleType) -> AngleType:
    """Add (or replace) the type ``t`` under its name; returns it."""
    ANGLE_TYPES[t.name] = t
    return t
