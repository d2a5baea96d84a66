"""Screws in Plücker coordinates: lines, twists, wrenches and the reciprocal product.

Conventions
-----------
A screw is the pair ``(direction; moment)`` of two 3-vectors, the moment taken
about the origin O of the frame the coordinates are written in ("приведённый к
началу O" in [1]_):

* a **line** through point ``r`` with unit direction ``d`` is ``(d; r × d)``
  (:class:`Screw`; ``r × d``, not ``d × r``);
* a **twist** (kinematic screw) of a rigid body is ``(ω; v_O)``: angular velocity
  and the velocity of the body point that is at O (:class:`Twist`);
* a **wrench** (force screw) is ``(F; M_O)``: resultant force and resultant moment
  about O (:class:`Wrench`).

The *reciprocal product* (relative moment, "относительный момент" in [1]_) of
``(d1; m1)`` and ``(d2; m2)`` is ``d1·m2 + m1·d2``.  For a twist and a wrench it
is the power of the wrench on the twist, and it does not depend on the origin.
Twists and wrenches are distinct frozen types; they are paired only by
:func:`reciprocal`, and the relative moment of two geometric screws (lines) by
:func:`mutual_moment`.

The *pitch* of ``(d; m)`` with ``d ≠ 0`` is ``h = d·m / d·d``; its axis is the
line with direction ``d / |d|`` through ``p = d × m / d·d`` (the axis point
nearest to O).  A screw with ``d = 0`` has infinite pitch (pure translation /
pure couple); its axis direction is ``m / |m|`` and it has no axis point.
A *unit* screw has ``|d| = 1``, or ``|m| = 1`` when ``d = 0`` ([1]_ normalises
``x² + y² + z² = 1``, which cannot cover a pure translation).

Moving the reference point to ``P`` replaces ``m`` by ``m − P × d`` (for a twist,
the velocity of the body point at ``P``; for a wrench, the moment about ``P``).

Batch helpers (:func:`plucker_lines`, :func:`reciprocal_products`, :func:`pitches`,
:func:`axis_points`, :func:`moved_about`, :func:`reciprocal_complements`) take
arrays whose last axis holds the six coordinates ``(..., 6)``.

References
----------
.. [1] F. A. Doronin, "Применение теории винтов в статике и динамике
   пространственных механизмов параллельной структуры" (Application of the theory
   of screws in the statics and dynamics of spatial mechanisms of parallel
   structure), *Izvestiya PGUPS* 2015, no. 3, pp. 130–137 (Doronin 2015).
.. [2] R. S. Ball, *The Theory of Screws*, Dublin, 1876.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from multiloop.topo.errors import InputError, ScrewPairingError, explain

__all__ = [
    "Screw",
    "Twist",
    "Wrench",
    "ScrewPairingError",
    "reciprocal",
    "mutual_moment",
    "plucker_lines",
    "reciprocal_products",
    "pitches",
    "axis_points",
    "moved_about",
    "reciprocal_complements",
]

#: relative tolerance under which a direction part counts as zero (infinite pitch)
_ZERO = 1e-12


def _vec3(value: Any, what: str) -> tuple[float, float, float]:
    if isinstance(value, (str, bytes)):
        raise InputError(explain(what, expected="3 numbers", got=repr(value)[:60]))
    try:
        x, y, z = value
        out = (float(x), float(y), float(z))
    except (TypeError, ValueError):
        shape = getattr(value, "shape", None)
        got = f"shape {shape}" if shape is not None else repr(value)[:60]
        raise InputError(explain(what, expected="3 numbers (shape (3,))", got=got)) from None
    if not (math.isfinite(out[0]) and math.isfinite(out[1]) and math.isfinite(out[2])):
        raise InputError(explain(what, expected="finite numbers", got=repr(value)[:60]))
    return out


@dataclass(frozen=True, slots=True)
class _ScrewBase:
    """Common coordinates and geometry of :class:`Screw`, :class:`Twist`, :class:`Wrench`."""

    direction: tuple[float, float, float]
    moment: tuple[float, float, float]

    def __post_init__(self) -> None:
        name = type(self).__name__
        object.__setattr__(self, "direction", _vec3(self.direction, f"{name} direction"))
        object.__setattr__(self, "moment", _vec3(self.moment, f"{name} moment"))

    # -- construction / export -------------------------------------------------
    @classmethod
    def from_array(cls, coords: Any):
        """Build from six Plücker coordinates ``(d1, d2, d3, m1, m2, m3)``."""
        arr = np.asarray(coords, dtype=float)
        if arr.shape != (6,):
            raise InputError(explain(f"{cls.__name__} coordinates", expected="shape (6,)",
                                     got=f"shape {arr.shape}"))
        return cls(tuple(arr[:3]), tuple(arr[3:]))

    def as_array(self) -> np.ndarray:
        """The six coordinates ``(direction, moment)`` as a new float array."""
        return np.array(self.direction + self.moment, dtype=float)

    # -- geometry ----------------------------------------------------------------
    @property
    def is_infinite_pitch(self) -> bool:
        """True for a pure translation (twist) or a pure couple (wrench)."""
        d = np.asarray(self.direction)
        m = np.asarray(self.moment)
        return bool(np.linalg.norm(d) <= _ZERO * max(1.0, np.linalg.norm(m)))

    @property
    def pitch(self) -> float:
        """``h = d·m / d·d`` (``inf`` when ``d = 0``); unit: length."""
        return float(pitches(self.as_array()))

    @property
    def axis_point(self) -> np.ndarray:
        """Point of the axis nearest the origin, ``d × m / d·d`` (NaN for infinite pitch)."""
        return axis_points(self.as_array())

    @property
    def axis_direction(self) -> np.ndarray:
        """Unit vector along the axis: ``d/|d|``, or ``m/|m|`` for infinite pitch."""
        d = np.asarray(self.direction)
        if self.is_infinite_pitch:
            m = np.asarray(self.moment)
            n = np.linalg.norm(m)
            return m / n if n > 0 else np.full(3, np.nan)
        return d / np.linalg.norm(d)

    def normalized(self):
        """The unit screw: ``|d| = 1``, or ``|m| = 1`` for a pure translation/couple.

        Raises
        ------
        InputError
            For the zero screw.
        """
        arr = self.as_array()
        n = np.linalg.norm(arr[:3]) if not self.is_infinite_pitch else np.linalg.norm(arr[3:])
        if n == 0:
            raise InputError(explain(f"{type(self).__name__}.normalized()", expected="a non-zero screw",
                                     got="all six coordinates zero"))
        return type(self).from_array(arr / n)

    def about(self, point: Any):
        """The same screw with its moment taken about ``point`` (change of reference point).

        ``m_P = m − P × d``: the velocity of the body point at ``P`` for a twist, the
        moment about ``P`` for a wrench, the moment of the line about ``P``.
        """
        return type(self).from_array(moved_about(self.as_array(), _vec3(point, "point")))

    def transformed(self, rotation: Any, translation: Any = (0.0, 0.0, 0.0)):
        """The screw carried by the rigid motion ``x ↦ R x + t``: ``(R d; R m + t × R d)``."""
        R = np.asarray(rotation, dtype=float)
        if R.shape != (3, 3):
            raise InputError(explain("rotation", expected="a 3×3 matrix", got=f"shape {R.shape}"))
        t = np.asarray(_vec3(translation, "translation"))
        d = R @ np.asarray(self.direction)
        m = R @ np.asarray(self.moment) + np.cross(t, d)
        return type(self).from_array(np.concatenate([d, m]))

    # -- linear algebra within one kind ------------------------------------------
    def _same(self, other: Any) -> None:
        if type(other) is not type(self):
            raise ScrewPairingError(explain(f"{type(self).__name__} + {type(other).__name__}",
                                            expected="two screws of the same kind",
                                            got="different kinds",
                                            hint="twists and wrenches only meet in reciprocal(t, w)"))

    def __add__(self, other):
        self._same(other)
        return type(self).from_array(self.as_array() + other.as_array())

    def __sub__(self, other):
        self._same(other)
        return type(self).from_array(self.as_array() - other.as_array())

    def __neg__(self):
        return type(self).from_array(-self.as_array())

    def __mul__(self, scalar: float):
        if isinstance(scalar, _ScrewBase) or not np.isscalar(scalar):
            return NotImplemented
        return type(self).from_array(float(scalar) * self.as_array())

    __rmul__ = __mul__


@dataclass(frozen=True, slots=True)
class Screw(_ScrewBase):
    """A geometric screw (a line with a pitch), Plücker coordinates about O.

    Examples
    --------
    >>> s = Screw.from_line(point=(0, -3, 0), direction=(0, 0, -2))
    >>> s.direction, s.moment
    ((0.0, 0.0, -1.0), (3.0, 0.0, 0.0))
    """

    @classmethod
    def from_line(cls, point: Any, direction: Any, pitch: float = 0.0) -> "Screw":
        """Unit screw on the line through ``point`` along ``direction``: ``(u; r × u + h u)``."""
        r = np.asarray(_vec3(point, "line point"))
        d = np.asarray(_vec3(direction, "line direction"))
        n = np.linalg.norm(d)
        if n == 0:
            raise InputError(explain("line direction", expected="a non-zero vector", got="(0, 0, 0)"))
        u = d / n
        return cls.from_array(np.concatenate([u, np.cross(r, u) + float(pitch) * u]))

    @classmethod
    def from_points(cls, start: Any, end: Any) -> "Screw":
        """Unit line screw from ``start`` towards ``end``."""
        a = np.asarray(_vec3(start, "start point"))
        b = np.asarray(_vec3(end, "end point"))
        if np.allclose(a, b, rtol=0, atol=0):
            raise InputError(explain("line", expected="two distinct points", got=f"{tuple(a)} twice"))
        return cls.from_line(a, b - a)

    def as_twist(self, rate: float = 1.0) -> "Twist":
        """The twist of rate ``rate`` about this screw (rad/s, or m/s if infinite pitch)."""
        return Twist.from_array(rate * self.as_array())

    def as_wrench(self, intensity: float = 1.0) -> "Wrench":
        """The wrench of intensity ``intensity`` on this screw (N, or N·m if a couple)."""
        return Wrench.from_array(intensity * self.as_array())


@dataclass(frozen=True, slots=True)
class Twist(_ScrewBase):
    """Kinematic screw ``(ω; v_O)`` of a rigid body (rad/s; m/s).

    Examples
    --------
    Rotation at 1 rad/s about the vertical through A = (0, −3, 0) (Doronin 2015, V6):

    >>> Twist.from_axis((0, -3, 0), (0, 0, 1)).as_array().tolist()
    [0.0, 0.0, 1.0, -3.0, 0.0, 0.0]
    """

    @property
    def angular(self) -> np.ndarray:
        """Angular velocity ω."""
        return np.asarray(self.direction)

    @property
    def linear(self) -> np.ndarray:
        """Velocity of the body point at the origin."""
        return np.asarray(self.moment)

    @classmethod
    def from_axis(cls, point: Any, direction: Any, pitch: float = 0.0, rate: float = 1.0) -> "Twist":
        """Screw motion about the axis through ``point``: ``ω = rate·u``, ``v_O = r × ω + h ω``."""
        return Screw.from_line(point, direction, pitch).as_twist(rate)

    @classmethod
    def translation(cls, velocity: Any) -> "Twist":
        """Pure translation with the given velocity (infinite pitch)."""
        return cls((0.0, 0.0, 0.0), _vec3(velocity, "velocity"))

    def velocity_at(self, point: Any) -> np.ndarray:
        """Velocity of the body point at ``point``: ``v_O + ω × r``."""
        r = np.asarray(_vec3(point, "point"))
        return self.linear + np.cross(self.angular, r)


@dataclass(frozen=True, slots=True)
class Wrench(_ScrewBase):
    """Force screw ``(F; M_O)``: resultant force (N) and moment about O (N·m).

    Examples
    --------
    >>> Wrench.from_force((-2, -1.5, 0), (0, 0, -2500)).as_array().tolist()
    [0.0, 0.0, -2500.0, 3750.0, -5000.0, 0.0]
    """

    @property
    def force(self) -> np.ndarray:
        """Resultant force."""
        return np.asarray(self.direction)

    @property
    def torque(self) -> np.ndarray:
        """Resultant moment about the origin."""
        return np.asarray(self.moment)

    @classmethod
    def from_force(cls, point: Any, force: Any, couple: Any = (0.0, 0.0, 0.0)) -> "Wrench":
        """Force ``F`` applied at ``point`` plus a free couple: ``(F; r × F + couple)``."""
        r = np.asarray(_vec3(point, "point of application"))
        f = np.asarray(_vec3(force, "force"))
        c = np.asarray(_vec3(couple, "couple"))
        return cls.from_array(np.concatenate([f, np.cross(r, f) + c]))

    @classmethod
    def couple(cls, moment: Any) -> "Wrench":
        """A pure couple (infinite pitch)."""
        return cls((0.0, 0.0, 0.0), _vec3(moment, "couple"))


def reciprocal(a: Twist | Wrench, b: Twist | Wrench) -> float:
    """Reciprocal product of a twist and a wrench (either order): the power ``ω·M_O + v_O·F``.

    Raises
    ------
    ScrewPairingError
        Unless exactly one argument is a :class:`Twist` and the other a :class:`Wrench`.

    Examples
    --------
    >>> t = Twist.from_axis((0, 0, 0), (0, 0, 1))
    >>> reciprocal(t, Wrench.from_force((1, 0, 0), (0, 2, 0)))
    2.0
    """
    kinds = {type(a), type(b)}
    if kinds != {Twist, Wrench}:
        raise ScrewPairingError(explain(
            f"reciprocal({type(a).__name__}, {type(b).__name__})",
            expected="one Twist and one Wrench",
            got=f"{type(a).__name__} and {type(b).__name__}",
            hint="use mutual_moment() for two geometric Screws"))
    return float(reciprocal_products(a.as_array(), b.as_array()))


def mutual_moment(a: Screw, b: Screw) -> float:
    """Relative (mutual) moment ``d1·m2 + m1·d2`` of two geometric screws.

    For two unit lines it is ``−dist · sin(angle)``; zero iff the lines meet or are parallel.
    """
    if type(a) is not Screw or type(b) is not Screw:
        raise ScrewPairingError(explain(
            f"mutual_moment({type(a).__name__}, {type(b).__name__})",
            expected="two geometric Screws", got=f"{type(a).__name__} and {type(b).__name__}",
            hint="pair a Twist with a Wrench through reciprocal()"))
    return float(reciprocal_products(a.as_array(), b.as_array()))


# ---------------------------------------------------------------------------
# vectorised helpers, last axis = the six coordinates
# ---------------------------------------------------------------------------
def plucker_lines(points: Any, directions: Any) -> np.ndarray:
    """Unit line screws ``(u; r × u)`` for ``points`` and ``directions`` of shape ``(..., 3)``.

    Returns
    -------
    ndarray, shape ``(..., 6)``
        Zero directions give NaN rows.
    """
    r = np.asarray(points, dtype=float)
    d = np.asarray(directions, dtype=float)
    n = np.linalg.norm(d, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        u = d / n
    r, u = np.broadcast_arrays(r, u)
    return np.concatenate([u, np.cross(r, u)], axis=-1)


def reciprocal_products(a: Any, b: Any) -> np.ndarray:
    """``a[:3]·b[3:] + a[3:]·b[:3]`` over the last axis (broadcasting)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    return (np.einsum("...i,...i->...", a[..., :3], b[..., 3:])
            + np.einsum("...i,...i->...", a[..., 3:], b[..., :3]))


