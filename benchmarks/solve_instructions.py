"""Instructions executed by one call of the 360-position four-bar solve, ours and
pylinkage's, counted by Valgrind's callgrind: the measure of per-call work that this
virtual machine's timings (±40 % between runs minutes apart) cannot give (plain script;
needs ``valgrind``, a Debian package).

Run:  python benchmarks/solve_instructions.py [--calls 1000]

The goal row "solve four-bar, 360 positions / pylinkage ≤ 0.7×" of ``bench_solve.ratios``,
call by call: ``solve(m, x)`` in a ``kin.kernel.using("on")`` block (all outputs, and
``outputs=["B"]``), and pylinkage's ``step_fast`` run as ``bench_solve`` times it (numba,
the linkage built once, its coordinates reset each call).  Each is called 50 times, then
``--calls`` times under the count (``callgrind_control -i on/off`` around them), in its
own process; an empty call's count is printed too (the loop's own cost).
"""
from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
WHATS = ("ours, all outputs", "ours, one output point", "pylinkage step_fast", "an empty call")


def _call(what: str):
    """The call counted for ``what`` (one of :data:`WHATS`)."""
    sys.path.insert(0, str(HERE))
    import numpy as np
    import bench_solve as b
    from multiloop.kin import kernel
    from multiloop.kin.solve import solve
    m = b.four_bar()
    kernel.load()
    x = np.linspace(0, 2 * np.pi, 360, endpoint=False)
    if what == "pylinkage step_fast":
        return b.pylinkage_run(m, x)[0][2]
    if what == "an empty call":
        return lambda: None
    kw = {"outputs": ["B"]} if what == "ours, one output point" else {}

    def call():
        with kernel.using("on"):
            solve(m, x, **kw)
    return call


def _child(what: str, calls: int) -> None:
    f = _call(what)
    for _ in range(50):
        f()
    subprocess.run(["callgrind_control", "-i", "on", str(os.getpid())], capture_output=True, check=False)
    for _ in range(calls):
        f()
    subprocess.run(["callgrind_control", "-i", "off", str(os.getpid())], capture_output=True, check=False)


def count(what: str, calls: int) -> int:
    """The instructions of ``calls`` calls of ``what``."""
    cmd = ["valgrind", "--tool=callgrind", "--instr-atstart=no", f"--callgrind-out-file={os.devnull}",
           sys.executable, __file__, "--child", what, "--calls", str(calls)]
    p = subprocess.run(cmd, capture_output=True, text=True, check=True)
    return int(re.search(r"Collected : (\d+)", p.stderr).group(1))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=1000)
    ap.add_argument("--child", choices=WHATS, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        _child(a.child, a.calls)
        return
    per = {what: count(what, a.calls) / a.calls for what in WHATS}
    for what, n in per.items():
        print(f"solve four-bar, 360 positions, {what}: {n:,.0f} instructions a call ({a.calls} calls)")
    pl = per["pylinkage step_fast"]
    print(f"ours / pylinkage, all outputs {per['ours, all outputs'] / pl:.3f}, one output point "
          f"{per['ours, one output point'] / pl:.3f} (instructions)")


if __name__ == "__main__":
    main()
