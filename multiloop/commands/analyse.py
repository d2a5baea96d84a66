"""``multiloop analyse FILE [--json]``: the structural report of Pozhbelko & Kuts 2020."""
from __future__ import annotations

import json
import sys
import time

from multiloop.inputs import load_mechanism as load  # files, .pyslvs or catalogue names
from multiloop.topo.numbers import structural_report


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


def _row(label: str, value) -> tuple[str, str]:
    return label, str(value)


def format_report(r) -> str:
    """A readable table in the order of Pozhbelko & Kuts 2020's bullet list."""
    la = "-".join(map(str, r.La)) if r.La is not None else "— (non-planar)"
    rows = [
        ("name", r.name or "(unnamed)"),
        ("links n", r.n),
        ("joints / pairs p", f"{r.n_joints} / {r.p}"),
        ("link assortment [LA]", "[" + " ".join(f"n{i + 2}={c}" for i, c in enumerate(r.LA) if c) + "]"),
        ("multiple-joint assortment [MJA]", "[" + (" ".join(f"V{j + 2}={c}" for j, c in enumerate(r.MJA) if c) or "none") + "]"),
        ("MJ factor V", r.V),
        ("loops K (graph / formula)", f"{r.K} / {r.K_formula:g}"),
        ("all loops L = K + 1", r.L),
        ("AVC", f"{r.AVC:g}" + ("  (assembly check passed)" if r.AVC == 0 else "  (INCONSISTENT data)")),
        ("mobility F (3 routes)", " = ".join(f"{x:g}" for x in r.F_routes)),
        ("drivers N", r.N),
        ("redundant constraints rc = N - F", r.rc),
        ("sides of all loops SL (2 routes)", f"{r.SL} / {r.SL_formula}"),
        ("loop assortment [La]", la + (f"  (L0 = {r.L0})" if r.L0 is not None else "")),
        ("code", r.code),
        ("code*", r.code_star),
        ("planar", "yes" if r.planar else "no"),
        ("degenerate", ("yes: rigid sub-chain {" + ", ".join(r.rigid_subchain) + "}") if r.degenerate else "no"),
        ("fractionated", ("yes: " + ", ".join([f"cut link {x}" for x in r.cut_links] + [f"cut joint {x}" for x in r.cut_joints])) if r.fractionated else "no"),
        ("existence domain (j <= K, V <= 2(K-1))", ("ok" if r.existence_ok else "VIOLATED") + f"  (j_max = {r.j_max}, V = {r.V}, K = {r.K})"),
        (f"mobility in λ = {r.lam} space / redundant", f"{r.F_space} / {r.rc_space}"),
    ]
    if r.actual_F is not None:
        rows.append(("actual mobility (Jacobian rank)", str(r.actual_F) + (f"; redundant: {', '.join(r.redundant)}" if r.redundant else "")))
    rows.append(("canonical form", r.canonical if len(r.canonical) <= 60 else r.canonical[:57] + "..."))
    width = max(len(k) for k, _ in rows)
    lines = [f"  {k:<{width}}  {v}" for k, v in rows]
    lines.append(f"  [La] rule: {r.la_rule}")
    for w in r.warnings:
        lines.append(f"  warning: {w}")
    return "\n".join(lines)


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
    if args.json:
        print(json.dumps(r.as_dict(), indent=2))
    else:
        print(format_report(r))
    return 0
