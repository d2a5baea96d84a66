"""``multiloop solve FILE [--steps N] [--from A --to B] [--derivatives] [--json|--csv]
[--plot out.png] [--animate out.gif]``: positions, velocities, accelerations.

Inputs on the command line are **degrees** for an R driver and **metres** for a
P driver.  ``--steps N`` alone: one full turn from the reference in N equal steps,
the first being the reference itself (0, 360/N, …, 360(N−1)/N degrees); for a P
driver the default range is a stroke from 0 to +10 % of the mechanism's size
(the largest extent of its reference joint positions), N points.  ``--from A
--to B``: N points from A to B inclusive.  With several drivers every driver
takes the same values.

JSON layout (stable; NaN is ``null``)::

    {"mechanism": name, "formula": "I(0,1) → II1(2,3)",
     "drivers": [{"joint": "O", "kind": "R", "unit": "deg"}],
     "input": [...]            # one driver: a list; several: a list of lists
     "status": ["ok", ...],
     "joints": {"A": {"x": [...], "y": [...], "vx", "vy", "ax", "ay"}},
     "links":  {"crank": {"angle": [...], "omega": [...], "epsilon": [...]}},
     "points": {"M": {"x", "y", "vx", "vy", "ax", "ay"}},
     "notes": [...]}

``x, y`` in m; ``angle`` in degrees (rotation from the reference);
``vx…ay``, ``omega``, ``epsilon`` only with ``--derivatives``: time derivatives
for the driver at 1 rad/s (or 1 m/s) with zero acceleration, i.e. the analogues
d/dφ and d²/dφ² (m, m, rad, rad per rad of input).  CSV: one row per position,
columns ``input[_joint]``, ``status``, ``<joint>.x``, … in the same order.
Files are written only after the whole solve and all figures succeeded.
"""
from __future__ import annotations

import csv
import io
import json
import sys
from pathlib import Path

import numpy as np

from multiloop.outputs import Outputs, figure_formats, quiet_warnings
from multiloop.topo.errors import InputError, explain
from multiloop.inputs import load_mechanism as load  # files, .pyslvs or catalogue names
from multiloop.topo.model import JointKind

__all__ = ["add_arguments", "run", "state_to_dict", "input_values"]


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
    p.add_argument("--method", choices=("auto", "closed_form", "newton"), default="auto",
                   help="closed-form groups (default) or Newton with continuation for all")
    p.add_argument("--assemble", action="store_true",
                   help="solve each input on its own, on the reference's branch signs (no continuation: "
                        "positions on other circuits come back ok)")
    out = p.add_mutually_exclusive_group()
    out.add_argument("--json", action="store_true", help="print the stable JSON (see docs/kinematics.md)")
    out.add_argument("--csv", action="store_true", help="print CSV, one row per position")
    p.add_argument("--plot", metavar="OUT.png", default=None,
                   help="mechanism in its reference position with tracer paths; "
                        "the analogues go to OUT_analogues.png")
    p.add_argument("--animate", metavar="OUT.gif", default=None, help="one cycle as a GIF")
    p.add_argument("--svg", metavar="OUT.svg", default=None,
                   help="CAD drawing at the first position: layers LINKS, FRAME, PINS, PATHS, LABELS (mm)")
    p.add_argument("--dxf", metavar="OUT.dxf", default=None, help="the same drawing as DXF (ezdxf, mm)")


#: largest --steps accepted
MAX_STEPS = 1_000_000


def input_values(m, steps: int | None, start: float | None, stop: float | None) -> np.ndarray:
    """CLI inputs in CLI units (deg / m), shape (N,): exactly ``from + k·step``."""
    if steps is not None and not 1 <= steps <= MAX_STEPS:
        raise InputError(explain("--steps", expected=f"an integer from 1 to {MAX_STEPS}", got=str(steps)))
    if (start is None) != (stop is None):
        raise InputError(explain("--from/--to", expected="both or neither", got="only one"))
    for name, v in (("--from", start), ("--to", stop)):
        if v is not None and not np.isfinite(v):
            raise InputError(explain(name, expected="a finite number", got=str(v)))
    n = steps if steps is not None else 36
    if start is not None:
        if n == 1:
            return np.array([start])
        out = start + np.arange(n) * ((stop - start) / (n - 1))
        out[-1] = stop
        return out
    kinds = {m.joint(d.joint).kind for d in m.drivers}
    if kinds == {JointKind.R}:
        return np.arange(n) * (360.0 / n)
    xy = np.array([j.at for j in m.joints], float)
    size = float(np.max(np.ptp(xy, axis=0))) if len(xy) > 1 else 1.0
    if kinds == {JointKind.P}:
        return np.linspace(0.0, 0.1 * size, n) if n > 1 else np.zeros(1)
    raise InputError(explain("drivers", expected="--from/--to when R and P drivers are mixed",
                             got="no range"))


