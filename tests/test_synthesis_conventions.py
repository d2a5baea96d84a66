"""Dimensional synthesis: the converging polish, the timing / Grashof / mode / direction
conventions, the constraint report and hostile target tables (``multiloop synthesise``)."""
from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from multiloop.catalogue.dimensional import Evaluator, Problem, design_space, path_target, synthesise
from multiloop.catalogue.dimensional.objective import Constraints
from multiloop.catalogue.dimensional.optimise import polish
from multiloop.catalogue.named import load_named
from multiloop.catalogue.named import path as named_path
from multiloop.cli import main
from multiloop.kin.solve import solve
from multiloop.topo.errors import InputError
from multiloop.topo.model import Driver, TracerPoint


def _with_point(m, link):
    if any(p.link == link for p in m.points):
        return m, next(p.name for p in m.points if p.link == link)
    at = tuple(np.mean([j.at for j in m.joints if link in j.links], axis=0) + [0.003, 0.004])
    return replace(m, points=m.points + (TracerPoint("T", link, at),)), "T"


def _problem(m, pt, target, timing="reference", **cons):
    tgt = path_target(m, target, pt, timing=timing)
    sp = design_space(m, [pt], region=tgt.points)
    return Problem(Evaluator(m, sp), tgt, Constraints(**cons), 96)


# ---------------------------------------------------------------------------------
# 1. the polish converges: from within 1e-3 (unit box) of an exact design to 1e-10
POLISH = [("four_bar", "coupler", False), ("four_bar", "coupler", True), ("watt_1", "link_5", False),
          ("crank_slider", "rod", False), ("stephenson_3_triad", None, True)]


@pytest.mark.parametrize("name,link,timed", POLISH, ids=[f"{c[0]}-{'timed' if c[2] else 'free'}" for c in POLISH])
def test_polish_returns_a_perturbed_exact_solution(name, link, timed):
    m = load_named(name)
    m, pt = _with_point(m, link) if link else (m, m.points[0].name)
    deg = np.arange(7.0, 300.0, 29.0)
    st = solve(m, np.radians(deg))
    T = st.point_positions[:, st.point_index(pt)]
    pr = _problem(m, pt, np.column_stack([T, deg]) if timed else T)
    z = pr.x0 + 1e-3 * (pr.upper - pr.lower) * np.random.default_rng(3).uniform(-1, 1, len(pr.x0))
    assert np.sqrt(np.mean(pr.residuals(z, pr.match(z)) ** 2)) > 1e-5       # really perturbed
    z2, phi2, _ = polish(pr, z, pr.match(z), max_nfev=120)
    assert np.sqrt(np.mean(pr.residuals(z2, phi2) ** 2)) < 1e-10


def test_synthesise_started_on_the_exact_design_returns_it():
    m, pt = _with_point(load_named("four_bar"), "coupler")
    T = solve(m, np.radians(np.arange(0.0, 360.0, 20.0))).point_positions[:, 0]
    r = synthesise(m, path=T, point=pt, evaluations=6000, tol=1e-12)
    assert r.error_rms < 1e-10


# ---------------------------------------------------------------------------------
# 2. conventions
def _slider_driven():
    """crank_slider driven by its slider (P driver on the frame)."""
    m = load_named("crank_slider")
    return replace(m, drivers=(Driver("S", ("frame", "piston")),), name="slider_driven")


@pytest.mark.parametrize("make", [lambda: load_named("four_bar"), _slider_driven], ids=["R", "P"])
def test_absolute_timing_is_reference_timing_plus_the_drivers_zero(make):
    """Two routes: the driver's absolute value at the start read off the geometry
    (crank angle from the x-axis; slider position from the guide's point) and the
    evaluator's :meth:`driver_zero`."""
    m = make()
    pt = m.points[0].name
    rot = m.joint(m.drivers[0].joint).kind.value == "R"
    phi = np.radians([10.0, 30.0, 50.0, 70.0]) if rot else np.array([-0.04, -0.03, -0.02, -0.01])
    T = solve(m, phi).point_positions[:, 0]
    if rot:
        O, A = np.array(m.joint(m.drivers[0].joint).at), np.array(m.joint("A").at)
        zero = np.degrees(np.arctan2(*(A - O)[::-1]))
        col = zero + np.degrees(phi)
    else:
        col = (np.array(m.joint("B").at) - np.array(m.joint("S").at)) @ np.array(m.joint("S").axis) + phi
    pa = _problem(m, pt, np.column_stack([T, col]), timing="absolute")
    np.testing.assert_allclose(pa.timing_for(pa.x0[None, :])[0], phi, atol=1e-12)
    assert pa.batch(pa.x0[None, :])[0] < 1e-12


