"""Compile numba's kernels into their disk cache once, at install (``python -m multiloop.warmup``).

numba compiles each kernel on first use and keeps the machine code next to its source
(``cache=True``); a synthesis's first run of an install otherwise pays that compile (tens
of seconds of CPU: every group kind's step, the sensitivities, the tracer, the matching
and the polish's rounds, each caller linking and optimising the kernels it calls), and so
does each test worker of a fresh checkout.  ``install.sh`` runs this module after the
install: a small solve on the compiled plan and small syntheses that take every compiled
route (a four-bar path with free timing matched and searched, prescribed timing, a triad
six-bar with either free timing), each route named, not left to the library's default.
Without numba there is nothing to compile and it says so.  Exit 0 either way: a failed
warm-up only leaves the compile to the first use.
"""
from __future__ import annotations

import sys
import time

import numpy as np

__all__ = ["warm"]


def warm() -> list[str]:
    """Run every compiled route once on small problems; returns what was run."""
    from multiloop.catalogue.dimensional import synthesise
    from multiloop.catalogue.named import load_named
    from multiloop.kin import kernel
    from multiloop.kin.solve import solve

    if kernel.load() is None:
        return []
    done = []
    four_bar = load_named("four_bar")
    with kernel.using("on"):
        for _ in range(2):                  # the second call takes the lean route (the chart cached)
            solve(four_bar, np.linspace(0.0, 2 * np.pi, 400, endpoint=False))
    done.append("solve (compiled plan)")
    deg = np.arange(0.0, 300.0, 60.0)
    T = solve(four_bar, np.radians(deg)).point_positions[:, 0]
    for how in ("matched", "searched"):
        synthesise(four_bar, path=T, point="P", evaluations=400, seed=0, free_timing=how)
        done.append(f"four-bar synthesis, free timing {how}")
    synthesise(four_bar, path=np.column_stack([T, deg]), point="P", evaluations=200, seed=0)
    done.append("four-bar synthesis, prescribed timing")
    triad = load_named("stephenson_3_triad")
    pt = triad.points[0].name
    st = solve(triad, np.radians(np.linspace(0.0, 60.0, 5)))
    for how in ("matched", "searched"):
        synthesise(triad, path=st.point_positions[:, st.point_index(pt)], point=pt, evaluations=200, seed=0,
                   free_timing=how)
    done.append("triad six-bar synthesis, free timing matched and searched")
    return done


def main() -> int:
    t = time.process_time()
    try:
        done = warm()
    except Exception as exc:            # (a warm-up never fails an install)
        print(f"multiloop warm-up: skipped ({type(exc).__name__}: {exc}); kernels compile on first use",
              file=sys.stderr)
        return 0
    if not done:
        print("multiloop warm-up: numba is not installed, nothing to compile")
    else:
        print(f"multiloop warm-up: numba's kernels compiled and cached ({'; '.join(done)}) in "
              f"{time.process_time() - t:.0f} s CPU")
    return 0


if __name__ == "__main__":
    sys.exit(main())