def pitches(s: Any) -> np.ndarray:
    """Pitch ``d·m / d·d`` of screws ``(..., 6)``; ``inf`` where ``d = 0``."""
    s = np.asarray(s, dtype=float)
    d, m = s[..., :3], s[..., 3:]
    dd = np.einsum("...i,...i->...", d, d)
    dm = np.einsum("...i,...i->...", d, m)
    scale = np.maximum(1.0, np.einsum("...i,...i->...", m, m))
    zero = dd <= (_ZERO ** 2) * scale
    with np.errstate(invalid="ignore", divide="ignore"):
        h = np.where(zero, np.inf, dm / np.where(zero, 1.0, dd))
    return h[()] if np.ndim(h) == 0 else h


def axis_points(s: Any) -> np.ndarray:
    """Axis point nearest the origin, ``d × m / d·d``, of screws ``(..., 6)``; NaN where ``d = 0``."""
    s = np.asarray(s, dtype=float)
    d, m = s[..., :3], s[..., 3:]
    dd = np.einsum("...i,...i->...", d, d)[..., None]
    scale = np.maximum(1.0, np.einsum("...i,...i->...", m, m))[..., None]
    zero = dd <= (_ZERO ** 2) * scale
    p = np.cross(d, m) / np.where(zero, 1.0, dd)
    return np.where(zero, np.nan, p)


