"""Tests of ``multiloop check``: every number against a second route.

Closed forms (Norton R. L., Design of Machinery, 5th ed., 2012, ch. 4: four-bar
toggle positions, transmission angle; offset crank-slider dead centres), Kennedy's
theorem (Kennedy 1886), Grashof's criterion (Grashof 1883) against the sweep, and fine
sweeps of the solver for the multi-loop mechanisms.
"""
from __future__ import annotations

import itertools
import json
import math
import os
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given, strategies as st

from multiloop.cli import main
from multiloop.kin.check import check
from multiloop.kin.check.grashof import grashof_class
from multiloop.kin.check.instant_centres import instant_centres
from multiloop.kin.check.transmission import angle_specs, angle_values
from multiloop.kin.solve import solve
from multiloop.topo.assur import decompose
from multiloop.topo.io import load
from multiloop.topo.model import MechanismBuilder

CAT = Path(__file__).resolve().parents[1] / "catalogue" / "mechanisms"


def _ang(x):
    return float(np.degrees(x)) % 360.0


def _close_mod360(a, b, tol):
    d = (a - b + 180.0) % 360.0 - 180.0
    return abs(d) <= tol


def four_bar(a, b, c, d, theta0, sign=1.0):
    """Crank a (O2 at the origin, at angle theta0), coupler b, rocker c, ground d along x."""
    A = np.array([a * math.cos(theta0), a * math.sin(theta0)])
    O4 = np.array([d, 0.0])
    AC = O4 - A
    L = float(np.hypot(*AC))
    if L < 1e-9 * d:  # the crank pin on the rocker's pivot: no reference configuration
        return None
    x = (b * b + L * L - c * c) / (2 * L)
    y2 = b * b - x * x
    if y2 <= 0:
        return None
    u = AC / L
    n = np.array([-u[1], u[0]])
    B = A + x * u + sign * math.sqrt(y2) * n
    bld = MechanismBuilder("fb")
    bld.add_link("frame", frame=True)
    for lk in ("crank", "coupler", "rocker"):
        bld.add_link(lk)
    bld.add_joint("O2", "R", ("frame", "crank"), at=(0.0, 0.0))
    bld.add_joint("A", "R", ("crank", "coupler"), at=tuple(A))
    bld.add_joint("B", "R", ("coupler", "rocker"), at=tuple(B))
    bld.add_joint("O4", "R", ("rocker", "frame"), at=(d, 0.0))
    bld.add_driver("O2")
    return bld.build()


def crank_slider(a, b, e, theta0):
    A = np.array([a * math.cos(theta0), a * math.sin(theta0)])
    Bx = A[0] + math.sqrt(b * b - (A[1] - e) ** 2)
    bld = MechanismBuilder("cs")
    bld.add_link("frame", frame=True)
    for lk in ("crank", "rod", "piston"):
        bld.add_link(lk)
    bld.add_joint("O", "R", ("frame", "crank"), at=(0.0, 0.0))
    bld.add_joint("A", "R", ("crank", "rod"), at=tuple(A))
    bld.add_joint("B", "R", ("rod", "piston"), at=(Bx, e))
    bld.add_joint("S", "P", ("frame", "piston"), at=(Bx, e), axis=(1.0, 0.0))
    bld.add_driver("O")
    return bld.build()


lengths = st.floats(0.2, 2.0)


def _margin(L):
    s = sorted(L)
    return abs(s[0] + s[3] - s[1] - s[2]) / s[3]


# ---------------------------------------------------------------- four-bars (hypothesis)
@given(a=lengths, b=lengths, c=lengths, d=lengths, t0=st.floats(0.0, 2 * math.pi))
def test_four_bar_grashof_class_matches_sweep(a, b, c, d, t0):
    assume(_margin((a, b, c, d)) > 0.05)
    m = four_bar(a, b, c, d, t0)
    assume(m is not None)
    rep = check(m)
    dc = rep.drivers[0]
    cls = grashof_class((d, a, b, c), fixed=0)
    assert [g.cls for g in rep.grashof] == [cls]
    # second route: what the sweep shows
    crank_turns = dc.full_rotation
    rocker_dead = dict(dc.dead_centres)["rocker"]
    if cls == "crank-rocker" and min(a, b, c, d) == a:
        assert crank_turns and len(rocker_dead) == 2
    elif cls == "double crank":
        assert crank_turns and len(rocker_dead) == 0
    elif cls in ("double rocker", "non-Grashof") or (cls == "crank-rocker" and min(a, b, c, d) == c):
        assert not crank_turns and len(dc.limits) == 2


