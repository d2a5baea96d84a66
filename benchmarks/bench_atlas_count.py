"""Benchmark of number synthesis by counting (``multiloop atlas --table`` beyond 12 links)
against nauty's genbg piped into a compiled filter, and the plan of the 14-link count.

Run::

    python benchmarks/bench_atlas_count.py                  # n = 10, 11 (F = 2) and 12
    python benchmarks/bench_atlas_count.py --sample14 24    # + 24 random 14-link tasks: the estimate
    python benchmarks/bench_atlas_count.py --routes 12      # every 12-link row by two routes
    python benchmarks/bench_atlas_count.py --no-yardstick --routes 14 --joints 9,10 \
        --route-names compiled,python,swapped --against docs/atlas/table_n14_F1.json
    python benchmarks/bench_atlas_count.py --no-yardstick --routes 14 --la 9-4-0-0-1 --mja 3 --route-names python \
        --against docs/atlas/table_n14_F1.json             # one 14-link row, second route
    python benchmarks/bench_atlas_count.py --no-yardstick --simple-rows docs/atlas/table_n14_F1.json

Yardstick: plain ``genbg -d2:2 -Z1`` per joint count with the same degree bounds, piped
into ``benchmarks/c/chainfilter.c`` (``cc -O3 -march=native``), which tests every link
subset of every generated graph in Gray-code order; it counts, it does not tally rows.
Ours: the compiled counter (genbg with ``c/chaincount.c``: degenerate partial chains cut
with their subtree, rows tallied inside), task by task as ``Atlas.count_table`` runs
them, one process.  Both counts must agree.  CPU seconds of the child processes (the
machine is shared: CPU, not wall time, is the measure per core).

``--routes N`` counts every row of the N-link 1-DOF table by the compiled counter and by
the Python route (plain genbg, no pruning, through the NumPy filter and tally) and
prints both totals and any row where they differ (the run fails if one does).

``--sample14 K`` times K of the 704 tasks of the 14-link count, drawn at random (seed 1),
and estimates the whole count's CPU time and chains (mean × 704, with the standard
error), and the wall time on 16 and 64 cores (CPU / cores, at least the longest task).
"""
from __future__ import annotations

import argparse
import json
import os
import random
import sqlite3
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from multiloop.catalogue.atlas_build import parse_assortment  # noqa: E402
from multiloop.catalogue.synthesis import SynthesisOptions, plan_tasks  # noqa: E402
from multiloop.catalogue.synthesis.counter_build import find_counter  # noqa: E402
from multiloop.catalogue.synthesis.counting import count_rows, count_tasks  # noqa: E402
from multiloop.catalogue.synthesis.nauty import _tool, genbg_bounds  # noqa: E402

FILTER_SRC = ROOT / "benchmarks" / "c" / "chainfilter.c"


def children_cpu() -> float:
    t = os.times()
    return t.children_user + t.children_system


