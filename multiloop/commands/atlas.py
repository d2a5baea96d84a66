"""``multiloop atlas``: number and type synthesis, SQLite atlas, queries, HTML gallery.

Examples::

    multiloop atlas --links 10 --dof 1 --simple-joints          # 230 chains
    multiloop atlas --links 10 --dof 1 --table                  # universal structural table
    multiloop atlas --links 12 --dof 1 --db atlas.sqlite --workers 2 --no-loops
    multiloop atlas --db atlas.sqlite --query "V=2 AND K=4" --json
    multiloop atlas --links 8 --dof 1 --html gallery/
    multiloop atlas --links 12 --dof 1 --scheduler tcp://127.0.0.1:8786
"""
from __future__ import annotations

import sys
from pathlib import Path

from multiloop.outputs import Outputs, dumps_json, quiet_warnings
from multiloop.topo.errors import InputError, explain


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
    p.add_argument("--limit", type=int, help="list at most this many chains")
    p.add_argument("--html", metavar="DIR", help="write the HTML gallery to DIR")
    p.add_argument("--html-limit", type=int, default=2000, help="chains per gallery page (default 2000)")
    p.add_argument("--charts", metavar="DIR", help="write the existence-domain and invariant charts (PNG)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


def _options(args):
    from multiloop.catalogue.synthesis import SynthesisOptions

    return SynthesisOptions(args.links, args.dof, simple_joints=args.simple_joints,
                            max_multiplicity=args.max_multiplicity,
                            max_link_degree=args.max_link_degree, planar=args.planar,
                            no_fractionated=args.no_fractionated)


#: the integer options and their ranges (SQLite and C ints stop at 2**63 and 2**31)
_INT_RANGES = {"--dof": ("dof", 1, 2 ** 31 - 1),
               "--max-multiplicity": ("max_multiplicity", 1, 2 ** 31 - 1),
               "--max-link-degree": ("max_link_degree", 2, 2 ** 31 - 1),
               "--workers": ("workers", 1, 1024), "--limit": ("limit", 0, 2 ** 63 - 1),
               "--curves": ("curves", 1, 10 ** 6),
               "--html-limit": ("html_limit", 1, 2 ** 63 - 1)}


def _check_options(args) -> None:
    """Every integer option within its range, the query well formed: all before the
    atlas file is opened (a rejected run creates no file)."""
    from multiloop.catalogue.atlas import parse_query

    for flag, (attr, lo, hi) in _INT_RANGES.items():
        value = getattr(args, attr)
        if value is not None and not lo <= value <= hi:
            raise InputError(explain(flag, expected=f"an integer from {lo} to {hi}",
                                     got=str(value) if abs(value) < 10 ** 30 else f"a {len(str(abs(value)))}-digit number"))
    if args.query is not None:
        parse_query(args.query)
    if args.table and args.links is None:
        raise InputError(explain("--table", expected="--links N --dof F", got="no --links"))
    if args.curves is not None and not (args.mechanisms and args.links is not None and args.dof == 1):
        raise InputError(explain("--curves", expected="--links N --dof 1 --mechanisms",
                                 got="--curves without them", hint="the curves belong to the stored mechanisms"))


def run(args) -> int:
    from multiloop.catalogue.atlas import Atlas
    from multiloop.catalogue.listing import atlas_listing, listing_text

    _check_options(args)
    if args.links is None and not Path(args.db).exists():
        raise InputError(explain("--db", expected="an existing atlas file (or --links N to build one)",
                                 got=repr(args.db)))
    if args.scheduler is not None:
        from multiloop.catalogue.distributed import require_dask
        require_dask()
    opts = _options(args) if args.links is not None else None
    if args.scheduler is not None and opts is not None and not Path(args.db).exists():
        from multiloop.catalogue.distributed import connect_scheduler   # fail before a file is created
        connect_scheduler(args.scheduler).close()
    outs = Outputs("multiloop atlas")
    for d in (args.html, args.charts):
        if d is not None:
            outs.directory(d, "--html" if d is args.html else "--charts")
    with Atlas(args.db) as atlas:
        built = None
        if opts is not None:
            loops = args.loops if args.loops is not None else opts.n <= 10
            built = atlas.build(opts, loops=loops, workers=args.workers, scheduler=args.scheduler,
                                progress=not args.no_progress)
        inv = None
        if args.mechanisms and opts is not None and opts.F == 1 and args.query is None:
            from multiloop.catalogue.inversions import build_mechanisms
            inv = build_mechanisms(atlas, opts, progress=not args.no_progress)
            if args.curves is not None:
                from multiloop.catalogue.curve_atlas import build_curves
                from multiloop.catalogue.distributed import default_workers
                curves = build_curves(atlas, opts, args.curves, progress=not args.no_progress,
                                      workers=args.workers or default_workers(), scheduler=args.scheduler)
                print(curves.to_text(), file=sys.stderr)
        doc = atlas_listing(atlas, opts, args.query, args.limit, args.table, args.mechanisms, built, inv)
        print(dumps_json(doc) if args.json else listing_text(doc, opts, args.query, args.limit))
        if args.html is not None:
            from multiloop.catalogue.html import gallery_files

            pairs = [(opts.n, opts.F)] if opts is not None else None
            for name, text in gallery_files(atlas, pairs, args.query, args.html_limit).items():
                outs.add(Path(args.html) / name, text, "--html")
        if args.charts is not None:
            from multiloop.kin.figures.chains import atlas_chart_files
            with quiet_warnings("multiloop atlas"):
                for name, data in atlas_chart_files(atlas).items():
                    outs.add(Path(args.charts) / name, data, "--charts")
        outs.commit()
        if args.html is not None:
            print(f"gallery: {Path(args.html) / 'index.html'}", file=sys.stderr)
        if args.charts is not None:
            print(f"charts: {args.charts}", file=sys.stderr)
    return 0
