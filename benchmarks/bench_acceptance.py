"""How topology synthesis accepts a design: the driver's certified motion against the
whole design check (plain script).

Run:  python benchmarks/bench_acceptance.py [--repeat R]

For catalogue mechanisms with one crank, prints the CPU time of the two ways to answer
"does the motion from the reference reach these 24 target inputs on one branch": the
whole ``check(m, positions=…)`` (what topology synthesis ran per design before) and
``motion_events(m).reaches(x)`` (what it runs now), each on a freshly loaded mechanism
(no plan or chart cached), best of R; and asserts that both answer the same.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from multiloop.inputs import load_mechanism  # noqa: E402
from multiloop.kin.check import check  # noqa: E402
from multiloop.kin.solve import motion_events  # noqa: E402

from bench_solve import _cpu_best  # noqa: E402  (the benchmarks' best-of-R in CPU time)

NAMES = ("four_bar", "watt_1", "watt_2", "stephenson_3", "stephenson_3_triad")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    x = np.radians(np.linspace(0.0, 350.0, 24))
    print(f"{'mechanism':20s} {'check':>10s} {'motion':>10s} {'ratio':>6s}")
    for name in NAMES:
        def by_check():
            m = load_mechanism(name)
            return check(m, min_transmission=0.0, positions={m.drivers[0].joint: list(x)}).drivers[0]

        def by_motion():
            return motion_events(load_mechanism(name)).reaches(x)
        t_c, t_m = _cpu_best(by_check, args.repeat), _cpu_best(by_motion, args.repeat)
        assert (len(by_check().unreachable) == 0) == bool(by_motion().all()), name
        print(f"{name:20s} {t_c * 1e3:8.1f}ms {t_m * 1e3:8.1f}ms {t_c / t_m:5.1f}x")


if __name__ == "__main__":
    main()
