"""Benchmark of ``multiloop synthesise`` against pylinkage's synthesis (plain script).

Run:  python benchmarks/bench_synthesis.py [--quick] [--no-charts]

Targets (path generation, free timing):

* ``pylinkage example``: the four points of pylinkage's ``path_generation``
  docstring, ``(0, 1), (1, 2), (2, 1.5), (3, 0)``;
* ``four-bar 5 points``: five points of the catalogue four-bar's coupler curve
  (crank at 0°, 60°, 120°, 180°, 240°; an exact target);
* ``four-bar 10 points``: ten points of the same curve (every 33° from 7°).

Methods, each timed warm (numba compiled, imports done):

* pylinkage ``synthesis.path_generation`` (Burmester orientation search, the first
  verified solution; ``orientation_resolution`` 4 and 6) — 4 and 5 points only,
  its search grows as resolution^(points − 1);
* ours, ``synthesise(..., method="de")`` and ``method="cmaes"`` at budgets
  0.25 … 4 s from the catalogue four-bar with its joints moved by 25 % (not from
  the answer); the wall time includes the polish (the budget bounds the global
  search only).

Error (the same measure for everyone): the coupler curve of the result over one
turn (36 000 driver steps, continuous branch from the reference; pylinkage's own
simulation for its linkages), and for each target the distance to that polyline; max over targets, relative to the target size.  This ignores the
order of the targets (pylinkage does not impose it); ours also meets them in order.

Evaluations per second: our batched objective (a population of 300 in one call)
against the same objective called once per candidate, and against building the
mechanism and calling ``kin.solve`` once per candidate.

Chart: benchmarks/charts/synthesis_error_time.png (error vs wall time, one curve per
method, one panel per target).
"""
from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from multiloop.catalogue.dimensional import Evaluator, Problem, design_space, path_target, synthesise  # noqa: E402
from multiloop.catalogue.named import load_named  # noqa: E402
from multiloop.kin.solve import solve  # noqa: E402

CHARTS = ROOT / "benchmarks" / "charts"


def targets() -> dict[str, np.ndarray]:
    m = load_named("four_bar")
    c5 = solve(m, np.radians(np.arange(0.0, 300.0, 60.0))).point_positions[:, 0]
    c10 = solve(m, np.radians(np.arange(7.0, 360.0, 33.0))[:10]).point_positions[:, 0]
    return {"pylinkage example": np.array([(0, 1), (1, 2), (2, 1.5), (3, 0)], float),
            "four-bar 5 points": c5, "four-bar 10 points": c10}


def unordered_error(curve: np.ndarray, T: np.ndarray) -> float:
    """max over targets of the distance to the sampled curve (as a polyline between
    consecutive finite samples), relative to the target size."""
    ok = np.all(np.isfinite(curve), axis=1)
    seg = ok[:-1] & ok[1:]
    if not seg.any():
        return float("inf")
    a, b = curve[:-1][seg], curve[1:][seg]
    ab = b - a
    L2 = np.maximum(np.sum(ab * ab, axis=1), 1e-300)
    d = []
    for t in T:
        u = np.clip(np.sum((t - a) * ab, axis=1) / L2, 0.0, 1.0)
        q = a + u[:, None] * ab
        d.append(np.min(np.hypot(*(q - t).T)))
    return float(max(d) / np.max(np.ptp(T, axis=0)))


def start_mechanism():
    """The catalogue four-bar with every joint moved by 25 % of its size (seed 1): a
    generic start, not the answer (a polish from it alone does not reach the targets)."""
    from dataclasses import replace
    m = load_named("four_bar")
    rng = np.random.default_rng(1)
    js = [replace(j, at=tuple(np.asarray(j.at) + rng.normal(0.0, 0.025, 2))) for j in m.joints]
    return replace(m, joints=tuple(js))


def ours(T: np.ndarray, method: str, budget: float, seed: int = 0) -> tuple[float, float, float]:
    m = start_mechanism()
    t0 = time.perf_counter()
    res = synthesise(m, path=T, point="P", method=method, budget=budget, seed=seed, tol=1e-9)
    wall = time.perf_counter() - t0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = solve(res.mechanism, np.linspace(0.0, 2 * np.pi, 36001))
    return wall, unordered_error(st.point_positions[:, 0], T), res.error_max


