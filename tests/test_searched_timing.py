"""Free timing with the driver values among the search's variables (``free_timing="searched"``)."""
from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from multiloop.catalogue.dimensional import Evaluator, Problem, design_space, path_target, synthesise
from multiloop.catalogue.dimensional.objective import Constraints
from multiloop.catalogue.dimensional.searched_timing import SearchedTiming
from multiloop.catalogue.named import load_named
from multiloop.cli import main
from multiloop.kin.solve import solve
from multiloop.topo.errors import ParameterError


def _problem(direction="any", n=6, **cons):
    m = load_named("four_bar")
    T = solve(m, np.radians(np.arange(0.0, 60.0 * n, 60.0))).point_positions[:, 0]
    tgt = path_target(m, T, "P")
    sp = design_space(m, ["P"], region=tgt.points)
    return Problem(Evaluator(m, sp), tgt, Constraints(direction=direction, **cons), 96), m, T


PROBLEMS = {d: _problem(d)[0] for d in ("any", "ccw", "cw")}


@settings(max_examples=60, deadline=None)
@given(direction=st.sampled_from(["any", "ccw", "cw"]), data=st.data())
def test_every_point_of_the_box_meets_the_targets_in_order_within_a_turn(direction, data):
    pr = PROBLEMS[direction]
    v = SearchedTiming(pr)
    u = np.array(data.draw(st.lists(st.floats(0.0, 1.0), min_size=len(v.lower), max_size=len(v.lower))))
    Y = v.lower + u * (v.upper - v.lower)
    Z, PHI = v.split(Y[None, :])
    steps = np.diff(PHI[0])
    assert np.array_equal(Z[0], Y[:len(pr.names)])
    assert np.all(steps >= 0) or np.all(steps <= 0)                 # one way
    assert abs(PHI[0, -1] - PHI[0, 0]) <= 2 * np.pi + 1e-12          # within one turn
    if direction != "any":                                           # the sense the direction asks for
        up = (direction == "ccw") == (pr.sense > 0)
        assert np.all(steps >= 0) if up else np.all(steps <= 0)


@settings(max_examples=60, deadline=None)
@given(start=st.floats(-3.0, 3.0), steps=st.lists(st.floats(0.01, 0.6), min_size=5, max_size=5),
       up=st.booleans())
def test_encode_then_split_gives_the_driver_values_back(start, steps, up):
    v = SearchedTiming(PROBLEMS["any"])
    phi = start + (1.0 if up else -1.0) * np.r_[0.0, np.cumsum(steps)]
    Y = np.r_[PROBLEMS["any"].x0, v.encode(phi)]
    assert np.allclose(v.split(Y[None, :])[1][0], phi, atol=1e-5)    # (the shares' floor: 1e-6 of the span)


def test_the_objective_is_the_polishs_residuals_at_its_driver_values():
    pr, v = PROBLEMS["any"], SearchedTiming(PROBLEMS["any"])
    rng = np.random.default_rng(4)
    Y = v.x0 + np.repeat([0.02, 0.3], 30)[:, None] * rng.uniform(-1, 1, (60, len(v.x0))) * (v.upper - v.lower)
    Y = np.clip(Y, v.lower, v.upper)                     # (the wider half: designs that do not assemble too)
    Z, PHI = v.split(Y)
    f = v.batch(Y)
    T = pr.target.points
    for k in range(len(Y)):                              # the other route: kin.solve of each design alone
        st = solve(pr.ev.with_design(Z[k][:pr.nx]), PHI[k], assemble=True)   # (each input on the reference branch)
        r = (st.point_positions[:, st.point_index("P")] - T) / pr.target.size
        want = np.sqrt(np.sum(r * r) / pr.n_targets) if np.all(st.status == "ok") else 1e3
        assert f[k] == pytest.approx(want, rel=1e-12, abs=1e-15)


def test_a_constraint_over_the_whole_motion_reads_the_grid():
    pr = _problem(full_rotation=True)[0]
    v = SearchedTiming(pr)
    Y = np.tile(v.x0, (4, 1))
    Z, PHI = v.split(Y)
    rms = np.sqrt(np.sum(pr.residuals_batch(Z, PHI) ** 2, axis=1) / pr.n_targets)
    assert np.allclose(v.batch(Y), rms + pr.penalty_batch(Z))


def test_searched_timing_recovers_an_exact_target_and_is_reproducible():
    _, m, T = _problem(n=5)
    runs = [synthesise(m, path=T, point="P", evaluations=20000, seed=2, free_timing="searched") for _ in range(2)]
    r = runs[0]
    assert r.error_max < 1e-6
    assert np.array_equal(r.inputs, runs[1].inputs) and r.design == runs[1].design
    assert r.evaluations == runs[1].evaluations <= 20000


def test_free_timing_is_checked():
    _, m, T = _problem()
    with pytest.raises(ParameterError, match="free_timing"):
        synthesise(m, path=T, point="P", evaluations=100, free_timing="grid")
    timed = np.column_stack([T, np.arange(len(T)) * 60.0])
    with pytest.raises(ParameterError, match="prescribed driver values"):
        synthesise(m, path=timed, point="P", evaluations=100, free_timing="searched")


def test_cli_free_timing(tmp_path, capsys):
    _, m, T = _problem(n=5)
    f = tmp_path / "t.csv"
    np.savetxt(f, T, delimiter=",")
    out = tmp_path / "o.toml"
    rc = main(["synthesise", "four_bar", "--path", str(f), "--out", str(out), "--evaluations", "4000",
               "--free-timing", "searched", "--json"])
    doc = json.loads(capsys.readouterr().out)
    assert rc == 0 and out.exists() and doc["free_timing"] == "searched"
    with pytest.raises(SystemExit) as exc:                              # (argparse's choices)
        main(["synthesise", "four_bar", "--path", str(f), "--out", str(tmp_path / "p.toml"), "--free-timing", "grid"])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and "--free-timing" in err and not (tmp_path / "p.toml").exists()


def test_the_default_free_timing_is_searched_with_a_search_and_matched_for_a_polish():
    """Left out, free timing is searched when a global search runs (the same run as asked
    for by name, design and evaluations), matched for ``method="local"`` (no search to
    vary the driver values in: the same run as ``"matched"``) and with a constraint on
    the whole motion, and None with prescribed driver values, where ``"matched"`` is
    accepted and said as None too."""
    _, m, T = _problem(n=5)
    runs = {ft: synthesise(m, path=T, point="P", evaluations=3000, seed=1, free_timing=ft)
            for ft in (None, "searched")}
    assert runs[None].free_timing == "searched"
    assert runs[None].design == runs["searched"].design and runs[None].evaluations == runs["searched"].evaluations
    local = {ft: synthesise(m, path=T, point="P", evaluations=500, method="local", free_timing=ft)
             for ft in (None, "matched")}
    assert local[None].free_timing == "matched" and local[None].design == local["matched"].design
    for kw in (dict(full_rotation=True), dict(min_transmission=20.0)):
        assert synthesise(m, path=T, point="P", evaluations=300, **kw).free_timing == "matched"
        assert synthesise(m, path=T, point="P", evaluations=300, free_timing="searched", **kw).free_timing == "searched"
    timed = np.column_stack([T, np.arange(len(T)) * 60.0])
    for ft in (None, "matched"):
        assert synthesise(m, path=timed, point="P", evaluations=300, free_timing=ft).free_timing is None
