"""Which compiled step solves which plan step: the one map from a group's kind to the
adapter next to its kernel (see :mod:`kin.groups.step` for the protocol)."""
from __future__ import annotations

from multiloop.topo.assur import DriverStep, GroupKind

from .actuator import ActuatorStep
from .class4 import Class4Step
from .driver import DriverStepSolver, is_closed_form
from .newton import NewtonStep
from .prp import PRPStep
from .rpp import RPPStep
from .rpr import RPRStep
from .rrp import RRPStep
from .rrr import RRRStep
from .step import GroupStep
from .triad import TriadStep

__all__ = ["CLOSED_FORM", "closed_form_step", "newton_step"]

#: group kind -> its closed-form step
CLOSED_FORM: dict[GroupKind, type[GroupStep]] = {
    GroupKind.RRR: RRRStep, GroupKind.RRP: RRPStep, GroupKind.RPR: RPRStep,
    GroupKind.PRP: PRPStep, GroupKind.RPP: RPPStep, GroupKind.TRIAD: TriadStep,
    GroupKind.CLASS_IV: Class4Step, GroupKind.ACTUATED: ActuatorStep,
}


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