@given(a=lengths, b=lengths, c=lengths, d=lengths, t0=st.floats(0.0, 2 * math.pi))
def test_four_bar_limits_law_of_cosines(a, b, c, d, t0):
    assume(_margin((a, b, c, d)) > 0.05)
    m = four_bar(a, b, c, d, t0)
    assume(m is not None)
    dc = check(m).drivers[0]
    assume(not dc.full_rotation)
    cands = []
    for k in (b + c, b - c):
        cs = (a * a + d * d - k * k) / (2 * a * d)
        if abs(cs) <= 1:
            cands += [math.acos(cs) - t0, -math.acos(cs) - t0]
    # a reference at a limit (coupler and rocker flat within rounding) has its limit where
    # the rounded coordinates put it, up to sqrt(rounding) away: not an oracle case
    assume(all(abs(math.remainder(y, 2 * math.pi)) > 1e-4 for y in cands))
    assert len(dc.limits) == 2
    for x in dc.limits:
        assert any(_close_mod360(_ang(x), _ang(y), 1e-7) for y in cands), (x, cands)


@given(a=st.floats(0.2, 0.6), b=st.floats(1.5, 2.5), c=st.floats(1.0, 2.0), t0=st.floats(0.0, 2 * math.pi))
def test_crank_rocker_transmission_extremes_at_ground_collinear(a, b, c, t0):
    d = 2.0
    assume(a + max(b, c, d) < sum(sorted((b, c, d))[:2]) + 0.05 * d)   # Grashof, crank shortest
    m = four_bar(a, b, c, d, t0)
    assume(m is not None)
    dc = check(m).drivers[0]
    assume(dc.full_rotation)
    tr = {x.joint: x.extreme for x in dc.angles}["B"]
    mu_min = math.degrees(math.acos((b * b + c * c - (d - a) ** 2) / (2 * b * c)))
    mu_max = math.degrees(math.acos((b * b + c * c - (d + a) ** 2) / (2 * b * c)))
    ext = sorted([mu_min, mu_max])
    assert tr.min == pytest.approx(ext[0], abs=1e-8)
    assert tr.max == pytest.approx(ext[1], abs=1e-8)
    # where: crank along the ground line (θ = 0 or π absolute)
    for at in (tr.at_min, tr.at_max):
        assert any(_close_mod360(_ang(at), _ang(t - t0), 1e-6) for t in (0.0, math.pi))


@given(a=st.floats(0.2, 0.6), b=st.floats(1.5, 2.5), c=st.floats(1.0, 2.0), t0=st.floats(0.0, 2 * math.pi))
def test_rocker_dead_centres_where_crank_and_coupler_collinear(a, b, c, t0):
    d = 2.0
    assume(a + max(b, c, d) < sum(sorted((b, c, d))[:2]) + 0.05 * d)
    # not at Grashof's equality s + l = p + q (a change point, e.g. 0.5, 1.5, 1, 2): there
    # all four links fold onto one line once a turn, a branch point, where the check
    # reports the branch point and not the rocker's second dead centre
    assume(_margin((a, b, c, d)) > 0.05)
    m = four_bar(a, b, c, d, t0)
    assume(m is not None)
    dc = check(m).drivers[0]
    assume(dc.full_rotation)
    dead = dict(dc.dead_centres)["rocker"]
    assert len(dead) == 2
    s = solve(m, np.array(dead))
    O2, A, B = (s.positions[:, s.joint_index(n)] for n in ("O2", "A", "B"))
    u, v = A - O2, B - A
    cross = (u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]) / (a * b)
    assert np.all(np.abs(cross) < 1e-9)


