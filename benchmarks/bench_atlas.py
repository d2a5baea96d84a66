"""Benchmark of the atlas against nauty's genbg piped into a compiled filter.

Run::

    python benchmarks/bench_atlas.py            # n = 10 and 11 (a few minutes on 2 busy cores)
    python benchmarks/bench_atlas.py --with-12  # also n = 12

Yardstick: the same generator commands as the atlas (``geng -t`` for simple joints,
``genbg -d2:2 -Z1`` per joint count; ``-Z1`` is safe: two joints sharing two links make a
rigid pair), one run per joint count, piped into ``benchmarks/c/chainfilter.c``
(compiled here with ``cc -O2``), which counts the non-degenerate chains by visiting
every link subset in Gray-code order.  Ours: ``multiloop atlas`` into a fresh SQLite
file (canonical forms, codes, planarity, fractionation; [La] where the command computes
it by default, n <= 10), with the command's default workers (all cores) and with one.
Both counts must agree.  Times are wall clock, min of ``--repeat`` runs; CPU seconds
(this process and its children) are printed beside them because the machine is shared.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from multiloop.catalogue.atlas import Atlas  # noqa: E402
from multiloop.catalogue.synthesis import LITERATURE_SJ_F1, SynthesisOptions, plan_tasks  # noqa: E402
from multiloop.catalogue.synthesis.nauty import _generator_command, _tool  # noqa: E402

GOAL = 1.5   # issue 11: multiloop atlas --links 11 --dof 2 within 1.5x of genbg + compiled filter
FILTER_SRC = ROOT / "benchmarks" / "c" / "chainfilter.c"


def build_filter(workdir: Path) -> Path:
    exe = workdir / "chainfilter"
    subprocess.run(["cc", "-O2", "-o", str(exe), str(FILTER_SRC)], check=True)
    return exe


def cpu() -> float:
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def yardstick(opts: SynthesisOptions, exe: Path) -> tuple[float, float, int]:
    """Wall seconds, CPU seconds and count of generator | chainfilter, task by task."""
    t0, c0, total = time.perf_counter(), cpu(), 0
    for task in plan_tasks(opts, split=1):
        cmd = _generator_command(task, opts)
        gen = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
        m = 0 if task.m == opts.p else task.m
        out = subprocess.run([str(exe), str(opts.n), str(m)], stdin=gen.stdout, capture_output=True,
                             text=True, check=True).stdout
        gen.stdout.close()
        gen.wait()
        total += int(out)
    return time.perf_counter() - t0, cpu() - c0, total


def ours(opts: SynthesisOptions, workers: int | None) -> tuple[float, float, int]:
    """``multiloop atlas --links n --dof F`` into a fresh file (the command's defaults)."""
    with tempfile.TemporaryDirectory() as d:
        with Atlas(Path(d) / "bench.sqlite") as atlas:
            t0, c0 = time.perf_counter(), cpu()
            r = atlas.build(opts, loops=opts.n <= 10, workers=workers, progress=False)
            return time.perf_counter() - t0, cpu() - c0, r.count


def versions() -> str:
    def first(cmd):
        try:
            return subprocess.run(cmd, capture_output=True, text=True).stdout.splitlines()[0]
        except (OSError, IndexError):
            return "?"
    nauty = first(["dpkg-query", "-W", "-f", "${Version}", "nauty"])
    return f"nauty {nauty} ({_tool('genbg')}), {first(['cc', '--version'])}, python {sys.version.split()[0]}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--with-12", action="store_true", help="also the 12-link 1-DOF atlases")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--quick", action="store_true", help="one repeat, no 1-worker column")
    args = ap.parse_args(argv)
    repeat = 1 if args.quick else args.repeat
    print(versions())
    cases = [("SJ F=1 n=10", SynthesisOptions(10, 1, simple_joints=True)),
             ("MJ F=1 n=10", SynthesisOptions(10, 1)),
             ("MJ F=2 n=11", SynthesisOptions(11, 2))]
    if args.with_12:
        cases += [("SJ F=1 n=12", SynthesisOptions(12, 1, simple_joints=True)),
                  ("MJ F=1 n=12", SynthesisOptions(12, 1))]
    print(f"{'case':<13}{'chains':>8}{'yardstick s':>13}{'cpu':>7}{'ours s':>9}{'cpu':>7}"
          f"{'ours 1w s':>11}{'ratio':>8}")
    with tempfile.TemporaryDirectory() as d:
        exe = build_filter(Path(d))
        for name, opts in cases:
            ys = min((yardstick(opts, exe) for _ in range(repeat)), key=lambda r: r[0])
            us = min((ours(opts, None) for _ in range(repeat)), key=lambda r: r[0])
            one = None if args.quick else ours(opts, 1)
            assert ys[2] == us[2], (name, ys[2], us[2])
            if opts.simple_joints and opts.F == 1:
                assert us[2] == LITERATURE_SJ_F1[opts.n]
            ratio = us[0] / ys[0]
            print(f"{name:<13}{us[2]:>8}{ys[0]:>13.2f}{ys[1]:>7.1f}{us[0]:>9.2f}{us[1]:>7.1f}"
                  f"{'' if one is None else f'{one[0]:.2f}':>11}{ratio:>7.2f}x", flush=True)
            if name == "MJ F=2 n=11":
                print(f"goal atlas --links 11 --dof 2 / (genbg -Z1 + compiled filter): {ratio:.2f}x wall, "
                      f"{us[1] / ys[1]:.2f}x CPU (goal <= {GOAL}x) -> {'met' if ratio <= GOAL else 'NOT met'}",
                      flush=True)
    print(f"load average at the end: {' '.join(f'{x:.1f}' for x in os.getloadavg())} on {os.cpu_count()} cores")
    return 0


if __name__ == "__main__":
    sys.exit(main())
