"""The workspace of a tracer point over the box of every driver's usable range.

The box is the product of the drivers' usable ranges (each driver's ``range`` cut by its
assembly limits, found with the others at the reference).  It is sampled by

* every driver swept over its range with each other driver at its low end, its
  reference and its high end (``3^(n-1)`` sweeps per driver), and
* a grid of the interior,

all solved in one call, each on the assembly modes of the reference (``solve(...,
assemble=True)``: a batch path would stop at the first sample beyond a limit).  Samples
that do not assemble are left out.  For groups whose mode changes only at their reach
limit (the triangles of the hydraulic machines) these are the modes continuous motion
keeps; a group with a change point inside the box would be sampled on its reference mode
only.
The extreme x and y are *refined*, not read off the samples: from the best sample, a
zoom search (a pattern search with a full grid as its poll set; Kolda, Lewis & Torczon
2003, "Optimization by direct search", SIAM Rev. 45(3) 385-482) solves a small grid of
driver values around the current best, clamped to the box, moves to its best sample or
halves the window, down to 1e-10 of each range; all four extremes are polled in one solve
per iteration.  Polling every direction of the window (not only the driver axes) keeps
the search moving along a curved assembly limit, where a compass search stalls.

With two or three drivers whose box assembles everywhere, the boundary and area are
exact (:mod:`~kin.check.envelope`: the box's edges and the singular curves, of every
two-dimensional face for three drivers, each arc labelled by what sets it, the area by
Green's theorem), unless a face has rank one throughout or, for three drivers, the
Jacobian has rank one inside the box (``Workspace.reason`` then says why); a box end at
a reach limit is first moved inside it by the fewest units in the last place that make
its edge assemble.  Otherwise the boundary is the outline of the samples' alpha shape (Edelsbrunner,
Kirkpatrick & Seidel 1983, "On the shape of a set of points in the plane", IEEE Trans.
Inf. Theory 29(4) 551-559): the triangles of their Delaunay triangulation whose longest
edge is below ``alpha`` (6 × the median edge), the edges of one kept triangle only,
chained into loops; the loop of largest area is the boundary, and the area is that of
the kept triangles (holes excluded).  Its accuracy is the sampling's: about one grid
step.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from multiloop.kin.solve import solve

from .envelope import edge_fractions, envelope
from multiloop.topo.errors import ParameterError, explain

__all__ = ["Workspace", "workspace", "alpha_outline"]

#: interior grid points per driver (one driver: 401, two: 41, three or more: 15)
_GRID = {1: 401, 2: 41}
_LINE = 61            # samples along each box-edge sweep
_FACE = 31            # samples per driver on each face of the box (three drivers or more)
_ZOOM = {1: 9, 2: 9, 3: 7}   # zoom-search window: samples per driver


@dataclass(frozen=True)
class Workspace:
    """Extremes, boundary and area of a tracer point's workspace (docs/check.md).

    ``x``/``y``: (min, max) in m; ``x_at``/``y_at``: the driver values (rad or m from
    the reference) at the min and at the max; ``boundary``: (K, 2) polygon; ``box``:
    (low, high) per driver; ``samples``: (M, 2) the solved sample positions."""

    point: str
    x: tuple[float, float]
    y: tuple[float, float]
    x_at: tuple[tuple[float, ...], tuple[float, ...]]
    y_at: tuple[tuple[float, ...], tuple[float, ...]]
    boundary: np.ndarray = field(repr=False)
    area: float
    box: tuple[tuple[float, float], ...]
    rotary: tuple[bool, ...]
    samples: np.ndarray = field(repr=False)
    arcs: tuple = ()        # (label, (K, 2) points) per boundary arc, labelled by what sets it
    exact: bool = False     # boundary and area from the box edges and singular curves
    reason: str = ""        # why the boundary is the samples' outline (empty when exact)

    def arc_labels(self) -> list[str]:
        """The boundary arcs' labels, in order around the boundary, runs merged."""
        out = []
        for lab, _ in self.arcs:
            if not out or out[-1] != lab:
                out.append(lab)
        return out

    def user(self, xs) -> list[float]:
        """Driver values in the user's units (deg for R, m for P)."""
        return [float(np.degrees(v)) if r else float(v) for v, r in zip(xs, self.rotary)]

    def as_dict(self) -> dict:
        return {"point": self.point, "x": list(self.x), "y": list(self.y),
                "x_at": [self.user(v) for v in self.x_at], "y_at": [self.user(v) for v in self.y_at],
                "boundary": self.boundary.tolist(), "area": self.area, "exact": self.exact,
                "reason": self.reason,
                "arcs": [{"set_by": lab, "from": pts[0].tolist(), "to": pts[-1].tolist(),
                          "n_points": len(pts)} for lab, pts in self.arcs]}


