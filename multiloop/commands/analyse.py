"""``multiloop analyse FILE [--json]``: the structural report of Pozhbelko & Kuts 2020."""
from __future__ import annotations

import sys
import time

from multiloop.inputs import load_mechanism as load  # files, .pyslvs or catalogue names
from multiloop.topo.numbers import structural_report
from multiloop.outputs import emit


def add_arguments(p) -> None:
    p.add_argument("file", help="mechanism or chain (.toml or .json)")
    p.add_argument("--json", action="store_true", help="print the stable JSON report")
    p.add_argument("--drivers", type=int, default=None, metavar="N",
                   help="number of drivers N for rc (default: the drivers in the file)")
    p.add_argument("--lambda", dest="lam", type=int, default=3, choices=(2, 3, 4, 5, 6),
                   help="freedoms of the space for the Dobrovolsky/Malyshev count "
                        "(3 planar; 6 gives the designer's redundant constraints)")
    p.add_argument("--no-geometry", action="store_true",
                   help="skip the rank check of the constraint Jacobian")
    p.add_argument("--no-loops", action="store_true",
                   help="skip the loop assortment [La] (its embedding search grows with the "
                        "2-vertex cuts of the chain; everything else stays polynomial)")


#: chains above this many links get progress lines on stderr
PROGRESS_LINKS = 30


def run(args) -> int:
    m = load(args.file)
    loops = not args.no_loops
    progress = m.n_links > PROGRESS_LINKS
    if progress:
        print(f"analyse: {m.n_links} links, {m.n_joints} joints: structural numbers, canonical "
              f"form, degeneracy" + (", loop assortment [La] (--no-loops skips it)" if loops else ""),
              file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    r = structural_report(m, n_drivers=args.drivers, lam=args.lam, geometry=not args.no_geometry,
                          loops=loops)
    if progress:
        print(f"analyse: done in {time.perf_counter() - t0:.2f} s", file=sys.stderr, flush=True)
    emit(r, args.json)
    return 0
