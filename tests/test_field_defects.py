"""Regression tests of the defects found by the field runs (wrong answers, round trips,
readers that trusted their input, messages that exploded)."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from multiloop.cli import main
from multiloop.inputs import load_mechanism
from multiloop.kin.forces import forces, kinetic_energy, potential_energy
from multiloop.kin.solve import solve
from multiloop.topo.io import load, mechanism_to_dict
from multiloop.topo.model import Link, MechanismBuilder

ROOT = Path(__file__).resolve().parents[1]
FOUR_BAR = ROOT / "catalogue/mechanisms/four_bar.toml"


def _canonical(m) -> str:
    return json.dumps(mechanism_to_dict(m), sort_keys=True)


# --- 1. convert writes files multiloop reads back ---------------------------------------
@pytest.mark.parametrize("suffix", [".toml", ".json"])
def test_convert_of_a_force_table_reads_back(tmp_path, capsys, suffix):
    out = tmp_path / f"out{suffix}"
    assert main(["convert", "crank_slider_loaded", str(out)]) == 0
    assert main(["analyse", str(out)]) == 0, capsys.readouterr().err
    assert _canonical(load(out)) == _canonical(load_mechanism("crank_slider_loaded"))


# --- 2. a massless link's moment of inertia ---------------------------------------------
def _rocker_inertia_only(mass):
    b = MechanismBuilder.from_mechanism(load(FOUR_BAR))
    b.links = [Link(lk.name, lk.is_frame, mass, lk.cg, 0.01, lk.color) if lk.name == "rocker" else lk
               for lk in b.links]
    b.drivers = [type(d)(d.joint, d.links, 20.0, d.acceleration) for d in b.drivers]
    return b.build()


def test_massless_link_inertia_loads_the_balancing_moment():
    """M_b ω = d(T)/dt (energy method; no gravity, no applied load) for a rocker with
    J = 0.01 kg m² and no mass; the field value was |M_b| up to 4.03 N m."""
    m = _rocker_inertia_only(None)
    q = np.radians(np.arange(0.0, 360.0, 5.0))[:, None]
    fr = forces(m, q, accelerations=np.zeros(1))
    ok = fr.ok
    assert ok.sum() > 60
    w, h = 20.0, 1e-6

    def energy(t):
        s = solve(m, q + w * t, derivatives=True, input_rates=np.array([w]))
        return kinetic_energy(s) + potential_energy(s)
    dE = (energy(h) - energy(-h)) / (2 * h)
    mb = fr.balancing[:, 0]
    np.testing.assert_allclose(mb[ok] * w, dE[ok], atol=1e-5 * np.abs(dE).max())
    assert 3.9 < np.abs(mb[ok]).max() < 4.2
    # and the tiny-mass route agrees with the massless one
    tiny = forces(_rocker_inertia_only(1e-9), q, accelerations=np.zeros(1))
    np.testing.assert_allclose(tiny.balancing[ok], fr.balancing[ok], atol=1e-6)


# --- 3-5. the .pyslvs writer: names, frame-second drivers, what is lost ------------------
def _four_bar_edit(old: str, new: str, count: int = -1) -> str:
    text = FOUR_BAR.read_text()
    assert old in text
    return text.replace(old, new, count)


@pytest.mark.parametrize("bad", ["cou,pler", "cou]pler", "cou pler", "9coupler"])
def test_pyslvs_writer_refuses_names_pyslvs_would_read_differently(tmp_path, capsys, bad):
    f = tmp_path / "m.toml"
    f.write_text(_four_bar_edit('"coupler"', json.dumps(bad)))
    out = tmp_path / "m.pyslvs"
    assert main(["convert", str(f), str(out)]) == 2
    err = capsys.readouterr().err
    assert "Pyslvs link name" in err and str(f) in err and not out.exists()


def test_point_named_like_a_joint_is_refused(tmp_path, capsys):
    f = tmp_path / "m.toml"
    f.write_text(_four_bar_edit('name = "P"', 'name = "A"'))
    assert main(["solve", str(f)]) == 2
    assert "[[point]] 'A': expected a name no joint has" in capsys.readouterr().err


def test_frame_second_driver_is_exported_with_the_input_negated(tmp_path, capsys):
    f = tmp_path / "m.toml"
    f.write_text(_four_bar_edit('joint = "O2"', 'joint = "O2"\nlinks = ["crank", "frame"]'))
    out = tmp_path / "m.pyslvs"
    assert main(["convert", str(f), str(out)]) == 0
    assert "input is negated" in capsys.readouterr().err
    back = load_mechanism(out)
    assert back.drivers[0].links == ("ground", "crank")
    q = np.radians([[10.0], [50.0]])
    mine, theirs = solve(load(f), -q), solve(back, q)
    np.testing.assert_allclose(mine.positions, theirs.positions, atol=1e-9)


def test_pyslvs_export_names_what_it_drops(tmp_path, capsys):
    out = tmp_path / "m.pyslvs"
    assert main(["convert", "crank_slider_loaded", str(out)]) == 0
    err = capsys.readouterr().err
    for word in ("masses", "forces", "joint names"):
        assert word in err, err
    assert main(["convert", str(out), str(tmp_path / "again.pyslvs")]) == 0
    assert "does not keep" not in capsys.readouterr().err     # nothing more to lose


def test_convert_of_a_bare_chain_names_the_file(tmp_path, capsys):
    f = tmp_path / "chain.toml"
    f.write_text('joints = [["a", "b"], ["b", "c"], ["c", "d"], ["d", "a"]]\n')
    assert main(["convert", str(f), str(tmp_path / "x.pyslvs")]) == 2
    err = capsys.readouterr().err
    assert str(f) in err and "'None'" not in err


# --- 6-8, 10. readers that trusted their input -------------------------------------------
EXPR = ("M[J[R, color[Green], P[0, 0], L[ground, L1]], J[R, color[Green], P[10, 0], L[L1, L2]], "
        "J[R, color[Green], P[30, 20], L[L2, L3]], J[R, color[Green], P[40, 0], L[ground, L3]]]")
PYSLVS_BAD = {
    "nan": ("mechanism: " + EXPR.replace("P[0, 0]", "P[nan, 0]") + "\ninput: [[0, 1]]\n", "finite"),
    "inf_angle": ("mechanism: " + EXPR.replace("J[R, color[Green], P[10", "J[P, A[inf], color[Green], P[10")
                  + "\ninput: [[0, 1]]\n", "finite"),
    "input_5": ("mechanism: " + EXPR + "\ninput: 5\n", "joint-index pairs"),
    "input_bool": ("mechanism: " + EXPR + "\ninput: [[true, 1]]\n", "joint indices"),
    "input_negative": ("mechanism: " + EXPR + "\ninput: [[-4, 1]]\n", "joint indices"),
    "deep": ("[" * 100_000 + "]" * 100_000, "nested at most"),
    "alias_bomb": ("a: &a [x, x, x, x, x, x, x, x, x]\nb: &b [*a, *a, *a, *a, *a, *a, *a, *a, *a]\n"
                   "c: &c [*b, *b, *b, *b, *b, *b, *b, *b, *b]\nd: [*c, *c, *c, *c, *c, *c, *c, *c, *c]\n"
                   "mechanism: x\n", "without anchors or aliases"),
    "huge_int": ("mechanism: " + EXPR + "\ninput: [[0, 1" + "0" * 5000 + "]]\n", "unreadable"),
    "latin1": ("mechanism: caf\xe9\n".encode("latin-1"), "UTF-8"),
}


@pytest.mark.parametrize("case", sorted(PYSLVS_BAD))
def test_pyslvs_reader_refuses_with_exit_2(tmp_path, capsys, case):
    text, words = PYSLVS_BAD[case]
    f = tmp_path / "m.pyslvs"
    f.write_bytes(text if isinstance(text, bytes) else text.encode())
    assert main(["convert", str(f), str(tmp_path / "out.toml")]) == 2
    err = capsys.readouterr().err
    assert words in err and len(err) < 10_000, err[:500]
    assert not (tmp_path / "out.toml").exists()


@pytest.mark.parametrize("suffix,text", [
    (".toml", _four_bar_edit("at = [0.1, 0.0]", "at = [1" + "0" * 400 + ", 0.0]")),
    (".json", '{"joints": [["a", "b"], ["b", "a"]], "gravity": [1' + "0" * 400 + ", 0]}"),
    (".json", '{"joints": [["a", "b"], ["b", "a"]], "gravity": [1' + "0" * 5000 + ", 0]}"),
    (".toml", "gravity = [1" + "0" * 5000 + ", 0]\n"),
])
def test_integers_beyond_the_float_range_exit_2(tmp_path, capsys, suffix, text):
    f = tmp_path / f"m{suffix}"
    f.write_text(text)
    assert main(["analyse", str(f)]) == 2
    err = capsys.readouterr().err
    assert "internal error" not in err and ("float range" in err or "sensible size" in err), err


def test_non_regular_input_files_are_refused(tmp_path, capsys):
    import os
    fifo = tmp_path / "pipe.toml"
    os.mkfifo(fifo)
    zero = tmp_path / "zero.pyslvs"
    zero.symlink_to("/dev/zero")
    for f in (fifo, zero):
        assert main(["analyse", str(f)]) == 2
        assert "expected a regular file" in capsys.readouterr().err
    big = tmp_path / "big.toml"
    big.write_bytes(b"# " + b"x" * (9 << 20))
    assert main(["analyse", str(big)]) == 2
    assert "at most 8 MiB" in capsys.readouterr().err


def test_two_thousand_coincident_joints_give_a_short_message(tmp_path, capsys):
    lines = [f'[[joint]]\nname = "J{i}"\nlinks = ["a{i}", "a{i + 1}"]\nat = [0.0, 0.0]\n' for i in range(2000)]
    f = tmp_path / "pile.toml"
    f.write_text("\n".join(lines))
    assert main(["analyse", str(f)]) == 2
    err = capsys.readouterr().err
    assert len(err) < 10_000 and "or more problems" in err and "... and" in err, err[:300]


def test_lone_surrogate_and_non_utf8_terminal(tmp_path, capsys, monkeypatch):
    import io
    import sys
    f = tmp_path / "m.json"
    f.write_text('{"joints": [["a\\ud800", "b"], ["b", "c"], ["c", "a"]]}')
    assert main(["analyse", str(f)]) == 2
    assert "lone surrogate" in capsys.readouterr().err
    latin = io.TextIOWrapper(io.BytesIO(), encoding="ascii")
    monkeypatch.setattr(sys, "stdout", latin)
    g = tmp_path / "u.toml"
    g.write_text(_four_bar_edit('"coupler"', '"шатун"'))
    assert main(["solve", str(g), "--steps", "3"]) == 0
    latin.flush()
    assert b"\\u2192" in latin.buffer.getvalue()   # the arrow of the structure formula


# --- 7. huge numbers on the command line ---------------------------------------------------
@pytest.mark.parametrize("argv,words", [
    (["solve", "four_bar", "--from", "0", "--to", "1e308", "--steps", "5"], "at most 1e+09 deg"),
    (["solve", "stephenson_3_triad", "--from", "1e20", "--to", "1e20"], "at most 1e+09 deg"),
    (["solve", "dyad_rrp", "--from", "0", "--to", "1e12"], "at most"),
    (["atlas", "--links", "6", "--dof", "1", "--limit", str(2 ** 63)], "--limit"),
    (["atlas", "--links", "6", "--dof", "1", "--limit", "-1"], "--limit"),
    (["atlas", "--links", "6", "--dof", str(2 ** 63)], "--dof"),
    (["atlas", "--links", "6", "--dof", "1", "--max-multiplicity", str(2 ** 63)], "--max-multiplicity"),
    (["atlas", "--links", "6", "--dof", "1", "--max-link-degree", str(2 ** 64)], "--max-link-degree"),
    (["atlas", "--links", "6", "--dof", "1", "--workers", str(2 ** 63)], "--workers"),
    (["atlas", "--links", "6", "--dof", "1", "--html", "h", "--html-limit", str(2 ** 63)], "--html-limit"),
    (["atlas", "--links", "6", "--dof", "1", "--query", "K ="], "--query"),
])
def test_out_of_range_numbers_exit_2_and_create_nothing(tmp_path, monkeypatch, capsys, argv, words):
    monkeypatch.chdir(tmp_path)
    assert main(argv + (["--db", "a.sqlite"] if argv[0] == "atlas" else [])) == 2
    err = capsys.readouterr().err
    assert words in err and "internal" not in err, err
    assert not list(tmp_path.iterdir()), "a rejected run created a file"


def test_dof_hint_covers_every_f(capsys):
    assert main(["atlas", "--links", "6", "--dof", "4", "--db", ":memory:"]) == 2
    assert "an even F (2, 4, …) an odd n" in capsys.readouterr().err


def test_atlas_disk_full_is_reported_as_disk_full(tmp_path):
    from multiloop.catalogue.atlas import Atlas
    from multiloop.catalogue.synthesis import SynthesisOptions
    from multiloop.topo.errors import OutputError
    with Atlas(tmp_path / "full.sqlite") as atlas:
        pages = atlas.con.execute("PRAGMA page_count").fetchone()[0]
        atlas.con.execute(f"PRAGMA max_page_count = {pages + 2}")   # SQLITE_FULL, as a full disk
        with pytest.raises(OutputError, match="disk full"):
            atlas.build(SynthesisOptions(10, 1), progress=False, workers=1)


def test_atlas_list_columns_match_the_printed_form(tmp_path, capsys):
    db = str(tmp_path / "a.sqlite")
    assert main(["atlas", "--links", "8", "--dof", "1", "--db", db, "--no-progress", "--json"]) == 0
    capsys.readouterr()
    counts = []
    for q in ("La = '4-4-6-6'", "La = '[4, 4, 6, 6]'", "LA = '4-4'"):
        assert main(["atlas", "--db", db, "--query", q, "--json"]) == 0
        counts.append(json.loads(capsys.readouterr().out)["count"])
    assert counts[0] == counts[1] > 0 and counts[2] > 0


def test_engine_json_has_no_bare_nan():
    import dataclasses
    from multiloop.catalogue.engines import single_cylinder_spec
    from multiloop.kin.engine import analyse_engine
    res = analyse_engine(single_cylinder_spec(), 72, check=False)
    bad = dataclasses.replace(res, balancing=np.full_like(res.balancing, np.nan), cycle_integral=math.nan)
    doc = json.loads(json.dumps(bad.as_dict(), allow_nan=False))
    assert doc["balancing"][0] is None and doc["cycle_integral"] is None


# --- 11. dyad_rpr under scale and translation ---------------------------------------------
def _moved(m, k, off):
    from multiloop.topo.model import Joint, TracerPoint
    b = MechanismBuilder.from_mechanism(m)
    b.joints = [Joint(j.name, j.kind, j.links, (j.at[0] * k + off[0], j.at[1] * k + off[1]), j.axis) for j in b.joints]
    b.points = [TracerPoint(p.name, p.link, (p.at[0] * k + off[0], p.at[1] * k + off[1])) for p in b.points]
    return b.build()


def _reference_relative_dets(m):
    """The relative determinant of every Assur group of ``m`` at its reference pose."""
    from multiloop.kin.groups.newton import ConstraintSystem, relative_det
    from multiloop.topo.assur import AssurGroup, decompose
    from multiloop.topo.constraints import link_origins
    org = link_origins(m)
    Z = np.zeros((1, m.n_links, 3))
    Z[0, :, :2] = [org[x] for x in m.link_names]
    out = []
    for s in decompose(m).steps:
        if isinstance(s, AssurGroup):
            u = [m.link_names.index(x) for x in s.links]
            cols = (3 * np.asarray(u)[:, None] + np.arange(3)).ravel()
            out.append(relative_det(ConstraintSystem.compile(m, s.constraints).jacobian(Z)[0][:, cols]))
    return np.array(out)


@pytest.mark.parametrize("name", ["dyad_rpr", "dyad_prp", "stephenson_3_triad", "six_bar_slider"])
@pytest.mark.parametrize("k,off", [(1e-12, (3.0, 5.0)), (1e-8, (0.0, 0.0)), (1e8, (-2.0, 7.0)), (1.0, (1e6, 1e6))])
def test_relative_det_is_invariant_under_scale_and_translation(name, k, off):
    m1 = load_mechanism(name)
    d1 = _reference_relative_dets(m1)
    dk = _reference_relative_dets(_moved(m1, k, (off[0] * k, off[1] * k)))
    assert d1.min() > 1e-3
    np.testing.assert_allclose(dk, d1, rtol=1e-6)


@pytest.mark.parametrize("k", [1e-12, 1e8])
def test_newton_tracks_dyad_rpr_at_any_scale(k, monkeypatch):
    """The Newton route's singularity measure does not depend on the unit: the dyad
    scaled by k and moved by (3k, 5k) tracks all 36 positions (the reference check of
    compile_plan is bypassed here)."""
    import multiloop.kin.solve as ks
    monkeypatch.setattr(ks, "_SINGULAR", 0.0)
    m1 = load_mechanism("dyad_rpr")
    q = np.radians(np.arange(0.0, 360.0, 10.0))
    ref, st = solve(m1, q, method="newton"), solve(_moved(m1, k, (3 * k, 5 * k)), q, method="newton")
    assert st.ok.sum() == ref.ok.sum() == 36
    np.testing.assert_allclose(st.positions / k - np.array([3.0, 5.0]), ref.positions, atol=1e-9)


def test_dyad_rpr_solves_at_scale_1e_minus_8():
    m = _moved(load_mechanism("dyad_rpr"), 1e-8, (0.0, 0.0))
    assert solve(m, np.radians(np.arange(0.0, 360.0, 10.0))).ok.all()


# --- 12. names with $ in plots, log-axis ticks, warnings -----------------------------------
@pytest.mark.parametrize("cmd", ["solve", "forces", "check"])
def test_dollar_names_plot(tmp_path, capsys, cmd):
    f = tmp_path / "d.toml"
    f.write_text(FOUR_BAR.read_text().replace('"O2"', '"$O_2$"').replace('"coupler"', '"$x^{$"')
                 .replace('name = "P"', 'name = "$\\\\alpha"'))
    out = tmp_path / "p.png"
    assert main([cmd, str(f), "--plot", str(out)]) == 0, capsys.readouterr().err
    assert out.stat().st_size > 0


def test_log_axis_ticks_stay_mathtext_and_names_literal():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from multiloop.kin.figures.style import no_mathtext
    fig, ax = plt.subplots()
    ax.plot([1, 2, 3], [10, 100, 1000], label="$x^{$")
    ax.set_yscale("log")
    ax.legend()
    ax.set_title("cost $5 $6")
    no_mathtext(fig)
    fig.canvas.draw()
    ticks = [t.get_text() for t in ax.get_yticklabels() if t.get_text()]
    assert ticks and all("mathdefault" in t for t in ticks)
    assert ax.get_title() == "cost \\$5 \\$6"
    assert ax.get_legend().get_texts()[0].get_text() == "\\$x^{\\$"
    plt.close(fig)


def test_warnings_are_one_line_without_source_paths(capsys):
    assert main(["forces", "dyad_prp", "--steps", "360"]) == 0
    err = capsys.readouterr().err
    assert "multiloop forces: warning: singular positions" in err
    assert ".py:" not in err and "SingularityWarning" not in err


# --- Smaller -------------------------------------------------------------------------------
def test_readme_pyslvs_example_is_shipped_and_prints_what_the_readme_shows(monkeypatch, capsys):
    readme = (ROOT / "README.md").read_text()
    monkeypatch.chdir(ROOT / "docs/examples")
    assert main(["decompose", "crank_slider_rp.pyslvs"]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first in readme and first.startswith("structure formula: I(0,1)")


def test_convert_writes_one_line_per_vector(tmp_path):
    out = tmp_path / "c.toml"
    assert main(["convert", "crank_slider_loaded", str(out)]) == 0
    text = out.read_text()
    assert "\nat = [" in text and "at = [\n" not in text and "links = [\n" not in text
    assert _canonical(load(out)) == _canonical(load_mechanism("crank_slider_loaded"))


def test_check_options(tmp_path, capsys):
    chain = tmp_path / "chain.toml"
    chain.write_text('joints = [["a", "b"], ["b", "c"], ["c", "d"], ["d", "a"]]\n')
    assert main(["check", str(chain)]) == 2
    assert str(chain) in capsys.readouterr().err
    assert main(["check", "four_bar", "--min-transmission", "100"]) == 2
    assert "between 0 and 90" in capsys.readouterr().err
    assert main(["check", "four_bar", "--output", "B", "--json"]) == 0
    assert "joint B" in json.dumps(json.loads(capsys.readouterr().out))
    for argv in (["--positions", "-60", "120"], ["--positions=-60,120"], ["--positions", "30,60"]):
        assert main(["check", "four_bar", "--json", *argv]) == 0, argv
        json.loads(capsys.readouterr().out)


def test_solve_plot_draws_a_regular_pose(tmp_path, monkeypatch):
    from multiloop.kin.figures import mechanism as fm
    shown = []
    real = fm.plot_mechanism
    monkeypatch.setattr(fm, "plot_mechanism", lambda st, index=0, **kw: shown.append(index) or real(st, index, **kw))
    # dyad_prp's guides are parallel (singular) at 120 deg: a sweep starting there
    assert main(["solve", "dyad_prp", "--from", "120", "--to", "150", "--steps", "4",
                 "--plot", str(tmp_path / "p.png")]) == 0
    assert shown == [1]


# --- found by the fuzzing stage ----------------------------------------------------------
@pytest.mark.parametrize("seed,old,new", [
    ("platforms/doronin_platform.toml", "center = [-2.0, -1.5, 0.0]", "center = [-2.0, -1e308, 0.0]"),
    ("platforms/doronin_platform.toml", "g = 9.81", "g = 1e308"),
    ("platforms/doronin_platform.toml", "weight = 2500.0", "weight = 1e-320"),
    ("engines/single_cylinder.toml", "bore = 0.072", "bore = 1e308"),
    ("engines/single_cylinder.toml", "rod_length = 0.110", "rod_length = 1e308"),
    ("engines/single_cylinder.toml", "compression_ratio = 10.0", "compression_ratio = 1e308"),
    ("engines/single_cylinder.toml", "n_compression = 1.35", "n_compression = 1e308"),
])
def test_extreme_engine_and_platform_numbers_exit_2(tmp_path, capsys, seed, old, new):
    text = (ROOT / "catalogue" / seed).read_text()
    assert old in text
    f = tmp_path / "x.toml"
    f.write_text(text.replace(old, new))
    argv = ["platform", str(f)] if seed.startswith("platforms") else ["engine", str(f), "--steps", "16"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "internal error" not in err and err.startswith("multiloop"), err
