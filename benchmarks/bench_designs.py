"""Many designs through one solver: coupler curves of D designs × N positions (plain script).

Run:  python benchmarks/bench_designs.py [--quick]

Measured in one run, each the best of a few repeats (CPU, one thread):

* four-bar coupler curves, D = 10⁴ designs × N = 96 positions:
  ``kin.design.solve_designs(..., outputs=["P"])`` on the compiled route (synthesis's;
  the NumPy route's ratio beside it) against a bare NumPy closed form of
  the same curves (crank cos/sin, one RRR, the coupler point; no status, no pose store);
* Stephenson III (class III triad) curves, D = 10³ × N = 96: the batch (the compiled
  tracker, ``kin/groups/_triad_nb.py``, when numba is installed, as synthesis's
  objective runs it; else NumPy's) against the per-candidate route (each design's steps
  run alone along the inputs: the NumPy triad tracker once per candidate, as synthesis
  did before the batch existed);
* synthesis evaluations per second, four-bar path with free timing (10 points, DE, 2 s):
  ``synthesise`` (its objective scores each candidate on a 96-position grid for order
  and continuity) against Pyslvs 22.07's ``FPlanar`` with its DE
  (``benchmarks/peers/pyslvs_synthesis.py``, run in an interpreter that has Pyslvs:
  ``--pyslvs-python`` or ``$MULTILOOP_PYSLVS_PYTHON``), evaluations over its search's
  own wall time (it stops its ``max_time`` by whole seconds, often early);
* where that synthesis's time goes (:func:`synthesis_parts`): the population objective
  per candidate and its curves, and each part of one trust-region iteration of the
  polish beside the pose store's route that its tracer call replaced.

Each line that states a goal is collected by ``multiloop bench --goals``.
"""
from __future__ import annotations

import argparse
import contextlib
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from multiloop.catalogue.dimensional import design_space  # noqa: E402
from multiloop.catalogue.named import load_named  # noqa: E402
from multiloop.kin import kernel  # noqa: E402
from multiloop.kin.design import design_mechanism, solve_designs  # noqa: E402
from multiloop.kin.design import _one_design  # noqa: E402  (the per-candidate route, for the ratio)
from multiloop.kin.solve import plan_of  # noqa: E402


def _best(f, repeat=3):
    best, out = np.inf, None
    for _ in range(repeat):
        t = time.perf_counter()
        out = f()
        best = min(best, time.perf_counter() - t)
    return best, out


def _alternated(fns, rounds=5):
    """``(best seconds, last result)`` of each of ``fns``, called in turn for ``rounds``
    rounds (the same machine for each: its speed drifts within seconds)."""
    best, out = [np.inf] * len(fns), [None] * len(fns)
    for _ in range(rounds):
        for i, f in enumerate(fns):
            t = time.perf_counter()
            out[i] = f()
            best[i] = min(best[i], time.perf_counter() - t)
    return list(zip(best, out))


def _population(m, D, rel, seed=0):
    space = design_space(m, [p.name for p in m.points])
    size = float(np.ptp(np.array([j.at for j in m.joints]), axis=0).max())
    X = space.x0 + rel * size * np.random.default_rng(seed).standard_normal((D, space.size))
    X[0] = space.x0
    return space.names, X


