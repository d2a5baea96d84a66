"""Shared helpers of every figure: text drawn as given (no mathtext).

matplotlib parses any text with a pair of ``$`` as mathtext, so a mechanism named
``cost $5 $6`` would fail to render (or render as maths).  :func:`no_mathtext`
switches parsing off for every text artist of a figure; the figure functions call
it before they return.
"""
from __future__ import annotations

__all__ = ["no_mathtext"]


def no_mathtext(fig):
    """Draw every text of ``fig`` literally (``$`` is a dollar sign); returns ``fig``."""
    from matplotlib.text import Text

    for t in fig.findobj(Text):
        t.set_parse_math(False)
    return fig
