"""``multiloop forces FILE [--at ANGLE] [--steps N] [--json] [--plot out.png]``.

Kinetostatics of a mechanism file (the kinetostatics (docs/forces.md)): reactions in every pair and the balancing
moment/force of every driver, checked by virtual power.  FILE may also name a bundled
mechanism of ``catalogue/mechanisms`` (e.g. ``crank_slider_loaded``) or an engine file
(``[engine]`` table: the engine is built as a mechanism with its gas forces as 1° force
tables against the crank angle; ``multiloop engine`` uses the exact curve).

Driver speeds and accelerations come from ``[[driver]] speed`` / ``acceleration``
(defaults 1 rad/s or 1 m/s, and 0).  ``--at`` gives one input (deg for an R driver, m
for a P driver; several drivers: comma-separated); otherwise ``--steps`` positions over
one turn of the first driver (720 deg when a force table runs past 360 deg).

JSON (documented in docs/forces.md): ``mechanism``, ``method``, ``blocks``,
``drivers`` (joint, links, speed, acceleration, unit), ``input`` (deg or m, per position
and driver), ``status``, ``balancing`` (driver joint → list), ``reactions`` (pair name →
``joint``, ``kind``, ``from``, ``on``, ``Fx``, ``Fy``, and for P pairs ``moment`` and
``offset``), ``virtual_power_residual`` (W), ``relative_residual``.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from multiloop.outputs import Outputs, figure_formats, quiet_warnings
from multiloop.topo.errors import InputError, explain
from multiloop.topo.model import JointKind


def add_arguments(p) -> None:
    p.add_argument("file", help="mechanism file (.toml/.json) with masses and loads, or a catalogue name")
    p.add_argument("--at", default=None, metavar="ANGLE",
                   help="one input: deg (R driver) or m (P driver); comma-separated for several drivers")
    p.add_argument("--steps", type=int, default=72, metavar="N", help="positions over one cycle (default 72)")
    p.add_argument("--method", choices=("groups", "global"), default="groups",
                   help="group by group along the Assur plan (default) or one global system")
    p.add_argument("--json", action="store_true", help="print the JSON report")
    p.add_argument("--plot", default=None, metavar="OUT.png", help="plot balancing and reactions against the input")


def _resolve(path: str) -> Path:
    p = Path(path)
    if p.exists():
        return p
    from importlib import resources  # noqa: PLC0415
    for sub in ("mechanisms", "engines"):
        cand = Path(str(resources.files("multiloop.catalogue") / sub / f"{path}.toml"))
        if cand.exists():
            return cand
    return p


def load_any(path: str):
    """A mechanism from a mechanism file, or built from an engine file."""
    from multiloop.topo.io import load, read_document  # noqa: PLC0415
    p = _resolve(path)
    if p.suffix.lower() in (".toml", ".json") and p.exists():
        doc = read_document(p)
        if isinstance(doc, dict) and "engine" in doc:
            from multiloop.kin.engine import engine_from_dict, engine_mechanism  # noqa: PLC0415
            try:
                return engine_mechanism(engine_from_dict(doc), gas_loads=True)
            except InputError as exc:
                raise InputError(f"{p}: {exc}") from None
    return load(p)


def _inputs(m, at: str | None, steps: int) -> np.ndarray:
    nd = len(m.drivers)
    kinds = [m.joint(d.joint).kind for d in m.drivers]
    if at is not None:
        try:
            vals = [float(x) for x in str(at).split(",")]
        except ValueError:
            raise InputError(explain("--at", expected="a number (deg or m) per driver, comma-separated",
                                     got=repr(at))) from None
        if len(vals) != nd:
            raise InputError(explain("--at", expected=f"{nd} value(s), one per driver", got=f"{len(vals)}"))
        q = [math.radians(v) if k is JointKind.R else v for v, k in zip(vals, kinds)]
        return np.array([q], float)
    if steps < 1:
        raise InputError(explain("--steps", expected="a positive integer", got=repr(steps)))
    period = 360.0
    for ld in m.loads:
        if ld.table is not None and max(r[0] for r in ld.table) > 360.0:
            period = 720.0
    q = np.zeros((steps, nd))
    if kinds[0] is JointKind.R:
        q[:, 0] = np.radians(np.arange(steps) * period / steps)
    else:
        q[:, 0] = np.linspace(0.0, 0.1, steps)  # a P driver: 0.1 m of travel
    return q


def _clean(a) -> list:
    a = np.asarray(a, float)
    out = np.where(np.isfinite(a), a, np.nan).tolist()

    def fix(x):
        if isinstance(x, list):
            return [fix(y) for y in x]
        return None if x != x else x
    return fix(out)


def report_dict(fr, inputs_user: np.ndarray) -> dict:
    """The JSON-ready dict of a :class:`~kin.forces.ForceResult` (docs/forces.md)."""
    m = fr.mechanism
    drivers = []
    for i, d in enumerate(m.drivers):
        kind = m.joint(d.joint).kind
        drivers.append({"joint": d.joint, "links": list(d.links), "kind": kind.value,
                        "speed": float(d.speed) if d.speed is not None else 1.0,
                        "acceleration": float(d.acceleration) if d.acceleration is not None else 0.0,
                        "unit": "N m" if kind is JointKind.R else "N"})
    reactions = {}
    for i, p in enumerate(fr.pairs):
        entry = {"joint": p.joint, "kind": p.kind, "from": p.a, "on": p.b,
                 "Fx": _clean(fr.reactions[:, i, 0]), "Fy": _clean(fr.reactions[:, i, 1])}
        if p.kind == "P":
            entry["normal"] = _clean(fr.normal_forces[:, i])
            entry["moment"] = _clean(fr.pair_moments[:, i])
            with np.errstate(all="ignore"):
                entry["offset"] = _clean(fr.line_of_action(p.name))
        reactions[p.name] = entry
    bal = {}
    for i, d in enumerate(m.drivers):
        key = d.joint if sum(x.joint == d.joint for x in m.drivers) == 1 else f"{d.joint}:{d.links[0]}->{d.links[1]}"
        bal[key] = _clean(fr.balancing[:, i])
    return {"mechanism": m.name, "method": fr.method, "blocks": [list(b) for b in fr.blocks],
            "notes": list(fr.notes), "drivers": drivers, "input": _clean(inputs_user),
            "status": [str(s) for s in fr.status], "balancing": bal, "reactions": reactions,
            "virtual_power_residual": _clean(fr.virtual_power_residual),
            "relative_residual": _clean(fr.relative_residual)}


def run(args) -> int:
    from multiloop.kin.forces import forces  # noqa: PLC0415
    outs = Outputs("multiloop forces")
    if args.plot is not None:
        outs.target(args.plot, "--plot", formats=("",) + figure_formats())
    m = load_any(args.file)
    if not m.drivers:
        raise InputError(explain("[[driver]]", expected="at least one driver", got="none",
                                 hint="kinetostatics needs the input joint(s)"))
    q = _inputs(m, args.at, args.steps)
    fr = forces(m, q, method=args.method)
    kinds = [m.joint(d.joint).kind for d in m.drivers]
    q_user = np.array([[math.degrees(v) if k is JointKind.R else v for v, k in zip(row, kinds)] for row in q])
    if args.plot is not None:
        from multiloop.kin.figures.engine import plot_forces  # noqa: PLC0415
        with quiet_warnings("multiloop forces"):
            outs.add_figure(args.plot, plot_forces(fr, q_user[:, 0]), dpi=110)
        outs.commit()
    if args.json:
        print(json.dumps(report_dict(fr, q_user)))
        return 0
    print(f"{m.name or 'mechanism'}: kinetostatics, {fr.n_positions} position(s), method {fr.method}"
          + (f" ({'; '.join(fr.notes)})" if fr.notes else ""))
    print("  blocks solved: " + " <- ".join("{" + ", ".join(b) + "}" for b in fr.blocks))
    heads = ["input"] + [f"Mb[{d.joint}]" if k is JointKind.R else f"Fb[{d.joint}]" for d, k in zip(m.drivers, kinds)] \
        + ["VP residual", "status"]
    print("  " + "  ".join(f"{h:>14}" for h in heads))
    for n in range(fr.n_positions):
        row = [f"{q_user[n, 0]:14.4f}"] + [f"{fr.balancing[n, i]:14.6g}" for i in range(len(m.drivers))] \
            + [f"{fr.virtual_power_residual[n]:14.3g}", f"{fr.status[n]:>14}"]
        print("  " + "  ".join(row))
    if fr.n_positions == 1:
        print("  reactions (force of 'from' on 'on', N):")
        for i, p in enumerate(fr.pairs):
            extra = ""
            if p.kind == "P":
                extra = f"  normal {fr.normal_forces[0, i] + 0.0:.6g} N, couple {fr.pair_moments[0, i] + 0.0:.6g} N m"
            print(f"    {p.name:<28} Fx {fr.reactions[0, i, 0] + 0.0:14.6g}  Fy {fr.reactions[0, i, 1] + 0.0:14.6g}{extra}")
    bad = int(np.sum(~fr.ok))
    if bad:
        print(f"  {bad} position(s) failed: {fr.message}")
    print(f"  max |virtual power residual| = {np.nanmax(np.abs(fr.virtual_power_residual)) if fr.ok.any() else float('nan'):.3g} W"
          f" (relative {np.nanmax(fr.relative_residual) if fr.ok.any() else float('nan'):.3g})")
    return 0
