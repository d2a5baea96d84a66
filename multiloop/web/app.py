"""The workbench page of one browser session, and the server that serves it.

:class:`Workbench` holds every widget and result of one session (two tabs are two
sessions: nothing is shared but the read-only mechanisms given on the command line).
A mechanism opens at once at its reference; its motions and its design check are
computed by background :class:`~.jobs.Job` s and appear when ready, so a long job never
blocks the page.
"""
from __future__ import annotations

import gc
import os
import sys
from importlib import resources

import numpy as np

from .markup import html

__all__ = ["Workbench", "serve", "catalogue_names", "load_choice", "ADDRESS"]

#: the only address served unless another host is asked for
ADDRESS = "127.0.0.1"

#: the hint of the message for a mechanism that is not one of the menu's
MENU_HINT = "choose a catalogue mechanism, a file given to serve, or upload one"

#: the message line with no message
EMPTY_MESSAGE = html('<div id="ml-message"></div>')


def _catalogue_folder():
    return resources.files("multiloop.catalogue") / "mechanisms"


def catalogue_names() -> list[str]:
    return sorted(e.name[:-5] for e in _catalogue_folder().iterdir() if e.name.endswith(".toml"))


def load_choice(files: dict, name: str):
    """The mechanism of a menu entry ``name``: a FILE given to ``serve`` (read at start)
    or a catalogue name (read from the catalogue's folder); never a path of the page's.

    Raises
    ------
    InputError
        ``name`` is neither.
    """
    from pathlib import Path

    from multiloop.inputs import load_mechanism
    from multiloop.topo.errors import InputError

    from .menus import refusal
    if name in files:
        return files[name]
    if name in catalogue_names():
        return load_mechanism(Path(str(_catalogue_folder() / f"{name}.toml")))
    raise InputError(refusal("mechanism menu", name, MENU_HINT))


#: results shared read-only by every session of this server, per named mechanism
#: (catalogue name or FILE): its drawing and structure tab, the sweeps of its drivers,
#: its check documents per threshold; the events of the first mechanism's warm-up
_SCENES: dict[str, tuple] = {}
_SWEEPS: dict[str, tuple] = {}
_CHECKS: dict[tuple[str, float], tuple] = {}      # (its JSON document, the CheckReport)
_WARMING: dict = {}


def _scene(m, key: str | None) -> tuple:
    """(Scene, structure HTML) of ``m``, from the server's cache when ``key`` names it."""
    from .scene import scene_of
    from .structure_view import structure_html
    if key is not None and key in _SCENES:
        return _SCENES[key]
    out = (scene_of(m), structure_html(m))
    if key is not None:
        _SCENES[key] = out
    return out


def _sweeps(m, key: str | None, cancel=None) -> tuple:
    """The sweep of every driver of ``m``, from the server's cache when ``key`` names it."""
    from .scene import sweep_driver
    if key is not None and key in _SWEEPS:
        return _SWEEPS[key]
    out = tuple(sweep_driver(m, k, cancel=cancel) for k in range(len(m.drivers)))
    if key is not None:
        _SWEEPS[key] = out
    return out


def _drivers(job, m, key):
    """Set ``job.sweeps``, the sweeps of every driver of ``m`` (shown at once:
    ``job.notify``), and return, when the second core (:mod:`.second_core`) takes a share
    of the work (half the drivers; the angles' extremes of a design with one driver),
    the check of every driver (``check``'s ``driver_checks``); else None, and the check
    moves the drivers itself after the sweeps."""
    from multiloop.kin.check import driver_check

    from .jobs import LOG
    from .scene import sweep_driver
    from .second_core import SECOND_CORE
    ks, wait = ((), None) if key is not None and key in _SWEEPS else SECOND_CORE.drivers(m, job)
    if wait is None:
        angles = SECOND_CORE.angles(m, job)
        job.sweeps = _sweeps(m, key, job.poll)
        job.report(1 / 2)
        job.notify()
        if angles is None:
            return None
        LOG.info("job %s: the angles of %s on the second core", job.name, m.drivers[0].joint)
        return (driver_check(m, 0, cancel=job.poll, angles=angles),)
    LOG.info("job %s: drivers %s moved on the second core", job.name, ", ".join(m.drivers[k].joint for k in ks))

    def both(k):
        return sweep_driver(m, k, cancel=job.poll), driver_check(m, k, cancel=job.poll)
    done = {k: both(k) for k in range(len(m.drivers)) if k not in ks}
    done.update(zip(ks, wait() or [both(k) for k in ks]))    # (the child failed: moved here)
    job.sweeps = tuple(done[k][0] for k in range(len(m.drivers)))
    if key is not None:
        _SWEEPS[key] = job.sweeps
    job.report(1 / 2)
    job.notify()
    return tuple(done[k][1] for k in range(len(m.drivers)))


