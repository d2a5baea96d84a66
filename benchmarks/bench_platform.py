"""Benchmark: strut forces of six-strut platforms, speed and accuracy of the two methods.

Runs in a few seconds: ``python benchmarks/bench_platform.py [--n 20000]``.

Prints
* time per platform of the batched equilibrium solve (``np.linalg.solve`` on a
  stack), the batched screw method (one SVD per removed strut) and a Python loop
  of single queries (``platform_statics``), as ratios to the batched solve;
* accuracy near singularity: a symmetric hexapod is driven towards its singular
  layout (half angles → 30°); for each condition number, the largest force, the
  residual ``max|Lᵀ S + W| / max|S|`` of each method and their disagreement
  ``max|S_eq − S_screw| / max|S|``.
"""
from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np
import scipy

from multiloop.kin.spatial.platform import (Platform, PointLoad, Strut, condition_numbers, platform_statics, plucker_matrices,
                          strut_forces_equilibrium, strut_forces_screws, symmetric_struts)


def _random_sets(n: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    ap = rng.uniform(0, 2 * np.pi, (n, 6))
    ab = rng.uniform(0, 2 * np.pi, (n, 6))
    P = np.stack([np.cos(ap), np.sin(ap), rng.normal(0, 0.2, (n, 6))], axis=-1)
    B = np.stack([1.5 * np.cos(ab), 1.5 * np.sin(ab), -np.ones((n, 6))], axis=-1)
    W = rng.normal(0, 100, (n, 6))
    return P, B, W


def _time(fn, repeat=3):
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=20000, help="platforms in the batch")
    ap.add_argument("--loop", type=int, default=300, help="platforms in the single-query loop")
    args = ap.parse_args(argv)

    P, B, W = _random_sets(args.n)
    L = plucker_matrices(P, B)
    ok = condition_numbers(P, B) < 1e8
    t_eq, S_eq = _time(lambda: strut_forces_equilibrium(L, W, check=False))
    t_sc, (S_sc, _) = _time(lambda: strut_forces_screws(L, W, check=False))
    plats = [Platform(tuple(Strut(tuple(p), tuple(b))
                            for p, b in zip(P[k], B[k])),
                      (PointLoad((0, 0, 0), tuple(W[k, :3]), tuple(W[k, 3:])),))
             for k in range(args.loop)]
    t_loop, _ = _time(lambda: [platform_statics(p) for p in plats if not p.is_singular], repeat=1)
    per_eq = t_eq / args.n
    per_sc = t_sc / args.n
    per_loop = t_loop / args.loop
    diff = np.abs(S_eq - S_sc)[ok]
    scale = np.maximum(1.0, np.abs(S_eq[ok]))
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"Python {platform.python_version()}, NumPy {np.__version__}, SciPy {scipy.__version__}; "
          f"{os.cpu_count()} CPUs, load average {load:.2f}")
    print(f"batch of {args.n} random platforms ({ok.sum()} with cond < 1e8)")
    print(f"  equilibrium (batched solve)   {per_eq * 1e6:8.2f} µs/platform   ratio 1.00")
    print(f"  screw method (batched SVD)    {per_sc * 1e6:8.2f} µs/platform   ratio {per_sc / per_eq:.2f}")
    print(f"  single queries (Python loop)  {per_loop * 1e6:8.2f} µs/platform   ratio {per_loop / per_eq:.1f}")
    print(f"  max relative disagreement of the methods: {np.max(diff / scale):.2e}")
    print()
    print("towards a singular layout (symmetric hexapod, half angles -> 30 deg)")
    print(f"  {'30° - angle':>11} {'cond':>10} {'max|S| (N)':>11} {'rel resid eq':>13} {'rel resid screw':>16} "
          f"{'disagree':>10}")
    for delta in (10.0, 1.0, 1e-2, 1e-4, 1e-6, 1e-8):
        s = symmetric_struts(1.0, 0.5, 30.0 - delta, 30.0 - delta, 1.0)
        Pp = np.array([x.platform for x in s])
        Bp = np.array([x.base for x in s])
        Lp = plucker_matrices(Pp, Bp)
        w = np.array([10.0, 0.0, -1000.0, 0.0, 5.0, 1.0])
        cond = float(condition_numbers(Pp, Bp))
        se = strut_forces_equilibrium(Lp, w, check=False)
        ss, _ = strut_forces_screws(Lp, w, check=False)
        smax = float(np.max(np.abs(se)))
        re = np.max(np.abs(Lp.T @ se + w)) / smax
        rs = np.max(np.abs(Lp.T @ ss + w)) / smax
        dis = np.max(np.abs(se - ss)) / smax
        print(f"  {delta:>11.0e} {cond:10.3g} {smax:11.3g} {re:13.2e} {rs:16.2e} {dis:10.2e}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
