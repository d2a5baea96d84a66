"""Number synthesis by counting (catalogue/synthesis/counting.py): the compiled counter
inside genbg, the Python route and the swapped-class route agree on every row; the
enumeration restricted to one row equals the unrestricted one's row; a killed count
resumes to the same table; the command counts beyond the stored sizes."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections import Counter

import pytest

from multiloop.catalogue.atlas import Atlas
from multiloop.catalogue.synthesis import SynthesisOptions, nauty_available, number_synthesis, universal_table
from multiloop.catalogue.synthesis import counter_build
from multiloop.catalogue.synthesis.counting import count_rows, count_signature, count_tasks
from multiloop.cli import main
from multiloop.topo.errors import InputError
from tests.common import alive, child_pids, tasks_done

pytestmark = pytest.mark.skipif(not nauty_available(),
                                reason="nauty's geng/genbg not installed (apt-get install nauty)")
compiled = pytest.mark.skipif(counter_build.find_counter() is None,
                              reason="the compiled counter is not built (install.sh builds it)")


def _table(opts: SynthesisOptions, route: str) -> Counter:
    out: Counter = Counter()
    for task in count_tasks(opts):
        out += count_rows(task, opts, route)
    return out


def _stored(tmp_path, opts: SynthesisOptions) -> Counter:
    """The rows of the stored chains (nauty's generator, the NumPy filter, one record and
    canonical form per chain): the atlas's own route."""
    with Atlas(tmp_path / "stored.sqlite") as atlas:
        atlas.build(opts, loops=False, progress=False)
        return Counter({(r.LA, r.MJA): r.chains for r in universal_table(opts, atlas.chains(opts)) if r.chains})


# (n = 11, F = 2: 13 450 chains, 20 s here, is in `python benchmarks/bench_atlas_count.py`'s yardstick, which
# checks the counter's count against genbg piped into a compiled filter)
CASES = [SynthesisOptions(8, 1), SynthesisOptions(10, 1), SynthesisOptions(9, 2), SynthesisOptions(10, 3),
         SynthesisOptions(10, 1, max_multiplicity=2),
         SynthesisOptions(10, 1, simple_joints=True), SynthesisOptions(9, 2, max_link_degree=3)]


@compiled
@pytest.mark.parametrize("opts", CASES, ids=lambda o: o.key())
def test_compiled_python_and_stored_routes_agree_on_every_row(tmp_path, opts):
    fast = _table(opts, "compiled")
    assert fast == _table(opts, "python") == _stored(tmp_path, opts)
    assert sum(fast.values()) > 0


@pytest.mark.parametrize("opts", [SynthesisOptions(8, 1), SynthesisOptions(9, 2), SynthesisOptions(10, 3)],
                         ids=lambda o: o.key())
def test_swapped_classes_give_the_same_rows(opts):
    """genbg with the joints first and the links added last: another search tree."""
    assert _table(opts, "swapped") == _table(opts, "python")


@pytest.mark.parametrize("n", [8, 10])
@pytest.mark.parametrize("route", ["compiled", "python"])
def test_restricted_enumeration_equals_the_unrestricted_row(n, route):
    """Every row of the number-synthesis table (the empty ones too) counted alone."""
    if route == "compiled" and counter_build.find_counter() is None:
        pytest.skip("the compiled counter is not built")
    full = _table(SynthesisOptions(n, 1), route)
    rows = number_synthesis(SynthesisOptions(n, 1))
    assert len(rows) > len(full)          # some rows are empty
    for row in rows:
        alone = _table(SynthesisOptions(n, 1, la=row.LA, mja=row.MJA), route)
        assert sum(alone.values()) == full.get((row.LA, row.MJA), 0), row
        assert set(alone) <= {(row.LA, row.MJA)}


