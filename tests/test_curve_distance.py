"""Refinement by the distance between curves (issue 37, item 3): the chamfer residuals of
:mod:`multiloop.catalogue.dimensional.curve_distance`, the fit that reaches an exact
design from a perturbed one (closed and open targets), and topology synthesis's last
stage, whose designs pass the same checks as the point-matched ones.

Every budget here is a number of evaluations: no outcome depends on wall time."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from multiloop.catalogue.curves import chamfer_score, polyline_distance
from multiloop.catalogue.dimensional.budget import Meter
from multiloop.catalogue.dimensional.curve_distance import CurveProblem, fit_curve, nearest_on_polyline
from multiloop.catalogue.named import load_named
from multiloop.catalogue.open_targets import on_interval
from multiloop.kin.check import check
from multiloop.kin.solve import motion_events, solve
from multiloop.topo.model import MechanismBuilder


def _moved(m, shift):
    """``m`` with every joint and tracer point moved by ``shift`` (n_joints + n_points, 2)."""
    b = MechanismBuilder.from_mechanism(m)
    from dataclasses import replace
    k = len(b.joints)
    b.joints = [replace(j, at=tuple(np.add(j.at, shift[i]))) for i, j in enumerate(b.joints)]
    b.points = [replace(p, at=tuple(np.add(p.at, shift[k + i]))) for i, p in enumerate(b.points)]
    return b.build()


def _traced(m, lo, hi, n=600):
    return solve(m, np.linspace(lo, hi, n)).point_positions[:, 0]


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(-1.4, 1.4), st.floats(-1.4, 1.4)), min_size=1, max_size=20),
       st.floats(0.0, 2 * np.pi))
def test_nearest_point_on_a_dense_curve_is_the_exact_segment_projection(pts, turn):
    """On a densely sampled closed curve, the nearest point found from the nearest vertex
    is at the exact polyline distance (every segment tried, ``polyline_distance``), and
    it lies on the polyline."""
    t = np.linspace(0.0, 2 * np.pi, 400) + turn          # (the last point is the first)
    C = np.column_stack([np.cos(t) + 0.3 * np.cos(2 * t), 0.7 * np.sin(t)])
    P = np.array(pts, float)
    far = polyline_distance(P, C)
    keep = far < 0.2                          # (near the curve: where the fit works)
    P, far = P[keep], far[keep]
    if not len(P):
        return
    Q = nearest_on_polyline(P, C[:-1], closed=True)
    np.testing.assert_allclose(np.linalg.norm(P - Q, axis=1), far, atol=1e-12)
    assert np.all(polyline_distance(Q, C) < 1e-12)


def test_residuals_vanish_on_the_design_s_own_curve_and_grow_off_it():
    """The chamfer residuals of a four-bar against its own coupler curve are at the chord
    error of the samples (≤ 1e-4 of the size); against a curve moved by 1 % of the size
    they are about 1 %.  Both halves are there: target → curve and curve → target."""
    m = load_named("four_bar")
    target = _traced(m, 0.0, 2 * np.pi, 500)[:-1]
    prob = CurveProblem(m, target, True, "P")
    r = prob.residuals_batch(prob.x0[None], prob.timing_for(prob.x0))[0]
    assert r.shape == (2 * len(prob.target) + 2 * prob.s.size + 1,) and np.sqrt(r @ r) < 1e-4 and r[-1] == 0.0
    off = CurveProblem(m, target + [0.01 * prob.size, 0.0], True, "P")
    r = off.residuals_batch(off.x0[None], off.timing_for(off.x0))[0]
    n = 2 * len(off.target)
    halves = np.sqrt(np.sum(r[:n] ** 2)), np.sqrt(np.sum(r[n:] ** 2))
    assert 0.003 < halves[0] < 0.011 and 0.003 < halves[1] < 0.011


def test_a_span_that_nears_the_driver_s_limit_is_penalised():
    """A four-bar whose crank does not turn fully: traced over half its range the hinge
    residual is 0; traced to within 1e-5 of its limit (the dyad nearly stretched, its
    folded transmission angle below MIN_MARGIN) it is positive, and it is the last
    residual."""
    from multiloop.catalogue.dimensional.curve_distance import MIN_MARGIN
    m = load_named("four_bar")
    shift = np.zeros((len(m.joints) + len(m.points), 2))
    shift[1] = [0.04, 0.03]                       # (A further out: the crank longer)
    m = _moved(m, shift)
    motion = motion_events(m)
    assert not motion.turns_fully and motion.hi > 0.5
    target = np.c_[np.linspace(0.0, 0.1, 50), np.zeros(50)]
    hinge = []
    for f in (0.5, 1.0 - 1e-5):
        prob = CurveProblem(m, target, False, "P", span=f * motion.hi)
        hinge.append(prob.residuals_batch(prob.x0[None], prob.timing_for(prob.x0))[0][-1])
    assert hinge[0] == 0.0 and 0.0 < hinge[1] <= 1.0 and MIN_MARGIN > 0


def _jacobian_problem(name, closed, shift=0.03):
    """A curve problem of catalogue mechanism ``name`` against its own curve moved by a
    wave of ``shift`` of its size (closed: a whole turn; open: 1.5 rad, span 1.2)."""
    m = load_named(name)
    st = solve(m, np.linspace(0.0, 2 * np.pi if closed else 1.5, 200, endpoint=not closed))
    T = st.point_positions[:, 0][np.asarray(st.status == "ok")]
    k = np.arange(len(T))
    T = T + shift * m.size * np.c_[np.sin(k / 9), np.cos(k / 13)]
    return CurveProblem(m, T, closed, m.points[0].name, None if closed else 1.2)


def _central_jacobian(prob, z):
    span = prob.upper - prob.lower
    out = []
    for i in range(len(z)):
        h = 1e-7 * span[i]
        zp, zm = z.copy(), z.copy()
        zp[i] += h
        zm[i] -= h
        out.append((prob.residuals_batch(zp[None], prob.timing_for(zp))[0]
                    - prob.residuals_batch(zm[None], prob.timing_for(zm))[0]) / (2 * h))
    return np.stack(out, axis=1)


@pytest.mark.parametrize("name, closed, margin", [("four_bar", True, None), ("stephenson_3_triad", True, None),
                                                  ("watt_1", False, None), ("stephenson_3", False, None),
                                                  ("four_bar", True, 60.0), ("watt_1", False, 60.0)])
@pytest.mark.parametrize("mode", ["off", "on"])
def test_the_exact_jacobian_equals_central_differences(name, closed, margin, mode, monkeypatch):
    """Every residual's exact derivative (the poses' sensitivities through the chamfer
    halves, an open target's span, and, with the margin raised so that the hinge is
    active, the hinge's) equals central differences of the residuals, with the NumPy and
    with the compiled sensitivities; the residuals are :meth:`residuals_batch`'s."""
    from multiloop.catalogue.dimensional import curve_distance
    from multiloop.kin import kernel
    if margin is not None:
        monkeypatch.setattr(curve_distance, "MIN_MARGIN", margin)
    prob = _jacobian_problem(name, closed)
    z = prob.x0
    with kernel.using(mode):
        R, J = prob.jacobian_batch(z[None])
        np.testing.assert_array_equal(R[0], prob.residuals_batch(z[None], prob.timing_for(z))[0])
    assert (R[0, -1] > 0) == (margin is not None)
    fd = _central_jacobian(prob, z)
    np.testing.assert_allclose(J[0], fd, rtol=0, atol=2e-6 * np.abs(fd).max())


