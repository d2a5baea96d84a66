"""``synthesise`` against plain SciPy differential evolution on the literature's
four-bar path-generation benchmark cases, at equal wall time (plain script).

Run:  python benchmarks/bench_synthesis_literature.py [--budgets 1 3] [--seeds 5] [--cases ...]
      [--quick] [--chart docs/figures/synthesis_vs_de.png] [--json out.json]

``--quick`` runs the goal's case alone (the ellipse: "literature case 5"), and a goal
line is printed for it at each budget.

Cases (sum of squared distances, SSD, in the case's units):

* ``line6``: six points on a vertical line, (20, 20) … (20, 45), free timing, a
  crank-rocker (the crank shortest, Grashof) — Kunjur & Krishnamurty (1997), used by
  Cabrera et al. (2002, case 1) and Acharyya & Mandal (2009, case 1); an exact
  solution exists (published optima f ≈ 1e-11 … 1e-2);
* ``closed18``: 18 points of a closed curve, crank angles 20° apart from a free start
  — Cabrera et al. (2002, case 2), Acharyya & Mandal (2009, case 2);
* ``arc5``: five points on an arc with the crank angles 30°, 45°, 60°, 75°, 90°
  prescribed — Kunjur & Krishnamurty (1997), Acharyya & Mandal (2009, case 3);
  here the angles are measured from the global x-axis (``--timing absolute``) in
  both formulations;
* ``ellipse``: nine distinct points of the ellipse x = 10 + 10 cos t,
  y = 10 + 8 sin t, t = 0°, 40°, … 320°, free timing — Ullah & Kota (1997), used by
  Acharyya & Mandal (2009, case 4) and Ebrahimi & Payvandy (2015);
* ``fourbar10``: ten points of the catalogue four-bar's coupler curve, free timing
  (an exact solution exists);
* ``sixbar12``: twelve points of the catalogue Watt I six-bar's coupler curve, free
  timing (an exact solution exists).

Curves of more points, not run by default (``--cases``): ``fourbar24``, ``fourbar40``,
``sixbar24``, ``sixbar40`` (the coupler curves above at 24 and 40 points) and
``ellipse24``, ``ellipse40`` (the ellipse above at 24 and 40 points spread over the
turn: no four-bar meets them exactly); they compare the two free timings on targets
that are curves rather than precision points.

The case data were typed from the papers' problem statements as they are usually
reproduced; the bounds follow the papers (lengths in [5, 60] for ``line6``, in
[0, 50] for ``closed18``, and so on; see ``CASES``).

Methods, the same objective (SSD) and the same wall time:

* ``plain DE``: :func:`scipy.optimize.differential_evolution` with its default
  settings (population 15 × variables, mutation (0.5, 1), recombination 0.7),
  ``vectorized=True`` (and so ``updating="deferred"``), except ``tol=0`` (it runs
  until the time is up instead of stopping at its own convergence test, which
  stopped some runs after 0.2 s with an infeasible design) and ``polish=False``
  (the final L-BFGS-B polish ignores the time limit: it took up to 6 s more), on the
  textbook formulation (Cabrera et al. 2002): r1, r2, r3, r4, rcx, rcy, x0, y0, θ0
  and one crank angle per point (free timing; a cyclic-order penalty) or the first
  crank angle (step timing), the rocker's closed form on the open branch, a penalty
  of 1e4 per point that does not assemble and per violated Grashof condition.  The
  six-bar's textbook formulation is our evaluator's joint coordinates plus one
  driver angle per point (no matching).  It stops at the wall time ours took;
* ``synthesise``: ``multiloop.catalogue.dimensional.synthesise`` (default method,
  ``--budget`` = the budget) from the catalogue mechanism scaled onto the target,
  every joint bounded by the textbook's reach.

Error: the SSD of the returned design at its own driver values (ours: reached by
continuous motion from the reference, in order; DE's: the textbook's branch at its
angles).  Median and best over the seeds.
"""
from __future__ import annotations

