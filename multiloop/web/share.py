"""The open design in the page's address: ``?design=CODE``, opened by a fresh page.

A design that is not a menu name (an edit, an upload, a synthesised candidate) is
encoded in the address as its mechanism file (``topo.io.dumps_toml``) compressed with
zlib and written in base64url (RFC 4648 §5, no padding): :func:`design_code`.  A page
opened with that address decodes it with :func:`design_from_code` and reads the text with
the upload's parser (:func:`multiloop.inputs.load_upload`), so a code is data, never a
path, and a damaged code is one line (*expected … got …*).  A code is at most
:data:`MAX_CODE` characters (a longer design is not put in the address) and unpacks to at
most :data:`MAX_TEXT` bytes (a "zip bomb" is refused before it is read).  A design that is
a menu name puts ``?mechanism=NAME`` in the address instead.

The server changes the address through :class:`Address`: its model's tags carry the code
or the name, and the browser rewrites the address with ``history.replaceState`` (no
request, no reload).  Every other argument of the address, the token first, is kept as
it is, character for character.

Examples
--------
>>> from multiloop.inputs import load_mechanism
>>> m = load_mechanism("four_bar")
>>> design_from_code(design_code(m)) == m
True
"""
from __future__ import annotations

import base64
import binascii
import re
import zlib

from multiloop.topo.errors import InputError, LinkageError, explain

__all__ = ["address_argument", "design_code", "design_from_code", "requested_design", "shared_design", "open_first", "Address",
           "ADDRESS_JS", "MAX_CODE", "MAX_TEXT"]

#: longest code put in (and read from) the address, in characters (browsers and servers
#: take addresses of 8 KiB and more)
MAX_CODE = 6000
#: most bytes a code may unpack to (the mechanism file's text)
MAX_TEXT = 1 << 20
#: where a code comes from, in messages
WHAT = "design (the address's ?design=)"

_CODE = re.compile(r"[A-Za-z0-9_-]+={0,2}")

#: the address's glue: tags [code, name] from the server (``model``, the address's Div);
#: ?design=CODE (or ?mechanism=NAME, or neither) replaces those arguments, every other one
#: kept as it is.  Run on every change of the tags and once the page is ready (the first
#: design's tags come with the page, not as a change).
ADDRESS_JS = """
const [code, name] = model.tags;
const keep = window.location.search.replace(/^\\?/, '').split('&')
  .filter(p => p && !p.startsWith('design=') && !p.startsWith('mechanism='));
if (code) { keep.push('design=' + code); } else if (name) { keep.push('mechanism=' + encodeURIComponent(name)); }
const url = window.location.pathname + (keep.length ? '?' + keep.join('&') : '') + window.location.hash;
if (url != window.location.pathname + window.location.search + window.location.hash) {
  window.history.replaceState(window.history.state, '', url);
}
"""


def design_code(m) -> str | None:
    """The address code of design ``m`` (zlib + base64url of its TOML file), or None when
    it would be longer than :data:`MAX_CODE` characters."""
    from multiloop.topo.io import dumps_toml
    packed = zlib.compress(dumps_toml(m).encode("utf-8"), 9)
    code = base64.urlsafe_b64encode(packed).rstrip(b"=").decode("ascii")
    return code if len(code) <= MAX_CODE else None


def design_from_code(code: str):
    """The design of an address code, read by the mechanism files' parser.

    Raises
    ------
    InputError
        ``code`` is not a code of :func:`design_code` (too long, not base64url, not zlib,
        unpacking to more than :data:`MAX_TEXT` bytes), or its text is not a mechanism
        file (the parser's message).
    """
    from multiloop.inputs import load_upload
    text = str(code)
    if len(text) > MAX_CODE:
        raise InputError(explain(WHAT, expected=f"a code of at most {MAX_CODE} characters",
                                 got=f"{len(text)} characters"))
    fault = "not base64url" if not _CODE.fullmatch(text) else None
    data = b""
    if fault is None:
        try:
            unpack = zlib.decompressobj()
            data = unpack.decompress(base64.urlsafe_b64decode(text.rstrip("=") + "=" * (-len(text.rstrip("=")) % 4)), MAX_TEXT)
            if unpack.unconsumed_tail:
                fault = f"more than {MAX_TEXT} bytes"
            elif not unpack.eof:
                fault = "a cut-off code"
        except (binascii.Error, ValueError, zlib.error):
            fault = "a damaged code"
    if fault is not None:
        shown = text if len(text) <= 40 else text[:40] + "…"
        raise InputError(explain(WHAT, expected="a design code of this page (zlib + base64url of a mechanism file)",
                                 got=f"{fault}: {shown!r}", hint="copy the whole address again"))
    try:
        return load_upload("design.toml", data)
    except LinkageError as exc:
        raise InputError(f"{WHAT}: {exc}") from None


def address_argument(doc, key: str, limit: int) -> str | None:
    """The first ``?key=`` value of the page's address as text (at most ``limit``
    characters), or None: text only, never used as a path."""
    try:
        values = doc.session_context.request.arguments.get(key) or []
    except AttributeError:               # no request (a document made outside a server)
        return None
    if not values:
        return None
    raw = values[0]
    text = raw.decode("utf-8", "replace") if isinstance(raw, bytes) else str(raw)
    return text[:limit]


def requested_design(doc) -> str | None:
    """The ``?design=`` code of the page's address, or None (text only, at most a
    character more than :data:`MAX_CODE`, so that a longer one is refused as too long)."""
    return address_argument(doc, "design", MAX_CODE + 1)


def shared_design(code: str | None) -> tuple:
    """(design, None) for a good code, (None, message) for a bad one, (None, None)
    without one."""
    if code is None:
        return None, None
    try:
        return design_from_code(code), None
    except LinkageError as exc:
        return None, str(exc)


def open_first(page, first: str, requested: str | None, shared: str | None, hint: str) -> None:
    """The first design of a ``page`` (a :class:`~.app.Workbench`): the address's design
    code ``shared`` when it reads, else the menu entry ``first``; then the one-line
    message for a bad code, or for a ``requested`` name (``?mechanism=``) that is not
    ``first`` (not an entry of the menu; ``hint``: the menu's hint)."""
    design, fault = shared_design(shared)
    if design is not None:
        page.open_design(design, f"shared: {design.name or 'design'}")
    if page.mechanism is None:
        page.open_name(first)
    if fault is not None:
        page.say(fault)
    elif requested is not None and requested != first:
        from .menus import refusal
        page.say(refusal("mechanism (the address's ?mechanism=)", requested, hint))


class Address:
    """The page's address follows the design shown (:meth:`follow`)."""

    def __init__(self):
        from bokeh.models import CustomJS, Div
        self.model = Div(visible=False, tags=["", ""], name="ml-address")
        #: the glue, also run by the page once it is ready (``doc.js_on_event(DocumentReady, …)``)
        self.glue = CustomJS(args=dict(model=self.model), code=ADDRESS_JS)
        self.model.js_on_change("tags", self.glue)

    def follow(self, m, key: str | None) -> None:
        """Design ``m`` is shown: ``?mechanism=KEY`` for a menu name ``key``, else
        ``?design=CODE`` (neither for a design too large for the address)."""
        code = design_code(m) if key is None else None
        self.model.tags = [code or "", key or ""]