def test_non_grashof_limits_published_example():
    # docs: a triple rocker stops where the driven dyad is collinear (law of cosines)
    a, b, c, d = 1.0, 1.0, 2.0, 2.5
    m = four_bar(a, b, c, d, math.radians(60.0))
    dc = check(m).drivers[0]
    th = math.degrees(math.acos((a * a + d * d - (b + c) ** 2) / (2 * a * d)))
    assert not dc.full_rotation
    # at the limit the dyad is stretched out: transmission 180° (toggle), both modes reachable
    assert {x.joint: x.extreme for x in dc.angles}["B"].max == pytest.approx(180.0, abs=1e-2)
    assert check(m).circuits[0].reachable == 2
    assert "out of reach" in dc.limit_groups[0]
    rep = check(m, positions={"O2": [math.radians(10.0), math.pi]}, output="rocker")
    assert rep.drivers[0].unreachable == (math.pi,)
    # the library's JSON form is strict JSON already (the CLI prints it as it is)
    doc = json.loads(json.dumps(rep.as_dict(), allow_nan=False))
    assert doc["drivers"]["O2"]["unreachable_positions"] == [180.0]
    assert sorted(_ang(x) for x in dc.limits) == pytest.approx(sorted([(th - 60) % 360, (-th - 60) % 360]),
                                                               abs=1e-8)


# ---------------------------------------------------------------- offset crank-slider
@pytest.mark.parametrize("a,b,e,t0", [(0.05, 0.2, 0.01, 0.3), (0.04, 0.15, -0.02, 2.0), (0.05, 0.2, 0.0, 1.0)])
def test_offset_crank_slider_dead_centres(a, b, e, t0):
    m = crank_slider(a, b, e, t0)
    rep = check(m)
    dead = sorted(_ang(x) for x in dict(rep.drivers[0].dead_centres)["piston"])
    want = sorted(_ang(t - t0) for t in (math.asin(e / (b + a)), math.pi + math.asin(e / (b - a))))
    assert len(dead) == 2
    for x, y in zip(dead, want):
        assert _close_mod360(x, y, 1e-7)
    assert rep.as_dict()["dead_centres"]["piston"] == pytest.approx(dead)


# ---------------------------------------------------------------- Kennedy on the catalogue
CATALOGUE = sorted(p for p in CAT.glob("*.toml") if not p.stem.startswith("excavator"))


