"""Prescribed timing's search: the targets' driver values alone against the driver grid.

The search scores a candidate at the targets' driver values alone
(``Problem.score_at``); the route before solved the 96-sample driver grid with them and
scored a candidate only when the grid's samples from the reference reached every target.
Either way the chosen design's continuity is the certified walk's answer.  This script
compares the two searches on random prescribed four-bar problems whose targets a design
reaches continuously (the catalogue four-bar's joints and point moved by ``--spread`` of
its size, kept when ``solve`` walks it over the targets' span; 5–8 targets over 30–300°,
either sense), each synthesised from the catalogue four-bar with both routes, seeds
0–2 and an evaluation budget (the same work on any machine):

    python benchmarks/bench_prescribed_search.py [--problems 30] [--seed 2] [--spread 0.45]

Per problem and seed: the largest error relative to the size, ``!`` where the returned
design is not certified to reach its targets in order (or misses a constraint), and the
CPU seconds; then per route the exact designs (error < 1e-12), the median and geometric
mean error, the uncertified ones and the CPU total.
"""
from __future__ import annotations

import argparse
import time
import warnings
from dataclasses import replace

import numpy as np

from multiloop.catalogue.dimensional import synthesise
from multiloop.catalogue.dimensional.objective import Problem
from multiloop.catalogue.named import load_named
from multiloop.kin.solve import solve

ROUTES = {"targets": Problem.targets_only, "grid": lambda self, tim: False}


def problems(count: int, seed: int, spread: float):
    """``count`` random problems ``(path (n, 3) in degrees, span °, sense)``."""
    base = load_named("four_bar")
    xy = np.array([j.at for j in base.joints])
    size = float(np.max(np.ptp(xy, axis=0)))
    rng = np.random.default_rng(seed)
    while count:
        js = [replace(j, at=tuple(np.asarray(j.at) + rng.normal(0, spread * size, 2))) for j in base.joints]
        pt = replace(base.points[0], at=tuple(np.asarray(base.points[0].at) + rng.normal(0, spread * size, 2)))
        m = replace(base, joints=tuple(js), points=(pt,))
        sense, span = rng.choice([-1.0, 1.0]), np.radians(rng.uniform(30, 300))
        try:
            reached = np.asarray(solve(m, sense * np.linspace(0, span, 400)).ok).all()
        except Exception:               # (a design whose reference does not assemble: drawn again)
            continue
        if not reached:
            continue
        count -= 1
        th = np.sort(rng.uniform(0, span, int(rng.integers(5, 9)))) * sense
        yield np.column_stack([solve(m, th).point_positions[:, 0], np.degrees(th)]), np.degrees(span), sense


def run(path, route: str, seed: int, evaluations: int):
    """One synthesis: (relative error, certified and met, CPU s)."""
    base = load_named("four_bar")
    size = float(np.max(np.ptp(np.array([j.at for j in base.joints]), axis=0)))
    Problem.targets_only = ROUTES[route]
    try:
        t = time.process_time()
        r = synthesise(base, path=path, point=base.points[0].name, evaluations=evaluations, seed=seed,
                       timing="reference")
        cpu = time.process_time() - t
    finally:
        Problem.targets_only = ROUTES["targets"]
    ok = all(c["met"] for c in r.constraints) and not any("continuous" in x for x in r.notes)
    err = float(np.max(np.hypot(*(np.asarray(r.achieved) - np.asarray(r.target)).T))) / size
    return err, ok, cpu


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problems", type=int, default=30)
    ap.add_argument("--seed", type=int, default=2)
    ap.add_argument("--spread", type=float, default=0.45)
    ap.add_argument("--evaluations", type=int, default=8000)
    a = ap.parse_args()
    warnings.simplefilter("ignore")
    out = {k: [] for k in ROUTES}
    for i, (path, span, sense) in enumerate(problems(a.problems, a.seed, a.spread), 1):
        for route in ROUTES:
            cells = []
            for seed in range(3):
                err, ok, cpu = run(path, route, seed, a.evaluations)
                out[route].append((err, ok, cpu))
                cells.append(f"{err:.1e}{'' if ok else '!'} ({cpu:.2f} s)")
            print(f"problem {i} ({len(path)} targets over {span:.0f}°, sense {sense:+.0f}) {route}: "
                  + "  ".join(cells), flush=True)
    for route, rows in out.items():
        e = np.array([r[0] for r in rows])
        print(f"{route}: {len(e)} runs, exact {(e < 1e-12).sum()}, median error {np.median(e):.2g}, "
              f"geometric mean {np.exp(np.mean(np.log(np.fmax(e, 1e-300)))):.2g}, "
              f"not certified {sum(not r[1] for r in rows)}, CPU {sum(r[2] for r in rows):.1f} s")


if __name__ == "__main__":
    main()
