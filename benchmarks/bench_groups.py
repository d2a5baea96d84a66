"""Benchmark of the group kernels (plain script, not a test).

    python benchmarks/bench_groups.py [--n 100000] [--repeat 7] [--no-charts]

Per position, on an RRR dyad (a four-bar's driven dyad: crank 0.5, coupler 1.6,
rocker 1.2, frame pin (2, 0.3)):

* the vectorised closed form (:func:`kin.groups.rrr_position` / ``rrr_rates``);
* a generic Newton on the same dyad (vectorised NumPy, unknown B, warm start
  from the solution one degree of crank earlier, stopped at a residual tolerance
  1e-4 ... 1e-14), velocities then from its Jacobian;
* SciPy ``fsolve`` per position (a scalar loop, the usual generic approach);
* velocities by central differences of closed-form positions, steps 1e-2 ... 1e-10.

Errors are against a 40-digit mpmath evaluation on a subset of positions.  Also
per-position times of the other dyad kinds, of the triad's all-modes solver and
of the triad tracker.  Writes two charts to ``benchmarks/charts/``:
``groups_speed_accuracy.png`` and ``groups_singular.png`` (behaviour as the dyad
approaches full extension, det -> 0).
"""
from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import numpy as np

from multiloop.kin.groups.base import SINGULAR_RTOL
from multiloop.kin.groups import (prp_position, rpp_position, rpr_position, rrp_position,
                        rrr_position, rrr_rates, triad_modes, triad_track)

L2, L3, R = 1.6, 1.2, 0.5
C0 = np.array([2.0, 0.3])
CHARTS = Path(__file__).with_name("charts")


def best(f, repeat):
    """Best wall time of ``repeat`` calls (s) and the last result."""
    t = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = f()
        t = min(t, time.perf_counter() - t0)
    return t, out


def crank(phi):
    e = np.stack([np.cos(phi), np.sin(phi)], -1)
    n = np.stack([-np.sin(phi), np.cos(phi)], -1)
    return R * e, R * n, -R * e                      # position, velocity, accel (ω = 1)


def residual(A, C, B):
    r = np.maximum(np.abs(np.linalg.norm(B - A, axis=-1) - L2),
                   np.abs(np.linalg.norm(B - C, axis=-1) - L3))
    return np.max(r) / max(L2, L3)


# ------------------------------------------------------------------ references
def mp_rrr(A, C, vA, vC, l2=L2, l3=L3, sign=1):
    """RRR position and velocity of B at 40 digits (independent of float rounding)."""
    import mpmath as mp
    mp.mp.dps = 40
    B = np.empty_like(A)
    vB = np.empty_like(A)
    for i in range(len(A)):
        ax, ay = mp.mpf(A[i, 0]), mp.mpf(A[i, 1])
        cx, cy = mp.mpf(C[i, 0]), mp.mpf(C[i, 1])
        dx, dy = cx - ax, cy - ay
        d2 = dx * dx + dy * dy
        t = (l2 ** 2 + d2 - mp.mpf(l3) ** 2) / (2 * d2)
        k = sign * mp.sqrt(mp.mpf(l2) ** 2 / d2 - t * t)
        bx, by = ax + t * dx - k * dy, ay + t * dy + k * dx
        # velocity: (B-A)·(vB-vA) = 0, (B-C)·(vB-vC) = 0
        m11, m12, m21, m22 = bx - ax, by - ay, bx - cx, by - cy
        r1 = m11 * vA[i, 0] + m12 * vA[i, 1]
        r2 = m21 * vC[i, 0] + m22 * vC[i, 1]
        det = m11 * m22 - m12 * m21
        B[i] = float(bx), float(by)
        vB[i] = float((r1 * m22 - m12 * r2) / det), float((m11 * r2 - r1 * m21) / det)
    return B, vB