def _motion_and_check(job, m, threshold, key=None):
    """Worker: the sweeps of every driver, then the check (its JSON document; the
    report itself in ``job.report``, for its verdict in the page's units); both
    stop at the next solve once the job is cancelled.  The first mechanism's warm-up
    computes the same: its results are awaited, not computed twice."""
    warming = _WARMING.get(key)
    while warming is not None and not warming.wait(0.1):
        job.poll()
    if key is not None and (key, threshold) in _CHECKS:
        from .second_core import SECOND_CORE
        SECOND_CORE.prepare(m)
        job.sweeps = _sweeps(m, key, job.poll)
        job.report(1 / 2)
        job.notify()
        doc, job.report = _CHECKS[key, threshold]
        return doc
    from multiloop.kin.check import check
    dcs = _drivers(job, m, key)
    job.report = check(m, min_transmission=threshold, cancel=job.poll, driver_checks=dcs)
    doc = job.report.as_dict()
    if key is not None:
        _CHECKS[key, threshold] = (doc, job.report)
    return doc


def warm_up(name: str, m, threshold: float, child, ready, shown) -> None:
    """Fill the server's cache for the first mechanism a page shows (``name``, ``m``):
    from the child process ``child`` (:mod:`.prepare`) when there is one, else here;
    ``ready`` is set once its drawing and motion are there (or failed) and
    ``_WARMING[name]`` once the warm-up ends.  Then, after the first page was shown
    (``shown``), start the second core (:mod:`.second_core`), import what the other
    mechanisms and the synthesis use and freeze what is there for the garbage collector."""
    try:
        if child is not None:
            from .prepare import results
            for kind, value in results(child):
                cache, k = {"scene": (_SCENES, name), "sweeps": (_SWEEPS, name),
                            "check": (_CHECKS, (name, threshold))}[kind]
                cache[k] = value
                if kind == "sweeps" or not (m.drivers and m.has_geometry):
                    ready.set()
        else:
            _scene(m, name)
            if m.drivers and m.has_geometry:
                _sweeps(m, name)
    except Exception:  # noqa: BLE001 - a session computes what is missing and reports its errors
        pass
    finally:
        ready.set()                         # a session never waits for a failed warm-up
        _WARMING.pop(name).set()
    shown.wait(timeout=20)
    from .second_core import SECOND_CORE
    SECOND_CORE.start()                     # (its own imports meanwhile, in the child)
    from multiloop.kin.check import check  # noqa: F401 - imported for the sessions' next jobs
    from multiloop.topo.assur import decompose  # noqa: F401

    from . import synthesis_view  # noqa: F401
    # the imports' 130 000 objects out of the cyclic collector's sight: a full collection
    # scanned them all (80 ms, inside whichever job it fell in: the re-check's random
    # slow drops); with them frozen it takes 3-8 ms (Python's gc.freeze, made for this)
    gc.freeze()


def _first_choice(files: dict) -> str:
    choices = list(files) + catalogue_names()
    return choices[0] if files or "four_bar" not in choices else "four_bar"