def _box_samples(box: np.ndarray) -> np.ndarray:
    """Edge sweeps (each driver over its range, the others at low / 0 / high), every face
    of the box (one driver at an end, a grid of the others) and an interior grid, as (M, n)
    driver values."""
    n = box.shape[0]
    levels = [np.unique([box[k, 0], 0.0, box[k, 1]]) for k in range(n)]
    rows = []
    for k in range(n):
        line = [np.linspace(box[k, 0], box[k, 1], _LINE)]
        others = [levels[j] for j in range(n) if j != k]
        rows.append(_grid(line + others, [k] + [j for j in range(n) if j != k]))
        if n > 2:                        # the faces: driver k at an end, the others on a grid
            face = [np.linspace(box[j, 0], box[j, 1], _FACE) for j in range(n) if j != k]
            rows.append(_grid([box[k]] + face, [k] + [j for j in range(n) if j != k]))
    g = _GRID.get(n, 15)
    rows.append(_grid([np.linspace(box[k, 0], box[k, 1], g) for k in range(n)], list(range(n))))
    return np.vstack(rows)


def _grid(axes, order) -> np.ndarray:
    """The product of ``axes`` as rows, column ``order[i]`` taking ``axes[i]``."""
    G = np.array(np.meshgrid(*axes, indexing="ij")).reshape(len(axes), -1).T
    out = np.empty_like(G)
    out[:, order] = G
    return out


