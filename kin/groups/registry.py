"""The group kinds: the one map from a group's kind to the adapter next to its kernel.

Each adapter (a :class:`~kin.groups.step.GroupStep` subclass, see :mod:`kin.groups.step`
for the protocol) solves its kind and declares the kind's facts; the library asks them
here and never switches on the kind:

* the solver's step (:func:`closed_form_step`, :mod:`kin.solve`; batches of designs,
  :mod:`kin.design`) and the advice for a singular reference (:func:`singular_hint`);
* the compiled kernel's scalar function (:data:`COMPILED`, :mod:`kin.kernel`) and its
  lowering of a batch of designs (:data:`LOWERING`);
* the design check's assembly modes and monitored angles (:func:`mode_count`,
  :func:`angle_defs`, :mod:`kin.check`), which the synthesis's transmission constraint
  reads too;
* the synthesis's margin of a reference configuration (:func:`reference_margin`,
  ``catalogue.dimensional``);
* the decomposition's hook that gives a group a kind registered at run time (the
  adapter's ``relabel``, added to :func:`topo.assur.add_kind_rule` by :func:`register`).

A new kind is one adapter class next to its kernel and one entry in :data:`BUILT_IN`,
or, without editing the library, :func:`register` (or the block :func:`registered`).
"""
from __future__ import annotations

import contextlib

from multiloop.topo.assur import AssurGroup, DriverStep, GroupKind, add_kind_rule, remove_kind_rule

from .actuator import ActuatorStep
from .class4 import Class4Step
from .driver import DriverStepSolver, is_closed_form, slide_lower, slide_place, turn_lower, turn_place
from .newton import NewtonStep
from .prp import PRPStep
from .rpp import RPPStep
from .rpr import RPRStep
from .rrp import RRPStep
from .rrr import RRRStep
from .step import GroupStep
from .triad import TriadStep

__all__ = ["BUILT_IN", "KINDS", "CLOSED_FORM", "COMPILED", "LOWERING", "TRACKED", "register", "unregister",
           "registered", "adapter_of", "closed_form_step", "newton_step", "has_closed_form", "mode_count", "angle_defs",
           "reference_margin", "singular_hint"]

#: the library's closed-form adapters, in the compiled kernel's order
BUILT_IN: tuple[type[GroupStep], ...] = (RRRStep, RRPStep, RPRStep, PRPStep, RPPStep, TriadStep, Class4Step,
                                         ActuatorStep)

#: group kind -> its closed-form adapter (the built-in ones and those registered since)
KINDS: dict[object, type[GroupStep]] = {a.kind: a for a in BUILT_IN}
#: the same map under its first name
CLOSED_FORM = KINDS


def _has_rule(adapter) -> bool:
    return adapter.relabel.__func__ is not GroupStep.relabel.__func__


for _a in BUILT_IN:                 # a library kind the decomposition does not know by itself
    if _has_rule(_a):
        add_kind_rule(_a.relabel)
del _a

#: a compiled step's key (:attr:`~kin.groups.step.Lowered.key`) -> its scalar function,
#: which :mod:`kin.kernel` compiles with numba (a kind absent here: NumPy path); fixed when
#: the kernel is imported, so a kind registered at run time reuses a key or has none
COMPILED: dict = {"drive_R": turn_place, "drive_P": slide_place,
                  **{a.kind: a.compiled for a in BUILT_IN if a.compiled is not None}}
#: a compiled step's key -> its lowering of a batch of designs (the adapter's
#: ``compiled_lower``, compiled with the kernel: :func:`kin.kernel.lower_designs`); a key
#: absent here is lowered by the adapter's own :meth:`~kin.groups.step.GroupStep.lower`
LOWERING: dict = {"drive_R": turn_lower, "drive_P": slide_lower,
                  **{a.kind: a.compiled_lower for a in BUILT_IN if a.compiled_lower is not None}}


