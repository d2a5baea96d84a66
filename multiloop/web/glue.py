"""The four widgets the page needs that Bokeh does not have, each a Bokeh model plus a
few lines of BokehJS glue: a player (a frame slider and a play toggle), a download
button for text made on the server, an upload button that checks a file's size in the
browser before sending it, and a progress bar.

Everything else on the page is a stock Bokeh model (``bokeh.models``).  Bokeh alone,
without a widget layer on top, is what makes the page load fast: a server that imports
Panel as well spends ~0.6 s more before it listens and sends ~0.8 MB more script
(docs/web.md gives the measurements).
"""
from __future__ import annotations

import base64
from contextlib import contextmanager

import numpy as np
from bokeh.models import Button, CustomJS, Div, FileInput, Slider, Toggle

from multiloop.inputs import MAX_UPLOAD, MECHANISM_UPLOAD, check_upload_size
from multiloop.topo.errors import InputError, explain

from .markup import Html, html, join

__all__ = ["Player", "Download", "Upload", "progress_html", "div", "floats", "upload_bytes", "on_upload", "held"]

#: the play toggle's glue: step the slider every ``interval`` ms while the toggle is on,
#: from the end back to the start (one timer per slider, stopped with the toggle)
PLAY_JS = """
const key = '__mlPlay' + slider.id;
if (window[key]) { clearInterval(window[key]); window[key] = null; }
if (cb_obj.active) {
  window[key] = setInterval(() => {
    slider.value = slider.value >= slider.end ? slider.start : slider.value + 1;
  }, interval);
}
cb_obj.label = cb_obj.active ? '❚❚ pause' : '▶ play';
"""

#: the download button's glue: the server puts [count, file name, text, encoding] in the
#: button's tags (encoding "base64" for a binary file); the browser saves the file under
#: that name (a blob: URL, nothing fetched)
DOWNLOAD_JS = """
const [count, name, text, encoding] = cb_obj.tags;
if (!name) { return; }
const body = encoding === 'base64' ? Uint8Array.from(atob(text), c => c.charCodeAt(0)) : text;
const a = document.createElement('a');
a.href = URL.createObjectURL(new Blob([body], {type: encoding === 'base64' ? 'application/octet-stream' : 'text/plain'}));
a.download = name;
document.body.appendChild(a); a.click(); a.remove();
setTimeout(() => URL.revokeObjectURL(a.href), 10000);
"""


#: the upload button's glue: a file chooser of its own (an <input type=file> made once per
#: button, class ``css``); a file of at most ``limit`` bytes is read and sent as Bokeh's
#: FileInput sends it (base64 in ``target``'s value, its name in ``filename``); a larger
#: one is not read, and only [count, name, size] go to the server (``target.tags``)
UPLOAD_JS = """
const key = '__mlUpload' + cb_obj.id;
let input = window[key];
if (!input || !input.isConnected) {
  input = window[key] = document.createElement('input');
  Object.assign(input, {type: 'file', accept: accept, className: css});
  input.style.display = 'none';
  document.body.appendChild(input);
  input.addEventListener('change', () => {
    const file = input.files[0];
    input.value = '';                       // the same file chosen again is a change
    if (!file) { return; }
    if (file.size > limit) {
      target.tags = [(target.tags[0] || 0) + 1, file.name, file.size];
      return;
    }
    const reader = new FileReader();
    reader.onload = () => {
      const url = String(reader.result);
      target.setv({filename: file.name, value: url.slice(url.indexOf(',') + 1)});
    };
    reader.readAsDataURL(file);
  });
}
input.click();
"""


class Player:
    """A frame slider (``slider``, model name ``ml-frame``) and a play toggle (``play``)
    that steps it in the browser every ``interval`` ms: playing costs the server nothing."""

    def __init__(self, interval: int = 40, width: int = 380):
        self.slider = Slider(start=0, end=1, value=0, step=1, title="frame", show_value=False, width=width,
                             name="ml-frame", css_classes=["ml-frame"])
        self.play = Toggle(label="▶ play", width=90, css_classes=["ml-play"])
        self.play.js_on_change("active", CustomJS(args=dict(slider=self.slider, interval=int(interval)),
                                                  code=PLAY_JS))

    def frames(self, n: int, value: int) -> None:
        """``n`` frames (at least 2 positions on the slider), at frame ``value``."""
        self.slider.update(start=0, end=max(n - 1, 1), value=int(value))

    @property
    def disabled(self) -> bool:
        return self.slider.disabled

    @disabled.setter
    def disabled(self, off: bool) -> None:
        self.slider.disabled = self.play.disabled = bool(off)
        if off:
            self.play.active = False


