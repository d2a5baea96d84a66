"""Regression tests of the second round of field defects (issue 34): two hangs, a
segfault, and inputs that ended in exit 1.  Every bound is a count (Newton corrections,
calls), never a time."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from multiloop.cli import main
from multiloop.kin.result import Status
from multiloop.kin.solve import solve
from multiloop.topo.io import load, loads

ROOT = Path(__file__).resolve().parents[1]
FOUR_BAR = ROOT / "catalogue/mechanisms/four_bar.toml"


def _four_bar(old: str, new: str) -> str:
    text = FOUR_BAR.read_text()
    assert old in text
    return text.replace(old, new, 1)


class _Spent(Exception):
    """Raised by the counting guard: the work went past its bound."""


@pytest.fixture
def newton_calls(monkeypatch):
    """Count the Newton solves of :mod:`kin.groups.newton` and stop a run that makes more
    than ``limit`` of them (the old code ran them without end)."""
    import multiloop.kin.groups.newton as nw
    real = nw.newton
    seen = {"n": 0, "limit": 8_000}

    def counted(*a, **k):
        seen["n"] += 1
        if seen["n"] > seen["limit"]:
            raise _Spent(f"more than {seen['limit']} Newton solves")
        return real(*a, **k)
    monkeypatch.setattr(nw, "newton", counted)
    return seen


# --- 1. a driver on a floating joint ----------------------------------------------------
FLOATING = _four_bar('joint = "O2"', 'joint = "B"')      # the coupler-rocker pin drives


def _b_limits(m) -> list[float]:
    """The inputs (rad) where the four-bar driven at B stops: the triangle A-B-O4 with
    |A O4| = |O2 O4| ± |O2 A| (crank and frame in line), signed from the reference."""
    at = {j.name: np.array(j.at) for j in m.joints}
    c, r = np.linalg.norm(at["A"] - at["B"]), np.linalg.norm(at["O4"] - at["B"])
    frame, crank = np.linalg.norm(at["O4"] - at["O2"]), np.linalg.norm(at["A"] - at["O2"])
    u, v = at["A"] - at["B"], at["O4"] - at["B"]
    theta0 = math.atan2(u[0] * v[1] - u[1] * v[0], u @ v)            # rocker from coupler at B
    out = []
    for d in (frame - crank, frame + crank):
        beta = math.acos((c * c + r * r - d * d) / (2 * c * r))
        out.append(math.copysign(beta, theta0) - theta0)
    return sorted(out)


def test_a_floating_driver_solves_to_its_limits_by_a_bounded_count(newton_calls):
    m = loads(FLOATING, "toml")
    x = np.radians(np.arange(0.0, 360.0, 30.0))
    st = solve(m, x)
    lo, hi = _b_limits(m)
    inside = (x >= lo) & (x <= hi) | (x - 2 * np.pi >= lo)
    assert np.array_equal(st.ok, inside), st.status
    assert set(st.codes[~inside]) <= {Status.LIMIT, Status.OTHER_CIRCUIT}
    assert f"limit at {np.degrees(hi):.6g}°" in st.status[2]
    assert newton_calls["n"] < 5000


@pytest.mark.parametrize("argv", [["solve", "FILE"], ["check", "FILE", "--json"]])
def test_solve_and_check_of_a_floating_driver_give_a_result(tmp_path, capsys, newton_calls, argv):
    f = tmp_path / "floating.toml"
    f.write_text(FLOATING)
    assert main([str(f) if a == "FILE" else a for a in argv]) == 0
    out = capsys.readouterr().out
    if argv[0] == "check":
        got = json.loads(out)["drivers"]["B"]["range"]
        np.testing.assert_allclose(got, np.degrees(_b_limits(load(f))), rtol=0, atol=1e-6)


def test_a_track_stops_when_its_count_of_corrections_is_spent():
    """The continuation's work is a count: a budget of corrections, then a message."""
    from multiloop.kin.groups.newton import ConstraintSystem, track
    from multiloop.kin.solve import compile_plan
    m = loads(FLOATING, "toml")
    st = compile_plan(m).steps[-1]
    x = np.radians(np.linspace(0.0, 90.0, 46))[:, None]
    Z = np.zeros((len(x), m.n_links, 3))
    Z[:, :, :2] = compile_plan(m).origins
    u = list(st.unknown)
    assert isinstance(st.system, ConstraintSystem)
    full = track(st.system, Z, x, u)
    assert full.ok[:15].all() and not full.ok[25:].any()
    short = track(st.system, Z, x, u, max_steps=12)
    assert short.ok[:10].all() and not short.ok[12:].any()
    assert "the continuation stopped: its 12 Newton corrections for 46 positions are spent" in short.reason[-1]
    np.testing.assert_array_equal(short.Z[:10], full.Z[:10])