def test_restricted_build_stores_exactly_the_chains_of_the_row(tmp_path):
    opts = SynthesisOptions(8, 1)
    with Atlas(tmp_path / "a.sqlite") as atlas:
        atlas.build(opts, loops=False, progress=False)
        every = list(atlas.chains(opts))
    for la, mja in {(r.LA, r.MJA) for r in every}:
        with Atlas(tmp_path / f"{la}{mja}.sqlite") as atlas:
            row = SynthesisOptions(8, 1, la=la, mja=mja)
            atlas.build(row, loops=False, progress=False)
            alone = sorted(r.canonical for r in atlas.chains(row))
        assert alone == sorted(r.canonical for r in every if (r.LA, r.MJA) == (la, mja))


@pytest.mark.parametrize("la, mja, bad", [((6, 4), (1,), "la"), ((5, 4), None, "la"),
                                          (None, (20,), "mja"), ((5, 5), (-1,), "mja")])
def test_a_row_off_the_structural_equations_is_refused(la, mja, bad):
    with pytest.raises(InputError, match=rf"^{bad}|; {bad}"):
        SynthesisOptions(10, 1, la=la, mja=mja)


def test_the_generator_signature_names_the_count():
    """A changed search (another bound, another split) is another count, never resumed
    into the old one."""
    a, b = SynthesisOptions(12, 1), SynthesisOptions(12, 1, max_link_degree=5)
    assert count_signature(a) == count_signature(SynthesisOptions(12, 1)) != count_signature(b)


def test_counter_path_follows_the_source(tmp_path, monkeypatch):
    """A changed chaincount.c is built afresh (the cache is named after its digest);
    MULTILOOP_COUNTER=none turns the counter off."""
    monkeypatch.setenv("MULTILOOP_CACHE", str(tmp_path))
    before = counter_build.counter_path()
    copy = tmp_path / "chaincount.c"
    copy.write_bytes(counter_build.SOURCE.read_bytes() + b"\n/* changed */\n")
    monkeypatch.setattr(counter_build, "SOURCE", copy)
    assert counter_build.counter_path() != before and counter_build.find_counter() is None
    monkeypatch.setenv("MULTILOOP_COUNTER", "none")
    assert counter_build.find_counter() is None


@compiled
@pytest.mark.slow
def test_a_killed_count_resumes_to_the_same_table_and_leaves_no_generator(tmp_path):
    db = tmp_path / "c.sqlite"
    code = ("import sys; from multiloop.catalogue.atlas import Atlas; "
            "from multiloop.catalogue.synthesis import SynthesisOptions; "
            "Atlas(sys.argv[1]).count_table(SynthesisOptions(11, 2), progress=False)")
    proc = subprocess.Popen([sys.executable, "-c", code, str(db)])
    done, kids = 0, set()
    for _ in range(3000):                      # until a few tasks are stored (bounded polling)
        time.sleep(0.02)
        kids |= child_pids(proc.pid)
        done = tasks_done(db)
        if done >= 3 or proc.poll() is not None:
            break
    assert proc.poll() is None, "the count ended before it could be killed"
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    for _ in range(500):
        if not any(map(alive, kids)):
            break
        time.sleep(0.01)
    assert not any(map(alive, kids)), "a generator outlived the killed count"
    opts = SynthesisOptions(11, 2)
    with Atlas(db) as atlas:
        resumed = atlas.count_table(opts, progress=False)
        assert 0 < resumed.tasks_run < resumed.tasks_total and atlas.is_counted(opts)
        assert atlas.table_counts(opts) == _table(opts, "python")
        assert resumed.count == 13450


