"""Benchmark: kinetostatics of the 90° V-twin over many positions, batched vs a loop.

Run: ``python benchmarks/bench_forces.py [--n 100000] [--loop 300]``.

Prints the time per position of

* the closed-form engine route (:func:`kin.engine.engine_reactions`: reference §4.5,
  vectorised over positions and cylinders),
* the general kinetostatics (:func:`kin.forces.forces`, group by group along the
  Assur plan, batched LAPACK solves) on the precomputed kinematic state, and the
  same with one global system,
* the kinematic state itself (:func:`kin.engine.engine_state`, exact closed form),

against a per-position Python loop of the same functions (timed on ``--loop``
positions and scaled), with the ratios.  Accuracy of the batch: the largest
|M_b(general) − M_b(closed form)| and the largest relative virtual-power residual.
Every time is the minimum over ``--repeat`` runs in this process; the versions of
Python and NumPy and the load average are printed with the numbers.

Goal (issue 11): the general group-by-group route ≤ 1.5 µs per position on the V-twin
at 10⁵ positions (state precomputed, determinant check on).
"""
from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

from multiloop.catalogue.engines import v_twin_spec
from multiloop.kin.engine import engine_mechanism, engine_reactions, engine_state
from multiloop.kin.forces import PointLoad, forces
from multiloop.topo.assur import decompose

GOAL_US = 1.5


_CPU: dict = {}


def _best(fn, repeat=3, key=None):
    """Min wall time over ``repeat`` runs (and, under ``key``, the min process CPU time,
    which a machine shared with other jobs inflates less)."""
    best = cpu = np.inf
    out = None
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        best = min(best, time.perf_counter() - t0)
        cpu = min(cpu, time.process_time() - c0)
    if key:
        _CPU[key] = cpu
    return best, out


def run(n: int = 100_000, n_loop: int = 300, repeat: int = 3) -> dict:
    spec = v_twin_spec()
    m = engine_mechanism(spec)
    plan = decompose(m)
    phi = np.linspace(0.0, 4 * np.pi, n, endpoint=False)
    t_state, st = _best(lambda: engine_state(spec, phi, mechanism=m), repeat)
    t_closed, rx = _best(lambda: engine_reactions(spec, phi), repeat, "closed")
    loads = [PointLoad(f"piston{j + 1}", rx["Fg"][:, j], at=m.joint(f"B{j + 1}").at) for j in range(2)]
    t_groups, fr = _best(lambda: forces(m, st, plan=plan, extra_loads=loads), repeat, "groups")
    t_global, _ = _best(lambda: forces(m, st, method="global", extra_loads=loads), repeat)
    t_nocheck, _ = _best(lambda: forces(m, st, plan=plan, extra_loads=loads, check=False), repeat)
    # per-position loops of the same maths on a sample
    idx = np.linspace(0, n - 1, n_loop).astype(int)
    t0 = time.perf_counter()
    for i in idx:
        engine_reactions(spec, phi[i:i + 1])
    t_closed_loop = (time.perf_counter() - t0) / n_loop
    t0 = time.perf_counter()
    for i in idx[: max(n_loop // 3, 10)]:
        s1 = engine_state(spec, phi[i:i + 1], mechanism=m)
        l1 = [PointLoad(ld.link, ld.force[i:i + 1], at=ld.at) for ld in loads]
        forces(m, s1, plan=plan, extra_loads=l1)
    t_groups_loop = (time.perf_counter() - t0) / max(n_loop // 3, 10)
    us = 1e6
    out = {
        "n": n,
        "state_us": t_state / n * us,
        "closed_form_us": t_closed / n * us,
        "groups_us": t_groups / n * us,
        "global_us": t_global / n * us,
        "groups_nocheck_us": t_nocheck / n * us,
        "closed_form_loop_us": t_closed_loop * us,
        "groups_loop_us": t_groups_loop * us,
        "groups_cpu_us": _CPU["groups"] / n * us,
        "closed_cpu_us": _CPU["closed"] / n * us,
        "max_dMb": float(np.nanmax(np.abs(fr.balancing[:, 0] - rx["Mb"]))),
        "max_rel_residual": float(np.nanmax(fr.relative_residual)),
    }
    return out


def versions() -> str:
    """Python, NumPy and multiloop versions and the machine's load."""
    from importlib.metadata import version  # noqa: PLC0415
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return (f"Python {platform.python_version()}, NumPy {np.__version__}, multiloop {version('multiloop')}; "
            f"{os.cpu_count()} CPUs, load average {load:.2f}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=100_000)
    ap.add_argument("--loop", type=int, default=300)
    ap.add_argument("--repeat", type=int, default=7)
    a = ap.parse_args(argv)
    r = run(a.n, a.loop, a.repeat)
    print(versions())
    print(f"V-twin kinetostatics, {r['n']} positions (min of {a.repeat} repeats); time per position:")
    print(f"  closed form (Vasilenko et al. 2018), batched {r['closed_form_us']:8.3f} µs   "
          f"loop {r['closed_form_loop_us']:9.1f} µs   ratio {r['closed_form_loop_us'] / r['closed_form_us']:8.0f}x")
    print(f"  general, group by group, batched           {r['groups_us']:8.3f} µs   "
          f"loop {r['groups_loop_us']:9.1f} µs   ratio {r['groups_loop_us'] / r['groups_us']:8.0f}x")
    print(f"  general, groups, check=False               {r['groups_nocheck_us']:8.3f} µs")
    print(f"  general, one global system                 {r['global_us']:8.3f} µs   "
          f"(groups/global {r['groups_us'] / r['global_us']:.2f})")
    print(f"  exact kinematic state (closed form)        {r['state_us']:8.3f} µs")
    print(f"  general / closed form                      {r['groups_us'] / r['closed_form_us']:8.2f}x")
    print(f"  CPU time (process_time, min): general {r['groups_cpu_us']:.3f} µs, closed form {r['closed_cpu_us']:.3f} µs")
    for what, t in (("wall", r["groups_us"]), ("CPU", r["groups_cpu_us"])):
        print(f"  goal: general group-by-group <= {GOAL_US} µs per position, {what} time {t:.3f} µs "
              f"({t / GOAL_US:.2f} x goal) -> {'met' if t <= GOAL_US else 'NOT met'}")
    print(f"  accuracy: max |M_b(general) - M_b(closed)| = {r['max_dMb']:.3g} N m, "
          f"max relative virtual-power residual {r['max_rel_residual']:.3g}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
