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


# --- 3, 4. damaged curve atlases ---------------------------------------------------------
@pytest.fixture(scope="module")
def curve_atlas(tmp_path_factory):
    pytest.importorskip("usearch")
    from multiloop.catalogue.synthesis import nauty_available
    from tests.common import four_bar_curve_atlas
    if not nauty_available():
        pytest.skip("nauty's geng/genbg not installed")
    return four_bar_curve_atlas(tmp_path_factory.mktemp("atlas") / "atlas.sqlite")


def _damaged(src: Path, dst: Path, sql: str, params=()) -> Path:
    import sqlite3
    dst.write_bytes(src.read_bytes())
    con = sqlite3.connect(dst)
    con.executescript(sql) if not params else con.execute(sql, params)
    con.commit()
    con.close()
    return dst


def _flipped(data: bytes, seed: int = 1, bits: int = 40) -> bytes:
    import random
    rng, b = random.Random(seed), bytearray(data)
    for _ in range(bits):
        b[rng.randrange(len(b))] ^= 1 << rng.randrange(8)
    return bytes(b)


def _stored_graph(db: Path) -> bytes:
    import sqlite3
    con = sqlite3.connect(db)
    try:
        return con.execute("SELECT data FROM curve_indexes WHERE n = 4").fetchone()[0]
    finally:
        con.close()


_INDEX_KIND = """
import sys
from multiloop.catalogue.atlas import Atlas
from multiloop.catalogue.curve_atlas import CurveIndex
with Atlas(sys.argv[1], readonly=True) as atlas:
    ix, exact = CurveIndex(atlas), CurveIndex(atlas, exact=True)
    same = all(abs(ix.query(q, 1)[0].distance - exact.query(q, 1)[0].distance) < 1e-6 for q in exact.vectors)
    print(ix.kind, same)
"""