def test_step_timing_has_a_free_offset_and_sense():
    m = load_named("four_bar")
    phi = np.radians(40.0 + 20.0 * np.arange(6))
    T = solve(m, phi).point_positions[:, 0]
    steps = np.column_stack([T, 100.0 + np.degrees(phi - phi[0])])        # any start: only steps count
    pr = _problem(m, "P", steps, timing="step")
    assert {"timing.offset", "timing.sense"} <= set(pr.names)
    z = pr.x0.copy()
    z[pr.names.index("timing.offset")] = phi[0]
    assert pr.batch(z[None, :])[0] < 1e-12
    z[pr.names.index("timing.sense")] = -0.5                              # the clockwise reading
    assert pr.batch(z[None, :])[0] > 1e-3
    r = synthesise(m, path=steps, point="P", timing="step", evaluations=6000, seed=1)
    assert r.error_max < 1e-6


def test_direction_picks_the_walk_and_is_reported():
    m = load_named("four_bar")
    T = solve(m, np.radians(np.arange(0.0, 300.0, 50.0))).point_positions[:, 0]
    for d, sign in (("ccw", 1.0), ("cw", -1.0)):
        r = synthesise(m, path=T, point="P", direction=d, evaluations=3000, seed=0)
        row = next(c for c in r.constraints if c["name"] == "direction")
        steps = np.diff(r.inputs)
        assert row["met"] == bool(np.all(sign * steps >= 0)) and row["value"] in ("ccw", "cw", "both")
    r = synthesise(m, path=T, point="P", direction="ccw", evaluations=3000)
    assert r.error_max < 1e-6 and np.all(np.diff(r.inputs) > 0)     # the target is traced ccw


def test_grashof_crank_rocker_and_mode_reference_are_met_and_reported():
    m = load_named("four_bar")
    T = solve(m, np.radians(np.arange(0.0, 360.0, 40.0))).point_positions[:, 0]
    r = synthesise(m, path=T, point="P", grashof="crank-rocker", mode="reference", evaluations=4500)
    rows = {c["name"]: c for c in r.constraints}
    assert rows["grashof"]["met"] and rows["mode"]["met"] and rows["mode"]["value"] == 0
    j = {x.name: np.array(x.at) for x in r.mechanism.joints}
    L = sorted([np.linalg.norm(j["A"] - j["O2"]), np.linalg.norm(j["B"] - j["A"]),
                np.linalg.norm(j["O4"] - j["B"]), np.linalg.norm(j["O4"] - j["O2"])])
    assert L[0] + L[3] <= L[1] + L[2] + 1e-12
    assert np.isclose(np.linalg.norm(j["A"] - j["O2"]), L[0])
    with pytest.raises(InputError, match="four-bar"):
        synthesise(load_named("watt_1"), path=T, point="P", grashof="double-crank", evaluations=1500)


