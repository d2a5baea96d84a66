"""Benchmark of the atlas: time to the full atlas against a brute-force generate-and-filter.

Run::

    python benchmarks/bench_atlas.py            # everything (about 15 min on 2 busy cores)
    python benchmarks/bench_atlas.py --quick    # up to 10 links

Rows (each printed as ``ours`` vs ``baseline`` with the ratio):

* ``count``: the enumeration alone (nauty with pruning options + NumPy exact
  degeneracy filter), serial;
* ``atlas``: the full SQLite atlas (canonical form, assortments, codes, planarity,
  fractionation) with 1 and 2 worker processes; ``+La``: the same with the loop
  assortments of :func:`topo.loops.loop_assortment` (2 workers, n <= 11);
* ``baseline``: generate-and-filter without pruning: ``geng -c -d2`` / ``genbg -c
  -d2:2`` (no ``-t``, no ``-Z1``), every graph built as a :class:`topo.model.Mechanism`
  and tested with :func:`topo.degeneracy.is_degenerate`.  When the baseline would run
  longer than ``--budget`` seconds, its per-graph rate is measured on a prefix and
  multiplied by the number of graphs (nauty's ``-u`` count); such rows say
  ``(extrapolated)``.

Peak memory is the largest resident set of this process and of its children.
Writes ``benchmarks/charts/atlas_times.png``.
"""
from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from multiloop.catalogue.atlas import Atlas  # noqa: E402
from multiloop.catalogue.synthesis import (  # noqa: E402
    LITERATURE_SJ_F1, SynthesisOptions, _decode_bipartite, _decode_simple, _tool, count_task,
    plan_tasks,
)
from multiloop.topo.degeneracy import is_degenerate  # noqa: E402
from multiloop.topo.model import chain_from_joint_lists  # noqa: E402


def _baseline_commands(opts: SynthesisOptions):
    p, n = opts.p, opts.n
    if opts.simple_joints:
        yield [_tool("geng"), "-cq", "-d2", str(n), f"{p}:{p}"], None
        return
    for m in range(p, 0, -1):
        if p + m < 2 * n:
            break
        e = p + m
        if m == p:
            yield [_tool("geng"), "-cq", "-d2", str(n), f"{p}:{p}"], None
        else:
            yield [_tool("genbg"), "-cq", "-d2:2", str(n), str(m), f"{e}:{e}"], m


def _count_only(cmd, timeout: float) -> int:
    args = [a for a in cmd[1:] if a != "-cq"] + ["-c"]
    out = subprocess.run(cmd[:1] + ["-u"] + args, capture_output=True, text=True,
                         timeout=timeout).stderr
    for line in out.splitlines():
        if "graphs generated" in line:
            return int(line.split()[1])
    return 0


def baseline(opts: SynthesisOptions, budget: float) -> tuple[float | None, int | None, bool]:
    """Seconds of generate-and-filter, survivors (None if extrapolated), extrapolated?

    ``None`` seconds when even counting the unpruned graphs exceeds the budget.
    """
    t0 = time.perf_counter()
    kept = 0
    seen = 0
    try:
        total = sum(_count_only(c, budget) for c, _ in _baseline_commands(opts))
    except subprocess.TimeoutExpired:
        return None, None, True
    t0 = time.perf_counter()
    extrapolated = False
    for cmd, m in _baseline_commands(opts):
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE)
        for line in proc.stdout:
            line = line.rstrip(b"\n")
            masks = (_decode_simple([line], opts.n, opts.p) if m is None else
                     _decode_bipartite([line], opts.n, m))[0]
            mech = chain_from_joint_lists([[str(x) for x in range(opts.n) if j >> x & 1]
                                           for j in masks.tolist()])
            kept += not is_degenerate(mech)
            seen += 1
            if time.perf_counter() - t0 > budget:
                extrapolated = True
                break
        proc.kill()
        proc.wait()
        if extrapolated:
            break
    dt = time.perf_counter() - t0
    if extrapolated:
        return dt / seen * total, None, True
    return dt, kept, False


def ours_count(opts: SynthesisOptions) -> tuple[float, int]:
    t0 = time.perf_counter()
    c = sum(count_task(t, opts) for t in plan_tasks(opts))
    return time.perf_counter() - t0, c


def ours_atlas(opts: SynthesisOptions, workers: int, loops: bool = False) -> tuple[float, int]:
    with tempfile.TemporaryDirectory() as d:
        with Atlas(Path(d) / "bench.sqlite") as atlas:
            t0 = time.perf_counter()
            r = atlas.build(opts, loops=loops, workers=workers, progress=False)
            return time.perf_counter() - t0, r.count


