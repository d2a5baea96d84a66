"""Benchmark of path synthesis without a start (``multiloop synthesise --path T.csv``):
the curve index, targets no four-bar traces, and LInK's capital letters (plain script).

Run (after building an atlas with curves, e.g.
``multiloop atlas --links 4 --dof 1 --mechanisms --curves 64 --db A``,
``--links 6 … --curves 24``, ``--links 8 --simple-joints … --curves 4``)::

    python benchmarks/bench_topology_synthesis.py --db A [--index] [--exact 3] [--letters ABC…]
        [--budget 30] [--json out.json] [--chart docs/figures/synthesis_letters.png]

* ``--index``: query time and recall@10 of usearch's HNSW graph against the exact scan
  (queries: 200 stored curves, each moved, turned, scaled and started elsewhere).
* ``--scale N``: the same at N descriptors (the stored ones repeated with 2 % noise).
* ``--exact N``: N fresh realisations (seeds outside the atlas's) of six- and eight-link
  mechanisms, traced at a point of a link outside every four-bar loop of the chain;
  synthesised with ``links=(4,)`` and with ``links=(4, 6, 8)``; the error is the
  synthesiser's (max distance to the polished target points over the target size), the
  deviation the largest distance of any target point from the traced curve; recovered:
  deviation at most 1e-3.
* ``--letters``: capital letters (DejaVu Sans outlines from matplotlib's ``TextPath``,
  the outer contour; closed) scored with LInK's chamfer distance
  (:func:`catalogue.curves.chamfer_score`); the best design per number of links.

Time per target is wall time on this machine (2 cores shared; one process).
"""
from __future__ import annotations

import argparse
import json
import string
import sys
import time

import numpy as np

from multiloop.catalogue.atlas import Atlas
from multiloop.catalogue.curve_atlas import CurveIndex, stored_curve
from multiloop.catalogue.curves import CURVE_POINTS, descriptor
from multiloop.catalogue.topology_synthesis import synthesise


def index_benchmark(db: str, queries: int = 200, k: int = 10) -> dict:
    rng = np.random.default_rng(0)
    with Atlas(db, readonly=True) as atlas:
        t = time.perf_counter()
        hnsw = CurveIndex(atlas)
        build = time.perf_counter() - t
        exact = CurveIndex(atlas, exact=True)
        ds = []
        for cid in rng.choice(hnsw.ids, min(queries, len(hnsw)), replace=False):
            c = stored_curve(atlas, int(cid))
            z = np.roll(c["shape"] * 3 * np.exp(1j * rng.uniform(0, 6.3)) + 2 - 1j, int(rng.integers(CURVE_POINTS)))
            ds.append(descriptor(np.stack([z.real, z.imag], 1), closed=True))
    out = {"curves": len(hnsw), "index": hnsw.kind, "open_s": build}   # (a stored graph is loaded, not built)
    for name, ix in (("hnsw", hnsw), ("exact", exact)):
        t = time.perf_counter()
        res = [ix.query(d, k) for d in ds]
        out[f"{name}_query_ms"] = 1000 * (time.perf_counter() - t) / len(ds)
        out[f"{name}_ids"] = [[h.curve for h in r] for r in res]
    out["recall_at_10"] = float(np.mean([len(set(a) & set(b)) / len(b) for a, b in
                                         zip(out.pop("hnsw_ids"), out.pop("exact_ids"))]))
    return out