class Download:
    """A button that downloads a file the server makes when it is clicked: ``make()``
    returns (file name, text or bytes), or None when there is nothing to download."""

    def __init__(self, label: str, make, width: int = 150, css: str | None = None):
        self.make = make
        self.button = Button(label=label, width=width, tags=[0, "", "", ""],      # [clicks, name, text, encoding]
                             css_classes=[css] if css else [])
        self.button.js_on_change("tags", CustomJS(code=DOWNLOAD_JS))
        self.button.on_click(lambda: self.click())

    def click(self) -> None:
        out = self.make()
        if out is None:
            return
        name, body = out
        binary = isinstance(body, bytes)
        text = base64.b64encode(body).decode("ascii") if binary else body
        # a new count: the same file twice is still a change
        self.button.tags = [self.button.tags[0] + 1, name, text, "base64" if binary else ""]

    def payload(self) -> tuple[str, str | bytes] | None:
        """The last file sent to the browser: (name, text or bytes), None before any."""
        _, name, text, encoding = self.button.tags
        if not name:
            return None
        return name, base64.b64decode(text) if encoding == "base64" else text


class Upload:
    """A button (``button``, CSS class ``css``) that uploads one file: ``fn(name, bytes)``
    gets a file of at most ``limit`` bytes (the command line's cap), read by the browser
    and sent through a hidden FileInput (``target``, which :func:`on_upload` reads); a
    larger file is refused by the browser before it is read, and ``fail(message)``
    shows the message: it never reaches the socket (whose messages Bokeh caps at 20 MB;
    past that the page lost its session and its results)."""

    def __init__(self, label: str, accept: str, fn, fail, css: str, limit: int = MAX_UPLOAD,
                 hint: str = MECHANISM_UPLOAD):
        self.target = FileInput(accept=accept, multiple=False, visible=False, tags=[0, "", 0])
        self.button = Button(label=label, css_classes=[css])
        self.button.js_on_click(CustomJS(args=dict(target=self.target, accept=accept, limit=int(limit),
                                                   css=f"{css}-file"), code=UPLOAD_JS))
        self.limit, self.hint = limit, hint
        on_upload(self.target, fn, fail)
        self.target.on_change("tags", lambda attr, old, new: self._refused(new, fail))

    def _refused(self, tags, fail) -> None:
        """The browser's notice of a file larger than the cap: (count, name, size)."""
        try:
            check_upload_size(str(tags[1]), int(tags[2]), self.limit, self.hint)
        except InputError as exc:
            fail(str(exc))
        except (IndexError, TypeError, ValueError):
            fail(explain("upload", expected="a file's name and size from the page", got="another value"))


def progress_html(fraction: float) -> Html:
    """A progress bar (``<progress id="ml-progress">``) at ``fraction`` of 1."""
    v = int(round(1000 * min(max(fraction, 0.0), 1.0)))
    return html('<progress id="ml-progress" value="{v}" max="1000" style="width:300px"></progress>', v=v)


def floats(a) -> np.ndarray:
    """A fresh C-contiguous float64 copy of ``a``: a data source's column that Bokeh
    sends to the page as one binary buffer (a list is written and read as JSON, number
    by number)."""
    return np.array(a, dtype=float, order="C")


def div(text: str = "", **kw) -> Div:
    """A Div showing ``text``: HTML when it is an :class:`~.markup.Html` fragment, else
    the text itself (stretching to the width unless a width is given)."""
    if "width" not in kw:
        kw.setdefault("sizing_mode", "stretch_width")
    return Div(text=join([text]), **kw)


def upload_bytes(value) -> bytes:
    """The bytes of a file input's value (Bokeh's FileInput sends them base64-encoded)."""
    if isinstance(value, (bytes, bytearray)):
        return bytes(value)
    try:
        return base64.b64decode(value or "", validate=True)
    except ValueError:
        raise InputError(explain("upload", expected="a file's bytes (base64 from the page)",
                                 got="an undecodable value")) from None


