"""LInK's 26 capital-letter targets scored with LInK's own chamfer metric (issue 37,
"LINK-ABC").

**Targets.** ``alphabet.npy`` (26 × 200 × 2, float64, letters A–Z in order) of
https://github.com/ahnobari/LInKGenerator at commit
8be6cedf750d9925576aca2a6dc5bf4156c1ab33 (the companion repository of LInK's letter
demo; LInK's ``Test.py`` reads the same file name, ``./TestData/alphabet.npy``, which
LInK's repository itself does not hold).  LInKGenerator has no licence file, so the
data are not redistributed here: see ``benchmarks/data/README.md`` for the URL and the
SHA-256 this script checks.

**LInK's per-letter results.** ``alpha_res.npy`` of the same commit: per letter
``[mechanism, [CD, OD, og_scale], curve]``, the output of LInK's
``PathSynthesis.synthesize`` (``LInK/OptimJax.py`` in https://github.com/ahnobari/LInK,
commit caff27e92fd3fda8e5176ea07af8e880d6e53304: it returns ``performance = [CD *
og_scale, OD * og_scale**2, og_scale]``).  Their mean CD is 0.025402, the mean published
for LInK's alphabet.  The 26 values are copied into :data:`LINK_CD` (with the joints of
each mechanism, :data:`LINK_JOINTS`).

**Metric.** LInK's final chamfer distance, ported from ``LInK/OptimJax.py`` (commit
above) to NumPy, function by function (:func:`uniformize`, :func:`preprocess_curves`,
:func:`batch_chamfer_distance`, :func:`batch_ordered_distance`, :func:`find_transforms`,
:func:`apply_transforms`, :func:`get_scales`), as ``PathSynthesis.synthesize`` computes
it after its optimisation:

* closed target (LInK's rule in ``Test.py``: ``|p_-1 - p_0| <= 1.1 |p_1 - p_0|``):
  the target is ``preprocess_curves`` (arc-length resampled to 200 points, centred,
  unit RMS radius, its farthest point turned onto +x) and resampled to 2000 points;
  the mechanism's curve is traced at 2000 equal input steps over one turn and resampled
  to 2000 points by arc length; ``find_transforms`` centres it and scales it to unit
  RMS radius and turns it by the best of 100 angles (``linspace(0, 2π, 100)``) by the
  *ordered* distance; the score is the chamfer distance (the mean nearest-point
  distance from each curve to the other, summed) times ``og_scale``, the target's RMS
  radius;
* open target (``partial=True``): LInK closes the stroke by half an ellipse through its
  ends, normalises the closed curve as above, and scores only the stroke's part (up to
  the point nearest the stroke's last point) against the part of the mechanism's
  curve between the points nearest the stroke's ends, in the closed curve's
  normalised frame, times ``og_scale``.  Our open designs trace the stroke over their
  written input interval only, and are written in the target's own frame; so the
  stroke's part is built exactly as LInK builds it (:func:`link_stroke`), our curve over
  its interval (2000 equal input steps, resampled to 2000 points) takes the place of
  LInK's matched part, both in the target's frame, and the chamfer distance is divided
  by the closed curve's RMS radius (LInK's frame) and multiplied by ``og_scale``.  The
  one step not ported is LInK's re-alignment of a full-turn curve to the ellipse-closed
  target, which an open design over its interval has no use for.

Run::

    python benchmarks/bench_link_abc.py --targets alphabet.npy --db ATLAS.sqlite \\
        --evaluations N [--letters ABC] [--json out.json] [--chart out.png]

Each letter is synthesised by :func:`catalogue.topology_synthesis.synthesise` with
``links=(4, 6, 8)`` (at most 8 links), an evaluation budget (reproducible), the open
mode for LInK's open letters and the closed mode for its closed ones; every returned
design passes ``check`` on one branch (the synthesiser keeps no other); the best by
LInK's metric among the returned designs is reported.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import string
import sys
import time

import numpy as np

TARGETS_URL = ("https://github.com/ahnobari/LInKGenerator/raw/"
               "8be6cedf750d9925576aca2a6dc5bf4156c1ab33/alphabet.npy")
TARGETS_SHA256 = "26d217d44b6c95486121d7d080f9a342f00decd46e416912a4da4d949b0333f5"
RESULTS_URL = ("https://github.com/ahnobari/LInKGenerator/raw/"
               "8be6cedf750d9925576aca2a6dc5bf4156c1ab33/alpha_res.npy")

# LInK's chamfer distance per letter (alpha_res.npy[i, 1][0], float32, rounded to 5
# significant digits) and its mechanism's number of joints (alpha_res.npy[i, 0][0]).
LINK_CD = dict(zip(string.ascii_uppercase, (
    0.018849, 0.023409, 0.0081646, 0.0065046, 0.053765, 0.011719, 0.043194, 0.022087,
    0.016367, 0.011243, 0.14694, 0.008138, 0.021987, 0.033101, 0.0049118, 0.012664,
    0.015698, 0.029067, 0.022587, 0.015277, 0.0066984, 0.0082314, 0.020155, 0.040977,
    0.01616, 0.042544)))
LINK_JOINTS = dict(zip(string.ascii_uppercase, (
    19, 19, 17, 16, 19, 18, 20, 18, 20, 20, 15, 19, 18, 17, 20, 16, 19, 16, 17, 20, 20,
    19, 17, 18, 17, 16)))
LINK_MEAN_PUBLISHED = 0.0254

N_FINAL = 2000          # LInK's optim_timesteps (Test.py default)
N_CURVE = 200           # LInK's curve_size


# --- LInK/OptimJax.py, ported to NumPy (same names, same arithmetic) -----------------

def uniformize(curves: np.ndarray, n: int) -> np.ndarray:
    """``OptimJax.uniformize``: arc-length resampling of (B, m, 2) curves to n points
    at ``linspace(-1e-6, 1 - 1e-6, n)`` of the normalised length (first point kept)."""
    curves = np.asarray(curves, float)
    seg = np.linalg.norm(curves[:, 1:] - curves[:, :-1], axis=-1)
    l = np.cumsum(np.pad(seg, ((0, 0), (1, 0))), axis=-1)
    l = l / l[:, -1:]
    sampling = np.linspace(-1e-6, 1 - 1e-6, n)
    end_is = np.stack([np.searchsorted(a, sampling)[1:] for a in l])
    rows = np.arange(len(curves))[:, None]
    l_end, l_start = l[rows, end_is], l[rows, end_is - 1]
    ws = (l_end - sampling[None, 1:]) / (l_end - l_start)
    end_g, start_g = curves[rows, end_is], curves[rows, end_is - 1]
    return np.concatenate([curves[:, :1], end_g - (end_g - start_g) * ws[..., None]], axis=1)


def preprocess_curves(curves: np.ndarray, n: int = N_CURVE) -> np.ndarray:
    """``OptimJax.preprocess_curves``: uniformize, centre, unit RMS radius, the
    farthest point turned onto the +x axis."""
    c = uniformize(curves, n)
    c = c - c.mean(1)[:, None]
    c = c / np.sqrt(np.square(c).sum(-1).sum(-1) / n)[:, None, None]
    k = np.square(c).sum(-1).argmax(axis=1)
    far = c[np.arange(len(c)), k]
    th = -np.arctan2(far[:, 1], far[:, 0])
    return _rotate(c, th)


def _rotate(curves: np.ndarray, th) -> np.ndarray:
    cs, sn = np.cos(th)[:, None], np.sin(th)[:, None]
    x, y = curves[..., 0], curves[..., 1]
    return np.stack([cs * x - sn * y, sn * x + cs * y], axis=-1)


def get_scales(curves: np.ndarray) -> np.ndarray:
    """``OptimJax.get_scales``: RMS distance from the mean point."""
    c = np.asarray(curves, float)
    return np.sqrt(np.square(c - c.mean(1)[:, None]).sum(-1).sum(-1) / c.shape[1])


def _cdist(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.sqrt(np.square(a[:, :, None, :] - b[:, None, :, :]).sum(-1))


def batch_chamfer_distance(c1: np.ndarray, c2: np.ndarray) -> np.ndarray:
    """``OptimJax.batch_chamfer_distance``: mean distance from each point of c2 to its
    nearest point of c1 plus the mean from each point of c1 to its nearest of c2."""
    out = []
    for a, b in zip(c1, c2):
        d = _cdist(a[None], b[None])[0]
        out.append(d.min(0).mean() + d.min(1).mean())
    return np.array(out)


def batch_ordered_distance(c1: np.ndarray, c2: np.ndarray) -> np.ndarray:
    """``OptimJax.batch_ordered_distance``: the cyclic shift (either direction) of c1
    against c2 with the least summed point distance; its mean squared distance.
    The shift sums are wrapped diagonal sums of the distance matrix, read as strided
    views of the matrix written twice side by side; float32, as LInK's JAX arrays."""
    from numpy.lib.stride_tricks import as_strided

    n = c2.shape[1]
    j = np.arange(n)
    D = np.empty((n, 2 * n), np.float32)
    rs, cs = D.strides
    out = []
    for a, b in zip(np.asarray(c1, np.float32), np.asarray(c2, np.float32)):
        np.hypot(b[:, None, 0] - a[None, :, 0], b[:, None, 1] - a[None, :, 1], out=D[:, :n])  # cdist(c2, c1)
        D[:, n:] = D[:, :n]
        # cw: shift i pairs c2[j] with c1[(j - i) mod n] = D[j, j - i + n]
        cw = as_strided(D[:, n:], shape=(n, n), strides=(-cs, rs + cs)).sum(1)
        # ccw: with c1[(n - 1 - j - i) mod n] = D[j, 2n - 1 - j - i]
        ccw = as_strided(D[:, 2 * n - 1:], shape=(n, n), strides=(-cs, rs - cs)).sum(1)
        ds = []
        for idx in ((j - int(np.argmin(cw))) % n, (n - 1 - j - int(np.argmin(ccw))) % n):
            ds.append(np.square(np.linalg.norm(b - a[idx], axis=-1)).mean())
        out.append(min(ds))
    return np.array(out, float)