def scale_benchmark(db: str, size: int, queries: int = 200, k: int = 10) -> dict:
    """Index build and query time, recall@10 at ``size`` descriptors: the stored ones
    repeated with 2 % Gaussian noise (a stand-in for a larger atlas; same distribution
    of shapes), usearch HNSW against the exact NumPy scan."""
    from usearch.index import Index

    with Atlas(db, readonly=True) as atlas:
        base = CurveIndex(atlas, exact=True).vectors
    rng = np.random.default_rng(1)
    reps = int(np.ceil(size / len(base)))
    V = np.repeat(base, reps, axis=0)[:size]
    V = (V * (1 + 0.02 * rng.standard_normal(V.shape))).astype(np.float32)
    Q = (V[rng.choice(size, queries)] * (1 + 0.01 * rng.standard_normal((queries, V.shape[1])))).astype(np.float32)
    t = time.perf_counter()
    ix = Index(ndim=V.shape[1], metric="l2sq", dtype="f32", connectivity=32, expansion_add=128, expansion_search=256)
    ix.add(np.arange(size, dtype=np.uint64), V)
    build = time.perf_counter() - t
    t = time.perf_counter()
    got = [set(np.asarray(ix.search(q, k).keys).tolist()) for q in Q]
    hnsw_ms = 1000 * (time.perf_counter() - t) / queries
    t = time.perf_counter()
    exact = [set(np.argpartition(np.sum((V - q) ** 2, axis=1), k)[:k].tolist()) for q in Q]
    exact_ms = 1000 * (time.perf_counter() - t) / queries
    recall = float(np.mean([len(a & b) / k for a, b in zip(got, exact)]))
    return {"vectors": size, "build_s": build, "hnsw_query_ms": hnsw_ms, "exact_query_ms": exact_ms,
            "recall_at_10": recall}


def _beyond_four_bar(m) -> list[str]:
    """Links of the groups that no four-bar loop with the frame carries: a triad or
    class IV group, or a group with an outer joint whose point moves with floating
    links only (none hinged to the frame; a multiple joint shared with a crank is not)."""
    from multiloop.topo.assur import GroupKind, decompose

    on_frame = {x for j in m.joints if m.frame in j.links for x in j.links}
    out = []
    for g in decompose(m).groups:
        carriers = [set(m.joint(j).links) - set(g.links) for j in g.outer_joints]
        floating = [c for c in carriers if c and not c & on_frame]
        if g.kind in (GroupKind.TRIAD, GroupKind.CLASS_IV) or floating:
            out += [x for x in g.links if x not in on_frame]
    return out


def _fresh_target(atlas_path: str, n: int, seed: int):
    """A realisation not in the atlas (seeds from 10⁹), traced at a point of a link
    beyond every four-bar loop (:func:`_beyond_four_bar`)."""
    from multiloop.catalogue.inversions import iter_mechanisms
    from multiloop.catalogue.realisations import TURN_SAMPLES, realise
    from multiloop.catalogue.synthesis import SynthesisOptions
    from multiloop.kin.solve import solve

    with Atlas(atlas_path, readonly=True) as atlas:
        invs = [r for r in iter_mechanisms(atlas, SynthesisOptions(n, 1)) if r.closed_form]
    rng = np.random.default_rng(seed)
    for _ in range(200):
        inv = invs[int(rng.integers(len(invs)))]
        seed += 1
        r = realise(inv, 10 ** 9 + seed, tries=100)
        far = [] if r is None else _beyond_four_bar(r.mechanism)
        if not far:
            continue
        st = solve(r.mechanism, np.linspace(0, 2 * np.pi, TURN_SAMPLES)[:-1])
        p, _, _ = st.point_on_link(far[-1], tuple(rng.uniform(-1, 1, 2)))
        return f"{inv.formula}, link {far[-1]}", p
    raise RuntimeError("no realisation found")


def exact_benchmark(db: str, count: int, budget: float, four_bar: bool = True) -> list[dict]:
    """Per target: the best design of ``links=(4, 6, 8)`` (and of the four-bar alone),
    its error at the polished points, its deviation (every target point to the traced
    curve, over the target's size), links, structure and wall time; a target counts as
    recovered when the deviation is at most 1e-3."""
    rows = []
    for i in range(count):
        for n in (6, 8):
            try:
                formula, target = _fresh_target(db, n, 1000 * i + n)
            except (RuntimeError, ValueError):
                continue
            row = {"n": n, "formula": formula}
            for label, links in ((("four_bar", (4,)),) if four_bar else ()) + (("atlas", (4, 6, 8)),):
                t = time.perf_counter()
                res = synthesise(target, links=links, atlas=db, budget=budget, top=3)
                best = res.designs[0] if res.designs else None
                row[label] = None if best is None else {"error_max": best.error_max, "links": best.links,
                                                        "deviation_max": best.deviation_max,
                                                        "structure": best.structure}
                row[f"{label}_s"] = time.perf_counter() - t
            row["recovered"] = bool(row["atlas"] and row["atlas"]["deviation_max"] <= 1e-3)
            rows.append(row)
            print(json.dumps(row), file=sys.stderr)
    done = sum(r["recovered"] for r in rows)
    print(f"recovered to 1e-3 of the target size: {done} of {len(rows)}; "
          f"mean time per target {np.mean([r['atlas_s'] for r in rows]):.1f} s", file=sys.stderr)
    return rows


