"""Synthesis budgets: ``--evaluations N`` is reproducible (the same seed gives the same
file on a loaded machine and with any number of BLAS threads), ``--budget S`` is a
wall-time cap, and the report says which limit stopped the run."""
from __future__ import annotations

import itertools
import json
import os
import subprocess
import sys
import time

import numpy as np
import pytest

from multiloop.catalogue.dimensional import synthesise
from multiloop.catalogue.dimensional.budget import DEFAULT_EVALUATIONS, STOPS, Budget, Meter
from multiloop.catalogue.named import load_named
from multiloop.cli import main
from multiloop.kin.solve import solve
from multiloop.topo.errors import InputError

MULTILOOP = [sys.executable, "-m", "multiloop"]


def _cli_text(exc, command: str) -> str:
    """What the command line prints of a library error raised under ``command``."""
    import argparse

    from multiloop.cli import _flags, build_parser, flagged
    sub = next(a for a in build_parser([command])._actions if isinstance(a, argparse._SubParsersAction))
    return flagged(str(exc), exc.parameters, _flags(sub.choices[command]))


def _ellipse(n: int = 25) -> np.ndarray:
    """A closed target no four-bar traces exactly (the search never stops at a tolerance of 0)."""
    t = np.linspace(0.0, 2 * np.pi, n)
    return np.column_stack([0.06 + 0.05 * np.cos(t), 0.09 + 0.02 * np.sin(t)])


@pytest.fixture(scope="module")
def tiny_atlas(tmp_path_factory):
    from multiloop.catalogue.synthesis import nauty_available
    from tests.common import four_bar_curve_atlas
    if not nauty_available():
        pytest.skip("nauty's geng/genbg not installed")
    return four_bar_curve_atlas(tmp_path_factory.mktemp("budget-atlas") / "atlas.sqlite")


@pytest.fixture
def target_csv(tmp_path):
    f = tmp_path / "target.csv"
    np.savetxt(f, _ellipse(), delimiter=",")
    return f


# ---------------------------------------------------------------------------------
# 1. the limits: checked, defaulted, and named by the parameter (library) or the flag (CLI)
BAD = [0, -5, float("nan"), 2 ** 70, 1.5, "1.5", "nan", True, "many"]


@pytest.mark.parametrize("value", BAD, ids=[repr(v) for v in BAD])
def test_bad_evaluations_name_the_parameter(value):
    m = load_named("four_bar")
    with pytest.raises(InputError, match=r"^evaluations: expected a whole number of evaluations from 1 to "):
        synthesise(m, path=_ellipse(), point="P", evaluations=value)


@pytest.mark.parametrize("text", ["0", "-5", "nan", str(2 ** 70), "1.5", "1e4", ""])
@pytest.mark.parametrize("start", [True, False], ids=["start", "no-start"])
def test_bad_evaluations_exit_2_naming_the_flag(tmp_path, capsys, target_csv, text, start):
    out = tmp_path / "o.toml"
    args = ["synthesise"] + (["four_bar"] if start else []) + ["--path", str(target_csv), "--out", str(out),
                                                              "--evaluations", text]
    rc = main(args)
    err = capsys.readouterr().err
    assert rc == 2 and "Traceback" not in err and not out.exists(), err
    assert f"--evaluations: expected a whole number of evaluations from 1 to 1e+12, got '{text}'" in err


@pytest.mark.parametrize("seconds", [0, -1.0, float("nan"), float("inf")])
def test_bad_budget_names_the_parameter(seconds):
    with pytest.raises(InputError, match=r"^budget: expected a positive number of seconds"):
        Budget.of(None, seconds)
    with pytest.raises(InputError) as e:                   # the command line names its flag
        Budget.of(None, seconds)
    assert _cli_text(e.value, "synthesise").startswith("--budget: expected a positive number of seconds")


def test_default_limits():
    assert Budget.of() == Budget(DEFAULT_EVALUATIONS, None) and Budget.of().is_reproducible
    assert Budget.of(seconds=2.0) == Budget(None, 2.0) and not Budget.of(seconds=2.0).is_reproducible
    assert Budget.of(None, None, default=None) == Budget(None, None)
    assert Budget.of("300", 4) == Budget(300, 4.0)
    r = synthesise(load_named("four_bar"), path=_ellipse(), point="P", method="local")
    assert r.limits == Budget(DEFAULT_EVALUATIONS, None) and r.evaluations <= DEFAULT_EVALUATIONS


def test_a_meter_shares_and_charges_its_run():
    run = Meter.start(Budget(1000))
    phase = run.share(0.6)
    assert phase.left() == 600 and phase.take(700) == 600 and run.used == 600
    assert phase.stop() == "evaluations" and run.stop() is None and run.left() == 400
    assert run.take(500, whole=True) == 0 and run.stop() == "evaluations"          # all or none, remembered
    part = Meter.start(Budget(1000)).until(0.5)
    assert part.portion(4) == Budget(125, None) and part.portion(600) is None
    assert part.portion(600, smallest=Budget(1, 0.0)) is None and part.portion(500) == Budget(1, None)