def bare_curves(m, names, X, phi):
    """The floor: the four-bar's coupler point for every design and input in one NumPy pass
    (the crank's cos/sin, the RRR closed form, the coupler point), no status or store."""
    col = {n: i for i, n in enumerate(names)}
    get = lambda j: (X[:, col[j + ".x"]][:, None], X[:, col[j + ".y"]][:, None])  # noqa: E731
    (ox, oy), (a0x, a0y), (b0x, b0y), (cx, cy), (px, py) = (get(j) for j in ("O2", "A", "B", "O4", "P"))
    la2 = (b0x - a0x) ** 2 + (b0y - a0y) ** 2
    lc2 = (b0x - cx) ** 2 + (b0y - cy) ** 2
    sign = np.sign((cx - a0x) * (b0y - a0y) - (cy - a0y) * (b0x - a0x))
    c, s = np.cos(phi), np.sin(phi)
    rx, ry = a0x - ox, a0y - oy
    ax, ay = ox + c * rx - s * ry, oy + s * rx + c * ry
    dx, dy = cx - ax, cy - ay
    d2 = dx * dx + dy * dy
    t = 0.5 * (la2 / d2 + 1.0 - lc2 / d2)
    k = sign * np.sqrt(la2 / d2 - t * t)
    bx, by = ax + t * dx - k * dy, ay + t * dy + k * dx
    # the coupler's rotation takes B0 − A0 to B − A (|B − A| = |B0 − A0|)
    ux, uy = b0x - a0x, b0y - a0y
    cr, sr = (ux * (bx - ax) + uy * (by - ay)) / la2, (ux * (by - ay) - uy * (bx - ax)) / la2
    qx, qy = px - a0x, py - a0y
    return np.stack([ax + cr * qx - sr * qy, ay + sr * qx + cr * qy], axis=-1)


def four_bar_goal(D: int, N: int) -> None:
    m = load_named("four_bar")
    names, X = _population(m, D, 0.02)
    phi = np.linspace(0.0, 2 * np.pi, N, endpoint=False)
    plan_of(m)

    def route(mode):
        def run():
            with kernel.using(mode):
                return solve_designs(m, names, X, phi, outputs=["P"]).point("P")
        return run
    with kernel.using("on"):               # synthesis's route (kin.kernel.compiled_batches)
        solve_designs(m, names, X[:2], phi)
    # alternated rounds, the best of each (this machine's speed drifts within seconds: a
    # slow spell during one route's repeats had read 2.46x against 1.14-1.30x)
    (numpy_route, _), (ours, r), (floor, P) = _alternated([route("off"), route("on"),
                                                           lambda: bare_curves(m, names, X, phi)])
    both = np.isfinite(r[..., 0]) & np.isfinite(P[..., 0])
    dev = float(np.max(np.abs(r[both] - P[both])))
    ratio = ours / floor
    print(f"four-bar coupler curves, D = {D} x N = {N}: batch {ours * 1e3:.1f} ms compiled "
          f"({ours / (D * N) * 1e9:.0f} ns per design-position; NumPy route {numpy_route * 1e3:.1f} ms, "
          f"{numpy_route / floor:.2f}x), bare NumPy closed form {floor * 1e3:.1f} ms, "
          f"largest difference {dev:.1e} m; goal ratio <= 1.5: {ratio:.2f} -> {'MET' if ratio <= 1.5 else 'NOT MET'}")


def triad_goal(D: int, N: int) -> None:
    m = load_named("stephenson_3_triad")
    names, X = _population(m, D, 0.003)
    phi = np.linspace(0.0, np.radians(60.0), N)
    sp = plan_of(m)
    jit = kernel.compiled_batches()          # as synthesis's objective runs its populations
    with kernel.using("on") if jit else contextlib.nullcontext():
        solve_designs(m, names, X[:2], phi, outputs=["P"])     # numba's import and disk cache, untimed
        ours, r = _best(lambda: solve_designs(m, names, X, phi, outputs=["P"]))
    geo = r.geometry
    designs = [design_mechanism(geo, d) for d in range(D)]
    steps = list(range(len(sp.steps)))
    per, _ = _best(lambda: [_one_design(sp, md, steps, phi[:, None]) for md in designs], repeat=1)
    per_dp = ours / (D * N) * 1e6
    ratio = per / ours
    met = ratio >= 20 and per_dp <= 1.0
    print(f"Stephenson III (triad) curves, D = {D} x N = {N}: batch ({'compiled' if jit else 'NumPy'} tracker) "
          f"{ours * 1e3:.1f} ms ({per_dp:.2f} us per "
          f"design-position), per-candidate route {per * 1e3:.0f} ms; goal >= 20x faster and <= 1 us: "
          f"{ratio:.1f}x, {per_dp:.2f} us -> {'MET' if met else 'NOT MET'}")


