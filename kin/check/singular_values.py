"""Angles at located singular points: the exact value, not a reading beside it.

At a reach limit or a branch point (a crossing) of a group, the group's Jacobian
determinant vanishes, and with it the sine of an RRR dyad's or an actuated triangle's
transmission angle (0° or 180°), the cosine of an RRP/RPR pressure angle (90°) and a
triad's line angle at the leg whose determinant vanishes (0°; Hunt 1983, "Structural
kinematics of in-parallel-actuated robot-arms", J. Mech. Transm. Autom. Des. 105(4)
705-712).  The solver cannot be evaluated *at* the point (it is singular), so the
extremes are read beside it (1e-9 to 1e-7 of the input away, where a square-root
approach leaves up to about 1e-2°).  Where the position is such a located point, the
angle there is known exactly and is reported instead: a value read beside the point
(toward the reference) that lies within :data:`SNAP` of a degenerate value of its type
(:attr:`kin.check.angle_types.AngleType.degenerate`) is that value at the point, and
it competes with the other candidates of the extreme.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from .angle_types import angle_type

__all__ = ["SNAP", "singular_points", "exact_extremes"]

#: a reading beside a located singular point this close to a degenerate value is it (deg)
SNAP = 0.5


def singular_points(mo) -> list[tuple[float, str | None]]:
    """Located singular points of the motion ``mo``: its assembly limits and crossings,
    as (input, group label or None when the walk did not name it)."""
    out = []
    ev = mo.events
    for seg in mo.segments:
        if seg.limit is None or seg.bound == "range":
            continue
        side = "hi" if seg.side.sign > 0 else "lo"
        out.append((float(seg.limit), ev.limits.get(side) if ev is not None else None))
        out += [(float(x), None) for x, _ in seg.singular]
    if ev is not None:
        out += [(float(x), label) for x, label in ev.crossings]
    return out


def _segment_of(mo, x):
    for seg in mo.segments:
        if seg.x.size and min(seg.x[0], seg.limit if seg.limit is not None else seg.x[-1]) - 1e-12 <= x <= \
                max(seg.x[-1], seg.limit if seg.limit is not None else seg.x[-1]) + 1e-12:
            return seg
    return None


def exact_extremes(mo, specs, ext, values) -> list:
    """``ext`` (one :class:`~kin.check.events.Extreme` or None per spec) with the exact
    value at every located singular point of ``mo`` whose group is the spec's (or
    unnamed) and whose reading beside it is within :data:`SNAP` of a degenerate value;
    ``values(state)`` gives the (N, len(specs)) angles in degrees."""
    out = list(ext)
    for x, label in singular_points(mo):
        seg = _segment_of(mo, x)
        if seg is None:
            continue
        step = 1e-7 * max(1.0, abs(x))
        toward = x - step if x > 0 else x + step
        st, r = seg.side.at(np.array([toward]))
        v = values(st)[r[0]]
        for c, sp in enumerate(specs):
            e = out[c]
            if e is None or not np.isfinite(v[c]) or (label is not None and sp.group != label):
                continue
            exact = min(angle_type(sp.quantity).degenerate, key=lambda d: abs(d - v[c]), default=None)
            if exact is None or abs(exact - v[c]) > SNAP:
                continue
            if exact <= e.min:
                e = replace(e, min=exact, at_min=x)
            if exact >= e.max:
                e = replace(e, max=exact, at_max=x)
            out[c] = e
    return out
