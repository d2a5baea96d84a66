"""Input sweeps: the driver values a run visits, in user units (deg, m) and in SI.

The command line and the façade take inputs in degrees for an R driver and metres for
a P driver; the solvers take radians and metres.  :func:`input_range` is the sweep of
``multiloop solve``, :func:`cycle_inputs` that of ``multiloop forces`` (one load
period), :func:`driver_forces` each driver's balancing force or torque over its own
sweep (the others held at the reference).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from multiloop.topo.errors import ParameterError, explain
from multiloop.topo.model import Mechanism

from .forces import forces, reduce_inputs, table_period
from .forces.solver import MAX_ANGLE_DEG, MAX_SLIDE_SIZES
from .motion import DriverMotion

__all__ = ["MAX_STEPS", "MAX_CYCLE_STEPS", "input_range", "si_inputs", "cycle_inputs", "driver_sweep",
           "driver_forces", "DriverForces"]


#: most positions :func:`input_range` gives
MAX_STEPS = 1_000_000


def input_range(m: Mechanism, steps: int | None = None, start: float | None = None,
                stop: float | None = None) -> np.ndarray:
    """Inputs in user units (deg for R drivers, m for P drivers), shape (N,).

    ``steps`` alone (default 36): one full turn from the reference, the first being the
    reference itself (0, 360/N, …); for P drivers a stroke from 0 to +10 % of the
    mechanism's size (the largest extent of its reference joints), N points.
    ``start``/``stop``: N points from ``start`` to ``stop`` inclusive, exactly
    ``start + k·step``.  Every driver takes the same values.  Without ``start``/``stop``,
    a driver with a ``range`` is swept over that range (from low to high); then the
    result is ``(N, n_drivers)`` when there are several drivers (one column each, the
    others on their usual default).

    Raises
    ------
    InputError
        ``steps`` outside 1…:data:`MAX_STEPS`; only one of ``start``/``stop``; a
        non-finite one, or one beyond the limits of the ``forces`` and ``check`` commands
        (1e9 deg for an R driver, 100 × the mechanism's size for a P driver).
    """
    if steps is not None and not 1 <= steps <= MAX_STEPS:
        raise ParameterError(explain("steps", expected=f"an integer from 1 to {MAX_STEPS}", got=str(steps)), "steps")
    if (start is None) != (stop is None):
        raise ParameterError(explain("start/stop", expected="both or neither", got="only one"), "start", "stop")
    rotary = {m.is_rotary(d) for d in m.drivers}
    size = m.size
    limit = min(MAX_ANGLE_DEG if True in rotary else np.inf,
                MAX_SLIDE_SIZES * size if False in rotary else np.inf)
    for name, v in (("start", start), ("stop", stop)):
        if v is not None and not np.isfinite(v):
            raise ParameterError(explain(name, expected="a finite number", got=str(v)), name)
        if v is not None and abs(v) > limit:
            raise ParameterError(explain(name, expected=f"a magnitude of at most {limit:.6g}"
                                         + (" deg" if True in rotary and limit == MAX_ANGLE_DEG else
                                            f" m ({MAX_SLIDE_SIZES:g} × the mechanism's size)"),
                                         got=f"{v:g}"), name)
    n = steps if steps is not None else 36
    if start is None and any(d.range is not None for d in m.drivers):
        return _ranged_default(m, n, size)
    if start is not None:
        if n == 1:
            return np.array([start])
        out = start + np.arange(n) * ((stop - start) / (n - 1))
        out[-1] = stop
        return out
    if rotary == {True}:
        return np.arange(n) * (360.0 / n)
    if rotary == {False}:
        return np.linspace(0.0, 0.1 * size, n) if n > 1 else np.zeros(1)
    raise ParameterError(explain("drivers", expected="'start' and 'stop' when R and P drivers are mixed",
                                 got="no range"), "drivers", "start", "stop")


def _default_column(m: Mechanism, d, n: int, size: float) -> np.ndarray:
    """Driver ``d``'s default sweep in user units: its ``range`` (low to high), else a
    turn from the reference (R) or 0 to 10 % of the size (P)."""
    rotary = m.is_rotary(d)
    if d.range is not None:
        lo, hi = np.degrees(d.range) if rotary else d.range
        return np.linspace(lo, hi, n) if n > 1 else np.zeros(1)
    if rotary:
        return np.arange(n) * (360.0 / n)
    return np.linspace(0.0, 0.1 * size, n) if n > 1 else np.zeros(1)


def _ranged_default(m: Mechanism, n: int, size: float) -> np.ndarray:
    """The default sweep when a driver has a ``range``: each driver's
    :func:`_default_column`, (N,) for one driver and (N, n_drivers) for several."""
    cols = [_default_column(m, d, n, size) for d in m.drivers]
    return np.stack(cols, axis=1) if len(cols) > 1 else cols[0]


def si_inputs(m: Mechanism, x_user: np.ndarray) -> np.ndarray:
    """The inputs of :func:`input_range` in radians (R) and metres (P): ``(N,)`` for one
    driver, ``(N, n_drivers)`` for several (what :func:`~kin.solve.solve` takes);
    ``x_user`` is ``(N,)`` (every driver the same) or ``(N, n_drivers)``."""
    x_user = np.asarray(x_user, float)
    cols = []
    for k, d in enumerate(m.drivers):
        x = x_user[:, k] if x_user.ndim == 2 else x_user
        cols.append(np.radians(x) if m.is_rotary(d) else x)
    return np.stack(cols, axis=1) if len(cols) > 1 else cols[0]


#: most positions :func:`cycle_inputs` gives
MAX_CYCLE_STEPS = 100_000


def cycle_inputs(m: Mechanism, at: str | None = None, steps: int = 72) -> np.ndarray:
    """Driver inputs for kinetostatics in radians and metres, shape (N, n_drivers).

    ``at``: one position, comma-separated user values (deg / m) per driver, R inputs
    reduced into one load period (:func:`~kin.forces.reduce_inputs`).  Otherwise
    ``steps`` positions over one load period of the first driver (360 deg, or 720 deg
    when a force table runs past 360 deg), or :func:`input_range`'s stroke when every
    driver is a P joint; when a driver has a ``range``, :func:`input_range`'s default
    (each such driver over its range).
    """
    nd = len(m.drivers)
    if at is not None:
        try:
            vals = [float(x) for x in str(at).split(",")]
        except ValueError:
            raise ParameterError(explain("at", expected="a number (deg or m) per driver, comma-separated",
                                         got=repr(at)), "at") from None
        if len(vals) != nd:
            raise ParameterError(explain("at", expected=f"{nd} value(s), one per driver", got=f"{len(vals)}"), "at")
        return reduce_inputs(m, [vals], degrees=True)
    if not 1 <= steps <= MAX_CYCLE_STEPS:
        raise ParameterError(explain("steps", expected=f"an integer from 1 to {MAX_CYCLE_STEPS}", got=repr(steps)),
                             "steps")
    q = np.zeros((steps, nd))
    if any(d.range is not None for d in m.drivers):   # a driver's range is its default sweep
        return si_inputs(m, input_range(m, steps)).reshape(steps, nd)
    if m.is_rotary(0):
        q[:, 0] = np.radians(np.arange(steps) * table_period(m) / steps)
    elif not any(m.is_rotary(d) for d in m.drivers):
        x = input_range(m, steps)               # the solve command's default stroke
        q[:] = x if x.ndim == 2 else x[:, None]
    else:
        raise ParameterError(explain("drivers", expected="'at' when the first driver is a P joint and others are R",
                                     got="no default sweep"), "drivers", "at")
    return q


def driver_sweep(m: Mechanism, k: int, steps: int = 72) -> np.ndarray:
    """(steps, n_drivers) inputs in rad / m: driver ``k`` over its own default sweep
    (its ``range``, else a turn or 10 % of the size, :func:`input_range`), the others at
    the reference."""
    if not 1 <= steps <= MAX_CYCLE_STEPS:
        raise ParameterError(explain("steps", expected=f"an integer from 1 to {MAX_CYCLE_STEPS}", got=repr(steps)),
                             "steps")
    motion = DriverMotion.held(m, k)
    col = _default_column(m, m.drivers[k], steps, m.size)
    return motion.inputs(np.radians(col) if motion.rotary else col)


@dataclass(frozen=True)
class DriverForces:
    """Each driver's balancing moment (N m) or force (N) over its own sweep, the other
    drivers held at the reference: ``results[k]`` is the :class:`~kin.forces.ForceResult`
    of driver ``k``'s sweep."""

    mechanism: Mechanism
    results: tuple

    def as_dict(self) -> dict:
        """``{joint: {"unit", "input", "balancing", "min", "max", "status"}}`` (user units)."""
        out = {}
        for k, (d, fr) in enumerate(zip(self.mechanism.drivers, self.results)):
            rotary = self.mechanism.is_rotary(d)
            b = fr.balancing[:, k]
            ok = fr.ok & np.isfinite(b)
            out[d.joint] = {"unit": "N m" if rotary else "N", "input_unit": "deg" if rotary else "m",
                            "input": fr.inputs_user[:, k].tolist(), "balancing": b.tolist(),
                            "min": float(b[ok].min()) if ok.any() else None,
                            "max": float(b[ok].max()) if ok.any() else None,
                            "status": [str(x) for x in fr.status]}
        return out

    def to_text(self) -> str:
        L = ["balancing of each driver over its own sweep (the others at the reference):"]
        for joint, e in self.as_dict().items():
            if e["min"] is None:
                L.append(f"  {joint}: no position solved ({e['status'][0]})")
                continue
            x, b = np.array(e["input"]), np.array(e["balancing"], float)
            lo, hi = int(np.nanargmin(b)), int(np.nanargmax(b))
            L.append(f"  {joint} from {x[0]:.6g} to {x[-1]:.6g} {e['input_unit']}: min {e['min']:.6g} {e['unit']} "
                     f"at {x[lo]:.6g}, max {e['max']:.6g} {e['unit']} at {x[hi]:.6g}")
        return "\n".join(L) + "\n"


def driver_forces(m: Mechanism, steps: int = 72, method: str = "groups") -> DriverForces:
    """Kinetostatics of each driver moved alone over its sweep (:func:`driver_sweep`)."""
    return DriverForces(m, tuple(forces(m, driver_sweep(m, k, steps), method=method)
                                 for k in range(len(m.drivers))))