import argparse
import json
import time
from dataclasses import dataclass, replace

import numpy as np

# ---------------------------------------------------------------------------------
# the cases


@dataclass(frozen=True)
class Case:
    name: str
    points: np.ndarray
    timing: str | None = None          # None (free), "step" or "absolute"
    angles: np.ndarray | None = None   # deg: steps or absolute crank angles
    lengths: tuple = (0.0, 50.0)       # r1..r4 bounds
    coupler: tuple = (-50.0, 50.0)     # rcx, rcy bounds
    pivot: tuple = (-50.0, 50.0)       # x0, y0 bounds
    grashof: str = "any"
    mechanism: str = "four_bar"


def _ellipse(n: int = 9):
    t = np.radians(np.arange(n) * 360.0 / n)
    return np.column_stack([10 + 10 * np.cos(t), 10 + 8 * np.sin(t)])


def _catalogue_curve(name, n):
    from multiloop.catalogue.named import load_named
    from multiloop.kin.solve import solve
    m = load_named(name)
    st = solve(m, np.radians(np.linspace(7.0, 7.0 + 330.0, n)))
    return st.point_positions[:, 0]


CLOSED18 = np.array([[0.5, 1.1], [0.4, 1.1], [0.3, 1.1], [0.2, 1.0], [0.1, 0.9], [0.05, 0.75], [0.02, 0.6],
                     [0.0, 0.5], [0.0, 0.4], [0.03, 0.3], [0.1, 0.25], [0.15, 0.2], [0.2, 0.3], [0.3, 0.4],
                     [0.4, 0.5], [0.5, 0.7], [0.6, 0.9], [0.6, 1.0]])
ARC5 = np.array([[3.0, 3.0], [2.759, 3.363], [2.372, 3.663], [1.890, 3.862], [1.355, 3.943]])


def cases() -> dict[str, Case]:
    """The default cases (:func:`literature_cases`) and the longer curves."""
    out = literature_cases()
    for n in (24, 40):
        out[f"fourbar{n}"] = replace(out["fourbar10"], name=f"fourbar{n}", points=_catalogue_curve("four_bar", n))
        out[f"sixbar{n}"] = replace(out["sixbar12"], name=f"sixbar{n}", points=_catalogue_curve("watt_1", n))
        out[f"ellipse{n}"] = replace(out["ellipse"], name=f"ellipse{n}", points=_ellipse(n))
    return out


def literature_cases() -> dict[str, Case]:
    return {
        "line6": Case("line6", np.array([[20.0, 20.0 + 5 * i] for i in range(6)]), lengths=(5.0, 60.0),
                      coupler=(-60.0, 60.0), pivot=(-60.0, 60.0), grashof="crank-rocker"),
        "closed18": Case("closed18", CLOSED18, "step", 20.0 * np.arange(18)),
        "arc5": Case("arc5", ARC5, "absolute", np.array([30.0, 45.0, 60.0, 75.0, 90.0]), lengths=(0.0, 5.0),
                     coupler=(-5.0, 5.0), pivot=(-5.0, 5.0)),
        "ellipse": Case("ellipse", _ellipse(), lengths=(0.0, 50.0), coupler=(-50.0, 50.0), pivot=(-50.0, 50.0)),
        "fourbar10": Case("fourbar10", _catalogue_curve("four_bar", 10), lengths=(0.0, 0.3), coupler=(-0.3, 0.3),
                          pivot=(-0.3, 0.3)),
        "sixbar12": Case("sixbar12", _catalogue_curve("watt_1", 12), mechanism="watt_1", lengths=(0.0, 0.3),
                         coupler=(-0.3, 0.3), pivot=(-0.3, 0.3)),
    }


# ---------------------------------------------------------------------------------
# the textbook formulation (Cabrera et al. 2002), vectorised over the population

_PEN = 1e4


