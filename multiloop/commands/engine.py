"""``multiloop engine FILE [--steps N] [--json] [--plot DIR]``: the diagrams of Vasilenko et al. 2018.

FILE is an engine file (``[engine]``, ``[[cylinder]]``, ``[gas]``; docs/forces.md) or
the name of a bundled one (``single_cylinder``, ``v_twin``, ``radial_5cyl_masses``).
Prints the main numbers (stroke, λ, swept volume, firing intervals, λ-approximation
error, indicated work, ∮M_b dφ, peak reactions, the virtual-power check and the
general-kinetostatics cross-check); ``--json`` gives every array; ``--plot DIR`` writes
kinematics, pressure, balancing, cyclogram, rod_com and reactions PNGs.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from multiloop.kin.engine import MAX_STEPS, analyse_engine, load_engine
from multiloop.inputs import resolve
from multiloop.outputs import Outputs, quiet_warnings
from multiloop.topo.errors import InputError, explain


def add_arguments(p) -> None:
    p.add_argument("file", help="engine file (.toml/.json) or catalogue name")
    p.add_argument("--steps", type=int, default=720, metavar="N",
                   help="crank positions over the 720 deg cycle (default 720)")
    p.add_argument("--json", action="store_true", help="print the JSON report")
    p.add_argument("--plot", default=None, metavar="DIR", help="write the diagrams as PNG into DIR")
    p.add_argument("--no-check", action="store_true", help="skip the general kinetostatics cross-check")


def run(args) -> int:
    if not 8 <= args.steps <= MAX_STEPS:
        raise InputError(explain("--steps", expected=f"an integer from 8 to {MAX_STEPS}", got=repr(args.steps)))
    outs = Outputs("multiloop engine")
    if args.plot is not None:
        outs.directory(args.plot, "--plot")
    spec = load_engine(resolve(args.file, ("engines",)))
    res = analyse_engine(spec, args.steps, check=not args.no_check)
    if args.plot is not None:
        from multiloop.kin.figures.engine import engine_figures  # noqa: PLC0415
        with quiet_warnings("multiloop engine"):
            for name, fig in engine_figures(res).items():
                outs.add_figure(Path(args.plot) / name, fig, dpi=110)
        paths = outs.commit()
        if not args.json:
            print("wrote " + ", ".join(str(p) for p in paths))
    if args.json:
        print(json.dumps(res.as_dict()))
        return 0
    cyc = res.cyclogram
    W = res.indicated_work.sum()
    e = res.approx_error
    rows = [
        ("engine", spec.name),
        ("cylinders", ", ".join(f"{c.name} (bank {c.bank:g} deg, firing TDC +{c.firing:g})" for c in spec.cylinders)),
        ("crank r / rod l / λ / offset", f"{spec.crank_radius * 1e3:g} mm / {spec.rod_length * 1e3:g} mm / "
                                         f"{spec.lam:.6g} / {spec.offset * 1e3:g} mm"),
        ("stroke (exact) / swept volume", f"{spec.stroke * 1e3:.6f} mm / {spec.swept_volume * 1e6:.4f} cm3 per cylinder"),
        ("speed", f"{spec.rpm:g} rpm = {spec.omega:.6g} rad/s"),
        ("firing angles / intervals", "/".join(f"{x:g}" for x in cyc["firing_angles"]) + " deg / "
                                      + "/".join(f"{x:g}" for x in cyc["firing_intervals"]) + " deg, order "
                                      + "-".join(cyc["firing_order"])),
        ("λ-approximation max error", f"s {e['s']['max_abs'] * 1e6:.4g} µm, v {e['v']['max_abs']:.4g} m/s, "
                                      f"a {e['a']['max_abs']:.4g} m/s² ({100 * e['a']['max_rel']:.3f} %)"),
        ("peak acceleration (exact)", f"{np.abs(res.acceleration).max():.6g} m/s²"),
        ("indicated work W_ind", f"{W:.6g} J per cycle ({W * spec.rpm / 120.0 / 1e3:.4g} kW indicated)"),
        ("∮ M_b dφ", f"{res.cycle_integral:.6g} J (−W_ind = {-W:.6g} J)"),
        ("balancing moment min / max / mean", f"{res.balancing.min():.6g} / {res.balancing.max():.6g} / "
                                              f"{res.cycle_integral / (4 * np.pi):.6g} N m"),
        ("peak |R12| crank pin / |R01| bearing", f"{np.linalg.norm(res.reactions['R12'], axis=-1).max():.6g} N / "
                                                 f"{np.linalg.norm(res.reactions['R01'], axis=-1).max():.6g} N"),
        ("min radius of curvature of rod COM", f"{np.min(res.rod_com_radius) * 1e3:.6g} mm"),
        ("virtual power residual (max)", f"{np.nanmax(np.abs(res.virtual_power_residual)):.3g} W"),
    ]
    if res.general_check:
        g = res.general_check
        rows.append(("general kinetostatics vs closed form", f"|ΔM_b| ≤ {g['max_balancing_difference']:.3g} N m "
                     f"(relative {g['relative_balancing_difference']:.2g}), method {g['method']}"))
    width = max(len(k) for k, _ in rows)
    for k, v in rows:
        print(f"  {k:<{width}}  {v}")
    return 0
