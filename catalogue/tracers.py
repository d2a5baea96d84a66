"""The best tracer points of a realisation for a target curve.

An atlas stores the curves of a few points per link, but every point of every
moving link is a candidate tracer.  A point of a link moves rigidly with it, so its
path is affine in the point's reference position ``a``:
``P(θ; a) = P(θ; 0) + a_x (P(θ; e_x) − P(θ; 0)) + a_y (P(θ; e_y) − P(θ; 0))``
(three traced points give every other one).  :func:`best_tracers` solves the
realisations of one mechanism in one batch, traces a grid of points on each moving
link at once, normalises the closed curves and ranks them
by the aligned distance to the target (:func:`.curves.aligned_distances`): the
retrieval's realisations are read with their best tracer instead of the stored one
(the multi-point search of coupler-curve atlases, Hrones & Nelson 1951, done by
computer).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from multiloop.topo.model import Mechanism
from multiloop.kin.design import solve_designs
from multiloop.kin.geometry import design_matrix, design_names

from .curves import CURVE_POINTS, aligned_distances, normalise_closed

__all__ = ["TracerFit", "best_tracers", "TRACER_GRID"]

#: points per side of the grid of candidate tracers on a link
TRACER_GRID = 12
#: driver samples over one turn
TURN = 181


@dataclass(frozen=True, slots=True)
class TracerFit:
    """A tracer point (``link``, reference position ``at``) and how its closed curve
    meets the target: the aligned distance, and the centre, radius and rotation of the
    similarity that carries its normalised curve onto the target's."""

    distance: float
    link: str
    at: tuple[float, float]
    centre: complex
    radius: float
    rotation: complex


def _traces(m: Mechanism, designs: list[dict], links) -> tuple[np.ndarray, dict]:
    """Per link: the paths of the points at reference positions (0, 0), (1, 0), (0, 1)
    of every design over one turn (the last sample, which repeats the first, left out),
    each ``(D, TURN − 1, 2)``, from one batched solve (:func:`kin.design.solve_designs`);
    and which designs turn fully."""
    names = design_names(m)
    X = design_matrix(names, designs)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = solve_designs(m, names, X, np.linspace(0.0, 2 * np.pi, TURN))
    out = {}
    for link in links:
        k = m.link_names.index(link)
        o = st.world(k, (0.0, 0.0))[:, :-1]
        out[link] = (o, st.world(k, (1.0, 0.0))[:, :-1] - o, st.world(k, (0.0, 1.0))[:, :-1] - o)
    return np.all(st.ok, axis=1), out


def _grid(m: Mechanism, at: dict, link: str, n: int) -> np.ndarray:
    """Candidate reference positions on ``link`` of the design with joint positions
    ``at``: a square grid over its joints' box widened by half the design's size on
    every side."""
    every = np.array([at[j.name] for j in m.joints], float)
    pts = np.array([at[j.name] for j in m.joints if link in j.links], float)
    size = float(np.max(np.ptp(every, axis=0))) or 1.0
    lo, hi = pts.min(axis=0) - 0.5 * size, pts.max(axis=0) + 0.5 * size
    gx, gy = np.meshgrid(np.linspace(lo[0], hi[0], n), np.linspace(lo[1], hi[1], n))
    return np.column_stack([gx.ravel(), gy.ravel()])


def best_tracers(m: Mechanism, designs: list[dict], target_shape: np.ndarray, links, *, per_link: int = 1,
                 grid: int = TRACER_GRID) -> list[list[TracerFit]]:
    """For each design of ``m``'s topology (joint positions by name), the ``per_link`` best
    tracer points of each of ``links`` for a closed target whose normalised shape is
    ``target_shape`` (:func:`.curves.normalise`, :data:`.curves.CURVE_POINTS` samples),
    nearest first.  A design that does not turn fully gives none."""
    full, traces = _traces(m, designs, links)
    out: list[list[TracerFit]] = [[] for _ in designs]
    for link, (o, ex, ey) in traces.items():
        for d in np.flatnonzero(full):
            at = _grid(m, designs[d], link, grid)
            P = o[d][None] + at[:, 0, None, None] * ex[d][None] + at[:, 1, None, None] * ey[d][None]
            length = np.sum(np.linalg.norm(np.diff(P, axis=1), axis=2), axis=1)
            keep = np.isfinite(length) & (length > 1e-6 * max(float(np.max(length)), 1e-300))
            if not keep.any():
                continue
            at, P = at[keep], P[keep]
            z, c, r = normalise_closed(P, CURVE_POINTS)
            dist, _, rot, _ = aligned_distances(target_shape, z)
            for k in np.argsort(dist)[:per_link]:
                # a reversed traversal is the same curve: the similarity does not depend on it
                out[d].append(TracerFit(float(dist[k]), link, (float(at[k, 0]), float(at[k, 1])), complex(c[k]),
                                        float(r[k]), complex(rot[k])))
    return [sorted(f, key=lambda t: t.distance) for f in out]