def find_transforms(in_curves: np.ndarray, target_curve: np.ndarray, n_angles: int = 100):
    """``OptimJax.find_transforms``: translation (mean), scale (RMS radius) and the
    best of ``n_angles`` rotations by :func:`batch_ordered_distance`."""
    tr = in_curves.mean(1)
    c = in_curves - tr[:, None]
    s = np.sqrt(np.square(c).sum(-1).sum(-1) / in_curves.shape[1])
    c = c / s[:, None, None]
    angles = np.linspace(0, 2 * np.pi, n_angles)
    best = []
    for one in c:
        rot = _rotate(np.repeat(one[None], n_angles, 0), angles)
        d = batch_ordered_distance(rot, np.repeat(target_curve[None], n_angles, 0))
        best.append(angles[int(np.argmin(d))])
    return tr, s, np.array(best)


def apply_transforms(curves: np.ndarray, translations, scales, rotations) -> np.ndarray:
    """``OptimJax.apply_transforms``: scale, rotate, translate."""
    return _rotate(curves * scales[:, None, None], rotations) + translations[:, None]


# --- the two branches of PathSynthesis.synthesize's final score ----------------------

def is_link_closed(target: np.ndarray) -> bool:
    """LInK's rule (``Test.py``): closed when the end-to-start gap is at most 1.1 times
    the first step."""
    t = np.linalg.norm(target[0] - target[1])
    e = np.linalg.norm(target[0] - target[-1])
    return bool(e / t <= 1.1)


