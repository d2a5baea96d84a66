"""Named engines: builders returning a :class:`~topo.model.Mechanism` with masses.

Each builder reads its engine file in ``catalogue/engines/`` (format: ``docs/forces.md``)
and builds the mechanism with :func:`kin.engine.engine_mechanism`; the ``*_spec``
functions return the :class:`~kin.engine.EngineSpec` itself (geometry, masses, speed,
gas model) for :func:`kin.engine.analyse_engine`.

* :func:`single_cylinder` — crank–slider with a 5 mm cylinder offset;
* :func:`v_twin` — 90° V-twin, both rods on one crank pin (a 3-link multiple joint);
* :func:`radial` — the five-cylinder radial engine of Pozhbelko & Kuts 2020 example 2, all rods and
  the crank on one 6-link pin (j = 5); ``radial(n)`` builds any N-cylinder radial
  engine with the same dimensions and equal firing intervals (odd N).

Dimensions and masses are illustrative (documented in each file); the radial
engine's topology is the paper's, its geometry a reconstruction.

References
----------
.. [1] Pozhbelko V., Kuts E. (2020), example 2 (radial engine, fig. 7).
.. [2] Vasilenko V.N. et al. (2018) (one/two-cylinder four-stroke engine).
"""
from __future__ import annotations

from dataclasses import replace
from importlib import resources
from pathlib import Path

from multiloop.kin.engine import Cylinder, EngineSpec, engine_mechanism, load_engine
from multiloop.topo.model import Mechanism

__all__ = ["ENGINE_FILES", "engine_path", "single_cylinder", "single_cylinder_spec", "v_twin",
           "v_twin_spec", "radial", "radial_spec"]

#: catalogue name -> file in ``catalogue/engines/``
ENGINE_FILES = {"single_cylinder": "single_cylinder.toml", "v_twin": "v_twin.toml",
                "radial_5cyl_masses": "radial_5cyl_masses.toml"}


def engine_path(name: str) -> Path:
    """Path of a catalogue engine file (``name`` as in :data:`ENGINE_FILES`)."""
    return Path(str(resources.files("multiloop.catalogue") / "engines" / ENGINE_FILES[name]))


def single_cylinder_spec() -> EngineSpec:
    return load_engine(engine_path("single_cylinder"))


def v_twin_spec(angle_deg: float | None = None) -> EngineSpec:
    """The catalogue V-twin; ``angle_deg`` changes the V angle (cylinder 2 at
    ``bank_1 + angle``, firing on its second TDC: intervals 360 ∓ angle)."""
    spec = load_engine(engine_path("v_twin"))
    if angle_deg is None:
        return spec
    c1, c2 = spec.cylinders
    return replace(spec, cylinders=(c1, Cylinder(c2.name, c1.bank + angle_deg, c2.firing)))


def radial_spec(n: int = 5) -> EngineSpec:
    """The Pozhbelko & Kuts 2020 radial engine; ``n`` cylinders every 360/n deg from the vertical,
    odd cylinders firing on their first TDC and even ones on the second."""
    spec = load_engine(engine_path("radial_5cyl_masses"))
    if n == 5:
        return spec
    cyls = tuple(Cylinder(str(i + 1), (90.0 + 360.0 * i / n) % 360.0, 0.0 if i % 2 == 0 else 360.0)
                 for i in range(n))
    return replace(spec, cylinders=cyls, name=f"{n}-cylinder radial engine (all rods on one pin)")


def single_cylinder() -> Mechanism:
    """Single-cylinder offset crank–slider with masses (4 links, 4 joints)."""
    return engine_mechanism(single_cylinder_spec())


def v_twin(angle_deg: float | None = None) -> Mechanism:
    """90° V-twin with masses; the crank pin ``A`` joins crank, rod1 and rod2."""
    return engine_mechanism(v_twin_spec(angle_deg))


def radial(n: int = 5) -> Mechanism:
    """Radial engine with masses; ``A`` joins the crank and all ``n`` rods (Pozhbelko & Kuts 2020
    example 2 for n = 5: 12 links, n2 = 11, n6 = 1, V5 = 1, F = 1)."""
    return engine_mechanism(radial_spec(n))
