"""Six-strut spatial platforms: strut forces, kinematic screws, stiffness and vibrations.

A rigid platform is held by six struts, each a line between a hinge on the
platform and a hinge on the base (any geometry: Gough–Stewart hexapods, the
box-like support of [1]_, ...).  Everything is computed in one fixed frame.

Conventions
-----------
* ``e_i`` is the unit vector of strut ``i`` pointing **from the platform hinge to
  the base hinge** ("единичные векторы направлены от шарниров" in [1]_).
* Strut force ``S_i`` is **tension positive**: the strut pulls the platform hinge
  towards the base hinge with force ``S_i e_i``.  Compression is negative.
* Plücker rows of the struts are ``(e_i; p_i × e_i)`` with the moment about the
  origin O (``r × d``, :mod:`kin.screws`).  The Plücker matrix ``L`` stacks them
  as rows, ``(6, 6)``.
* The applied loads reduce to one wrench ``W = Σ (F; r × F + couple)``; gravity is
  *not* added automatically (put the weight in as a load).
* Equilibrium: ``Lᵀ S + W = 0`` (the six equations ΣF = 0, ΣM_O = 0).
* Virtual velocities [1]_: ``V_i`` is the twist ``(ω; v_O)`` of the platform with
  strut ``i`` removed, reciprocal to the five other strut lines.  Then
  ``S_i = −(W ∘ V_i) / (e_i ∘ V_i)``, ``∘`` the reciprocal product.  ``V_i`` is a
  unit screw (``|ω| = 1``, a pure translation has ``|v| = 1``) with the sign for
  which strut ``i`` *lengthens* (``e_i ∘ V_i < 0``: the rate of change of the
  strut length is ``−e_i ∘ V``).  [1]_ prints V1 with the opposite sign and
  V2, V3 with this one; a screw's axis and pitch do not depend on the sign.
* Singularity: the struts are singular when their six lines are linearly
  dependent (they belong to a linear complex).  The condition number reported is
  that of the dimensionless Plücker matrix: moments about the centroid of the
  platform hinges divided by the RMS hinge distance from it, so it is invariant
  under rigid motions and scaling.
* Vibrations (small, about the equilibrium; preload/geometric stiffness ignored):
  generalised coordinates ``q = (x, y, z, φx, φy, φz)``: displacement of the centre
  of mass and small rotations about axes parallel to the frame axes.  With ``L_C``
  the Plücker matrix about the centre of mass, the stiffness matrix is
  ``C = L_Cᵀ diag(c) L_C`` ([1]_: ``C = (C1·Pluck)ᵀ·Pluck``), the inertia matrix
  ``A = diag(m, m, m, J)`` with ``J`` the central inertia tensor, and the circular
  frequencies ``k`` solve ``det(C − k² A) = 0`` (rad/s, ascending).

References
----------
.. [1] F. A. Doronin, "Применение теории винтов в статике и динамике
   пространственных механизмов параллельной структуры", *Izvestiya PGUPS* 2015,
   no. 3, pp. 130–137 (Doronin 2015); geometry reconstructed in
   ``docs/platform.md``.
.. [2] D. Stewart, "A platform with six degrees of freedom", *Proc. IMechE* 180
   (1965); V. E. Gough, discussion, *Proc. Auto. Div. IMechE* (1956–57).
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import scipy.linalg

from multiloop.topo.errors import InputError, SingularityWarning, SingularStrutsError, explain

from multiloop.topo.io import (read_document, read_number, read_string, read_table, read_tables, read_vector,
                               table_label)

from .screws import Twist, Wrench, reciprocal_complements, reciprocal_products

__all__ = [
    "Strut",
    "PointLoad",
    "RigidBody",
    "Platform",
    "PlatformStatics",
    "PlatformModes",
    "SingularStrutsError",
    "COORDINATES",
    "NORMALISATIONS",
    "plucker_matrices",
    "condition_numbers",
    "strut_forces_equilibrium",
    "strut_forces_screws",
    "platform_statics",
    "platform_modes",
    "symmetric_struts",
    "platform_from_dict",
    "load_platform",
    "loads_platform",
]

#: names of the generalised coordinates of the modes
COORDINATES = ("x", "y", "z", "phi_x", "phi_y", "phi_z")

#: how mode shapes may be normalised (:meth:`PlatformModes.shapes`): x = 1 as printed by
#: Doronin 2015, mass-normalised (φᵀAφ = 1), largest component = 1
NORMALISATIONS = ("first", "mass", "max")

#: condition number above which the struts are treated as singular
SINGULAR_CONDITION = 1e10

_OTHERS = np.array([[j for j in range(6) if j != i] for i in range(6)])


def _snap(a, scale: float = 1.0) -> list[float]:
    """Floats with round-off (``|x| <= 1e-9 scale``) shown as 0 (display only)."""
    return [0.0 if abs(v) <= 1e-9 * scale else float(v) for v in np.asarray(a, dtype=float).ravel()]


# ---------------------------------------------------------------------------
# value objects
# ---------------------------------------------------------------------------
def _point(value: Any, what: str) -> tuple[float, float, float]:
    """Three finite numbers (a list, tuple or array) as a tuple."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
        raise InputError(explain(what, expected="3 numbers [x, y, z]", got=repr(value)[:60]))
    return read_vector(list(value), what, 3)


