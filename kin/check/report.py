"""The frozen result of a design check, its JSON form and its text form."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..result import json_ready
from .angle_types import ANGLE_TYPES, angle_type
from .events import Extreme

__all__ = ["AngleResult", "DriverAngles", "DriverCheck", "GroupCircuit", "CheckReport"]


def _deg(x: float, rotary: bool) -> float:
    """Driver value for the report: degrees in [0, 360) for R, metres for P."""
    if not rotary:
        return float(x)
    d = float(np.degrees(x)) % 360.0
    return 0.0 if d >= 360.0 - 1e-9 else d


@dataclass(frozen=True)
class AngleResult:
    """Extremes of one monitored angle (degrees) over a driver's reachable motion."""

    joint: str
    quantity: str           # its type's name (kin.check.angle_types.ANGLE_TYPES)
    group: str
    extreme: Extreme | None

    def flagged(self, threshold: float) -> bool:
        """Whether an extreme comes within ``threshold`` (deg) of a degenerate value of
        the angle's type (:meth:`~kin.check.angle_types.AngleType.flagged`)."""
        e = self.extreme
        return e is not None and angle_type(self.quantity).flagged(e.min, e.max, threshold)


@dataclass(frozen=True)
class DriverAngles:
    """Range of motion of one driver and the exact extremes of every monitored angle over
    it: the part of a :class:`DriverCheck` that a screen of many designs asks for
    (:func:`multiloop.kin.check.driver_angles`)."""

    joint: str
    rotary: bool
    full_rotation: bool
    limits: tuple[float, ...]                       # signed, forward then backward
    angles: tuple[AngleResult, ...]

    def flagged(self, threshold: float) -> tuple[AngleResult, ...]:
        """The angles that come closer than ``threshold`` (degrees) to a toggle."""
        return tuple(a for a in self.angles if a.flagged(threshold))


@dataclass(frozen=True)
class GroupCircuit:
    """Assembly modes of one group at the reference and how many continuous motion reaches."""

    group: str
    kind: str
    modes: int | None
    reachable: int | None
    note: str

    def as_dict(self) -> dict:
        return {"group": self.group, "kind": self.kind, "modes": self.modes,
                "reachable": self.reachable, "note": self.note}


@dataclass(frozen=True)
class DriverCheck:
    """Everything computed while one driver moves (values in rad or m from the reference)."""

    joint: str
    rotary: bool
    full_rotation: bool
    periodic: bool
    limits: tuple[float, ...]                       # signed, forward then backward
    limit_groups: tuple[str, ...]
    branch_points: tuple[tuple[float, str], ...]
    dead_centres: tuple[tuple[str, tuple[float, ...]], ...]
    angles: tuple[AngleResult, ...]
    output: str | None
    output_unit: str
    ratio_x: np.ndarray = field(repr=False)
    ratio: np.ndarray = field(repr=False)
    unreachable: tuple[float, ...] = ()
    ratio_unbounded_at: tuple[float, ...] = ()     # limits where the velocity ratio has no bound
    ratio_extreme: object = None                   # Extreme of |velocity ratio| (exact, not the grid's)
    driver_range: tuple[float, float] | None = None  # the driver's own range (file), rad or m
    binds: tuple[str, ...] = ()                    # per limit: "assembly" or "range"

    @property
    def usable(self) -> tuple[float, float] | None:
        """The usable range (low, high) from the reference: the driver's range cut by
        the assembly limits (None for a full rotation or no limit at all)."""
        if not self.limits:
            return None
        return (min(self.limits), max(self.limits))

    def bound_at(self, end: str) -> str | None:
        """What stops the motion at its ``"low"`` or ``"high"`` end."""
        for x, b in zip(self.limits, self.binds):
            if (x > 0.0) == (end == "high") or (x == 0.0 and end == "low"):
                return b
        return None

    @property
    def unit(self) -> str:
        return "deg" if self.rotary else "m"

    def value(self, x: float) -> float:
        return _deg(x, self.rotary)

    def as_dict(self) -> dict:
        v = self.value
        d = {"kind": "R" if self.rotary else "P", "unit": self.unit,
             "full_rotation": self.full_rotation,
             "limits": sorted(v(x) for x in self.limits),
             "range": ([float(np.degrees(min(self.limits, default=0.0))),
                        float(np.degrees(max(self.limits, default=0.0)))] if self.rotary
                       else [min(self.limits, default=None), max(self.limits, default=None)])
             if self.limits else None,
             "limit_groups": list(self.limit_groups),
             "driver_range": (None if self.driver_range is None else
                              [float(np.degrees(x)) if self.rotary else x for x in self.driver_range]),
             "usable_range": (None if self.usable is None or (self.rotary and self.driver_range is None)
                              else [float(np.degrees(x)) if self.rotary else x for x in self.usable]),
             "binds": {e: self.bound_at(e) for e in ("low", "high")} if self.limits else None,
             "periodic": self.periodic,
             "branch_points": [{"at": v(x), "group": g} for x, g in self.branch_points],
             "dead_centres": {k: sorted(v(x) for x in xs) for k, xs in self.dead_centres},
             "angles": {a.joint: _angle_dict(a, v) for a in self.angles},
             "unreachable_positions": [v(x) for x in self.unreachable]}
        if self.output is not None:
            d["mechanical_advantage"] = {
                "output": self.output, "velocity_ratio_unit": self.output_unit,
                "input": [v(x) for x in self.ratio_x],
                "velocity_ratio": [None if not np.isfinite(y) else float(y) for y in self.ratio],
                "max_abs_velocity_ratio": (None if self.ratio_unbounded_at or self.ratio_extreme is None
                                           else float(self.ratio_extreme.max)),
                "min_abs_velocity_ratio": None if self.ratio_extreme is None else float(self.ratio_extreme.min),
                "unbounded_at": [v(x) for x in self.ratio_unbounded_at]}
        return d


