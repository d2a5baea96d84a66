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
* ``kin.sensitivity`` — exact derivatives of a design batch's poses by its design
  variables and inputs (``pose_sensitivity``: each step's velocity analogue).
* ``kin.kernel`` — compiled plans: ``kernel_plan`` (a plan as flat arrays),
  ``run_positions`` (one numba kernel over a batch), ``load``, ``using`` and the modes
  (``MULTILOOP_KERNEL``: ``auto``, ``on``, ``off``).
* ``kin.forces`` — :func:`forces` (kinetostatics group by group, virtual-power check),
  ``ForceResult``.
* ``kin.figures`` — every figure: mechanism, analogues, animation, engine diagrams,
  platform, atlas chain drawings.
* ``kin.engine`` — crank–slider engines (single, V-twin, radial), an application of the
  planar pipeline: ``EngineSpec``, ``analyse_engine``, ``engine_mechanism``, gas models.
* ``kin.spatial`` — six-strut spatial platforms by screw theory (``Screw``, ``Twist``,
  ``Wrench``, ``reciprocal``, ``Platform``), separate from the planar pipeline.
"""
from .state import KinematicState

__all__ = ["KinematicState", "ForceResult", "Screw", "Twist", "Wrench", "reciprocal"]

#: the value types re-exported from modules with heavy imports (scipy.linalg, networkx),
#: loaded when first asked for (PEP 562): ``kin.solve`` alone does not pay for them
_LAZY = {"ForceResult": ".forces", "Screw": ".spatial.screws", "Twist": ".spatial.screws",
         "Wrench": ".spatial.screws", "reciprocal": ".spatial.screws"}


def __getattr__(name: str):
    if name in _LAZY:
        from importlib import import_module
        value = getattr(import_module(_LAZY[name], __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