def test_the_polish_takes_the_exact_jacobian(monkeypatch):
    """:func:`~.optimise.polish` asks a problem that has one for its exact Jacobian (and
    not for the forward differences' designs), and the fit still reaches its target."""
    from multiloop.catalogue.dimensional import optimise
    prob = _jacobian_problem("four_bar", True, shift=0.01)
    calls = []
    exact = prob.jacobian_batch
    monkeypatch.setattr(prob, "jacobian_batch", lambda *a: calls.append(1) or exact(*a))
    monkeypatch.setattr(optimise, "_jacobian", lambda *a, **k: pytest.fail("differenced"))
    z, _, n = optimise.polish(prob, prob.x0, np.empty(0), max_nfev=30)
    rms = lambda v: np.sqrt(np.sum(prob.residuals_batch(v[None], prob.timing_for(v))[0] ** 2))   # noqa: E731
    assert calls and rms(z) < 0.5 * rms(prob.x0)


def _apart(a, b, size, closed):
    """The largest distance either way between polylines ``a`` and ``b`` (closed: the
    last point joined to the first), over ``size``."""
    close = (lambda c: np.vstack([c, c[:1]])) if closed else (lambda c: c)
    return max(polyline_distance(a, close(b)).max(), polyline_distance(b, close(a)).max()) / size