def closed_with_ellipse(target: np.ndarray, n: int = N_CURVE) -> np.ndarray:
    """``synthesize(partial=True)``'s closure of a stroke: the ellipse arc (centred at the
    ends' midpoint) from its last point back to its first, the longer-away of the two
    arcs by LInK's test, appended."""
    target = np.asarray(target, float)
    center = (target[-1] + target[0]) / 2
    sp, ep = target[-1], target[0]
    a, b = np.linalg.norm(sp - center), np.linalg.norm(ep - center)
    s_ang = np.arctan2(sp[1] - center[1], sp[0] - center[0])
    e_ang = np.arctan2(ep[1] - center[1], ep[0] - center[0])

    def arc(a0):
        t = np.linspace(a0, e_ang, n)
        return np.stack([center[0] + a * np.cos(t), center[1] + b * np.sin(t)], 1)

    e1, e2 = arc(s_ang), arc(s_ang + 2 * np.pi)
    l1 = np.linalg.norm(e1 - target.mean(0), axis=-1).sum()
    l2 = np.linalg.norm(e2 - target.mean(0), axis=-1).sum()
    return np.concatenate([target, e1 if l1 > l2 else e2], 0)


def link_frame(curve: np.ndarray):
    """The similarity by which :func:`preprocess_curves` puts ``curve`` into LInK's
    frame (centre and RMS radius of its 200-point resampling, farthest point on +x), as
    a function of points (..., 2).  LInK synthesises in this frame; a design synthesised
    in the target's own frame is carried into it by this similarity (a mechanism moved,
    turned and scaled as a whole traces the moved, turned and scaled curve)."""
    u = uniformize(np.asarray(curve, float)[None], N_CURVE)[0]
    m = u.mean(0)
    s = np.sqrt(np.square(u - m).sum(-1).sum(-1) / N_CURVE)
    c = (u - m) / s
    far = c[int(np.square(c).sum(-1).argmax())]
    th = -np.arctan2(far[1], far[0])
    cs, sn = np.cos(th), np.sin(th)

    def apply(p):
        q = (np.asarray(p, float) - m) / s
        return np.stack([cs * q[..., 0] - sn * q[..., 1], sn * q[..., 0] + cs * q[..., 1]], axis=-1)

    return apply


