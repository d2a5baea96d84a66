"""Spatial statics and vibrations of six-strut platforms by screw theory (Doronin 2015).

This package stands apart from the planar pipeline: it never touches a
:class:`~multiloop.topo.model.Mechanism`.

API index:

* ``screws`` — :class:`Screw`, :class:`Twist`, :class:`Wrench` (Plücker coordinates),
  paired only by :func:`reciprocal`; batch helpers (``plucker_lines``, ``pitches``,
  ``axis_points``, ``reciprocal_complements``).
* ``platform`` — :class:`Platform` (read by :func:`load_platform`), strut forces by the
  screw method and by the six equilibrium equations (:func:`platform_statics`), stiffness
  and inertia matrices, natural frequencies and modes (:func:`platform_modes`); the
  results own their ``as_dict``.
* ``report`` — :func:`platform_report`, the JSON report of a platform.

Figures live in :mod:`multiloop.kin.figures.platform`.
"""
from .platform import *  # noqa: F401,F403
from .platform import __all__ as _platform_all
from .report import *  # noqa: F401,F403
from .report import __all__ as _report_all
from .screws import *  # noqa: F401,F403
from .screws import __all__ as _screws_all

__all__ = [*_screws_all, *_platform_all, *_report_all]