def _four_bar_run(budget: float, free_timing: str | None = None):
    """A whole synthesis run of the four-bar's ten points (free timing ``free_timing``,
    default the library's: searched; DE,
    seed 0) with a wall-time ``budget``, after a short one that reads numba's disk cache
    (outside the timing, as Pyslvs's start-up is)."""
    import bench_synthesis as bs
    T = bs.targets()["four-bar 10 points"]
    kw = dict(path=T, point="P", method="de", seed=0, free_timing=free_timing)
    bs.synthesise(bs.start_mechanism(), evaluations=500, **kw)
    return bs.synthesise(bs.start_mechanism(), budget=float(budget), **kw)


def synthesis_goal(py: str | None, budget: int = 2, rounds: int = 3) -> None:
    """The issue's row "synthesis evaluations/s, four-bar, 10 points" against Pyslvs: our
    whole run (:func:`_four_bar_run`, ``budget`` seconds) with each free timing
    (``searched``, the default, and ``matched``) and Pyslvs's DE (the same seconds)
    alternated ``rounds`` times, the fastest of each (this machine's speed moves by ±40 %
    within minutes: alternated rounds see the same machine), and the search alone."""
    import bench_synthesis as bs
    T = bs.targets()["four-bar 10 points"]
    ours: dict = {"searched": [], "matched": []}
    errors: dict = {"searched": [], "matched": []}
    theirs = []
    for _ in range(rounds if py is not None else 1):
        for how in ours:
            res = _four_bar_run(budget, how)
            ours[how].append(res.evaluations / res.seconds)
            errors[how].append(res.error_max)
        if py is not None:
            _, _, n, run = bs.pyslvs_run(T, budget, py)
            theirs.append(n / run)                  # (over its search's own time, not the budget)
    de = bs.eval_rates(480)["batched objective"]
    search = {how: search_rate(rounds=3, free_timing=how) for how in ours}
    top = max(theirs) if theirs else None
    for how, rates in ours.items():
        best = max(rates)
        what = ("each population member on a 96-position grid, the targets matched in order" if how == "matched" else
                "each population member at its own 10 target inputs, the timing among the variables")
        line = (f"free timing {how}: ours {best:,.0f} evaluations/s over the whole run (population and polish; "
                f"fastest of {' '.join(f'{r:,.0f}' for r in rates)}; {what}; largest errors "
                f"{' '.join(f'{e:.2e}' for e in errors[how])}), the search alone {search[how]:,.0f}/s"
                + (f", the population objective alone {de:,.0f}/s" if how == "matched" else ""))
        if top is None:
            print(f"synthesis, four-bar 10 points, {line}; Pyslvs not run")
            continue
        print(f"synthesis evaluations per second, four-bar 10 points, DE {budget} s, {rounds} alternated rounds, "
              f"{line}; Pyslvs FPlanar {top:,.0f} (fastest of {' '.join(f'{r:,.0f}' for r in theirs)}); "
              f"goal ratio >= 2: {best / top:.2f} (the search alone {search[how] / top:.2f}) -> "
              f"{'MET' if best >= 2 * top else 'NOT MET'}")


def synthesis_rate(evaluations: int = 30_000, seeds=(0, 1, 2)) -> list[float]:
    """Evaluations per CPU second of whole synthesis runs under an evaluation budget
    (the four-bar's ten points, free timing; the same work on any machine, so two
    versions of the code compare by this rate whatever the load): one line per seed."""
    import bench_synthesis as bs
    T = bs.targets()["four-bar 10 points"]
    bs.synthesise(bs.start_mechanism(), path=T, point="P", method="de", evaluations=3000, seed=0)   # (warm)
    rates = []
    for seed in seeds:
        t = time.process_time()
        r = bs.synthesise(bs.start_mechanism(), path=T, point="P", method="de", evaluations=evaluations, seed=seed)
        rates.append(r.evaluations / (time.process_time() - t))
        print(f"synthesis, four-bar 10 points, free timing {r.free_timing}, at most {evaluations} evaluations, "
              f"seed {seed}: {r.evaluations} ({r.stopped}), {rates[-1]:,.0f} evaluations a CPU second, "
              f"error {r.error_max:.2e}")
    return rates