def link_stroke(target: np.ndarray) -> tuple[np.ndarray, object]:
    """An open target as LInK scores it: the stroke's part of the ellipse-closed curve's
    ``preprocess_curves`` (200 points) resampled to 2000 (LInK's ``target_uni``), up to
    (not including) the point nearest the stroke's last point, found as LInK finds it
    (``target_uni`` carried back onto the closed curve by ``find_transforms``); and
    :func:`link_frame` of the closed curve, the frame that part is in."""
    size = len(target)
    closed = closed_with_ellipse(target)
    copy = preprocess_curves(closed[None], N_CURVE)[0]
    target_uni = uniformize(copy[None], N_FINAL)[0]
    tr, sc, an = find_transforms(uniformize(closed[None], N_FINAL), target_uni)
    back = apply_transforms(target_uni[None], tr, sc, -an)[0]
    k = int(np.argmin(np.linalg.norm(back - closed[size - 1], axis=-1)))
    return target_uni[:k], link_frame(closed)


def link_cd(target: np.ndarray, curve: np.ndarray, closed: bool, stroke=None) -> float:
    """LInK's final chamfer distance of ``curve`` (the design's tracer in the target's
    frame: one turn of 2000 equal input steps for a closed target, its input interval
    for an open one) against ``target`` (module docstring), the curve first carried
    into LInK's frame (:func:`link_frame`).  ``stroke``: :func:`link_stroke` of the
    target, if already computed."""
    target = np.asarray(target, float)
    og_scale = float(get_scales(target[None])[0])
    if closed:
        best = uniformize(link_frame(target)(curve)[None], N_FINAL)
        copy = preprocess_curves(target[None], N_CURVE)[0]
        target_uni = uniformize(copy[None], N_FINAL)[0]
        tr, sc, an = find_transforms(best, target_uni)
        tiled = apply_transforms(target_uni[None], tr, sc, -an)
        return float(batch_chamfer_distance(best / sc[:, None, None], tiled / sc[:, None, None])[0] * og_scale)
    part, frame = link_stroke(target) if stroke is None else stroke
    best = uniformize(frame(curve)[None], N_FINAL)
    return float(batch_chamfer_distance(best, uniformize(part[None], N_FINAL))[0] * og_scale)


def get_partial_matches(curves: np.ndarray, target_curve: np.ndarray) -> np.ndarray:
    """``OptimJax.get_partial_matches``: of each closed curve, the arc between its
    points nearest the target's ends (of the two arcs, the one nearer the target by
    :func:`batch_ordered_distance`), resampled to the target's number of points."""
    n = target_curve.shape[0]
    out = []
    for c in curves:
        s = int(np.linalg.norm(target_curve[0] - c, axis=-1).argmin())
        e = int(np.linalg.norm(target_curve[-1] - c, axis=-1).argmin())
        lo, hi = min(s, e), max(s, e)
        p1 = uniformize(c[lo:hi + 1][None], n)[0]
        p2 = uniformize(np.concatenate([c[hi:], c[:lo + 1]], 0)[None], n)[0]
        parts = np.stack([p1, p2])
        f = batch_ordered_distance(parts, np.stack([target_curve, target_curve]))
        out.append(uniformize(parts[int(np.argmin(f))][None], n)[0])
    return np.array(out)