def pylinkage_run(T: np.ndarray, resolution: int) -> tuple[float, float]:
    from pylinkage.synthesis import path_generation
    t0 = time.perf_counter()
    r = path_generation([tuple(p) for p in T], max_solutions=1, orientation_resolution=resolution)
    wall = time.perf_counter() - t0
    if not r.solutions:
        return wall, float("inf")
    L = r.solutions[0]
    traj = L.step_fast(iterations=36000, dt=0.01)
    return wall, unordered_error(traj[:, -1, :], T)


def eval_rates(n: int = 300) -> dict[str, float]:
    """Evaluations per second: batched, per-candidate objective, per-candidate kin.solve."""
    m = load_named("four_bar")
    T = targets()["four-bar 10 points"]
    sp = design_space(m, ["P"], region=T)
    ev = Evaluator(m, sp)
    pr = Problem(ev, path_target(m, T, "P"))
    rng = np.random.default_rng(0)
    Z = pr.x0 + rng.normal(0.0, 0.003, (n, len(pr.x0)))
    pr.batch(Z[:10])
    t0 = time.perf_counter()
    pr.batch(Z)
    batched = n / (time.perf_counter() - t0)
    t0 = time.perf_counter()
    for z in Z:
        pr.batch(z[None, :])
    loop = n / (time.perf_counter() - t0)
    k = max(n // 6, 10)
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for z in Z[:k]:
            solve(ev.with_design(z), pr.grid)
    per_solve = k / (time.perf_counter() - t0)
    return {"batched objective": batched, "objective per candidate": loop, "kin.solve per candidate": per_solve}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer budgets")
    ap.add_argument("--no-charts", action="store_true")
    ap.add_argument("--no-pylinkage", action="store_true")
    a = ap.parse_args(argv)
    budgets = [0.25, 1.0] if a.quick else [0.25, 0.5, 1.0, 2.0, 4.0]
    rows = []
    have_pl = not a.no_pylinkage
    import cma  # noqa: F401  (imported before timing, like numba's compilation)
    if have_pl:
        try:
            import pylinkage  # noqa: F401
            pylinkage_run(targets()["pylinkage example"], 4)      # warm up numba
        except ImportError:
            have_pl = False
    for name, T in targets().items():
        for method in ("de", "cmaes"):
            for b in budgets:
                wall, err, ordered = ours(T, method, b)
                rows.append((name, f"ours {method}", wall, err))
                print(f"{name:20s} ours {method:6s} budget {b:5.2f} s  wall {wall:6.2f} s  "
                      f"error {err:.2e} (in order {ordered:.2e})", flush=True)
        if have_pl and len(T) <= 5:
            for res in ((4, 6) if not a.quick else (4,)):
                wall, err = pylinkage_run(T, res)
                rows.append((name, "pylinkage path_generation", wall, err))
                print(f"{name:20s} pylinkage resolution {res}  wall {wall:6.2f} s  error {err:.2e}", flush=True)
    rates = eval_rates()
    for k, v in rates.items():
        print(f"evaluations per second, {k}: {v:,.0f}")
    print(f"batched / per candidate: {rates['batched objective'] / rates['objective per candidate']:.0f}x; "
          f"batched / kin.solve per candidate: {rates['batched objective'] / rates['kin.solve per candidate']:.0f}x")
    if not a.no_charts:
        chart(rows)
    return 0


def chart(rows) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    names = list(dict.fromkeys(r[0] for r in rows))
    fig, axes = plt.subplots(1, len(names), figsize=(5 * len(names), 4.2), dpi=110, squeeze=False)
    styles = {"ours de": ("o-", "C0"), "ours cmaes": ("s-", "C1"), "pylinkage path_generation": ("^--", "C3")}
    for ax, name in zip(axes[0], names):
        for meth, (mk, col) in styles.items():
            pts = sorted((r[2], r[3]) for r in rows if r[0] == name and r[1] == meth)
            if pts:
                x, y = zip(*pts)
                y = [v if np.isfinite(v) else 1.0 for v in y]
                ax.loglog(x, np.maximum(y, 1e-16), mk, color=col, label=meth)
        ax.set_title(name)
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel("max distance to the targets / target size")
        ax.grid(True, which="both", lw=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    CHARTS.mkdir(parents=True, exist_ok=True)
    fig.savefig(CHARTS / "synthesis_error_time.png")
    print(f"chart: {CHARTS / 'synthesis_error_time.png'}")


if __name__ == "__main__":
    raise SystemExit(main())
