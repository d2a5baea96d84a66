"""Menus that name choices, never files.

Bokeh does not check a menu's value against its options: a script in the page (or a
message written by hand) can set any string.  A :class:`Menu` keeps the list of what its
Bokeh ``Select`` may hold on the server (:attr:`Menu.choices`: catalogue names, the files
given to ``serve``, this page's uploads and designs, the atlases given to ``serve``…)
and passes a value on only when it is one of them.  Anything else gets the page's
one-line message, and the menu goes back to the choice it had.
"""
from __future__ import annotations

from multiloop.topo.errors import explain

__all__ = ["Menu", "refusal", "file_entries"]

#: characters of a refused value quoted in the message
QUOTED = 60


def refusal(what: str, value, hint: str | None = None) -> str:
    """The message for ``value``, which is not one of the choices of ``what``."""
    text = str(value)
    shown = repr(text if len(text) <= QUOTED else text[:QUOTED] + "…")
    return explain(what, expected="one of its entries", got=shown, hint=hint or "choose an entry of the menu")


def file_entries(paths) -> list[str]:
    """Menu entries for the files given to ``serve``: each file's name without its
    folders (a page shows no path of the server's); a name met again gets " (2)", " (3)"…"""
    from pathlib import PurePath
    out: list[str] = []
    for p in paths:
        base, k = PurePath(str(p)).name or str(p), 1
        entry = base
        while entry in out:
            k += 1
            entry = f"{base} ({k})"
        out.append(entry)
    return out


class Menu:
    """A Bokeh ``Select`` (:attr:`select`) whose value is one of :attr:`choices`.

    Parameters
    ----------
    what : str
        The menu's name in a message ("mechanism menu").
    say : callable
        Shows a one-line message on the page.
    choices : sequence of str
        What the menu may hold.
    value : str, optional
        The first choice shown (default: the first of ``choices``).
    hint : str, optional
        The hint of the message for a value that is not a choice.
    labels : dict, optional
        What the menu shows for a choice (default: the choice itself).
    **select : keywords of the ``Select`` (title, width, css_classes…).
    """

    def __init__(self, what: str, say, choices=(), value: str | None = None, hint: str | None = None,
                 labels: dict | None = None, **select):
        from bokeh.models import Select
        self.what, self.say, self.hint, self.labels = what, say, hint, dict(labels or {})
        self.choices: tuple[str, ...] = tuple(choices)
        self.value = self._default(value)        # the last choice accepted
        self.select = Select(options=self._options(), value=self.value, **select)
        self._calls: list = []
        self.select.on_change("value", lambda attr, old, new: self._changed(new))

    def _options(self) -> list:
        return [(c, self.labels[c]) if c in self.labels else c for c in self.choices]

    def _default(self, value) -> str:
        if value in self.choices:
            return value
        return self.choices[0] if self.choices else ""

    def on_choice(self, fn) -> None:
        """Call ``fn(value)`` when the page chooses another entry of the menu."""
        self._calls.append(fn)

    def set(self, choices=None, value: str | None = None) -> None:
        """The server's change of the choices and/or the value shown (no ``on_choice`` call)."""
        if choices is not None:
            self.choices = tuple(choices)
            self.select.options = self._options()
        self.value = self._default(self.value if value is None else value)
        self.select.value = self.value

    def _changed(self, new) -> None:
        if new == self.value:
            return
        if new not in self.choices:
            self.say(refusal(self.what, new, self.hint))
            self.select.value = self.value
            return
        self.value = new
        for fn in self._calls:
            fn(new)
