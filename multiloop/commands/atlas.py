"""``multiloop atlas``: number and type synthesis, SQLite atlas, queries, HTML gallery.

Examples::

    multiloop atlas --links 10 --dof 1 --simple-joints          # 230 chains
    multiloop atlas --links 10 --dof 1 --table                  # universal structural table
    multiloop atlas --links 12 --dof 1 --db atlas.sqlite --workers 2 --no-loops
    multiloop atlas --db atlas.sqlite --query "V=2 AND K=4" --json
    multiloop atlas --links 8 --dof 1 --html gallery/
    multiloop atlas --links 12 --dof 1 --scheduler tcp://127.0.0.1:8786
    multiloop atlas --links 14 --dof 1 --table --no-loops       # counted by row, not stored
    multiloop atlas --links 14 --dof 1 --table --la 6-6-2 --mja 2    # one row recounted
"""
from __future__ import annotations

import sys
from pathlib import Path

from multiloop.outputs import Outputs, dumps_json, quiet_warnings


def add_arguments(p) -> None:
    p.add_argument("--links", "-n", type=int, help="number of links n")
    p.add_argument("--dof", "-F", type=int, default=1, help="degrees of freedom F (default 1)")
    p.add_argument("--db", default="atlas.sqlite", help="SQLite atlas file (default atlas.sqlite)")
    p.add_argument("--table", action="store_true",
                   help="number synthesis: every ([LA], [MJA]) with the number of chains realising it")
    p.add_argument("--json", action="store_true", help="JSON on stdout (count, chains / table)")
    p.add_argument("--query", help="filter, e.g. \"V=2 AND K=4\" (columns: n F p K V n_joints j_max "
                                   "i_max planar fractionated L0 LA MJA La code code_star)")
    p.add_argument("--simple-joints", action="store_true", help="simple joints only")
    p.add_argument("--no-fractionated", action="store_true", help="drop fractionated chains")
    p.add_argument("--planar", action="store_true", help="planar chains only")
    p.add_argument("--max-multiplicity", type=int, metavar="J", help="largest joint multiplicity j")
    p.add_argument("--max-link-degree", type=int, metavar="I", help="largest number of joints on a link")
    p.add_argument("--la", metavar="N2-N3-...", help="only chains of this link assortment [LA] (restricts the enumeration)")
    p.add_argument("--mja", metavar="V2-V3-...", help="only chains of this multiple-joint assortment [MJA] (0: simple joints)")
    p.add_argument("--workers", type=int, help="local processes (default: all cores)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler address (tcp://host:8786)")
    loops = p.add_mutually_exclusive_group()
    loops.add_argument("--loops", dest="loops", action="store_true", default=None,
                       help="compute loop assortments [La] (default for n <= 10)")
    loops.add_argument("--no-loops", dest="loops", action="store_false",
                       help="skip [La] (planarity is still stored)")
    p.add_argument("--mechanisms", action="store_true",
                   help="also count the distinct frames and (frame, driver) choices; with --dof 1, "
                        "store every inversion with its Assur structure (resumable)")
    p.add_argument("--curves", type=int, metavar="K",
                   help="with --mechanisms: K certified realisations of every closed-form mechanism and their "
                        "coupler curves with descriptors (resumable)")
    p.add_argument("--points-per-link", type=int, metavar="P",
                   help="with --curves: P traced points on each moving link but the driven one (default 2)")
    p.add_argument("--limit", type=int, help="list at most this many chains")
    p.add_argument("--html", metavar="DIR", help="write the HTML gallery to DIR")
    p.add_argument("--html-limit", type=int, default=2000, help="chains per gallery page (default 2000)")
    p.add_argument("--charts", metavar="DIR", help="write the existence-domain and invariant charts (PNG)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


def run(args) -> int:
    from multiloop.catalogue.atlas import Atlas
    from multiloop.catalogue.atlas_build import atlas_request, build_atlas, counts_only
    from multiloop.catalogue.listing import atlas_listing, listing_text

    opts = atlas_request(vars(args))
    outs = Outputs("multiloop atlas")
    for d in (args.html, args.charts):
        if d is not None:
            outs.directory(d, "--html" if d is args.html else "--charts")
    with Atlas(args.db) as atlas:
        built, inv, curves = build_atlas(atlas, opts, loops=args.loops, workers=args.workers,
                                         scheduler=args.scheduler, progress=not args.no_progress,
                                         mechanisms=args.mechanisms and args.query is None, curves=args.curves,
                                         table=args.table, points_per_link=args.points_per_link)
        if curves is not None:
            print(curves.to_text(), file=sys.stderr)
        doc = atlas_listing(atlas, opts, args.query, args.limit, args.table, args.mechanisms, built, inv,
                            counted=counts_only(opts, args.table))
        print(dumps_json(doc) if args.json else listing_text(doc, opts, args.query, args.limit))
        if args.html is not None:
            from multiloop.catalogue.html import gallery_files

            pairs = [(opts.n, opts.F)] if opts is not None else None
            outs.add_files(args.html, gallery_files(atlas, pairs, args.query, args.html_limit), "--html")
        if args.charts is not None:
            from multiloop.kin.figures.chains import atlas_chart_files
            with quiet_warnings("multiloop atlas"):
                outs.add_files(args.charts, atlas_chart_files(atlas), "--charts")
        outs.commit()
        if args.html is not None:
            print(f"gallery: {Path(args.html) / 'index.html'}", file=sys.stderr)
        if args.charts is not None:
            print(f"charts: {args.charts}", file=sys.stderr)
    return 0