class Workbench:
    """Every widget and result of one browser session."""

    def __init__(self, files: dict | None = None, atlases=(), threshold: float = 40.0, later: bool = False,
                 requested: str | None = None, shared: str | None = None):
        """``later``: the check panel joins the page at :meth:`show_rest` (the first
        render then carries the drawing and its player alone); ``requested``: the menu
        entry the page's address names (``?mechanism=NAME``), opened first (anything but
        an entry is the one-line message, over the default mechanism); ``shared``: the
        address's design code (``?design=CODE``, :mod:`.share`), opened before all (a bad
        code is the one-line message)."""
        from bokeh.models import Column, Row

        from .check_view import CheckView
        from .editing import Editor
        from .exports import ExportBar
        from .glue import Upload, div
        from .holding import Hold
        from .later_tabs import LaterTabs
        from .mechanism_view import MechanismView
        from .menus import Menu
        from .share import Address, open_first
        from .units import UnitsBar

        self.files = dict(files or {})          # name -> Mechanism (read at start-up)
        self.threshold = threshold
        self.mechanism, self.mechanism_name = None, ""
        self.check_doc = None                   # the open design's check, once computed
        self.job = None
        self.wake = None                        # wake(): poll soon, from a job's thread (set by the server)
        self.hold = Hold()                      # an edit's showing, held until its job ends (:mod:`.holding`)
        self.message = div(EMPTY_MESSAGE)
        self.check = CheckView(self.move_to, self.cancel_check)
        self.view = MechanismView(self.say, cursors=[self.check.cursor], on_drag=lambda *a: self.editor.drag(*a))
        self.editor = Editor(self.say, self._show_edit, self.view.sweeps_of)
        self.edit_base = ""                      # the name of the design the edits start from
        choices = list(self.files) + catalogue_names()
        first = requested if requested in choices else _first_choice(self.files)
        self.menu = Menu("mechanism menu", self.say, choices, first, MENU_HINT, title="mechanism", width=240,
                         css_classes=["ml-pick"])
        self.pick = self.menu.select
        self.opener = Upload("open a .toml, .json or .pyslvs file…", ".toml,.json,.pyslvs", self.open_upload,
                             self.say, "ml-open")
        self.upload = self.opener.target
        self.exports = ExportBar(lambda: (self.mechanism, self.check_doc, self.threshold), self.say)
        self.units = UnitsBar(self.say, (self.editor, self.view, self.check))
        self.check.mark = self.view.mark
        self.address = Address()
        self.structure = div("")
        self.designs: dict = {}                 # menu entry -> an uploaded or synthesised design
        self.menu.on_choice(self.open_name)
        self.synthesis, self.atlas = None, None
        self.mechanism_tab = Row(Column(self.editor.panel, self.view.panel), *([] if later else [self.check.panel]))
        self.pages = LaterTabs([("Mechanism", self.mechanism_tab), ("Structure", self.structure),
                                ("Synthesis", lambda: self._synthesis_view(choices, atlases))]
                               + ([("Atlas", lambda: self._atlas_view(list(atlases)))] if atlases else []))
        self.tabs = self.pages.tabs
        header = Row(div(html("<b>multiloop workbench</b>"), width=200), self.pick, self.opener.button, self.upload,
                     self.exports.menu.select, self.exports.download.button, *self.units.widgets)
        self.panel = Column(header, self.message, self.tabs, self.address.model, sizing_mode="stretch_width")
        open_first(self, first, requested, shared, MENU_HINT)

    def _synthesis_view(self, choices, atlases):
        from .synthesis_view import SynthesisView
        self.synthesis = SynthesisView(["(open mechanism)"] + choices, self._start, self.open_candidate, self.say,
                                       atlases)
        self.units.add(self.synthesis)
        return self.synthesis.panel

    def _atlas_view(self, atlases):
        from .atlas_view import AtlasView
        self.atlas = AtlasView(atlases, self.say, self.open_candidate, self.start_synthesis)
        return self.atlas.panel

    # ------------------------------------------------------------------ messages
    def say(self, text: str) -> None:
        """One line at the top of the page (the message of a bad file or option)."""
        self.message.text = html('<div id="ml-message" data-error="1" style="color:#b00020;font-weight:bold">'
                                 "{text}</div>", text=text)

    def clear(self) -> None:
        self.message.text = EMPTY_MESSAGE

    # ------------------------------------------------------------------ opening
    def open_name(self, name: str) -> None:
        """Open the menu's entry ``name``: a FILE, a design opened before, or a catalogue
        name (anything else is refused with the message)."""
        from multiloop.topo.errors import LinkageError
        if name in self.designs:
            self.open_design(self.designs[name], name)
            return
        try:
            m = load_choice(self.files, name)
        except LinkageError as exc:
            self.say(str(exc))
            self._follow()
            return
        self.open_design(m, name, key=name)

    def _follow(self) -> None:
        """The menu names the mechanism shown (a new entry for an uploaded or synthesised
        design), without opening it again."""
        name = self.mechanism_name
        if name and name not in self.menu.choices:
            self.menu.set([name, *self.menu.choices], name)
        elif name:
            self.menu.set(value=name)

    def open_upload(self, name: str, data: bytes) -> None:
        from multiloop.inputs import load_upload
        from multiloop.topo.errors import LinkageError
        try:
            m = load_upload(name, data)
        except LinkageError as exc:
            self.say(str(exc))
            return
        self.open_design(m, f"upload: {name}")

    def _start(self, name: str):
        if name == "(open mechanism)":
            if self.mechanism is None:
                from multiloop.topo.errors import InputError, explain
                raise InputError(explain("start mechanism", expected="an open mechanism", got="none"))
            return self.mechanism
        return load_choice(self.files, name)

    def open_candidate(self, m, name: str | None = None) -> None:
        """Open a synthesised design and show it in the mechanism tab."""
        self.open_design(m, name)
        if self.mechanism is m:
            self.tabs.active = 0

    def start_synthesis(self, m, name: str) -> None:
        """Open ``m`` and make it the synthesis's start (the Synthesis tab shown)."""
        self.open_design(m, name)
        if self.mechanism is m:
            self.pages.build(2)
            self.synthesis.choose_start("(open mechanism)")
            self.tabs.active = 2

    def _show_edit(self, m) -> None:
        """Show a design the editor made (an edit, an undo or a redo)."""
        self.open_design(m, f"edited: {self.edit_base}", edited=True)

    def open_design(self, m, name: str | None = None, key: str | None = None, edited: bool = False) -> None:
        """Show ``m``: the reference drawing and the structure now, motion and check later
        (at once when the server has them for ``key``, a catalogue name or FILE); the job
        of the mechanism shown before is cancelled.  A design not ``edited`` starts the
        editor's history; an ``edited`` one is shown with its check when that ends within
        :data:`~.holding.EDIT_WAIT_MS` (:class:`~.holding.Hold`)."""
        from multiloop.topo.errors import LinkageError

        from .jobs import Job
        try:
            scene, structure = _scene(m, key)
        except LinkageError as exc:
            self.say(f"{name}: {exc}" if edited else str(exc))
            self._follow()                  # the menu goes back to the mechanism shown
            return
        if self.job is not None:
            self.job.cancel()
        self.clear()
        self.mechanism, self.mechanism_name = m, name or f"design: {m.name or 'unnamed'}"
        self.check_doc = None
        if not edited:
            self.edit_base = self.mechanism_name
            self.editor.reset(m)
        if key is None:
            self.designs[self.mechanism_name] = m
        self.scene = scene
        self.job = None
        if m.drivers and m.has_geometry:
            self.job = Job(lambda job: _motion_and_check(job, m, self.threshold, key), "check", self.wake)
        # an edit's drawing and check together, unless its job takes longer
        self.hold.open(lambda: _show_design(self, m, key, scene, structure, edited), edited and self.job is not None)

    def cancel_check(self) -> None:
        """The check panel's Cancel: the running motion / check job stops at its next solve."""
        if self.job is not None:
            self.job.cancel()

    # ------------------------------------------------------------------ updates
    def poll(self) -> None:
        """The session's periodic callback: results of the background jobs."""
        if self.synthesis is not None:
            self.synthesis.poll()
        if self.atlas is not None:
            self.atlas.opener.poll()
        job = self.job
        if not (job is not None and job.running):
            self.hold.release()
        if job is None or self.hold.show is not None:
            return
        if not self.shown_sweeps and getattr(job, "sweeps", None) is not None:
            self.shown_sweeps = True
            self.view.show(self.scene, job.sweeps, self.mechanism_name, keep_view=self.view.keep_view)
            self.check.busy("check: computing…", running=True)
        if job.running:
            return
        self.job = None
        if job.state == "cancelled":
            self.check.busy("check cancelled")
        elif job.state == "failed":
            self.say(job.error)
            self.check.busy(f"check failed: {job.error}")
        elif job.state == "done":
            self.check_doc = job.result
            self.check.show(job.result, self.view.current if self.view.sweeps else None, self.threshold,
                            getattr(job, "report", None))

    def move_to(self, x) -> None:
        if x is not None and self.view.sweeps and np.isfinite(x):
            self.view.move_to(float(x))

    def show_rest(self) -> None:
        """Add the check panel to the mechanism tab (once)."""
        if self.check.panel not in self.mechanism_tab.children:
            self.mechanism_tab.children = [*self.mechanism_tab.children, self.check.panel]

    def stop_jobs(self) -> None:
        """Cancel the running motion / check and synthesis (the tab is gone)."""
        if self.job is not None:
            self.job.cancel()
        if self.synthesis is not None:
            self.synthesis.cancel()

    def close(self) -> None:
        self.stop_jobs()
        if self.atlas is not None:
            self.atlas.close()


