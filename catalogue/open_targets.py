"""Open targets: a stroke traced over part of the driver's motion.

An **open** target (a rocker over part of its range, a crank over part of a turn) is
not a closed curve, and a design need not turn its driver fully to trace it:

* **Retrieval** (:func:`ranked_windows`) compares the target with *sub-arcs* of the
  stored closed curves (:func:`.curves.window_distances`: windows of several lengths at
  every start, both directions, each normalised for position, size and rotation),
  nearest first, each with the similarity that carries its window onto the target.
* **The input interval.**  The polish gives every target point its own driver value
  (free timing); the design's input interval ``[a, b]`` is the span of those values.
  :meth:`kin.motion.DriverMotion.holds_span` says whether the interval lies in the
  driver's certified range of motion (:func:`kin.solve.motion_events`), and :func:`on_interval` writes the design
  with its reference configuration at the first target point and its driver's
  ``range`` over the interval only, so ``solve`` and ``check`` move it over that part.

Which targets are open: :func:`.curves.is_closed` (the end-to-start gap more than
1.1 times the longest step between consecutive points), or the caller's ``closed=``.
"""
from __future__ import annotations

import numpy as np

from multiloop.topo.model import Driver, JointKind, Mechanism, MechanismBuilder, TracerPoint
from multiloop.kin.solve import solve

from .atlas import Atlas
from .curve_atlas import CurveIndex, stored_curve
from .curves import FINE_FRACTIONS, FINE_OFFSETS, normalise_open, similarity_to, window_distances

__all__ = ["ranked_windows", "on_interval"]

#: the fewest nearest curves that the fine windows rank again
FINE_POOL = 256

#: the most stored curves whose coarse windows an open target is compared with: a larger
#: index is scanned at an even stride (every mechanism's curves are stored together, so
#: the stride passes through all of them): the scan of 1.09 million curves took 96 s,
#: of 2**17 at a stride 12 s, of 2**16 6 s
OPEN_SCAN = 1 << 16


def ranked_windows(atlas: Atlas, index: CurveIndex, target: np.ndarray,
                   candidates: int) -> list[tuple[float, dict, object]]:
    """``(distance, curve, similarity)`` of the ``candidates`` stored curves whose best
    window is nearest the open ``target``, nearest first.  Every indexed curve (at most
    :data:`OPEN_SCAN` of them, at an even stride) is compared on the coarse windows
    (:data:`.curves.WINDOW_FRACTIONS`, starts on the stored samples); the nearest
    ``2 × candidates`` (at least :data:`FINE_POOL`) again on windows every 1/32 of the
    arc starting every quarter of a sample (:data:`.curves.FINE_FRACTIONS`,
    :data:`.curves.FINE_OFFSETS`), which rank them: a target starting between two
    samples or spanning a length between two coarse ones was up to 6 % off its own
    curve, more than near-twin curves differ.  The similarity maps the curve's
    mechanism so that the window lies on the target."""
    a, ct, rt = normalise_open(target)
    K = len(index.shapes)
    scanned = np.arange(0, K, -(-K // OPEN_SCAN))
    coarse = window_distances(a, index.shapes[scanned] if K > OPEN_SCAN else index.shapes)
    pool = np.argsort(coarse["distance"], kind="stable")[:max(2 * int(candidates), FINE_POOL)]
    pool = pool[np.isfinite(coarse["distance"][pool])]
    if K > OPEN_SCAN:
        pool = scanned[pool]
    found = window_distances(a, index.shapes[pool], FINE_FRACTIONS, FINE_OFFSETS)
    order = np.argsort(found["distance"], kind="stable")[:max(int(candidates), 0)]
    out = []
    for i in order:
        if not np.isfinite(found["distance"][i]):
            break
        c = stored_curve(atlas, int(index.ids[pool[i]]))
        centre = c["centre"] + c["radius"] * complex(found["centre"][i])
        tf = similarity_to(ct, rt, centre, c["radius"] * float(found["radius"][i]), complex(found["rotation"][i]))
        out.append((float(found["distance"][i]), c, tf))
    return out


def on_interval(m: Mechanism, inputs) -> tuple[Mechanism, tuple[float, float]]:
    """The design moved to its configuration at ``inputs[0]`` (the first target point)
    as its reference, with its driver's ``range`` the inputs' span from there; and that
    range (rad or m).  A design with a P joint keeps its reference (a guide's direction
    is not re-read here): its range is the span from the reference, widened to hold it."""
    x = np.asarray(inputs, float)
    d = m.drivers[0]
    if any(j.kind is not JointKind.R for j in m.joints):
        rng = (min(0.0, float(x.min())), max(0.0, float(x.max())))
        return _rebuilt(m, m.joints, m.points, Driver(d.joint, d.links, d.speed, d.acceleration, rng)), rng
    st = solve(m, x[:1])
    if not np.all(st.ok):
        raise ValueError("the design does not assemble at its first target input")
    rng = (float(x.min() - x[0]), float(x.max() - x[0]))
    joints = [type(j)(j.name, j.kind, j.links, tuple(float(v) for v in st.positions[0, k]), j.axis)
              for k, j in enumerate(m.joints)]
    points = [TracerPoint(p.name, p.link, tuple(float(v) for v in st.point_positions[0, k]))
              for k, p in enumerate(m.points)]
    return _rebuilt(m, joints, points, Driver(d.joint, d.links, d.speed, d.acceleration, rng)), rng


def _rebuilt(m: Mechanism, joints, points, driver: Driver) -> Mechanism:
    b = MechanismBuilder.from_mechanism(m)
    b.joints, b.points, b.drivers = list(joints), list(points), [driver] + list(m.drivers[1:])
    return b.build()
