"""Benchmark of kin.solve against peers, per position (plain script).

Run:  python benchmarks/bench_solve.py [--quick] [--no-charts]

Mechanisms: a Grashof four-bar, a Stephenson-type six-bar (crank + two RRR
dyads) and a Stephenson III with a class III triad.  Methods, measured in one run:

* ours, closed form: ``solve(m, x, plan=plan)`` vectorised over 10⁵ positions
  (positions only; plan compiled once);
* ours, generic Newton with continuation (``method="newton"``, sequential);
* pylinkage (``Linkage.step_fast``, numba) where it has the groups;
* python-solvespace (one ``solve()`` per position, warm-started).

Printed: time per position, closure residual (max over positions, relative to
the mechanism size: distance errors of every link), failures, ratios to ours.
Charts (benchmarks/charts/): solve_speed_accuracy.png (time per position vs
closure residual, Newton at tolerances 1e-4…1e-14, and velocity error vs time
with finite-difference derivatives at several steps), solve_singular.png (what
each method does approaching a non-Grashof reach limit).
"""
from __future__ import annotations

import argparse
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from multiloop.kin import kernel  # noqa: E402
from multiloop.kin.solve import compile_plan, solve  # noqa: E402
from multiloop.topo.model import MechanismBuilder  # noqa: E402

CHARTS = ROOT / "benchmarks" / "charts"


# ----------------------------------------------------------------------------- mechanisms
def _circle(A, C, l1, l2, sign):
    (ax, ay), (cx, cy) = A, C
    dx, dy = cx - ax, cy - ay
    d = math.hypot(dx, dy)
    a = (l1 * l1 - l2 * l2 + d * d) / (2 * d)
    h = math.sqrt(l1 * l1 - a * a)
    return (ax + a * dx / d - sign * h * dy / d, ay + a * dy / d + sign * h * dx / d)


def four_bar():
    A, C = (0.0, 1.0), (4.0, 0.0)
    B = _circle(A, C, 4.0, 3.5, -1)
    b = MechanismBuilder(name="four-bar")
    b.add_link("ground", frame=True)
    for n, lk, at in [("O", ("ground", "crank"), (0, 0)), ("A", ("crank", "coupler"), A),
                      ("B", ("coupler", "rocker"), B), ("C", ("rocker", "ground"), C)]:
        b.add_joint(n, "R", lk, at=at)
    b.add_driver("O")
    return b.build()


def six_bar():
    """Crank, ternary coupler (A, B, D) + rocker (B, C); then dyad D–E–F."""
    b = MechanismBuilder(name="stephenson six-bar")
    b.add_link("ground", frame=True)
    J = [("O", ("ground", "crank"), (0.0, 0.0)), ("A", ("crank", "coupler"), (0.0, 1.0)),
         ("B", ("coupler", "rocker"), (3.2, 2.3)), ("C", ("rocker", "ground"), (4.0, 0.0)),
         ("D", ("coupler", "l5"), (1.8, 3.0)), ("E", ("l5", "l6"), (3.5, 5.0)),
         ("F", ("l6", "ground"), (6.5, 3.0))]
    for n, lk, at in J:
        b.add_joint(n, "R", lk, at=at)
    b.add_driver("O")
    return b.build()


def triad():
    b = MechanismBuilder(name="stephenson III (triad)")
    b.add_link("frame", frame=True)
    J = [("O", ("frame", "crank"), (0.0, 0.0)), ("A1", ("crank", "b1"), (0.1, 0.0)),
         ("P1", ("b1", "T"), (0.6, 0.5)), ("P2", ("T", "b2"), (1.154, 0.77)),
         ("P3", ("T", "b3"), (0.649, 0.232)), ("A2", ("b2", "frame"), (0.679, 1.428)),
         ("A3", ("b3", "frame"), (0.672, -0.306))]
    for n, lk, at in J:
        b.add_joint(n, "R", lk, at=at)
    b.add_driver("O")
    return b.build()


def _bars(m):
    """(joint_i, joint_j, length) for every pair of R joints on one link (rigid distances)."""
    idx = {j.name: i for i, j in enumerate(m.joints)}
    out = []
    for lk in m.link_names:
        js = [j for j in m.joints_of(lk)]
        for a in range(len(js)):
            for c in range(a + 1, len(js)):
                pa, pc = np.array(js[a].at), np.array(js[c].at)
                out.append((idx[js[a].name], idx[js[c].name], float(np.hypot(*(pa - pc)))))
    return out