def yardstick(opts: SynthesisOptions, exe: Path) -> tuple[float, int]:
    """CPU seconds and count of plain genbg | chainfilter, one run per joint count."""
    c0, total = children_cpu(), 0
    for task in plan_tasks(opts, split=1):
        gen = subprocess.Popen([_tool("genbg"), "-q", *genbg_bounds(task, opts)],
                               stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
        out = subprocess.run([str(exe), str(opts.n), str(task.m)], stdin=gen.stdout, capture_output=True,
                             text=True, check=True).stdout
        gen.stdout.close()
        gen.wait()
        total += int(out)
    return children_cpu() - c0, total


def ours(opts: SynthesisOptions) -> tuple[float, int]:
    """CPU seconds and count of the compiled counter over the count's tasks."""
    c0 = children_cpu()
    total = sum(sum(count_rows(t, opts, "compiled").values()) for t in count_tasks(opts))
    return children_cpu() - c0, total


def sample14(k: int) -> None:
    opts = SynthesisOptions(14, 1)
    tasks = count_tasks(opts)
    picked = random.Random(1).sample(tasks, k)
    cpu, chains = [], []
    for i, task in enumerate(picked, 1):
        c0 = children_cpu()
        found = sum(count_rows(task, opts, "compiled").values())
        cpu.append(children_cpu() - c0)
        chains.append(found)
        print(f"  {i:>3}/{k} {task.key:<22} {cpu[-1]:8.1f} s CPU {found:>9} chains", flush=True)
    N = len(tasks)
    tot, se = statistics.fmean(cpu) * N, statistics.stdev(cpu) / k ** 0.5 * N
    ch, chse = statistics.fmean(chains) * N, statistics.stdev(chains) / k ** 0.5 * N
    print(f"14 links, 1 DOF: {N} tasks; estimate {tot / 3600:.1f} ± {se / 3600:.1f} CPU hours, "
          f"{ch / 1e6:.1f} ± {chse / 1e6:.1f} million chains ({ch / tot:.0f} chains/s/core)")
    for cores in (2, 16, 64):
        print(f"  on {cores:>2} cores: about {max(tot / cores, max(cpu)) / 3600:.2f} h "
              f"(the longest sampled task {max(cpu):.0f} s)")


def routes(n: int, la=None, mja=None, joints=None, names=("compiled", "python"), against=None) -> bool:
    """Rows of the n-link 1-DOF table by several routes: every row, or the row ``la``/``mja``
    (the enumeration restricted to it), or the tasks with ``joints`` joints; each route's
    rows are compared with the first route's and, with ``against`` (a committed table as
    ``multiloop atlas --table --json`` prints it), with that table's rows of the same
    subset."""
    opts = SynthesisOptions(n, 1, la=la, mja=mja)
    tasks = [t for t in count_tasks(opts) if joints is None or t.m in joints]
    tables = {}
    for route in names:
        c0, t0 = children_cpu(), time.process_time()
        table: dict = {}
        for task in tasks:
            for row, k in count_rows(task, opts, route).items():
                table[row] = table.get(row, 0) + k
        tables[route] = table
        print(f"n={n} F=1 {route:<9} {sum(table.values()):>10} chains in {len(table)} rows, "
              f"{children_cpu() - c0 + time.process_time() - t0:.0f} s CPU", flush=True)
    if against is not None:
        rows = json.loads(Path(against).read_text())["table"]
        m_of = {(tuple(r["LA"]), tuple(r["MJA"])): r["n_joints"] for r in rows}
        tables[Path(against).name] = {row: r["chains"] for r in rows if r["chains"]
                                      for row in [_trimmed(r["LA"], r["MJA"])]
                                      if (joints is None or m_of[(tuple(r["LA"]), tuple(r["MJA"]))] in joints)
                                      and (la is None or row[0] == _trimmed(la, ())[0])
                                      and (mja is None or row[1] == _trimmed((), mja)[1])}
    first, *others = tables
    differ = sorted({row for o in others for row in set(tables[first].items()) ^ set(tables[o].items())})
    for row in differ:
        print(f"  differs: {row}")
    by_v: dict = {}
    for (la_, mja_), k in tables[first].items():
        v = sum((j - 1) * c for j, c in enumerate(mja_, 2))
        by_v[v] = by_v.get(v, 0) + k
    print("  by V: " + ", ".join(f"{v}: {k}" for v, k in sorted(by_v.items())))
    print(f"  {len(tables[first])} rows agree across {', '.join(tables)}" if not differ else "  ROUTES DIFFER")
    return not differ


def simple_rows(n: int, against: str) -> bool:
    """The simple-joint rows (V = 0) of a committed n-link table against the simple-joint
    atlas, built by its own route (nauty's geng: links as vertices, joints as edges) and
    stored, counted by [LA]."""
    with tempfile.TemporaryDirectory() as d:
        db = Path(d) / "sj.sqlite"
        c0, t0 = children_cpu(), time.time()
        subprocess.run([sys.executable, "-m", "multiloop", "atlas", "--links", str(n), "--dof", "1", "--simple-joints",
                        "--no-loops", "--no-progress", "--db", str(db)], check=True, stdout=subprocess.DEVNULL)
        with sqlite3.connect(db) as con:
            geng = {_trimmed(json.loads(la), ())[0]: k for la, k in con.execute("SELECT LA, COUNT(*) FROM chains GROUP BY LA")}
    rows = json.loads(Path(against).read_text())["table"]
    table = {_trimmed(r["LA"], ())[0]: r["chains"] for r in rows if r["V"] == 0 and r["chains"]}
    same = geng == table
    print(f"n={n} F=1 V=0: geng route {sum(geng.values())} chains in {len(geng)} rows ({children_cpu() - c0:.0f} s CPU), "
          f"{Path(against).name} {sum(table.values())} in {len(table)} rows: {'every row agrees' if same else 'DIFFER'}")
    return same


def _trimmed(la, mja) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """A row's key as the routes tally it: both assortments without trailing zeros."""
    def cut(xs):
        xs = list(xs)
        while xs and xs[-1] == 0:
            xs.pop()
        return tuple(xs)
    return cut(la), cut(mja)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sample14", type=int, metavar="K", help="time K random tasks of the 14-link count")
    ap.add_argument("--no-12", action="store_true", help="skip the 12-link case")
    ap.add_argument("--no-yardstick", action="store_true", help="skip the comparison with genbg | chainfilter")
    ap.add_argument("--routes", type=int, metavar="N", help="every row of the N-link table by two routes")
    ap.add_argument("--la", help="with --routes: the one row of this link assortment (N2-N3-...)")
    ap.add_argument("--mja", help="with --routes: ... and this multiple-joint assortment (V2-V3-...)")
    ap.add_argument("--joints", help="with --routes: only the tasks with these joint counts (e.g. 9,10)")
    ap.add_argument("--route-names", default="compiled,python", help="routes to compare (compiled,python,swapped)")
    ap.add_argument("--against", metavar="TABLE.json", help="with --routes: compare with a committed table too")
    ap.add_argument("--simple-rows", metavar="TABLE.json",
                    help="the table's simple-joint rows (V = 0) against the geng route's stored atlas")
    args = ap.parse_args(argv)
    if find_counter() is None:
        print("the compiled counter is not built: python3 -m multiloop.catalogue.synthesis.counter_build")
        return 2
    print(f"genbg {_tool('genbg')}, counter {find_counter().name}, python {sys.version.split()[0]}")
    cases = [] if args.no_yardstick else \
        [SynthesisOptions(10, 1), SynthesisOptions(11, 2)] + ([] if args.no_12 else [SynthesisOptions(12, 1)])
    if cases:
        print(f"{'case':<12}{'chains':>9}{'genbg|filter CPU s':>20}{'counter CPU s':>15}{'ratio':>8}{'chains/s/core':>15}")
    with tempfile.TemporaryDirectory() as d:
        exe = Path(d) / "chainfilter"
        subprocess.run(["cc", "-O3", "-march=native", "-o", str(exe), str(FILTER_SRC)], check=True)
        for opts in cases:
            ys, ycount = yardstick(opts, exe)
            us, count = ours(opts)
            assert ycount == count, (opts, ycount, count)
            print(f"n={opts.n} F={opts.F:<5}{count:>9}{ys:>20.1f}{us:>15.1f}{us / ys:>7.2f}x{count / us:>15.0f}",
                  flush=True)
    if args.sample14:
        sample14(args.sample14)
    if args.routes and not routes(args.routes, parse_assortment(args.la, "la"), parse_assortment(args.mja, "mja"),
                                  None if args.joints is None else {int(j) for j in args.joints.split(",")},
                                  tuple(args.route_names.split(",")), args.against):
        return 1
    if args.simple_rows and not simple_rows(json.loads(Path(args.simple_rows).read_text())["table"][0]["K"] * 2 + 2,
                                            args.simple_rows):
        return 1
    print(f"load average at the end: {' '.join(f'{x:.1f}' for x in os.getloadavg())} "
          f"on {os.cpu_count()} cores, {time.strftime('%H:%M UTC', time.gmtime())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