@pytest.mark.parametrize("damage", ["flip", "truncate", "empty", "text"])
def test_a_stored_graph_that_fails_its_checksum_is_rebuilt_from_the_curves(curve_atlas, tmp_path, damage):
    """Flipped bytes crashed usearch's reader (signal 11): the child process runs the
    index so that a crash is a failed assertion, not a lost test run."""
    import subprocess
    import sys
    data = _stored_graph(curve_atlas)
    new = {"flip": _flipped(data), "truncate": data[: len(data) // 2], "empty": b"", "text": "a graph"}[damage]
    db = _damaged(curve_atlas, tmp_path / "a.sqlite", "UPDATE curve_indexes SET data = ? WHERE n = 4", (new,))
    proc = subprocess.run([sys.executable, "-c", _INDEX_KIND, str(db)], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-1500:]
    assert proc.stdout.split() == ["usearch-hnsw", "True"]          # rebuilt in memory, same answers
    assert "table curve_indexes row 4: the stored graph fails its SHA-256 checksum" in proc.stderr


def test_synthesis_on_an_atlas_with_a_flipped_graph_gives_designs(curve_atlas, tmp_path):
    import subprocess
    import sys
    db = _damaged(curve_atlas, tmp_path / "a.sqlite", "UPDATE curve_indexes SET data = ? WHERE n = 4",
                  (_flipped(_stored_graph(curve_atlas)),))
    st = solve(load(FOUR_BAR), np.radians(np.arange(0.0, 360.0, 15.0)))
    target = tmp_path / "t.csv"
    np.savetxt(target, st.point_positions[:, 0], delimiter=",")
    out = tmp_path / "o.toml"
    proc = subprocess.run([sys.executable, "-m", "multiloop", "synthesise", "--path", str(target), "--out", str(out),
                           "--db", str(db), "--links", "4", "--budget", "5", "--top", "1"],
                          capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0 and out.is_file(), proc.stderr[-1500:]
    assert "fails its SHA-256 checksum; it is rebuilt from the curves" in proc.stderr


def test_an_atlas_without_checksums_rebuilds_its_graphs_and_its_next_build_stores_them(curve_atlas, tmp_path):
    """An atlas written before the checksum column: its graph is not trusted (built from
    the curves in memory); the next build adds the column and stores the checksum."""
    from multiloop.catalogue.atlas import Atlas
    from multiloop.catalogue.curve_atlas import CurveIndex
    db = _damaged(curve_atlas, tmp_path / "old.sqlite",
                  "CREATE TABLE old AS SELECT n, curves, data FROM curve_indexes; DROP TABLE curve_indexes; "
                  "CREATE TABLE curve_indexes (n INTEGER PRIMARY KEY, curves INTEGER NOT NULL, data BLOB NOT NULL); "
                  "INSERT INTO curve_indexes SELECT * FROM old; DROP TABLE old;")
    with Atlas(db, readonly=True) as atlas:
        assert CurveIndex(atlas).kind == "usearch-hnsw"
    assert main(["atlas", "--links", "4", "--dof", "1", "--simple-joints", "--no-loops", "--mechanisms",
                 "--curves", "6", "--db", str(db), "--no-progress"]) == 0
    with Atlas(db, readonly=True) as atlas:
        assert CurveIndex(atlas).kind == "usearch-hnsw (stored)"


_CORRUPTIONS = {
    # name: (SQL, command, what the message says)
    "descriptor-short": ("UPDATE curves SET descriptor = substr(descriptor, 1, 64) WHERE id = 1", "build",
                         "table curves row 1: expected descriptor: a BLOB of 128 bytes, got a BLOB of 64 bytes"),
    "descriptor-text": ("UPDATE curves SET descriptor = 'text' WHERE id = 1", "build",
                        "table curves row 1: expected descriptor: a BLOB of 128 bytes, got the text 'text'"),
    "descriptor-empty": ("UPDATE curves SET descriptor = x'' WHERE id = 1", "build",
                         "table curves row 1: expected descriptor: a BLOB of 128 bytes, got a BLOB of 0 bytes"),
    "shape-short": ("UPDATE curves SET shape = substr(shape, 1, 100)", "synthesise",
                    "expected shape: a BLOB of 512 bytes, got a BLOB of 100 bytes"),
    "shape-text": ("UPDATE curves SET shape = 'x'", "synthesise", "expected shape: a BLOB of 512 bytes, got the text"),
    "radius-zero": ("UPDATE curves SET radius = 0", "synthesise", "expected radius: a finite number > 0, got 0"),
    "radius-nan": ("UPDATE curves SET radius = 'NaN'", "synthesise",
                   "expected radius: a finite number > 0, got the text 'NaN'"),
    "realisation-json": ("UPDATE realisations SET joints = '{garbage'", "synthesise",
                         "table realisations row 1: expected joints: a JSON object of 4 positions"),
    "index-schema": ("DROP TABLE curve_indexes; CREATE TABLE curve_indexes (a TEXT, b BLOB)", "synthesise",
                     "table curve_indexes: expected the columns n, curves, data, sha256, got the columns a, b"),
    "chain-utf8": ("UPDATE chains SET LA = CAST(x'c328ff' AS TEXT)", "query",
                   "table chains row 1: expected LA: UTF-8 text, got an undecodable byte"),
    "chain-json": ("UPDATE chains SET joints = '[[0, 99]]'", "query",
                   "table chains row 1: expected joints: a JSON list of lists of link indices below 4"),
    # found by the fuzzing stage (MULTILOOP_FUZZ=5000, case 1851): the build's row gone, its tasks collide
    "builds-dropped": ("DROP TABLE builds", "build",
                       "expected an intact atlas, got IntegrityError: UNIQUE constraint failed: tasks.build_id"),
    # found by the fuzzing stage (MULTILOOP_FUZZ=5000, case 4475): int('garbage') in the counts, exit 1
    "mechanism-class": ("UPDATE mechanisms SET class = 'garbage' WHERE rowid = 1", "build",
                        "table mechanisms row of class 'garbage': expected class: an integer from 0 to 100"),
}


@pytest.mark.parametrize("case", sorted(_CORRUPTIONS))
def test_a_damaged_atlas_exits_2_naming_the_table_and_the_row(curve_atlas, tmp_path, capsys, case):
    sql, command, words = _CORRUPTIONS[case]
    db = _damaged(curve_atlas, tmp_path / "a.sqlite", sql)
    target = tmp_path / "t.csv"
    target.write_text(_circle(0.05, 40))
    argv = {"synthesise": ["synthesise", "--path", str(target), "--out", str(tmp_path / "o.toml"), "--db", str(db),
                           "--links", "4", "--budget", "1"],
            "query": ["atlas", "--db", str(db), "--query", "n = 4"],
            "build": ["atlas", "--links", "4", "--dof", "1", "--simple-joints", "--no-loops", "--mechanisms",
                      "--curves", "6", "--db", str(db), "--no-progress"]}[command]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"error: atlas '{db}': {words}" in err or f"error: atlas '{db}': table" in err and words in err, err
    assert "hint: rebuild the atlas into a new file" in err
    assert not (tmp_path / "o.toml").exists()


def test_a_query_that_is_not_utf8_exits_2(curve_atlas, capsys):
    assert main(["atlas", "--db", str(curve_atlas), "--query", "LA = '\udcff'"]) == 2
    assert "--query: expected UTF-8 text, got an undecodable byte" in capsys.readouterr().err


# --- 7. smaller ----------------------------------------------------------------------------
def _fill_the_disk(atlas) -> None:
    pages = atlas.con.execute("PRAGMA page_count").fetchone()[0]
    atlas.con.execute(f"PRAGMA max_page_count = {pages + 2}")             # SQLITE_FULL, as a full disk


def test_a_failed_atlas_build_removes_the_file_it_created_and_keeps_one_it_found(tmp_path):
    from multiloop.catalogue.atlas import Atlas
    from multiloop.catalogue.synthesis import SynthesisOptions
    from multiloop.topo.errors import OutputError
    new = tmp_path / "new.sqlite"
    with pytest.raises(OutputError, match="disk full"):
        with Atlas(new) as atlas:
            _fill_the_disk(atlas)
            atlas.build(SynthesisOptions(10, 1), progress=False, workers=1)
    assert list(tmp_path.iterdir()) == []
    old = tmp_path / "old.sqlite"
    with Atlas(old) as atlas:
        atlas.build(SynthesisOptions(6, 1), progress=False, workers=1)
    with pytest.raises(OutputError, match="disk full"):
        with Atlas(old) as atlas:
            _fill_the_disk(atlas)
            atlas.build(SynthesisOptions(10, 1), progress=False, workers=1)
    with Atlas(old, readonly=True) as atlas:
        assert atlas.count(SynthesisOptions(6, 1)) == 4


def test_synthesise_links_beyond_the_atlas_exit_2(tmp_path, capsys):
    target = tmp_path / "t.csv"
    target.write_text(_circle(0.05, 40))
    assert main(["synthesise", "--path", str(target), "--out", str(tmp_path / "o.toml"), "--links", str(2 ** 70),
                 "--db", str(tmp_path / "none.sqlite")]) == 2
    err = capsys.readouterr().err
    assert f"error: --links: expected even numbers of links >= 4, e.g. 4,6,8, got '{2 ** 70}'" in err
    assert "hint: links: expected an integer 2…" in err


@pytest.mark.parametrize("plot", ["p.png", "adir"])
def test_plot_without_a_start_is_refused_before_the_work(tmp_path, monkeypatch, capsys, plot):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "adir").mkdir()
    (tmp_path / "t.csv").write_text(_circle(0.05, 40))
    assert main(["synthesise", "--path", "t.csv", "--out", "o.toml", "--plot", plot, "--db", "none.sqlite"]) == 2
    assert f"error: --plot: expected a START mechanism, got --plot '{plot}' without one" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["adir", "t.csv"]


def test_a_read_only_output_is_never_replaced(tmp_path, capsys):
    import os
    import stat
    out = tmp_path / "out.toml"
    out.write_text("# mine\n")
    out.chmod(0o444)
    assert main(["convert", "four_bar", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"--out '{out}': expected a writable file, got a read-only file (-r--r--r--" in err or \
        f"'{out}': expected a writable file, got a read-only file (-r--r--r--" in err, err
    assert out.read_text() == "# mine\n" and stat.S_IMODE(os.stat(out).st_mode) == 0o444
    assert [p.name for p in tmp_path.iterdir()] == ["out.toml"]          # no temporary file left