def closure(m, P) -> float:
    """Max |distance − length| over all rigid pairs, relative to the size; NaN rows skipped."""
    bars = _bars(m)
    size = np.ptp(np.array([j.at for j in m.joints]), axis=0).max()
    ok = np.all(np.isfinite(P.reshape(len(P), -1)), axis=1)
    P = P[ok]
    if not len(P):
        return float("nan")
    err = 0.0
    for i, j, L in bars:
        err = max(err, float(np.max(np.abs(np.hypot(*(P[:, i] - P[:, j]).T) - L))))
    return err / size


def _best(f, repeat=3):
    best = np.inf
    out = None
    for _ in range(repeat):
        t = time.perf_counter()
        out = f()
        best = min(best, time.perf_counter() - t)
    return best, out


def _faults(f, repeat=5) -> float:
    """Minor page faults per call of ``f`` (memory taken fresh from the OS: in a VM each
    costs microseconds, and how often the allocator hands memory back depends on the
    process's history, so the same code can differ by 2x between processes)."""
    import resource
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for _ in range(repeat):
        f()
    return (resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before) / repeat


# ----------------------------------------------------------------------------- peers
def pylinkage_run(m, x):
    """pylinkage for crank + RRR dyads built from the mechanism (None if unsupported)."""
    try:
        import pylinkage as pl
    except ImportError:
        return None, "not installed"
    if m.name.startswith("stephenson III"):
        return None, "no triad in pylinkage's Linkage API (its assur.Triad is fsolve-based, graph path only)"
    at = {j.name: j.at for j in m.joints}
    ground = {n: pl.Ground(*at[n], name=n) for n in ("O", "C", "F") if n in at}
    O = np.array(at["O"])
    A = np.array(at["A"])
    step = float(x[1] - x[0])
    crank = pl.Crank(anchor=ground["O"], radius=float(np.hypot(*(A - O))), angular_velocity=step,
                     initial_angle=float(math.atan2(*(A - O)[::-1])) - step)
    d = lambda p, q: float(np.hypot(*(np.array(at[p]) - np.array(at[q]))))  # noqa: E731
    comps = [*ground.values(), crank]
    B = pl.RRRDyad(anchor1=crank.output, anchor2=ground["C"], distance1=d("A", "B"), distance2=d("B", "C"),
                   x=at["B"][0], y=at["B"][1], name="B")
    comps.append(B)
    names = ["O", "C"] + (["F"] if "F" in ground else []) + ["A", "B"]
    if "D" in at:
        D = pl.FixedDyad(anchor1=crank.output, anchor2=B, distance=d("A", "D"),
                         angle=_angle_at(at["A"], at["B"], at["D"]), name="D")
        E = pl.RRRDyad(anchor1=D, anchor2=ground["F"], distance1=d("D", "E"), distance2=d("E", "F"),
                       x=at["E"][0], y=at["E"][1], name="E")
        comps += [D, E]
        names += ["D", "E"]
    lk = pl.Linkage(comps)
    coords0 = lk.get_coords()
    lk.step_fast(iterations=10)           # numba compilation, outside the timing

    def run():                            # built once; each repeat restarts from the reference
        lk.set_coords(coords0)
        return lk.step_fast(iterations=len(x))

    t, traj = _best(run, repeat=5)
    P = np.full((len(x), m.n_joints, 2), np.nan)
    for k, n in enumerate(names):
        P[:, m.joint_names.index(n)] = traj[:, k]
    return (t / len(x), P, run), "ok"


def _angle_at(A, B, D):
    """pylinkage FixedDyad angle: angle at A from A→B to A→D."""
    a = math.atan2(B[1] - A[1], B[0] - A[0])
    b = math.atan2(D[1] - A[1], D[0] - A[0])
    return b - a


