"""``multiloop platform FILE [--json] [--plot out.png]``: six-strut platform report.

Prints the strut forces (tension positive, by virtual velocities and by the six
equilibrium equations), the kinematic screw of the platform with each strut
removed (pitch, axis point, axis direction), and, when every strut has a stiffness
and the file has a ``[body]``, the natural circular frequencies and mode shapes.
FILE may also name a bundled platform (``doronin_platform``, ``gough_stewart``).
JSON keys are documented in docs/platform.md.
"""
from __future__ import annotations

import argparse
import json
import math


from multiloop.kin.spatial.platform import load_platform
from multiloop.kin.spatial.report import platform_report
from multiloop.inputs import resolve
from multiloop.outputs import Outputs, figure_formats, quiet_warnings

__all__ = ["add_arguments", "run"]

_SYMBOL = {"x": "x", "y": "y", "z": "z", "phi_x": "φx", "phi_y": "φy", "phi_z": "φz"}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", metavar="FILE",
                        help="platform file (.toml/.json) or a bundled name, e.g. doronin_platform")
    parser.add_argument("--json", action="store_true", help="print a JSON report (keys: docs/platform.md)")
    parser.add_argument("--plot", metavar="PNG", help="draw platform, struts coloured by force, screw axes")
    parser.add_argument("--modes", choices=("first", "mass", "max"), default="first",
                        help="normalisation of the printed mode shapes: x = 1 as in Doronin 2015 (default), "
                             "phi^T A phi = 1, or largest component = 1 (JSON always has 'shape' mass-normalised "
                             "and 'shape_x1')")


def _fmt(v, width=10, prec=4) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "—".rjust(width)
    return f"{v:{width}.{prec}f}"


def _text(rep: dict) -> str:
    lines = [f"platform: {rep['name']}"]
    if rep["source"]:
        lines.append(f"source:   {rep['source']}")
    lines.append("conventions: tension positive; e_i from platform hinge to base hinge; "
                 "moments about the file's origin (r × F); twists (ω; v_O)")
    lines.append(f"condition number (dimensionless Plücker matrix): {rep['condition_number']:.4g}")
    lines.append("")
    lines.append("strut forces (N, tension +)")
    lines.append(f"  {'strut':<6}{'equilibrium':>16}{'screw method':>16}")
    for s, a, b in zip(rep["screws"], rep["forces"], rep["forces_screws"]):
        lines.append(f"  {s['strut']:<6}{a:16.4f}{b:16.4f}")
    lines.append(f"  max difference between the methods: {rep['discrepancy']:.2g} N")
    lines.append("")
    lines.append("kinematic screw with strut i removed (unit twist ω; v_O) and its axis")
    lines.append(f"  {'strut':<6}{'ω':>26}{'v_O':>28}{'pitch (m)':>12}{'axis point (m)':>28}  {'direction':>26}")
    for s in rep["screws"]:
        tw = s["twist"]
        om = "(" + ", ".join(f"{v:7.4f}" for v in tw[:3]) + ")"
        vo = "(" + ", ".join(f"{v:7.4f}" for v in tw[3:]) + ")"
        pitch = "∞ (transl.)" if s["translation"] else f"{s['pitch']:.4f}"
        ap = "—" if s["axis_point"] is None else "(" + ", ".join(f"{v:7.4f}" for v in s["axis_point"]) + ")"
        ad = "(" + ", ".join(f"{v:7.4f}" for v in s["axis_direction"]) + ")"
        lines.append(f"  {s['strut']:<6}{om:>26}{vo:>28}{pitch:>12}{ap:>28}  {ad:>26}")
    lines.append("")
    if rep["frequencies"] is None:
        lines.append("vibrations: skipped (needs a stiffness on every strut and a [body] table)")
        return "\n".join(lines)
    lines.append("natural circular frequencies")
    for m, hz in zip(rep["modes"], rep["frequencies_hz"]):
        lines.append(f"  {m['label']}   [{hz:.4f} Hz]")
    lines.append("")
    how = {"first": "x = 1 as printed by Doronin 2015", "mass": "mass-normalised, φᵀAφ = 1",
           "max": "largest component = 1"}[rep["modes_normalisation"]]
    lines.append(f"mode shapes (columns by ascending frequency; {how})")
    header = "".join(f"{'k=' + format(m['frequency'], '.2f'):>12}" for m in rep["modes"])
    lines.append(f"  {'':<6}{header}")
    for i, c in enumerate(rep["coordinates"]):
        row = ""
        for m in rep["modes"]:
            v = None if m["shape_printed"] is None else m["shape_printed"][i]
            row += "           —" if v is None else f"{v:12.3f}"
        lines.append(f"  {_SYMBOL[c]:<6}{row}")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    outs = Outputs("multiloop platform")
    if args.plot is not None:
        outs.target(args.plot, "--plot", formats=("",) + figure_formats())
    platform = load_platform(resolve(args.file, ("platforms",)))
    rep = platform_report(platform, args.modes)
    if args.plot is not None:
        from multiloop.kin.figures.platform import plot_platform

        with quiet_warnings("multiloop platform"):
            outs.add_figure(args.plot, plot_platform(platform), dpi=120)
        outs.commit()
    if args.json:
        print(json.dumps(rep, indent=2, ensure_ascii=False, allow_nan=False))
    else:
        print(_text(rep))
        if args.plot:
            print(f"\nplot written to {args.plot}")
    return 0
