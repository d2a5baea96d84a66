"""``multiloop forces FILE [--at ANGLE] [--steps N] [--json] [--plot out.png]``.

Kinetostatics of a mechanism file (docs/forces.md): reactions in every pair and the balancing
moment/force of every driver, checked by virtual power.  FILE may also name a bundled
mechanism of ``catalogue/mechanisms`` (e.g. ``crank_slider_loaded``) or an engine file
(``[engine]`` table: the engine is built as a mechanism with its gas forces as 1° force
tables against the crank angle; ``multiloop engine`` uses the exact curve).

Driver speeds and accelerations come from ``[[driver]] speed`` / ``acceleration``
(defaults 1 rad/s or 1 m/s, and 0).  ``--at`` gives one input (deg for an R driver, m
for a P driver; several drivers: comma-separated; R inputs beyond one load period are
reduced); otherwise ``--steps`` positions (at most 100 000) over one turn of the first
driver (720 deg when a force table runs past 360 deg), or the ``solve`` command's
default stroke for P drivers.  The JSON report is :meth:`ForceResult.as_dict`
(keys in docs/forces.md).  With several drivers and no ``--at``, each driver is also
moved alone over its own sweep (its ``range`` if it has one), the others at the
reference: its balancing force or torque (text section, JSON ``per_driver``).
"""
from __future__ import annotations


import numpy as np

from multiloop.kin.forces import METHODS, forces, has_loads, table_period
from multiloop.kin.result import json_ready
from multiloop.kin.sweep import cycle_inputs, driver_forces
from multiloop.inputs import load_mechanism_or_engine
from multiloop.outputs import Outputs, dumps_json, quiet_warnings
from multiloop.topo.errors import InputError, explain


def add_arguments(p) -> None:
    p.add_argument("file", help="mechanism file (.toml/.json) with masses and loads, or a catalogue name")
    p.add_argument("--at", default=None, metavar="ANGLE",
                   help="one input: deg (R driver) or m (P driver); comma-separated for several drivers")
    p.add_argument("--steps", type=int, default=72, metavar="N", help="positions over one cycle (default 72)")
    p.add_argument("--method", choices=METHODS, default=METHODS[0],
                   help="group by group along the Assur plan (default) or one global system")
    p.add_argument("--json", action="store_true", help="print the JSON report")
    p.add_argument("--plot", default=None, metavar="OUT.png", help="plot balancing and reactions against the input")


def run(args) -> int:
    outs = Outputs("multiloop forces")
    outs.figure_target(args.plot)
    m = load_mechanism_or_engine(args.file)
    if not m.drivers:
        raise InputError(explain("[[driver]]", expected="at least one driver", got="none",
                                 hint="kinetostatics needs the input joint(s)"))
    q = cycle_inputs(m, args.at, args.steps)
    fr = forces(m, q, method=args.method)
    q_user = fr.inputs_user
    note = None if has_loads(m) else "no loads (no link mass, no [[force]]): every reaction and balancing value is 0"
    if args.plot is not None:
        from multiloop.kin.figures.engine import plot_forces  # noqa: PLC0415
        with quiet_warnings("multiloop forces"):
            fig = plot_forces(fr, q_user[:, 0])
            if note:
                fig.suptitle(note, color="tab:red", fontsize=9, y=0.995)
            outs.add_figure(args.plot, fig, dpi=110)
        outs.commit()
    # several drivers and no --at: also each driver alone over its own sweep
    each = driver_forces(m, args.steps, args.method) if len(m.drivers) > 1 and args.at is None else None
    if args.json:
        doc = fr.as_dict()
        if each is not None:
            doc["per_driver"] = json_ready(each.as_dict())
        print(dumps_json(doc))
        return 0
    notes = [note] if note else []
    if args.at is not None and not np.allclose(q_user[0], [float(v) for v in args.at.split(",")]):
        notes.append(f"R inputs reduced modulo {table_period(m):g} deg (one load period)")
    print(fr.to_text(notes))
    if each is not None:
        print(each.to_text(), end="")
    return 0
