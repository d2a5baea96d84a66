"""``multiloop bench [NAME ...] [--goals] [--quick]``: run the benchmark scripts of ``benchmarks/``.

Each script times our code against the alternatives in the same run and prints the
ratios; charts go to ``benchmarks/charts/``.  Every line a script prints that states a
goal (it contains ``goal``) is collected and printed again at the end, so the summary
lists every ratio against its goal.  ``--goals`` runs the scripts that carry the
performance goals (analyse, atlas, solve, designs, forces, and the goal table of
``benchmarks/goals.py``).  Needs a source checkout (the scripts
are not installed with the package).
"""
from __future__ import annotations

import contextlib
import io
import os
import runpy
import sys
import time
from pathlib import Path

from multiloop.topo.errors import InputError, explain

BENCH_DIR = Path(__file__).resolve().parents[2] / "benchmarks"
#: the scripts that print the performance goals
GOAL_SCRIPTS = ("analyse", "atlas", "solve", "designs", "forces", "goals")
#: scripts that accept --quick
_QUICK = ("analyse", "atlas", "designs")


def available() -> list[str]:
    return sorted(p.stem[len("bench_"):] for p in BENCH_DIR.glob("bench_*.py"))


def add_arguments(p) -> None:
    p.add_argument("names", nargs="*", help="benchmarks to run (default: all); see --list")
    p.add_argument("--list", action="store_true", help="list the benchmarks")
    p.add_argument("--goals", action="store_true",
                   help="run the benchmarks with performance goals: " + ", ".join(GOAL_SCRIPTS))
    p.add_argument("--quick", action="store_true", help="pass --quick to the scripts that have it")


class _Tee(io.TextIOBase):
    """Write to the terminal and keep a copy."""

    def __init__(self, out):
        self.out, self.copy = out, io.StringIO()

    def write(self, s: str) -> int:
        self.out.write(s)
        self.copy.write(s)
        return len(s)

    def flush(self) -> None:
        self.out.flush()


def _run_script(name: str, quick: bool) -> tuple[str, float]:
    print(f"=== benchmarks/bench_{name}.py", flush=True)
    argv = sys.argv
    sys.argv = [str(BENCH_DIR / f"bench_{name}.py")] + (["--quick"] if quick and name in _QUICK else [])
    tee = _Tee(sys.stdout)
    t0 = time.perf_counter()
    try:
        with contextlib.redirect_stdout(tee):
            runpy.run_path(sys.argv[0], run_name="__main__")
    except SystemExit as exc:
        if exc.code not in (None, 0):
            print(f"bench_{name} exited with {exc.code}", file=sys.stderr)
    finally:
        sys.argv = argv
    return tee.copy.getvalue(), time.perf_counter() - t0


def run(args) -> int:
    if not BENCH_DIR.is_dir():
        raise InputError(explain("benchmarks", expected=f"the folder {BENCH_DIR}",
                                 got="nothing", hint="run from a source checkout"))
    names = available()
    if args.list:
        print("\n".join(names))
        return 0
    chosen = args.names or ([n for n in GOAL_SCRIPTS if n in names] if args.goals else names)
    unknown = [n for n in chosen if n not in names]
    if unknown:
        raise InputError(explain("benchmark", expected=f"one of {', '.join(names)}",
                                 got=", ".join(unknown)))
    summary = []
    for name in chosen:
        out, seconds = _run_script(name, args.quick)
        summary += [(name, line.strip()) for line in out.splitlines() if "goal" in line.lower()]
        print(f"(bench_{name}: {seconds:.0f} s)", flush=True)
    if summary:
        print("=== goals (every line above that states a goal)")
        for name, line in summary:
            print(f"[{name}] {line}")
    load = os.getloadavg() if hasattr(os, "getloadavg") else ()
    if load:
        print(f"machine load average {load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f} on {os.cpu_count()} cores")
    return 0