def test_a_closed_fit_traces_the_target_curve_from_a_perturbed_start():
    """A four-bar's coupler curve; the start is the four-bar with every joint and the
    tracer moved by up to 2 % of its size: the fit (3 000 evaluations) traces the curve
    to 1e-3 of its size both ways (target → curve, curve → target), from 1e-2, every
    step a design the ``accept`` check took.  (Not the chamfer score: its 200-point
    resampling has a floor of about 5e-3 for two samplings of one curve.)"""
    m = load_named("four_bar")
    target = _traced(m, 0.0, 2 * np.pi, 400)[:-1]
    size = np.ptp(target, axis=0).max()
    rng = np.random.default_rng(3)
    start = _moved(m, 0.02 * m.size * rng.uniform(-1, 1, (len(m.joints) + len(m.points), 2)))
    seen = []
    meter = Meter(3000)
    fit = fit_curve(start, target, True, "P", meter, accept=lambda d, span, *_: seen.append(d) or True)
    got, span = fit.at(1.0)
    assert span is None and fit.after < 0.01 * fit.before
    assert _apart(_traced(start, 0.0, 2 * np.pi)[:-1], target, size, True) > 1e-2
    assert _apart(_traced(got, 0.0, 2 * np.pi)[:-1], target, size, True) < 1e-3
    assert meter.used == fit.evaluations <= 3000 and seen and seen[-1] == got
    assert motion_events(got).turns_fully


def test_an_open_fit_finds_a_span_that_traces_the_stroke():
    """A stroke over 100° of the crank; the start's joints are moved by 1 % of its size
    and its span is 80°: the fitted design traces the stroke over its fitted span to
    1e-4 of its size both ways (from 0.24).  The span is not the stroke's own 100° to
    the digit: other four-bars trace the same stroke (the target is a curve, not a
    timing)."""
    m = load_named("four_bar")
    target = _traced(m, 0.0, np.radians(100.0), 200)
    size = np.ptp(target, axis=0).max()
    rng = np.random.default_rng(5)
    start = _moved(m, 0.01 * m.size * rng.uniform(-1, 1, (len(m.joints) + len(m.points), 2)))
    start, _ = on_interval(start, [0.0, np.radians(80.0)])      # (written over 80°, as a design is)
    assert start.drivers[0].range == pytest.approx((0.0, np.radians(80.0)))
    assert _apart(_traced(start, 0.0, np.radians(80.0)), target, size, False) > 0.2
    fit = fit_curve(start, target, False, "P", Meter(4000), span=np.radians(80.0))
    got, span = fit.at(1.0)
    assert np.radians(90.0) < span < np.radians(110.0) and got.drivers[0].range == (0.0, span)
    assert _apart(_traced(got, 0.0, span), target, size, False) < 1e-4
    assert solve(got, np.linspace(0.0, span, 50)).ok.all()        # (its range is the new span)