def synthesis_floor_goal(budget: float = 2.0, D: int = 10_000, N: int = 96) -> None:
    """The issue's row "synthesis evaluations/s against a bare NumPy four-bar pass" (goal
    at least 0.2 of it): the whole run's rate (four-bar, 10 points, free timing as the
    library's default: searched, ``budget`` seconds) and the search's alone, over the
    designs a second of the floor (:func:`bare_curves`, D designs × N inputs in one NumPy
    pass, the grid's N)."""
    m = load_named("four_bar")
    names, X = _population(m, D, 0.02)
    phi = np.linspace(0.0, 2 * np.pi, N, endpoint=False)
    floor, _ = _best(lambda: bare_curves(m, names, X, phi))
    floor_rate = D / floor
    res = _four_bar_run(budget)
    whole = res.evaluations / res.seconds
    search = search_rate(rounds=3)
    print(f"synthesis against a bare NumPy four-bar pass ({floor_rate:,.0f} designs/s of {N} positions), "
          f"free timing {res.free_timing}: whole run "
          f"{whole:,.0f}/s = {whole / floor_rate:.3f} of it, the search alone {search:,.0f}/s = "
          f"{search / floor_rate:.3f}; goal >= 0.2 -> {'MET' if whole >= 0.2 * floor_rate else 'NOT MET'} "
          f"(whole run), {'MET' if search >= 0.2 * floor_rate else 'NOT MET'} (search)")


def triad_case():
    """The triad goal's case: (start, ten target points, tracer point): the catalogue
    triad six-bar's tracer curve over 60° of its driver, from the mechanism with its joints
    moved by 0.3 % of its size."""
    from dataclasses import replace
    from multiloop.kin.solve import solve
    m = load_named("stephenson_3_triad")
    pt = m.points[0].name
    st = solve(m, np.radians(np.linspace(0.0, 60.0, 10)))
    T = st.point_positions[:, st.point_index(pt)]
    rng = np.random.default_rng(1)
    size = float(np.ptp(np.array([j.at for j in m.joints]), axis=0).max())
    start = replace(m, joints=tuple(replace(j, at=tuple(np.asarray(j.at) + rng.normal(0.0, 0.003 * size, 2)))
                                    for j in m.joints))
    return start, T, pt


def triad_synthesis_goal(budget: float = 2.0, rounds: int = 3) -> None:
    """The issue's row "synthesis evaluations/s, Stephenson III triad" (goal 6 500/s): ten
    points of the catalogue triad six-bar's tracer curve over 60° of its driver (free
    timing, an exact target), from the mechanism with its joints moved by 0.3 % of its
    size, ``budget`` seconds; the whole run's rate (it may stop early at the tolerance:
    the polish's share then weighs more), the fastest of ``rounds`` runs (the same work
    each: the same seed), and the search's alone."""
    from multiloop.catalogue.dimensional import synthesise
    start, T, pt = triad_case()
    synthesise(start, path=T, point=pt, evaluations=500, seed=0)                  # (warm: numba's cache)
    runs = [synthesise(start, path=T, point=pt, budget=budget, seed=0) for _ in range(rounds)]
    rates = [r.evaluations / r.seconds for r in runs]
    res, rate = runs[int(np.argmax(rates))], max(rates)
    search = _search_alone(_path_problem(start, T, pt), 5000, 3)
    print(f"synthesis evaluations per second, Stephenson III triad, 10 points, free timing, {budget:g} s: "
          f"whole run {rate:,.0f}/s (fastest of {' '.join(f'{r:,.0f}' for r in rates)}; {res.evaluations:,} in "
          f"{res.seconds:.2f} s, error {res.error_max:.1e}, stopped {res.stopped}), the search alone {search:,.0f}/s; "
          f"goal >= 6500 -> {'MET' if rate >= 6500 else 'NOT MET'} (whole run), "
          f"{'MET' if search >= 6500 else 'NOT MET'} (search)")