def solvespace_run(m, x):
    """python-solvespace: one solve per position, the frame pivots and the crank tip (set
    to its place per position) as constants in group 1, the rest solved in group 2."""
    try:
        from python_solvespace import ResultFlag, SolverSystem
    except ImportError:
        return None, "not installed"
    s = SolverSystem()
    wp = s.create_2d_base()                  # group 1: the work plane
    pts = {}
    at = {j.name: np.array(j.at, float) for j in m.joints}
    ground = {j.name for j in m.joints if m.frame in j.links}
    crank = m.drivers[0]
    tip = next(j.name for j in m.joints if "crank" in j.links and j.name != crank.joint)
    # the fixed points (frame pivots, and the crank tip set per position) in group 1 are
    # constants of the solve of group 2 (SolveSpace's fastest documented way to fix points)
    for name in sorted(ground | {tip}):
        pts[name] = s.add_point_2d(*at[name], wp)
    s.set_group(2)
    for j in m.joints:
        if j.name not in pts:
            pts[j.name] = s.add_point_2d(*at[j.name], wp)
    for i, j, L in _bars(m):
        a, c = m.joints[i].name, m.joints[j].name
        if {a, c} <= ground or (tip in (a, c) and crank.joint in (a, c)):
            continue
        s.distance(pts[a], pts[c], L, wp)
    O, A0 = at[crank.joint], at[tip]
    r = A0 - O
    P = np.full((len(x), m.n_joints, 2), np.nan)
    fails = 0
    t0 = time.perf_counter()
    for n, phi in enumerate(x):
        c, sn = math.cos(phi), math.sin(phi)
        s.set_params(pts[tip].params, [O[0] + c * r[0] - sn * r[1], O[1] + sn * r[0] + c * r[1]])
        flag = s.solve()
        if flag != ResultFlag.OKAY:
            fails += 1
            continue
        for k, j in enumerate(m.joints):
            P[n, k] = s.params(pts[j.name].params)
    t = time.perf_counter() - t0
    return (t / len(x), P, fails), "ok"


# ----------------------------------------------------------------------------- main table
def table(quick: bool):
    rows = []
    N = 10_000 if quick else 100_000
    Nn = 300 if quick else 2000
    for make in (four_bar, six_bar, triad):
        m = make()
        plan = compile_plan(m)
        x = np.linspace(0.0, 2 * np.pi, N)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            solve(m, x[:100], plan=plan)
            t_cf, st = _best(lambda: solve(m, x, plan=plan))
        res_cf = closure(m, st.positions)
        with kernel.using("on"), warnings.catch_warnings():        # the compiled plan (opt-in)
            warnings.simplefilter("ignore")
            solve(m, x[:100], plan=plan)
            t_k, stk = _best(lambda: solve(m, x, plan=plan))
        xn = np.linspace(0.0, 2 * np.pi, Nn)
        t_nt, sn = _best(lambda: solve(m, xn, plan=plan, method="newton"), repeat=1)
        res_nt = closure(m, sn.positions)
        line = {"mechanism": m.name, "N": N, "cf_us": 1e6 * t_cf / N, "cf_res": res_cf,
                "cf_fail": int((~st.ok).sum()), "nt_us": 1e6 * t_nt / Nn, "nt_res": res_nt,
                "nt_fail": int((~sn.ok).sum()), "k_us": 1e6 * t_k / N, "k_res": closure(m, stk.positions),
                "k_fail": int((~stk.ok).sum())}
        xs = np.linspace(0.0, 2 * np.pi, Nn)
        r, why = pylinkage_run(m, x)
        if r is None:
            line["pl"] = why
        else:
            tp, P, _ = r
            line["pl_us"], line["pl_res"] = 1e6 * tp, closure(m, P)
            line["pl_fail"] = int(np.any(np.isnan(P.reshape(len(P), -1)), axis=1).sum())
        r, why = solvespace_run(m, xs)
        if r is None:
            line["ss"] = why
        else:
            ts, P, fails = r
            line["ss_us"], line["ss_res"], line["ss_fail"] = 1e6 * ts, closure(m, P), fails
            ref = solve(m, xs, plan=plan)
            okk = np.all(np.isfinite(P.reshape(len(P), -1)), axis=1) & ref.ok
            line["ss_branch_dev"] = float(np.max(np.abs(P[okk] - ref.positions[okk]))) if okk.any() else float("nan")
        rows.append(line)
    return rows


