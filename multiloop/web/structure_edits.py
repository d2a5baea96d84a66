"""Edits of the open design's structure: an RRR dyad added at a joint or tracer point,
and the last Assur group removed.  Each makes a new frozen
:class:`~multiloop.topo.model.Mechanism` through the library's builder (which validates
it) and is kept only when the library still decomposes it
(:func:`multiloop.topo.assur.decompose`): the structure stays decomposable, and the
mobility does not change (a dyad and an Assur group have none of their own).

**The added dyad.**  Two new binary links join the chosen place ``A`` (a joint of the
design, which then also holds the dyad's first link, or a tracer point, where a new pin
on its link is put) to a new frame pivot ``F``, through a middle pin ``M``.  Let ``R``
be how far ``A`` moves from its reference over the design's motions (:func:`reaches`:
each driver over its range, the others at the reference, as ``check`` moves them) and
``s`` the design's size (:attr:`Mechanism.size`).  ``F`` lies ``R + s`` from ``A``,
away from the centre of the design's pins, so ``|AF|`` stays within ``[s, 2R + s]``;
both links are ``0.6 (2R + s)`` long, so the dyad reaches 20 % beyond the farthest
``A`` and assembles over the whole motion.
"""
from __future__ import annotations

import math

import numpy as np

from multiloop.topo.errors import InputError, explain

__all__ = ["with_dyad", "without_last_group", "attach_places", "reaches", "StructureBar", "DYAD_LINK"]

#: the added dyad's link lengths, in units of the farthest distance |AF| (module docstring)
DYAD_LINK = 0.6


def attach_places(m) -> list[str]:
    """Where a dyad may be added: the pins (R joints) of ``m`` with a position and not on
    the frame (a dyad from the frame to the frame would not move), and its tracer points."""
    from multiloop.topo.model import JointKind
    pins = [j.name for j in m.joints if j.kind is JointKind.R and j.at is not None and m.frame not in j.links]
    return pins + [p.name for p in m.points]


def reaches(m, sweeps=None) -> dict[str, float]:
    """How far each joint and tracer point of ``m`` moves from its reference over the
    sweeps of its drivers (:class:`~.scene.Sweep` s; None: solved here, by
    :func:`~.scene.sweep_driver`)."""
    from .scene import sweep_driver
    if sweeps is None:
        sweeps = [sweep_driver(m, k) for k in range(len(m.drivers))]
    names = [*m.joint_names, *(p.name for p in m.points)]
    ref = np.array([j.at for j in m.joints] + [p.at for p in m.points], float)
    far = np.zeros(len(names))
    for sw in sweeps:
        d = np.linalg.norm(np.asarray(sw.nodes, float) - ref, axis=-1)
        far = np.fmax(far, np.nanmax(np.where(np.isfinite(d), d, np.nan), axis=0, initial=0.0))
    return dict(zip(names, far.tolist()))


def _fresh(m, stem: str) -> str:
    """``stem`` followed by the first number that names no link, joint or point of ``m``."""
    taken = set(m.link_names) | set(m.joint_names) | {p.name for p in m.points}
    k = 1
    while any(f"{stem}{k}{s}" in taken for s in ("", "_a", "_b", "_A", "_M", "_F")):
        k += 1
    return f"{stem}{k}"


def _checked(b, what: str):
    """The builder's mechanism, if the library still decomposes it."""
    from multiloop.topo.assur import decompose
    from multiloop.topo.errors import LinkageError
    try:
        m = b.build()
        decompose(m)
    except LinkageError as exc:
        raise InputError(f"{what}: {exc}") from None
    return m