def prescribed_timing_rate(n_targets: int = 10, span_deg: float = 60.0, P: int = 80, rounds: int = 5) -> None:
    """A population objective with prescribed timing (the four-bar's own tracer curve at
    ``n_targets`` driver values over ``span_deg``, moved by 2 %): the targets' driver values
    alone (:meth:`~multiloop.catalogue.dimensional.objective.Problem.score_at`) against the
    whole driver grid and the targets (the route before), alternated, the fastest of
    ``rounds`` each; the two objectives agree wherever the grid finds the targets reached."""
    from multiloop.catalogue.dimensional.evaluator import Evaluator, design_space
    from multiloop.catalogue.dimensional.objective import _FAIL, Problem
    from multiloop.catalogue.dimensional.synthesise import one_blas_thread
    from multiloop.catalogue.dimensional.targets import PathTarget
    from multiloop.kin.solve import solve
    m = load_named("four_bar")
    x = np.radians(np.linspace(0.0, span_deg, n_targets))
    st = solve(m, x)
    pr = Problem(Evaluator(m, design_space(m, ["P"])), PathTarget(st.point_positions[:, st.point_index("P")] * 1.02,
                                                                   "P", timing=x))
    rng = np.random.default_rng(0)
    Z = np.clip(pr.x0[None] + 0.05 * m.size * rng.standard_normal((P, len(pr.x0))), pr.lower, pr.upper)
    routes = {"targets": Problem.targets_only.__get__(pr), "grid": lambda tim: False}
    out, best = {}, {key: np.inf for key in routes}
    with one_blas_thread():
        for _ in range(rounds):
            for key, route in routes.items():
                pr.targets_only = route
                out[key] = pr.batch(Z)
                t = time.perf_counter()
                for _ in range(50):
                    pr.batch(Z)
                best[key] = min(best[key], (time.perf_counter() - t) / 50)
    scored = out["grid"] != _FAIL
    same = bool(np.allclose(out["targets"][scored], out["grid"][scored], rtol=1e-12, atol=0.0))
    print(f"prescribed timing, four-bar, {n_targets} targets over {span_deg:g}°, population of {P}: "
          f"the targets alone {best['targets'] * 1e6:,.0f} µs ({P / best['targets']:,.0f} evaluations/s), "
          f"the whole grid ({pr.M} samples) and the targets {best['grid'] * 1e6:,.0f} µs ({P / best['grid']:,.0f}/s): "
          f"{best['grid'] / best['targets']:.2f}x; the same objective wherever the grid finds the targets reached "
          f"({int(scored.sum())} of {P}): {same}")


def _search_alone(problem, evaluations: int, rounds: int) -> float:
    """Evaluations per second of the global search alone on ``problem`` (DE, no probes,
    no polish), the fastest of ``rounds`` runs."""
    from multiloop.catalogue.dimensional import optimise
    from multiloop.catalogue.dimensional.budget import Budget, Meter
    from multiloop.catalogue.dimensional.synthesise import one_blas_thread
    with one_blas_thread():
        optimise.global_search(problem, meter=Meter.start(Budget.of(min(2000, evaluations))), tol=0.0)   # (warm)
        best = np.inf
        for _ in range(rounds):
            t = time.perf_counter()
            r = optimise.global_search(problem, meter=Meter.start(Budget.of(evaluations)), tol=0.0)
            best = min(best, (time.perf_counter() - t) / r.evaluations)
    return 1 / best


def _path_problem(m, T, point):
    """The synthesiser's problem for path ``T`` of ``point`` (free timing, no constraint)."""
    from multiloop.catalogue.dimensional.objective import Constraints
    from multiloop.catalogue.dimensional.synthesise import _checked, _problem, _target
    task, target = _target(m, T, point, False, None, None, None, None, "reference")
    return _problem(m, task, _checked(task, target, "any")[0], None, Constraints(), 96, None)


def search_rate(evaluations: int = 20_000, rounds: int = 5, free_timing: str = "searched") -> float:
    """Evaluations per second of the global search alone (differential evolution, no
    probes, no polish) on the four-bar's ten points with free timing ``free_timing``: the
    population objective inside the search's own loop, the fastest of ``rounds`` runs."""
    import bench_synthesis as bs
    from multiloop.catalogue.dimensional.synthesise import _search_view
    problem = _path_problem(bs.start_mechanism(), bs.targets()["four-bar 10 points"], "P")
    rate = _search_alone(_search_view(problem, free_timing), evaluations, rounds)
    print(f"global search (DE, no probes), four-bar 10 points, free timing {free_timing}: {rate:,.0f} "
          f"evaluations/s (fastest of {rounds} runs of {evaluations})")
    return rate


