"""Synthesis without a start (issue 37): open targets (a stroke over part of the
driver's motion) are matched against sub-arcs of the stored curves and written with the
driver's range over that part only; the run keeps screening further retrieved starts
while its best error is above ``tol`` and its budget lasts, and says what stopped it.

Every budget here is a number of evaluations: no outcome depends on wall time."""
from __future__ import annotations

import json

import numpy as np
import pytest

from multiloop.catalogue.curves import (CURVE_POINTS, WINDOW_FRACTIONS, is_closed, normalise, normalise_open,
                                        polyline_distance, similarity_to, window_distances)
from multiloop.catalogue.dimensional.budget import STOPS
from multiloop.cli import main
from multiloop.kin.solve import solve

#: the partial motion of the targets: 120° of crank, from 40° past the reference
ARC_DEG = (40.0, 160.0)


@pytest.fixture(scope="module")
def tiny_atlas(tmp_path_factory):
    from multiloop.catalogue.synthesis import nauty_available
    from tests.common import four_bar_curve_atlas
    if not nauty_available():
        pytest.skip("nauty's geng/genbg not installed")
    return four_bar_curve_atlas(tmp_path_factory.mktemp("open-atlas") / "atlas.sqlite")


def _four_bar(atlas_file, k: int = 0):
    """The atlas's k-th four-bar curve's realisation, turned, scaled by 2 and moved."""
    from multiloop.catalogue.atlas import Atlas
    from multiloop.catalogue.curve_atlas import CurveIndex, stored_curve
    from multiloop.catalogue.topology_synthesis import candidate_mechanism
    with Atlas(atlas_file) as a:
        c = stored_curve(a, int(CurveIndex(a, links=(4,)).ids[k]))
    return candidate_mechanism(c, lambda w: 2.0 * np.asarray(w) @ np.array([[0, 1], [-1, 0]]) + [3, 1], "P")


def _stroke(m, n: int = 60) -> np.ndarray:
    """The coupler point over 120° of crank (:data:`ARC_DEG`)."""
    return solve(m, np.radians(np.linspace(*ARC_DEG, n))).point_positions[:, 0]


def _curve(t: np.ndarray) -> np.ndarray:
    z = np.exp(1j * t) + 0.4 * np.exp(-2j * t) + 0.15 * np.exp(3j * t + 0.3)
    return np.column_stack([z.real, z.imag])


# ---------------------------------------------------------------------------------
# 1. retrieval: an open target against windows of the stored closed curves
@pytest.mark.parametrize("reverse", [False, True])
def test_window_distances_find_a_moved_sub_arc(reverse):
    """A sub-arc of a stored curve, moved, turned, scaled (and reversed), is found at
    (nearly) zero distance, and the similarity carries the stored curve onto it."""
    full = _curve(np.linspace(0.0, 2 * np.pi, 4000, endpoint=False))
    z, centre, radius = normalise(full, CURVE_POINTS, True)
    circle = np.exp(2j * np.pi * np.arange(CURVE_POINTS) / CURVE_POINTS)
    # the window of the stored samples 10 … 10 + 0.375 · 64, by arc length on the dense curve
    seg = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(np.vstack([full, full[:1]]), axis=0), axis=1))]
    s0, s1 = seg[-1] * 10 / CURVE_POINTS, seg[-1] * (10 + WINDOW_FRACTIONS[2] * CURVE_POINTS) / CURVE_POINTS
    arc = full[(seg[:-1] >= s0) & (seg[:-1] <= s1)]
    arc = arc[::-1] if reverse else arc
    target = 3.0 * arc @ np.array([[0.6, 0.8], [-0.8, 0.6]]) + [5.0, -2.0]
    assert not is_closed(target)
    a, ct, rt = normalise_open(target)
    found = window_distances(a, np.vstack([z, circle]))
    assert found["distance"][0] < 0.02 < found["distance"][1]
    assert found["fraction"][0] == WINDOW_FRACTIONS[2] and bool(found["reversed"][0]) == reverse
    tf = similarity_to(ct, rt, centre + radius * found["centre"][0], radius * found["radius"][0],
                       found["rotation"][0])
    size = np.ptp(target, axis=0).max()
    assert polyline_distance(target, tf(full)).max() < 0.01 * size