def moved_about(s: Any, point: Any) -> np.ndarray:
    """Coordinates of screws ``(..., 6)`` with the moment about ``point`` ``(..., 3)``: ``m − P × d``."""
    s = np.asarray(s, dtype=float)
    p = np.asarray(point, dtype=float)
    d = s[..., :3]
    m = s[..., 3:] - np.cross(p, d)
    d, m = np.broadcast_arrays(d, m)
    return np.concatenate([d, m], axis=-1)


def reciprocal_complements(s: Any, tol: float = 1e-10) -> tuple[np.ndarray, np.ndarray]:
    """The screw reciprocal to five given screws, for a stack ``(..., 5, 6)``.

    Solves ``reciprocal_products(s[..., k, :], x) = 0`` for ``k = 0..4`` by SVD of
    ``s Δ`` with ``Δ = [[0, I], [I, 0]]``.  The solution is normalised as in
    :meth:`Screw.normalized` (``|d| = 1``, or ``|m| = 1`` for infinite pitch); its
    sign is arbitrary here.

    Returns
    -------
    x : ndarray, shape ``(..., 6)``
        The reciprocal screw (NaN where the five are dependent).
    ratio : ndarray, shape ``(...)``
        ``σ₅ / σ₁`` of ``s Δ``: small means the five are linearly dependent (the
        reciprocal system has dimension > 1).
    """
    s = np.asarray(s, dtype=float)
    if s.shape[-2:] != (5, 6):
        raise InputError(explain("reciprocal_complements", expected="screws of shape (..., 5, 6)",
                                 got=f"shape {s.shape}"))
    sd = np.concatenate([s[..., 3:], s[..., :3]], axis=-1)       # s Δ
    _, sv, vt = np.linalg.svd(sd)
    x = vt[..., -1, :]
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = sv[..., 4] / sv[..., 0]
    x = _normalise_rows(x)
    x = np.where((ratio > tol)[..., None], x, np.nan)
    return x, ratio


def _normalise_rows(x: np.ndarray) -> np.ndarray:
    nd = np.linalg.norm(x[..., :3], axis=-1, keepdims=True)
    nm = np.linalg.norm(x[..., 3:], axis=-1, keepdims=True)
    infinite = nd <= 1e-9 * np.maximum(nm, 1e-300)
    denom = np.where(infinite, nm, nd)
    with np.errstate(invalid="ignore", divide="ignore"):
        y = x / denom
    # exact zeros on the direction part of a pure translation
    y = np.where(infinite & (np.arange(6) < 3), 0.0, y)
    return y