def synthesis_parts(P: int = 80, n: int = 2000) -> None:
    """Where a four-bar synthesis's time goes (the ten points, free timing; each part the
    fastest of three timings of ``n`` calls, BLAS on one thread as a run has it): the
    population objective per candidate (``P`` of them) and its curves alone (the tracer
    kernel on the 96-position grid), and per trust-region iteration of one design its
    residuals, exact Jacobian (the tracer call with derivatives inside), SVD, proposal and
    verdict; beside them the pose store's route to the same point and derivatives
    (``solve_designs`` + ``pose_sensitivity``) that the tracer call replaced."""
    import timeit
    import bench_synthesis as bs
    from multiloop.catalogue.dimensional import optimise as O
    from multiloop.catalogue.dimensional.synthesise import one_blas_thread
    from multiloop.kin.sensitivity import pose_sensitivity
    pr = _path_problem(bs.start_mechanism(), bs.targets()["four-bar 10 points"], "P")
    z = pr.x0
    phi = pr.match(z)
    rng = np.random.default_rng(0)
    Z = z[None] + 0.02 * (pr.upper - pr.lower) * rng.uniform(-1, 1, (P, len(z)))
    u0, _, _, scale, split = O.unit_variables(pr, z, phi)
    U = u0[None]
    R, J = O._unit_jacobians(pr, split(U), scale)
    svd = O._svd(J, True)
    h, _, pred = O._tr_propose(svd, R, J, np.ones(1), np.zeros(1))
    F = np.einsum("km,km->k", R, R)
    tb, X1, PHI1 = pr._tracer(), z[None, :pr.nx], phi[None]
    m = pr.ev.mechanism

    def store_route():
        with kernel.for_batches():
            st = solve_designs(m, pr.ev.space.names, X1, PHI1)
            return st.point("P"), pose_sensitivity(st).point("P")
    parts = [("population objective, per candidate", lambda: pr.batch(Z), P),
             ("  its curves alone (tracer kernel), per candidate", lambda: tb.curve(Z[:, :pr.nx], pr.grid), P),
             ("polish residuals, one design", lambda: O._residuals(pr, *split(U)), 1),
             ("polish exact Jacobian, one design", lambda: O._unit_jacobians(pr, split(U), scale), 1),
             ("  its tracer call with derivatives", lambda: tb.solve(X1, PHI1, jacobian=True), 1),
             ("  the pose store's route to the same (replaced)", store_route, 1),
             ("polish SVD (floored), one 20 x 20 Jacobian", lambda: O._svd(J, True), 1),
             ("polish proposal (step, predicted reduction)", lambda: O._tr_propose(svd, R, J, np.ones(1), np.zeros(1)), 1),
             ("polish verdict (radius, parameter, stop)",
              lambda: O._tr_accept(F, 0.9 * F, pred, h, U, np.ones(1), np.zeros(1)), 1)]
    with one_blas_thread():
        for name, f, per in parts:
            t = min(timeit.repeat(f, number=n, repeat=3)) / n
            print(f"synthesis part, four-bar 10 points: {name}: {t / per * 1e6:.2f} µs")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer designs")
    ap.add_argument("--pyslvs-python", default=None, metavar="PY",
                    help="an interpreter with pyslvs (default $MULTILOOP_PYSLVS_PYTHON or this one)")
    a = ap.parse_args(argv)
    print(f"numpy {np.__version__}")
    four_bar_goal(1000 if a.quick else 10_000, 96)
    triad_goal(100 if a.quick else 1000, 96)
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import bench_synthesis as bs
    synthesis_goal(bs.pyslvs_python(a.pyslvs_python))
    synthesis_floor_goal()
    triad_synthesis_goal()
    prescribed_timing_rate()
    synthesis_parts()


if __name__ == "__main__":
    main()
