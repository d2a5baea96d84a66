"""Crank–slider engines (Vasilenko et al. 2018): an application of the planar pipeline.

API index:

* ``model`` — :class:`Cylinder`, :class:`EngineSpec` (geometry, masses, speed, gas model);
* ``files`` — :func:`load_engine`, :func:`engine_from_dict` (engine files, strict);
* ``analysis`` — exact piston kinematics and the λ-approximation,
  :func:`engine_mechanism` (the spec as a :class:`~multiloop.topo.model.Mechanism`),
  :func:`analyse_engine` → :class:`EngineResult` (diagrams, cyclogram, reactions,
  balancing moment; ``as_dict`` for JSON).
* ``gas`` — cylinder pressure: :class:`IndicatorDiagram` (idealised Otto cycle) and
  :class:`PressureTable` (user data).

Figures live in :mod:`multiloop.kin.figures.engine`; the named engines of the catalogue in
:mod:`multiloop.catalogue.engines`.
"""
from .analysis import *  # noqa: F401,F403
from .analysis import __all__ as _analysis_all
from .gas import *  # noqa: F401,F403
from .gas import __all__ as _gas_all

__all__ = [*_analysis_all, *_gas_all]