def letter(ch: str) -> np.ndarray:
    """The outer contour of a DejaVu Sans capital (matplotlib ``TextPath``), closed."""
    from matplotlib.font_manager import FontProperties
    from matplotlib.textpath import TextPath

    polys = TextPath((0, 0), ch, size=1.0, prop=FontProperties(family="DejaVu Sans")).to_polygons()

    def area(p):
        return 0.5 * abs(np.dot(p[:-1, 0], p[1:, 1]) - np.dot(p[1:, 0], p[:-1, 1]))

    P = max(polys, key=area)
    P = P[:-1] if np.allclose(P[0], P[-1]) else P
    from multiloop.catalogue.curves import resample

    return resample(P, 200, closed=True)


def letters_benchmark(db: str, letters: str, budget: float, links=(4, 6, 8)) -> list[dict]:
    """Each letter synthesised once with ``links``; the best design per number of links."""
    rows = []
    for ch in letters:
        T = letter(ch)
        t = time.perf_counter()
        res = synthesise(T, links=links, atlas=db, budget=budget, top=12, topologies=2)
        row = {"letter": ch, "seconds": time.perf_counter() - t, "best": {}}
        for d in res.designs:
            key = str(d.links)
            if key not in row["best"] or d.chamfer < row["best"][key]["chamfer"]:
                row["best"][key] = {"chamfer": d.chamfer, "error_rms": d.error_rms, "structure": d.structure}
        rows.append(row)
        print(json.dumps(row), file=sys.stderr)
    return rows


def letters_chart(rows: list[dict], path: str, link_counts=(4, 6, 8)) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    best = [min((r["best"][str(n)]["chamfer"] for n in link_counts if str(n) in r["best"]), default=np.nan)
            for r in rows]
    for n, mk in zip(link_counts, "os^"):
        ys = [r["best"].get(str(n), {}).get("chamfer", np.nan) for r in rows]
        ax.plot(range(len(rows)), ys, mk, label=f"best {n}-link design")
    ax.plot(range(len(rows)), best, "k-", lw=1, label="best over links")
    ax.axhline(0.025, color="r", ls="--", label="LInK's average (15-20 joints)")
    ax.set_xticks(range(len(rows)), [r["letter"] for r in rows])
    ax.set_yscale("log")
    ax.set_ylabel("chamfer distance (LInK's metric)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--db", required=True)
    p.add_argument("--index", action="store_true")
    p.add_argument("--exact", type=int, default=0)
    p.add_argument("--no-four-bar", action="store_true", help="--exact without the four-bar-only runs")
    p.add_argument("--scale", type=int, default=0, help="index measurement at this many descriptors")
    p.add_argument("--letters", default="")
    p.add_argument("--budget", type=float, default=30.0)
    p.add_argument("--json", default=None)
    p.add_argument("--chart", default=None)
    args = p.parse_args(argv)
    doc = {}
    if args.index:
        doc["index"] = index_benchmark(args.db)
        print(json.dumps(doc["index"]))
    if args.scale:
        doc["scale"] = scale_benchmark(args.db, args.scale)
        print(json.dumps(doc["scale"]))
    if args.exact:
        doc["exact"] = exact_benchmark(args.db, args.exact, args.budget, four_bar=not args.no_four_bar)
    letters = string.ascii_uppercase if args.letters == "all" else args.letters
    if letters:
        doc["letters"] = letters_benchmark(args.db, letters, args.budget)
        if args.chart:
            letters_chart(doc["letters"], args.chart)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(doc, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