def test_closed_is_detected_or_given(tiny_atlas):
    """The rule: open when the end-to-start gap exceeds 1.1 times the longest step;
    ``closed=`` overrides it."""
    from multiloop.catalogue.topology_synthesis import synthesise
    t = np.linspace(0.0, 2 * np.pi, 60, endpoint=False)
    loop = _curve(t)
    assert is_closed(loop) and not is_closed(loop[:45])
    kw = dict(links=(4,), atlas=tiny_atlas, evaluations=300, top=1)
    assert synthesise(loop, **kw).closed and not synthesise(loop[:45], **kw).closed
    assert not synthesise(loop, closed=False, **kw).closed
    assert synthesise(loop[:45], closed=True, **kw).closed


# ---------------------------------------------------------------------------------
# 2. a partial motion recovered, and written over its part of the motion only
def test_partial_motion_is_recovered_over_its_interval(tiny_atlas, tmp_path, capsys):
    from multiloop.inputs import load_mechanism
    from multiloop.kin.check import check
    target = _stroke(_four_bar(tiny_atlas))
    csv = tmp_path / "stroke.csv"
    np.savetxt(csv, target, delimiter=",")
    out = tmp_path / "o.toml"
    assert main(["synthesise", "--path", str(csv), "--out", str(out), "--db", str(tiny_atlas), "--links", "4",
                 "--open", "--evaluations", "20000", "--top", "1", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    best = doc[0]
    assert best["error_max"] < 1e-3 and best["deviation_max"] < 1e-3 and best["stopped"] in STOPS
    design = load_mechanism(best["file"])
    lo, hi = design.drivers[0].range
    assert lo == 0.0 or hi == 0.0              # the reference is the stroke's first point
    assert best["input_range"] == pytest.approx(np.degrees([lo, hi]).tolist())
    # over its range the design traces the target's part, end to end, and no more
    traced = solve(design, np.linspace(lo, hi, 400)).point_positions[:, 0]
    size = np.ptp(target, axis=0).max()
    assert polyline_distance(traced, target).max() < 1e-3 * size
    assert polyline_distance(target, traced).max() < 1e-3 * size
    ends = sorted(np.linalg.norm(traced[[0, -1]] - target[0], axis=1))
    assert ends[0] < 1e-3 * size
    # the check moves it within its range (its usable range is that range)
    dc = check(design, min_transmission=0.0).drivers[0]
    assert dc.driver_range == pytest.approx((lo, hi)) and dc.usable == pytest.approx((lo, hi), abs=1e-9)


def test_a_rockers_stroke_is_recovered(tiny_atlas):
    """The same four-bar driven at its rocker (no full rotation), traced over the middle
    70 % of its certified range: a design (crank-driven) traces that stroke over its
    written range, and the range lies in its certified motion."""
    from multiloop.catalogue.topology_synthesis import synthesise
    from multiloop.kin.check import check
    from multiloop.topo.model import MechanismBuilder
    m = _four_bar(tiny_atlas)
    pivot = next(j for j in m.joints if m.frame in j.links and j.name != m.drivers[0].joint)
    b = MechanismBuilder.from_mechanism(m)
    b.drivers = [(pivot.name, (m.frame, next(k for k in pivot.links if k != m.frame)), None, None, None)]
    rocker = b.build()
    dc = check(rocker, min_transmission=0.0).drivers[0]
    assert not dc.full_rotation
    lo, hi = dc.usable
    target = solve(rocker, np.linspace(lo + 0.15 * (hi - lo), hi - 0.15 * (hi - lo), 50)).point_positions[:, 0]
    r = synthesise(target, links=(4,), atlas=tiny_atlas, evaluations=20000, top=1)
    d = r.designs[0]
    assert not r.closed and d.error_max < 1e-3 and d.deviation_max < 1e-3 and r.evaluations <= 20000
    a, b_ = d.interval
    traced = solve(d.mechanism, np.linspace(a, b_, 300)).point_positions[:, 0]
    size = np.ptp(target, axis=0).max()
    assert polyline_distance(traced, target).max() < 1e-3 * size
    dc = check(d.mechanism, min_transmission=0.0).drivers[0]
    assert dc.usable == pytest.approx((a, b_), abs=1e-9)


def test_open_and_closed_need_no_start(tmp_path, capsys):
    csv = tmp_path / "t.csv"
    np.savetxt(csv, _curve(np.linspace(0, 3, 30)), delimiter=",")
    assert main(["synthesise", "four_bar", "--path", str(csv), "--out", str(tmp_path / "o.toml"), "--open"]) == 2
    assert "--open/--closed" in capsys.readouterr().err and not (tmp_path / "o.toml").exists()


# ---------------------------------------------------------------------------------
# 3. the budget is used: more starts screened while the error is above tol
def test_the_budget_screens_further_starts(tiny_atlas, monkeypatch):
    """The stroke's own curve ranked third (the retrieval's first is moved there: the
    fine windows now rank it first): the first round (the two nearest curves of the
    four-bar) does not reach tol, so the run screens the next round."""
    import multiloop.catalogue.topology_synthesis as ts
    from multiloop.catalogue.topology_synthesis import synthesise
    ranked = ts._ranked
    monkeypatch.setattr(ts, "_ranked", lambda *a, **k: (lambda r: [*r[1:3], r[0], *r[3:]])(ranked(*a, **k)))
    target = _stroke(_four_bar(tiny_atlas))
    r = synthesise(target, links=(4,), atlas=tiny_atlas, evaluations=20000, top=1)
    assert r.polished > 2 and r.stopped == "tolerance" and r.designs[0].error_rms <= 1e-4
    assert r.evaluations <= 20000


def test_what_stopped_the_run(tiny_atlas):
    """An ellipse no four-bar traces exactly: with tol 0 the run spends its evaluations
    (``"evaluations"``); with one retrieved curve, an arc of it is screened and refined
    until a refine improves it by less than 1 % and says so (``"exhausted"``) with
    evaluations left."""
    from multiloop.catalogue.topology_synthesis import synthesise
    t = np.linspace(0.0, 2 * np.pi, 25)
    ellipse = np.column_stack([0.06 + 0.05 * np.cos(t), 0.09 + 0.02 * np.sin(t)])
    kw = dict(links=(4,), atlas=tiny_atlas, top=1, tol=0.0)
    spent = synthesise(ellipse, evaluations=3000, **kw)
    assert spent.stopped == "evaluations" and 3000 - 100 <= spent.evaluations <= 3000
    few = synthesise(ellipse[:15], evaluations=200_000, candidates=1, per_topology=1, **kw)
    assert few.stopped == "exhausted" and few.evaluations < 200_000
    assert "stopped: exhausted" in few.to_text()


# ---------------------------------------------------------------------------------
# 4. the written interval
def test_on_interval_moves_the_reference_to_the_first_input():
    """An all-R design is re-referenced at the first input (same motion, shifted input);
    a design with a P joint keeps its reference and its range holds it."""
    from multiloop.catalogue.named import load_named
    from multiloop.catalogue.open_targets import on_interval
    m = load_named("four_bar")
    x = np.radians([30.0, 50.0, 90.0])
    moved, rng = on_interval(m, x)
    assert rng == pytest.approx((0.0, np.radians(60.0))) and moved.drivers[0].range == pytest.approx(rng)
    a = solve(m, x).point_positions
    b = solve(moved, x - x[0]).point_positions
    np.testing.assert_allclose(a, b, atol=1e-9)
    slider = load_named("crank_slider")
    kept, rng = on_interval(slider, [0.3, 0.5, 1.0])
    assert rng == (0.0, 1.0) and [j.at for j in kept.joints] == [j.at for j in slider.joints]


def test_an_open_run_is_the_seeds_alone(tiny_atlas, monkeypatch):
    """Under an evaluation budget the open route gives the same designs when the clock
    jumps an hour at every reading (no decision reads it)."""
    import time
    from multiloop.catalogue.topology_synthesis import synthesise
    target = _stroke(_four_bar(tiny_atlas))
    kw = dict(links=(4,), atlas=tiny_atlas, evaluations=4000, top=2, seed=2)
    a = synthesise(target, **kw)
    t = [time.perf_counter()]

    def jumping():
        t[0] += 3600.0
        return t[0]
    monkeypatch.setattr(time, "perf_counter", jumping)
    b = synthesise(target, **kw)
    assert a.designs and [d.mechanism for d in a.designs] == [d.mechanism for d in b.designs]
    assert (a.evaluations, a.stopped, a.polished) == (b.evaluations, b.stopped, b.polished)
