"""Branch safety of the continuation (kin.continuation, kin.solve): never ``ok`` on the
wrong branch, whatever the spacing of the inputs.

Oracles are closed forms written here independently of the kernels: the four-bar
by the law of cosines (Norton, Design of Machinery, 2012, ch. 4), the crank-slider
with crank = rod (slider at 2 r cos θ on the reference mode), the parallelogram
(the coupler translates).  The mechanisms are in tests/data/branches.
"""
from __future__ import annotations

import json
import math
import warnings
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace
from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from multiloop.kin.result import Status, json_ready
from multiloop.catalogue.named import load_named
from multiloop.kin import solve as solve_module
from multiloop.kin.solve import plan_of, solve
from multiloop.topo.errors import InputError
from multiloop.topo.io import load
from multiloop.topo.model import MechanismBuilder
from test_assur import stephenson3_triad

DATA = Path(__file__).parent / "data" / "branches"


def _load(name):
    return load(DATA / f"{name}.toml")


def _solve(m, deg, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return solve(m, np.radians(np.asarray(deg, float)), **kw)


def _four_bar_B(m, deg):
    """B by the law of cosines on the reference's side of line A-D (crank at 90° + input)."""
    j = dict(zip(m.joint_names, m.joints))
    A0, B0, D = (np.array(j[n].at) for n in "ABD")
    b, c = np.hypot(*(B0 - A0)), np.hypot(*(B0 - D))
    u, v = D - A0, B0 - A0
    side = np.sign(u[0] * v[1] - u[1] * v[0])
    th = math.atan2(A0[1], A0[0]) + np.radians(deg)
    a = np.hypot(*A0)
    A = np.stack([a * np.cos(th), a * np.sin(th)], axis=-1)
    AD = D - A
    d = np.hypot(AD[:, 0], AD[:, 1])
    t = (b * b + d * d - c * c) / (2 * d * d)
    k = side * np.sqrt(np.maximum(b * b / (d * d) - t * t, 0.0))
    return A + t[:, None] * AD + k[:, None] * np.stack([-AD[:, 1], AD[:, 0]], axis=-1)


def test_uneven_steps_near_a_reach_limit_stay_on_the_reference_branch():
    m = _load("nongrashof")                      # limit at 47.87° from the reference
    for deg in (np.linspace(47.5, 47.6, 11), [0, 20, 40, 47.0, 47.5], [47.5, 47.51, 47.8, 47.87]):
        st = _solve(m, deg)
        assert st.success, st.message
        assert np.allclose(st.positions[:, 2], _four_bar_B(m, np.asarray(deg)), atol=1e-9)
        assert not st.notes


def test_past_the_limit_is_unreachable_and_says_where():
    m = _load("nongrashof")
    st = _solve(m, [40.0, 50.0, 60.0, -10.0, 320.0])
    assert list(st.codes) == [0, Status.LIMIT, Status.LIMIT, 0, 0]
    assert "group 1" in st.status[1] and "unreachable: limit at" in st.status[1] and "47.87" in st.status[1]
    assert np.isnan(st.positions[1:3, 1:3]).all()        # the moving joints A, B
    # 320° is −40°: reached by turning the other way (R inputs modulo 360°)
    assert np.allclose(st.positions[4, 2], _four_bar_B(m, np.array([-40.0]))[0], atol=1e-9)


def test_other_circuit_is_not_ok_unless_assemble_is_asked():
    m = _load("double_rocker")
    deg = [0.0, 30.0, 90.0, 240.0, 330.0]
    st = _solve(m, deg)
    assert list(st.codes) == [0, 0, Status.LIMIT, Status.OTHER_CIRCUIT, 0]
    assert st.status[3].startswith("other circuit")
    asm = _solve(m, deg, assemble=True)
    assert asm.ok[3] and asm.codes[2] == Status.OUT_OF_REACH


def test_parallelogram_keeps_the_mode_of_the_reference():
    m = _load("parallelogram")
    ic = m.link_names.index("coupler")
    st = _solve(m, np.linspace(119.5, 119.6, 11))
    assert st.success and np.allclose(st.angles[:, ic], 0.0, atol=1e-9)
    # the flat positions (120° and 300°) are both singular, by the same rule
    full = _solve(m, np.arange(0.0, 360.0, 10.0))
    bad = np.flatnonzero(~full.ok)
    assert list(full.inputs[bad, 0].round(9)) == list(np.radians([120.0, 300.0]).round(9))
    assert all(full.codes[bad] == Status.SINGULAR)
    assert np.allclose(full.angles[full.ok, ic], 0.0, atol=1e-9)
    assert len(full.notes) == 2 and "between row 11 and row 13" not in full.notes[0]
    assert "between row 11 and row 12" in full.notes[0] or "row 12" in full.notes[0]


def test_crossing_notes_give_the_input_of_each_turn():
    """A crossing met on the second turn is named by its input there (480°, not the
    first turn's 120°): the chart's crossing recurs once a period."""
    st = _solve(_load("parallelogram"), np.arange(0.0, 721.0, 90.0))
    met = sorted(float(n.split("meet at input ")[1].split("°")[0]) for n in st.notes if "meet at input" in n)
    assert met == [120.0, 300.0, 480.0, 660.0]


def test_crank_equal_to_rod_continues_smoothly_through_the_bifurcation():
    m = _load("crank_equals_rod")                # bifurcation at input 45°
    deg = np.array([44.5, 44.55, 44.6, 44.99, 45.01, 46.0, 90.0])
    st = _solve(m, deg)
    th = np.radians(45.0 + deg)
    assert st.success, st.message
    assert np.allclose(st.positions[:, 2, 0], 100.0 * np.cos(th), atol=1e-7)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-0.9, 1.0), min_size=1, max_size=12))