def test_a_track_resumed_from_a_memo_gives_the_same_result():
    from multiloop.kin.groups.newton import track
    from multiloop.kin.solve import compile_plan
    m = loads(FLOATING, "toml")
    sp = compile_plan(m)
    st = sp.steps[-1]
    x = np.radians(np.linspace(0.0, 60.0, 31))[:, None]
    Z = np.zeros((len(x), m.n_links, 3))
    Z[:, :, :2] = sp.origins
    u = list(st.unknown)
    first = track(st.system, Z[:20], x[:20], u)
    again = track(st.system, Z, x, u, resume=first)
    alone = track(st.system, Z, x, u)
    for a, b in ((again, alone),):
        np.testing.assert_array_equal(a.Z, b.Z)
        np.testing.assert_array_equal(a.ok, b.ok)
        np.testing.assert_array_equal(a.code, b.code)
        assert a.n_iter == b.n_iter


# --- 2. synthesise --tol --------------------------------------------------------------
@pytest.mark.parametrize("tol", ["-1", "nan", "inf"])
@pytest.mark.parametrize("start", [[], ["four_bar"]])
def test_synthesise_refuses_a_tolerance_that_is_not_a_finite_number_at_least_0(tmp_path, capsys, tol, start):
    target = tmp_path / "t.csv"
    target.write_text("0,0\n1,0\n1,1\n0,1\n")
    out = tmp_path / "o.toml"
    argv = ["synthesise", *start, "--path", str(target), "--out", str(out), "--db", str(tmp_path / "none.sqlite"),
            "--budget", "2", f"--tol={tol}"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "error: --tol: expected a finite number >= 0" in err and f"got {float(tol)!r}" in err, err
    assert not out.exists()


def test_the_tie_bands_of_topology_synthesis_always_progress():
    """``_order`` with a negative tolerance or NaN errors ends, after a bounded count of
    key calls (it looped without end), NaN last."""
    from types import SimpleNamespace
    from multiloop.catalogue.topology_synthesis import _order
    calls = {"n": 0}

    def key(d):
        calls["n"] += 1
        if calls["n"] > 10_000:
            raise _Spent("more than 10 000 key calls")
        return d.error_rms, d.links
    items = [SimpleNamespace(error_rms=e, links=n) for e, n in
             [(0.3, 6), (float("nan"), 4), (0.1, 8), (0.1, 4), (0.2, 6)]]
    for tol in (-1.0, float("nan")):            # no ties: by error, NaN last
        got = [d.error_rms for d in _order(items, tol, key)]
        assert got[:4] == [0.1, 0.1, 0.2, 0.3] and math.isnan(got[4])
    got = [(d.error_rms, d.links) for d in _order(items, 0.0, key)]
    assert got[:4] == [(0.1, 4), (0.1, 8), (0.2, 6), (0.3, 6)] and math.isnan(got[4][0])
    wide = [(d.error_rms, d.links) for d in _order(items, 1.0, key)]
    assert wide[:4] == [(0.1, 4), (0.2, 6), (0.3, 6), (0.1, 8)]


def test_a_library_error_names_the_parameter_and_the_command_its_flag(tmp_path):
    from multiloop.catalogue.topology_synthesis import synthesise
    from multiloop.topo.errors import ParameterError
    with pytest.raises(ParameterError, match=r"^tol: expected a finite number >= 0") as e:
        synthesise([[0, 0], [1, 0], [1, 1], [0, 1]], tol=float("nan"), atlas=tmp_path / "none.sqlite")
    assert e.value.parameter == "tol" and "--tol" not in str(e.value)


# --- 5. huge finite driver ranges --------------------------------------------------------
@pytest.mark.parametrize("ends", ["-1e308, 1e308", f"-{2 ** 70}, {2 ** 70}", "-1e18, 1e18", "-1e200, 1e200"])
@pytest.mark.parametrize("cmd", ["check", "solve"])
def test_a_driver_range_beyond_the_input_bound_exits_2_naming_it(tmp_path, capsys, ends, cmd):
    from multiloop.topo.model import MAX_ANGLE_DEG
    f = tmp_path / "wide.toml"
    f.write_text(_four_bar('joint = "O2"', f'joint = "O2"\nrange = [{ends}]'))
    assert main([cmd, str(f)]) == 2
    err = capsys.readouterr().err
    assert f"{f}: [[driver]] on joint 'O2' range: expected ends of magnitude at most {MAX_ANGLE_DEG:g} deg" in err, err


def test_a_slide_range_beyond_the_input_bound_exits_2_naming_it(tmp_path, capsys):
    from multiloop.topo.model import MAX_SLIDE_SIZES
    text = (ROOT / "catalogue/mechanisms/excavator.toml").read_text()
    f = tmp_path / "wide.toml"
    f.write_text(text.replace("range = [-0.6, 0.7]", "range = [-1e18, 0.7]"))
    assert main(["check", str(f)]) == 2
    err = capsys.readouterr().err
    assert "[[driver]] on joint 'boom_cyl_slide' range: expected ends of magnitude at most" in err
    assert f"({MAX_SLIDE_SIZES:g} × the mechanism's size)" in err


def test_check_of_a_rotary_range_of_many_turns_samples_one_turn(tmp_path, capsys):
    """A range within the bound but of millions of turns: the motion repeats each turn,
    the range's ends bind (the old grid had 4e9 samples: exit 1)."""
    f = tmp_path / "turns.toml"
    f.write_text(_four_bar('joint = "O2"', 'joint = "O2"\nrange = [-1e9, 1e9]'))
    assert main(["check", str(f), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)["drivers"]["O2"]
    np.testing.assert_allclose(d["usable_range"], [-1e9, 1e9], rtol=1e-15)
    assert d["binds"] == {"low": "range", "high": "range"}
    assert len(d["dead_centres"]["rocker"]) == 4       # one turn each way


# --- 7. a range's own ends are inside it ------------------------------------------------
def test_the_ends_of_a_range_are_inside_it(tmp_path, capsys):
    """753537757.363939 deg goes to radians, back to degrees (the default sweep) and to
    radians again one unit in the last place higher than the range's end."""
    f = tmp_path / "ends.toml"
    f.write_text(_four_bar('joint = "O2"', 'joint = "O2"\nrange = [-753537757.363939, 753537757.363939]'))
    assert main(["solve", str(f), "--steps", "3"]) == 0
    out = capsys.readouterr().out
    assert "out of range" not in out, out


# --- 6. degenerate targets ---------------------------------------------------------------
def _circle(r: float, n: int = 20) -> str:
    t = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    return "".join(f"{r * math.cos(a)!r},{r * math.sin(a)!r}\n" for a in t)


DEGENERATE = {
    "same": ("x,y\n" + "1,1\n" * 10, "same.csv lines 2–11: expected path points that are not all the same",
             "got every point at (1, 1)"),
    "tiny": (_circle(1e-300), "tiny.csv lines 1–20: expected path points that are not all the same",
             "got a target of size 2e-300 m"),
    "field": ("x,y\n" + "1" * 140_000 + ",2\n1,2\n3,4\n5,6\n", "field.csv line 2: expected numbers separated by ','",
              "field larger than field limit"),
}


@pytest.mark.parametrize("case", sorted(DEGENERATE))
@pytest.mark.parametrize("start", [[], ["four_bar"]])
def test_degenerate_targets_exit_2_naming_the_file_and_line(tmp_path, capsys, case, start):
    text, where, got = DEGENERATE[case]
    f = tmp_path / f"{case}.csv"
    f.write_text(text)
    out = tmp_path / "o.toml"
    assert main(["synthesise", *start, "--path", str(f), "--out", str(out), "--db", str(tmp_path / "none.sqlite"),
                 "--budget", "1"]) == 2
    err = capsys.readouterr().err
    assert where in err and got in err and "internal error" not in err, err
    assert not out.exists()


def test_a_csv_target_obeys_the_input_cap(tmp_path, capsys):
    from multiloop.topo.io import MAX_INPUT_BYTES
    f = tmp_path / "big.csv"
    f.write_bytes(b"x,y\n" + b"a" * (MAX_INPUT_BYTES + 1))
    assert main(["synthesise", "four_bar", "--path", str(f), "--out", str(tmp_path / "o.toml")]) == 2
    assert f"file '{f}': expected at most {MAX_INPUT_BYTES >> 20} MiB" in capsys.readouterr().err


# --- 7. messages that name their file or key ---------------------------------------------
def test_non_finite_inputs_name_their_index_and_driver():
    from multiloop.kin.forces import reduce_inputs
    from multiloop.topo.errors import InputError
    m = load(FOUR_BAR)
    with pytest.raises(InputError, match=r"^inputs\[2, 0\] \(driver 'O2'\): expected finite numbers, got nan$"):
        solve(m, [0.0, 1.0, float("nan")])
    with pytest.raises(InputError, match=r"^driver inputs\[0, 0\] \(driver 'O2'\): expected finite numbers, got inf"):
        reduce_inputs(m, [float("inf")])


def test_a_singular_reference_names_the_file_and_the_mechanism(tmp_path, capsys):
    f = tmp_path / "toggle.toml"          # B on the line A-O4: coupler and rocker in line
    f.write_text(_four_bar("at = [0.133881, 0.072471]", "at = [0.18, -0.034641]"))
    for cmd in ("solve", "check"):
        assert main([cmd, str(f)]) == 2
        err = capsys.readouterr().err
        assert f"error: {f}: mechanism 'four_bar': group 1 II1(2,3) (RRR; links coupler, rocker): expected a " \
               "regular group in the reference configuration" in err, err
