"""The web workbench of ``multiloop serve`` (the optional ``[web]`` extra: Bokeh).

One page per browser session: a mechanism moved by a player, its structural report,
its design check marked on the input axis and the drawing, dimensional synthesis from a
drawn or uploaded target, and a browser of stored atlases.  Everything shown comes from
the library's own functions (:mod:`.scene` solves the motions once; the rest are views).

The designer's edits each have a module: :mod:`.editing` (typed and dragged points,
undo / redo), :mod:`.structure_edits` (a dyad added, the last group removed),
:mod:`.units` (display units), :mod:`.share` (the design in the address),
:mod:`.atlas_design` (an atlas card as a design) and :mod:`.target_drawing` (the
synthesis's drawn target).
"""
from __future__ import annotations

__all__ = ["serve"]


def serve(*args, **kwargs):
    """:func:`multiloop.web.app.serve` (imports Bokeh only when called)."""
    from .app import serve as _serve
    return _serve(*args, **kwargs)
