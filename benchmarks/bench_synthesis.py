"""Benchmark of ``multiloop synthesise`` against pylinkage's and Pyslvs's synthesis (plain script).

Run:  python benchmarks/bench_synthesis.py [--quick] [--no-charts] [--pyslvs-python PY]

``--pyslvs-python`` (or ``$MULTILOOP_PYSLVS_PYTHON``) names an interpreter that has
Pyslvs 22.7.0 (it builds from its sdist only with Cython 3.0: ``pip install 'cython<3.1'
wheel`` then ``pip wheel --no-build-isolation --no-deps pyslvs==22.7.0``, and at run time
its parser needs ``lark-parser`` 0.12, not ``lark`` 1.x: with ``lark`` 1.3 it fails with
``VisitError ... invalid options``); the default
is this interpreter when it imports ``pyslvs``, else the Pyslvs rows are skipped with a
message.

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
* Pyslvs 22.7.0 ``FPlanar`` + its differential evolution (``benchmarks/peers/
  pyslvs_synthesis.py``, run in Pyslvs's interpreter; whole-second budgets 1, 2, 4 s):
  the same start expression (written by ``multiloop convert``'s exporter), ground pivots
  in the same box as ours, link lengths in ``[0, 2 × box]``, one free input angle per
  target.  The problem is passed in mm (×1000) because Pyslvs prints its result
  expression to 4 decimals; the result is read back with our Pyslvs importer;
* ours, ``synthesise(..., method="de")`` and ``method="cmaes"`` at budgets
  0.25 … 4 s from the catalogue four-bar with its joints moved by 25 % (not from
  the answer); the wall time includes the polish (the budget bounds the global
  search only).

Error (the same measure for everyone): the coupler curve of the result over one
turn (36 000 driver steps, continuous branch from the reference; pylinkage's own
simulation for its linkages), and for each target the distance to that polyline; max over targets, relative to the target size.  This ignores the
order of the targets (pylinkage does not impose it); ours also meets them in order.

Function generation (the output joint's rotation against the crank's, the catalogue
four-bar's ``O4``): ``function 3 pairs``, three pairs of the catalogue four-bar (exact;
Freudenstein 1955), and ``log10 7 pairs``, Freudenstein's classic y = log10 x,
1 <= x <= 10, on 60° of crank and 60° of output (7 equally spaced pairs; no four-bar meets
it exactly).  pylinkage ``synthesis.function_generation`` (Freudenstein's equation,
exact for 3 pairs, least squares beyond) is given the absolute angles of the catalogue
four-bar's reference (60° crank, 64.94° rocker) and its ground length; ours starts from
the perturbed four-bar.  Error: the largest output-angle error (deg) over the pairs,
every result solved by ``kin.solve`` on one continuous branch from its first pair.

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


def pyslvs_python(given: str | None) -> str | None:
    """The interpreter that runs Pyslvs, or None (with the reason printed)."""
    import os
    import subprocess
    py = given or os.environ.get("MULTILOOP_PYSLVS_PYTHON") or sys.executable
    r = subprocess.run([py, "-c", "import pyslvs; print(pyslvs.__version__)"], capture_output=True, text=True)
    if r.returncode != 0:
        print(f"Pyslvs rows skipped: {py} cannot import pyslvs (give --pyslvs-python; see the docstring)")
        return None
    print(f"Pyslvs {r.stdout.strip()} in {py}")
    return py


def pyslvs_run(T: np.ndarray, budget: int, py: str) -> tuple[float, float, int, float]:
    """Pyslvs's FPlanar + DE on the target (in mm); our importer reads the result back:
    (the subprocess's wall time, the error, Pyslvs's evaluations, its search's own wall
    time).  A rate is the evaluations over the search's own time: Pyslvs stops its
    ``max_time`` by whole seconds, so its search ran 1.4–1.95 s of a 2-s budget in four
    runs (11:30–11:36 UTC 2026-11-30), and over the budget its rate read up to 30 % low."""
    import json
    import subprocess
    from multiloop.topo.pyslvs import expression_of, mechanism_from_expression
    from dataclasses import replace
    m = start_mechanism()
    mm = replace(m, joints=tuple(replace(j, at=tuple(1000.0 * np.asarray(j.at))) for j in m.joints),
                 points=tuple(replace(q, at=tuple(1000.0 * np.asarray(q.at))) for q in m.points))
    expr, inputs = expression_of(mm)
    xy = np.vstack([np.array([j.at for j in m.joints]), T])
    size = float(np.max(np.ptp(xy, axis=0)))
    lo, hi = xy.min(axis=0) - size, xy.max(axis=0) + size          # our default box (margin 1)
    job = {"expression": expr, "input": inputs, "target": (1000.0 * T).tolist(),
           "box": (1000.0 * np.r_[lo, hi]).tolist(), "upper": 2000.0 * float(np.max(hi - lo)),
           "max_time": int(budget), "algorithm": "DE"}
    t0 = time.perf_counter()
    r = subprocess.run([py, str(ROOT / "benchmarks" / "peers" / "pyslvs_synthesis.py")],
                       input=json.dumps(job), capture_output=True, text=True, check=True)
    wall = time.perf_counter() - t0
    out = json.loads(r.stdout)
    res = mechanism_from_expression(out["expression"], inputs)
    res = replace(res, joints=tuple(replace(j, at=tuple(np.asarray(j.at) / 1000.0)) for j in res.joints),
                  points=tuple(replace(q, at=tuple(np.asarray(q.at) / 1000.0)) for q in res.points))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = solve(res, np.linspace(0.0, 2 * np.pi, 36001))
    return wall, unordered_error(st.point_positions[:, 0], T), out["evaluations"], out["wall"]


def function_targets() -> dict[str, np.ndarray]:
    """(crank rotation, output rotation) in degrees from the reference; output = O4."""
    m = load_named("four_bar")
    sign = -1.0                         # O4 = (rocker, frame): frame w.r.t. rocker = −rocker
    d3 = np.array([0.0, 30.0, 60.0])
    st = solve(m, np.radians(d3))
    exact = np.c_[d3, sign * np.degrees(st.angles[:, st.link_index("rocker")])]
    x = np.linspace(1.0, 10.0, 7)
    rocker_dir = np.sign(exact[-1, 1])  # the output direction of the catalogue four-bar
    log = np.c_[60.0 * (x - 1.0) / 9.0, rocker_dir * 60.0 * np.log10(x)]
    return {"function 3 pairs": exact, "log10 7 pairs": log}


def output_error(m, rows: np.ndarray, offset: float = 0.0) -> float:
    """Largest |output rotation − target| (deg) over the rows, one continuous branch
    from the drawn configuration, whose output is ``offset`` (deg) from the first row."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = solve(m, np.radians(rows[:, 0]))
    got = offset - np.degrees(st.angles[:, st.link_index("rocker")])
    err = np.abs(got - rows[:, 1])
    return float(np.max(err)) if np.all(np.isfinite(err)) else float("inf")


