"""Batched curve normalisation and alignment against the one-curve routes, the tracer
refit of a realisation (every point of a link, from three traced points), the polyline
distance, and the synthesiser's local method."""
from __future__ import annotations

import numpy as np
from hypothesis import given, strategies as st

from multiloop.catalogue.curves import (
    CURVE_POINTS, aligned_distance, aligned_distances, normalise, normalise_closed, polyline_distance, resample,
    similarity_to,
)
from multiloop.catalogue.inversions import inversion
from multiloop.catalogue.tracers import _grid, best_tracers
from multiloop.kin.solve import solve


def _crank_rocker():
    """A Grashof crank-rocker four-bar (frame 0, crank 1 driven at J1)."""
    at = {"J1": (0.0, 0.0), "J2": (0.3, 0.1), "J3": (1.2, 0.9), "J4": (1.0, 0.0)}
    return inversion([(0, 1), (1, 2), (2, 3), (3, 0)], 0, 0, 1, at=at)


@given(st.integers(0, 2 ** 32 - 1), st.integers(3, 40), st.integers(3, 90), st.booleans())
def test_resample_is_linear_interpolation_by_arc_length(seed, n, m, closed):
    P = np.random.default_rng(seed).normal(size=(n, 2))
    Q = np.vstack([P, P[:1]]) if closed else P
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(Q, axis=0), axis=1))])
    t = np.linspace(0.0, s[-1], m, endpoint=not closed)
    ref = np.stack([np.interp(t, s, Q[:, 0]), np.interp(t, s, Q[:, 1])], axis=1)
    assert np.allclose(resample(P, m, closed), ref, atol=1e-12)


@given(st.integers(0, 2 ** 32 - 1))
def test_batched_normalise_and_alignment_equal_the_single_routes(seed):
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 2 * np.pi, 150, endpoint=False)
    curves = np.stack([np.stack([np.cos(t) + a * np.cos(2 * t + b), np.sin(t) + a * np.sin(3 * t)], axis=1) * r
                       for a, b, r in rng.uniform(0.05, 0.4, (5, 3))])
    z, c, r = normalise_closed(curves)
    for k in range(len(curves)):
        zk, ck, rk = normalise(curves[k], CURVE_POINTS, True)
        assert np.allclose(z[k], zk) and np.isclose(c[k], ck) and np.isclose(r[k], rk)
    d, s, rot, rev = aligned_distances(z[0], z)
    for k in range(len(curves)):
        assert np.allclose((d[k], s[k], rot[k], rev[k]), aligned_distance(z[0], z[k]), atol=1e-12)
    assert d[0] < 1e-6                               # (a difference of sums: cancellation)


def test_best_tracer_finds_a_grid_point_of_a_moved_coupler_curve():
    """The target: the path of a coupler point that lies on the refit's grid, turned,
    scaled and moved; the refit finds that point and the similarity back."""
    m = _crank_rocker()
    joints = {j.name: j.at for j in m.joints}
    at = _grid(m, joints, "3", 12)[57]
    st_ = solve(m, np.linspace(0, 2 * np.pi, 361)[:-1])
    p = st_.point_on_link("3", tuple(at))[0]
    target = 2.5 * p @ np.array([[0.6, 0.8], [-0.8, 0.6]]) + [4.0, -1.0]
    zt, ct, rt = normalise(target, CURVE_POINTS, True)
    far = {**joints, "J3": (1.2, 2.9)}               # a second design of the same topology, far off
    fits = best_tracers(m, [far, joints], zt, ["3", "4"], per_link=1)
    best = fits[1][0]
    assert fits[0] and fits[0][0].distance > 10 * best.distance
    assert best.link == "3" and np.allclose(best.at, at)
    assert best.distance < 2e-3                      # resampling of 180 against 360 samples
    moved = similarity_to(ct, rt, best.centre, best.radius, best.rotation)(p)
    assert np.max(np.linalg.norm(moved - target, axis=1)) < 1e-2 * np.ptp(target[:, 0])


def test_polyline_distance_is_to_segments():
    curve = np.stack([np.linspace(0, 1, 3), np.zeros(3)], axis=1)          # two long segments
    assert np.allclose(polyline_distance([[0.25, 0.5], [0.75, -0.2], [1.5, 0.0], [-1.0, 0.0]], curve),
                       [0.5, 0.2, 0.5, 1.0])
    # a circle sampled coarsely: the chord error, not the sample spacing
    t = np.linspace(0, 2 * np.pi, 200)
    circle = np.stack([np.cos(t), np.sin(t)], axis=1)
    on = np.stack([np.cos(t[:-1] + 0.5 * (t[1] - t[0])), np.sin(t[:-1] + 0.5 * (t[1] - t[0]))], axis=1)
    assert np.max(polyline_distance(on, circle)) < 1.1 * (1 - np.cos(np.pi / 199))