def test_bounds_are_kept_and_reported_violations_are_measured(tmp_path, capsys):
    """The bounds hold, and the transmission row is the design's own minimum transmission
    angle (``check``'s exact extremes over the continuous motion of the written file,
    not the driver grid's samples), met exactly when it reaches 89.5°.  Whether the search
    meets 89.5° is its trade of the targets against the penalty: a four-bar can keep it
    all turn (the next test), by a crank too small to trace the target."""
    from multiloop.kin.check import check
    from multiloop.topo.io import load
    m = load_named("four_bar")
    T = solve(m, np.radians(np.arange(0.0, 360.0, 40.0))).point_positions[:, 0]
    f = tmp_path / "t.csv"
    np.savetxt(f, T, delimiter=",")
    out = tmp_path / "o.toml"
    args = ["synthesise", str(named_path("four_bar")), "--path", str(f), "--out", str(out), "--evaluations", "3000",
            "--bounds", "O2.x=-0.01:0.01", "O4.y=-0.02:0.0", "--min-transmission", "89.5"]
    assert main(args + ["--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert -0.01 <= doc["design"]["O2.x"] <= 0.01 and -0.02 <= doc["design"]["O4.y"] <= 0.0
    mt = next(c for c in doc["constraints"] if c["name"] == "min_transmission")
    mu = {a.joint: a.extreme for a in check(load(out), min_transmission=0.0).drivers[0].angles}["B"]
    lowest = min(mu.min, 180.0 - mu.max)                             # folded to [0°, 90°]
    assert abs(mt["value"] - lowest) <= 1e-6                         # check's own, not the grid's samples
    assert mt["met"] == (mt["value"] >= 89.5)
    assert np.isclose(mt["violation"], max(0.0, 89.5 - mt["value"]))
    assert doc["constraints_met"] == all(c["met"] for c in doc["constraints"])
    # the text report of the same run (same seed and evaluations: the same design) prints that row
    assert main(args) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("constraint min_transmission"))
    state = "met" if mt["met"] else f"NOT met, violated by {mt['violation']:.3g}"
    assert line == f"constraint min_transmission (89.5): {state}; value {mt['value']:.4g}"


def test_a_small_crank_keeps_the_transmission_angle_within_half_a_degree_of_90():
    """Frame d, crank a, coupler = rocker = sqrt((d² + a²) / 2): cos μ = 2ad cos θ / (d² + a²),
    so a crank of 0.4 % of the frame keeps μ within asin(0.008) = 0.458° of 90° all turn.
    Three routes: the closed form, ``check`` and the synthesis report's constraint row."""
    import math

    from multiloop.catalogue.dimensional.report import constraint_report
    from multiloop.kin.check import check
    from tests.test_check import four_bar
    d, a = 0.1, 0.0004
    b = math.sqrt((d * d + a * a) / 2)
    m, pt = _with_point(four_bar(a, b, b, d, math.radians(90.0)), "coupler")
    closed = 90.0 - math.degrees(math.asin(2 * a * d / (d * d + a * a)))
    assert 89.5 < closed < 89.55
    dc = check(m, min_transmission=89.5).drivers[0]
    mu = {x.joint: x.extreme for x in dc.angles}["B"]
    assert dc.full_rotation and mu.min == pytest.approx(closed, abs=1e-9) and mu.max == pytest.approx(180 - closed)
    T = solve(m, np.radians(np.arange(0.0, 360.0, 40.0))).point_positions[:, 0]
    pr = _problem(m, pt, T, min_transmission=89.5)
    row = next(r for r in constraint_report(pr, pr.x0, pr.match(pr.x0), True) if r["name"] == "min_transmission")
    assert row["met"] and row["value"] == pytest.approx(closed, abs=1e-8) and row["violation"] == 0.0


def test_the_penalty_reads_the_lowest_transmission_between_the_samples():
    """The penalty's estimate of the lowest angle on a rotary grid is the parabola's vertex
    through the lowest sample and its neighbours (cyclic over a whole turn): exact for a
    parabola, at the sample where a neighbour is missing, between the true minimum and the
    lowest sample at a V-shaped dip."""
    from multiloop.catalogue.dimensional.objective import _lowest
    x = np.arange(12.0)
    f = np.stack([(x - 4.3) ** 2 + 30.0,                                   # a parabola: its vertex
                  np.where(x < 5, np.inf, (x - 4.3) ** 2 + 30.0),           # the lowest sample at the end
                  30.0 + np.abs(x - 6.3),                                   # a V: above its true minimum
                  np.r_[(x[:3] + 0.4) ** 2, np.full(9, 50.0)]])             # a whole turn: cyclic neighbours
    f[3, 11] = 0.6 ** 2
    lo = _lowest(f, True)
    assert lo[0] == pytest.approx(30.0, abs=1e-12)
    assert lo[1] == f[1, 5]
    assert 30.0 <= lo[2] <= f[2].min()
    assert lo[3] == pytest.approx(0.0, abs=1e-12)
    assert np.array_equal(_lowest(f, False), f.min(axis=1))                 # (a slider's grid: the samples)


# ---------------------------------------------------------------------------------
# 3. hostile targets and options: exit 2, one message, nothing written
def _csv(tmp_path, body: bytes):
    f = tmp_path / "t.csv"
    f.write_bytes(body)
    return f


BAD = {"empty": (b"", "empty file"), "header": (b"x,y\n", "header line only"),
       "latin1": (b"x,y\n0,0\n1,\xe9\n2,1\n", "UTF-8"), "huge": (b"1e300,0\n0,1\n1,1\n", "magnitude"),
       "tiny": (b"-1e300,0\n0,1\n1,1\n", "magnitude"), "zero": (b"1,1\n1,1\n1,1\n1,1\n", "not all the same")}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_target_tables_exit_2(tmp_path, capsys, case):
    body, words = BAD[case]
    out = tmp_path / "o.toml"
    rc = main(["synthesise", "four_bar", "--path", str(_csv(tmp_path, body)), "--out", str(out), "--evaluations", "3000"])
    err = capsys.readouterr().err
    assert rc == 2 and words in err and "Traceback" not in err and not out.exists()


@pytest.mark.parametrize("args,words", [(["--seed", "-1"], "seed"), (["--min-transmission", "100"], "[0, 90]"),
                                        (["--bounds", "O2.x=1:0"], "low < high"),
                                        (["--bounds", "O2.x=a:b"], "NAME=LOW:HIGH"),
                                        (["--bounds", "Q.x=0:1"], "design variable"),
                                        (["--timing", "step"], "third column"),
                                        (["--grashof", "crank-rocker", "--mode", "reference"], None)])
def test_bad_options_exit_2(tmp_path, capsys, args, words):
    f = _csv(tmp_path, b"0,0\n0.01,0.02\n0.03,0.01\n0.02,-0.01\n")
    out = tmp_path / "o.toml"
    rc = main(["synthesise", "four_bar", "--path", str(f), "--out", str(out), "--evaluations", "1500"] + args)
    err = capsys.readouterr().err
    if words is None:                   # valid options (the control)
        assert rc == 0 and out.exists()
    else:
        assert rc == 2 and words in err and not out.exists()


def test_direction_with_absolute_timing_exit_2(tmp_path, capsys):
    f = _csv(tmp_path, b"0,0,10\n0.01,0.02,20\n0.03,0.01,30\n")
    rc = main(["synthesise", "four_bar", "--path", str(f), "--out", str(tmp_path / "o.toml"),
               "--timing", "absolute", "--direction", "cw"])
    assert rc == 2 and "third column fixes the direction" in capsys.readouterr().err


def test_long_targets_are_resampled_within_memory(tmp_path):
    """3 000 and 10 000 rows once needed 404 GiB / 3.2 GB: now at most MAX_ROWS are used, with a note."""
    import resource
    from multiloop.catalogue.dimensional.targets import MAX_ROWS
    m = load_named("four_bar")
    T = solve(m, np.linspace(0.1, 6.0, 10000)).point_positions[:, 0]
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    r = synthesise(m, path=T, point="P", evaluations=3000)
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 600_000      # kB
    assert len(r.target) == MAX_ROWS and any("10000 rows were resampled" in n for n in r.notes)
    assert r.error_max < 1e-6


def test_description_is_replaced_not_appended(tmp_path):
    m = load_named("four_bar")
    T = solve(m, np.radians(np.arange(0.0, 360.0, 40.0))).point_positions[:, 0]
    r = synthesise(m, path=T, point="P", evaluations=1500)
    d = r.mechanism.description
    assert m.description and m.description not in d and "synthesised" in d and f"{len(T)} targets" in d
    r2 = synthesise(r.mechanism, path=T, point="P", evaluations=1500)
    assert r2.mechanism.description.count("synthesised") == 1


# ---------------------------------------------------------------------------------
# 4. the comparison with plain DE (benchmarks/bench_synthesis_literature.py)
def _bench():
    import importlib.util
    from pathlib import Path
    f = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_synthesis_literature.py"
    spec = importlib.util.spec_from_file_location("bench_synthesis_literature", f)
    mod = importlib.util.module_from_spec(spec)
    import sys
    sys.modules[spec.name] = mod           # (its dataclasses look their module up)
    spec.loader.exec_module(mod)
    return mod


def test_textbook_four_bar_equals_kin_solve():
    """Two routes: the benchmark's textbook closed form (Cabrera et al. 2002) and
    kin.solve trace the same coupler points for the catalogue four-bar."""
    B = _bench()
    m = load_named("four_bar")
    j = {x.name: np.array(x.at) for x in m.joints}
    P = np.array(m.points[0].at)
    ang = lambda v: np.arctan2(v[1], v[0])  # noqa: E731
    t3 = ang(j["B"] - j["A"])
    c, s = np.cos(-t3), np.sin(-t3)
    rc = np.array([[c, -s], [s, c]]) @ (P - j["A"])
    V = np.array([[np.linalg.norm(j["O4"] - j["O2"]), np.linalg.norm(j["A"] - j["O2"]),
                   np.linalg.norm(j["B"] - j["A"]), np.linalg.norm(j["B"] - j["O4"]), rc[0], rc[1],
                   j["O2"][0], j["O2"][1], ang(j["O4"] - j["O2"])]])
    phi = np.radians(np.arange(0.0, 360.0, 30.0))
    pts, ok = B._four_bar_points(V, (ang(j["A"] - j["O2"]) + phi)[None, :])
    assert ok.all()
    np.testing.assert_allclose(pts[0], solve(m, phi).point_positions[:, 0], atol=1e-12)


@pytest.mark.benchmark
def test_search_is_at_least_as_good_as_plain_de():
    """The default search's median SSD is no worse than plain SciPy DE's at equal wall time."""
    B = _bench()
    cs = B.cases()
    for name in ("line6", "arc5", "ellipse"):
        ours, de = [], []
        for seed in range(3):
            e, wall = B.ours(cs[name], 1.5, seed)
            ours.append(e)
            de.append(B.plain_de(cs[name], wall, seed)[0])
        assert np.median(ours) <= np.median(de), (name, ours, de)


def test_csv_messages_name_file_lines_and_semicolon_tables_are_read():
    """Field defects (issue 22, smaller): every fault names the file's line (blank lines
    and the header counted); a ';'-separated table is read, not taken as a header."""
    import pytest as _pt
    from multiloop.catalogue.dimensional.targets import parse_table
    from multiloop.topo.errors import InputError
    a = parse_table("x;y\n0;0\n1;0\n0;1\n", (2,), "path", "t.csv")
    assert a.shape == (3, 2)
    b = parse_table("0;0\n1;0\n0;1\n", (2,), "path", "t.csv")
    assert b.shape == (3, 2)
    with _pt.raises(InputError, match="t.csv line 5"):
        parse_table("x,y\n0,0\n\n1,0\n0,nan\n", (2,), "path", "t.csv")
    with _pt.raises(InputError, match="t.csv line 4"):
        parse_table("x,y\n0,0\n\n1,0,3\n", (2,), "path", "t.csv")


def test_assess_a_design_that_does_not_assemble_at_its_reference():
    """A design that reaches no grid sample (two letters of LInK's alphabet met one in
    the polish, ``benchmarks/bench_link_abc.py``): the assessment says the targets are
    not reached (it raised a ValueError on the empty range of motion before)."""
    from multiloop.catalogue.dimensional.synthesise import _assess

    m = load_named("four_bar")
    pt = m.points[0].name
    st = solve(m, np.radians(np.arange(0.0, 300.0, 30.0)))
    pr = _problem(m, pt, st.point_positions[:, st.point_index(pt)])
    z = pr.x0.copy()
    assert _assess(pr, z, pr.match(z))[2]
    far = z.copy()
    far[0] = np.nan                                   # a design that solves at no driver value
    assert not pr.ev.poses(far[None, :pr.nx], [0.0]).ok.any()
    rel, ang, ok = _assess(pr, far, np.zeros(len(st.point_positions)))
    assert not ok and ang is None


def test_continuity_is_the_certified_motions_not_the_grids():
    """A four-bar that fails Grashof by 1e-4 locks over 3.3° around 180°, between two
    samples of the 96-sample grid: every sample assembles, so the grid alone calls the
    crank fully turning and targets across the gap reached.  The returned assessment and
    the report's ``continuous`` row take the certified motion's answer (``check``'s walk):
    not reached; targets short of the gap are."""
    import math

    from multiloop.catalogue.dimensional.report import constraint_report
    from multiloop.catalogue.dimensional.synthesise import _assess, _certified
    from multiloop.kin.check import check
    from tests.test_check import four_bar
    a, b, c = 0.3, 1.0, 0.6
    m, pt = _with_point(four_bar(a, b, c, b + c - a + 1e-4, math.radians(1.875)), "coupler")
    assert not check(m).drivers[0].full_rotation
    for deg, reached in ((np.array([100.0, 150.0, 200.0, 250.0]), False), (np.array([20.0, 60.0, 120.0]), True)):
        st = solve(m, np.radians(deg[deg < 170.0]))                      # (any points: continuity is the question)
        T = np.resize(st.point_positions[:, st.point_index(pt)], (len(deg), 2))
        pr = _problem(m, pt, np.column_stack([T, deg]))
        z, phi = pr.x0, pr.timing_for(pr.x0[None, :])[0]
        grid = _assess(pr, z, phi)
        assert grid[2]                                                   # the grid: all samples assemble
        chosen = _certified(pr, [(grid, z, phi, 0)])
        assert chosen[0][2] is reached
        row = next(r for r in constraint_report(pr, z, phi, chosen[0][2]) if r["name"] == "continuous")
        assert row["met"] is reached
