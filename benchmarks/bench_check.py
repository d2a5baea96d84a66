"""Benchmark of ``multiloop check`` (plain script).

Run:  python benchmarks/bench_check.py [--repeat R]

For the knitting needle drive (10 links, a multiple joint, four RRR dyads), the
Stephenson III triad mechanism and the 24-link chain of eleven dyads, prints the time
of one full ``check`` of a copy of the design under a name of its own (best of R; the
check keeps a design's motion beside its plan, and ``decompose`` keeps plans by the
coordinate-free form, so a copy must differ), and, measured in the same run, the alternative a
designer would script by hand: a fine sweep of the solver (72 001 positions with
derivatives) reading the transmission extremes and dead centres off the samples, with
its time and its error against the refined values.
"""
from __future__ import annotations

import argparse
from dataclasses import replace
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from multiloop.kin.check import check  # noqa: E402
from multiloop.kin.check.transmission import angle_specs, angle_values  # noqa: E402
from multiloop.kin.solve import compile_plan, solve  # noqa: E402
from multiloop.topo.assur import decompose  # noqa: E402
from multiloop.topo.io import load  # noqa: E402

CAT = ROOT / "catalogue" / "mechanisms"


def _best(f, repeat):
    """Best wall time and best CPU time of ``repeat`` runs (the machine is shared)."""
    t, c = [], []
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        out = f()
        t.append(time.perf_counter() - t0)
        c.append(time.process_time() - c0)
    return min(t), min(c), out


def _sweep(m, n=72001):
    plan = compile_plan(m)
    x = np.linspace(0, 2 * np.pi, n)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        s = solve(m, x, derivatives=True, plan=plan)
    V = angle_values(s, angle_specs(decompose(m)))
    return V.min(axis=0), V.max(axis=0)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    print(f"{'mechanism':24s} {'links':>5s} {'check wall/CPU (s)':>19s} {'sweep 72001 wall/CPU (s)':>25s} "
          f"{'ratio':>6s} {'sweep angle error (deg)':>24s}")
    for name in ("knitting_needle_drive", "stephenson_3_triad", "linkage_24"):
        m = load(CAT / f"{name}.toml")
        # each run on a design never seen before: the check keeps a design's motion beside
        # its plan (by identity), and decompose keeps plans by the coordinate-free form, so
        # a second check of the same object, or of a copy, would reuse the first's work
        runs = iter(range(a.repeat))
        t_check, c_check, rep = _best(lambda: check(replace(m, name=f"{m.name} (run {next(runs)})")), a.repeat)
        t_sweep, c_sweep, (lo, hi) = _best(lambda: _sweep(m), a.repeat)
        ex = [x.extreme for x in rep.drivers[0].angles]
        err = max(max(abs(lo[i] - e.min), abs(hi[i] - e.max)) for i, e in enumerate(ex)) if ex else 0.0
        print(f"{name:24s} {m.n_links:5d} {t_check:9.3f} / {c_check:7.3f} {t_sweep:14.3f} / {c_sweep:8.3f} "
              f"{c_sweep / c_check:6.2f} {err:24.2e}")


if __name__ == "__main__":
    main()
