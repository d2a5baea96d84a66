"""A binary link's length typed in the edit row.

A mechanism file gives no lengths: they follow from the reference coordinates.  So a
length typed for a binary link (two pins) is a move of one of its pins, by this rule:

* the **free end** is the pin the Assur plan knows later: a frame pivot is known first,
  then each pin as soon as the step solving one of its links (``plan.step_of``) runs;
  between two pins known at the same step, the one listed later in the file;
* the free end moves along the line from the other end through it (the link keeps its
  direction) until the two are ``length`` apart;
* every other joint and tracer point stays where it is, so the other links on the free
  end follow (their lengths from the coordinates, as for a typed position).

The new design is kept only when the library still builds it, compiles its plan and
solves it at the reference inputs; any other length (0, a pin on another pin, a group
at a dead centre) is refused with one line naming the link.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np

from multiloop.topo.errors import InputError, LinkageError, explain

__all__ = ["binary_links", "free_end", "with_length", "LengthBar"]


def binary_links(m) -> list[str]:
    """The links of ``m`` whose length can be typed: not the frame, two joints, both pins
    (R joints) with a position."""
    from multiloop.topo.model import JointKind
    out = []
    for lk in m.link_names:
        js = m.joints_of(lk)
        if lk != m.frame and len(js) == 2 and all(j.kind is JointKind.R and j.at is not None for j in js):
            out.append(lk)
    return out


def free_end(m, link: str) -> tuple[str, str]:
    """(fixed, free): the pins of binary ``link``, the free one moved by a typed length
    (module docstring).

    Raises
    ------
    InputError
        ``link`` is not one of :func:`binary_links`, or both its pins are on the frame.
    """
    if link not in binary_links(m):
        raise InputError(explain("edited link", expected="a binary link of the design (two pins)", got=repr(link)))
    a, b = m.joints_of(link)
    rank = _known_at(m)
    if m.frame in a.links and m.frame in b.links:
        raise InputError(explain(f"length of link '{link}'", expected="a link that moves",
                                 got="a link pinned to the frame at both ends"))
    if rank(b) >= rank(a):
        return a.name, b.name
    return b.name, a.name


def _known_at(m):
    """The step of the Assur plan at which a joint's position is known (-1: the frame;
    the file's order when the design has no plan)."""
    from multiloop.topo.assur import decompose
    try:
        plan = decompose(m)
    except LinkageError:
        return lambda j: -1 if m.frame in j.links else 0
    return lambda j: -1 if m.frame in j.links else min(plan.step_of(lk) for lk in j.links)


def with_length(m, link: str, length: float, shown=None):
    """``m`` with binary ``link`` ``length`` (m) long, its free end moved (module
    docstring); ``shown(v)`` writes a length for the message (default: in m).

    Raises
    ------
    InputError
        Not a binary link, a length that is not a finite number > 0, or a design the
        library no longer builds, compiles or solves at its reference inputs.
    """
    shown = shown or (lambda v: f"{v!r} m")
    fixed, free = free_end(m, link)
    what = f"length of link '{link}'"
    if not (isinstance(length, (int, float)) and math.isfinite(length) and length > 0):
        raise InputError(explain(what, expected="a finite length > 0", got=shown(length)))
    p, q = np.asarray(m.joint(fixed).at, float), np.asarray(m.joint(free).at, float)
    u = (q - p) / math.dist(p, q)
    at = p + length * u
    new = replace(m, joints=tuple(replace(j, at=(float(at[0]), float(at[1]))) if j.name == free else j
                                  for j in m.joints))
    reason = _assembly_problem(new)
    if reason is not None:
        raise InputError(explain(what, expected="a length at which the design still assembles",
                                 got=f"{shown(length)}, where {reason}"))
    return new


def _assembly_problem(m) -> str | None:
    """None when the library builds ``m``, compiles its plan and solves it at the
    reference inputs, else the first line of its message."""
    from multiloop.kin.solve import plan_of, solve
    from multiloop.topo.model import MechanismBuilder
    try:
        MechanismBuilder.from_mechanism(m).build()
        if m.drivers:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                st = solve(m, np.zeros((1, len(m.drivers))), plan=plan_of(m))
            if not bool(np.asarray(st.ok).all()):
                return "it does not assemble at the reference inputs"
    except LinkageError as exc:
        return str(exc).splitlines()[0]
    return None


class LengthBar:
    """The edit row's length: a menu of :func:`binary_links`, the length (in the page's
    length unit) and **Set length**.  ``push(m)`` makes the new design an edit (the
    editor's history); ``say`` shows the one-line message; :meth:`refresh` follows the
    design shown, :meth:`use_units` the page's units."""

    def __init__(self, say, push):
        from bokeh.models import Button, Row, TextInput

        from .menus import Menu
        from .units import Units
        self.say, self.push = say, push
        self.units, self.design = Units(), None
        self.link = Menu("edited link", say, title="edit link", width=140, css_classes=["ml-edit-link"])
        self.length = TextInput(title="length (m)", width=110, css_classes=["ml-edit-length"])
        self.apply = Button(label="Set length", width=90, css_classes=["ml-edit-length-apply"])
        self.link.on_choice(lambda name: self._fill())
        self.apply.on_click(lambda: self.typed(self.link.value, self.length.value))
        self.panel = Row(self.link.select, self.length, self.apply)

    def refresh(self, m) -> None:
        """The design ``m`` is the editor's current one (None: no design)."""
        self.design = m
        names = [] if m is None or not m.has_geometry else binary_links(m)
        self.link.set(names, self.link.value if self.link.value in names else (names[0] if names else ""))
        self._fill()

    def use_units(self, units) -> None:
        self.units = units
        self.length.title = f"length ({units.length})"
        self._fill()

    def typed(self, link: str, text) -> None:
        """The length typed for ``link``, in the display unit: the edit, or the message."""
        m, what = self.design, f"length of link '{link}'"
        if m is None or not m.has_geometry:
            self.say(explain("edit", expected="an open design with geometry", got="none"))
            return
        try:
            new = with_length(m, link, self.units.typed(text, "m", what), self._shown)
        except InputError as exc:
            self.say(str(exc))
            return
        self.push(new)

    def _shown(self, v) -> str:
        return f"{format(self.units.shown(v, 'm'), '.12g')} {self.units.length}"

    def _fill(self) -> None:
        """The chosen link's length as the design has it (12 significant digits)."""
        m, name = self.design, self.link.value
        if m is None or name not in (binary_links(m) if m.has_geometry else ()):
            self.length.value = ""
            return
        a, b = m.joints_of(name)
        self.length.value = format(self.units.shown(math.dist(a.at, b.at), "m"), ".12g")
