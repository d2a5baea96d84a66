"""``multiloop bench [NAME ...] [--goals] [--quick]``: run the benchmark scripts of ``benchmarks/``.

Each script times our code against the alternatives in the same run and prints the
ratios; charts go to ``benchmarks/charts/``.  Every line a script prints that states a
goal (it contains ``goal``) is collected and printed again at the end, so the summary
lists every ratio against its goal.  ``--goals`` runs the scripts that carry the
performance goals (analyse, atlas, solve, designs, synthesis_literature, forces, and the
goal table of ``benchmarks/goals.py``).  Needs a source checkout (the scripts are not
installed with the package).
"""
from __future__ import annotations

from pathlib import Path

from multiloop.benchrun import available, run_benchmarks
from multiloop.topo.errors import InputError, explain

BENCH_DIR = Path(__file__).resolve().parents[2] / "benchmarks"
#: the scripts that print the performance goals
GOAL_SCRIPTS = ("analyse", "atlas", "solve", "designs", "synthesis_literature", "forces", "goals")


def add_arguments(p) -> None:
    p.add_argument("names", nargs="*", help="benchmarks to run (default: all); see --list")
    p.add_argument("--list", action="store_true", help="list the benchmarks")
    p.add_argument("--goals", action="store_true",
                   help="run the benchmarks with performance goals: " + ", ".join(GOAL_SCRIPTS))
    p.add_argument("--quick", action="store_true", help="pass --quick to the scripts that have it")


def run(args) -> int:
    if not BENCH_DIR.is_dir():
        raise InputError(explain("benchmarks", expected=f"the folder {BENCH_DIR}",
                                 got="nothing", hint="run from a source checkout"))
    names = available(BENCH_DIR)
    if args.list:
        print("\n".join(names))
        return 0
    chosen = args.names or ([n for n in GOAL_SCRIPTS if n in names] if args.goals else names)
    unknown = [n for n in chosen if n not in names]
    if unknown:
        raise InputError(explain("benchmark", expected=f"one of {', '.join(names)}",
                                 got=", ".join(unknown)))
    run_benchmarks(BENCH_DIR, chosen, args.quick)
    return 0