def _angle_dict(a: AngleResult, v) -> dict:
    e = a.extreme
    if e is None:
        return {"quantity": a.quantity, "group": a.group, "min": None, "max": None}
    return {"quantity": a.quantity, "group": a.group, "min": e.min, "at_min": v(e.at_min),
            "max": e.max, "at_max": v(e.at_max)}


@dataclass(frozen=True)
class CheckReport:
    """Result of :func:`multiloop.kin.check.check` (see docs/check.md for every key)."""

    mechanism: str
    formula: str
    min_transmission: float
    drivers: tuple[DriverCheck, ...]
    circuits: tuple[GroupCircuit, ...]
    grashof: tuple
    instant_centres: tuple
    instant_centres_at: tuple[float, ...]
    verdict: tuple[str, ...]
    workspace: object = None                       # Workspace of --workspace POINT, or None

    def _repr_html_(self) -> str:
        """Notebook view: verdict and drivers, bars of the transmission ranges."""
        from multiloop.kin.notebook import check_html  # noqa: PLC0415 - only when a notebook asks
        return check_html(self)

    @property
    def ok(self) -> bool:
        return not self.verdict

    def to_text(self) -> str:
        """The text report of ``multiloop check`` (:func:`kin.check.text.format_report`)."""
        from .text import format_report
        return format_report(self).rstrip("\n")

    def as_dict(self) -> dict:
        """JSON-ready dict with the documented keys (NaN and infinities as ``None``)."""
        first = self.drivers[0] if self.drivers else None
        tables = {name: {} for name in ANGLE_TYPES}
        dead = {}
        for dc in self.drivers:
            for a in dc.angles:
                if a.extreme is None:
                    continue
                tgt = tables[a.quantity]
                cur = tgt.get(a.joint)
                e = a.extreme
                if cur is None or e.min < cur["min"] or e.max > cur["max"]:
                    tgt[a.joint] = {"min": min(e.min, cur["min"]) if cur else e.min,
                                    "max": max(e.max, cur["max"]) if cur else e.max,
                                    "quantity": a.quantity, "driver": dc.joint}
        if first is not None:
            dead = {k: sorted(first.value(x) for x in xs) for k, xs in first.dead_centres}
        summaries = {t.summary: {j: {k: v[k] for k in t.summary_keys} for j, v in tables[name].items()}
                     for name, t in ANGLE_TYPES.items()}
        return json_ready({
            "mechanism": self.mechanism, "formula": self.formula,
            "min_transmission": self.min_transmission,
            "drivers": {dc.joint: dc.as_dict() for dc in self.drivers},
            **summaries,
            "dead_centres": dead,
            "circuits": [c.as_dict() for c in self.circuits],
            "branch_points": [{"driver": dc.joint, "at": dc.value(x), "group": g}
                              for dc in self.drivers for x, g in dc.branch_points],
            "grashof": [g.as_dict() for g in self.grashof],
            "instant_centres": {"at": list(self.instant_centres_at),
                                "centres": [c.as_dict() for c in self.instant_centres]},
            "mechanical_advantage": {dc.joint: dc.as_dict().get("mechanical_advantage")
                                     for dc in self.drivers},
            "verdict": list(self.verdict),
            "ok": self.ok,
            **({"workspace": self.workspace.as_dict()} if self.workspace is not None else {}),
        })