# ---------------------------------------------------------------------------------
# 2. an evaluation budget bounds the run and no decision reads the clock
@pytest.mark.parametrize("method", ["de", "cmaes", "local"])
def test_the_evaluations_bound_the_run_and_are_reported(method):
    m = load_named("four_bar")
    r = synthesise(m, path=_ellipse(), point="P", evaluations=1500, tol=0.0, method=method, seed=2)
    assert 0 < r.evaluations <= 1500
    assert r.stopped in STOPS
    if method != "local":           # the search spends its share (60 %) to the last design
        assert r.stopped == "evaluations" and r.history[-1][2] <= 0.6 * 1500
    doc = r.as_dict()
    assert doc["limits"] == {"evaluations": 1500, "seconds": None} and doc["stopped"] == r.stopped


def _warped_clock(monkeypatch, step: float = 3600.0):
    """``time.perf_counter`` jumps by ``step`` seconds at every reading: a decision that
    reads the clock (a deadline, a share of seconds, a probe every so often) goes another way."""
    ticks = itertools.count()
    monkeypatch.setattr(time, "perf_counter", lambda: step * next(ticks))


@pytest.mark.parametrize("method", ["de", "cmaes"])
def test_no_decision_reads_the_clock_under_an_evaluation_budget(monkeypatch, method):
    """The same run with a clock that jumps an hour at every reading gives the same design."""
    m = load_named("four_bar")
    kw = dict(path=_ellipse(), point="P", evaluations=2500, tol=0.0, method=method, seed=7)
    a = synthesise(m, **kw)
    _warped_clock(monkeypatch)
    b = synthesise(m, **kw)
    assert a.design == b.design and a.evaluations == b.evaluations and a.stopped == b.stopped
    assert [h[1:] for h in a.history] == [h[1:] for h in b.history]         # generation by generation


def test_no_decision_reads_the_clock_without_a_start(monkeypatch, tiny_atlas):
    from multiloop.catalogue.topology_synthesis import synthesise as topo
    kw = dict(links=(4,), atlas=tiny_atlas, top=2, evaluations=3000, seed=1)
    a = topo(_ellipse(), **kw)
    _warped_clock(monkeypatch)
    b = topo(_ellipse(), **kw)
    assert a.designs and [d.mechanism for d in a.designs] == [d.mechanism for d in b.designs]
    assert a.evaluations == b.evaluations <= 3000 and a.stopped == b.stopped


def test_a_wall_time_cap_stops_the_run_and_says_so(monkeypatch):
    """A clock that runs a minute per reading: a 1-second cap stops the run, reported as
    ``"budget"``; the evaluations alone would have gone on."""
    m = load_named("four_bar")
    _warped_clock(monkeypatch, 60.0)
    r = synthesise(m, path=_ellipse(), point="P", evaluations=50_000, budget=1.0, tol=0.0)
    assert r.stopped == "budget" and r.evaluations < 5000 and np.isfinite(r.error_max)


# ---------------------------------------------------------------------------------
# 3. the same seed and evaluations give the same file: with two busy processes beside
#    the run, and with one or two BLAS threads
def _busy(n: int = 2) -> list[subprocess.Popen]:
    return [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(n)]


def _run_cli(args, threads: int, busy: int = 0) -> None:
    env = dict(os.environ, OPENBLAS_NUM_THREADS=str(threads), OMP_NUM_THREADS=str(threads),
               MKL_NUM_THREADS=str(threads))
    burners = _busy(busy)
    try:
        done = subprocess.run(MULTILOOP + args, env=env, capture_output=True, text=True, timeout=600)
    finally:
        for p in burners:
            p.kill()
            p.wait()
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


@pytest.mark.parametrize("start", [True, False], ids=["start", "no-start"])
def test_same_seed_and_evaluations_give_the_same_file_on_a_busy_machine(tmp_path, target_csv, tiny_atlas, start):
    """Two runs: one BLAS thread on a quiet machine; two BLAS threads with two processes
    burning the CPU beside it.  The written files are the same, byte for byte."""
    files = []
    for k, (threads, busy) in enumerate(((1, 0), (2, 2))):
        out = tmp_path / f"run{k}" / "o.toml"
        out.parent.mkdir()
        args = ["synthesise"] + (["four_bar", "--point", "P", "--tol", "0", "--evaluations", "4000"] if start else
                                 ["--db", str(tiny_atlas), "--links", "4", "--top", "2", "--evaluations", "3000"])
        doc = _run_cli(args + ["--path", str(target_csv), "--out", str(out), "--seed", "3", "--json"], threads, busy)
        rows = [doc] if start else doc
        assert all(r["stopped"] in STOPS for r in rows)
        files.append({p.name: p.read_bytes() for p in sorted(out.parent.iterdir())})
    assert files[0] and files[0] == files[1]


def test_the_text_report_says_what_stopped_the_run(tmp_path, capsys, target_csv):
    out = tmp_path / "o.toml"
    assert main(["synthesise", "four_bar", "--path", str(target_csv), "--out", str(out), "--evaluations", "800",
                 "--tol", "0"]) == 0
    text = capsys.readouterr().out
    assert "limits: 800 evaluations; stopped: evaluations)" in text