#: the compiled steps' keys whose step follows a mode along the inputs (the adapter's
#: ``tracked``): batches of designs run them, ``solve``'s kernels never do
TRACKED: frozenset = frozenset(a.kind for a in BUILT_IN if a.compiled is not None and a.tracked)


def register(adapter: type[GroupStep]) -> None:
    """Add a group kind at run time: ``adapter`` names it (``adapter.kind``, a string not
    yet registered) and declares its facts (:mod:`kin.groups.step`); its ``relabel`` is
    the decomposition's rule for the groups of the kind.  Register before the
    mechanisms are decomposed: a plan made earlier keeps its kinds."""
    taken = {str(k) for k in (*KINDS, *GroupKind)}
    if not isinstance(adapter.kind, str) or str(adapter.kind) in taken:
        raise ValueError(f"group kind: expected a new kind name (not {', '.join(sorted(taken))}), "
                         f"got {adapter.kind!r}")
    KINDS[adapter.kind] = adapter
    if _has_rule(adapter):
        add_kind_rule(adapter.relabel)


def unregister(kind) -> None:
    """Remove a kind added by :func:`register` (a built-in kind stays)."""
    adapter = KINDS.get(kind)
    if adapter is None or adapter in BUILT_IN:
        raise ValueError(f"group kind: expected a registered kind, got {kind!r}")
    del KINDS[kind]
    if _has_rule(adapter):
        remove_kind_rule(adapter.relabel)


@contextlib.contextmanager
def registered(adapter: type[GroupStep]):
    """A block in which ``adapter``'s kind is registered (:func:`register`)."""
    register(adapter)
    try:
        yield adapter
    finally:
        unregister(adapter.kind)


def adapter_of(group) -> type[GroupStep] | None:
    """The closed-form adapter of an Assur group, or None (no kernel for its kind, no
    layout, or a driver step)."""
    if not isinstance(group, AssurGroup) or group.layout is None:
        return None
    return KINDS.get(group.kind)


def has_closed_form(kind) -> bool:
    """Does a group of ``kind`` have a closed-form (or all-modes) kernel?"""
    return kind in KINDS


def mode_count(m, g) -> int | None:
    """Assembly modes of group ``g`` at the reference, or None when they are not
    enumerated (no kernel for its kind, or the count failed)."""
    a = adapter_of(g)
    if a is None:
        return None
    try:
        n = a.assembly_modes(m, g)
    except Exception:  # noqa: BLE001 - a count we cannot make is reported as unknown
        return None
    return None if n is None else int(n)


def angle_defs(m, g) -> tuple:
    """The monitored angles of group ``g`` (empty for a kind without a definition)."""
    a = adapter_of(g)
    return () if a is None else tuple(a.monitored_angles(m, g))


def reference_margin(m, g, at, axis):
    """The relative determinant ``(P,)`` of group ``g`` in designs' reference
    configurations (``at(joint)``, ``axis(joint)``: ``(P, 2)``), or None for a kind
    without one."""
    a = adapter_of(g)
    return None if a is None else a.reference_margin(m, g, at, axis)


def singular_hint(step) -> str | None:
    """The advice when plan step ``step`` is singular in the reference (None: the
    general one)."""
    a = KINDS.get(step.kind) if isinstance(step, AssurGroup) else None
    return None if a is None else a.singular_hint


def closed_form_step(mechanism, st, size: float) -> GroupStep | None:
    """The closed-form step of plan step ``st``, or None when its kind has none (it is
    then solved by :func:`newton_step`)."""
    s = st.step
    if isinstance(s, DriverStep):
        return DriverStepSolver(mechanism, st, size) if is_closed_form(s) else None
    a = adapter_of(s)
    return None if a is None else a(mechanism, st, size)


def newton_step(mechanism, st, size: float) -> GroupStep:
    """Newton with continuation: any step."""
    return NewtonStep(mechanism, st, size)
