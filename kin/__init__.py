"""kin: solvers, kinematics, kinetostatics, engines and spatial screws.

API index.  Functions are imported from their modules (``from multiloop.kin.solve import solve``;
they are not re-exported here because ``kin.solve`` and ``kin.forces`` are module
names); the value types are re-exported.

* ``kin.state`` — :class:`KinematicState`, the frozen result of kinematics
  (positions ``(N, n_joints, 2)``, angles, derivatives, ``status``, ``point_on_link``).
* ``kin.result`` — ``BatchStatus``: ``ok`` / ``success`` / ``message`` of batch results.
* ``kin.groups`` — closed-form dyads (RRR, RRP, RPR, PRP, RPP) with their 2×2 rate
  systems, the all-modes class III triad and its tracker, the class IV group, and the
  generic Newton group solver (``kin.groups.newton``).
* ``kin.solve`` — :func:`solve` (whole mechanism along an Assur plan), ``compile_plan``.
* ``kin.plot`` — mechanism figure, analogue diagrams, animation.
* ``kin.forces`` — :func:`forces` (kinetostatics group by group, virtual-power check),
  ``ForceResult``.
* ``kin.engine`` / ``kin.gas`` / ``kin.engine_plot`` — crank–slider engines (single,
  V-twin, radial): ``EngineSpec``, ``analyse_engine``, ``engine_reactions``,
  ``engine_mechanism``; indicator diagrams ``IndicatorDiagram``, ``PressureTable``.
* ``kin.screws`` — ``Screw``, ``Twist``, ``Wrench``, ``reciprocal``.
* ``kin.platform`` / ``kin.platform_plot`` — six-strut platforms: statics by screws and
  by equilibrium, vibrations.
"""
from .forces import ForceResult
from .screws import Screw, Twist, Wrench, reciprocal
from .state import KinematicState

__all__ = ["KinematicState", "ForceResult", "Screw", "Twist", "Wrench", "reciprocal"]
