"""Running the benchmark scripts of a source checkout (``multiloop bench``).

Each ``bench_<name>.py`` times our code against the alternatives in the same run and
prints the ratios.  :func:`run_benchmarks` runs the scripts one after the other in
this process, shows their output as it comes, and then prints again every line that
states a goal (it contains ``goal``), so the summary lists every ratio against its
goal, and the machine's load average.
"""
from __future__ import annotations

import contextlib
import io
import os
import runpy
import sys
import time
from pathlib import Path

__all__ = ["available", "run_benchmarks"]

#: scripts that accept --quick
QUICK = ("analyse", "atlas", "designs", "synthesis_literature", "web")


def available(bench_dir: Path) -> list[str]:
    """The names of the ``bench_<name>.py`` scripts in ``bench_dir``, sorted."""
    return sorted(p.stem[len("bench_"):] for p in Path(bench_dir).glob("bench_*.py"))


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


def _run_script(bench_dir: Path, name: str, quick: bool) -> tuple[str, float]:
    print(f"=== benchmarks/bench_{name}.py", flush=True)
    argv = sys.argv
    sys.argv = [str(Path(bench_dir) / f"bench_{name}.py")] + (["--quick"] if quick and name in QUICK else [])
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


def run_benchmarks(bench_dir: Path, names, quick: bool = False) -> None:
    """Run ``bench_<name>.py`` of ``bench_dir`` for each name (``--quick`` to those in
    :data:`QUICK` when ``quick``), then print the goal lines and the load average."""
    summary = []
    for name in names:
        out, seconds = _run_script(bench_dir, name, quick)
        summary += [(name, line.strip()) for line in out.splitlines() if "goal" in line.lower()]
        print(f"(bench_{name}: {seconds:.0f} s)", flush=True)
    if summary:
        print("=== goals (every line above that states a goal)")
        for name, line in summary:
            print(f"[{name}] {line}")
    load = os.getloadavg() if hasattr(os, "getloadavg") else ()
    if load:
        print(f"machine load average {load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f} on {os.cpu_count()} cores")