def link_solve(A: np.ndarray, x: np.ndarray, node_types: np.ndarray, thetas: np.ndarray) -> np.ndarray:
    """Positions (joints, len(thetas), 2) of a LInK mechanism (adjacency ``A``, joint
    positions ``x``, ``node_types`` 1 for a frame joint), as LInK's dyadic solver
    computes them (``solve_rev_vectorized_batch_CPU`` in LInKGenerator's
    ``LInK/Solver.py``): joint 1 turns about joint 0 at the absolute angle theta, every
    later moving joint k closes a dyad on the two earlier joints it is linked to, on
    the side it is on in ``x``.  Written here from that description, for
    :func:`check_link_results`."""
    x = np.asarray(x, float)
    n = len(x)
    fixed = np.asarray(node_types, float).reshape(-1) == 1
    P = np.repeat(x[:, None, :], len(thetas), axis=1)
    r = np.linalg.norm(x[1] - x[0])
    P[1] = x[0] + r * np.stack([np.cos(thetas), np.sin(thetas)], -1)
    for k in range(3, n):
        if fixed[k]:
            continue
        i, j = np.argsort(A[k, :k], kind="stable")[-2:]
        gik, gjk = np.linalg.norm(x[i] - x[k]), np.linalg.norm(x[j] - x[k])
        d = P[j] - P[i]
        lij = np.linalg.norm(d, axis=-1)
        cphi = (lij ** 2 + gik ** 2 - gjk ** 2) / (2 * lij * gik)
        sgn = np.sign((x[i, 1] - x[k, 1]) * (x[i, 0] - x[j, 0]) - (x[i, 1] - x[j, 1]) * (x[i, 0] - x[k, 0]))
        phi = sgn * np.arccos(cphi)
        u = d / lij[:, None] * gik
        P[k] = P[i] + np.stack([np.cos(phi) * u[:, 0] - np.sin(phi) * u[:, 1],
                                np.sin(phi) * u[:, 0] + np.cos(phi) * u[:, 1]], -1)
    return P


def link_result_cd(target: np.ndarray, mechanism) -> float:
    """LInK's final CD of one of its own results (``alpha_res.npy[i, 0]``: adjacency,
    positions, node types, …), computed by this port as ``PathSynthesis.synthesize``
    computes it (the tracer: the last joint over one turn of 2000 steps, in LInK's
    frame)."""
    A, x, nt = (np.asarray(v, float) for v in mechanism[:3])
    curve = link_solve(A, x, nt, np.linspace(0, 2 * np.pi, N_FINAL))[-1]
    target = np.asarray(target, float)
    og_scale = float(get_scales(target[None])[0])
    best = uniformize(curve[None], N_FINAL)
    if is_link_closed(target):
        target_uni = uniformize(preprocess_curves(target[None], N_CURVE), N_FINAL)[0]
        tr, sc, an = find_transforms(best, target_uni)
        tiled = apply_transforms(target_uni[None], tr, sc, -an)
    else:
        part, _ = link_stroke(target)
        closed = closed_with_ellipse(target)
        target_uni = uniformize(preprocess_curves(closed[None], N_CURVE), N_FINAL)[0]
        tr, sc, an = find_transforms(best, target_uni)
        tiled = apply_transforms(uniformize(part[None], N_FINAL), tr, sc, -an)
        best = get_partial_matches(best, tiled[0])
    return float(batch_chamfer_distance(best / sc[:, None, None], tiled / sc[:, None, None])[0] * og_scale)


def check_link_results(targets: np.ndarray, results_path: str, letters: str) -> list[dict]:
    """This port of LInK's metric on LInK's own designs against the CD LInK stored."""
    R = np.load(results_path, allow_pickle=True)
    rows = []
    for ch in letters:
        i = string.ascii_uppercase.index(ch)
        rows.append({"letter": ch, "port": link_result_cd(targets[i], R[i, 0]), "stored": float(R[i, 1][0])})
        print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
    return rows


# --- the benchmark ---------------------------------------------------------------------

def load_targets(path: str) -> np.ndarray:
    with open(path, "rb") as f:
        data = f.read()
    got = hashlib.sha256(data).hexdigest()
    if got != TARGETS_SHA256:
        raise SystemExit(f"expected {path} to be LInKGenerator's alphabet.npy (sha256 {TARGETS_SHA256}), "
                         f"got sha256 {got}; hint: download {TARGETS_URL}")
    T = np.load(path)
    assert T.shape == (26, 200, 2)
    return T


