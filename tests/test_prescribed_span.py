"""Prescribed timing solves the targets' driver values and only the grid samples between
the reference and them (objective.Problem._reach_span): the objective equals the whole
grid's bit for bit, on R and P drivers, with targets inside, beyond and on both sides of
the reachable motion; the whole grid is kept where a constraint reads the whole motion."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from multiloop.catalogue.dimensional.evaluator import Evaluator, design_space
from multiloop.catalogue.dimensional.objective import Constraints, Problem
from multiloop.catalogue.dimensional.targets import PathTarget
from multiloop.catalogue.named import load_named

from test_design_batch import _slider_driven as _slider_driven_with


def _slider_driven():
    return _slider_driven_with(point=True)


def _problem(name, timing, cons=Constraints()):
    m = _slider_driven() if name == "slider driven" else load_named(name)
    pt = m.points[0].name
    ev = Evaluator(m, design_space(m, [pt]))
    T = np.random.default_rng(0).normal(0.0, m.size, (len(timing), 2))
    return m, Problem(ev, PathTarget(T, pt, timing=np.asarray(timing, float)), cons)


def _whole_grid(pr, Z, monkeypatch):
    with monkeypatch.context() as mp:
        mp.setattr(pr, "_reach_span", lambda tim: None)
        return pr.batch(Z)


@settings(max_examples=30, deadline=None)
@given(name=st.sampled_from(["four_bar", "watt_1", "crank_slider", "slider driven"]),
       seed=st.integers(0, 2**31 - 1), reach=st.sampled_from([0.1, 0.5, 1.0, 2.5]),
       spread=st.sampled_from([0.01, 0.05, 0.2]), side=st.sampled_from([-1.0, 0.0, 1.0]))
def test_the_span_gives_the_whole_grids_objective_to_the_bit(name, seed, reach, spread, side):
    rng = np.random.default_rng(seed)
    m = _slider_driven() if name == "slider driven" else load_named(name)
    span = np.pi if m.is_rotary(0) else m.size
    timing = np.sort(rng.uniform(-reach, reach, 5)) * span
    if side:                                     # (every target on one side of the reference)
        timing = side * np.sort(np.abs(timing))
    _, pr = _problem(name, timing)
    Z = np.clip(pr.x0[None] + spread * m.size * rng.standard_normal((60, len(pr.x0))), pr.lower, pr.upper)
    got = pr.batch(Z)
    mp = pytest.MonkeyPatch()
    try:
        assert np.array_equal(got, _whole_grid(pr, Z, mp))
    finally:
        mp.undo()


def test_narrow_timing_solves_a_few_samples_and_constraints_on_the_motion_keep_the_grid():
    m, pr = _problem("four_bar", np.radians([0.0, 20.0, 40.0, 60.0]))
    idx, nf = pr._reach_span(pr.timing_for(pr.x0[None]))
    assert nf == len(idx) == 17 and np.array_equal(idx, np.arange(17))          # 0 .. 60° at 3.75°
    _, pr = _problem("four_bar", np.radians([-30.0, 10.0]))
    idx, nf = pr._reach_span(pr.timing_for(pr.x0[None]))
    assert nf == 4 and np.array_equal(idx[nf:], pr.M - 1 - np.arange(8))           # back to −30°
    for cons in (Constraints(full_rotation=True), Constraints(min_transmission=30.0)):
        _, pr = _problem("four_bar", np.radians([0.0, 20.0]), cons)
        assert pr._reach_span(pr.timing_for(pr.x0[None])) is None
    _, pr = _problem("four_bar", np.radians([-179.0, 179.0]))                     # (a whole turn's span)
    assert pr._reach_span(pr.timing_for(pr.x0[None])) is None
