"""``multiloop synthesise [START.toml] (--path T.csv | --function F.csv | --motion POSES.csv) --out OUT.toml``:
dimensional synthesis from a start (its topology, names, one driver and a starting geometry), or, with
``--path`` alone, the atlas chooses the topology (``catalogue.topology_synthesis``; ``--top K`` designs
written as ``OUT.toml``, ``OUT-2.toml``, …).  The tables' columns and units, the options and the report
are in docs/synthesis.md and ``--help``; nothing is written unless the whole run succeeds.
"""
from __future__ import annotations

import sys

from multiloop.outputs import Outputs, dumps_json, quiet_warnings
from multiloop.topo.errors import InputError, explain
from multiloop.inputs import load_mechanism as load  # files, .pyslvs or catalogue names
from multiloop.topo.formats import dumps_mechanism
from multiloop.catalogue.dimensional.budget import Budget
from multiloop.catalogue.dimensional.objective import DIRECTIONS, GRASHOF, MODES
from multiloop.catalogue.dimensional.optimise import METHODS
from multiloop.catalogue.dimensional.report import parse_bounds, progress_bar, synthesis_text
from multiloop.catalogue.dimensional.searched_timing import FREE_TIMINGS
from multiloop.catalogue.dimensional.targets import TIMINGS

__all__ = ["add_arguments", "run"]


def add_arguments(p) -> None:
    p.add_argument("start", nargs="?", default=None,
                   help="start mechanism (.toml or .json): topology, one driver, a geometry; without it "
                        "(--path only) the atlas chooses the topology")
    task = p.add_mutually_exclusive_group(required=True)
    task.add_argument("--path", metavar="TARGET.csv", help="path generation: rows x,y[,input]")
    task.add_argument("--function", metavar="TABLE.csv", help="function generation: rows input,output")
    task.add_argument("--motion", metavar="POSES.csv", help="motion generation: rows x,y,angle")
    p.add_argument("--point", metavar="NAME", help="tracer point of --path (default: the only one)")
    p.add_argument("--shape-only", action="store_true", help="--path: the target may be scaled, rotated, moved")
    p.add_argument("--output", metavar="JOINT", help="output joint of --function")
    p.add_argument("--link", metavar="NAME", help="link of --motion")
    p.add_argument("--out", metavar="OUT.toml", required=True, help="the synthesised mechanism")
    p.add_argument("--seed", type=int, default=0, help="random seed (reproducible runs)")
    p.add_argument("--evaluations", default=None, metavar="N",
                   help="stop after N designs evaluated: reproducible (default 20000; without START 100000)")
    p.add_argument("--budget", type=float, default=None, metavar="S", help="a wall-time cap in seconds")
    p.add_argument("--method", choices=METHODS, default=METHODS[0],
                   help="global search (default de); local: polish the start only")
    p.add_argument("--tol", type=float, default=None,
                   help="stop when the relative RMS error is below this (default 1e-6); without START: "
                        "errors within it tie and fewer links win, and the search stops once the best is within it "
                        "(default 1e-4)")
    p.add_argument("--db", dest="atlas", default=None,
                   help="without START: the atlas with coupler curves (default: the default atlas, built into the "
                        "user cache on first use)")
    p.add_argument("--links", default="4,6,8", help="without START: numbers of links to try (default 4,6,8)")
    p.add_argument("--top", type=int, default=3, metavar="K", help="without START: designs returned (default 3)")
    shape = p.add_mutually_exclusive_group()
    shape.add_argument("--open", dest="closed", action="store_const", const=False, default=None,
                       help="without START: the target is an open stroke over part of the driver's motion (default: "
                            "open when its end-to-start gap exceeds 1.1 times its longest step)")
    shape.add_argument("--closed", dest="closed", action="store_const", const=True,
                       help="without START: the target is a closed curve traced over whole turns")
    p.add_argument("--full-rotation", action="store_true", help="require a fully rotating driver")
    p.add_argument("--min-transmission", type=float, default=None, metavar="DEG",
                   help="minimum transmission angle of every RRR dyad")
    p.add_argument("--max-ratio", type=float, default=None, help="longest / shortest link length at most this")
    p.add_argument("--length-bounds", type=float, nargs=2, default=None, metavar=("LOW", "HIGH"),
                   help="every link length (distance between two joints of a link, the frame's too) in [LOW, HIGH] m")
    p.add_argument("--timing", choices=TIMINGS, default="reference",
                   help="--path's third column: from the reference (default), absolute (crank angle from the "
                        "x-axis, slider position from the guide's point), or steps from a free start")
    p.add_argument("--bounds", nargs="+", metavar="NAME=LOW:HIGH", default=None,
                   help="bounds of design variables by name (e.g. O2.x=-1:1; names in the JSON report's design)")
    p.add_argument("--grashof", choices=GRASHOF, default="any",
                   help="four-bar: crank-rocker (driven link shortest, Grashof) or double-crank (frame shortest)")
    p.add_argument("--mode", choices=MODES, default="any", help="reference: each dyad keeps the start's branch")
    p.add_argument("--direction", choices=DIRECTIONS, default="any",
                   help="the driven link's turning sense through the targets (free or step timing)")
    p.add_argument("--free-timing", choices=FREE_TIMINGS, default=None, help="free timing: driver values searched "
                   "(default with a search), or matched to the curve (--method local, --full-rotation, --min-transmission)")
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    p.add_argument("--plot", metavar="P.png", default=None, help="target vs achieved and the mechanism")


