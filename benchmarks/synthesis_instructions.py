"""Instructions executed by one synthesis run, counted by Valgrind's callgrind: the
measure of work that this virtual machine's timings (±50 % between runs of the same
code) cannot give (plain script; needs ``valgrind``, a Debian package).

Run:  python benchmarks/synthesis_instructions.py [--evaluations 30000] [--seed 0] [--search]
      [--case four-bar|triad] [--free-timing matched|searched]

The four-bar's ten points of ``bench_synthesis`` (or the Stephenson III triad's,
``--case triad``; free timing, DE, an evaluation budget: the same work whatever the
load) are synthesised twice in one process under callgrind,
the first run with another seed so that every compiled function is loaded from numba's
disk cache before the count (loading links object code with LLVM: billions of
instructions), the second counted alone (``callgrind_control -i on/off`` around it).
Two versions of the code compare by their counts when they return the same design
(the line prints its error)."""
from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def _case(case: str):
    """(start mechanism, target points, tracer point) of ``case``: the four-bar's ten
    points of ``bench_synthesis``, or the Stephenson III triad's of
    ``bench_designs.triad_synthesis_goal``."""
    sys.path.insert(0, str(HERE))
    import bench_synthesis as bs
    if case == "four-bar":
        return bs.start_mechanism(), bs.targets()["four-bar 10 points"], "P"
    from bench_designs import triad_case
    return triad_case()


def _child(evaluations: int, seed: int, search: bool, case: str, free_timing: str) -> None:
    from multiloop.catalogue.dimensional import synthesise
    start, T, point = _case(case)
    if search:                              # the global search alone (DE, no probes, no polish)
        from bench_designs import _path_problem
        from multiloop.catalogue.dimensional.budget import Budget, Meter
        from multiloop.catalogue.dimensional.optimise import global_search
        from multiloop.catalogue.dimensional.synthesise import _search_view
        problem = _search_view(_path_problem(start, T, point), free_timing)
        def run(s):
            return global_search(problem, seed=s, meter=Meter.start(Budget.of(evaluations)), tol=0.0)
    else:
        def run(s):
            return synthesise(start, path=T, point=point, method="de", evaluations=evaluations, seed=s,
                              free_timing=free_timing)
    run(seed + 1)
    subprocess.run(["callgrind_control", "-i", "on", str(os.getpid())], capture_output=True, check=False)
    r = run(seed)
    subprocess.run(["callgrind_control", "-i", "off", str(os.getpid())], capture_output=True, check=False)
    error = r.error_max if hasattr(r, "error_max") else r.fun
    print(f"result: {r.evaluations} evaluations, error {error:.9e}", flush=True)


def count(evaluations: int, seed: int, out: str = os.devnull, search: bool = False,
          case: str = "four-bar", free_timing: str = "matched") -> tuple[int, str]:
    """The instructions of the counted run (``search``: the global search alone) and its
    result line."""
    cmd = ["valgrind", "--tool=callgrind", "--instr-atstart=no", f"--callgrind-out-file={out}",
           sys.executable, __file__, "--child", "--evaluations", str(evaluations), "--seed", str(seed),
           "--case", case, "--free-timing", free_timing, *(["--search"] if search else [])]
    p = subprocess.run(cmd, capture_output=True, text=True, check=True)
    got = re.search(r"Collected : (\d+)", p.stderr)
    line = next((x for x in p.stdout.splitlines() if x.startswith("result:")), "")
    return int(got.group(1)), line


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--evaluations", type=int, default=30_000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--search", action="store_true", help="count the global search alone (DE: no probes, no polish)")
    ap.add_argument("--case", choices=("four-bar", "triad"), default="four-bar",
                    help="the four-bar's ten points, or the Stephenson III triad's (the triad goal's case)")
    ap.add_argument("--free-timing", choices=("matched", "searched"), default="matched",
                    help="synthesise's free_timing (what the search varies)")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        _child(a.evaluations, a.seed, a.search, a.case, a.free_timing)
        return
    n, line = count(a.evaluations, a.seed, search=a.search, case=a.case, free_timing=a.free_timing)
    what = "the global search alone" if a.search else "synthesis"
    print(f"{what}, {a.case} 10 points, free timing {a.free_timing}, {a.evaluations} evaluations, seed {a.seed}: "
          f"{n:,} instructions "
          f"({n / a.evaluations:,.0f} an evaluation); {line}")


if __name__ == "__main__":
    main()