def ours_function(rows: np.ndarray, method: str, budget: float) -> tuple[float, float]:
    t0 = time.perf_counter()
    res = synthesise(start_mechanism(), function=rows, output="O4", method=method, budget=budget, tol=1e-10)
    return time.perf_counter() - t0, output_error(res.mechanism, rows)


def pylinkage_function(rows: np.ndarray) -> tuple[float, float]:
    """pylinkage's Freudenstein synthesis from the catalogue four-bar's absolute angles."""
    from dataclasses import replace
    from pylinkage.synthesis import function_generation
    m = load_named("four_bar")
    B = np.asarray(m.joint("B").at) - np.asarray(m.joint("O4").at)
    th2, th4 = 60.0, float(np.degrees(np.arctan2(B[1], B[0])))
    pairs = [(np.radians(th2 + a), np.radians(th4 - b)) for a, b in rows]   # rocker = −output
    t0 = time.perf_counter()
    r = function_generation(pairs, ground_length=0.1, require_grashof=False)
    wall = time.perf_counter() - t0
    if not r.raw_solutions:
        return wall, float("inf")
    s = r.raw_solutions[0]
    at = {"O2": s.ground_pivot_a, "A": s.crank_pivot_b, "B": s.coupler_pivot_c, "O4": s.ground_pivot_d}
    fb = replace(m, joints=tuple(replace(j, at=tuple(map(float, at[j.name]))) for j in m.joints), points=())
    # the solution is drawn at the first pair (both tables start at (0, 0)); its rocker
    # may sit off the first pair's angle by what the least squares left
    C = np.asarray(s.coupler_pivot_c) - np.asarray(s.ground_pivot_d)
    offset = th4 - float(np.degrees(np.arctan2(C[1], C[0])))
    return wall, output_error(fb, rows, offset)