def test_hypothesis_uneven_steps_never_ok_off_the_reference_branch(u):
    # inputs clustered near both reach limits (+47.87°, −227.87°) with uneven spacing
    m = _load("nongrashof")
    deg = np.array([47.873 * x if x > 0 else 227.87 * x for x in u])
    st = _solve(m, deg)
    ok = st.ok
    assert np.allclose(st.positions[ok, 2], _four_bar_B(m, deg[ok]), atol=1e-7)
    inside = (deg > -227.86) & (deg < 47.87)
    assert ok[inside].all()


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(-360.0, 360.0), min_size=2, max_size=8))
def test_hypothesis_parallelogram_any_spacing_keeps_translating(deg):
    m = _load("parallelogram")
    st = _solve(m, deg)
    assert np.allclose(st.angles[st.ok, m.link_names.index("coupler")], 0.0, atol=1e-8)
    flat = np.isclose(np.mod(deg, 180.0), 120.0 % 180.0, atol=1e-7)
    assert st.ok[~flat].all()


@settings(max_examples=10, deadline=None)
@given(st.lists(st.floats(0.0, 360.0), min_size=2, max_size=5))
def test_hypothesis_triad_large_steps_match_a_fine_continuation(deg):
    m = stephenson3_triad()
    coarse = _solve(m, deg)
    path = [0.0]
    for x in deg:                       # the same path, walked in 0.5° steps
        n = max(int(np.ceil(abs(x - path[-1]) / 0.5)), 1)
        path += list(np.linspace(path[-1], x, n + 1)[1:])
    fine = _solve(m, path)
    rows = np.cumsum([0] + [max(int(np.ceil(abs(b - a) / 0.5)), 1)
                            for a, b in zip([0.0] + deg[:-1], deg)])[1:]
    both = coarse.ok & fine.ok[rows]
    assert np.allclose(coarse.positions[both], fine.positions[rows][both], atol=1e-9)
    assert np.array_equal(coarse.ok, fine.ok[rows])


def _walked(m, deg, **kw):
    """``solve`` by the certified walk along the path (the one-pass route refused)."""
    with mock.patch.object(solve_module, "_along_chart", return_value=None):
        return _solve(m, deg, **kw)


@settings(max_examples=12, deadline=None)
@given(st.sampled_from(["stephenson_3", "stephenson_3_triad"]),
       st.lists(st.floats(-720.0, 720.0), min_size=1, max_size=8))
def test_hypothesis_a_tracked_motion_without_crossings_is_solved_in_one_pass_as_the_walk_solves_it(name, deg):
    """A class III or IV mechanism whose chart has no crossing: the path through the
    inputs solved in one pass on the reference branches gives the walk's statuses,
    positions and velocities (to rounding)."""
    m = load_named(name)
    one, walked = _solve(m, deg, derivatives=True), _walked(m, deg, derivatives=True)
    assert list(one.status) == list(walked.status)
    size = plan_of(m).size
    for a, b in ((one.positions, walked.positions), (one.velocities, walked.velocities)):
        assert np.allclose(a, b, rtol=0, atol=1e-12 * size, equal_nan=True)


