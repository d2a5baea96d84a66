"""``multiloop solve FILE [--steps N] [--from A --to B] [--derivatives] [--json|--csv]
[--plot out.png] [--animate out.gif]``: positions, velocities, accelerations.

Inputs on the command line are **degrees** for an R driver and **metres** for a P
driver; the default sweeps are those of :func:`multiloop.kin.sweep.input_range`.

The JSON (:meth:`KinematicState.as_dict`, NaN is ``null``) and the CSV columns are
documented in docs/kinematics.md, section 3; derivatives (``--derivatives``) are for
the driver at 1 rad/s (or 1 m/s): the analogues d/dφ and d²/dφ².
Files are written only after the whole solve and all figures succeeded.
"""
from __future__ import annotations

import sys

from multiloop.kin.solve import METHODS
from multiloop.outputs import dumps_json, Outputs, quiet_warnings
from multiloop.inputs import load_mechanism as load  # files, .pyslvs or catalogue names

__all__ = ["add_arguments", "run"]


def add_arguments(p) -> None:
    p.add_argument("file", help="mechanism with geometry, a frame and drivers (.toml or .json)")
    p.add_argument("--steps", type=int, default=None, metavar="N",
                   help="number of positions (default 36; alone: one full turn from the reference)")
    p.add_argument("--from", dest="start", type=float, default=None, metavar="A",
                   help="first input (deg for R drivers, m for P drivers)")
    p.add_argument("--to", dest="stop", type=float, default=None, metavar="B",
                   help="last input (inclusive)")
    p.add_argument("--derivatives", action="store_true",
                   help="velocities and accelerations (analogues: driver at unit rate)")
    p.add_argument("--method", choices=METHODS, default=METHODS[0],
                   help="closed-form groups (default) or Newton with continuation for all")
    p.add_argument("--assemble", action="store_true",
                   help="solve each input on its own, on the reference's branch signs (no continuation: "
                        "positions on other circuits come back ok)")
    out = p.add_mutually_exclusive_group()
    out.add_argument("--json", action="store_true", help="print the stable JSON (see docs/kinematics.md)")
    out.add_argument("--csv", action="store_true", help="print CSV, one row per position")
    p.add_argument("--plot", metavar="OUT.png", default=None,
                   help="mechanism at its first regular position with tracer paths; "
                        "the analogues go to OUT_analogues.png")
    p.add_argument("--animate", metavar="OUT.gif", default=None, help="one cycle as a GIF")
    p.add_argument("--svg", metavar="OUT.svg", default=None,
                   help="CAD drawing at the first position: layers LINKS, FRAME, PINS, PATHS, LABELS (mm)")
    p.add_argument("--dxf", metavar="OUT.dxf", default=None, help="the same drawing as DXF (ezdxf, mm)")


def run(args) -> int:
    import warnings

    from multiloop.kin.solve import compile_plan, solve
    from multiloop.kin.state import doc_csv, doc_text, failure_text
    from multiloop.kin.sweep import input_range, si_inputs

    m = load(args.file)
    outs = Outputs("multiloop solve")
    outs.figure_target(args.plot)
    if args.animate is not None:
        outs.target(args.animate, "--animate", formats=("gif",))
    for flag, path in (("--svg", args.svg), ("--dxf", args.dxf)):
        if path is not None:
            outs.target(path, flag, formats=(flag[2:],))
    plan = compile_plan(m)
    x_cli = input_range(m, args.steps, args.start, args.stop)
    want_der = args.derivatives or args.plot is not None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        state = solve(m, si_inputs(m, x_cli), derivatives=want_der, plan=plan, method=args.method,
                      assemble=args.assemble)
    doc = state.as_dict(plan.assur.formula, x_cli, derivatives=args.derivatives)   # the rates only when asked
    # render every file in memory first: nothing is written half-way
    if args.plot is not None:
        from multiloop.kin.figures.mechanism import iter_solve_figures
        with quiet_warnings("multiloop solve"):
            for path, fig in iter_solve_figures(state, args.plot):
                outs.add_figure(path, fig)
    if args.animate is not None:
        from multiloop.kin.figures.mechanism import animate
        outs.add_rendered(args.animate, lambda tmp: animate(state, tmp), "--animate")
    if args.svg is not None or args.dxf is not None:
        from multiloop.kin.figures.cad import mechanism_dxf, mechanism_svg
        if args.svg is not None:
            outs.add(args.svg, mechanism_svg(state), "--svg")
        if args.dxf is not None:
            outs.add(args.dxf, mechanism_dxf(state), "--dxf")
    if args.json:
        text = dumps_json(doc)
    elif args.csv:
        text = doc_csv(doc)
    else:
        text = doc_text(doc)
    outs.commit()
    print(text)
    if not state.success:
        print(f"multiloop solve: {failure_text(state, doc)}", file=sys.stderr)
    return 0
