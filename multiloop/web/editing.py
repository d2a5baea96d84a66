"""Editing the open design by hand: a joint's or a tracer point's reference coordinates
typed in, a binary link's length typed in (:mod:`.lengths`), a dyad added or the last group removed (:mod:`.structure_edits`), and undo /
redo over every edit (buttons, and Ctrl-Z / Ctrl-Shift-Z in the page).

An edit makes a new :class:`~multiloop.topo.model.Mechanism` (frozen: nothing is
changed in place) with the point moved in the reference configuration; the link
lengths follow from the reference, as in a mechanism file.  The page then opens it like
any design: it re-solves and re-checks in the background, and a design that no longer
assembles is the page's one-line message (the edit stays, so it can be undone).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

from multiloop.topo.errors import InputError, explain

__all__ = ["moved", "History", "Editor", "UNDO_KEYS_JS"]


def moved(m, name: str, xy) -> object:
    """``m`` with joint or tracer point ``name`` at ``xy`` (m) in the reference.

    Raises
    ------
    InputError
        ``name`` is neither a joint nor a tracer point of ``m``, or ``xy`` is not two
        finite numbers.
    """
    try:
        x, y = (float(v) for v in xy)
    except (TypeError, ValueError):
        x = y = math.nan
    if not (math.isfinite(x) and math.isfinite(y)):
        raise InputError(explain(f"position of {name}", expected="two finite numbers (x, y in m)", got=repr(xy)))
    if name in m.joint_names:
        return replace(m, joints=tuple(replace(j, at=(x, y)) if j.name == name else j for j in m.joints))
    if name in [p.name for p in m.points]:
        return replace(m, points=tuple(replace(p, at=(x, y)) if p.name == name else p for p in m.points))
    raise InputError(explain("edited point", expected="a joint or tracer point of the design", got=repr(name)))


@dataclass(frozen=True, slots=True)
class History:
    """The designs of an editing session (``designs[0]`` as opened) and the one shown
    (``at``): an edit drops what was undone after ``at`` and appends."""

    designs: tuple = ()
    at: int = -1

    @classmethod
    def of(cls, m) -> History:
        return cls((m,), 0)

    @property
    def current(self):
        return self.designs[self.at] if self.designs else None

    def edited(self, m) -> History:
        return History(self.designs[:self.at + 1] + (m,), self.at + 1)

    def undone(self) -> History:
        return replace(self, at=max(self.at - 1, 0))

    def redone(self) -> History:
        return replace(self, at=min(self.at + 1, len(self.designs) - 1))

    @property
    def can_undo(self) -> bool:
        return self.at > 0

    @property
    def can_redo(self) -> bool:
        return 0 <= self.at < len(self.designs) - 1


#: Ctrl-Z / Ctrl-Shift-Z (Cmd on a Mac) anywhere in the page but a text field: a count and
#: the direction in the Undo button's tags, which the server reads (one listener a page)
UNDO_KEYS_JS = """
if (window.__mlUndoKeys) { return; }
window.__mlUndoKeys = true;
document.addEventListener('keydown', (e) => {
  if (!(e.ctrlKey || e.metaKey) || e.key.toLowerCase() !== 'z') { return; }
  const t = e.composedPath()[0];
  if (t && (t.tagName === 'INPUT' || t.tagName === 'TEXTAREA')) { return; }
  e.preventDefault();
  undo.tags = [(undo.tags[0] || 0) + 1, e.shiftKey ? 1 : -1];
});
"""


class Editor:
    """The edit row of the mechanism tab: a point menu, x and y (in the page's length
    unit, :attr:`units`), Apply, Undo, Redo.  ``show(m)`` is called with each design the
    edits make (the page opens it); ``sweeps_of(m)``: the page's sweeps of design ``m``
    when it has them (:class:`~.structure_edits.StructureBar`)."""

    def __init__(self, say, show, sweeps_of=None):
        from bokeh.models import Button, Column, CustomJS, Row, TextInput

        from .lengths import LengthBar
        from .menus import Menu
        from .structure_edits import StructureBar
        from .units import Units
        self.say, self.show = say, show
        self.units = Units()
        self.history = History()
        self.point = Menu("edited point", say, (), title="edit point", width=140, css_classes=["ml-edit-point"])
        self.x = TextInput(title="x (m)", width=110, css_classes=["ml-edit-x"])
        self.y = TextInput(title="y (m)", width=110, css_classes=["ml-edit-y"])
        self.apply = Button(label="Apply", width=70, css_classes=["ml-edit-apply"])
        self.undo = Button(label="↶ Undo", width=80, disabled=True, css_classes=["ml-undo"], tags=[0, 0])
        self.redo = Button(label="↷ Redo", width=80, disabled=True, css_classes=["ml-redo"])
        self.apply.on_click(lambda: self.typed(self.point.value, (self.x.value, self.y.value)))
        self.undo.on_click(lambda: self.step(-1))
        self.redo.on_click(lambda: self.step(+1))
        self.point.on_choice(lambda name: self._fill())
        self.undo.on_change("tags", lambda attr, old, new: self._key(new))
        #: the page's key listener (added by the page on DocumentReady)
        self.keys = CustomJS(args=dict(undo=self.undo), code=UNDO_KEYS_JS)
        #: the structure edits (a dyad added, the last group removed), edits of this history
        self.structure = StructureBar(say, self.push, sweeps_of)
        #: a binary link's length typed (:mod:`.lengths`), an edit of this history
        self.lengths = LengthBar(say, self.push)
        self.panel = Column(Row(self.point.select, self.x, self.y, self.apply, self.undo, self.redo),
                            Row(self.lengths.panel, self.structure.panel))

    def reset(self, m) -> None:
        """A design opened (not edited): its history starts with it."""
        self.history = History.of(m)
        self._refresh()

    def edit(self, name: str, xy) -> None:
        """Move ``name`` to ``xy`` (text or numbers, m); a bad value is the message."""
        m = self.history.current
        if m is None or not m.has_geometry:
            self.say(explain("edit", expected="an open design with geometry", got="none"))
            return
        try:
            new = moved(m, name, xy)
        except InputError as exc:
            self.say(str(exc))
            return
        self.push(new)

    def push(self, new) -> None:
        """``new`` (made from the current design) is the next edit: shown, undoable."""
        self.history = self.history.edited(new)
        self._refresh()
        self.show(new)

    def typed(self, name: str, xy) -> None:
        """The edit typed in the page: ``xy`` (text) in the display length unit."""
        try:
            at = tuple(self.units.typed(v, "m") for v in xy)
        except InputError:
            self.say(explain(f"position of {name}", expected=f"two finite numbers (x, y in {self.units.length})",
                             got=repr(tuple(xy))))
            return
        self.edit(name, at)

    def use_units(self, units) -> None:
        """Show and read x and y in ``units`` (a :class:`~.units.Units`)."""
        self.units = units
        self.x.title, self.y.title = f"x ({units.length})", f"y ({units.length})"
        self.lengths.use_units(units)
        self._fill()

    def drag(self, name: str, xy) -> bool:
        """A handle dragged to ``xy`` in the drawing: the same edit as typed, and the
        edit row then shows that point; whether the edit was made."""
        at = self.history.at
        self.edit(name, xy)
        if self.history.at == at:
            return False
        self.point.set(value=name)
        self._fill()
        return True

    def step(self, k: int) -> None:
        """Undo (``k = -1``) or redo (``+1``) one edit."""
        h = self.history.undone() if k < 0 else self.history.redone()
        if h.at == self.history.at:
            return
        self.history = h
        self._refresh()
        self.show(h.current)

    def _key(self, tags) -> None:
        """Ctrl-Z (``tags[1] = -1``) or Ctrl-Shift-Z (``+1``) from the page."""
        try:
            k = int(tags[1])
        except (IndexError, TypeError, ValueError):
            return
        if k in (-1, 1):
            self.step(k)

    def _refresh(self) -> None:
        m = self.history.current
        names = [] if m is None else list(m.joint_names) + [p.name for p in m.points]
        self.point.set(names, self.point.value if self.point.value in names else (names[0] if names else ""))
        self.undo.disabled, self.redo.disabled = not self.history.can_undo, not self.history.can_redo
        self.structure.refresh(m)
        self.lengths.refresh(m)
        self._fill()

    def _fill(self) -> None:
        """x and y of the chosen point, as the design has them (in the display unit: the
        file's own digits in m, 12 significant digits in another unit)."""
        m, name = self.history.current, self.point.value
        at = None
        if m is not None and name in m.joint_names:
            at = m.joint(name).at
        elif m is not None:
            at = next((p.at for p in m.points if p.name == name), None)
        self.x.value, self.y.value = ("", "") if at is None else (self._text(at[0]), self._text(at[1]))

    def _text(self, v) -> str:
        shown = self.units.shown(v, "m")
        return repr(shown) if self.units.length == "m" else format(shown, ".12g")