def print_table(rows):
    print(f"{'mechanism':<26}{'method':<26}{'µs/position':>12}{'residual':>11}{'fails':>7}{'ratio':>9}")
    for r in rows:
        base = r["cf_us"]
        items = [("ours closed form (N=%d)" % r["N"], r["cf_us"], r["cf_res"], r["cf_fail"]),
                 ("ours compiled plan", r["k_us"], r["k_res"], r["k_fail"]),
                 ("ours Newton", r["nt_us"], r["nt_res"], r["nt_fail"])]
        if "pl_us" in r:
            items.append(("pylinkage step_fast", r["pl_us"], r["pl_res"], r["pl_fail"]))
        if "ss_us" in r:
            items.append(("python-solvespace", r["ss_us"], r["ss_res"], r["ss_fail"]))
        for name, us, res, fail in items:
            print(f"{r['mechanism']:<26}{name:<26}{us:>12.4g}{res:>11.1e}{fail:>7}{us / base:>9.3g}")
        if "pl" in r:
            print(f"{r['mechanism']:<26}{'pylinkage':<26}  {r['pl']}")
        if "ss" in r:
            print(f"{r['mechanism']:<26}{'python-solvespace':<26}  {r['ss']}")
        if "ss_branch_dev" in r:
            print(f"{'':<26}{'(solvespace vs ours: max |Δ position| = %.1e m)' % r['ss_branch_dev']}")


# ----------------------------------------------------------------------------- charts
def chart_speed_accuracy(quick: bool):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from multiloop.kin.groups.newton import ConstraintSystem, track
    m = six_bar()
    plan = compile_plan(m)
    N = 20_000 if quick else 100_000
    x = np.linspace(0.0, 2 * np.pi, N)
    t_cf, st = _best(lambda: solve(m, x, plan=plan))
    pts = [("closed form (vectorised)", 1e6 * t_cf / N, closure(m, st.positions))]
    with kernel.using("on"):
        solve(m, x[:10], plan=plan)                      # numba's start-up outside the timing
        t_k, stk = _best(lambda: solve(m, x, plan=plan))
    pts.append(("closed form, compiled plan (kin.kernel)", 1e6 * t_k / N, closure(m, stk.positions)))
    # Newton of the whole mechanism at several tolerances
    cons = [c for s in plan.assur.steps for c in s.constraints]
    sysm = ConstraintSystem.compile(m, cons)
    unk = [i for i, lk in enumerate(m.link_names) if lk != m.frame]
    xn = np.linspace(0.0, 2 * np.pi, 200 if quick else 720)
    newton_pts = []
    for tol in (1e-4, 1e-6, 1e-8, 1e-10, 1e-12, 1e-14):
        Z = np.zeros((len(xn), m.n_links, 3))
        Z[:, :, :2] = plan.origins
        t0 = time.perf_counter()
        tr = track(sysm, Z, xn[:, None], unk, tol=tol)
        t = time.perf_counter() - t0
        ref = solve(m, xn, plan=plan)
        err = np.nanmax(np.abs(tr.Z[:, :, :2] - ref.poses[:, :, :2])) / 5.5
        newton_pts.append((tol, 1e6 * t / len(xn), max(err, 1e-17)))
    # velocity: analytic vs finite differences at several steps
    xv = np.linspace(0.1, 6.0, 2000)
    t_an, an = _best(lambda: solve(m, xv, plan=plan, derivatives=True))
    vel_pts = [("analytic (closed-form dyad rates)", 1e6 * t_an / len(xv), 0.0)]
    t_pos, _ = _best(lambda: solve(m, xv, plan=plan))
    for h in (1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9):
        t0 = time.perf_counter()
        p, q = solve(m, xv + h, plan=plan), solve(m, xv - h, plan=plan)
        fd = (p.positions - q.positions) / (2 * h)
        t = time.perf_counter() - t0
        err = np.nanmax(np.abs(fd - an.velocities)) / np.nanmax(np.abs(an.velocities))
        vel_pts.append((f"central FD h={h:g}", 1e6 * (t + t_pos) / len(xv), err))
    # two analytic routes for the velocity: group rates vs whole-mechanism linear system
    from multiloop.kin.groups.newton import rates
    Zd = np.zeros_like(an.poses)
    Zd, _ = rates(sysm, an.poses, Zd, np.ones((len(xv), 1)), unk)
    J = an.pose_rates
    vel_pts[0] = (vel_pts[0][0], vel_pts[0][1], max(float(np.nanmax(np.abs(Zd - J))), 1e-17))
    fig, axs = plt.subplots(1, 2, figsize=(12, 5), dpi=110)
    ax = axs[0]
    for (label, t, e), mark in zip(pts, ("o", "D")):
        ax.loglog([t], [max(e, 1e-17)], mark, ms=10, label=label)
    ax.loglog([p[1] for p in newton_pts], [p[2] for p in newton_pts], "s-", label="generic Newton (tracked)")
    for tol, t, e in newton_pts:
        ax.annotate(f"tol {tol:g}", (t, e), textcoords="offset points", xytext=(5, 3), fontsize=8)
    ax.set_xlabel("time per position (µs)")
    ax.set_ylabel("position error / size (vs closed form; closed form: closure residual)")
    ax.set_title(f"{m.name}: positions")
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=8)
    ax = axs[1]
    ax.loglog([vel_pts[0][1]], [vel_pts[0][2]], "o", ms=10,
              label="analytic: closed-form dyad rates vs whole-mechanism linear system")
    ax.loglog([p[1] for p in vel_pts[1:]], [max(p[2], 1e-17) for p in vel_pts[1:]], "^",
              label="central finite differences (2 extra solves)")
    for name, t, e in vel_pts[1:]:
        ax.annotate(name.split()[-1], (t, max(e, 1e-17)), textcoords="offset points", xytext=(5, 3), fontsize=8)
    ax.set_xlabel("time per position (µs)")
    ax.set_ylabel("relative velocity error")
    ax.set_title(f"{m.name}: velocities (d/dφ)")
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    CHARTS.mkdir(parents=True, exist_ok=True)
    fig.savefig(CHARTS / "solve_speed_accuracy.png")
    plt.close(fig)
    return pts, newton_pts, vel_pts