def run_without_start(args, limits: dict) -> int:
    """The atlas chooses the topology (``catalogue.topology_synthesis``)."""
    from multiloop.catalogue.topology_synthesis import design_files, parse_links, synthesise as topo_synthesise

    if not args.path or args.function or args.motion:
        raise InputError(explain("START", expected="a start mechanism, or --path alone (the atlas chooses)",
                                 got="no START"))
    if args.plot is not None:        # refused, not ignored: the atlas route draws no figure
        raise InputError(explain("--plot", expected="a START mechanism", got=f"--plot {args.plot!r} without one",
                                 hint="draw a design it writes: multiloop solve OUT.toml --plot P.png"))
    outs = Outputs("multiloop synthesise")
    outs.target(args.out, "--out", formats=("toml", "json"))
    # (the library checks the target and the options before it reads or builds an atlas)
    res = topo_synthesise(args.path, links=parse_links(args.links), atlas=args.atlas, top=args.top, **limits,
                          point=args.point or "P", closed=args.closed,
                          tol=1e-4 if args.tol is None else args.tol, seed=args.seed, build_progress=sys.stderr.isatty(),
                          say=lambda text: print(f"multiloop synthesise: {text}", file=sys.stderr, flush=True))
    if not res.designs:
        raise InputError(explain("--path", expected="a design that passes check",
                                 got=f"none of {res.polished} polished candidates",
                                 hint="more --evaluations, more --links, or more curves in the atlas"))
    files = design_files(args.out, len(res.designs))
    for d, f in zip(res.designs, files):
        outs.add(f, dumps_mechanism(d.mechanism, f), "--out")
    outs.commit()
    files = [str(f) for f in files]
    print(dumps_json(res.as_list(files)) if args.json else res.to_text(files))
    return 0


def run(args) -> int:
    from multiloop.catalogue.dimensional import synthesise

    limits = Budget.of(args.evaluations, args.budget, default=None).keywords()
    if args.start is None:
        return run_without_start(args, limits)
    if args.closed is not None:     # refused, not ignored: a start's motion is --full-rotation's
        raise InputError(explain("--open/--closed", expected="no START (the atlas route)", got="a START",
                                 hint="with a start, --full-rotation asks for a closed curve over whole turns"))
    m = load(args.start)
    outs = Outputs("multiloop synthesise")
    outs.target(args.out, "--out", formats=("toml", "json"))
    outs.figure_target(args.plot)
    with progress_bar(sys.stderr.isatty() and not args.json) as cb:     # the library checks the task
        res = synthesise(m, path=args.path, point=args.point, shape_only=args.shape_only, function=args.function,
                         output=args.output, motion=args.motion, link=args.link, seed=args.seed,
                         **limits, method=args.method, tol=1e-6 if args.tol is None else args.tol,
                         full_rotation=args.full_rotation, min_transmission=args.min_transmission, max_ratio=args.max_ratio,
                         length_bounds=args.length_bounds, progress=cb, timing=args.timing,
                         grashof=args.grashof, mode=args.mode, direction=args.direction, free_timing=args.free_timing,
                         bounds=parse_bounds(args.bounds))
    outs.add(args.out, dumps_mechanism(res.mechanism, args.out), "--out")
    if args.plot is not None:
        from multiloop.catalogue.dimensional.figure import plot_synthesis
        with quiet_warnings("multiloop synthesise"):
            outs.add_figure(args.plot, plot_synthesis(res))
    outs.commit()
    doc = dict(res.as_dict(), out=str(args.out))
    print(dumps_json(doc) if args.json else synthesis_text(doc))
    return 0