def _four_bar_points(V, alpha):
    """Coupler points ``(P, N, 2)`` and assembled mask of designs ``V`` (P, 9) at global
    crank angles ``alpha`` (P, N)."""
    r1, r2, r3, r4, cx, cy, x0, y0, t0 = (V[:, i:i + 1] for i in range(9))
    ax, ay = x0 + r2 * np.cos(alpha), y0 + r2 * np.sin(alpha)
    ox, oy = x0 + r1 * np.cos(t0), y0 + r1 * np.sin(t0)
    dx, dy = ox - ax, oy - ay
    d = np.hypot(dx, dy)
    d = np.where(d > 0, d, 1e-300)
    a = (r3 ** 2 - r4 ** 2 + d ** 2) / (2 * d)
    h2 = r3 ** 2 - a ** 2
    ok = h2 >= 0
    h = np.sqrt(np.where(ok, h2, 0.0))
    ex, ey = dx / d, dy / d
    bx, by = ax + a * ex - h * ey, ay + a * ey + h * ex
    t3 = np.arctan2(by - ay, bx - ax)
    px = ax + cx * np.cos(t3) - cy * np.sin(t3)
    py = ay + cx * np.sin(t3) + cy * np.cos(t3)
    return np.stack([px, py], axis=-1), ok


def _order_penalty(th):
    """Free crank angles must be met in one cyclic order within one turn."""
    d = np.mod(np.diff(th, axis=1), 2 * np.pi)
    return np.where(np.sum(d, axis=1) <= 2 * np.pi + 1e-12, 0.0, _PEN)


def textbook(case: Case):
    """``(f, bounds, decode)``: the vectorised SSD objective ``f(V.T)``, bounds, and
    ``decode(v) -> SSD`` (the objective without penalties, inf when it fails)."""
    T = case.points
    N = len(T)
    if case.mechanism != "four_bar":
        return _textbook_generic(case)
    lo_l, hi_l = case.lengths
    b = [(lo_l, hi_l)] * 4 + [case.coupler] * 2 + [case.pivot] * 2 + [(0.0, 2 * np.pi)]
    if case.timing is None:
        b += [(0.0, 2 * np.pi)] * N
    elif case.timing == "step":
        b += [(0.0, 2 * np.pi)]

    def angles(V):
        if case.timing is None:
            return V[:, 8:9] + V[:, 9:]
        if case.timing == "step":
            return V[:, 8:9] + V[:, 9:10] + np.radians(case.angles)[None, :]
        return np.broadcast_to(np.radians(case.angles), (V.shape[0], N))

    def parts(V):
        pts, ok = _four_bar_points(V, angles(V))
        ssd = np.sum(np.where(ok[..., None], (pts - T) ** 2, 0.0), axis=(1, 2))
        pen = _PEN * np.sum(~ok, axis=1)
        if case.timing is None:
            pen = pen + _order_penalty(V[:, 9:])
        if case.grashof == "crank-rocker":
            L = V[:, :4]
            s, lg = L.min(1), L.max(1)
            grashof = 2 * (s + lg) <= L.sum(1)
            pen = pen + np.where(grashof & (L[:, 1] <= s), 0.0, _PEN)
        return ssd, pen

    def f(VT):
        ssd, pen = parts(np.atleast_2d(VT.T))
        return ssd + pen

    def decode(v):
        ssd, pen = parts(v[None, :])
        return float(ssd[0]) if pen[0] == 0 else float("inf")
    return f, b, decode


