"""Topology synthesis on targets no sampler of ours drew: closed coupler curves of six-
and eight-bars dimensioned by an independent sampler (plain script).

Run:  python benchmarks/bench_unseen_targets.py [--count 20] [--evaluations 40000]
      [--db ATLAS] [--json out.json]
      python benchmarks/bench_unseen_targets.py --coverage 20   (no synthesis)

The atlas's realisations (``catalogue.realisations.realise``) draw link proportions
from their own distribution, so targets traced by them (``bench_topology_synthesis.py
--exact``) favour the atlas.  Here each target comes from a topology that the atlas
also holds, dimensioned another way: every joint, frame pivots included, drawn
uniformly in the unit square (link ratios of 10:1 and more occur), kept when the crank
turns fully and the traced curve spans at least 0.05; the tracer is a point drawn in
the same square on a link beyond every four-bar loop (a floating link of the second
group, or the triad's ternary link).  Topologies: Watt I/II and Stephenson I/II
six-bars (two RRR dyads after the crank, the catalogue's joint names), the Stephenson
III triad six-bar, and an eight-bar with a triple pin (the topology of an atlas
realisation with a multiple joint, its dimensions redrawn).

Each target is synthesised with ``links=(4, 6, 8)`` on the default atlas (or
``--db``) and with ``links=(4,)`` (the best four-bar), under the same evaluation
budget (reproducible, whatever the machine's load).  Reported per target: the best
design's error (max distance of the polished target points, over the target's size)
and deviation (every target point to the design's traced curve), its links, and the
CPU seconds.  The summary: median and mean deviation, how many within 1e-3 and 1e-2,
and how many beat the best four-bar.  ``--coverage N`` measures instead how far fresh
targets lie from the stored curves (the nearest descriptor, exact scan), unseen ones
against the atlas's own sampler's, and the index's recall@10 on them.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from multiloop.catalogue.named import load_named
from multiloop.catalogue.topology_synthesis import synthesise
from multiloop.kin.solve import solve
from multiloop.topo.errors import LinkageError
from multiloop.topo.model import TracerPoint

SIX_BARS = ("watt_1", "watt_2", "stephenson_1", "stephenson_2", "stephenson_3_triad")
TURN = np.linspace(0.0, 2.0 * np.pi, 361)[:-1]


def _eight_bar_with_triple_pin():
    """The topology of an eight-link mechanism with a multiple joint, all its groups
    dyads (an atlas of the 8-link chains with multiple joints, built into a temporary
    file in about a second), realised once for a reference to redraw."""
    import subprocess
    import tempfile
    from multiloop.catalogue.atlas import Atlas
    from multiloop.catalogue.inversions import iter_mechanisms
    from multiloop.catalogue.realisations import realise
    from multiloop.catalogue.synthesis import SynthesisOptions
    from multiloop.topo.assur import GroupKind, decompose

    with tempfile.TemporaryDirectory() as tmp:
        db = str(Path(tmp) / "eight.sqlite")
        subprocess.run([sys.executable, "-m", "multiloop", "atlas", "--links", "8", "--dof", "1", "--mechanisms",
                        "--db", db], check=True, capture_output=True)
        with Atlas(db, readonly=True) as atlas:
            invs = [r for r in iter_mechanisms(atlas, SynthesisOptions(8, 1)) if r.closed_form]
    for k, inv in enumerate(invs):
        r = realise(inv, 7 * 10 ** 8 + k, tries=100)
        if r is None or not any(len(j.links) > 2 for j in r.mechanism.joints):
            continue
        if all(g.kind is GroupKind.RRR for g in decompose(r.mechanism).groups):
            return replace(r.mechanism, name="eight-bar, triple pin")
    raise RuntimeError("no eight-link mechanism with a multiple joint")


def _far_links(m) -> list[str]:
    """Links of the groups that no four-bar loop with the frame carries; for a Watt II
    (two four-bars in series, every link in one) the last group's coupler."""
    from multiloop.topo.assur import decompose
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from bench_topology_synthesis import _beyond_four_bar
    far = _beyond_four_bar(m)
    if far:
        return far
    on_frame = {x for j in m.joints if m.frame in j.links for x in j.links}
    return [x for x in decompose(m).groups[-1].links if x not in on_frame]


def _redrawn(m, rng):
    """``m`` with every joint drawn uniformly in the unit square."""
    joints = tuple(replace(j, at=tuple(rng.uniform(-0.5, 0.5, 2))) for j in m.joints)
    return replace(m, joints=joints, points=())


def unseen_target(base, rng, tries: int = 20_000):
    """(mechanism, its traced curve (360, 2)) of ``base`` redrawn until the crank turns
    fully and the curve spans at least 0.05."""
    far = _far_links(base)
    for _ in range(tries):
        m = _redrawn(base, rng)
        link = far[int(rng.integers(len(far)))]
        m = replace(m, points=(TracerPoint("P", link, tuple(rng.uniform(-0.5, 0.5, 2))),))
        try:
            st = solve(m, TURN)
        except (LinkageError, ValueError):
            continue
        if not np.all(st.status == "ok"):
            continue
        c = st.point_positions[:, 0]
        if np.ptp(c, axis=0).max() >= 0.05:
            return m, c
    raise RuntimeError(f"no full-turning redraw of {base.name} in {tries} tries")


