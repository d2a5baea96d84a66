"""Transmission and pressure angles of every group, as functions of a solved state.

Definitions (all in degrees):

* **RRR dyad** (outer A, inner B, outer C): the transmission angle μ is the angle at
  B between BA and BC, in [0°, 180°]; 90° is ideal, 0° and 180° are the toggle
  (the dyad's Jacobian determinant l₂l₃ sin(φ₂ − φ₃) vanishes there; Vasechkin et
  al. 2017, kind 1).  The same angle at the inner pin of an actuated triangle (a
  cylinder A–B driving the lever B–C) is the actuator's transmission angle.
* **RRP dyad** (rod A–B, slider at B on a guide): the pressure angle α is the angle
  between the rod line and the guide, in [0°, 90°]; the transmission angle is
  90° − α (α = 90° is the RRP toggle, det = l cos(φ₂ − φ₃) = 0).
* **RPR dyad** (block pivoted at A slides on a guide link pivoted at C): the force of
  the block on the guide is normal to the guide and the point A of the guide link
  moves normal to CA, so α is the angle between the guide and the line CA, in
  [0°, 90°] (α = 90° is the RPR toggle s = 0).
* **Triad** (binary links Aᵢ–Pᵢ on the ternary link): at each inner joint Pᵢ, μᵢ is
  the angle between the *line* of binary link PᵢAᵢ and the *line* from Pᵢ to the
  intersection Iⱼₖ of the other two binary-link lines (the instant centre of the
  ternary link when leg i is removed), in [0°, 90°].  It is a line-to-line angle
  because Iⱼₖ passes through infinity when legs j and k become parallel, which flips
  the direction PᵢIⱼₖ; as lines the angle stays continuous.  μᵢ = 0° exactly when the
  three leg lines are concurrent or parallel, the triad's singularity (Hunt 1983);
  90° is ideal, and only the minimum is flagged.

PRP and RPP dyads have no reach limit; their only singularity (parallel guides) is a
design error rejected when the plan is built, so no angle is reported for them.
Which angle a group kind has is a fact of the kind, declared by its adapter
(``monitored_angles``) and asked through :func:`kin.groups.registry.angle_defs`; every
fact of a type of angle (its formula, range, ideal, degenerate and flagged values) is
its object in :mod:`kin.check.angle_types`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from multiloop.kin.groups.registry import angle_defs
from multiloop.topo.assur import AssurPlan

from .angle_types import angle_type, guide_of

__all__ = ["AngleSpec", "angle_specs", "angle_values", "signed_dets_of", "guide_direction"]


@dataclass(frozen=True)
class AngleSpec:
    """One monitored angle: ``joint`` (where it is reported), ``quantity`` (the name of
    its type in :data:`kin.check.angle_types.ANGLE_TYPES`), the group label and the
    joint/link names the formula needs (``points``: three joint names; ``guide``:
    (P joint, guide link) for sliders; for a triad ``points`` = (Aᵢ, Pᵢ, Aⱼ, Pⱼ, Aₖ, Pₖ))."""

    joint: str
    quantity: str
    group: str
    kind: str
    points: tuple[str, ...]
    guide: tuple[str, str] | None = None

    @property
    def ideal(self) -> float:
        """The best value of the angle (its type's, degrees)."""
        return angle_type(self.quantity).ideal


def angle_specs(plan: AssurPlan) -> tuple[AngleSpec, ...]:
    """The monitored angles of every group of ``plan``, in solving order."""
    m = plan.mechanism
    out: list[AngleSpec] = []
    for g in plan.groups:
        out += [AngleSpec(d.joint, d.quantity, g.describe(), g.kind, d.points, d.guide)
                for d in angle_defs(m, g)]
    return tuple(out)


class _StateView:
    """What an angle reads, from a solved state: ``point(joint)`` (N, 2), ``angle(link)``
    (N,) and ``axis(joint)`` (2,) (a design batch, :class:`kin.design.DesignPoses`, has
    the same three methods over (D, N))."""

    def __init__(self, state):
        self.state = state

    def point(self, joint: str) -> np.ndarray:
        return self.state.positions[:, self.state.joint_index(joint)]

    def angle(self, link: str) -> np.ndarray:
        return self.state.angles[:, self.state.link_index(link)]

    def axis(self, joint: str) -> np.ndarray:
        ax = np.asarray(self.state.mechanism.joint(joint).axis, float)
        return ax / np.hypot(*ax)


def guide_direction(state, spec: AngleSpec):
    """Unit direction (N, 2) of the guide of a pressure angle ``spec`` in the world."""
    return guide_of(_StateView(state), spec.guide)


def spec_value(view, sp: AngleSpec) -> np.ndarray:
    """One monitored angle in degrees over a view's batch (see :class:`_StateView`),
    computed by its type (:func:`kin.check.angle_types.angle_type`): a transmission
    angle in [0, 180], a pressure angle in [0, 90], a triad's folded angle in [0, 90]."""
    return angle_type(sp.quantity).value(view, sp)


def angle_values(state, specs) -> np.ndarray:
    """``(N, len(specs))`` angles in degrees (NaN where the position failed)."""
    view = _StateView(state)
    out = np.full((state.positions.shape[0], len(specs)), np.nan)
    for c, sp in enumerate(specs):
        out[:, c] = spec_value(view, sp)
    return out


def signed_dets_of(state, specs) -> np.ndarray:
    """``(N, len(specs))`` normalised signed determinants of the groups of ``specs`` (their
    types' :meth:`~kin.check.angle_types.AngleType.signed_det`; zero: singular)."""
    view = _StateView(state)
    out = np.full((state.positions.shape[0], len(specs)), np.nan)
    for c, sp in enumerate(specs):
        out[:, c] = angle_type(sp.quantity).signed_det(view, sp)
    return out
