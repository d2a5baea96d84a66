"""Per-kind facts the design check needs: the assembly modes and the transmission definition.

Each function takes the mechanism and one Assur group (a ``topo.assur.AssurGroup`` with
its layout) and answers for that group's kind; :mod:`kin.groups.registry` maps every
kind to its functions, so :mod:`kin.check` never switches on the kind.

Transmission definitions (Vasechkin et al. 2017 [1]_, kinds 1-3; Hunt 1983 [2]_ for the
triad):

* ``"transmission"`` at the inner pin B of a triangle A-B-C (the RRR dyad, and the
  actuated triangle whose side A-B is a cylinder): the angle between BA and BC.  For a
  cylinder this is the angle between the actuator axis and the lever C-B it drives.
* ``"pressure"`` of an RRP or RPR dyad: the angle between a line X-Y and a guide.
* ``"triad"``: the angle at each inner joint of a triad between its leg and the line to
  the instant centre of the other two legs.

Assembly modes at the reference: 2 for a triangle with a reach limit (RRR, RRP, RPR,
and the actuated triangle, whose two signs of the RRR closed form are its two modes),
1 for PRP and RPP, and the real roots of the degree-6 polynomial for a triad or a
class IV group (Hunt 1983 [2]_).

References
----------
.. [1] Vasechkin M.A., Matveeva E.V., Sidorenko A.S., Chertov E.D. Mathematical model
   of kinematic calculation of flat lever mechanisms. Vestnik VGUIT 79(2) (2017) 73-79.
.. [2] Hunt K.H. Structural kinematics of in-parallel-actuated robot-arms. ASME J.
   Mech. Trans. Autom. Des. 105 (1983) 705-712.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .class4 import class4_modes
from .triad import triad_modes

__all__ = ["AngleDef", "triangle_angles", "rrp_angles", "rpr_angles", "triad_angles",
           "no_angles", "two_modes", "one_mode", "triad_mode_count", "class4_mode_count"]


class AngleDef(NamedTuple):
    """One monitored angle of a group: reported at ``joint``; ``quantity`` is
    ``"transmission"``, ``"pressure"`` or ``"triad"``; ``points`` the joint names its
    formula reads; ``guide`` = (P joint, guide link) for a pressure angle."""

    joint: str
    quantity: str
    points: tuple[str, ...]
    guide: tuple[str, str] | None = None


def triangle_angles(m, g) -> tuple[AngleDef, ...]:
    """RRR dyad or actuated triangle: the angle at the inner pin between its two sides."""
    lay = g.layout
    return (AngleDef(lay.inner, "transmission", (lay.outer1, lay.inner, lay.outer2)),)


def rrp_angles(m, g) -> tuple[AngleDef, ...]:
    """RRP dyad: the rod outer1-inner against the guide of the slider's P joint outer2."""
    o1, inner, o2, _, _ = g.layout
    return (AngleDef(inner, "pressure", (o1, inner), (o2, m.joint(o2).links[0])),)


def rpr_angles(m, g) -> tuple[AngleDef, ...]:
    """RPR dyad: the guide against the line from the guide's pivot to the block's pivot."""
    o1, inner, o2, l1, _ = g.layout
    guide = m.joint(inner).links[0]
    gx, bx = (o1, o2) if guide == l1 else (o2, o1)
    return (AngleDef(inner, "pressure", (gx, bx), (inner, guide)),)


def triad_angles(m, g) -> tuple[AngleDef, ...]:
    """Triad: one angle at each inner joint (legs i, j, k in turn)."""
    outs, inns = g.layout.outers, g.layout.inners
    return tuple(AngleDef(inns[i], "triad", (outs[i], inns[i], outs[(i + 1) % 3], inns[(i + 1) % 3],
                                             outs[(i + 2) % 3], inns[(i + 2) % 3])) for i in range(3))


def no_angles(m, g) -> tuple[AngleDef, ...]:
    """PRP, RPP (no reach limit) and the class IV group: no monitored angle."""
    return ()


def two_modes(m, g) -> int:
    """A triangle with a reach limit: its two assembly modes."""
    return 2


def one_mode(m, g) -> int:
    """PRP and RPP: one assembly mode."""
    return 1


def _at(m) -> dict[str, np.ndarray]:
    return {j.name: np.asarray(j.at, float) for j in m.joints}


def triad_mode_count(m, g) -> int:
    """The real assembly modes of a triad at the reference (all-modes kernel)."""
    at, lay = _at(m), g.layout
    A = np.array([at[o] for o in lay.outers])
    b = np.array([at[i] for i in lay.inners])
    return int(triad_modes(A, b, np.hypot(*(b - A).T)).n_modes)


def class4_mode_count(m, g) -> int:
    """The real assembly modes of a class IV group at the reference (all-modes kernel)."""
    at, lay = _at(m), g.layout
    O = np.array([at[lay.outer1], at[lay.outer2]])
    J = np.array([at[j] for j in (lay.j11, lay.j12, lay.j21, lay.j22)])
    r = J - O[[0, 0, 1, 1]]
    ll = np.array([np.hypot(*(J[2] - J[0])), np.hypot(*(J[3] - J[1]))])
    return int(class4_modes(O, r, ll).n_modes)
