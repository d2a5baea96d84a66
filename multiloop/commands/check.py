"""``multiloop check FILE [--json] [--plot P] [--html DIR] [--min-transmission DEG]
[--output LINK] [--at DEG] [--positions DEG,…]``: design check over the whole motion.

Text report by default; ``--json`` prints :meth:`CheckReport.as_dict` (keys in
docs/check.md: ``drivers``, ``transmission``, ``dead_centres``, ``pressure_angles``,
``triad_transmission``, ``circuits``, ``branch_points``, ``grashof``,
``instant_centres``, ``mechanical_advantage``, ``verdict``, ``ok``).  Driver values
are degrees for R drivers (in [0, 360) from the reference) and metres for P drivers.
Files are written only after the whole check and every figure succeeded.
"""
from __future__ import annotations

from pathlib import Path

from multiloop.outputs import Outputs, emit, quiet_warnings
from multiloop.inputs import load_mechanism as load  # files, .pyslvs or catalogue names

__all__ = ["add_arguments", "run"]


def add_arguments(p) -> None:
    p.add_argument("file", help="mechanism with geometry, a frame and drivers (.toml or .json)")
    p.add_argument("--json", action="store_true", help="print the stable JSON (docs/check.md)")
    p.add_argument("--plot", metavar="P.png", default=None,
                   help="one figure: mechanism with coupler curves, transmission and MA "
                        "against input, instant centres")
    p.add_argument("--html", metavar="DIR", default=None, help="one-page report with its figures")
    p.add_argument("--min-transmission", type=float, default=40.0, metavar="DEG",
                   help="flag transmission angles below DEG (default 40)")
    p.add_argument("--output", metavar="LINK", default=None,
                   help="output link, tracer point or joint of the velocity ratio / mechanical advantage")
    p.add_argument("--at", type=float, default=None, metavar="DEG",
                   help="driver value of the instant-centre figure (deg or m; default the reference)")
    p.add_argument("--positions", default=None, nargs="+", metavar="V,V,…",
                   help="driver values the design must reach (deg or m, first driver), comma- or "
                        "space-separated: unreachable ones are flagged (circuit defect); a list "
                        "starting with a negative value: --positions -60 120, or --positions=-60,120")
    p.add_argument("--workspace", metavar="POINT", default=None,
                   help="workspace of tracer point POINT over the box of the drivers' usable ranges: "
                        "extreme x and y with the driver values, boundary polygon, area")


def run(args) -> int:
    from multiloop.kin.check import check
    from multiloop.kin.check.inputs import check_options, instant_at, positions

    m, output = check_options(load(args.file), args.file, args.min_transmission, args.output)
    outs = Outputs("multiloop check")
    outs.figure_target(args.plot or None)
    if args.html:
        outs.directory(args.html, "--html")
    rep = check(m, min_transmission=args.min_transmission, output=output, at=instant_at(m, args.at),
                positions=positions(m, args.positions), workspace=args.workspace)
    if args.plot or args.html:
        from multiloop.kin.check.figures import html_page, overview_figure, report_figures
        with quiet_warnings("multiloop check"):
            if args.plot:
                p = Path(args.plot)
                outs.add_figure(p, overview_figure(m, rep), "--plot")     # no suffix: PNG
            if args.html:
                d = Path(args.html)
                figs = report_figures(m, rep)
                for name, fig in figs.items():
                    outs.add_figure(d / name, fig, "--html")
                outs.add(d / "index.html", html_page(rep, list(figs)), "--html")
    emit(rep, args.json)
    outs.commit()
    return 0
