"""Which compiled step solves which plan step: the one map from a group's kind to the
adapter next to its kernel (see :mod:`kin.groups.step` for the protocol), the map from
a lowered step to its scalar function for the compiled kernel (:mod:`kin.kernel`), and the
per-kind facts the design check asks for (:mod:`kin.groups.facts`): the number of
assembly modes and the transmission definition."""
from __future__ import annotations

from typing import Callable, NamedTuple

from multiloop.topo.assur import DriverStep, GroupKind

from .actuator import ActuatorStep, actuator_place
from .class4 import Class4Step
from .driver import DriverStepSolver, is_closed_form, slide_place, turn_place
from . import facts as F
from .newton import NewtonStep
from .prp import PRPStep, prp_place
from .rpp import RPPStep, rpp_place
from .rpr import RPRStep, rpr_place
from .rrp import RRPStep, rrp_place
from .rrr import RRRStep, rrr_place
from .step import GroupStep
from .triad import TriadStep

__all__ = ["CLOSED_FORM", "COMPILED", "FACTS", "KindFacts", "closed_form_step", "newton_step", "has_closed_form",
           "mode_count", "angle_defs"]

#: group kind -> its closed-form step
CLOSED_FORM: dict[GroupKind, type[GroupStep]] = {
    GroupKind.RRR: RRRStep, GroupKind.RRP: RRPStep, GroupKind.RPR: RPRStep,
    GroupKind.PRP: PRPStep, GroupKind.RPP: RPPStep, GroupKind.TRIAD: TriadStep,
    GroupKind.CLASS_IV: Class4Step, GroupKind.ACTUATED: ActuatorStep,
}


#: a compiled step's key (:attr:`~kin.groups.step.Lowered.key`) -> its scalar function,
#: which :mod:`kin.kernel` compiles with numba (a kind absent here: NumPy path)
COMPILED: dict = {
    "drive_R": turn_place, "drive_P": slide_place, GroupKind.RRR: rrr_place, GroupKind.RRP: rrp_place,
    GroupKind.RPR: rpr_place, GroupKind.PRP: prp_place, GroupKind.RPP: rpp_place,
    GroupKind.ACTUATED: actuator_place,
}


class KindFacts(NamedTuple):
    """What the check asks of a kind: ``modes(m, group)`` (assembly modes at the
    reference) and ``angles(m, group)`` (its monitored angles, :class:`~kin.groups.facts.AngleDef`)."""

    modes: Callable
    angles: Callable


#: group kind -> its check facts (a kind absent here: modes not enumerated, no angle)
FACTS: dict[GroupKind, KindFacts] = {
    GroupKind.RRR: KindFacts(F.two_modes, F.triangle_angles),
    GroupKind.RRP: KindFacts(F.two_modes, F.rrp_angles),
    GroupKind.RPR: KindFacts(F.two_modes, F.rpr_angles),
    GroupKind.PRP: KindFacts(F.one_mode, F.no_angles),
    GroupKind.RPP: KindFacts(F.one_mode, F.no_angles),
    GroupKind.TRIAD: KindFacts(F.triad_mode_count, F.triad_angles),
    GroupKind.CLASS_IV: KindFacts(F.class4_mode_count, F.no_angles),
    GroupKind.ACTUATED: KindFacts(F.two_modes, F.triangle_angles),
}


def has_closed_form(kind) -> bool:
    """Does a group of ``kind`` have a closed-form (or all-modes) kernel?"""
    return kind in CLOSED_FORM


def mode_count(m, g) -> int | None:
    """Assembly modes of group ``g`` at the reference, or None when they are not
    enumerated (no kernel for its kind, or the count failed)."""
    f = FACTS.get(g.kind)
    if f is None or g.layout is None:
        return None
    try:
        return int(f.modes(m, g))
    except Exception:  # noqa: BLE001 - a count we cannot make is reported as unknown
        return None


def angle_defs(m, g) -> tuple:
    """The monitored angles of group ``g`` (empty for a kind without a definition)."""
    f = FACTS.get(g.kind)
    return () if f is None or g.layout is None else tuple(f.angles(m, g))


def closed_form_step(mechanism, st, size: float) -> GroupStep | None:
    """The closed-form step of plan step ``st``, or None when its kind has none (it is
    then solved by :func:`newton_step`)."""
    s = st.step
    if isinstance(s, DriverStep):
        return DriverStepSolver(mechanism, st, size) if is_closed_form(s) else None
    kind = CLOSED_FORM.get(s.kind)
    return None if kind is None or s.layout is None else kind(mechanism, st, size)


def newton_step(mechanism, st, size: float) -> GroupStep:
    """Newton with continuation: any step."""
    return NewtonStep(mechanism, st, size)
