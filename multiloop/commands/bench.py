"""``multiloop bench [NAME ...] [-- ARGS]``: run the benchmark scripts of ``benchmarks/``.

Each script times our code against the alternatives in the same run and prints the
ratios; charts go to ``benchmarks/charts/``.  Needs a source checkout (the scripts
are not installed with the package).
"""
from __future__ import annotations

import runpy
import sys
from pathlib import Path

from multiloop.topo.errors import InputError, explain

BENCH_DIR = Path(__file__).resolve().parents[2] / "benchmarks"


def available() -> list[str]:
    return sorted(p.stem[len("bench_"):] for p in BENCH_DIR.glob("bench_*.py"))


def add_arguments(p) -> None:
    p.add_argument("names", nargs="*", help="benchmarks to run (default: all); see --list")
    p.add_argument("--list", action="store_true", help="list the benchmarks")


def run(args) -> int:
    if not BENCH_DIR.is_dir():
        raise InputError(explain("benchmarks", expected=f"the folder {BENCH_DIR}",
                                 got="nothing", hint="run from a source checkout"))
    names = available()
    if args.list:
        print("\n".join(names))
        return 0
    chosen = args.names or names
    unknown = [n for n in chosen if n not in names]
    if unknown:
        raise InputError(explain("benchmark", expected=f"one of {', '.join(names)}",
                                 got=", ".join(unknown)))
    for name in chosen:
        print(f"=== benchmarks/bench_{name}.py", flush=True)
        argv = sys.argv
        sys.argv = [str(BENCH_DIR / f"bench_{name}.py")]
        try:
            runpy.run_path(sys.argv[0], run_name="__main__")
        except SystemExit as exc:
            if exc.code not in (None, 0):
                print(f"bench_{name} exited with {exc.code}", file=sys.stderr)
        finally:
            sys.argv = argv
    return 0