@compiled
def test_the_command_counts_a_table_beyond_the_stored_sizes(tmp_path, capsys):
    """Beyond 12 links ``--table`` counts by row; one row is recounted alone by
    ``--la/--mja`` (a 13-link, 2-freedom row: every other joint count is skipped)."""
    db = tmp_path / "t.sqlite"
    args = ["atlas", "--links", "13", "--dof", "2", "--table", "--la", "9-4", "--mja", "0-0-0-1",
            "--db", str(db), "--no-progress", "--json"]
    assert main(args) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["chains"] == [] and doc["complete"] is True
    (row,) = doc["table"]
    assert (row["LA"], row["MJA"], row["V"]) == ([9, 4], [0, 0, 0, 1], 4)
    assert row["chains"] == doc["count"]
    with Atlas(db) as atlas:
        assert atlas.count() == 0                     # nothing stored but the tallies
    # the same row out of the count restricted by the joints alone (the links unpruned)
    by_joints = _table(SynthesisOptions(13, 2, mja=(0, 0, 0, 1)), "compiled")
    assert len(by_joints) > 1 and doc["count"] == by_joints[((9, 4), (0, 0, 0, 1))]


def test_bad_rows_and_filters_exit_2_before_a_file_is_made(tmp_path, capsys):
    db = tmp_path / "x.sqlite"
    for extra in (["--la", "x-1"], ["--la", "6-4", "--mja", "1"], ["--planar"]):
        assert main(["atlas", "--links", "14", "--dof", "1", "--table", "--db", str(db), *extra]) == 2
        err = capsys.readouterr().err
        assert "expected" in err and "Traceback" not in err
    assert not db.exists()


def test_local_processes_and_dask_cluster_count_the_same_table(tmp_path):
    distributed = pytest.importorskip("distributed")
    opts = SynthesisOptions(10, 1)
    tables = []
    with Atlas(tmp_path / "serial.sqlite") as a:
        a.count_table(opts, progress=False, workers=1)
        tables.append(a.table_counts(opts))
    with Atlas(tmp_path / "pool.sqlite") as a:
        a.count_table(opts, progress=False, workers=2)
        tables.append(a.table_counts(opts))
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        with Atlas(tmp_path / "dask.sqlite") as a:
            a.count_table(opts, progress=False, scheduler=client)
            tables.append(a.table_counts(opts))
    assert tables[0] == tables[1] == tables[2] and sum(tables[0].values()) == 2645


TABLE_14 = os.path.join(os.path.dirname(__file__), "..", "docs", "atlas", "table_n14_F1.json")


def test_the_committed_14_link_table_has_every_row_of_the_number_synthesis():
    """The committed 14-link, 1-DOF table (``docs/atlas/table_n14_F1.json``): its rows are
    exactly the rows of the number synthesis (Assur-group structural equations), and
    its simple-joint rows sum to the published count of 14-link one-DOF simple-joint
    chains, 318 162 (Tsai 2001; Mruthyunjaya 2003)."""
    with open(TABLE_14) as f:
        doc = json.load(f)
    assert doc["complete"] is True and doc["count"] == sum(r["chains"] for r in doc["table"])
    rows = {(tuple(r["LA"]), tuple(r["MJA"])) for r in doc["table"]}
    expected = {(tuple(r.LA), tuple(r.MJA)) for r in number_synthesis(SynthesisOptions(14, 1))}
    assert rows == expected
    assert sum(r["chains"] for r in doc["table"] if r["V"] == 0) == 318162


@compiled
@pytest.mark.parametrize("la, mja", [("14", "8-1"), ("14", "4-3")])
def test_a_committed_14_link_row_recounts_alone_to_the_same_number(tmp_path, capsys, la, mja):
    """Any row of the committed table recounts by one command (``--la/--mja``: the
    enumeration restricted to the row) to its committed number."""
    with open(TABLE_14) as f:
        committed = {("-".join(map(str, r["LA"])), "-".join(map(str, r["MJA"]))): r["chains"]
                     for r in json.load(f)["table"]}
    assert main(["atlas", "--links", "14", "--dof", "1", "--table", "--la", la, "--mja", mja,
                 "--db", str(tmp_path / "row.sqlite"), "--no-progress", "--json"]) == 0
    (row,) = json.loads(capsys.readouterr().out)["table"]
    assert row["chains"] == committed[(la, mja)] > 0