def _show_design(wb, m, key, scene, structure, edited: bool = False) -> None:
    """The widgets of the design ``wb`` opened (``m``, its ``scene`` and ``structure``):
    its drawing with the motion the server or the job has (an ``edited`` design in the
    view of the one before, when it fits), the check panel waiting."""
    wb._follow()
    wb.address.follow(m, key)
    wb.structure.text = structure
    sweeps = (_SWEEPS.get(key) if key is not None else None) or getattr(wb.job, "sweeps", None)
    wb.shown_sweeps = sweeps is not None
    wb.view.show(scene, list(sweeps or ()), wb.mechanism_name, keep_view=edited)
    if not m.drivers:
        wb.check.show(None, None, wb.threshold)
    elif not m.has_geometry:
        wb.check.busy("no geometry: nothing to move or check")
    else:
        wb.check.busy("check: computing…" if sweeps else "motion and check: computing…", running=True)


def _start_warm_up(files: dict, threshold: float):
    """Start the warm-up of the first mechanism a page shows: a child process
    (:mod:`.prepare`) when one starts.  Returns a function that starts :func:`warm_up`'s
    thread (after Bokeh's import: in this process they would only take turns) and
    returns its events (ready, first page shown)."""
    import threading

    from .prepare import start
    name = _first_choice(files)
    m = load_choice(files, name)
    from .second_core import cores
    child = start(m, threshold) if cores() > 1 else None     # on one core it would only take turns
    _WARMING[name] = threading.Event()

    def then():
        warm, shown = threading.Event(), threading.Event()
        threading.Thread(target=warm_up, args=(name, m, threshold, child, warm, shown),
                         name="multiloop-web-warm-up", daemon=True).start()
        return warm, shown
    return then