def chart_singular():
    """Approach the reach limit of a non-Grashof four-bar (r=1.5, l=c=2, g=3)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from multiloop.kin.groups.newton import ConstraintSystem, track
    A0 = (0.0, 1.5)
    B = _circle(A0, (3.0, 0.0), 2.0, 2.0, -1)
    b = MechanismBuilder(name="non-Grashof four-bar")
    b.add_link("g", frame=True)
    for n, lk, at in [("O", ("g", "c"), (0, 0)), ("A", ("c", "cp"), A0), ("B", ("cp", "r"), B), ("C", ("r", "g"), (3, 0))]:
        b.add_joint(n, "R", lk, at=at)
    b.add_driver("O")
    m = b.build()
    # limit: |A - C| = 4  ->  crank absolute angle a* with 2.25 + 9 - 9 cos a* = 16
    a_star = math.acos(-4.75 / 9.0)
    phi_star = a_star - math.pi / 2
    d = np.logspace(-1, -12, 23)
    x = phi_star - d
    cf = solve(m, np.concatenate([np.linspace(0, x[0], 30), x]), derivatives=True)
    cf_pos, cf_vel, ok = cf.positions[30:], cf.velocities[30:], cf.ok[30:]
    # exact velocity of B near the limit grows like d^-1/2: compare FD and Newton
    h = 1e-7
    warnings.simplefilter("ignore")
    p, q = solve(m, np.concatenate([np.linspace(0, x[0], 30), x + h])), solve(m, np.concatenate([np.linspace(0, x[0], 30), x - h]))
    fd = (p.positions[30:] - q.positions[30:]) / (2 * h)
    vmag = np.linalg.norm(cf_vel[:, 2], axis=1)
    fd_err = np.linalg.norm(fd[:, 2] - cf_vel[:, 2], axis=1) / vmag
    plan = compile_plan(m)
    cons = [c for s in plan.assur.steps for c in s.constraints]
    sysm = ConstraintSystem.compile(m, cons)
    unk = [1, 2, 3]
    xx = np.concatenate([np.linspace(0, x[0], 30), x])
    Z = np.zeros((len(xx), m.n_links, 3))
    Z[:, :, :2] = plan.origins
    tr = track(sysm, Z, xx[:, None], unk, singular_tol=0.0)
    iB = m.link_names.index("r")            # the rocker's reference point is B
    nt_err = np.linalg.norm(tr.Z[30:, iB, :2] - cf.poses[30:, iB, :2], axis=1)
    res = np.array([closure(m, cf_pos[i:i + 1]) for i in range(len(d))])
    fig, ax = plt.subplots(figsize=(7.5, 5), dpi=110)
    ax.loglog(d[ok], np.maximum(res[ok], 1e-17), "o-", label="closed form: closure residual")
    okn = tr.ok[30:] | np.isfinite(nt_err)
    ax.loglog(d[okn], np.maximum(nt_err[okn], 1e-17), "s-", label="Newton (tracked): |B − B_closed form|")
    ax.loglog(d[ok], np.maximum(fd_err[ok], 1e-17), "^-", label="central FD (h = 1e-7): relative velocity error")
    ax.loglog(d[ok], vmag[ok] / vmag[ok][0] * 1e-16, ":", color="0.5", label="|v_B| (scaled): grows like d^-1/2")
    ax.set_xlabel("distance to the reach limit in the input (rad)")
    ax.set_ylabel("error")
    ax.set_title("approaching a non-Grashof reach limit (det → 0)")
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    CHARTS.mkdir(parents=True, exist_ok=True)
    fig.savefig(CHARTS / "solve_singular.png")
    plt.close(fig)
    return d, res, nt_err, fd_err


def _versions() -> None:
    """The versions of everything timed in this run."""
    from importlib.metadata import PackageNotFoundError, version
    out = [f"python {sys.version.split()[0]}", f"numpy {np.__version__}"]
    for pkg in ("pylinkage", "numba", "python-solvespace"):
        try:
            out.append(f"{pkg} {version(pkg)}")
        except PackageNotFoundError:
            out.append(f"{pkg} not installed")
    print(", ".join(out))


def bare_four_bar(m):
    """The floor of a NumPy solve of ``four_bar()``: one vectorised pass giving the same
    positions and link angles as ``solve`` (crank cos/sin, the RRR closed form, two
    ``arctan2``), with no continuity check, status, derivatives or pose store."""
    at = {j.name: np.array(j.at, float) for j in m.joints}
    O, A0, B0, C = at["O"], at["A"], at["B"], at["C"]
    la2, lc2 = float(np.sum((B0 - A0) ** 2)), float(np.sum((B0 - C) ** 2))
    r = A0 - O
    th1, th2 = math.atan2(*(B0 - A0)[::-1]), math.atan2(*(B0 - C)[::-1])
    sign = float(np.sign((C - A0)[0] * (B0 - A0)[1] - (C - A0)[1] * (B0 - A0)[0]))

    def run(x):
        c, s = np.cos(x), np.sin(x)
        P = np.empty((4, 2, len(x)))                  # joint-major, returned transposed
        P[0], P[3] = O[:, None], C[:, None]
        ax, ay = O[0] + c * r[0] - s * r[1], O[1] + s * r[0] + c * r[1]
        dx, dy = C[0] - ax, C[1] - ay
        d2 = dx * dx + dy * dy
        t = 0.5 * (la2 / d2 + 1.0 - lc2 / d2)
        k = sign * np.sqrt(la2 / d2 - t * t)
        bx, by = ax + t * dx - k * dy, ay + t * dy + k * dx
        P[1, 0], P[1, 1], P[2, 0], P[2, 1] = ax, ay, bx, by
        ang = np.empty((4, len(x)))
        ang[0], ang[1] = 0.0, x
        ang[2] = np.arctan2(by - ay, bx - ax) - th1
        ang[3] = np.arctan2(by - C[1], bx - C[0]) - th2
        return P.transpose(2, 0, 1), ang.T
    return run


def _cpu_best(f, repeat):
    """Best of ``repeat`` calls in process CPU time (less sensitive to the other
    processes of a shared machine than wall time)."""
    best = np.inf
    for _ in range(repeat):
        t = time.process_time()
        f()
        best = min(best, time.process_time() - t)
    return best


def _alternated(fns: dict, repeat: int, rounds: int = 5) -> dict:
    """Best CPU time of each function of ``fns``, measured in ``rounds`` alternated rounds
    of ``repeat // rounds`` consecutive calls (the load of a shared machine drifts between
    rounds; within a round the allocator hands the same memory back, as in a loop of
    calls, while the first call of a round may take fresh pages: see the page faults)."""
    best = {k: np.inf for k in fns}
    for _ in range(rounds):
        for k, f in fns.items():
            best[k] = min(best[k], _cpu_best(f, max(repeat // rounds, 1)))
    return best


def ratios() -> None:
    """The solve goals: default ``solve(m, x)`` on the four-bar (plan cached on the
    mechanism), all outputs and one output point (``outputs=["B"]``), by the NumPy path
    and by the compiled plan (:mod:`kin.kernel`, ``MULTILOOP_KERNEL`` off / on), against
    pylinkage ``step_fast`` (numba), 10⁵ and 360 positions, and the floor of any NumPy
    solve (:func:`bare_four_bar`), all in the same run (CPU time, best of alternated
    rounds)."""
    m = four_bar()
    bare = bare_four_bar(m)
    kernel.load()
    for n, goal_np, goal_k in ((100000, 0.5, 0.5), (360, 1.0, 0.7)):
        x = np.linspace(0, 2 * np.pi, n, endpoint=False)
        r, why = pylinkage_run(m, x)
        if r is None:
            print(f"{n} positions: pylinkage {why}")
            continue
        P, _ = bare(x)
        for mode in ("off", "on"):
            with kernel.using(mode):
                assert np.nanmax(np.abs(P - solve(m, x).positions)) < 1e-12 * 8        # the same positions
                solve(m, x, outputs=["B"])

        def timed(mode, **kw):
            def f():
                with kernel.using(mode):
                    solve(m, x, **kw)
            return f
        t = _alternated({"pl": r[2], "floor": lambda: bare(x), ("off", "all"): timed("off"),
                         ("off", "one"): timed("off", outputs=["B"]), ("on", "all"): timed("on"),
                         ("on", "one"): timed("on", outputs=["B"])}, 12 if n > 10000 else 500, rounds=3)
        pl = t["pl"]
        for mode, goal in (("off", goal_np), ("on", goal_k)):
            path = "NumPy path" if mode == "off" else "compiled plan"
            for what, key in (("all outputs", "all"), ("one output point", "one")):
                v = t[mode, key]
                print(f"{n} positions, {what}, {path}: ours {v * 1e3:.3f} ms, pylinkage step_fast {pl * 1e3:.3f} ms, "
                      f"ratio {v / pl:.2f} (goal <= {goal}) -> {'MET' if v / pl <= goal else 'NOT MET'}")
        print(f"  floor (bare NumPy pass, all joints, no continuity or status) {t['floor'] * 1e3:.3f} ms = "
              f"{t['floor'] / pl:.2f}x pylinkage; page faults per call (5 in a row): NumPy path "
              f"{_faults(timed('off')):.0f}, compiled plan {_faults(timed('on')):.0f}, "
              f"floor {_faults(lambda: bare(x)):.0f}")


def kernel_startup() -> None:
    """The compiled plan's start-up: the first compile (an empty numba cache, a fresh
    process), a later process (the cache read), and the cold start of ``multiloop solve
    four_bar`` (36 positions: numba is not imported) — CPU seconds of each child."""
    import resource
    import subprocess
    import tempfile
    code = ("import time, numpy as np; t = time.process_time(); from multiloop.kin import kernel; kernel.load();"
            "from multiloop.kin.solve import solve; from multiloop.catalogue.named import load_named;"
            "m = load_named('four_bar'); x = np.linspace(0, 6, 50); t1 = time.process_time();"
            "\nwith kernel.using('off'): solve(m, x)\n"          # the plan and its chart (NumPy)
            "t2 = time.process_time()\nwith kernel.using('on'): solve(m, x)\n"
            "print(f'{t1 - t:.2f} {time.process_time() - t2:.2f}')")

    def child(argv, env):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        out = subprocess.run(argv, env=env, capture_output=True, text=True, check=True).stdout
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        return out, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    with tempfile.TemporaryDirectory() as cache:
        env = dict(__import__("os").environ, NUMBA_CACHE_DIR=cache)
        for what in ("first process (compiles)", "second process (disk cache)"):
            out, _ = child([sys.executable, "-c", code], env)
            imp, first = out.split()
            print(f"kernel, {what}: import of numba and the kernel {imp} s CPU, its first batch "
                  f"(compile or cache read) {first} s CPU")
    cli = [sys.executable, "-m", "multiloop", "solve", "four_bar"]
    env = {k: v for k, v in __import__("os").environ.items() if k != "MULTILOOP_KERNEL"}
    child(cli, env)                                               # warm the file cache
    best = min(child(cli, env)[1] for _ in range(5))
    print(f"cold start of `multiloop solve four_bar` (36 positions, numba not imported): {best:.2f} s CPU, best of 5")


def memory(n: int = 10 ** 6) -> None:
    """Peak memory of ``solve`` on ``n`` positions of the catalogue's ``linkage_24``, traced
    by :mod:`tracemalloc` (NumPy's buffers are traced), against what the result keeps (the
    pose store: every array of the returned state). Goal: peak ≤ 2 × the store."""
    import tracemalloc

    from multiloop.inputs import load_mechanism
    m = load_mechanism("linkage_24")
    x = np.linspace(0.0, 2 * np.pi, n)
    solve(m, x[:100])                                   # the plan compiled before tracing
    tracemalloc.start()
    t = time.process_time()
    st = solve(m, x)
    cpu = time.process_time() - t
    kept, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    store = {k: v.nbytes for k, v in vars(st).items() if isinstance(v, np.ndarray)}
    print(f"linkage_24, {n} positions: {cpu:.1f} s CPU; peak {peak / 2 ** 20:.0f} MiB, kept after the call "
          f"{kept / 2 ** 20:.0f} MiB (arrays of the result {sum(store.values()) / 2 ** 20:.0f} MiB, some of them views: "
          f"{', '.join(f'{k} {v / 2 ** 20:.0f}' for k, v in store.items())}); peak / kept = {peak / kept:.2f} "
          f"(goal <= 2) -> {'MET' if peak <= 2 * kept else 'NOT MET'}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer positions")
    ap.add_argument("--no-charts", action="store_true")
    ap.add_argument("--ratios", action="store_true", help="only the issue-11 ratios against pylinkage")
    ap.add_argument("--memory", action="store_true", help="only the peak memory of 10^6 positions of linkage_24")
    a = ap.parse_args(argv)
    if a.memory:
        memory()
        return
    _versions()
    ratios()
    kernel_startup()
    if a.ratios:
        return
    print(f"numpy {np.__version__}; goals: four-bar ≤ 0.1 µs/position with residual ≤ 1e-12 (vectorised, 1e5); "
          "triad mechanism ≤ 5 µs/position, no failures")
    rows = table(a.quick)
    print_table(rows)
    fb = rows[0]
    tr = rows[2]
    for path, us, res in (("NumPy path", fb["cf_us"], fb["cf_res"]), ("compiled plan", fb["k_us"], fb["k_res"])):
        print(f"goal four-bar, {path}: {us:.3g} µs/position, residual {res:.1e} -> "
              f"{'MET' if us <= 0.1 and res <= 1e-12 else 'NOT MET'}")
    print(f"goal triad: {tr['cf_us']:.3g} µs/position, {tr['cf_fail']} failures -> "
          f"{'MET' if tr['cf_us'] <= 5 and tr['cf_fail'] == 0 else 'NOT MET'}")
    if not a.no_charts:
        pts, newton_pts, vel_pts = chart_speed_accuracy(a.quick)
        print("speed/accuracy (six-bar): " + "; ".join(f"Newton tol {t:g}: {us:.3g} µs, err {e:.1e}"
                                                        for t, us, e in newton_pts))
        print("velocity: " + "; ".join(f"{n}: {us:.3g} µs, err {e:.1e}" for n, us, e in vel_pts))
        d, res, nt, fd = chart_singular()
        print("near the reach limit (distance 1e-1 … 1e-12 rad): closure residual max "
              f"{np.nanmax(res):.1e}; FD velocity error from {fd[0]:.1e} to {np.nanmax(fd):.1e}")
        print(f"charts written to {CHARTS}")


if __name__ == "__main__":
    main()