# ------------------------------------------------------------------ generic Newton
def newton_rrr(A, C, B0, tol, max_iter=60):
    """Vectorised Newton on |B-A|² = l2², |B-C|² = l3²; stops when the max
    relative residual of the batch is below ``tol``.  Returns B, iterations."""
    B = B0.copy()
    scale = max(L2, L3)
    for it in range(max_iter + 1):
        ra, rc = B - A, B - C
        f1 = 0.5 * (np.sum(ra * ra, -1) - L2 * L2)
        f2 = 0.5 * (np.sum(rc * rc, -1) - L3 * L3)
        res = np.max(np.maximum(np.abs(f1) / L2, np.abs(f2) / L3)) / scale
        if res <= tol or it == max_iter:
            return B, it
        det = ra[:, 0] * rc[:, 1] - ra[:, 1] * rc[:, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            dx = (f1 * rc[:, 1] - f2 * ra[:, 1]) / det
            dy = (ra[:, 0] * f2 - rc[:, 0] * f1) / det
        B = B - np.stack([dx, dy], -1)
    return B, max_iter


def jac_velocity(A, C, B, vA, vC):
    """Velocity of B from the Jacobian of the point form (generic route)."""
    ra, rc = B - A, B - C
    r1 = np.sum(ra * vA, -1)
    r2 = np.sum(rc * vC, -1)
    det = ra[:, 0] * rc[:, 1] - ra[:, 1] * rc[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.stack([(r1 * rc[:, 1] - ra[:, 1] * r2) / det,
                         (ra[:, 0] * r2 - r1 * rc[:, 0]) / det], -1)


def fsolve_rrr(A, C, B0):
    from scipy.optimize import fsolve
    out = np.empty_like(B0)
    for i in range(len(A)):
        a, c = A[i], C[i]
        f = lambda b: [np.dot(b - a, b - a) - L2 * L2, np.dot(b - c, b - c) - L3 * L3]  # noqa: E731
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            out[i] = fsolve(f, B0[i], xtol=1e-14)
    return out


# ------------------------------------------------------------------ main study
def speed_accuracy(n, repeat, charts):
    phi = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    A, vA, aA = crank(phi)
    C = np.broadcast_to(C0, A.shape).copy()
    vC = np.zeros_like(A)
    sub = np.linspace(0, n - 1, 200).astype(int)
    Bx, vBx = mp_rrr(A[sub], C[sub], vA[sub], vC[sub])
    rows = []

    t_pos, (B, ok, _) = best(lambda: rrr_position(A, C, L2, L3, 1.0), repeat)
    t_rate, r = best(lambda: rrr_rates(A, C, B, vA, vC, aA, vC), repeat)
    t_vel, rv = best(lambda: rrr_rates(A, C, B, vA, vC), repeat)
    assert ok.all()
    res_cf = residual(A, C, B)
    verr_cf = np.max(np.abs(rv.vB[sub] - vBx)) / np.max(np.abs(vBx))
    perr_cf = np.max(np.abs(B[sub] - Bx)) / max(L2, L3)
    rows.append(("closed form", t_pos / n, res_cf, perr_cf, (t_pos + t_vel) / n, verr_cf))
    print(f"RRR closed form, N = {n}: position {t_pos / n * 1e6:.4f} us/pos, "
          f"velocity {t_vel / n * 1e6:.4f} us/pos, velocity+acceleration "
          f"{t_rate / n * 1e6:.4f} us/pos")
    print(f"  closure residual (relative) {res_cf:.2e}; position error {perr_cf:.2e}; "
          f"velocity error {verr_cf:.2e} (vs 40-digit mpmath)")
    goal = "MET" if t_pos / n <= 1e-7 and res_cf <= 1e-12 else "NOT met"
    print(f"  goal <= 0.1 us/pos with residual <= 1e-12: {goal}")

    # generic Newton, warm start from one degree of crank earlier
    B0 = rrr_position(*crank(phi - np.radians(1.0))[:1], C, L2, L3, 1.0).B
    newton = []
    for tol in (1e-4, 1e-6, 1e-8, 1e-10, 1e-12, 1e-14):
        t_nw, (Bn, it) = best(lambda: newton_rrr(A, C, B0, tol), max(2, repeat // 2))
        t_jv, vn = best(lambda: jac_velocity(A, C, Bn, vA, vC), max(2, repeat // 2))
        res = residual(A, C, Bn)
        perr = np.max(np.abs(Bn[sub] - Bx)) / max(L2, L3)
        verr = np.max(np.abs(vn[sub] - vBx)) / np.max(np.abs(vBx))
        newton.append((tol, t_nw / n, res, perr, (t_nw + t_jv) / n, verr, it))
        rows.append((f"Newton tol {tol:.0e}", t_nw / n, res, perr, (t_nw + t_jv) / n, verr))
    m = 2000
    t_fs, Bf = best(lambda: fsolve_rrr(A[:m], C[:m], B0[:m]), 1)
    res_fs = residual(A[:m], C[:m], Bf)
    rows.append(("scipy fsolve loop", t_fs / m, res_fs, np.nan, np.nan, np.nan))
    # finite-difference velocities of closed-form positions
    fdm = []
    for h in (1e-2, 1e-4, 1e-6, 1e-8, 1e-10):
        def fd():
            Bp = rrr_position(crank(phi + h)[0], C, L2, L3, 1.0).B
            Bm = rrr_position(crank(phi - h)[0], C, L2, L3, 1.0).B
            return (Bp - Bm) / (2 * h)
        t_fd, vfd = best(fd, repeat)
        verr = np.max(np.abs(vfd[sub] - vBx)) / np.max(np.abs(vBx))
        fdm.append((h, (t_pos + t_fd) / n, verr))
        rows.append((f"FD velocity h={h:.0e}", t_pos / n, res_cf, perr_cf, (t_pos + t_fd) / n, verr))

    print("\n  method                  pos us/pos  residual   pos err   pos+vel us  vel err   "
          "ratio(time) vs closed form")
    for name, tp, res, perr, tv, verr in rows:
        print(f"  {name:22s} {tp * 1e6:10.4f}  {res:9.1e}  {perr:8.1e}  {tv * 1e6:10.4f}  "
              f"{verr:8.1e}   x{tp / (t_pos / n):8.1f}")
    print("  Newton iterations per tolerance:",
          ", ".join(f"{tol:.0e}:{it}" for tol, *_, it in newton))

    # other kernels
    print("\nOther kernels (N = %d):" % n)
    u = np.stack([np.cos(0.3 * phi), np.sin(0.3 * phi)], -1)
    u2 = np.stack([np.cos(0.3 * phi + 1.2), np.sin(0.3 * phi + 1.2)], -1)
    P = np.broadcast_to(np.array([1.5, -0.2]), A.shape)
    for name, f in (("RRP position", lambda: rrp_position(A, P, u, 2.0, 0.1, 1.0)),
                    ("RPR position", lambda: rpr_position(A, C, 0.1, 1.0)),
                    ("PRP position", lambda: prp_position(A, u, 0.1, C, u2, 0.0)),
                    ("RPP position", lambda: rpp_position(A, P, u, 1.0, 0.1))):
        t, _ = best(f, repeat)
        print(f"  {name:14s} {t / n * 1e6:.4f} us/pos")
    A63 = np.array([[0.250191, 0.794428], [0.551371, -0.549586], [-0.399667, 0.747107]])
    b63 = np.array([[0.0, 0.0], [-0.989469, 0.642457], [0.594139, -0.06413]])
    l63 = np.array([0.593942, 0.561953, 0.53133])
    At = A63 + 0.02 * np.stack([np.cos(phi[:, None] * [1, -0.7, 1.3] + [0, 1, 2]),
                                np.sin(phi[:, None] * [1, -0.7, 1.3] + [0, 1, 2])], -1)
    nt = min(n, 20000)
    t, md = best(lambda: triad_modes(At[:nt], b63, l63), 1)
    print(f"  triad all modes (eigenvalues + polish): {t / nt * 1e6:.2f} us/pos "
          f"(N = {nt}, modes per position {np.bincount(md.n_modes).nonzero()[0].tolist()}, "
          f"max residual {np.nanmax(md.residual):.1e})")
    start = md.P[0, 2]                                  # a mode that survives the path
    for stride in (1, 32):
        nn = nt if stride == 1 else n
        t, tr = best(lambda: triad_track(At[:nn], b63, l63, start, stride=stride), 1 if stride == 1 else 3)
        print(f"  triad track stride={stride:2d}: {t / nn * 1e6:.2f} us/pos (N = {nn}, "
              f"ok {tr.ok.mean() * 100:.0f} %)")
    if charts:
        chart_speed(rows, newton, fdm, res_cf, verr_cf, t_pos / n, (t_pos + t_vel) / n,
                    t_fs / m, res_fs)


def chart_speed(rows, newton, fdm, res_cf, verr_cf, t_cf, tv_cf, t_fs, res_fs):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    tiny = 1e-17
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.4))
    a = ax[0]
    a.loglog([t_cf * 1e6], [max(res_cf, tiny)], "o", ms=9, label="closed form")
    a.loglog([r[1] * 1e6 for r in newton], [max(r[2], tiny) for r in newton], "s-",
             label="Newton (vectorised), tol 1e-4…1e-14")
    groups = {}
    for r in newton:                       # tolerances reaching the same residual: one label
        groups.setdefault(f"{max(r[2], tiny):.1e}", []).append(r)
    for rs in groups.values():
        a.annotate("tol " + ", ".join(f"{r[0]:.0e}" for r in rs),
                   (rs[0][1] * 1e6, max(rs[0][2], tiny)), fontsize=7,
                   xytext=(5, 3), textcoords="offset points")
    a.loglog([t_fs * 1e6], [max(res_fs, tiny)], "^", ms=8, label="scipy fsolve loop")
    a.set_xlabel("time per position (µs)")
    a.set_ylabel("closure residual (relative)")
    a.set_title("RRR position: speed vs accuracy")
    a.grid(True, which="both", alpha=0.3)
    a.legend(fontsize=8)
    a = ax[1]
    a.loglog([tv_cf * 1e6], [max(verr_cf, tiny)], "o", ms=9, label="closed form (2×2 system)")
    a.loglog([r[4] * 1e6 for r in newton], [max(r[5], tiny) for r in newton], "s-",
             label="Newton positions + Jacobian")
    a.loglog([f[1] * 1e6 for f in fdm], [f[2] for f in fdm], "d-",
             label="central differences, h=1e-2…1e-10")
    for f in fdm:
        a.annotate(f"h={f[0]:.0e}", (f[1] * 1e6, f[2]), fontsize=7, xytext=(4, 2),
                   textcoords="offset points")
    a.set_xlabel("time per position, position + velocity (µs)")
    a.set_ylabel("velocity error (relative, vs 40-digit)")
    a.set_title("RRR velocity: speed vs accuracy")
    a.grid(True, which="both", alpha=0.3)
    a.legend(fontsize=8)
    fig.tight_layout()
    CHARTS.mkdir(exist_ok=True)
    fig.savefig(CHARTS / "groups_speed_accuracy.png", dpi=120)
    plt.close(fig)


def singular_study(charts):
    """Approach full extension d = (l2 + l3)(1 - δ): errors against δ."""
    deltas = np.logspace(-1, -17, 65)
    n = len(deltas)
    A = np.zeros((n, 2))
    d = (L2 + L3) * (1 - deltas)
    C = np.stack([d, np.zeros(n)], -1)
    vA = np.broadcast_to(np.array([0.3, 1.0]), (n, 2)).copy()
    vC = np.zeros((n, 2))
    Bx, vBx = mp_rrr(A, C, vA, vC)
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # the kernels must not warn
        B, ok, det = rrr_position(A, C, L2, L3, 1.0)
        r = rrr_rates(A, C, B, vA, vC)
    vnorm = np.linalg.norm(vBx, axis=-1)
    cf_p = np.linalg.norm(B - Bx, axis=-1) / L2
    cf_v = np.linalg.norm(r.vB - vBx, axis=-1) / vnorm
    # Newton from a 1e-3 perturbation, tol 1e-14
    B0 = Bx + 1e-3 * np.array([1.0, -1.0])
    nw_p = np.empty(n)
    nw_v = np.empty(n)
    nw_it = np.empty(n)
    nw_flip = np.zeros(n, bool)
    for i in range(n):
        Bn, it = newton_rrr(A[i:i + 1], C[i:i + 1], B0[i:i + 1], 1e-14)
        nw_p[i] = np.linalg.norm(Bn[0] - Bx[i]) / L2
        nw_v[i] = np.linalg.norm(jac_velocity(A[i:i + 1], C[i:i + 1], Bn, vA[i:i + 1],
                                              vC[i:i + 1])[0] - vBx[i]) / vnorm[i]
        nw_it[i] = it
        ca, ba = C[i] - A[i], Bn[0] - A[i]
        nw_flip[i] = ca[0] * ba[1] - ca[1] * ba[0] < 0            # other assembly branch
    fd = {}
    for h in (1e-4, 1e-6, 1e-8):
        Bp = rrr_position(A + h * vA, C, L2, L3, 1.0).B
        Bm = rrr_position(A - h * vA, C, L2, L3, 1.0).B
        fd[h] = np.linalg.norm((Bp - Bm) / (2 * h) - vBx, axis=-1) / vnorm
    print("\nNear full extension (d = (l2+l3)(1-δ)):")
    for dl in (1e-2, 1e-6, 1e-10, 1e-13, 1e-15, 1e-17):
        i = np.argmin(np.abs(np.log(deltas / dl)))
        print(f"  δ={deltas[i]:.0e}: closed form pos err {cf_p[i]:.1e}, vel err {cf_v[i]:.1e}, "
              f"singular flag {bool(r.singular[i])}; Newton pos err {nw_p[i]:.1e} "
              f"({int(nw_it[i])} it{', OTHER BRANCH' if nw_flip[i] else ''}), vel err "
              f"{nw_v[i]:.1e}; FD(h=1e-6) vel err "
              f"{fd[1e-6][i]:.1e}")
    if nw_flip.any():
        print(f"  Newton (from 1e-3 off, tol 1e-14) converged to the OTHER branch for "
              f"δ <= {deltas[nw_flip].max():.0e} ({nw_flip.sum()} of {n} cases)")
    first = deltas[np.argmax(r.singular)] if r.singular.any() else np.nan
    print(f"  singular flag (|det| <= {SINGULAR_RTOL:.0e}·|c1||c2|) first raised at "
          f"δ ≈ {first:.1e}; relative det there {np.abs(det[i]) / (L2 * L3):.1e}")
    if not charts:
        return
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fl = lambda x: np.where(np.isfinite(x), np.maximum(x, 1e-17), np.nan)  # noqa: E731
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.4))
    a = ax[0]
    a.loglog(deltas, fl(cf_p), "o-", ms=3, label="closed form")
    a.loglog(deltas, fl(nw_p), "s-", ms=3, label="Newton tol 1e-14 (from 1e-3 off)")
    if nw_flip.any():
        a.loglog(deltas[nw_flip], fl(nw_p[nw_flip]), "rx", ms=6, label="Newton: other branch")
    a.loglog(deltas, 1e-16 / np.sqrt(deltas), "k:", lw=1, label="ε/√δ")
    a.set_xlabel("distance to the singularity δ = 1 − d/(l2+l3)")
    a.set_ylabel("position error of B (relative)")
    a.invert_xaxis()
    a.grid(True, which="both", alpha=0.3)
    a.legend(fontsize=8)
    a.set_title("RRR approaching full extension: position")
    a = ax[1]
    a.loglog(deltas, fl(cf_v), "o-", ms=3, label="closed form 2×2 system")
    a.loglog(deltas, fl(nw_v), "s-", ms=3, label="Newton + Jacobian")
    for h, e in fd.items():
        a.loglog(deltas, fl(e), "--", lw=1, label=f"central differences h={h:.0e}")
    if r.singular.any():
        a.axvline(first, color="r", lw=1, ls=":", label="singular flag raised")
    a.set_xlabel("distance to the singularity δ")
    a.set_ylabel("velocity error (relative)")
    a.invert_xaxis()
    a.grid(True, which="both", alpha=0.3)
    a.legend(fontsize=7)
    a.set_title("velocity (|v| grows like 1/√δ)")
    fig.tight_layout()
    CHARTS.mkdir(exist_ok=True)
    fig.savefig(CHARTS / "groups_singular.png", dpi=120)
    plt.close(fig)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--n", type=int, default=100_000)
    p.add_argument("--repeat", type=int, default=7)
    p.add_argument("--no-charts", action="store_true")
    a = p.parse_args(argv)
    speed_accuracy(a.n, a.repeat, not a.no_charts)
    singular_study(not a.no_charts)


if __name__ == "__main__":
    main()