#: longest ``?mechanism=`` value read from the page's address (longer is refused as it is)
MAX_REQUESTED = 200


def requested_mechanism(doc) -> str | None:
    """The menu entry the page's address names (``?mechanism=NAME``; its token and other
    arguments are left to :mod:`.access`), or None: text only, looked up among the
    menu's entries, never used as a path."""
    from .share import address_argument
    return address_argument(doc, "mechanism", MAX_REQUESTED)


def _page_maker(files: dict, atlases, threshold: float, watch, warm, shown):
    """The server's page function: the session's :class:`Workbench` once the warm-up is
    ``warm``; the check panel follows once the browser shows the drawing (``shown``).
    Its jobs stop once the tab's connection is lost (``watch``, a :class:`~.tabs.TabWatch`)."""
    from bokeh.events import DocumentReady
    from bokeh.models import CustomJS

    from .atlas_design import CARD_CLICK_JS
    from .layout_batch import LAYOUT_BATCH_JS
    from .glue import held

    def page(doc):
        warm.wait(timeout=5.0)           # the warm-up is the quickest way to the first page
        from .share import requested_design
        wb = Workbench(files, atlases, threshold, later=True, requested=requested_mechanism(doc),
                       shared=requested_design(doc))
        def poll():                     # the results shown in one batch of changes
            with held(doc):
                wb.poll()
        doc.add_periodic_callback(poll, 150)
        wb.wake = lambda: doc.add_next_tick_callback(poll)      # a job's result shown at once

        def later(ms, fn):
            def run():
                with held(doc):
                    fn()
            doc.add_timeout_callback(run, ms)
        wb.hold.later = later

        def rest(_event):               # a second message, after the drawing's
            wb.show_rest()
            shown.set()
        doc.on_event(DocumentReady, rest)
        doc.js_on_event(DocumentReady, wb.editor.keys)
        doc.js_on_event(DocumentReady, CustomJS(code=CARD_CLICK_JS))
        doc.js_on_event(DocumentReady, CustomJS(code=LAYOUT_BATCH_JS))
        doc.js_on_event(DocumentReady, wb.address.glue)
        watch.add(doc.session_context.id, wb.stop_jobs)

        def closed(ctx):                # the session's callbacks are removed by Bokeh itself
            watch.discard(ctx.id)
            wb.close()
        doc.on_session_destroyed(closed)
        doc.title = "multiloop"
        doc.add_root(wb.panel)
    return page