def _curve(design, point: str = "P") -> np.ndarray:
    from multiloop.kin.solve import solve

    m = design.mechanism
    lo, hi = (0.0, 2 * np.pi) if design.interval is None else (min(design.interval), max(design.interval))
    st = solve(m, np.linspace(lo, hi, N_FINAL))
    P = st.point_positions[:, st.point_index(point)]
    return P[np.all(np.isfinite(P), axis=1)]


def run_letter(ch: str, target: np.ndarray, db: str | None, evaluations: int, links=(4, 6, 8),
               top: int = 3, seed: int = 0) -> dict:
    from multiloop.catalogue.topology_synthesis import synthesise

    closed = is_link_closed(target)
    stroke = None if closed else link_stroke(target)
    t0 = time.perf_counter()
    c0 = time.process_time()
    res = synthesise(target, links=links, atlas=db, evaluations=evaluations, top=top, closed=closed, seed=seed)
    row = {"letter": ch, "mode": "closed" if closed else "open", "seconds": round(time.perf_counter() - t0, 1),
           "load_1min": round(os.getloadavg()[0], 2),
           "cpu_seconds": round(time.process_time() - c0, 1), "evaluations": res.evaluations,
           "stopped": res.stopped, "starts_screened": res.polished, "link_cd": LINK_CD[ch],
           "link_joints": LINK_JOINTS[ch], "designs": []}
    for d in res.designs:
        curve = _curve(d)
        row["designs"].append({"links": d.links, "structure": d.structure, "error_rms": d.error_rms,
                               "deviation_max": d.deviation_max, "input_range": d.input_range,
                               "cd": link_cd(target, curve, closed, stroke), "chamfer_ours": d.chamfer,
                               "fit": d.fit})
    if row["designs"]:
        best = min(row["designs"], key=lambda r: (r["cd"], r["links"]))
        row.update(cd=best["cd"], links=best["links"], structure=best["structure"])
    else:
        row.update(cd=None, links=None, structure=None)
    return row


def chart(rows: list[dict], path: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 3.6))
    x = np.arange(len(rows))
    ours = [np.nan if r["cd"] is None else r["cd"] for r in rows]
    ax.plot(x, [r["link_cd"] for r in rows], "s", color="tab:red", label="LInK (its own runs, 15-20 joints)")
    ax.plot(x, ours, "o", color="tab:blue", label="multiloop (at most 8 links)")
    ax.axhline(np.nanmean([r["link_cd"] for r in rows]), color="tab:red", ls="--", lw=1)
    ax.axhline(np.nanmean(ours), color="tab:blue", ls="--", lw=1)
    ax.set_xticks(x, [r["letter"] + ("" if r["mode"] == "closed" else "'") for r in rows])
    ax.set_yscale("log")
    ax.set_ylabel("chamfer distance (LInK's metric)")
    ax.set_xlabel("letter (' = open stroke); dashed: means")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)