def _positive(value: Any, what: str, unit: str) -> float:
    return read_number(value, what, positive=True, unit=unit)


@dataclass(frozen=True, slots=True)
class Strut:
    """A strut between a platform hinge and a base hinge (m); stiffness in N/m (optional)."""

    platform: tuple[float, float, float]
    base: tuple[float, float, float]
    stiffness: float | None = None
    name: str = ""

    def __post_init__(self) -> None:
        label = f"strut {self.name!r}" if self.name else "strut"
        object.__setattr__(self, "platform", _point(self.platform, f"{label} platform"))
        object.__setattr__(self, "base", _point(self.base, f"{label} base"))
        if self.stiffness is not None:
            object.__setattr__(self, "stiffness", _positive(self.stiffness, f"{label} stiffness", "N/m"))
        if self.platform == self.base:
            raise InputError(explain(label, expected="distinct platform and base hinges",
                                     got=f"both at {self.platform}", hint="a strut needs a length"))

    @property
    def direction(self) -> np.ndarray:
        """Unit vector ``e`` from the platform hinge to the base hinge."""
        d = np.subtract(self.base, self.platform)
        return d / np.linalg.norm(d)

    @property
    def length(self) -> float:
        """Distance between the hinges (m)."""
        return float(np.linalg.norm(np.subtract(self.base, self.platform)))

    def unit_wrench(self) -> Wrench:
        """The wrench of a unit tension on the platform: ``(e; p × e)``."""
        return Wrench.from_force(self.platform, self.direction)


@dataclass(frozen=True, slots=True)
class PointLoad:
    """A force ``force`` (N) applied at ``at`` (m), plus an optional free couple (N·m)."""

    at: tuple[float, float, float]
    force: tuple[float, float, float]
    moment: tuple[float, float, float] = (0.0, 0.0, 0.0)
    name: str = ""

    def __post_init__(self) -> None:
        label = f"load {self.name!r}" if self.name else "load"
        object.__setattr__(self, "at", _point(self.at, f"{label} at"))
        object.__setattr__(self, "force", _point(self.force, f"{label} force"))
        object.__setattr__(self, "moment", _point(self.moment, f"{label} moment"))

    def wrench(self) -> Wrench:
        """``(F; r × F + couple)`` about the origin."""
        return Wrench.from_force(self.at, self.force, self.moment)


@dataclass(frozen=True, slots=True)
class RigidBody:
    """Mass (kg), centre of mass (m) and central inertia tensor (kg·m², frame axes).

    ``inertia`` is stored as a 3×3 tuple of tuples; three numbers are read as the
    principal moments about axes through the centre parallel to x, y, z.
    """

    mass: float
    center: tuple[float, float, float]
    inertia: tuple[tuple[float, float, float], ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "mass", _positive(self.mass, "body mass", "kg"))
        object.__setattr__(self, "center", _point(self.center, "body center"))
        J = np.asarray(self.inertia, dtype=float)
        if J.shape == (3,):
            J = np.diag(J)
        if J.shape != (3, 3) or not np.all(np.isfinite(J)):
            raise InputError(explain("body inertia", expected="3 principal moments or a 3×3 matrix (kg·m²)",
                                     got=repr(self.inertia)[:60]))
        if not np.allclose(J, J.T, rtol=1e-12, atol=0):
            raise InputError(explain("body inertia", expected="a symmetric matrix", got=repr(J.tolist())[:60]))
        ev = np.linalg.eigvalsh(J)
        if ev[0] <= 0:
            raise InputError(explain("body inertia", expected="positive principal moments",
                                     got=f"{np.round(ev, 6).tolist()}"))
        if ev[0] + ev[1] < ev[2] * (1 - 1e-3):
            raise InputError(explain("body inertia", expected="principal moments with J1 + J2 ≥ J3 (a real body)",
                                     got=f"{np.round(ev, 6).tolist()}",
                                     hint="check the moments: for a box m(b²+c²)/12 etc."))
        object.__setattr__(self, "inertia", tuple(tuple(float(v) for v in row) for row in J))

    @classmethod
    def from_box(cls, mass: float, size: Any, center: Any) -> "RigidBody":
        """Homogeneous box with edges ``size = (lx, ly, lz)`` along the frame axes.

        ``Jx = m(ly² + lz²)/12``, ``Jy = m(lx² + lz²)/12``, ``Jz = m(lx² + ly²)/12``
        ([1]_: ``Jx = m(f² + b²)/12`` with b along y, f the thickness).
        """
        lx, ly, lz = _point(size, "body box")
        if min(lx, ly, lz) < 0:
            raise InputError(explain("body box", expected="non-negative edge lengths", got=repr(size)))
        m = _positive(mass, "body mass", "kg")
        J = (m / 12.0) * np.array([ly * ly + lz * lz, lx * lx + lz * lz, lx * lx + ly * ly])
        return cls(m, center, tuple(np.diag(J).tolist()))

    @property
    def inertia_matrix(self) -> np.ndarray:
        """``A = diag(m, m, m, J)`` (6×6), coordinates ``(x, y, z, φx, φy, φz)`` at the centre."""
        A = np.zeros((6, 6))
        A[:3, :3] = self.mass * np.eye(3)
        A[3:, 3:] = np.asarray(self.inertia)
        return A


