"""Benchmark: `analyse` (all structural numbers incl. canonical form and [La]) per chain.

Run: python benchmarks/bench_analyse.py [--chains 1000]

Times the full structural report on the 24-link, 11-loop chain of Pozhbelko & Kuts 2020 (fig. 9
remark; from the catalogue when present) and on random 12-link 1-DOF chains with and
without multiple joints, with a per-part breakdown (canonical form, [La], degeneracy)
and the VF2 pairwise alternative for isomorphism, and prints µs per chain.
"""
from __future__ import annotations

import argparse
import random
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from multiloop.topo.degeneracy import find_rigid_subchain  # noqa: E402
from multiloop.topo.isomorphism import are_isomorphic_vf2, canonical_form  # noqa: E402
from multiloop.topo.loops import loop_assortment  # noqa: E402
from multiloop.topo.model import chain_from_joint_lists  # noqa: E402
from multiloop.topo.numbers import structural_report  # noqa: E402


def random_one_dof_chain(rng: random.Random, n: int, multiple: bool):
    """A random connected 12-link chain with F = 1 (p = (3n − 4)/2), every link on
    >= 2 joints; with ``multiple`` some pins join three links (each counts 2 pairs)."""
    target_p = (3 * (n - 1) - 1) // 2
    while True:
        names = [f"l{i}" for i in range(n)]
        rng.shuffle(names)
        joints = [[names[i], names[(i + 1) % n]] for i in range(n)]
        p = n
        while p < target_p:
            if multiple and target_p - p >= 2 and rng.random() < 0.3:
                joints.append(rng.sample(names, 3))
                p += 2
            else:
                joints.append(rng.sample(names, 2))
                p += 1
        m = chain_from_joint_lists(joints)
        if find_rigid_subchain(m) is None:
            return m


def timed(fn, items, repeat=1):
    t = time.perf_counter()
    for _ in range(repeat):
        for x in items:
            fn(x)
    return (time.perf_counter() - t) / (len(items) * repeat)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--chains", type=int, default=1000)
    args = ap.parse_args()
    rng = random.Random(1)
    sets = {
        "12-link SJ F=1": [random_one_dof_chain(rng, 12, False) for _ in range(args.chains)],
        "12-link MJ F=1": [random_one_dof_chain(rng, 12, True) for _ in range(args.chains)],
    }
    try:
        from multiloop.catalogue.named import load_named
        sets["24-link (Pozhbelko & Kuts 2020 fig. 9)"] = [load_named("linkage_24")]
    except Exception as exc:  # noqa: BLE001
        print(f"(24-link catalogue chain unavailable: {exc})")
    print(f"{'chains':28s} {'report':>10s} {'canonical':>10s} {'[La]':>10s} {'degenerate':>10s}   (µs per chain)")
    for label, chains in sets.items():
        rep = 1 if len(chains) > 1 else 5
        t_all = timed(structural_report, chains, rep)
        t_can = timed(canonical_form, chains, rep)
        t_la = timed(loop_assortment, chains, rep)
        t_deg = timed(find_rigid_subchain, chains, rep)
        print(f"{label:28s} {t_all * 1e6:10.0f} {t_can * 1e6:10.0f} {t_la * 1e6:10.0f} {t_deg * 1e6:10.0f}")
    # isomorphism: canonical forms (one per chain, then hashing) vs pairwise VF2
    chains = sets["12-link SJ F=1"][:200]
    t = time.perf_counter()
    classes = {canonical_form(m) for m in chains}
    t_canon = time.perf_counter() - t
    t = time.perf_counter()
    reps: list = []
    for m in chains:
        if not any(are_isomorphic_vf2(m, r) for r in reps):
            reps.append(m)
    t_vf2 = time.perf_counter() - t
    assert len(reps) == len(classes)
    print(f"dedupe 200 chains: canonical {t_canon * 1e3:.1f} ms, pairwise VF2 {t_vf2 * 1e3:.1f} ms, "
          f"ratio VF2/canonical = {t_vf2 / t_canon:.1f}  ({len(classes)} classes)")


if __name__ == "__main__":
    main()