def _solve_point(m, X, ip) -> np.ndarray:
    """(M, 2) tracer point positions at driver values ``X`` (NaN where not assembled)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = solve(m, X, assemble=True)
    return np.where(st.ok[:, None], st.point_positions[:, ip], np.nan)


def _refine(m, ip, box: np.ndarray, starts: np.ndarray, signs: np.ndarray, coords: np.ndarray):
    """Zoom search of the four extremes at once: maximise ``signs[e] * p[coords[e]]`` from
    ``starts[e]`` inside ``box``.  Each iteration solves a ``k^n`` grid of half-width h
    around every current best (clamped to the box): a better sample becomes the new centre
    (h kept), else h is halved; a curved assembly limit does not stall it (all directions
    are sampled, not only the driver axes).  Returns (inputs (E, n), values (E,))."""
    n = box.shape[0]
    span = box[:, 1] - box[:, 0]
    k = _ZOOM.get(n, 5)
    offs = np.array(np.meshgrid(*[np.linspace(-1.0, 1.0, k)] * n, indexing="ij")).reshape(n, -1).T
    h = np.tile(span / (_GRID.get(n, 15) - 1), (len(starts), 1))
    x = starts.copy()
    best = signs * _solve_point(m, x, ip)[np.arange(len(x)), coords]
    E = np.arange(len(x))
    while np.any(h > 1e-10 * np.maximum(span, 1e-300)):
        cand = np.clip(x[:, None, :] + offs[None] * h[:, None, :], box[:, 0], box[:, 1])
        p = _solve_point(m, cand.reshape(-1, n), ip).reshape(len(x), len(offs), 2)
        v = signs[:, None] * p[E[:, None], np.arange(len(offs))[None, :], coords[:, None]]
        v = np.where(np.isfinite(v), v, -np.inf)
        i = np.argmax(v, axis=1)
        better = v[E, i] > best
        x = np.where(better[:, None], cand[E, i], x)
        best = np.where(better, v[E, i], best)
        h = np.where(better[:, None], h, 0.5 * h)
    return x, signs * best


def alpha_outline(P: np.ndarray) -> tuple[np.ndarray, float]:
    """Boundary polygon (K, 2) and area of the alpha shape of points ``P`` (M, 2)."""
    from scipy.spatial import Delaunay

    P = np.unique(np.round(P, 12), axis=0)
    if len(P) < 3 or np.linalg.matrix_rank(P - P[0]) < 2:
        return P, 0.0
    tri = Delaunay(P).simplices
    a, b, c = (P[tri[:, i]] for i in range(3))
    longest = np.max(np.stack([np.hypot(*(a - b).T), np.hypot(*(b - c).T), np.hypot(*(c - a).T)]), axis=0)
    edges_all = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    alpha = 6.0 * np.median(np.hypot(*(P[edges_all[:, 0]] - P[edges_all[:, 1]]).T))
    keep = tri[longest <= alpha]
    if not len(keep):
        return P[:0], 0.0
    u, v = P[keep[:, 1]] - P[keep[:, 0]], P[keep[:, 2]] - P[keep[:, 0]]
    area = float(0.5 * np.sum(np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0])))
    e = np.sort(np.concatenate([keep[:, [0, 1]], keep[:, [1, 2]], keep[:, [2, 0]]]), axis=1)
    uniq, count = np.unique(e, axis=0, return_counts=True)
    return P[_largest_loop(P, uniq[count == 1])], area


def _largest_loop(P: np.ndarray, edges: np.ndarray) -> list[int]:
    """The closed chain of boundary ``edges`` enclosing the largest area (vertex indices)."""
    nbr: dict[int, list[int]] = {}
    for u, v in edges.tolist():
        nbr.setdefault(u, []).append(v)
        nbr.setdefault(v, []).append(u)
    seen, best, best_area = set(), [], -1.0
    for s in nbr:
        if s in seen:
            continue
        loop, prev, cur = [s], None, s
        seen.add(s)
        while True:
            nxt = next((w for w in nbr[cur] if w != prev and (w not in seen or w == s)), None)
            if nxt is None or nxt == s:
                break
            loop.append(nxt)
            seen.add(nxt)
            prev, cur = cur, nxt
        q = P[loop]
        ar = 0.5 * abs(np.dot(q[:, 0], np.roll(q[:, 1], -1)) - np.dot(q[:, 1], np.roll(q[:, 0], -1)))
        if ar > best_area:
            best, best_area = loop + [loop[0]], ar
    return best


def _arc_label(m, arc, ends) -> str:
    """What sets a boundary arc: the drivers held at an end (their range, or an assembly
    limit), or a singular curve."""
    parts = []
    for k, end in arc.ends:
        why = ends[k][0 if end == "low" else 1] if ends is not None else None
        what = {"assembly": "an assembly limit", "range": "its range"}.get(why, why)
        parts.append(f"{m.drivers[k].joint} at its {end} end" + (f" ({what})" if what else ""))
    if arc.kind == "singular":
        return "singular curve (the Jacobian has rank one)" + (
            " on the face where " + ", ".join(parts) if parts else "")
    return ", ".join(parts)


def workspace(m, point: str, box, ends=None) -> Workspace:
    """The workspace of tracer point ``point`` over ``box`` = ((low, high) per driver,
    rad or m from the reference; see the module docstring); ``ends`` (optional): what
    sets each driver's low and high end (``"range"`` or ``"assembly"``), for the arcs'
    labels."""
    names = [p.name for p in m.points]
    if point not in names:
        raise ParameterError(explain("workspace", expected="a tracer point of the mechanism",
                                     got=repr(point), hint="points: " + (", ".join(names) or "none ([[point]])")),
                             "workspace")
    ip = names.index(point)
    box = _inside_limits(m, ip, np.array(box, float).reshape(len(m.drivers), 2))
    X = _box_samples(box)
    P = _solve_point(m, X, ip)
    good = np.isfinite(P).all(axis=1)
    if not good.any():
        raise ParameterError(explain("workspace", expected="positions that assemble", got="none in the box"),
                             "workspace")
    env, reason = _envelope(m, ip, box)
    Xg, Pg = X[good], P[good]
    if env is not None:                  # the box edges' Chebyshev samples: the corners exactly
        Xg, Pg = np.vstack([Xg, env.edge_inputs]), np.vstack([Pg, env.edge_points])
    coords = np.array([0, 0, 1, 1])
    signs = np.array([-1.0, 1.0, -1.0, 1.0])
    starts = np.array([Xg[np.argmax(s * Pg[:, c])] for s, c in zip(signs, coords)])
    xs, vals = _refine(m, ip, box, starts, signs, coords)
    if env is not None:
        boundary, area = env.boundary, env.area
        arcs = tuple((_arc_label(m, a, ends), a.points) for a in env.arcs)
    else:
        boundary, area = alpha_outline(Pg)
        arcs = ()
    rotary = tuple(m.is_rotary(d) for d in m.drivers)
    t = [tuple(float(v) for v in r) for r in xs]
    return Workspace(point, (float(vals[0]), float(vals[1])), (float(vals[2]), float(vals[3])),
                     (t[0], t[1]), (t[2], t[3]), boundary, area,
                     tuple((float(lo), float(hi)) for lo, hi in box), rotary, Pg, arcs, env is not None,
                     reason)


def _envelope(m, ip, box):
    """The exact envelope (:func:`~kin.check.envelope.envelope`) for two or three
    drivers whose box assembles everywhere on the reference's modes, with no face of
    rank one throughout and (three drivers) no critical point inside: (envelope, "");
    else (None, the reason), and the alpha shape is used."""
    if box.shape[0] not in (2, 3):
        return None, f"{box.shape[0]} driver(s): the exact boundary is built for two or three"
    if np.any(box[:, 1] <= box[:, 0]):
        return None, "a driver's usable range is a single value"
    try:
        return envelope(m, ip, box), ""
    except ValueError as e:
        return None, str(e)


def _inside_limits(m, ip, box: np.ndarray) -> np.ndarray:
    """``box`` with each end that lies on a reach limit (the solver reports the flat
    position there as singular: its determinant is zero) moved toward the reference by
    as few units in the last place as make its edge assemble (at most 2⁴⁰)."""
    box = box.copy()
    t = edge_fractions()                 # the envelope's own edge samples
    for k in range(box.shape[0]):
        for e in (0, 1):
            ulps = 0
            while ulps <= 2 ** 40:
                X = box[:, 0] + np.outer(t, box[:, 1] - box[:, 0])
                X[:, k] = box[k, e]
                if np.isfinite(_solve_point(m, X, ip)).all():
                    break
                ulps = max(1, 2 * ulps)
                inward = box[k, 1 - e] - box[k, e]
                box[k, e] += np.sign(inward) * ulps * np.spacing(abs(box[k, e]))
    return box
