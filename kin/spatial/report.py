"""The JSON-ready report of a platform: statics always, vibrations when the file has
the data (keys in docs/platform.md; Doronin 2015)."""
from __future__ import annotations

from .platform import COORDINATES, Platform, platform_modes, platform_statics

__all__ = ["CONVENTIONS", "platform_report"]

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


def platform_report(platform: Platform, normalise: str = "first") -> dict:
    """Statics (:meth:`PlatformStatics.as_dict`) and, when every strut has a stiffness
    and the body is given, the modes (:meth:`PlatformModes.as_dict`)."""
    out = {"name": platform.name, "source": platform.source, "conventions": dict(CONVENTIONS),
           **platform_statics(platform).as_dict(), "coordinates": list(COORDINATES),
           "frequencies": None, "frequencies_hz": None, "modes": None}
    if platform.has_vibration_data:
        out.update(platform_modes(platform).as_dict(normalise))
    return out
