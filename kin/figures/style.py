"""Shared helpers of every figure: names drawn as given (a ``$`` is a dollar sign).

matplotlib parses any text with a pair of unescaped ``$`` as mathtext, so a link named
``$x^{$`` fails to render (or a name ``cost $5 $6`` renders as maths).  Switching the
parser off (``set_parse_math(False)``) is no cure: the log-axis tick labels matplotlib
writes itself (``$\\mathdefault{10^{2}}$``) then print as raw text.  Instead
:func:`no_mathtext` escapes every unescaped ``$`` of the figure's texts except the tick
labels (``\\$`` is matplotlib's literal dollar); the figure functions call it before
they lay the figure out, and tick labels made from names go through :func:`escape_math`.
"""
from __future__ import annotations

import re

__all__ = ["no_mathtext", "escape_math"]

_DOLLAR = re.compile(r"(?<!\\)\$")


def escape_math(text: str) -> str:
    """``text`` with every unescaped ``$`` escaped (idempotent).

    Examples
    --------
    >>> escape_math("cost $5 $6")
    'cost \\\\$5 \\\\$6'
    >>> escape_math(escape_math("$x$")) == escape_math("$x$")
    True
    """
    return _DOLLAR.sub(r"\\$", text)


def _tick_texts(fig) -> set[int]:
    """The ids of the tick-label and offset texts matplotlib formats itself."""
    out: set[int] = set()
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            for tick in axis.majorTicks + axis.minorTicks:
                out.update((id(tick.label1), id(tick.label2)))
            out.add(id(axis.offsetText))
    return out


def no_mathtext(fig):
    """Draw every text of ``fig`` but the tick labels literally; returns ``fig``."""
    from matplotlib.text import Text

    ticks = _tick_texts(fig)
    for t in fig.findobj(Text):
        if id(t) not in ticks:
            text = t.get_text()
            if "$" in text:
                t.set_text(escape_math(text))
    return fig