def chart_links_time(rows: list[dict], path: str, budget_s: float = 60.0) -> None:
    """Error against links and against time: every returned design's chamfer distance by
    its number of links (the letter's best filled), and each letter's best by its wall
    seconds, with LInK's mean and the 60-s goal."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9, 3.6), sharey=True)
    link_mean = float(np.mean([r["link_cd"] for r in rows]))
    for i, r in enumerate(rows):
        jitter = (i / max(len(rows) - 1, 1) - 0.5) * 0.6
        for d in r["designs"]:
            best = d["cd"] == r["cd"]
            ax1.plot(d["links"] + jitter, d["cd"], "o", ms=4, color="tab:blue", mfc="tab:blue" if best else "none")
    ax1.axhline(link_mean, color="tab:red", ls="--", lw=1, label=f"LInK's mean ({link_mean:.4f}, 15-20 joints)")
    ax1.set_xticks(sorted({d["links"] for r in rows for d in r["designs"]}))
    ax1.set_xlabel("links of the design (filled: the letter's best)")
    ax1.set_ylabel("chamfer distance (LInK's metric)")
    ax1.set_yscale("log")
    ax1.legend(fontsize=7)
    ax2.plot([r["seconds"] for r in rows], [r["cd"] for r in rows], "o", color="tab:blue")
    for r in rows:
        ax2.annotate(r["letter"], (r["seconds"], r["cd"]), fontsize=6, xytext=(2, 2), textcoords="offset points")
    ax2.axhline(link_mean, color="tab:red", ls="--", lw=1)
    ax2.axvline(budget_s, color="gray", ls=":", lw=1, label=f"{budget_s:.0f} s a letter")
    ax2.set_xlabel("wall seconds of the letter")
    ax2.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=90)


def _charts(rows: list[dict], path: str) -> None:
    """:func:`chart` at ``path`` and :func:`chart_links_time` beside it (``*_links_time.png``)."""
    chart(rows, path)
    stem, dot, ext = path.rpartition(".")
    chart_links_time(rows, f"{stem}_links_time.{ext}" if dot else f"{path}_links_time")


def table(rows: list[dict]) -> str:
    lines = ["| letter | mode | ours: CD | links | wall s | CPU s | LInK: CD | LInK: joints |",
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        cd = "none" if r["cd"] is None else f"{r['cd']:.4f}"
        lines.append(f"| {r['letter']} | {r['mode']} | {cd} | {r['links'] or '-'} | {r['seconds']:.0f} | {r['cpu_seconds']:.0f} | "
                     f"{r['link_cd']:.4f} | {r['link_joints']} |")
    ours = [r["cd"] for r in rows if r["cd"] is not None]
    lines.append(f"| mean | | {np.mean(ours):.4f} ({len(ours)} letters) | | "
                 f"{np.mean([r['seconds'] for r in rows]):.0f} | {np.mean([r['cpu_seconds'] for r in rows]):.0f} | {np.mean([r['link_cd'] for r in rows]):.4f} | |")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--targets", default=None, help=f"LInKGenerator's alphabet.npy ({TARGETS_URL})")
    p.add_argument("--db", default=None, help="atlas (default: the default curve atlas)")
    p.add_argument("--evaluations", type=int, default=20000)
    p.add_argument("--letters", default=string.ascii_uppercase)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", default=None)
    p.add_argument("--chart", default=None)
    p.add_argument("--check-link", default=None, metavar="ALPHA_RES",
                   help="only score LInK's own designs (its alpha_res.npy) by this port, beside its stored CD")
    p.add_argument("--report", nargs="+", default=None, metavar="JSON",
                   help="no run: merge the rows of these --json files (e.g. letters run in two processes), "
                        "print the table, write --json and --chart (and the chart of error against links "
                        "and time beside it, *_links_time.png)")
    a = p.parse_args(argv)
    if a.report:
        docs = [json.load(open(f)) for f in a.report]
        rows = sorted({r["letter"]: r for d in docs for r in d["rows"]}.values(), key=lambda r: r["letter"])
        doc = {k: v for k, v in docs[0].items() if k != "rows"} | {"rows": rows}
        print(table(rows))
        if a.json:
            with open(a.json, "w") as f:
                json.dump(doc, f, indent=1)
        if a.chart:
            _charts(rows, a.chart)
        return 0
    if a.targets is None:
        p.error("--targets is required (LInKGenerator's alphabet.npy)")
    T = load_targets(a.targets)
    if a.check_link:
        rows = check_link_results(T, a.check_link, a.letters)
        print("| letter | LInK's CD, stored | LInK's design, this port |\n|---|---|---|")
        for r in rows:
            print(f"| {r['letter']} | {r['stored']:.5f} | {r['port']:.5f} |")
        if a.json:
            with open(a.json, "w") as f:
                json.dump(rows, f, indent=1)
        return 0
    rows = []
    for ch in a.letters:
        rows.append(run_letter(ch, T[string.ascii_uppercase.index(ch)], a.db, a.evaluations, seed=a.seed))
        print(json.dumps({k: v for k, v in rows[-1].items() if k != "designs"}), file=sys.stderr, flush=True)
        if a.json:
            with open(a.json, "w") as f:
                json.dump({"evaluations": a.evaluations, "seed": a.seed, "targets": TARGETS_URL,
                           "rows": rows}, f, indent=1)
    print(table(rows))
    if a.chart:
        _charts(rows, a.chart)
    return 0


if __name__ == "__main__":
    sys.exit(main())
