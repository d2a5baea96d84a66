"""SQLite atlas: exact counts, re-analysis, resume after a kill, local vs Dask, queries, CLI."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from multiloop.catalogue.atlas import Atlas, parse_query
from multiloop.catalogue.synthesis import SynthesisOptions, nauty_available
from multiloop.cli import main
from multiloop.topo.errors import InputError
from multiloop.topo.numbers import structural_report
from tests.common import alive, child_pids, tasks_done

pytestmark = pytest.mark.skipif(not nauty_available(),
                                reason="nauty's geng/genbg not installed (apt-get install nauty)")


def _canon(atlas, opts):
    return sorted(r.canonical for r in atlas.chains(opts))


def test_build_count_and_idempotent_rebuild(tmp_path):
    db = tmp_path / "a.sqlite"
    with Atlas(db) as atlas:
        r = atlas.build(SynthesisOptions(8, 1), progress=False)
        assert r.count == 60 and r.tasks_run == r.tasks_total
        again = atlas.build(SynthesisOptions(8, 1), progress=False)
        assert again.count == 60 and again.tasks_run == 0
        # a filtered build reuses the rows and counts only its own chains
        assert atlas.build(SynthesisOptions(8, 1, simple_joints=True), progress=False).count == 16
        assert atlas.count(SynthesisOptions(8, 1)) == 60
        assert atlas.duplicates() == 0
        assert atlas.is_complete(SynthesisOptions(8, 1))


@pytest.mark.parametrize("n, F", [(4, 1), (6, 3), (8, 1), (7, 2), (8, 3)])
def test_stored_chains_reanalysed_give_stored_numbers(tmp_path, n, F):
    with Atlas(tmp_path / "a.sqlite") as atlas:
        opts = SynthesisOptions(n, F)
        atlas.build(opts, progress=False)
        for rec in atlas.chains(opts):
            rep = structural_report(rec.as_mechanism())
            assert (rep.n, rep.F, rep.K, rep.V) == (n, F, rec.K, rec.V)
            assert rep.LA == rec.LA and rep.MJA == rec.MJA
            assert rep.code == rec.code and rep.code_star == rec.code_star
            assert rep.canonical == rec.canonical
            assert rep.planar == rec.planar and rep.La == rec.La and rep.L0 == rec.L0
            assert rep.fractionated == rec.fractionated
            assert not rep.degenerate and rep.consistent


def test_resume_after_partial_build(tmp_path):
    db = tmp_path / "a.sqlite"
    opts = SynthesisOptions(9, 2)
    with Atlas(db) as atlas:
        part = atlas.build(opts, progress=False, loops=False, max_tasks=2)
        assert part.tasks_run == 2 and not atlas.is_complete(opts)
    with Atlas(db) as atlas:
        rest = atlas.build(opts, progress=False, loops=False)
        assert rest.tasks_run == part.tasks_total - 2
        assert rest.count == 219 and atlas.duplicates() == 0


def test_resume_after_kill(tmp_path):
    """SIGKILL the CLI in the middle of a build; the rerun ends with the exact count."""
    db = tmp_path / "k.sqlite"
    cmd = [sys.executable, "-m", "multiloop", "atlas", "--links", "10", "--dof", "1", "--db", str(db),
           "--workers", "1", "--no-loops", "--no-progress"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 60
    done = 0
    while time.time() < deadline and proc.poll() is None:   # wait for the first stored task
        time.sleep(0.1)
        done = tasks_done(db)
        if done >= 1:
            break
    if proc.poll() is None:
        os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    assert main(["atlas", "--links", "10", "--dof", "1", "--db", str(db), "--no-loops",
                 "--no-progress", "--workers", "1"]) == 0
    with Atlas(db) as atlas:
        assert atlas.count(SynthesisOptions(10, 1)) == 2645
        assert atlas.duplicates() == 0
        assert atlas.is_complete(SynthesisOptions(10, 1))


def test_local_processes_and_dask_cluster_give_identical_atlases(tmp_path):
    distributed = pytest.importorskip("distributed")
    opts = SynthesisOptions(9, 2)
    with Atlas(tmp_path / "serial.sqlite") as a:
        a.build(opts, progress=False, loops=False, workers=1)
        serial = _canon(a, opts)
    with Atlas(tmp_path / "pool.sqlite") as a:
        a.build(opts, progress=False, loops=False, workers=2)
        pool = _canon(a, opts)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        with Atlas(tmp_path / "dask.sqlite") as a:
            a.build(opts, progress=False, loops=False, scheduler=client)
            dask = _canon(a, opts)
    assert serial == pool == dask and len(serial) == 219


def test_query_grammar_is_safe():
    assert parse_query("V=2 AND K=4") == ('("V" = ?) AND ("K" = ?)', [2, 4])
    sql, params = parse_query("(La = '[4, 4, 6]' or code_star='x') and not planar = false")
    assert params == ["[4, 4, 6]", "x", 0] and '"loops"' in sql
    for bad in ["V=2; DROP TABLE chains", "secret = 1", "V = = 2", "V=2 AND", "V = x",
                "V=2) OR (1=1", "1=1"]:
        with pytest.raises(InputError):
            parse_query(bad)


def test_cli_json_query_and_table(tmp_path, capsys):
    db = str(tmp_path / "c.sqlite")
    assert main(["atlas", "--links", "8", "--dof", "1", "--db", db, "--json", "--no-progress"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["count"] == 60 and len(out["chains"]) == 60
    assert set(out["chains"][0]) >= {"canonical", "LA", "MJA", "V", "K"}
    assert main(["atlas", "--db", db, "--query", "V=2 AND K=3", "--json"]) == 0
    q = json.loads(capsys.readouterr().out)
    assert q["count"] == 18 and all(c["V"] == 2 and c["K"] == 3 for c in q["chains"])
    assert main(["atlas", "--links", "8", "--dof", "1", "--db", db, "--table", "--json",
                 "--no-progress"]) == 0
    t = json.loads(capsys.readouterr().out)
    assert sum(r["chains"] for r in t["table"]) == 60
    assert main(["atlas", "--db", db, "--query", "drop table chains"]) == 2
    assert main(["atlas", "--links", "7", "--dof", "1", "--db", db]) == 2
    assert main(["atlas", "--db", str(tmp_path / "missing.sqlite")]) == 2


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
def test_killed_build_leaves_no_orphan_workers(tmp_path, sig):
    """Issue 10: killing `multiloop atlas` with pool workers must not leave them running;
    the rerun still ends with the exact count."""
    db = tmp_path / "o.sqlite"
    cmd = [sys.executable, "-m", "multiloop", "atlas", "--links", "10", "--dof", "1", "--db", str(db),
           "--workers", "2", "--no-loops", "--no-progress"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 60
    workers: set[int] = set()
    while time.time() < deadline and proc.poll() is None and len(workers) < 2:
        time.sleep(0.05)
        workers = child_pids(proc.pid)
    if proc.poll() is not None:
        pytest.skip("the build finished before its workers could be seen")
    os.kill(proc.pid, sig)
    proc.wait()
    deadline = time.time() + 120         # waits on the workers; the bound is a net
    while time.time() < deadline and any(alive(w) for w in workers):
        time.sleep(0.1)
    assert not [w for w in workers if alive(w)]
    assert main(["atlas", "--links", "10", "--dof", "1", "--db", str(db), "--no-loops",
                 "--no-progress", "--workers", "1"]) == 0
    with Atlas(db) as atlas:
        assert atlas.count(SynthesisOptions(10, 1)) == 2645


def test_bad_db_files_are_input_errors(tmp_path):
    bad = tmp_path / "not.sqlite"
    bad.write_bytes(b"this is not a database " * 100)
    for path in (bad, tmp_path):
        with pytest.raises(InputError, match=r"^atlas "):
            Atlas(path)
        assert main(["atlas", "--db", str(path), "--links", "6"]) == 2
    assert bad.read_bytes() == b"this is not a database " * 100


@pytest.mark.parametrize("query, what", [
    ("(" * 500 + "V=1" + ")" * 500, "nested"),
    (" OR ".join(["V=1"] * 5000), "comparisons"),
    ("V = 99999999999999999999999", "integer"),
    ("V = -9223372036854775809", "integer"),
])
def test_runaway_queries_are_input_errors(query, what):
    with pytest.raises(InputError, match=what):
        parse_query(query)


def test_query_limits_still_allow_reasonable_queries():
    sql, params = parse_query("(" * 50 + "V=1" + ")" * 50 + " AND " + " OR ".join(["K=2"] * 150))
    assert len(params) == 151


def test_unreachable_scheduler_is_an_input_error(tmp_path, monkeypatch):
    from multiloop.catalogue import distributed

    monkeypatch.setattr(distributed, "SCHEDULER_TIMEOUT", 0.5)
    with pytest.raises(InputError, match="^scheduler: expected a reachable"):
        list(distributed.map_tasks([], SynthesisOptions(6, 1), scheduler="tcp://127.0.0.1:9"))


def test_unreachable_scheduler_creates_no_file(tmp_path, monkeypatch):
    from multiloop.catalogue import distributed

    monkeypatch.setattr(distributed, "SCHEDULER_TIMEOUT", 0.5)
    db = tmp_path / "none.sqlite"
    assert main(["atlas", "--links", "6", "--db", str(db), "--scheduler", "tcp://127.0.0.1:9",
                 "--no-progress"]) == 2
    assert not db.exists()