def peak_mb() -> tuple[float, float]:
    me = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    kids = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    return me, kids


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="only up to 10 links")
    ap.add_argument("--budget", type=float, default=60.0, help="seconds before a baseline is extrapolated")
    ap.add_argument("--with-14", action="store_true",
                    help="also count the 1-DOF simple-jointed 14-link chains (literature: 318 162)")
    ap.add_argument("--chart", default=str(ROOT / "benchmarks" / "charts" / "atlas_times.png"))
    args = ap.parse_args(argv)
    cases = [("SJ F=1 n=10", SynthesisOptions(10, 1, simple_joints=True), 1.0),
             ("MJ F=1 n=10", SynthesisOptions(10, 1), 3.0),
             ("MJ F=2 n=11", SynthesisOptions(11, 2), None)]
    if not args.quick:
        cases.insert(1, ("SJ F=1 n=12", SynthesisOptions(12, 1, simple_joints=True), 10.0))
        cases.append(("MJ F=1 n=12", SynthesisOptions(12, 1), 600.0))
    print(f"{'case':<14}{'chains':>8}{'count s':>9}{'atlas 1w':>10}{'atlas 2w':>10}{'speed-up':>9}"
          f"{'+La 2w':>9}{'baseline s':>12}{'ratio':>8}{'goal s':>8}", flush=True)
    rows = []
    for name, opts, goal in cases:
        big = opts.n >= 12 and not opts.simple_joints
        tc, count = (None, None) if big else ours_count(opts)
        t1 = None if big else ours_atlas(opts, 1)[0]     # 1-worker atlas of MJ 12: ~10 min
        t2, count2 = ours_atlas(opts, 2)
        if count is None:
            count = count2
        assert count2 == count, (count, count2)
        tl = ours_atlas(opts, 2, loops=True)[0] if opts.n <= 11 else None
        if opts.simple_joints and opts.F == 1:
            assert count == LITERATURE_SJ_F1[opts.n]
        tb, kept, extra = baseline(opts, args.budget)
        if kept is not None:
            assert kept == count, (name, kept, count)
        ours = tc if tc is not None else t2
        ratio = "n/a" if tb is None else f"{tb / ours:.0f}x"
        speed = "" if t1 is None else f"{t1 / t2:.2f}"
        tbs = "n/a" if tb is None else f"{tb:.1f}"
        print(f"{name:<14}{count:>8}{'' if tc is None else f'{tc:.2f}':>9}"
              f"{'' if t1 is None else f'{t1:.2f}':>10}{t2:>10.2f}"
              f"{speed:>9}{'' if tl is None else f'{tl:.2f}':>9}{tbs:>11}{'*' if extra else ' '}"
              f"{ratio:>8}{'' if goal is None else f'{goal:.0f}':>8}", flush=True)
        rows.append((name, count, tc, t1, t2, tb, extra))
    if args.with_14:
        opts = SynthesisOptions(14, 1, simple_joints=True)
        tc, count = ours_count(opts)
        assert count == LITERATURE_SJ_F1[14], count
        print(f"{'SJ F=1 n=14':<14}{count:>8}{tc:>9.2f}   (count only; literature 318162)", flush=True)
    me, kids = peak_mb()
    print(f"peak memory: this process {me:.0f} MB, largest child {kids:.0f} MB")
    print("* baseline extrapolated from its per-graph rate on a prefix (see --budget); "
          "n/a: counting the unpruned graphs alone exceeds the budget")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        import numpy as np

        fig, ax = plt.subplots(figsize=(8, 4.5))
        x = np.arange(len(rows))
        w = 0.2
        ax.bar(x - 1.5 * w, [r[2] or 0 for r in rows], w, label="count (serial)")
        ax.bar(x - 0.5 * w, [r[3] or 0 for r in rows], w, label="atlas, 1 worker")
        ax.bar(x + 0.5 * w, [r[4] for r in rows], w, label="atlas, 2 workers")
        ax.bar(x + 1.5 * w, [r[5] or 0 for r in rows], w, label="baseline (generate-and-filter)",
               hatch=None, color="grey")
        ax.set_yscale("log")
        ax.set_xticks(x)
        ax.set_xticklabels([f"{r[0]}\n{r[1]} chains" for r in rows], fontsize=8)
        ax.set_ylabel("seconds (log)")
        ax.set_title("Time to the full atlas (bench_atlas.py)")
        ax.legend(fontsize=8)
        ax.grid(axis="y", alpha=0.3)
        fig.tight_layout()
        Path(args.chart).parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(args.chart, dpi=110)
        print(f"chart: {args.chart}")
    except Exception as exc:  # noqa: BLE001 - the numbers are printed anyway
        print(f"no chart: {exc}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