def _textbook_generic(case: Case):
    """Joint coordinates (our evaluator) plus one driver angle per point."""
    from multiloop.catalogue.dimensional import Evaluator, design_space
    m, pt = start_mechanism(case)
    sp = design_space(m, [pt], region=case.points)
    ev = Evaluator(m, sp)
    T = case.points
    n = sp.size
    b = [tuple(x) for x in _box(case, sp)] + [(0.0, 2 * np.pi)] * len(T)

    def parts(V):
        w, ok = ev.point(V[:, :n], V[:, n:], pt)
        ssd = np.sum(np.where(ok[..., None], (w - T) ** 2, 0.0), axis=(1, 2))
        return ssd, _PEN * np.sum(~ok, axis=1) + _order_penalty(V[:, n:])

    def f(VT):
        ssd, pen = parts(np.atleast_2d(VT.T))
        return np.where(np.isfinite(ssd), ssd + pen, 1e12)

    def decode(v):
        ssd, pen = parts(v[None, :])
        return float(ssd[0]) if pen[0] == 0 else float("inf")
    return f, b, decode


def plain_de(case: Case, seconds: float, seed: int) -> tuple[float, float]:
    """Plain SciPy DE on the textbook formulation for ``seconds``: (SSD, wall time)."""
    from scipy.optimize import differential_evolution
    f, b, decode = textbook(case)
    t0 = time.perf_counter()
    r = differential_evolution(f, b, vectorized=True, updating="deferred", rng=np.random.default_rng(seed),
                               maxiter=10 ** 7, tol=0.0, polish=False, callback=lambda intermediate_result:
                               time.perf_counter() - t0 >= seconds)
    return decode(r.x), time.perf_counter() - t0


# ---------------------------------------------------------------------------------
# ours

def start_mechanism(case: Case):
    """The catalogue mechanism scaled and moved onto the target (not the answer)."""
    from multiloop.catalogue.named import load_named
    m = load_named(case.mechanism)
    pt = m.points[0]
    xy = np.array([j.at for j in m.joints])
    s = float(np.max(np.ptp(case.points, axis=0))) / float(np.max(np.ptp(xy, axis=0))) * 1.5
    if case.name in ("fourbar10", "sixbar12"):
        s = 1.0
        rng = np.random.default_rng(7)
        js = [replace(j, at=tuple(np.asarray(j.at) + rng.normal(0, 0.05 * np.ptp(xy), 2))) for j in m.joints]
        return replace(m, joints=tuple(js)), pt.name
    shift = case.points.mean(axis=0) - s * np.asarray(pt.at)
    js = [replace(j, at=tuple(s * np.asarray(j.at) + shift)) for j in m.joints]
    pts = (replace(pt, at=tuple(s * np.asarray(pt.at) + shift)),)
    return replace(m, joints=tuple(js), points=pts), pt.name


def _box(case: Case, sp):
    """Our bounds: every coordinate within the textbook's reach (pivot box ± longest
    link, ± the coupler offset for the tracer point)."""
    reach = case.pivot[0] - case.lengths[1] - max(map(abs, case.coupler)), \
        case.pivot[1] + case.lengths[1] + max(map(abs, case.coupler))
    out = []
    for name in sp.names:
        out.append(reach if not name.endswith(".angle") else (sp.lower[sp.index(name)], sp.upper[sp.index(name)]))
    return np.array(out)


def ours(case: Case, budget: float, seed: int, free_timing: str | None = None) -> tuple[float, float]:
    from multiloop.catalogue.dimensional import design_space, synthesise
    m, pt = start_mechanism(case)
    sp = design_space(m, [pt], region=case.points)
    bounds = {n: tuple(b) for n, b in zip(sp.names, _box(case, sp))}
    path = case.points if case.timing is None else np.column_stack([case.points, case.angles])
    t0 = time.perf_counter()
    r = synthesise(m, path=path, point=pt, budget=budget, seed=seed, bounds=bounds,
                   timing=case.timing or "reference", grashof=case.grashof,
                   direction="ccw" if case.timing == "step" else "any",
                   free_timing=free_timing if case.timing is None else None)
    wall = time.perf_counter() - t0
    ok = all(c["met"] for c in r.constraints)
    ssd = float(np.sum((np.asarray(r.achieved) - np.asarray(r.target)) ** 2))
    return (ssd if ok else float("inf")), wall


# ---------------------------------------------------------------------------------

