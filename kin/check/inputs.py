"""The inputs of ``multiloop check`` in the library's terms: driver values given in
degrees (R drivers) or metres (P drivers) as radians and metres, the positions to reach
as a list per driver, and a joint named as the output as a tracer point.

Examples
--------
>>> from multiloop.catalogue.named import load_named
>>> m = load_named("four_bar")
>>> positions(m, ["-60,120"])[m.drivers[0].joint]      # doctest: +ELLIPSIS
[-1.047..., 2.094...]
"""
from __future__ import annotations

import math

import numpy as np

from multiloop.kin.motion import DriverMotion
from multiloop.topo.errors import InputError, ParameterError, explain
from multiloop.topo.model import Mechanism

__all__ = ["check_options", "instant_at", "positions", "output_point"]


def _to_api(m: Mechanism, v: float, k: int = 0) -> float:
    return math.radians(v) if m.is_rotary(k) else v


def _finite(v: float, what: str) -> float:
    if not math.isfinite(v) or abs(v) > 1e9:
        raise ParameterError(explain(what, expected="a finite number of magnitude ≤ 1e9", got=repr(v)), what)
    return v


def positions(m: Mechanism, text) -> dict | None:
    """Positions as text (comma-separated, or a list of such texts) as the ``positions``
    of :func:`~kin.check.check`: the first driver's values in rad or m; None without."""
    if text is None:
        return None
    text = ",".join(text) if isinstance(text, list) else text
    try:
        vals = [float(s) for s in text.split(",") if s.strip()]
    except ValueError:
        raise ParameterError(explain("positions", expected="comma-separated numbers", got=repr(text)),
                             "positions") from None
    if not m.drivers:
        return None
    return {m.drivers[0].joint: [_to_api(m, _finite(v, "positions")) for v in vals]}


def instant_at(m: Mechanism, at: float | None) -> np.ndarray | None:
    """``at`` in deg or m of the first driver as the ``at`` of :func:`~kin.check.check`."""
    if at is None or not m.drivers:
        return None
    return DriverMotion.held(m, 0).inputs([_to_api(m, _finite(at, "at"))])[0]


def output_point(m: Mechanism, name: str | None) -> tuple[Mechanism, str | None]:
    """``m`` and the output name: a joint given as the ``output`` becomes a tracer point
    ``joint <name>`` at the joint on its last link (a pin moves with every link on it)."""
    if name is None or name in m.link_names or any(p.name == name for p in m.points) \
            or name not in m.joint_names:
        return m, name
    from multiloop.topo.model import MechanismBuilder, TracerPoint
    j = m.joint(name)
    b = MechanismBuilder.from_mechanism(m)
    point = f"joint {name}"
    b.points.append(TracerPoint(point, j.links[-1], j.at))
    return b.build(), point


def check_options(m: Mechanism, source: str, min_transmission: float,
                  output: str | None) -> tuple[Mechanism, str | None]:
    """Check ``m`` (read from ``source``) has a driver and ``min_transmission`` (deg) lies
    in (0, 90); returns :func:`output_point` of ``output``."""
    if not m.drivers:
        raise InputError(explain(f"{source}: [[driver]]", expected="at least one driver", got="none",
                                 hint="the design check follows the motion of the input joint(s)"))
    if not 0.0 < _finite(min_transmission, "min_transmission") < 90.0:
        raise ParameterError(explain("min_transmission", expected="an angle between 0 and 90 deg",
                                     got=f"{min_transmission:g}",
                                     hint="a transmission angle lies in [0, 90] deg"), "min_transmission")
    return output_point(m, output)