def _to_api(m, x_cli: np.ndarray) -> np.ndarray:
    cols = []
    for d in m.drivers:
        cols.append(np.radians(x_cli) if m.joint(d.joint).kind is JointKind.R else x_cli)
    return np.stack(cols, axis=1) if len(cols) > 1 else cols[0]


def state_to_dict(state, plan=None, inputs_cli=None) -> dict:
    """The JSON document of a state: :meth:`KinematicState.as_dict` (kept for callers)."""
    return state.as_dict(plan.formula if plan is not None else None, inputs_cli)


def _csv(doc: dict) -> str:
    cols: list[tuple[str, list]] = []
    inp = doc["input"]
    if doc["drivers"] and len(doc["drivers"]) > 1:
        for k, d in enumerate(doc["drivers"]):
            cols.append((f"input_{d['joint']}", [r[k] for r in inp]))
    else:
        cols.append(("input", inp))
    cols.append(("status", doc["status"]))
    for table in ("joints", "links", "points"):
        for name, e in doc[table].items():
            for key, vals in e.items():
                cols.append((f"{name}.{key}", vals))
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow([c for c, _ in cols])
    for row in zip(*[v for _, v in cols]):
        w.writerow(["" if v is None else (repr(v) if isinstance(v, float) else v) for v in row])
    return buf.getvalue()


def _table(doc: dict) -> str:
    names = list(doc["joints"])
    units = sorted({d["unit"] for d in doc["drivers"]})
    unit = "/".join(units) + (" each driver" if len(doc["drivers"]) > 1 else "")
    head = [f"input ({unit})"] + [f"{n}.{c}" for n in names for c in "xy"]
    lines = [f"{doc['mechanism'] or 'mechanism'}: {doc['formula']}", "  ".join(f"{h:>12}" for h in head)]
    for i, s in enumerate(doc["status"]):
        x = doc["input"][i]
        x = x[0] if isinstance(x, list) else x
        if s != "ok":
            lines.append(f"{x:>12.6g}  {s}")
            continue
        vals = [doc["joints"][n][c][i] for n in names for c in "xy"]
        lines.append(f"{x:>12.6g}  " + "  ".join(f"{v:>12.6g}" for v in vals))
    for n in doc["notes"]:
        lines.append(f"note: {n}")
    return "\n".join(lines)


def run(args) -> int:
    import warnings

    from multiloop.kin.solve import compile_plan, solve

    m = load(args.file)
    outs = Outputs("multiloop solve")
    if args.plot is not None:
        outs.target(args.plot, "--plot", formats=("",) + figure_formats())
    if args.animate is not None:
        outs.target(args.animate, "--animate", formats=("gif",))
    for flag, path in (("--svg", args.svg), ("--dxf", args.dxf)):
        if path is not None:
            outs.target(path, flag, formats=(flag[2:],))
    plan = compile_plan(m)
    x_cli = input_values(m, args.steps, args.start, args.stop)
    want_der = args.derivatives or args.plot is not None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        state = solve(m, _to_api(m, x_cli), derivatives=want_der, plan=plan, method=args.method,
                      assemble=args.assemble)
    doc_state = state
    if want_der and not args.derivatives:
        doc_state = type(state)(state.mechanism, state.inputs, state.positions, state.angles, state.status,
                                point_names=state.point_names, point_positions=state.point_positions,
                                notes=state.notes, poses=state.poses)
    doc = state_to_dict(doc_state, plan.assur, x_cli)
    # render every file in memory first: nothing is written half-way
    if args.plot is not None:
        from multiloop.kin.figures.mechanism import plot_analogues, plot_mechanism
        p = Path(args.plot)
        with quiet_warnings("multiloop solve"):
            outs.add_figure(p, plot_mechanism(state))
            outs.add_figure(p.with_name(p.stem + "_analogues" + (p.suffix or ".png")), plot_analogues(state))
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
        text = json.dumps(doc, indent=1, ensure_ascii=False, allow_nan=False)
    elif args.csv:
        text = _csv(doc)
    else:
        text = _table(doc)
    outs.commit()
    print(text)
    if not state.success:
        bad = np.flatnonzero(~state.ok)
        x0 = doc["input"][int(bad[0])]
        unit = "/".join(sorted({d["unit"] for d in doc["drivers"]}))
        print(f"multiloop solve: {bad.size} of {state.n_positions} positions failed; first at input "
              f"{x0:g} {unit}: {state.status[bad[0]]}" if not isinstance(x0, list) else
              f"multiloop solve: {bad.size} of {state.n_positions} positions failed; first at input "
              f"{x0} {unit}: {state.status[bad[0]]}", file=sys.stderr)
    return 0