@pytest.mark.parametrize("path", CATALOGUE, ids=lambda p: p.stem)
def test_kennedy_and_primary_centres(path):
    m = load(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        x = [0.7 if d.range is None else min(max(0.7, 0.9 * d.range[0]), 0.9 * d.range[1])
             for d in m.drivers]                  # a cylinder inside its stroke
        s = solve(m, np.array([x]), derivatives=True)
    ics = instant_centres(s, 0)
    h = {frozenset((c.a, c.b)): np.array(c.homogeneous) for c in ics}
    for i, j, k in itertools.combinations(m.link_names, 3):
        M = np.array([h[frozenset(p)] for p in ((i, j), (j, k), (i, k))])
        M = M / np.maximum(np.linalg.norm(M, axis=1, keepdims=True), 1e-300)
        assert abs(np.linalg.det(M)) < 1e-9
    # second route: the centre of two links on one pin is that pin
    by = {frozenset((c.a, c.b)): c for c in ics}
    for jn, j in enumerate(m.joints):
        for p, q in itertools.combinations(j.links, 2):
            c = by[frozenset((p, q))]
            if j.kind.value == "R":
                assert c.point is not None
                assert np.allclose(c.point, s.positions[0, jn], atol=1e-9)
            else:
                assert c.point is None


# ---------------------------------------------------------------- against fine sweeps
def _fine(m, n=72001):
    x = np.linspace(0, 2 * np.pi, n)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return x, solve(m, x, derivatives=True)


@pytest.mark.parametrize("name", ["knitting_needle_drive", "stephenson_3_triad"])
def test_multi_loop_against_fine_sweep(name):
    m = load(CAT / f"{name}.toml")
    assert name != "knitting_needle_drive" or any(j.is_multiple for j in m.joints)
    rep = check(m)
    dc = rep.drivers[0]
    x, s = _fine(m)
    assert s.success and dc.full_rotation
    specs = angle_specs(decompose(m))
    V = angle_values(s, specs)
    h = x[1] - x[0]
    # every monitored angle is continuous along the motion (no jump of the definition)
    assert np.max(np.abs(np.diff(V, axis=0))) < 0.5
    for c, a in enumerate(dc.angles):
        e = a.extreme
        # the exact extremes bound every sample and are within the sampling error
        assert e.min <= V[:, c].min() + 1e-9 and e.max >= V[:, c].max() - 1e-9
        assert V[:, c].min() - e.min < 5e-3 and e.max - V[:, c].max() < 5e-3
        # and a local sweep 1e-4 rad around each refined extremum reaches it to 1e-9°
        for at, val, f in ((e.at_min, e.min, np.min), (e.at_max, e.max, np.max)):
            xl = np.concatenate([np.linspace(0, at - 1e-4, 400), np.linspace(at - 1e-4, at + 1e-4, 2001)])
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                loc = angle_values(solve(m, xl), specs)[400:, c]
            assert abs(f(loc) - val) < 1e-9
    for lk, xs in dc.dead_centres:
        w = s.omegas[:, s.link_index(lk)]
        flips = x[np.flatnonzero(np.sign(w[:-1]) * np.sign(w[1:]) < 0)]
        assert len(flips) == len(xs)
        for f in flips:
            assert min(abs(((f - y) + np.pi) % (2 * np.pi) - np.pi) for y in xs) < 2 * h


def test_triad_circuits_count_all_modes():
    rep = check(load(CAT / "stephenson_3_triad.toml"))
    (c,) = rep.circuits
    assert c.kind == "triad" and c.modes >= 2 and c.reachable == 1


# ---------------------------------------------------------------- Grashof unit cases
@pytest.mark.parametrize("L,fixed,cls", [
    ((100, 40, 120, 80), 0, "crank-rocker"),   # the catalogue four-bar: s + l = 140 < 180
    ((40, 100, 120, 80), 0, "double crank"),
    ((120, 80, 40, 100), 0, "double rocker"),
    ((100, 50, 100, 50), 0, "change point"),
    ((100, 70, 85, 60), 0, "non-Grashof"),
])
def test_grashof_classes(L, fixed, cls):
    assert grashof_class(L, fixed) == cls


# ---------------------------------------------------------------- CLI
def test_cli_plot_without_a_suffix_is_a_png(tmp_path, capsys):
    """``--plot NAME`` without a suffix writes a PNG, as every command's --plot (it raised
    inside matplotlib, exit 1, before)."""
    out = tmp_path / "overview"
    assert main(["check", str(CAT / "four_bar.toml"), "--plot", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_cli_json_keys(capsys):
    assert main(["check", str(CAT / "four_bar.toml"), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    for k in ("drivers", "transmission", "dead_centres", "circuits", "branch_points", "grashof",
              "instant_centres", "mechanical_advantage", "verdict"):
        assert k in d
    assert d["drivers"]["O2"]["full_rotation"] is True and d["drivers"]["O2"]["limits"] == []
    assert set(d["transmission"]["B"]) == {"min", "max"}
    assert all(0 <= v < 360 for v in d["dead_centres"]["rocker"])


@pytest.mark.parametrize("argv", [
    ["check", "no_such_file.toml"],
    ["check", str(CAT / "four_bar.toml"), "--min-transmission", "120"],
    ["check", str(CAT / "four_bar.toml"), "--output", "nosuch"],
    ["check", str(CAT / "four_bar.toml"), "--positions", "a,b"],
    ["check", str(CAT / "four_bar.toml"), "--at", "nan"],
])
def test_cli_bad_input_exit_2(argv, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("\n") == 1


def test_cli_circuit_defect_and_html(tmp_path, capsys):
    m = four_bar(1.0, 1.0, 2.0, 2.5, math.radians(60.0))
    from multiloop.topo.io import dumps_toml
    f = tmp_path / "nongrashof.toml"
    f.write_text(dumps_toml(m))
    out = tmp_path / "rep"
    assert main(["check", str(f), "--positions", "10,180", "--html", str(out)]) == 0
    txt = capsys.readouterr().out
    assert "circuit defect" in txt and "180.000000°" in txt
    assert (out / "index.html").exists() and list(out.glob("*.png"))


def test_two_drivers_each_moves_only_its_own_loop():
    # two copies of one crank-rocker on one frame: each driver's dead centres are the
    # single four-bar's, and the other loop (held) has none
    a, b, c, d, t0 = 0.4, 1.8, 1.5, 2.0, 1.0
    one = check(four_bar(a, b, c, d, t0)).drivers[0]
    A = (a * math.cos(t0), a * math.sin(t0))
    B = next(j.at for j in four_bar(a, b, c, d, t0).joints if j.name == "B")
    bld = MechanismBuilder("twin")
    bld.add_link("frame", frame=True)
    for k, dx in ((1, 0.0), (2, 10.0)):
        for lk in ("crank", "coupler", "rocker"):
            bld.add_link(f"{lk}{k}")
        bld.add_joint(f"O{k}", "R", ("frame", f"crank{k}"), at=(dx, 0.0))
        bld.add_joint(f"A{k}", "R", (f"crank{k}", f"coupler{k}"), at=(A[0] + dx, A[1]))
        bld.add_joint(f"B{k}", "R", (f"coupler{k}", f"rocker{k}"), at=(B[0] + dx, B[1]))
        bld.add_joint(f"C{k}", "R", (f"rocker{k}", "frame"), at=(d + dx, 0.0))
        bld.add_driver(f"O{k}")
    rep = check(bld.build())
    for k, dc in enumerate(rep.drivers, start=1):
        dead = dict(dc.dead_centres)
        assert dead[f"rocker{3 - k}"] == () and dead[f"crank{3 - k}"] == ()
        assert dead[f"rocker{k}"] == pytest.approx(dict(one.dead_centres)["rocker"], abs=1e-9)
        assert dc.output == f"rocker{k}"


# ---------------------------------------------------------------- driver_angles (the narrow route)
@pytest.mark.parametrize("name", ["four_bar", "knitting_needle_drive", "stephenson_3_triad", "crank_slider"])
def test_driver_angles_equal_the_check_s(name):
    from multiloop.kin.check import driver_angles
    m = load(CAT / f"{name}.toml")
    dc = check(m).drivers[0]
    da = driver_angles(m)
    assert (da.joint, da.rotary, da.full_rotation, da.limits) == (dc.joint, dc.rotary, dc.full_rotation, dc.limits)
    assert da.angles == dc.angles             # the same exact extremes, bit for bit
    assert da.flagged(40.0) == tuple(a for a in dc.angles if a.flagged(40.0))


def test_driver_angles_of_a_limited_crank_and_bad_index():
    from multiloop.kin.check import driver_angles
    from multiloop.topo.errors import InputError
    m = four_bar(1.0, 1.0, 2.0, 2.5, math.radians(60.0))      # triple rocker: two limits
    da, dc = driver_angles(m), check(m).drivers[0]
    assert not da.full_rotation and len(da.limits) == 2 and da.limits == dc.limits
    assert da.angles == dc.angles
    assert da.flagged(20.0)                   # stretched to 180° at its limits
    with pytest.raises(InputError, match="driver index"):
        driver_angles(m, 1)


def test_readme_check_example_is_what_check_prints(capsys):
    """Issue 36 part 2, 4: the README's ``multiloop check`` example had fallen behind the
    command's output (the velocity ratio's extremes gained their positions)."""
    import re
    root = Path(__file__).resolve().parents[1]
    readme = (root / "README.md").read_text()
    block = re.search(r"```\n\$ multiloop check catalogue/mechanisms/four_bar.toml[^\n]*\n(.*?)```", readme, re.S)
    assert block is not None
    assert main(["check", str(root / "catalogue/mechanisms/four_bar.toml")]) == 0
    assert capsys.readouterr().out.strip() == block.group(1).strip()


def test_four_bar_loops_come_in_the_same_order_whatever_the_hash_seed():
    """Before: the loops were walked over Python sets of link names, so ``check --json`` of
    knitting_needle_drive and watt_2 listed them in another order from one run to the next."""
    import subprocess
    import sys
    code = ("from multiloop.inputs import load_mechanism; from multiloop.kin.check.grashof import four_bar_loops;"
            "print([l.links for n in ('knitting_needle_drive', 'watt_2') for l in four_bar_loops(load_mechanism(n))])")
    runs = {subprocess.run([sys.executable, "-c", code], env={**os.environ, "PYTHONHASHSEED": str(seed)},
                           capture_output=True, text=True, check=True).stdout for seed in range(6)}
    assert len(runs) == 1, runs


def test_the_drawing_and_the_check_of_one_design_compute_its_motion_once(monkeypatch):
    """driver_angles (the page's motion) then check, twice: each driver's motion is
    solved once, and the reports are equal to a fresh check's."""
    from multiloop.kin.check import core, driver_angles
    from multiloop.kin.check.motion import driver_motion
    m = load(CAT / "excavator.toml")
    fresh = check(m).as_dict()
    calls = []
    monkeypatch.setattr(core, "driver_motion", lambda *a, **k: calls.append(a[2]) or driver_motion(*a, **k))
    m2 = load(CAT / "excavator.toml")
    angles = [driver_angles(m2, k) for k in range(len(m2.drivers))]
    reports = [check(m2).as_dict(), check(m2).as_dict()]
    assert sorted(calls) == list(range(len(m2.drivers)))
    assert reports[0] == reports[1] == fresh
    assert [sorted(a.limits) for a in angles] == [sorted(d["limits"]) for d in fresh["drivers"].values()]


def test_smooth_roots_and_extremes_finish_in_three_solver_calls(monkeypatch):
    """A smooth root or extreme is zoomed until its samples are 1e-4 rad apart, then
    finished by the secant's root or the parabola's vertex and one window of ± 1e-10
    around it: three solver calls per refinement (the zoom alone took six or seven); a
    kink (|velocity ratio| at the rocker's dead centres) by the corner of two lines once
    its samples are 2e-6 rad apart: four.  The four-bar's dead centres and transmission
    extremes keep their oracles (the Hypothesis tests above)."""
    from multiloop.kin.check import sweep
    calls = []
    for name in ("bisect", "golden"):
        refine = getattr(sweep.Side, name)

        def counting(self, *a, _refine=refine, _name=name, **k):
            before = len(sampled)
            out = _refine(self, *a, **k)
            calls.append((_name, len(sampled) - before))
            return out
        monkeypatch.setattr(sweep.Side, name, counting)
    sampled = []
    sample = sweep.Side._sample

    def counted(self, *a, **k):
        sampled.append(1)
        return sample(self, *a, **k)
    monkeypatch.setattr(sweep.Side, "_sample", counted)
    m = four_bar(0.2, 1.8, 1.5, 2.0, 0.7)
    dc = check(m).drivers[0]
    assert dict(dc.dead_centres)["rocker"] and calls
    assert [n for n, _ in calls] == ["bisect", "golden", "golden"]     # roots, ratio, angles
    assert [k for _, k in calls] == [3, 4, 3]


def test_a_kink_is_zoomed_to_the_end():
    """A pressure angle's minimum |·| = 0 is a kink, not a parabola: the second
    differences disagree, so it is zoomed to 1e-10 rad as before, and its minimum is 0°
    to 1e-9° (an offset crank-slider's slider passes straight below the crank pin)."""
    m = crank_slider(1.0, 3.0, 0.0, 0.3)
    dc = check(m).drivers[0]
    ext = [a.extreme for a in dc.angles if a.quantity == "pressure"]
    assert ext and all(abs(e.min) <= 1e-9 for e in ext)


@pytest.mark.parametrize("name", ["excavator", "knuckle_boom_crane", "stephenson_3_triad"])
def test_drivers_checked_apart_give_check_s_report_bit_for_bit(name):
    """A check's drivers are independent: each computed on its own copy of the design (as
    another process would, from a pickle), with its angles computed apart too
    (``driver_angles``), the report is ``check``'s, bit for bit."""
    import pickle

    from multiloop.catalogue.named import load_named
    from multiloop.kin.check import driver_angles, driver_check
    m = load_named(name)

    def copy():
        return pickle.loads(pickle.dumps(m))
    dcs = []
    for k in range(len(m.drivers)):
        angles = driver_angles(copy(), k).angles
        calls = []
        dcs.append(pickle.loads(pickle.dumps(driver_check(copy(), k, angles=lambda a=angles: calls.append(1) or a))))
        assert calls == [1]
    apart = check(copy(), driver_checks=tuple(dcs)).as_dict()
    assert json.dumps(apart, sort_keys=True) == json.dumps(check(m).as_dict(), sort_keys=True)


def test_driver_checks_of_other_drivers_are_refused_by_name():
    from multiloop.catalogue.named import load_named
    from multiloop.kin.check import driver_check
    from multiloop.topo.errors import ParameterError
    m = load_named("excavator_bucket")
    with pytest.raises(ParameterError, match="bucket_cyl_slide, thumb_cyl_slide"):
        check(m, driver_checks=(driver_check(m, 1),))
    with pytest.raises(Exception, match="driver index"):
        driver_check(m, 2)