def on_upload(file_input, fn, fail) -> None:
    """Call ``fn(file name, bytes)`` when the page sends a file through ``file_input``
    (``fail(message)`` if its bytes cannot be read).

    The browser sends the file's value and its name in one message, in either order:
    in a served page the call waits for the next tick, when both are set (outside a
    page, a new value calls at once)."""
    pending = []

    def read():
        pending.clear()
        try:
            name = file_input.filename
        except ValueError:                 # not sent (yet): Bokeh's UnsetValueError
            name = ""
        try:
            data = upload_bytes(file_input.value)
        except InputError as exc:
            fail(str(exc))
            return
        fn(name or "upload", data)

    def changed(attr, old, new):
        doc = file_input.document
        if doc is None or getattr(doc, "session_context", None) is None:
            if attr == "value":
                read()
        elif not pending:
            pending.append(doc.add_next_tick_callback(read))
    file_input.on_change("value", changed)
    file_input.on_change("filename", changed)


@contextmanager
def held(doc):
    """The changes made inside sent at its end in two messages at most (the data
    sources' changes, then the others: :func:`data_first`), two changes of one property
    as one (``doc.hold("combine")``).  Bokeh's server writes one message per change, and
    the page applies each on its own, drawing a frame between two (an edit and its
    re-check made about 60 messages, and the frames between them were most of the time
    the page took to show the new drawing).  ``doc`` None, or a document without a
    server session (the tests' Workbench): nothing held."""
    if doc is None:
        yield
        return
    doc.hold("combine")
    try:
        yield
    finally:
        _unhold_in_one_message(doc)


async def _written() -> None:
    """An awaitable already done: what a change held in a batch waits for."""


def _unhold_in_one_message(doc) -> None:
    """``doc.unhold()`` with the changes for each of the session's connections written
    as at most two PATCH-DOC messages (Bokeh's protocol takes a list of changes; its
    session writes one per change): the data sources' changes first, then the others
    (:func:`data_first`).  Each change is dispatched as ``unhold`` does (the models'
    Python callbacks, the echo to the page that made it suppressed); only the writing is
    gathered.  Without a session whose callback is running, plain ``unhold``."""
    session = getattr(getattr(doc, "session_context", None), "_session", None)
    connections = list(getattr(session, "_subscribed_connections", None) or ())
    if not connections or getattr(session, "_pending_writes", None) is None:
        doc.unhold()
        return
    batches: dict = {c: [] for c in connections}
    for c in connections:
        c.send_patch_document = lambda event, c=c: batches[c].append(event) or _written()
    try:
        doc.unhold()
    finally:
        for c in connections:
            del c.send_patch_document
    for c, events in batches.items():
        for part in data_first(events):
            session._pending_writes.append(c._socket.send_message(c.protocol.create("PATCH-DOC", part)))


def data_first(events: list) -> list[list]:
    """``events`` (one batch of changes, in order) as the messages to write: the changes
    of the data sources, then the others, each in their order (empty ones left out).

    The page applies a message's changes one after the other, at once; a data source's
    new columns reach its glyphs a moment later (BokehJS updates a glyph's arrays
    asynchronously), while a new text of a Div (or any widget that changes size) lays
    out the whole page and paints the drawing at once.  In one message a Div changed
    after a source whose length changed (an edit that adds or removes a link) painted
    half-updated glyphs: the paint threw ("Out of bounds"), inside the Div's change
    signal, and that model never signalled a change again (BokehJS's ``_changing``
    flag stayed set): the readout kept its last text for the rest of the session.  In a
    message of their own the sources' changes are complete on the glyphs before the
    next message lays anything out; the frame glue (run by the slider's change, in the
    second message) then reads the new frames and their readout arguments."""
    from bokeh.models import ColumnarDataSource
    data = [e for e in events if isinstance(getattr(e, "model", None), ColumnarDataSource)]
    rest = [e for e in events if not isinstance(getattr(e, "model", None), ColumnarDataSource)]
    return [part for part in (data, rest) if part]