@settings(max_examples=15, deadline=None)
@given(st.sampled_from(["stephenson_3", "stephenson_3_triad", "four_bar", "excavator", "watt_2"]),
       st.lists(st.floats(-400.0, 400.0), min_size=1, max_size=12), st.data())
def test_hypothesis_rows_of_a_batch_are_its_own_rows_with_derivatives_at_them_alone(name, deg, data):
    """``solve(..., rows=)`` solves the whole batch as one path and gives the rows asked
    for, in their order: poses and statuses identical to the whole batch's rows (the
    other inputs still guide a tracked group), points and derivatives computed at these
    rows alone and equal to rounding (each depends on its own pose alone)."""
    m = load_named(name)
    X = np.radians(np.asarray(deg, float))
    if len(m.drivers) > 1:
        X = np.column_stack([X] + [np.zeros_like(X)] * (len(m.drivers) - 1))
    rows = data.draw(st.lists(st.integers(0, len(deg) - 1), min_size=1, max_size=2 * len(deg)))
    whole, some = _solve(m, np.degrees(X), derivatives=True), _solve(m, np.degrees(X), derivatives=True, rows=rows)
    assert list(some.status) == [whole.status[r] for r in rows]
    assert np.array_equal(whole.poses[rows], some.poses, equal_nan=True)
    size = plan_of(m).size
    for name_ in ("positions", "velocities", "accelerations", "point_positions"):
        a, b = getattr(whole, name_), getattr(some, name_)
        assert (a is None) == (b is None)
        if a is not None:
            assert np.allclose(a[rows], b, rtol=1e-12, atol=1e-12 * size, equal_nan=True), name_
    for bad in ([len(deg)], [], [[0]], [0.5]):
        with pytest.raises(InputError, match="rows"):
            _solve(m, np.degrees(X), rows=bad)


def test_the_one_pass_is_taken_inside_the_chart_and_refused_at_a_crossing():
    """The one pass solves a triad's turn (no crossing on its chart), and is refused
    where the chart has a crossing (the walk then marks the rows beside it)."""
    original, calls = solve_module._along_chart, []

    def spy(*args):
        calls.append(original(*args))
        return calls[-1]
    m = load_named("stephenson_3_triad")
    with mock.patch.object(solve_module, "_along_chart", spy):
        _solve(m, [10.0, 200.0])
    assert calls and calls[-1] is not None
    sp = plan_of(m)
    crossed = replace(solve_module._chart(sp, True, np.zeros(1)), crossings=((1.0, 1),))
    assert original(sp, crossed, np.array([[0.5], [2.0]]), list(range(len(sp.steps))), True) is None


@settings(max_examples=20, deadline=None)
@given(st.sampled_from(["excavator", "excavator_bucket", "knuckle_boom_crane", "wheel_loader_zbar"]),
       st.integers(0, 2), st.lists(st.floats(-1.5, 1.5), min_size=1, max_size=10))
def test_hypothesis_one_driver_moved_of_several_is_solved_on_its_chart_as_the_walk_solves_it(name, k, frac):
    """A mechanism with several drivers, one moved and the others held at the reference
    (what the check asks for): each input solved on the chart of that driver's motion
    is what the certified walk from the reference to that input alone gives: the same
    assembled rows, positions and velocities (to rounding), inputs past a limit included
    (out of ±1.5 × the size).  (Along one path through all of them, a row after one past
    a limit is lost, as it is for a mechanism with one driver.)"""
    m = load_named(name)
    k = k % len(m.drivers)
    X = np.zeros((len(frac), len(m.drivers)))
    X[:, k] = np.asarray(frac) * plan_of(m).size
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        charted = solve(m, X, derivatives=True)
        with mock.patch.object(solve_module, "_moving_driver", return_value=None):
            alone = [solve(m, X[i:i + 1], derivatives=True) for i in range(len(X))]
    walked = SimpleNamespace(**{f: np.concatenate([getattr(a, f) for a in alone])
                                for f in ("ok", "positions", "velocities")})
    assert np.array_equal(charted.ok, walked.ok)
    ok = charted.ok
    size = plan_of(m).size
    for a, b in ((charted.positions, walked.positions), (charted.velocities, walked.velocities)):
        assert np.allclose(a[ok], b[ok], rtol=0, atol=1e-12 * size)
    for why in charted.status[~ok]:                 # the limit named with every driver's input
        assert all(d.joint in why for d in m.drivers) or "out of range" in why


