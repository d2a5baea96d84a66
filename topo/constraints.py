"""Pair constraints of a planar linkage and their Jacobian (the one home of both).

Body coordinates: link ``k`` has the pose ``Z[..., k, :] = (X, Y, θ)``, where
``(X, Y)`` is the current position of the link's reference point ``c_k`` (its first
joint's reference position, :func:`link_origins`) and ``θ`` its rotation from the
reference configuration.  The material point that sat at ``r`` in the reference
configuration is at ``X + R(θ)(r − c_k)``, so the reference configuration is
``Z = (c, 0)`` for every link.

A :class:`Constraint` is one block of scalar equations between two links (pair
form: a pin on k links is k − 1 pairs, :func:`multiloop.topo.graphs.pin_pairs`).
:class:`PairEquations` compiles a list of them once into index arrays, and
:meth:`PairEquations.jacobian` evaluates ``∂Φ/∂Z`` over a leading batch axis.  The
equations are the standard planar revolute, translational and driving constraints
of Nikravesh, *Computer-Aided Analysis of Mechanical Systems* (1988), ch. 3–4:

* pin ``R``: ``X_a + R(θ_a) ρ_a − X_b − R(θ_b) ρ_b = 0`` (2 rows);
* slider ``P``: ``θ_b − θ_a = 0`` and ``n_a · (p_b − p_a) = 0`` with ``n_a`` the
  guide normal carried by ``a`` (2 rows);
* driver ``drive_R``: ``θ_b − θ_a = φ``; ``drive_P``: ``u_a · (p_b − p_a) = s``.

:func:`reference_jacobian` is the same Jacobian at the reference configuration, for
the rank tests of :mod:`multiloop.topo.mobility` and :mod:`multiloop.topo.assur`.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from .model import Mechanism

__all__ = ["Constraint", "PairEquations", "link_origins", "reference_jacobian"]


@dataclass(frozen=True, slots=True)
class Constraint:
    """One block of scalar equations between two links (pair form).

    Attributes
    ----------
    kind : str
        ``"R"`` (2 equations: the joint's point on ``a`` equals its point on ``b``),
        ``"P"`` (2 equations: ``b`` keeps its angle to guide ``a`` and stays on the
        guide line), ``"drive_R"`` (1 equation: ``θ_b − θ_a = input``),
        ``"drive_P"`` (1 equation: slide of ``b`` along ``a``'s guide = input).
    joint : str
    a, b : str
        Links (``a`` = host/guide, ``b`` = the other/slider).
    driver : int
        Index of the driver for ``drive_*`` constraints, else -1.
    """

    kind: str
    joint: str
    a: str
    b: str
    driver: int = -1

    @property
    def n_equations(self) -> int:
        return 1 if self.kind.startswith("drive") else 2


def link_origins(m: Mechanism) -> dict[str, np.ndarray]:
    """Reference point of every link: its first joint's ``at`` (origin for the frame).

    The pose of a link is the current position of this point and the rotation from
    the reference configuration, so every pose is ``(c, 0)`` at the reference.
    """
    out = {}
    for lk in m.links:
        js = m.joints_of(lk.name)
        out[lk.name] = (np.zeros(2) if lk.is_frame or not js or js[0].at is None
                        else np.asarray(js[0].at, float))
    return out


def _rot(th):
    return np.cos(th), np.sin(th)


def _unit(v) -> np.ndarray:
    u = np.asarray(v, float)
    return u / np.hypot(*u)


def _arr(rows: list, k: int, shape: tuple, dtype=float) -> np.ndarray:
    out = (np.array([t[k] for t in rows], dtype).reshape(shape) if rows
           else np.zeros(shape, dtype))
    return _frozen(out)


def _frozen(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


@dataclass(frozen=True, eq=False)
class PairEquations:
    """Compiled equations of a set of constraints.

    Attributes
    ----------
    n_links : int
        Number of links of the mechanism (columns ``3 * n_links``).
    n_eq : int
    R_a, R_b : ndarray of int
        Link indices of pin constraints; ``R_ra, R_rb`` their local vectors
        ``r − c`` (shape (nR, 2)); ``R_row`` first row of each.
    P_* : arrays for slider / slide-driver constraints (``P_dir`` the local
        direction: normal for a slider, axis for a slide driver).
    A_* : arrays for angle equations (slider angle, rotation driver).
    drv : ndarray (n_eq,) of int
        Driver index acting on each row (-1 none), ``Φ_φ = -1`` there.
    labels : tuple of str
        One label per row, e.g. ``"B:crank-rod:x"``.
    """

    n_links: int
    n_eq: int
    R_a: np.ndarray
    R_b: np.ndarray
    R_ra: np.ndarray
    R_rb: np.ndarray
    R_row: np.ndarray
    P_a: np.ndarray
    P_b: np.ndarray
    P_ra: np.ndarray
    P_rb: np.ndarray
    P_dir: np.ndarray
    P_row: np.ndarray
    A_a: np.ndarray
    A_b: np.ndarray
    A_row: np.ndarray
    drv: np.ndarray
    labels: tuple[str, ...]

    @classmethod
    def compile(cls, m: Mechanism, constraints: Sequence[Constraint], *,
                joint_at: Mapping | None = None, joint_axis: Mapping | None = None,
                origins: Mapping | None = None):
        """Compile constraints of ``m``.

        ``joint_at``, ``joint_axis`` and ``origins`` override the mechanism's own
        reference geometry (a random realisation, for the generic rank).
        """
        idx = {x: i for i, x in enumerate(m.link_names)}
        joint = {j.name: j for j in m.joints}
        org = link_origins(m) if origins is None else origins
        R, P, A, drv, labels = [], [], [], [], []
        row = 0
        for c in constraints:
            a, b = idx[c.a], idx[c.b]
            at = joint_at[c.joint] if joint_at is not None else joint[c.joint].at
            r = np.asarray(at, float)
            ra, rb = r - org[c.a], r - org[c.b]
            if c.kind in ("P", "drive_P"):
                u = _unit(joint_axis[c.joint] if joint_axis is not None else joint[c.joint].axis)
            if c.kind == "R":
                R.append((a, b, ra, rb, row))
                drv += [-1, -1]
                labels += [f"{c.joint}:{c.a}-{c.b}:x", f"{c.joint}:{c.a}-{c.b}:y"]
            elif c.kind == "P":
                A.append((a, b, row))
                P.append((a, b, ra, rb, np.array([-u[1], u[0]]), row + 1))
                drv += [-1, -1]
                labels += [f"{c.joint}:angle", f"{c.joint}:line"]
            elif c.kind == "drive_P":
                P.append((a, b, ra, rb, u, row))
                drv.append(c.driver)
                labels.append(f"{c.joint}:slide")
            elif c.kind == "drive_R":
                A.append((a, b, row))
                drv.append(c.driver)
                labels.append(f"{c.joint}:rotation")
            else:  # pragma: no cover
                raise ValueError(c.kind)
            row += c.n_equations
        nR, nP, nA = len(R), len(P), len(A)
        return cls(len(idx), row,
                   _arr(R, 0, (nR,), int), _arr(R, 1, (nR,), int),
                   _arr(R, 2, (nR, 2)), _arr(R, 3, (nR, 2)), _arr(R, 4, (nR,), int),
                   _arr(P, 0, (nP,), int), _arr(P, 1, (nP,), int),
                   _arr(P, 2, (nP, 2)), _arr(P, 3, (nP, 2)), _arr(P, 4, (nP, 2)),
                   _arr(P, 5, (nP,), int),
                   _arr(A, 0, (nA,), int), _arr(A, 1, (nA,), int), _arr(A, 2, (nA,), int),
                   _frozen(np.array(drv, int)), tuple(labels))

    @staticmethod
    def _rho(Z, k, r):
        """Rotated local vectors R(θ_k) r, shape (N, n, 2) (written in place: this runs in
        every Newton iteration, where np.stack's overhead was most of its time)."""
        c, s = _rot(Z[:, k, 2])
        out = np.empty(c.shape + (2,))
        out[..., 0] = c * r[:, 0] - s * r[:, 1]
        out[..., 1] = c * r[:, 1] + s * r[:, 0]
        return out

    def jacobian(self, Z: np.ndarray) -> np.ndarray:
        """∂Φ/∂Z at the poses ``Z`` (shape (N, n_links, 3)), shape (N, n_eq, 3 n_links)."""
        N = Z.shape[0]
        J = np.zeros((N, self.n_eq, 3 * self.n_links))
        if self.R_a.size:               # (each block writes one entry per row: no index repeats)
            ra = self._rho(Z, self.R_a, self.R_ra)
            rb = self._rho(Z, self.R_b, self.R_rb)
            r0, a, b = self.R_row, 3 * self.R_a, 3 * self.R_b
            J[:, r0, a] += 1.0
            J[:, r0 + 1, a + 1] += 1.0
            J[:, r0, a + 2] += -ra[..., 1]
            J[:, r0 + 1, a + 2] += ra[..., 0]
            J[:, r0, b] -= 1.0
            J[:, r0 + 1, b + 1] -= 1.0
            J[:, r0, b + 2] -= -rb[..., 1]
            J[:, r0 + 1, b + 2] -= rb[..., 0]
        if self.P_a.size:
            ra = self._rho(Z, self.P_a, self.P_ra)
            rb = self._rho(Z, self.P_b, self.P_rb)
            n = self._rho(Z, self.P_a, self.P_dir)
            d = Z[:, self.P_b, :2] + rb - Z[:, self.P_a, :2] - ra
            r0, a, b = self.P_row, 3 * self.P_a, 3 * self.P_b
            J[:, r0, b] += n[..., 0]
            J[:, r0, b + 1] += n[..., 1]
            J[:, r0, b + 2] += n[..., 0] * -rb[..., 1] + n[..., 1] * rb[..., 0]
            J[:, r0, a] -= n[..., 0]
            J[:, r0, a + 1] -= n[..., 1]
            J[:, r0, a + 2] += (-n[..., 1] * d[..., 0] + n[..., 0] * d[..., 1]
                                - (n[..., 0] * -ra[..., 1] + n[..., 1] * ra[..., 0]))
        if self.A_a.size:
            J[:, self.A_row, 3 * self.A_b + 2] += 1.0
            J[:, self.A_row, 3 * self.A_a + 2] -= 1.0
        return J


def reference_jacobian(m: Mechanism, constraints: Sequence[Constraint], columns: Sequence[str],
                       joint_at: Mapping | None = None, joint_axis: Mapping | None = None,
                       origins: Mapping | None = None) -> np.ndarray:
    """Jacobian of pair constraints at the reference configuration ``Z = (c, 0)``.

    Parameters
    ----------
    m : Mechanism
    constraints : sequence of Constraint
    columns : sequence of str
        Links whose poses ``(x, y, θ)`` are the unknowns (3 columns each); the
        other links are known.
    joint_at, joint_axis : dict, optional
        Geometry overrides (a random realisation for generic rank); default the
        mechanism's own ``at``/``axis``.
    origins : dict, optional
        Link reference points (default :func:`link_origins`).

    Returns
    -------
    ndarray, shape (n_equations, 3 * len(columns))

    Examples
    --------
    >>> from multiloop.topo.model import MechanismBuilder
    >>> b = MechanismBuilder()
    >>> b.add_link("g", frame=True)
    >>> b.add_joint("O", "R", ("g", "crank"), at=(0, 0))
    >>> b.add_joint("A", "R", ("crank", "g"), at=(1, 0))
    >>> m = b.build()
    >>> reference_jacobian(m, [Constraint("R", "A", "g", "crank")], ["crank"]).tolist()
    [[-1.0, 0.0, 0.0], [0.0, -1.0, -1.0]]
    """
    org = link_origins(m) if origins is None else origins
    eqs = PairEquations.compile(m, constraints, joint_at=joint_at, joint_axis=joint_axis, origins=org)
    names = m.link_names
    Z = np.zeros((1, len(names), 3))
    for i, x in enumerate(names):
        Z[0, i, :2] = org[x]
    idx = {x: i for i, x in enumerate(names)}
    cols = [3 * idx[x] + k for x in columns for k in range(3)]
    return eqs.jacobian(Z)[0][:, cols]