def test_the_fit_ends_at_the_last_round_the_checks_take():
    """``accept`` is asked from the last round back: refusing every round leaves the
    start (its residual and design); refusing only the last round's design gives an
    earlier round's, whose residual lies between the start's and the last's."""
    m = load_named("four_bar")
    target = _traced(m, 0.0, 2 * np.pi, 300)[:-1] * 1.05
    none = fit_curve(m, target, True, "P", Meter(2000), accept=lambda d, span, *_: False, chunk=10)
    assert none.after == none.before and np.array_equal(none.end, none.start)
    asked = []
    every = fit_curve(m, target, True, "P", Meter(2000), accept=lambda d, span, *_: asked.append(d) or True, chunk=10)
    assert len(asked) == 1                       # (the last round passes: one check)
    refused = []
    last = fit_curve(m, target, True, "P", Meter(2000), accept=lambda d, span, *_: refused.append(d) or len(refused) > 1,
                     chunk=10)
    assert len(refused) == 2 and every.after < last.after < last.before
    assert not np.array_equal(last.end, every.end)


@pytest.fixture(scope="module")
def tiny_atlas(tmp_path_factory):
    from multiloop.catalogue.synthesis import nauty_available
    from tests.common import four_bar_curve_atlas
    if not nauty_available():
        pytest.skip("nauty's geng/genbg not installed")
    return four_bar_curve_atlas(tmp_path_factory.mktemp("curve-atlas") / "atlas.sqlite")


def _two_way_mean(m, target, closed=True):
    """The mean distance target → traced curve plus traced curve → target (one turn)."""
    from multiloop.catalogue.topology_synthesis import _traced as traced
    c = traced(m, "P", np.array([0.0, 2 * np.pi]), closed)
    close = (lambda p: np.vstack([p, p[:1]])) if closed else (lambda p: p)
    return polyline_distance(target, close(c)).mean() + polyline_distance(c, close(target)).mean()


def test_topology_synthesis_returns_the_curve_fitted_design_checked(tiny_atlas):
    """An ellipse of 200 points (a curve: more points than the finalists' polish takes)
    that no four-bar traces: the point-matched design is refined by the curve distance
    in the kept share of the budget.  The returned design says so (``fit``), lies nearer
    the target both ways in the target's own frame, its errors are the target points'
    distances to its traced curve, its driver turns fully, and ``check`` finds its
    motion on one branch."""
    import multiloop.catalogue.topology_synthesis as ts
    t = np.linspace(0.0, 2 * np.pi, 200, endpoint=False)
    ellipse = np.column_stack([0.06 + 0.05 * np.cos(t), 0.09 + 0.02 * np.sin(t)])
    seen = []
    stage = ts._curve_stage

    def spy(designs, *a, **k):
        seen.extend(designs)
        return stage(designs, *a, **k)
    ts._curve_stage = spy
    try:
        r = ts.synthesise(ellipse, links=(4,), atlas=tiny_atlas, top=1, evaluations=6000)
    finally:
        ts._curve_stage = stage
    d, before = r.designs[0], seen[0]
    assert before.fit == "points" and d.fit == "curve"
    assert _two_way_mean(d.mechanism, ellipse) < _two_way_mean(before.mechanism, ellipse)
    assert d.as_dict()["fit"] == "curve" and "fit curve" in r.to_text()
    assert d.error_max == pytest.approx(d.deviation_max) and d.error_rms <= d.error_max
    assert r.evaluations <= 6000 and d.evaluations > before.evaluations
    assert motion_events(d.mechanism).turns_fully
    assert check(d.mechanism).drivers[0].full_rotation


def test_precision_points_are_met_as_given(tiny_atlas):
    """An ellipse of 60 points (no more than the finalists' polish takes: precision
    points, whose polyline is not the curve they lie on): no curve refinement, and the
    whole budget goes to the point matching."""
    import multiloop.catalogue.topology_synthesis as ts
    t = np.linspace(0.0, 2 * np.pi, 60, endpoint=False)
    ellipse = np.column_stack([0.06 + 0.05 * np.cos(t), 0.09 + 0.02 * np.sin(t)])
    called = []
    stage = ts._curve_stage
    ts._curve_stage = lambda *a, **k: called.append(1) or stage(*a, **k)
    try:
        r = ts.synthesise(ellipse, links=(4,), atlas=tiny_atlas, top=1, evaluations=6000, tol=0.0)
    finally:
        ts._curve_stage = stage
    assert not called and r.designs[0].fit == "points" and 6000 - 100 <= r.evaluations <= 6000
