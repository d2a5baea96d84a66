"""``multiloop engine FILE [--steps N] [--json] [--plot DIR]``: the diagrams of Vasilenko et al. 2018.

FILE is an engine file (``[engine]``, ``[[cylinder]]``, ``[gas]``; docs/forces.md) or
the name of a bundled one (``single_cylinder``, ``v_twin``, ``radial_5cyl_masses``).
Prints the main numbers (stroke, λ, swept volume, firing intervals, λ-approximation
error, indicated work, ∮M_b dφ, peak reactions, the virtual-power check and the
general-kinetostatics cross-check); ``--json`` gives every array; ``--plot DIR`` writes
kinematics, pressure, balancing, cyclogram, rod_com and reactions PNGs.
"""
from __future__ import annotations

from pathlib import Path


from multiloop.kin.engine import MAX_STEPS, analyse_engine, load_engine
from multiloop.inputs import resolve
from multiloop.outputs import emit, Outputs, quiet_warnings
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
    emit(res, args.json)
    return 0