def run(count: int, evaluations: int, db: str | None, seed: int = 0) -> list[dict]:
    rng = np.random.default_rng(seed)
    bases = [load_named(n) for n in SIX_BARS] + [_eight_bar_with_triple_pin()]
    rows = []
    for i in range(count):
        base = bases[i % len(bases)]
        m, curve = unseen_target(base, rng)
        target = curve[::12]                                  # 30 points, in order
        row = {"target": i, "topology": base.name, "links": base.n_links}
        for label, links in (("atlas", (4, 6, 8)), ("four_bar", (4,))):
            t = time.process_time()
            res = synthesise(target, links=links, atlas=db, evaluations=evaluations, top=1)
            best = res.designs[0] if res.designs else None
            row[label] = None if best is None else {"error_max": best.error_max, "deviation_max": best.deviation_max,
                                                    "links": best.links, "structure": best.structure}
            row[f"{label}_cpu_s"] = time.process_time() - t
        rows.append(row)
        print(json.dumps(row), file=sys.stderr, flush=True)
    return rows


def summary(rows: list[dict]) -> str:
    dev = np.array([r["atlas"]["deviation_max"] if r["atlas"] else np.inf for r in rows])
    four = np.array([r["four_bar"]["deviation_max"] if r["four_bar"] else np.inf for r in rows])
    return (f"{len(rows)} unseen targets: deviation median {np.median(dev):.3g}, mean {np.mean(dev):.3g}; "
            f"within 1e-3: {int(np.sum(dev <= 1e-3))}, within 1e-2: {int(np.sum(dev <= 1e-2))}; "
            f"better than the best four-bar: {int(np.sum(dev < four))} (four-bar median {np.median(four):.3g}); "
            f"CPU per target {np.mean([r['atlas_cpu_s'] for r in rows]):.1f} s")


def coverage(count: int, db: str | None, seed: int = 0) -> dict:
    """The curve space's coverage: the descriptor distance (exact scan) from each fresh
    target to its nearest stored curve, for ``count`` targets of the unseen sampler and
    ``count`` of the atlas's own sampler (fresh seeds), and the recall@10 of the index
    the synthesiser uses against the exact scan on the same queries."""
    from multiloop.catalogue.atlas import Atlas
    from multiloop.catalogue.curve_atlas import CurveIndex
    from multiloop.catalogue.curves import descriptor
    from multiloop.catalogue.default_atlas import default_atlas_path
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from bench_topology_synthesis import _fresh_target

    path = str(db or default_atlas_path())
    rng = np.random.default_rng(seed)
    bases = [load_named(n) for n in SIX_BARS] + [_eight_bar_with_triple_pin()]
    unseen = [unseen_target(bases[i % len(bases)], rng)[1] for i in range(count)]
    own = [_fresh_target(path, 6 if i % 2 == 0 else 8, 10 ** 6 + 1000 * i)[1] for i in range(count)]
    out = {}
    with Atlas(path, readonly=True) as atlas:
        exact, index = CurveIndex(atlas, exact=True), CurveIndex(atlas)
        for label, curves in (("unseen", unseen), ("own sampler", own)):
            ds = [descriptor(c, closed=True) for c in curves]
            near = [exact.query(d, 10) for d in ds]
            got = [index.query(d, 10) for d in ds]
            out[label] = {"nearest": [h[0].distance for h in near],
                          "recall_at_10": float(np.mean([len({x.curve for x in a} & {x.curve for x in b}) / 10
                                                         for a, b in zip(near, got)]))}
        out["curves"], out["index"] = len(exact), index.kind
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=20)
    ap.add_argument("--evaluations", type=int, default=40_000)
    ap.add_argument("--db", default=None, help="the atlas with curves (default: the default atlas)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", default=None)
    ap.add_argument("--coverage", type=int, default=0,
                    help="only the coverage: this many targets of each sampler, no synthesis")
    a = ap.parse_args(argv)
    t = time.time()
    if a.coverage:
        cov = coverage(a.coverage, a.db, a.seed)
        for label in ("unseen", "own sampler"):
            d = np.array(cov[label]["nearest"])
            print(f"{label}: nearest stored curve (descriptor distance, exact scan over {cov['curves']:,} curves) "
                  f"median {np.median(d):.3g}, max {d.max():.3g}; {cov['index']} recall@10 "
                  f"{cov[label]['recall_at_10']:.2f}")
        if a.json:
            with open(a.json, "w") as f:
                json.dump(cov, f, indent=1)
        return 0
    rows = run(a.count, a.evaluations, a.db, a.seed)
    line = summary(rows)
    print(line)
    print(f"(wall {time.time() - t:.0f} s)")
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"rows": rows, "summary": line}, f, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
