"""Open targets (issue 37): partial motions of catalogue mechanisms recovered by the
synthesis without a start.

Each target is the tracer point ``P`` of a catalogue mechanism over 120° of crank, from
40° to 160° past its reference (60 points: an open stroke), which the atlas does not
hold.  It is synthesised with ``--open`` (sub-arc retrieval, the polish over an input
interval) and, for comparison, with ``--closed`` (matched as a closed curve over whole
turns, the treatment before the open mode).  Reported: the best design's links, its
error (the synthesiser's, over the target's size), its deviation (the largest distance
of a target point from the traced curve over the design's input range), the span of
that range against the target's 120°, evaluations, stop and wall time.

    python benchmarks/bench_open_targets.py --db ATLAS.sqlite --evaluations 30000 [--arc 40 160] [--json out.json]
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from multiloop.catalogue.named import load_named
from multiloop.catalogue.topology_synthesis import synthesise
from multiloop.kin.solve import solve

TARGETS = ("four_bar", "watt_1", "stephenson_3")
ARC_DEG = (40.0, 160.0)


def stroke(name: str, n: int = 60, arc=ARC_DEG) -> np.ndarray:
    m = load_named(name)
    st = solve(m, np.radians(np.linspace(*arc, n)))
    return st.point_positions[:, st.point_index("P")]


def run(name: str, db: str, evaluations: int, closed: bool, links, arc=ARC_DEG) -> dict:
    target = stroke(name, arc=arc)
    t0 = time.perf_counter()
    r = synthesise(target, links=links, atlas=db, evaluations=evaluations, top=1, closed=closed)
    row = {"target": name, "arc_deg": list(arc), "mode": "closed" if closed else "open",
           "seconds": round(time.perf_counter() - t0, 1),
           "evaluations": r.evaluations, "stopped": r.stopped, "polished": r.polished}
    if r.designs:
        d = r.designs[0]
        span = None if d.input_range is None else d.input_range[1] - d.input_range[0]
        row.update(links=d.links, error_max=d.error_max, deviation_max=d.deviation_max, range_span_deg=span)
    return row


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--db", required=True)
    p.add_argument("--evaluations", type=int, default=30000)
    p.add_argument("--links", default="4,6,8")
    p.add_argument("--targets", nargs="+", default=list(TARGETS))
    p.add_argument("--modes", nargs="+", default=["open", "closed"])
    p.add_argument("--arc", type=float, nargs=2, default=list(ARC_DEG), metavar=("FROM", "TO"),
                   help="the crank's part, degrees past the reference (default 40 160)")
    p.add_argument("--json", default=None)
    a = p.parse_args()
    links = tuple(int(v) for v in a.links.split(","))
    rows = []
    for name in a.targets:
        for mode in a.modes:
            rows.append(run(name, a.db, a.evaluations, mode == "closed", links, tuple(a.arc)))
            print(json.dumps(rows[-1]), flush=True)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
