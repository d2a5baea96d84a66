"""The polish's Jacobian, exact against differenced, on the same problems in one run.

For each mechanism (a Watt I, the Stephenson III triad six-bar, the Stephenson III
class IV six-bar, and an eight-bar with a triple pin from the 8-link atlas) it times:

* the curve-distance refinement's Jacobian (``CurveProblem``, a closed target: the
  mechanism's own coupler curve moved by a wave of 3 % of its size): exact
  (``CurveProblem.jacobian_batch``: design sensitivities, chamfer derivatives) against
  the polish's forward differences (``optimise._jacobian``: 1 + n designs in one batch);
* point matching's (``Problem``, free timing, 11 points): the same two;
* the design sensitivities alone at 240 inputs, compiled against NumPy;
* the polish itself (40 residual evaluations, its exact Jacobians), with the evaluator
  keeping its last solve (the Jacobian at the point of the residual just computed is
  not solved again) and without (alternated, the fastest of 4 each);

and prints the median of repeated calls (milliseconds) and the ratios, with the largest
difference between the two Jacobians relative to their largest entry.  Take it on an
idle machine (``uptime`` below 1)::

    python benchmarks/bench_jacobian.py [--repeat 20]
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def _timed(f, repeat: int) -> float:
    f()
    out = []
    for _ in range(repeat):
        t = time.perf_counter()
        f()
        out.append(time.perf_counter() - t)
    return 1e3 * statistics.median(out)


def _mechanisms():
    from bench_unseen_targets import _eight_bar_with_triple_pin
    from multiloop.catalogue.named import load_named
    from multiloop.topo.model import TracerPoint
    out = [load_named(n) for n in ("watt_1", "stephenson_3_triad", "stephenson_3")]
    m = _eight_bar_with_triple_pin()
    lk = m.link_names[-1]
    j = next(j for j in m.joints if lk in j.links)
    return out + [replace(m, points=(TracerPoint("T", lk, (j.at[0] + 0.1, j.at[1] + 0.2)),))]


def _curve_problem(m):
    from multiloop.catalogue.dimensional.curve_distance import CurveProblem
    from multiloop.kin.solve import solve
    st = solve(m, np.linspace(0.0, 2 * np.pi, 200, endpoint=False))
    ok = np.asarray(st.status == "ok")
    k = np.arange(int(ok.sum()))
    T = st.point_positions[ok, 0] + 0.03 * m.size * np.c_[np.sin(k / 9), np.cos(k / 13)]
    closed = bool(ok.all())
    return CurveProblem(m, T, closed, m.points[0].name, None if closed else 1.0)


def _point_problem(m):
    from multiloop.catalogue.dimensional import Evaluator, Problem, design_space, path_target
    from multiloop.kin.solve import solve
    pt = m.points[0].name
    st = solve(m, np.radians(np.arange(7.0, 360.0, 33.0)))
    ok = np.asarray(st.status == "ok")
    P = st.point_positions[ok, 0] + 1e-3 * m.size
    return Problem(Evaluator(m, design_space(m, [pt], region=P)), path_target(m, P, pt))


def _jacobians(prob, z, phi):
    """The exact Jacobian and the differenced one at ``(z, phi)``, both in the polish's
    unit-box variables (``optimise.unit_variables``), as callables."""
    from multiloop.catalogue.dimensional import optimise
    u, _, hi, scale, split = optimise.unit_variables(prob, z, phi)

    def exact():
        prob.ev._last = []              # (a cold Jacobian: the polish's follows a residual at its point)
        return prob.jacobian_batch(*split(u))[1][0] * scale

    def differenced():
        prob.ev._last = []
        return optimise._jacobian(prob, split, u, hi, len(z), prob.free_timing)[1][0]
    return exact, differenced


def _polish_times(prob, z, phi, rounds: int = 4) -> tuple[float, float]:
    """The polish's wall time (ms, the fastest of ``rounds``) with the evaluator's last
    solve kept and with it dropped before every solve."""
    from multiloop.catalogue.dimensional import optimise
    from multiloop.catalogue.dimensional.evaluator import Evaluator
    kept = Evaluator.poses

    def dropped(self, X, phi, outputs=None):
        self._last = []
        return kept(self, X, phi, outputs)
    out = {True: [], False: []}
    try:
        for _ in range(rounds):
            for keep in (False, True):
                Evaluator.poses = kept if keep else dropped
                t = time.perf_counter()
                optimise.polish(prob, z, phi, max_nfev=40)
                out[keep].append(1e3 * (time.perf_counter() - t))
    finally:
        Evaluator.poses = kept
    return min(out[True]), min(out[False])


def run(repeat: int) -> list[dict]:
    from multiloop.kin import kernel
    from multiloop.kin.design import solve_designs
    from multiloop.kin.sensitivity import pose_sensitivity
    rows = []
    for m in _mechanisms():
        row = {"mechanism": m.name, "links": m.n_links}
        for what, prob in (("curve", _curve_problem(m)), ("points", _point_problem(m))):
            z = prob.x0
            phi = prob.match(z) if prob.free_timing else np.empty(0)
            exact, differenced = _jacobians(prob, z, phi)
            Je, Jd = exact(), differenced()
            row[what] = {"variables": Je.shape[1], "exact_ms": _timed(exact, repeat),
                         "differenced_ms": _timed(differenced, repeat),
                         "difference": float(np.nanmax(np.abs(Je - Jd)) / np.nanmax(np.abs(Je)))}
            row[what]["polish_kept_ms"], row[what]["polish_dropped_ms"] = _polish_times(prob, z, phi)
        ev = prob.ev
        st = solve_designs(m, ev.space.names, prob.x0[None, :prob.nx], np.linspace(0.0, 1.0, 240))
        for mode in ("off", "on"):
            with kernel.using(mode):
                row[f"sensitivity_{mode}_ms"] = _timed(lambda: pose_sensitivity(st), repeat)
        rows.append(row)
    return rows


def report(rows: list[dict]) -> str:
    import os
    lines = [f"load {os.getloadavg()[0]:.2f}; medians of the repeated calls (ms)",
             "| mechanism | links | refinement: exact / differenced | points: exact / differenced | "
             "sensitivities at 240 inputs: compiled / NumPy |", "|---|---|---|---|---|"]
    for r in rows:
        c, p = r["curve"], r["points"]
        lines.append(f"| {r['mechanism']} | {r['links']} | {c['exact_ms']:.1f} / {c['differenced_ms']:.1f} "
                     f"({c['differenced_ms'] / c['exact_ms']:.1f}×; Δ {c['difference']:.0e}) | "
                     f"{p['exact_ms']:.1f} / {p['differenced_ms']:.1f} ({p['differenced_ms'] / p['exact_ms']:.1f}×; "
                     f"Δ {p['difference']:.0e}) | {r['sensitivity_on_ms']:.2f} / {r['sensitivity_off_ms']:.2f} "
                     f"({r['sensitivity_off_ms'] / r['sensitivity_on_ms']:.1f}×) |")
    lines += ["", "the polish, 40 residual evaluations (ms): the last solve kept / dropped",
              "| mechanism | refinement | points |", "|---|---|---|"]
    for r in rows:
        c, p = r["curve"], r["points"]
        lines.append(f"| {r['mechanism']} | {c['polish_kept_ms']:.0f} / {c['polish_dropped_ms']:.0f} "
                     f"({c['polish_dropped_ms'] / c['polish_kept_ms']:.2f}×) | {p['polish_kept_ms']:.0f} / "
                     f"{p['polish_dropped_ms']:.0f} ({p['polish_dropped_ms'] / p['polish_kept_ms']:.2f}×) |")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--repeat", type=int, default=20)
    a = p.parse_args(argv)
    print(report(run(a.repeat)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