def run(names, budgets, seeds, free_timing=None):
    allc = cases()
    rows = []
    for name in names:
        case = allc[name]
        for b in budgets:
            ours_e, de_e, walls = [], [], []
            for s in range(seeds):
                e1, w = ours(case, b, s, free_timing)
                e2, w2 = plain_de(case, w, s)
                ours_e.append(e1)
                de_e.append(e2)
                walls.append((w, w2))
            rows.append(dict(case=name, budget=b, ours=ours_e, de=de_e, walls=walls))
            print(_line(rows[-1]), flush=True)
    return rows


def _line(r):
    med = lambda v: float(np.median(v))  # noqa: E731
    w = np.array(r["walls"])
    return (f"| {r['case']} | {r['budget']:g} | {med(w[:, 0]):.2f} / {med(w[:, 1]):.2f} | "
            f"{med(r['ours']):.3g} | {min(r['ours']):.3g} | {med(r['de']):.3g} | {min(r['de']):.3g} |")


HEAD = ("| case | budget (s) | wall ours / DE (s, median) | ours median SSD | ours best | plain DE median | "
        "plain DE best |\n|---|---|---|---|---|---|---|")


def chart(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    names = list(dict.fromkeys(r["case"] for r in rows))
    fig, axes = plt.subplots(2, (len(names) + 1) // 2, figsize=(4 * ((len(names) + 1) // 2), 7), squeeze=False)
    for ax, name in zip(axes.ravel(), names):
        rs = [r for r in rows if r["case"] == name]
        for key, lab, c in (("ours", "synthesise", "C0"), ("de", "plain SciPy DE", "C1")):
            t = [np.median(np.array(r["walls"])[:, 0 if key == "ours" else 1]) for r in rs]
            v = [max(np.median(r[key]), 1e-16) for r in rs]
            best = [max(min(r[key]), 1e-16) for r in rs]
            ax.plot(t, v, "o-", color=c, label=f"{lab} (median)")
            ax.plot(t, best, "x--", color=c, alpha=0.6, label=f"{lab} (best)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(name)
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel("SSD")
    for ax in axes.ravel()[len(names):]:
        ax.axis("off")
    axes[0, 0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


#: the case of the performance goal "literature case 5 at equal wall time: no worse than
#: plain DE" (Acharyya & Mandal 2009's fourth case, Ullah & Kota 1997's ellipse)
GOAL_CASE = "ellipse"


def goal_lines(rows) -> list[str]:
    """The goal line of each budget of :data:`GOAL_CASE`: our median SSD against plain
    DE's at the same wall time."""
    out = []
    for r in rows:
        if r["case"] == GOAL_CASE:
            ours, de = float(np.median(r["ours"])), float(np.median(r["de"]))
            out.append(f"goal literature case {GOAL_CASE} (free timing), {r['budget']:g} s, {len(r['ours'])} seeds: "
                       f"median SSD ours {ours:.3g}, plain DE {de:.3g} at the same wall time (goal <= plain DE) "
                       f"-> {'MET' if ours <= de else 'NOT MET'}")
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--budgets", type=float, nargs="+", default=[1.0, 3.0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--cases", nargs="+", default=list(literature_cases()), choices=list(cases()))
    ap.add_argument("--quick", action="store_true", help=f"the goal's case ({GOAL_CASE}) only")
    ap.add_argument("--free-timing", choices=("matched", "searched"), default=None,
                    help="ours: free timing's search (synthesise's free_timing, default its default: searched; "
                         "prescribed cases unchanged)")
    ap.add_argument("--chart", default=None)
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    import scipy.optimize  # noqa: F401  (imports before the clocks)
    print(HEAD)
    rows = run([GOAL_CASE] if a.quick else a.cases, a.budgets, a.seeds, a.free_timing)
    for line in goal_lines(rows):
        print(line)
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(rows, fh, indent=1, default=float)
    if a.chart:
        chart(rows, a.chart)


if __name__ == "__main__":
    main()
