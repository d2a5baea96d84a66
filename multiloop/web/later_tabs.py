"""Tabs whose panels behind the first are built when first shown.

The first page then carries (and the browser renders) the first tab alone: a panel
given as a function is a placeholder until its tab is shown, then the function builds
it.  BokehJS 3.9 redraws a tab only on a new list of panels, so a built tab replaces
the list.
"""
from __future__ import annotations

__all__ = ["LaterTabs"]


class LaterTabs:
    """A Bokeh ``Tabs`` (:attr:`tabs`) of ``panels``, (title, model or function)
    pairs; a function's panel is built by :meth:`build` (on the tab's first show)."""

    def __init__(self, panels):
        from bokeh.models import TabPanel, Tabs

        from .glue import div
        self._later = {i: p for i, (_, p) in enumerate(panels) if callable(p)}
        self.tabs = Tabs(tabs=[TabPanel(title=t, child=div("…") if callable(p) else p) for t, p in panels])
        self.tabs.on_change("active", lambda attr, old, new: self.build(new))

    def build(self, i: int) -> None:
        """Build tab ``i`` unless it is built."""
        build = self._later.pop(i, None)
        if build is not None:
            from bokeh.models import TabPanel
            tabs = list(self.tabs.tabs)
            tabs[i] = TabPanel(title=tabs[i].title, child=build())
            self.tabs.tabs = tabs

    def show(self, i: int) -> None:
        """Build tab ``i`` if needed and show it."""
        self.build(i)
        self.tabs.active = i