@dataclass(frozen=True, slots=True)
class Platform:
    """A rigid platform on six struts with loads and (optionally) its mass data."""

    struts: tuple[Strut, ...]
    loads: tuple[PointLoad, ...] = ()
    body: RigidBody | None = None
    name: str = "platform"
    description: str = ""
    source: str = ""

    def __post_init__(self) -> None:
        struts = tuple(self.struts)
        if len(struts) != 6:
            raise InputError(explain("platform struts", expected="exactly six struts",
                                     got=f"{len(struts)}",
                                     hint="a rigid platform needs six struts to be held (no more, no fewer)"))
        bad = [type(s).__name__ for s in struts if not isinstance(s, Strut)]
        if bad:
            raise InputError(explain("platform struts", expected="Strut objects", got=", ".join(bad)))
        if not all(isinstance(q, PointLoad) for q in self.loads):
            raise InputError(explain("platform loads", expected="PointLoad objects",
                                     got=", ".join(type(q).__name__ for q in self.loads)))
        object.__setattr__(self, "struts", struts)
        object.__setattr__(self, "loads", tuple(self.loads))

    @property
    def platform_points(self) -> np.ndarray:
        """Platform hinges, ``(6, 3)``."""
        return np.array([s.platform for s in self.struts])

    @property
    def base_points(self) -> np.ndarray:
        """Base hinges, ``(6, 3)``."""
        return np.array([s.base for s in self.struts])

    @property
    def directions(self) -> np.ndarray:
        """Unit vectors ``e_i`` (platform → base), ``(6, 3)``."""
        return np.array([s.direction for s in self.struts])

    @property
    def stiffnesses(self) -> np.ndarray | None:
        """``(6,)`` stiffnesses (N/m), or None unless every strut has one."""
        c = [s.stiffness for s in self.struts]
        return None if any(v is None for v in c) else np.array(c, dtype=float)

    @property
    def condition_number(self) -> float:
        """Condition number of the dimensionless Plücker matrix (see module notes)."""
        return float(condition_numbers(self.platform_points, self.base_points))

    @property
    def is_singular(self) -> bool:
        """True when the six strut lines are (numerically) dependent: a linear complex."""
        return not self.condition_number < SINGULAR_CONDITION

    @property
    def has_vibration_data(self) -> bool:
        """True when every strut has a stiffness and the body is given."""
        return self.body is not None and self.stiffnesses is not None

    def plucker_matrix(self, origin: Any = (0.0, 0.0, 0.0)) -> np.ndarray:
        """Rows ``(e_i; (p_i − origin) × e_i)``, ``(6, 6)``."""
        return plucker_matrices(self.platform_points, self.base_points, origin)

    def wrench(self) -> Wrench:
        """Resultant wrench of the loads about the origin (a zero wrench with no loads)."""
        if not self.loads:
            return Wrench((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        at = np.array([q.at for q in self.loads])
        F = np.array([q.force for q in self.loads])
        M = np.array([q.moment for q in self.loads])
        return Wrench.from_array(np.concatenate([F.sum(axis=0), (np.cross(at, F) + M).sum(axis=0)]))

    def transformed(self, rotation: Any, translation: Any = (0.0, 0.0, 0.0)) -> "Platform":
        """The whole platform (struts, loads, body) carried by ``x ↦ R x + t``."""
        R = np.asarray(rotation, dtype=float)
        t = np.asarray(translation, dtype=float)
        if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-9):
            raise InputError(explain("rotation", expected="a 3×3 rotation matrix", got=repr(R.tolist())[:60]))

        def move(p):
            return tuple((R @ np.asarray(p) + t).tolist())

        def turn(v):
            return tuple((R @ np.asarray(v)).tolist())

        struts = tuple(replace(s, platform=move(s.platform), base=move(s.base)) for s in self.struts)
        loads = tuple(replace(q, at=move(q.at), force=turn(q.force), moment=turn(q.moment)) for q in self.loads)
        body = None
        if self.body is not None:
            J = R @ np.asarray(self.body.inertia) @ R.T
            J = 0.5 * (J + J.T)
            body = RigidBody(self.body.mass, move(self.body.center), tuple(map(tuple, J.tolist())))
        return replace(self, struts=struts, loads=loads, body=body)


# ---------------------------------------------------------------------------
# vectorised core
# ---------------------------------------------------------------------------
def plucker_matrices(platform_points: Any, base_points: Any, origin: Any = (0.0, 0.0, 0.0)) -> np.ndarray:
    """Plücker matrices of strut sets, rows ``(e_i; (p_i − origin) × e_i)``.

    Parameters
    ----------
    platform_points, base_points : array_like, shape ``(..., 6, 3)``
        Hinges on the platform and on the base.
    origin : array_like, shape ``(..., 3)``
        Reference point of the moments.

    Returns
    -------
    ndarray, shape ``(..., 6, 6)``
    """
    p = np.asarray(platform_points, dtype=float)
    b = np.asarray(base_points, dtype=float)
    o = np.asarray(origin, dtype=float)[..., None, :]
    d = b - p
    e = d / np.linalg.norm(d, axis=-1, keepdims=True)
    r = p - o
    r, e = np.broadcast_arrays(r, e)
    return np.concatenate([e, np.cross(r, e)], axis=-1)


def condition_numbers(platform_points: Any, base_points: Any) -> np.ndarray:
    """Condition numbers of the dimensionless Plücker matrices, shape ``(...)``.

    Moments are taken about the centroid of the platform hinges and divided by the
    RMS distance of the hinges from it (``inf`` for exactly dependent lines).
    """
    p = np.asarray(platform_points, dtype=float)
    c = p.mean(axis=-2)
    ell = np.sqrt(np.mean(np.sum((p - c[..., None, :]) ** 2, axis=-1), axis=-1))
    ell = np.where(ell > 0, ell, 1.0)
    L = plucker_matrices(p, base_points, c)
    L = np.concatenate([L[..., :3], L[..., 3:] / ell[..., None, None]], axis=-1)
    sv = np.linalg.svd(L, compute_uv=False)
    with np.errstate(divide="ignore"):
        return np.where(sv[..., -1] > 0, sv[..., 0] / sv[..., -1], np.inf)


def strut_forces_equilibrium(plucker: Any, wrench: Any, *, check: bool = True) -> np.ndarray:
    """Strut forces from the six equilibrium equations ``Lᵀ S + W = 0``.

    Parameters
    ----------
    plucker : array_like, shape ``(..., 6, 6)``
        Strut Plücker rows about O.
    wrench : array_like, shape ``(..., 6)``
        Applied wrench about the same O.
    check : bool
        Warn (:class:`~topo.errors.SingularityWarning`) when a set is singular.

    Returns
    -------
    ndarray, shape ``(..., 6)``
        Tension-positive forces; NaN rows for singular sets.
    """
    L = np.asarray(plucker, dtype=float)
    W = np.asarray(wrench, dtype=float)
    L, W = _broadcast_LW(L, W)
    LT = np.swapaxes(L, -1, -2)
    bad = _singular_mask(L)
    safe = np.where(bad[..., None, None], np.eye(6), LT)
    S = np.linalg.solve(safe, -W[..., None])[..., 0]
    S = np.where(bad[..., None], np.nan, S)
    if check and np.any(bad):
        warnings.warn(f"singular strut set(s) (linear complex) at {int(np.sum(bad))} of {bad.size} "
                      "configurations: forces are NaN there", SingularityWarning, stacklevel=2)
    return S


def strut_forces_screws(plucker: Any, wrench: Any, *, check: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Strut forces by virtual velocities, one kinematic screw per strut ([1]_).

    For each ``i`` the twist ``V_i`` reciprocal to the other five strut lines is
    found (SVD); ``S_i = −(W ∘ V_i)/(e_i ∘ V_i)``.

    Returns
    -------
    forces : ndarray, shape ``(..., 6)``
        Tension-positive forces (NaN for singular sets).
    twists : ndarray, shape ``(..., 6, 6)``
        ``twists[..., i, :]`` is the unit twist ``(ω; v_O)`` of the platform with
        strut ``i`` removed, signed so that strut ``i`` lengthens.
    """
    L = np.asarray(plucker, dtype=float)
    W = np.asarray(wrench, dtype=float)
    L, W = _broadcast_LW(L, W)
    V, _ = reciprocal_complements(L[..., _OTHERS, :])            # (..., 6, 6)
    eV = reciprocal_products(L, V)                                # (..., 6)
    sign = np.where(eV > 0, -1.0, 1.0)
    V = V * sign[..., None]
    eV = eV * sign
    WV = reciprocal_products(W[..., None, :], V)
    bad = _singular_mask(L)
    with np.errstate(invalid="ignore", divide="ignore"):
        S = -WV / eV
    S = np.where(bad[..., None], np.nan, S)
    V = np.where(bad[..., None, None], np.nan, V)
    if check and np.any(bad):
        warnings.warn(f"singular strut set(s) (linear complex) at {int(np.sum(bad))} of {bad.size} "
                      "configurations: forces are NaN there", SingularityWarning, stacklevel=2)
    return S, V


def _broadcast_LW(L: np.ndarray, W: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    if L.shape[-2:] != (6, 6):
        raise InputError(explain("Plücker matrix", expected="shape (..., 6, 6)", got=f"shape {L.shape}"))
    if W.shape[-1:] != (6,):
        raise InputError(explain("wrench", expected="shape (..., 6)", got=f"shape {W.shape}"))
    shape = np.broadcast_shapes(L.shape[:-2], W.shape[:-1])
    return np.broadcast_to(L, shape + (6, 6)), np.broadcast_to(W, shape + (6,))


def _singular_mask(L: np.ndarray) -> np.ndarray:
    sv = np.linalg.svd(L, compute_uv=False)
    with np.errstate(invalid="ignore", divide="ignore"):
        return ~(sv[..., -1] > sv[..., 0] / SINGULAR_CONDITION)


# ---------------------------------------------------------------------------
# single queries: result objects
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class PlatformStatics:
    """Strut forces of a loaded platform, by both methods, and the removed-strut screws.

    Attributes
    ----------
    forces : ndarray (6,)
        Tension-positive strut forces (N) from the six equilibrium equations
        ``Lᵀ S + W = 0`` (LU solve: backward stable, residual ~ eps·|S| even near
        singular layouts; see benchmarks/bench_platform.py).
    forces_screws : ndarray (6,)
        The same by virtual velocities, ``S_i = −(W ∘ V_i)/(e_i ∘ V_i)`` ([1]_);
        its residual grows like eps·cond·|S|.
    twists : tuple of Twist
        ``twists[i]``: unit kinematic screw of the platform with strut ``i`` removed.
    wrench : Wrench
        Resultant of the applied loads about O.
    condition_number : float
        Of the dimensionless Plücker matrix (see module notes).
    discrepancy : float
        ``max |forces − forces_screws|`` (N).
    residual : float
        ``max |Lᵀ S + W|`` of ``forces``.
    """

    forces: np.ndarray
    forces_screws: np.ndarray
    twists: tuple[Twist, ...]
    wrench: Wrench
    condition_number: float
    discrepancy: float
    residual: float
    success: bool = True
    status: str = "ok"
    message: str = "strut forces by virtual velocities and by equilibrium agree"
    strut_names: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        for a in (self.forces, self.forces_screws):
            a.flags.writeable = False

    def as_dict(self) -> dict:
        """JSON-ready statics (keys in docs/platform.md); round-off below 1e-9 of the
        largest force (or of 1 for screws) is shown as 0."""
        fscale = max(1.0, float(np.max(np.abs(self.forces))))
        names = self.strut_names or tuple(str(i + 1) for i in range(6))
        screws = []
        for name, tw in zip(names, self.twists):
            translation = tw.is_infinite_pitch
            screws.append({"strut": name, "twist": _snap(tw.as_array()),
                           "pitch": None if translation else _snap(tw.pitch)[0], "translation": translation,
                           "axis_point": None if translation else _snap(tw.axis_point),
                           "axis_direction": _snap(tw.axis_direction)})
        return {"forces": _snap(self.forces, fscale), "forces_screws": _snap(self.forces_screws, fscale),
                "discrepancy": self.discrepancy, "residual": self.residual,
                "condition_number": self.condition_number, "singular": False,
                "wrench": _snap(self.wrench.as_array()), "screws": screws}

    @property
    def pitches(self) -> np.ndarray:
        """Pitches of the removed-strut screws (m; ``inf`` for a translation)."""
        return np.array([t.pitch for t in self.twists])

    @property
    def axis_points(self) -> np.ndarray:
        """Axis points nearest O of the removed-strut screws, ``(6, 3)`` (NaN rows for translations)."""
        return np.array([t.axis_point for t in self.twists])

    @property
    def axis_directions(self) -> np.ndarray:
        """Unit axis directions of the removed-strut screws, ``(6, 3)``."""
        return np.array([t.axis_direction for t in self.twists])


def platform_statics(platform: Platform, *, tol: float = 1e-6) -> PlatformStatics:
    """Strut forces and instantaneous screw axes of a loaded platform.

    Parameters
    ----------
    platform : Platform
    tol : float
        Relative tolerance for the agreement of the two methods (an internal check).

    Raises
    ------
    SingularStrutsError
        The six lines are linearly dependent (condition number > 1e10): the
        platform is movable and the forces are undetermined.

    Examples
    --------
    A symmetric hexapod under a centred vertical load: six equal compressions.

    >>> p = Platform(symmetric_struts(1.0, 0.5, 10.0, 10.0, 1.0),
    ...              (PointLoad((0, 0, 0.3), (0, 0, -1200.0)),))
    >>> st = platform_statics(p)
    >>> bool(np.allclose(st.forces, st.forces[0])), round(float(st.forces[0]), 3)
    (True, -243.635)
    >>> np.allclose(st.forces, st.forces_screws)
    True
    """
    cond = platform.condition_number
    if not cond < SINGULAR_CONDITION:
        raise SingularStrutsError(explain(
            f"platform {platform.name!r}",
            expected="six linearly independent strut lines",
            got=f"a singular set (linear complex), condition number {cond:.3g}",
            hint="the platform can move infinitesimally; change the strut layout"), cond)
    L = platform.plucker_matrix()
    W = platform.wrench().as_array()
    S, V = strut_forces_screws(L, W, check=False)
    S_eq = strut_forces_equilibrium(L, W, check=False)
    residual = float(np.max(np.abs(L.T @ S_eq + W)))
    disc = float(np.max(np.abs(S - S_eq)))
    scale = max(1.0, float(np.max(np.abs(S_eq))))
    ok = disc <= tol * scale * max(1.0, cond * 1e-6)
    return PlatformStatics(
        forces=S_eq, forces_screws=S,
        twists=tuple(Twist.from_array(v) for v in V), wrench=Wrench.from_array(W),
        condition_number=cond, discrepancy=disc, residual=residual,
        strut_names=tuple(st.name for st in platform.struts), success=ok, status="ok" if ok else "methods disagree",
        message=("strut forces by virtual velocities and by equilibrium agree" if ok else
                 f"the two methods differ by {disc:.3g} N (ill-conditioned, condition number {cond:.3g})"))


@dataclass(frozen=True)
class PlatformModes:
    """Natural vibrations of an elastically supported platform.

    Attributes
    ----------
    frequencies : ndarray (6,)
        Natural circular frequencies ``k`` (rad/s), ascending.
    modes : ndarray (6, 6)
        Column ``j`` is the mode of ``frequencies[j]`` in ``q = (x, y, z, φx, φy, φz)``,
        mass-normalised (``φᵀ A φ = 1``), signed so that its largest kinetic-energy
        component is positive.
    stiffness_matrix, inertia_matrix, plucker : ndarray (6, 6)
        ``C``, ``A`` and the Plücker rows about the centre of mass.
    """

    frequencies: np.ndarray
    modes: np.ndarray
    stiffness_matrix: np.ndarray
    inertia_matrix: np.ndarray
    plucker: np.ndarray

    def __post_init__(self) -> None:
        for a in (self.frequencies, self.modes, self.stiffness_matrix, self.inertia_matrix, self.plucker):
            a.flags.writeable = False

    def as_dict(self, normalise: str = "first") -> dict:
        """JSON-ready modes (keys in docs/platform.md): ``shape`` mass-normalised,
        ``shape_x1`` with x = 1 (Doronin 2015), ``shape_printed`` as ``normalise``."""
        first, chosen = self.shapes("first"), self.shapes(normalise)
        return {"modes_normalisation": normalise, "frequencies": _snap(self.frequencies),
                "frequencies_hz": _snap(self.frequencies_hz),
                "modes": [{"frequency": float(self.frequencies[j]), "label": self.labels[j],
                           "dominant": self.dominant[j], "shape": _snap(self.modes[:, j]),
                           "shape_x1": None if np.isnan(first[0, j]) else _snap(first[:, j]),
                           "shape_printed": None if np.isnan(chosen[0, j]) else _snap(chosen[:, j])}
                          for j in range(6)]}

    @property
    def frequencies_hz(self) -> np.ndarray:
        """``k / 2π`` (Hz)."""
        return self.frequencies / (2 * np.pi)

    @property
    def energy_fractions(self) -> np.ndarray:
        """``(6, 6)``: share of each coordinate (row) in mode ``j``'s kinetic energy (column)."""
        d = np.diag(self.inertia_matrix)[:, None] * self.modes ** 2
        return d / d.sum(axis=0, keepdims=True)

    @property
    def dominant(self) -> tuple[str, ...]:
        """Per mode, the coordinate with the largest kinetic-energy share."""
        return tuple(COORDINATES[i] for i in np.argmax(self.energy_fractions, axis=0))

    @property
    def labels(self) -> tuple[str, ...]:
        """``"k1 = 6.537 rad/s (mostly phi_z, 87 %)"`` per mode, in frequency order."""
        ef = self.energy_fractions
        out = []
        for j, k in enumerate(self.frequencies):
            i = int(np.argmax(ef[:, j]))
            out.append(f"k{j + 1} = {k:.4g} rad/s (mostly {COORDINATES[i]}, {100 * ef[i, j]:.0f} %)")
        return tuple(out)

    def shapes(self, normalise: str = "mass") -> np.ndarray:
        """Mode shapes as columns, normalised by ``"mass"`` (``φᵀAφ = 1``), ``"first"``
        (x component = 1, as printed in [1]_; NaN columns when x ≈ 0) or ``"max"``
        (largest |component| = 1; mixes metres and radians)."""
        M = self.modes
        if normalise == "mass":
            return M.copy()
        if normalise == "first":
            x = M[0]
            tiny = np.abs(x) <= 1e-12 * np.max(np.abs(M), axis=0)
            with np.errstate(invalid="ignore", divide="ignore"):
                return np.where(tiny, np.nan, M / np.where(tiny, 1.0, x))
        if normalise == "max":
            i = np.argmax(np.abs(M), axis=0)
            return M / M[i, np.arange(6)]
        raise InputError(explain("normalise", expected=", ".join(map(repr, NORMALISATIONS[:-1]))
                                 + f" or {NORMALISATIONS[-1]!r}", got=repr(normalise)))


def platform_modes(platform: Platform) -> PlatformModes:
    """Natural circular frequencies and mode shapes of the platform on elastic struts.

    ``C = L_Cᵀ diag(c) L_C``, ``A = diag(m, m, m, J)``, ``C φ = k² A φ`` ([1]_, eqs.
    for ``C`` and ``k = sqrt(eigenvals(A⁻¹ C))``), solved as a symmetric-definite
    generalised eigenproblem.

    Raises
    ------
    InputError
        A strut without stiffness, no body, or a body so far away or so heavy that the
        matrices overflow.
    """
    c = platform.stiffnesses
    if c is None:
        missing = [i + 1 for i, s in enumerate(platform.struts) if s.stiffness is None]
        raise InputError(explain(f"platform {platform.name!r}", expected="a stiffness for every strut",
                                 got=f"none for strut(s) {missing}",
                                 hint="add stiffness = ... (N/m) to each [[strut]]"))
    if platform.body is None:
        raise InputError(explain(f"platform {platform.name!r}", expected="a [body] table (mass, center, inertia)",
                                 got="nothing", hint="vibrations need the mass data"))
    body = platform.body
    Lc = platform.plucker_matrix(body.center)
    C = Lc.T @ (c[:, None] * Lc)
    C = 0.5 * (C + C.T)
    A = body.inertia_matrix
    if not (np.all(np.isfinite(C)) and np.all(np.isfinite(A))):
        raise InputError(explain(f"platform {platform.name!r} [body]", expected="a centre, mass and inertia of a "
                                 "size that keeps the stiffness and inertia matrices finite",
                                 got=f"center {list(body.center)}", hint="give the coordinates in metres"))
    try:
        w, V = scipy.linalg.eigh(C, A)
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise InputError(explain(f"platform {platform.name!r} [body]", expected="a mass and inertia the "
                                 "eigenproblem C φ = k² A φ can be solved with",
                                 got=f"{type(exc).__name__} ({str(exc)[:80]})",
                                 hint="check the body's weight, g, box and inertia")) from None
    k = np.sqrt(np.clip(w, 0.0, None))
    # deterministic sign: largest kinetic-energy component positive
    energy = np.diag(A)[:, None] * V ** 2
    idx = np.argmax(energy, axis=0)
    V = V * np.sign(V[idx, np.arange(6)])
    return PlatformModes(frequencies=k, modes=V, stiffness_matrix=C, inertia_matrix=A, plucker=Lc)


# ---------------------------------------------------------------------------
# symmetric Gough–Stewart layout
# ---------------------------------------------------------------------------
def symmetric_struts(base_radius: float, platform_radius: float, base_half_angle: float,
                     platform_half_angle: float, height: float,
                     stiffness: float | None = None) -> tuple[Strut, ...]:
    """Struts of a symmetric 6-6 Gough–Stewart platform (3-fold symmetric about z).

    Base hinges lie on the circle of radius ``base_radius`` in the plane
    ``z = −height``, in pairs at ``120°·j ± β``; platform hinges on the circle
    ``platform_radius`` in ``z = 0``, in pairs at ``120°·j ± (60° − π)``, with
    ``β = base_half_angle`` and ``π = platform_half_angle`` in degrees.  Strut
    ``2j`` (0-based) joins base ``120°j − β`` to platform ``120°j − 60° + π``;
    strut ``2j+1`` joins base ``120°j + β`` to platform ``120°j + 60° − π``: the
    usual crossing layout, each platform pair meeting two neighbouring base pairs.
    """
    rb = _positive(base_radius, "symmetric base_radius", "m")
    rp = _positive(platform_radius, "symmetric platform_radius", "m")
    h = _positive(height, "symmetric height", "m")
    struts = []
    for j in range(3):
        for s in (-1, 1):
            tb = math.radians(120 * j + s * float(base_half_angle))
            tp = math.radians(120 * j + s * (60 - float(platform_half_angle)))
            struts.append(Strut(platform=(rp * math.cos(tp), rp * math.sin(tp), 0.0),
                                base=(rb * math.cos(tb), rb * math.sin(tb), -h),
                                stiffness=stiffness, name=str(len(struts) + 1)))
    return tuple(struts)


# ---------------------------------------------------------------------------
# files
# ---------------------------------------------------------------------------
_TOP_KEYS = {"name", "description", "source", "notes", "reconstruction", "strut", "load", "body", "symmetric"}
_KEYS = {
    "strut": {"name", "platform", "base", "stiffness"},
    "load": {"name", "at", "force", "moment"},
    "body": {"mass", "weight", "g", "center", "inertia", "box"},
    "symmetric": {"base_radius", "platform_radius", "base_half_angle", "platform_half_angle",
                  "height", "stiffness"},
}
_HINT = "check the spelling (docs/platform.md lists the format)"


def _symmetric(doc: Mapping) -> tuple[Strut, ...]:
    """Struts of a ``[symmetric]`` table (:func:`symmetric_struts`)."""
    sym = read_table(doc["symmetric"], "[symmetric]", _KEYS["symmetric"], hint=_HINT,
                     required=("base_radius", "platform_radius", "base_half_angle", "platform_half_angle", "height"))
    args = {k: read_number(sym[k], f"[symmetric] key '{k}'")
            for k in ("base_radius", "platform_radius", "base_half_angle", "platform_half_angle", "height")}
    stiff = sym.get("stiffness")
    if stiff is not None:
        stiff = read_number(stiff, "[symmetric] key 'stiffness'", positive=True, unit="N/m")
    return symmetric_struts(**args, stiffness=stiff)


def _explicit_struts(raw: list[dict]) -> tuple[Strut, ...]:
    """Six ``[[strut]]`` tables, with a stiffness on all of them or on none."""
    struts = []
    for i, t in enumerate(raw, 1):
        label = table_label("strut", i, t)
        read_table(t, label, _KEYS["strut"], required=("platform", "base"), hint=_HINT)
        p = read_vector(t["platform"], f"{label} key 'platform'", 3)
        b = read_vector(t["base"], f"{label} key 'base'", 3)
        c = t.get("stiffness")
        if c is not None:
            c = read_number(c, f"{label} key 'stiffness'", positive=True, unit="N/m")
        if p == b:
            raise InputError(explain(f"{label} keys 'platform' and 'base'", expected="two distinct hinges",
                                     got=f"both {list(p)}"))
        struts.append(Strut(p, b, c, read_string(t.get("name", str(i)), f"{label} key 'name'")))
    if len(struts) != 6:
        raise InputError(explain("[[strut]]", expected="exactly six [[strut]] tables", got=f"{len(struts)}",
                                 hint="a rigid platform is held by six struts"))
    given = [s.stiffness is not None for s in struts]
    if any(given) and not all(given):
        missing = [i + 1 for i, g in enumerate(given) if not g]
        raise InputError(explain("[[strut]] key 'stiffness'", expected="on all six struts or on none",
                                 got=f"missing on strut(s) {missing}"))
    return tuple(struts)


def _struts(doc: Mapping) -> tuple[Strut, ...]:
    raw = read_tables(doc, "strut")
    if "symmetric" not in doc:
        return _explicit_struts(raw)
    if raw:
        raise InputError(explain("top level", expected="either [[strut]] tables or a [symmetric] table", got="both"))
    return _symmetric(doc)


def _loads(doc: Mapping) -> tuple[PointLoad, ...]:
    loads = []
    zero = [0.0, 0.0, 0.0]
    for i, t in enumerate(read_tables(doc, "load"), 1):
        label = table_label("load", i, t)
        read_table(t, label, _KEYS["load"], hint=_HINT)
        if "force" not in t and "moment" not in t:
            raise InputError(explain(label, expected="key 'force' (with 'at') or 'moment'", got="neither"))
        if "force" in t and "at" not in t:
            raise InputError(explain(label, expected="key 'at'", got="nothing"))
        loads.append(PointLoad(read_vector(t.get("at", zero), f"{label} key 'at'", 3),
                               read_vector(t.get("force", zero), f"{label} key 'force'", 3),
                               read_vector(t.get("moment", zero), f"{label} key 'moment'", 3),
                               read_string(t.get("name", str(i)), f"{label} key 'name'")))
    return tuple(loads)


def _body_mass(bt: Mapping) -> float:
    if ("mass" in bt) == ("weight" in bt):
        raise InputError(explain("[body]", expected="exactly one of 'mass' (kg) or 'weight' (N, with 'g')",
                                 got="both" if "mass" in bt else "neither"))
    if "mass" in bt:
        if "g" in bt:
            raise InputError(explain("[body] key 'g'", expected="only together with 'weight'", got="'g' with 'mass'"))
        return read_number(bt["mass"], "[body] key 'mass'", positive=True, unit="kg")
    weight = read_number(bt["weight"], "[body] key 'weight'", positive=True, unit="N")
    read_table(bt, "[body] (with 'weight')", required=("g",))
    return weight / read_number(bt["g"], "[body] key 'g'", positive=True, unit="m/s²")


def _body(doc: Mapping) -> RigidBody | None:
    if "body" not in doc:
        return None
    bt = read_table(doc["body"], "[body]", _KEYS["body"], required=("center",), hint=_HINT)
    mass = _body_mass(bt)
    center = read_vector(bt["center"], "[body] key 'center'", 3)
    if ("inertia" in bt) == ("box" in bt):
        raise InputError(explain("[body]", expected="exactly one of 'inertia' (kg·m²) or 'box' ([lx, ly, lz], m)",
                                 got="both" if "inertia" in bt else "neither"))
    if "box" in bt:
        return RigidBody.from_box(mass, read_vector(bt["box"], "[body] key 'box'", 3), center)
    J = bt["inertia"]
    ok = isinstance(J, list) and len(J) == 3 and (
        all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in J)
        or all(isinstance(r, list) and len(r) == 3 for r in J))
    if not ok:
        raise InputError(explain("[body] key 'inertia'", expected="3 principal moments or a 3×3 matrix", got=repr(J)[:60]))
    try:
        return RigidBody(mass, center, J)
    except InputError as exc:
        raise InputError(str(exc).replace("body inertia", "[body] key 'inertia'", 1)) from None


def platform_from_dict(doc: Mapping[str, Any]) -> Platform:
    """Build a :class:`Platform` from a parsed TOML/JSON document (format: docs/platform.md).

    Phases: top level, struts (``[[strut]]`` or ``[symmetric]``), loads, body; each
    value is read with the typed readers of :mod:`topo.io`.

    Raises
    ------
    InputError
        Unknown key, malformed value (the table and key are named), not six struts.
    """
    if not isinstance(doc, Mapping):
        raise InputError(explain("platform document", expected="a table", got=type(doc).__name__))
    read_table(dict(doc), "top level", _TOP_KEYS)
    name = read_string(doc.get("name", "platform"), "key 'name'", allow_empty=True)
    description = read_string(doc.get("description", ""), "key 'description'", allow_empty=True)
    source = read_string(doc.get("source", ""), "key 'source'", allow_empty=True)
    return Platform(_struts(doc), _loads(doc), _body(doc), name, description, source)


def load_platform(path: str | Path) -> Platform:
    """Read a platform from a ``.toml`` or ``.json`` file (format: docs/platform.md).

    Raises
    ------
    InputError
        Missing file, syntax error, unknown key or malformed value (named).
    """
    doc = read_document(path)
    try:
        return platform_from_dict(doc)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None


def loads_platform(text: str) -> Platform:
    """Parse a platform from a TOML string."""
    try:
        import tomllib
    except ModuleNotFoundError:  # pragma: no cover - Python 3.10
        import tomli as tomllib

    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"<string>: TOML syntax error: {exc}") from None
    return platform_from_dict(doc)

