"""The JSON-ready report of a platform: statics always, vibrations when the file has
the data (keys in docs/platform.md; Doronin 2015)."""
from __future__ import annotations

import math
from dataclasses import dataclass

from .platform import COORDINATES, Platform, platform_modes, platform_statics

__all__ = ["CONVENTIONS", "PlatformReport", "platform_report", "report_text"]

#: the sign and frame conventions, as printed in every report
CONVENTIONS = {
    "forces": "N, tension positive: strut i pulls the platform hinge towards the base hinge; "
              "'forces' from the six equilibrium equations, 'forces_screws' by virtual velocities",
    "strut_direction": "e_i = unit vector from the platform hinge to the base hinge",
    "screws": "Plücker (direction; moment about the file's origin), moment = r x d",
    "twist": "(omega; v_O), unit |omega| = 1 (|v| = 1 for a translation), signed so strut i lengthens",
    "frequencies": "rad/s, ascending",
    "modes": "q = (x, y, z, phi_x, phi_y, phi_z) of the centre of mass",
}


@dataclass(frozen=True)
class PlatformReport:
    """The report of ``multiloop platform``: its JSON document (:meth:`as_dict`, keys in
    docs/platform.md) and its text (:meth:`to_text`)."""

    doc: dict

    def as_dict(self) -> dict:
        return self.doc

    def to_text(self) -> str:
        return report_text(self.doc)


def platform_report(platform: Platform, normalise: str = "first") -> PlatformReport:
    """Statics (:meth:`PlatformStatics.as_dict`) and, when every strut has a stiffness
    and the body is given, the modes (:meth:`PlatformModes.as_dict`)."""
    out = {"name": platform.name, "source": platform.source, "conventions": dict(CONVENTIONS),
           **platform_statics(platform).as_dict(), "coordinates": list(COORDINATES),
           "frequencies": None, "frequencies_hz": None, "modes": None}
    if platform.has_vibration_data:
        out.update(platform_modes(platform).as_dict(normalise))
    return PlatformReport(out)


_SYMBOL = {"x": "x", "y": "y", "z": "z", "phi_x": "φx", "phi_y": "φy", "phi_z": "φz"}


def _fmt(v, width=10, prec=4) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "—".rjust(width)
    return f"{v:{width}.{prec}f}"


def report_text(rep: dict) -> str:
    """Readable form of :func:`platform_report` (``multiloop platform``): strut forces by
    both methods, the screw of each strut-removed chain, frequencies and mode shapes."""
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
