"""The units the page shows and reads: mm, m or in for lengths, deg or rad for angles.

Files, exports and the ``check --json`` document keep the command line's units (m and
deg); only what the page shows (the edit row, the player's readout, the check's verdict
and events, plot axes and status lines, the Synthesis tab's errors, deviations, bounds
and timing) and what is typed or uploaded into it (a target table, :func:`table_in_si`)
are converted, by one frozen :class:`Units` value.  (The Structure tab shows counts
and codes only: no length or angle.)  A quantity is named by its command-line unit,
``"m"`` or ``"deg"``, as :attr:`multiloop.web.scene.Sweep.unit` names a driver's.

Examples
--------
>>> u = Units("mm", "rad")
>>> u.shown(0.12, "m"), u.label("m"), u.label("deg")
(120.0, 'mm', 'rad')
>>> u.typed("120", "m")
0.12
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from multiloop.topo.errors import InputError, explain

__all__ = ["Units", "UnitsBar", "LENGTHS", "ANGLES", "table_in_si"]

#: display units of a length: how many of them make a metre
LENGTHS = {"mm": 1000.0, "m": 1.0, "in": 1.0 / 0.0254}
#: display units of an angle: how many of them make a degree
ANGLES = {"deg": 1.0, "rad": math.pi / 180.0}


@dataclass(frozen=True, slots=True)
class Units:
    """The page's display units: ``length`` (a key of :data:`LENGTHS`) and ``angle`` (a
    key of :data:`ANGLES`).

    Raises
    ------
    InputError
        A unit that is not one of them.
    """

    length: str = "m"
    angle: str = "deg"

    def __post_init__(self):
        if self.length not in LENGTHS:
            raise InputError(explain("length unit", expected=" or ".join(LENGTHS), got=repr(self.length)))
        if self.angle not in ANGLES:
            raise InputError(explain("angle unit", expected=" or ".join(ANGLES), got=repr(self.angle)))

    def scale(self, unit: str) -> float:
        """Display units per command-line ``unit`` (``"m"`` or ``"deg"``)."""
        return LENGTHS[self.length] if unit == "m" else ANGLES[self.angle]

    def label(self, unit: str) -> str:
        """The display unit of a quantity in command-line ``unit``."""
        return self.length if unit == "m" else self.angle

    def shown(self, value: float, unit: str) -> float:
        """``value`` (in command-line ``unit``) in the display unit."""
        return float(value) * self.scale(unit)

    def typed(self, text, unit: str, what: str = "value") -> float:
        """A number typed in the display unit, in command-line ``unit``.

        Raises
        ------
        InputError
            ``text`` is not a finite number.
        """
        try:
            v = float(text)
        except (TypeError, ValueError):
            v = math.nan
        if not math.isfinite(v):
            raise InputError(explain(what, expected=f"a finite number (in {self.label(unit)})", got=repr(text)))
        return v / self.scale(unit)


def table_in_si(table, units: Units, rotary: bool = True):
    """A target table uploaded to the page (rows x, y and an optional input), read in
    the page's ``units``: x and y in its length unit, the input in its angle unit
    (``rotary``, a turning driver) or its length unit (a slider); returned in m and
    deg (or m), as a table file of ``multiloop synthesise`` holds them.

    Examples
    --------
    >>> table_in_si([[120.0, 30.0, 90.0]], Units("mm", "deg")).tolist()
    [[0.12, 0.03, 90.0]]
    """
    import numpy as np
    out = np.array(table, float)
    out[:, :2] /= units.scale("m")
    if out.shape[1] > 2:
        out[:, 2] /= units.scale("deg" if rotary else "m")
    return out


class UnitsBar:
    """The header's two unit menus; each new choice goes to ``views`` (their
    ``use_units(units)``)."""

    def __init__(self, say, views):
        from .menus import Menu
        self.units = Units()
        self.lengths = Menu("length unit menu", say, list(LENGTHS), "m", title="length", width=70,
                            css_classes=["ml-length-unit"])
        self.angles = Menu("angle unit menu", say, list(ANGLES), "deg", title="angle", width=70,
                           css_classes=["ml-angle-unit"])
        self.views = tuple(views)
        self.lengths.on_choice(lambda v: self._set())
        self.angles.on_choice(lambda v: self._set())
        self.widgets = (self.lengths.select, self.angles.select)

    def add(self, view) -> None:
        """A view made later (the Synthesis tab, on its first opening): it gets the
        units chosen now and every new choice."""
        self.views += (view,)
        view.use_units(self.units)

    def _set(self) -> None:
        self.units = Units(self.lengths.value, self.angles.value)
        for v in self.views:
            v.use_units(self.units)
