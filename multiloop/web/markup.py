"""The one builder of the page's HTML fragments: every value is text.

A fragment is a literal template whose ``{name}`` (or ``{name:spec}``) fields are filled
by :func:`html`: each value is formatted with its spec, then escaped with
``html.escape(..., quote=True)``, so a name from a file, an upload, a URL or an error
message can neither open a tag nor leave an attribute (double- or single-quoted).  A
value that is already a fragment (:class:`Html`, made by :func:`html` or :func:`join`)
goes in as it is.  ``tests/test_web_safety.py`` walks this package for HTML built any
other way (f-strings, ``%``, ``+``, ``str.format``).

Examples
--------
>>> html('<p id="x" title="{t}">{n:.2f} {name}</p>', t="it's", n=1.0, name="<img src=x>")
'<p id="x" title="it&#x27;s">1.00 &lt;img src=x&gt;</p>'
>>> html("<ul>{items}</ul>", items=join(html("<li>{v}</li>", v=v) for v in "a<"))
'<ul><li>a</li><li>&lt;</li></ul>'
"""
from __future__ import annotations

import html as _html
import string
from collections.abc import Iterable

__all__ = ["Html", "html", "join"]


class Html(str):
    """A fragment of HTML whose values were escaped (made by :func:`html` or :func:`join`)."""

    __slots__ = ()


class _Escaping(string.Formatter):
    def format_field(self, value, format_spec: str) -> str:
        text = format(value, format_spec)
        return text if isinstance(value, Html) else _html.escape(text, quote=True)


_FORMATTER = _Escaping()


def html(template: str, /, **values) -> Html:
    """``template`` (a literal) with its fields filled by ``values``, each escaped unless
    it is an :class:`Html` fragment already."""
    return Html(_FORMATTER.vformat(template, (), values))


def join(parts: Iterable) -> Html:
    """The fragments ``parts`` one after the other (a part that is not :class:`Html` is
    escaped as text)."""
    return Html("".join(p if isinstance(p, Html) else _html.escape(str(p), quote=True) for p in parts))
