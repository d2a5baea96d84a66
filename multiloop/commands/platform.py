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


from multiloop.kin.spatial.platform import NORMALISATIONS, load_platform
from multiloop.kin.spatial.report import platform_report
from multiloop.inputs import resolve
from multiloop.outputs import emit, Outputs, quiet_warnings

__all__ = ["add_arguments", "run"]

def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", metavar="FILE",
                        help="platform file (.toml/.json) or a bundled name, e.g. doronin_platform")
    parser.add_argument("--json", action="store_true", help="print a JSON report (keys: docs/platform.md)")
    parser.add_argument("--plot", metavar="PNG", help="draw platform, struts coloured by force, screw axes")
    parser.add_argument("--modes", choices=NORMALISATIONS, default=NORMALISATIONS[0],
                        help="normalisation of the printed mode shapes: x = 1 as in Doronin 2015 (default), "
                             "phi^T A phi = 1, or largest component = 1 (JSON always has 'shape' mass-normalised "
                             "and 'shape_x1')")


def run(args: argparse.Namespace) -> int:
    outs = Outputs("multiloop platform")
    outs.figure_target(args.plot)
    platform = load_platform(resolve(args.file, ("platforms",)))
    rep = platform_report(platform, args.modes)
    if args.plot is not None:
        from multiloop.kin.figures.platform import plot_platform

        with quiet_warnings("multiloop platform"):
            outs.add_figure(args.plot, plot_platform(platform), dpi=120)
        outs.commit()
    emit(rep, args.json)
    if args.plot and not args.json:
        print(f"\nplot written to {args.plot}")
    return 0
