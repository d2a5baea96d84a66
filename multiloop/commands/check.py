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

import math
from pathlib import Path

import numpy as np

from multiloop.outputs import Outputs, emit, figure_formats, quiet_warnings
from multiloop.topo.errors import InputError, explain
from multiloop.inputs import load_mechanism as load  # files, .pyslvs or catalogue names
from multiloop.topo.model import JointKind

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


def _to_api(m, v: float, k: int = 0) -> float:
    return math.radians(v) if m.joint(m.drivers[k].joint).kind is JointKind.R else v


def _finite(v: float, what: str) -> float:
    if not math.isfinite(v) or abs(v) > 1e9:
        raise InputError(explain(what, expected="a finite number of magnitude ≤ 1e9", got=repr(v)))
    return v


def _positions(m, text):
    if text is None:
        return None
    text = ",".join(text) if isinstance(text, list) else text
    try:
        vals = [float(s) for s in text.split(",") if s.strip()]
    except ValueError:
        raise InputError(explain("--positions", expected="comma-separated numbers", got=repr(text))) from None
    if not m.drivers:
        return None
    return {m.drivers[0].joint: [_to_api(m, _finite(v, "--positions")) for v in vals]}


def _joint_as_point(m, name):
    """``m`` and the output name: a joint given as ``--output`` becomes a tracer point
    ``joint <name>`` at the joint on its last link (a pin moves with every link on it)."""
    if name is None or name in m.link_names or any(p.name == name for p in m.points) \
            or name not in m.joint_names:
        return m, name
    from multiloop.topo.model import MechanismBuilder, TracerPoint
    j = m.joint(name)
    b = MechanismBuilder.from_mechanism(m)
    point = f"joint {name}"
    b.points.append(TracerPoint(point, j.links[-1], j.at))
    return b.build(), point


def run(args) -> int:
    from multiloop.kin.check import check

    m = load(args.file)
    if not m.drivers:
        raise InputError(explain(f"{args.file}: [[driver]]", expected="at least one driver", got="none",
                                 hint="the design check follows the motion of the input joint(s)"))
    if not 0.0 < _finite(args.min_transmission, "--min-transmission") < 90.0:
        raise InputError(explain("--min-transmission", expected="an angle between 0 and 90 deg",
                                 got=f"{args.min_transmission:g}",
                                 hint="a transmission angle lies in [0, 90] deg"))
    m, output = _joint_as_point(m, args.output)
    outs = Outputs("multiloop check")
    if args.plot:
        outs.target(args.plot, "--plot", formats=("",) + figure_formats())
    if args.html:
        outs.directory(args.html, "--html")
    at = None
    if args.at is not None and m.drivers:
        at = np.zeros(len(m.drivers))
        at[0] = _to_api(m, _finite(args.at, "--at"))
    rep = check(m, min_transmission=args.min_transmission, output=output, at=at,
                positions=_positions(m, args.positions), workspace=args.workspace)
    if args.plot or args.html:
        from multiloop.kin.check.figures import html_page, overview_figure, report_figures
        with quiet_warnings("multiloop check"):
            if args.plot:
                p = Path(args.plot)
                outs.add_figure(p, overview_figure(m, rep), "--plot", **({} if p.suffix else {"format": "png"}))
            if args.html:
                d = Path(args.html)
                figs = report_figures(m, rep)
                for name, fig in figs.items():
                    outs.add_figure(d / name, fig, "--html")
                outs.add(d / "index.html", html_page(rep, list(figs)), "--html")
    emit(rep, args.json)
    outs.commit()
    return 0