def eval_rates(n: int = 300) -> dict[str, float]:
    """Evaluations per second: batched, per-candidate objective, per-candidate kin.solve."""
    m = load_named("four_bar")
    T = targets()["four-bar 10 points"]
    sp = design_space(m, ["P"], region=T)
    ev = Evaluator(m, sp)
    pr = Problem(ev, path_target(m, T, "P"))
    rng = np.random.default_rng(0)
    Z = pr.x0 + rng.normal(0.0, 0.003, (n, len(pr.x0)))
    pr.batch(Z)
    batched = 0.0
    for _ in range(20):                    # best of 20 (one batch is a few ms)
        t0 = time.perf_counter()
        pr.batch(Z)
        batched = max(batched, n / (time.perf_counter() - t0))
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


def path_rows(a, budgets, have_pl: bool, py: str | None) -> list:
    rows = []
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
        if py is not None:
            for b in ((1, 2) if a.quick else (1, 2, 4)):
                wall, err, n, _ = pyslvs_run(T, b, py)
                rows.append((name, "Pyslvs FPlanar DE", wall, err))
                print(f"{name:20s} Pyslvs DE max_time {b} s  wall {wall:6.2f} s  error {err:.2e}  "
                      f"({n:,} evaluations)", flush=True)
    return rows


def function_rows(a, budgets, have_pl: bool) -> list:
    rows = []
    for name, F in function_targets().items():
        for method in ("de", "cmaes"):
            for b in budgets:
                wall, err = ours_function(F, method, b)
                rows.append((name, f"ours {method}", wall, err))
                print(f"{name:20s} ours {method:6s} budget {b:5.2f} s  wall {wall:6.2f} s  "
                      f"output error {err:.2e} deg", flush=True)
        if have_pl:
            wall, err = pylinkage_function(F)
            rows.append((name, "pylinkage function_generation", wall, err))
            print(f"{name:20s} pylinkage Freudenstein  wall {wall:6.4f} s  output error {err:.2e} deg "
                  f"(one continuous branch)", flush=True)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer budgets")
    ap.add_argument("--no-charts", action="store_true")
    ap.add_argument("--no-pylinkage", action="store_true")
    ap.add_argument("--no-pyslvs", action="store_true")
    ap.add_argument("--pyslvs-python", default=None, metavar="PY",
                    help="an interpreter with pyslvs (default $MULTILOOP_PYSLVS_PYTHON or this one)")
    a = ap.parse_args(argv)
    budgets = [0.25, 1.0] if a.quick else [0.25, 0.5, 1.0, 2.0, 4.0]
    have_pl = not a.no_pylinkage
    import cma  # noqa: F401  (imported before timing, like numba's compilation)
    if have_pl:
        try:
            import pylinkage
            print(f"pylinkage {pylinkage.__version__}")
            pylinkage_run(targets()["pylinkage example"], 4)      # warm up numba
        except ImportError:
            have_pl = False
    py = None if a.no_pyslvs else pyslvs_python(a.pyslvs_python)
    rows = path_rows(a, budgets, have_pl, py) + function_rows(a, budgets, have_pl)
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
    cols = 3
    fig, axes = plt.subplots(-(-len(names) // cols), cols, figsize=(5 * cols, 4.2 * -(-len(names) // cols)),
                             dpi=110, squeeze=False)
    styles = {"ours de": ("o-", "C0"), "ours cmaes": ("s-", "C1"), "pylinkage path_generation": ("^--", "C3"),
              "pylinkage function_generation": ("^", "C3"), "Pyslvs FPlanar DE": ("v-.", "C2")}
    for ax in axes.ravel()[len(names):]:
        ax.set_visible(False)
    for ax, name in zip(axes.ravel(), names):
        for meth, (mk, col) in styles.items():
            pts = sorted((r[2], r[3]) for r in rows if r[0] == name and r[1] == meth)
            if pts:
                x, y = zip(*pts)
                top = 1e2 if name in function_targets() else 1.0   # no usable mechanism: drawn at the top
                y = [v if np.isfinite(v) else top for v in y]
                ax.loglog(x, np.maximum(y, 1e-16), mk, color=col, label=meth)
        ax.set_title(name)
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel("largest output-angle error (deg)" if name in function_targets()
                      else "max distance to the targets / target size")
        ax.grid(True, which="both", lw=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    CHARTS.mkdir(parents=True, exist_ok=True)
    fig.savefig(CHARTS / "synthesis_error_time.png")
    print(f"chart: {CHARTS / 'synthesis_error_time.png'}")


if __name__ == "__main__":
    raise SystemExit(main())