def _five_bar(B):
    """Two cranks (O1, O2) and two rods meeting at B: a mechanism with two R drivers."""
    b = MechanismBuilder(name="five-bar")
    b.add_link("ground", frame=True)
    for n, lk, at in [("O1", ("ground", "c1"), (0.0, 0.0)), ("A", ("c1", "r1"), (0.0, 1.0)),
                      ("B", ("r1", "r2"), B), ("D", ("r2", "c2"), (3.0, 1.2)), ("O2", ("c2", "ground"), (3.0, 0.0))]:
        b.add_joint(n, "R", lk, at=at)
    b.add_driver("O1")
    b.add_driver("O2")
    return b.build()


@settings(max_examples=15, deadline=None)
@given(st.floats(1.0, 2.0), st.floats(1.3, 2.8), st.integers(0, 1),
       st.lists(st.floats(-9.0, 9.0), min_size=1, max_size=6))
def test_hypothesis_a_held_crank_of_several_reaches_what_the_walk_reaches_and_other_turns(bx, by, k, x):
    """A five-bar, one crank turned and the other held: every input that the certified
    walk from the reference reaches is reached on the crank's chart with the same pose; an
    input the chart reaches beyond is the same angle a whole number of turns away that the
    walk reaches (a limited R driver reaches an input modulo 360°, as with one driver)."""
    m = _five_bar((bx, by))
    X = np.zeros((len(x), 2))
    X[:, k] = x
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        charted = solve(m, X)
        with mock.patch.object(solve_module, "_moving_driver", return_value=None):
            walked = [solve(m, X[i:i + 1]) for i in range(len(X))]
            for i, w in enumerate(walked):
                if w.ok[0]:
                    assert charted.ok[i]
                    assert np.allclose(charted.positions[i], w.positions[0], rtol=0, atol=1e-12 * 4)
                elif charted.ok[i]:
                    turns = [X[i:i + 1] - 2 * np.pi * t * np.eye(2)[k] for t in range(-3, 4) if t]
                    alone = [solve(m, Y) for Y in turns]
                    assert any(a.ok[0] and np.allclose(a.positions[0], charted.positions[i], rtol=0, atol=1e-9)
                               for a in alone)


def test_runaway_inputs_are_reduced_or_refused():
    m = _load("nongrashof")
    st = _solve(m, [1e9 * 360.0 + 10.0, 1e300])
    assert st.ok[0] and np.allclose(st.positions[0, 2], _four_bar_B(m, np.array([10.0]))[0], atol=1e-6)
    assert st.codes[1] in (0, Status.LIMIT)
    # a triad that turns fully: reduced modulo its period like the four-bar (it used to
    # refuse, its path from the reference being longer than MAX_PATH steps)
    far = _solve(stephenson3_triad(), [1e9])
    near = _solve(stephenson3_triad(), [np.degrees(np.mod(np.radians(1e9), 4 * np.pi))])
    assert far.ok[0] and np.allclose(far.positions, near.positions, atol=1e-9)


def test_frozen_result_arrays_are_read_only():
    st = _solve(_load("nongrashof"), [0.0, 10.0])
    with pytest.raises(ValueError):
        st.positions[0, 0, 0] = 1.0


def test_tracked_route_past_a_limit_reports_it_without_crashing():
    # excavator (three P drivers, Newton groups + a dyad): the default stroke passes the
    # bucket dyad's limit; every later row is unreachable (was an IndexError)
    from multiloop.catalogue.named import load_named
    m = load_named("excavator")
    x = np.linspace(0.0, 0.7, 8)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = solve(m, np.stack([x, x, x], axis=1))
    bad = np.flatnonzero(~st.ok)
    assert st.ok[0] and bad.size and np.all(st.codes[bad[0]:] == Status.LIMIT)
    assert "unreachable: limit at" in st.status[bad[0]]


def test_json_ready_makes_strict_json():
    """Every result's as_dict ends with json_ready: NaN/inf -> null, NumPy -> Python."""
    doc = json_ready({"a": np.array([[1.0, np.nan], [np.inf, 2.0]]), "b": (np.float64(-np.inf), np.int64(3)),
                      "c": [np.bool_(True), "x", None], "d": np.float32(0.5)})
    assert doc == {"a": [[1.0, None], [None, 2.0]], "b": [None, 3], "c": [True, "x", None], "d": 0.5}
    assert type(doc["b"][1]) is int and type(doc["c"][0]) is bool
    json.dumps(doc, allow_nan=False)
