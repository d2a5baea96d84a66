"""Actual mobility and redundant constraints from the geometry (the structural numbers (README)).

The Chebyshev–Grübler count ``F = 3(n − 1) − 2p`` ignores geometry.  The actual
mobility at the reference configuration is ``3(n − 1) − rank J``, where ``J`` is
the Jacobian of all pair constraints (a pin of k links is k − 1 pairs, host = its
first link, :func:`multiloop.topo.graphs.pin_pairs`; a P joint keeps the relative angle and the guide line) with respect to
the poses ``(x, y, θ)`` of the moving links.  The number of redundant constraints
is ``2p − rank J = actual_F − formula_F``.

A parallelogram with a redundant parallel link has ``F = 0`` by formula but moves:
``actual_F = 1``, one redundant constraint.  The redundant pairs are named by a
greedy pass over the pairs in file order: a pair whose equations add less than
their count to the rank is redundant given the pairs before it.

The reference configuration is an *instant*: at a singular reference position the
actual mobility may exceed the finite mobility (a flat four-bar, for example).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .constraints import Constraint, link_origins, reference_jacobian
from .errors import InputError, explain
from .graphs import n_pairs, pin_pairs
from .model import JointKind, Mechanism

__all__ = ["MobilityReport", "actual_mobility", "pair_constraints"]


@dataclass(frozen=True, slots=True)
class MobilityReport:
    """Formula vs actual mobility.

    Attributes
    ----------
    formula_F : int
        Chebyshev–Grübler ``3(n − 1) − 2p``.
    actual_F : int
        ``3(n − 1) − rank J`` at the reference configuration.
    n_redundant : int
        ``2p − rank J``.
    redundant : tuple of str
        The redundant pairs, e.g. ``"D (crank3–coupler)"``.
    rank : int
    """

    formula_F: int
    actual_F: int
    n_redundant: int
    redundant: tuple[str, ...]
    rank: int

    def as_dict(self) -> dict:
        return {"formula_F": self.formula_F, "actual_F": self.actual_F,
                "n_redundant": self.n_redundant, "redundant": list(self.redundant)}


def pair_constraints(m: Mechanism) -> list[Constraint]:
    """All kinematic pairs as constraints (drivers excluded), in file order."""
    out = []
    for j in m.joints:
        if j.kind is JointKind.R:
            out += [Constraint("R", j.name, host, x) for host, x in pin_pairs(j.links)]
        else:
            out.append(Constraint("P", j.name, j.links[0], j.links[1]))
    return out


def _dimensionless_jacobian(m: Mechanism, cons: list[Constraint], moving: list[str]) -> np.ndarray:
    """The reference Jacobian with lengths in units of the mechanism's size.

    Dividing every length by the size ``s`` scales the rotation columns by ``1/s``,
    which leaves the rank unchanged but makes the rank tolerance independent of the
    units (a four-bar in metres, nanometres or kilometres has the same rank).
    """
    size = m.size
    at = {j.name: np.asarray(j.at, float) / size for j in m.joints}
    org = {x: c / size for x, c in link_origins(m).items()}
    axis = {j.name: np.asarray(j.axis, float) for j in m.joints if j.axis is not None}
    return reference_jacobian(m, cons, moving, joint_at=at, joint_axis=axis, origins=org)


def actual_mobility(m: Mechanism, tol: float = 1e-9) -> MobilityReport:
    """Actual mobility and redundant constraints at the reference configuration.

    Parameters
    ----------
    m : Mechanism
        With geometry (``at`` on every joint, ``axis`` on P joints) and a frame
        (without a frame the chain's mobility is computed with its first link
        fixed).
    tol : float
        Relative rank tolerance (lengths are measured in units of the mechanism's
        size, so the result does not depend on the units).

    Returns
    -------
    MobilityReport

    Raises
    ------
    InputError
        The mechanism has no geometry.

    Examples
    --------
    >>> from multiloop.topo.model import MechanismBuilder
    >>> b = MechanismBuilder()
    >>> b.add_link("g", frame=True)
    >>> for n, lk, at in [("O", ("g", "c1"), (0, 0)), ("A", ("c1", "cp"), (0, 1)),
    ...                   ("B", ("cp", "c2"), (2, 1)), ("C", ("c2", "g"), (2, 0)),
    ...                   ("D", ("g", "c3"), (1, 0)), ("E", ("c3", "cp"), (1, 1))]:
    ...     b.add_joint(n, "R", lk, at=at)
    >>> r = actual_mobility(b.build())
    >>> r.formula_F, r.actual_F, r.redundant
    (0, 1, ('E (c3–cp)',))
    """
    if not m.has_geometry:
        raise InputError(explain("actual mobility", expected="geometry ('at' on every joint, 'axis' on P joints)",
                                 got="a mechanism without geometry"))
    frame = m.frame or m.link_names[0]
    moving = [x for x in m.link_names if x != frame]
    cons = pair_constraints(m)
    J = _dimensionless_jacobian(m, cons, moving)
    scale = max(1.0, float(np.abs(J).max())) if J.size else 1.0
    rank = int(np.linalg.matrix_rank(J, tol=tol * scale)) if J.size else 0
    p = n_pairs(m)
    formula = 3 * len(moving) - 2 * p
    redundant = []
    r0, row = 0, 0
    # full row rank: every prefix of independent rows is independent, so none is redundant
    for c in (cons if rank < J.shape[0] else ()):
        k = c.n_equations
        sub = J[:row + k]
        r1 = int(np.linalg.matrix_rank(sub, tol=tol * scale))
        if r1 - r0 < k:
            redundant.append(f"{c.joint} ({c.a}–{c.b})")
        r0, row = r1, row + k
    return MobilityReport(formula, 3 * len(moving) - rank, 2 * p - rank, tuple(redundant), rank)