def with_dyad(m, place: str, reach: float | None = None):
    """``m`` with an RRR dyad from ``place`` (a joint or tracer point) to a new frame
    pivot (module docstring); ``reach``: how far ``place`` moves (None: :func:`reaches`).

    Raises
    ------
    InputError
        ``place`` is not one of :func:`attach_places`, or the result does not build or
        decompose (the library's message).
    """
    from multiloop.topo.model import JointKind, MechanismBuilder
    places = attach_places(m)
    if place not in places:
        raise InputError(explain("dyad place", expected="a moving joint or tracer point of the design",
                                 got=repr(place) if places else "a design without one"))
    b = MechanismBuilder.from_mechanism(m)
    stem = _fresh(m, "dyad")
    a, c = f"{stem}_a", f"{stem}_b"
    b.add_link(a)
    b.add_link(c)
    if place in m.joint_names:
        at = np.asarray(m.joint(place).at, float)
        b.joints = [j if j.name != place else type(j)(j.name, j.kind, (*j.links, a), j.at, j.axis) for j in b.joints]
    else:
        p = next(p for p in m.points if p.name == place)
        at = np.asarray(p.at, float)
        b.add_joint(f"{stem}_A", JointKind.R, (p.link, a), at=at)
    pins = np.array([j.at for j in m.joints if j.at is not None], float)
    away = at - pins.mean(axis=0)
    n = float(np.hypot(*away))
    u = away / n if n > 1e-9 * m.size else np.array([1.0, 0.0])
    s = m.size
    r = float(reaches(m)[place] if reach is None else reach)
    f = at + (r + s) * u
    half, length = (r + s) / 2, DYAD_LINK * (2 * r + s)
    mid = (at + f) / 2 + np.array([-u[1], u[0]]) * math.sqrt(length ** 2 - half ** 2)
    b.add_joint(f"{stem}_M", JointKind.R, (a, c), at=mid)
    b.add_joint(f"{stem}_F", JointKind.R, (c, m.frame), at=f)
    return _checked(b, "added dyad")


def without_last_group(m):
    """``m`` without its last Assur group (in solving order): its links, their pins, the
    tracer points and loads on them; a multiple joint keeps its other links.

    Raises
    ------
    InputError
        ``m`` has no group to remove (only driver links), or a driver acts inside it.
    """
    from multiloop.topo.assur import AssurGroup, decompose
    from multiloop.topo.model import MechanismBuilder
    plan = decompose(m)
    groups = [s for s in plan.steps if isinstance(s, AssurGroup)]
    if not groups or groups[-1].drivers:
        raise InputError(explain("remove the last group", expected="a design whose last step is an Assur group "
                                 "without drivers", got="only driver links" if not groups else "a driven group"))
    gone = set(groups[-1].links)
    b = MechanismBuilder.from_mechanism(m)
    joints = []
    for j in m.joints:
        keep = tuple(lk for lk in j.links if lk not in gone)
        if len(keep) == len(j.links):
            joints.append(j)
        elif len(keep) >= 2:
            joints.append(type(j)(j.name, j.kind, keep, j.at, j.axis))
    b.links = [lk for lk in m.links if lk.name not in gone]
    b.joints = joints
    b.points = [p for p in m.points if p.link not in gone]
    b.loads = [ld for ld in m.loads if ld.link not in gone]
    return _checked(b, "removed group")


class StructureBar:
    """The edit row's structure edits: a menu of :func:`attach_places`, **Add dyad** and
    **Remove last group**.  ``push(m)`` makes a new design an edit (the editor's history);
    ``say`` shows the one-line message; ``sweeps_of(m)`` gives the page's sweeps of ``m``
    when it has them (else the dyad's reach is solved on the spot).  :meth:`refresh`
    follows the design shown."""

    def __init__(self, say, push, sweeps_of=None):
        from bokeh.models import Button, Row

        from .menus import Menu
        self.say, self.push = say, push
        self.sweeps_of = sweeps_of or (lambda m: None)      # the page's sweeps of a design, if it has them
        self.design = None
        self.places = Menu("dyad place menu", say, title="add a dyad at", width=140, css_classes=["ml-dyad-at"])
        self.add = Button(label="Add dyad", width=90, css_classes=["ml-add-dyad"])
        self.remove = Button(label="Remove last group", width=150, css_classes=["ml-remove-group"])
        self.add.on_click(lambda: self._apply(self._dyad))
        self.remove.on_click(lambda: self._apply(without_last_group))
        self.panel = Row(self.places.select, self.add, self.remove)

    def refresh(self, m) -> None:
        """The design ``m`` is the editor's current one (None: no design)."""
        self.design = m
        places = [] if m is None or not m.has_geometry else attach_places(m)
        self.places.set(places, self.places.value if self.places.value in places else (places[0] if places else ""))

    def _dyad(self, m):
        sweeps = self.sweeps_of(m)
        place = self.places.value
        return with_dyad(m, place, reaches(m, sweeps).get(place) if sweeps else None)

    def _apply(self, edit) -> None:
        from multiloop.topo.errors import LinkageError
        m = self.design
        if m is None or not m.has_geometry:
            self.say(explain("structure edit", expected="an open design with geometry", got="none"))
            return
        try:
            new = edit(m)
        except LinkageError as exc:
            self.say(str(exc))
            return
        self.push(new)