def _make_server(page, port: int, host: str, token: str | None):
    """Bokeh's server for ``page`` on ``host:port`` and its :class:`~.access.Access`
    (``token``: None asks for none), every script from this server (no CDN) and only
    the BokehJS bundles the page uses (not MathJax's, nor the data table's nor WebGL's:
    2.3 MB of script that a first load would run for nothing).  A request the access
    rules refuse gets 403 before Bokeh sees it."""
    from bokeh.application import Application
    from bokeh.application.handlers.function import FunctionHandler
    from bokeh.server.server import BaseServer
    from bokeh.server.tornado import BokehTornado
    from bokeh.server.util import bind_sockets
    from tornado.httpserver import HTTPServer
    from tornado.ioloop import IOLoop

    from .access import Access, Refused, netloc

    class Tornado(BokehTornado):
        def resources(self, absolute_url=None):
            res = super().resources(absolute_url)
            return res.clone(components=[c for c in res.components if c in ("bokeh", "bokeh-widgets")])

        def find_handler(self, request, **kwargs):
            reason = access.refusal(request)
            if reason is not None:
                return self.get_handler_delegate(request, Refused, {"reason": reason})
            return super().find_handler(request, **kwargs)

    sockets, port = bind_sockets(host, port)
    access = Access.of(host, port, token)
    app = Tornado({"/": Application(FunctionHandler(page))}, extra_websocket_origins=sorted(access.hosts),
                  absolute_url=f"http://{netloc(host, port)}", check_unused_sessions_milliseconds=1000,
                  unused_session_lifetime_milliseconds=15000, exclude_headers=["Cookie"],
                  exclude_cookies=[access.cookie])
    app.add_transform(access.transform())
    http = HTTPServer(app)
    http.add_sockets(sockets)
    return BaseServer(IOLoop.current(), app, http), access


def serve(files: dict, *, port: int = 5006, host: str = ADDRESS, open_browser: bool = False,
          atlases=(), threshold: float = 40.0, ready=None, token: str | None = None,
          require_token: bool = True) -> None:
    """Serve the workbench until interrupted (Bokeh's server, every asset served by it).

    ``files`` maps names to mechanisms read before serving; ``port`` 0 lets the system
    pick a free one; ``token`` is the page's token (None: a fresh random one), asked of
    every request unless ``require_token`` is false (:mod:`.access`); ``ready(url)`` is
    called once the server listens, with the page's address (its port and token).

    Raises
    ------
    OSError
        The port cannot be bound (``errno.EADDRINUSE``: it is in use).
    """
    from .access import new_token
    from .tabs import TabWatch
    os.environ["BOKEH_RESOURCES"] = "server"      # BokehJS from this server, no CDN
    warm_up_then = _start_warm_up(files, threshold)     # before Bokeh's import: they overlap
    import bokeh.server.server  # noqa: F401 - imported first, then the warm-up's thread starts
    watch = TabWatch()
    page = _page_maker(files, atlases, threshold, watch, *warm_up_then())
    server, access = _make_server(page, port, host, (token or new_token()) if require_token else None)
    watch.start(server)
    url = access.url(host)
    if ready is not None:
        ready(url)
    if open_browser:
        import webbrowser
        server.io_loop.add_callback(lambda: webbrowser.open(url))
    try:
        server.start()
        server.io_loop.start()
    except KeyboardInterrupt:
        print("multiloop serve: stopped", file=sys.stderr)
    finally:
        server.stop()
