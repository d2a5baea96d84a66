"""The workbench page of one browser session, and the server that serves it.

:class:`Workbench` holds every widget and result of one session (two tabs are two
sessions: nothing is shared but the read-only mechanisms given on the command line).
A mechanism opens at once at its reference; its motions and its design check are
computed by background :class:`~.jobs.Job` s and appear when ready, so a long job never
blocks the page.
"""
from __future__ import annotations

import html
import os
import sys
from importlib import resources

import numpy as np

__all__ = ["Workbench", "serve", "catalogue_names", "ADDRESS"]

#: the only address served unless another host is asked for
ADDRESS = "127.0.0.1"


def catalogue_names() -> list[str]:
    folder = resources.files("multiloop.catalogue") / "mechanisms"
    return sorted(e.name[:-5] for e in folder.iterdir() if e.name.endswith(".toml"))


def _analysis(m):
    """The structural report and the Assur plan of ``m`` as HTML tables."""
    from multiloop.topo.assur import decompose
    from multiloop.topo.errors import LinkageError
    from multiloop.topo.numbers import structural_report

    rep = structural_report(m).as_dict()
    keep = ("n", "p", "LA", "MJA", "V", "K", "L", "AVC", "F", "N", "rc", "SL", "La", "L0", "code", "code_star",
            "planar", "degenerate", "fractionated", "actual_F", "redundant", "canonical")
    rows = "".join(f"<tr><td>{k}</td><td>{html.escape(str(rep.get(k)))}</td></tr>" for k in keep if k in rep)
    out = f'<h3>Structural report</h3><table id="ml-structure">{rows}</table>'
    if not m.drivers:
        return out
    try:
        plan = decompose(m).as_dict()
    except LinkageError as exc:
        return out + f"<p>{html.escape(str(exc))}</p>"
    grows = "".join(f"<tr><td>{html.escape(g['label'])}</td><td>{html.escape(str(g['kind']))}</td>"
                    f"<td>{html.escape(', '.join(g['links']))}</td><td>{html.escape(', '.join(g['joints']))}</td></tr>"
                    for g in plan["groups"])
    return out + (f'<h3>Structure formula</h3><p id="ml-formula">{html.escape(plan["formula"])}</p>'
                  f'<table id="ml-groups"><tr><th>group</th><th>kind</th><th>links</th><th>joints</th></tr>'
                  f"{grows}</table>")


#: results shared read-only by every session of this server: the sweeps of a named
#: mechanism (catalogue name or FILE) and its check documents per threshold
_SWEEPS: dict[str, tuple] = {}
_CHECKS: dict[tuple[str, float], dict] = {}


def _sweeps(m, key: str | None, cancel=None) -> tuple:
    """The sweep of every driver of ``m``, from the server's cache when ``key`` names it."""
    from .scene import sweep_driver
    if key is not None and key in _SWEEPS:
        return _SWEEPS[key]
    out = tuple(sweep_driver(m, k, cancel=cancel) for k in range(len(m.drivers)))
    if key is not None:
        _SWEEPS[key] = out
    return out


def _motion_and_check(job, m, threshold, key=None):
    """Worker: the sweeps of every driver, then the check (its JSON document); both
    stop at the next solve once the job is cancelled."""
    from multiloop.kin.check import check

    job.sweeps = _sweeps(m, key, job.poll)
    job.report(1 / 2)
    if key is not None and (key, threshold) in _CHECKS:
        return _CHECKS[key, threshold]
    doc = check(m, min_transmission=threshold, cancel=job.poll).as_dict()
    if key is not None:
        _CHECKS[key, threshold] = doc
    return doc


def warm_up(files: dict, imported) -> None:
    """Import what a session uses (then set the event ``imported``) and solve the sweeps
    of the first mechanism a page shows, so that the first session is built as fast as
    the next ones and shows its motion at once."""
    try:
        from multiloop.inputs import load_mechanism

        from . import check_view, mechanism_view, synthesis_view  # noqa: F401 - imported for the sessions
    finally:
        imported.set()                      # a session never waits for a failed warm-up
    name = _first_choice(files)
    try:
        m = files[name] if name in files else load_mechanism(name)
        if m.drivers and m.has_geometry:
            _sweeps(m, name)
    except Exception:  # noqa: BLE001 - the session's own job computes it again and reports
        pass


def _first_choice(files: dict) -> str:
    choices = list(files) + catalogue_names()
    return choices[0] if files or "four_bar" not in choices else "four_bar"


class Workbench:
    """Every widget and result of one browser session."""

    def __init__(self, files: dict | None = None, atlases=(), threshold: float = 40.0):
        import panel as pn

        from .check_view import CheckView
        from .mechanism_view import MechanismView
        from .synthesis_view import SynthesisView

        self.files = dict(files or {})          # name -> Mechanism (read at start-up)
        self.threshold = threshold
        self.mechanism, self.mechanism_name = None, ""
        self.job = None
        self.message = pn.pane.HTML('<div id="ml-message"></div>', sizing_mode="stretch_width")
        self.check = CheckView(self.move_to, self.cancel_check)
        self.view = MechanismView(cursors=[self.check.cursor])
        choices = list(self.files) + catalogue_names()
        first = _first_choice(self.files)
        self.pick = pn.widgets.Select(name="mechanism", options=choices, value=first, width=240,
                                      css_classes=["ml-pick"])
        self.upload = pn.widgets.FileInput(name="upload", accept=".toml,.json,.pyslvs", multiple=False)
        self.structure = pn.pane.HTML("", sizing_mode="stretch_width")
        self.pick.param.watch(lambda e: self.open_name(e.new), "value")
        self.upload.param.watch(lambda e: self.open_upload(), "value")
        self.synthesis = SynthesisView(["(open mechanism)"] + choices, self._start, self.open_design, self.say, atlases)
        tabs = [("Mechanism", pn.Row(self.view.panel, self.check.panel)), ("Structure", self.structure),
                ("Synthesis", self.synthesis.panel)]
        self.atlas = None
        if atlases:
            from .atlas_view import AtlasView
            self.atlas = AtlasView(list(atlases), self.say)
            tabs.append(("Atlas", self.atlas.panel))
        header = pn.Row(pn.pane.HTML("<b>multiloop workbench</b>"), self.pick,
                        pn.Column(pn.pane.HTML("open a .toml, .json or .pyslvs file:"), self.upload))
        # not dynamic: a tab rendered later by the server fetches Panel's stylesheets from
        # its CDN, whatever the resources setting (seen with Panel 1.9.4)
        self.tabs = pn.Tabs(*tabs, dynamic=False)
        self.panel = pn.Column(header, self.message, self.tabs, sizing_mode="stretch_width")
        self.open_name(first)

    # ------------------------------------------------------------------ messages
    def say(self, text: str) -> None:
        """One line at the top of the page (the message of a bad file or option)."""
        self.message.object = (f'<div id="ml-message" data-error="1" style="color:#b00020;font-weight:bold">'
                               f"{html.escape(text)}</div>")

    def clear(self) -> None:
        self.message.object = '<div id="ml-message"></div>'

    # ------------------------------------------------------------------ opening
    def open_name(self, name: str) -> None:
        from multiloop.inputs import load_mechanism
        from multiloop.topo.errors import LinkageError
        try:
            m = self.files[name] if name in self.files else load_mechanism(name)
        except LinkageError as exc:
            self.say(str(exc))
            return
        self.open_design(m, name, key=name)

    def open_upload(self) -> None:
        from multiloop.inputs import load_upload
        from multiloop.topo.errors import LinkageError
        name = self.upload.filename or "upload"
        try:
            m = load_upload(name, self.upload.value or b"")
        except LinkageError as exc:
            self.say(str(exc))
            return
        self.open_design(m, name)

    def _start(self, name: str):
        if name == "(open mechanism)":
            if self.mechanism is None:
                from multiloop.topo.errors import InputError, explain
                raise InputError(explain("start mechanism", expected="an open mechanism", got="none"))
            return self.mechanism
        from multiloop.inputs import load_mechanism
        return self.files[name] if name in self.files else load_mechanism(name)

    def open_design(self, m, name: str | None = None, key: str | None = None) -> None:
        """Show ``m``: the reference drawing and the structure now, motion and check later
        (at once when the server has them for ``key``, a catalogue name or FILE); the job
        of the mechanism shown before is cancelled."""
        from multiloop.topo.errors import LinkageError

        from .jobs import Job
        from .scene import scene_of
        try:
            scene = scene_of(m)
            structure = _analysis(m)
        except LinkageError as exc:
            self.say(str(exc))
            return
        if self.job is not None:
            self.job.cancel()
        self.clear()
        self.mechanism, self.mechanism_name = m, name or m.name or "design"
        self.scene = scene
        self.structure.object = structure
        ready = _SWEEPS.get(key) if key is not None else None
        self.shown_sweeps = ready is not None
        self.view.show(scene, list(ready or ()), self.mechanism_name)
        if not m.drivers:
            self.check.show(None, None, self.threshold)
        elif not m.has_geometry:
            self.check.busy("no geometry: nothing to move or check")
        else:
            self.check.busy("check: computing…" if ready else "motion and check: computing…", running=True)
            self.job = Job(lambda job: _motion_and_check(job, m, self.threshold, key), "check")
        self.tabs.active = 0

    def cancel_check(self) -> None:
        """The check panel's Cancel: the running motion / check job stops at its next solve."""
        if self.job is not None:
            self.job.cancel()

    # ------------------------------------------------------------------ updates
    def poll(self) -> None:
        """The session's periodic callback: results of the background jobs."""
        self.synthesis.poll()
        job = self.job
        if job is None:
            return
        if not self.shown_sweeps and getattr(job, "sweeps", None) is not None:
            self.shown_sweeps = True
            self.view.show(self.scene, job.sweeps, self.mechanism_name)
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
            events = self.check.show(job.result, self.view.current if self.view.sweeps else None, self.threshold)
            if self.view.sweeps:
                self.view.mark(events)

    def move_to(self, x) -> None:
        if x is not None and self.view.sweeps and np.isfinite(x):
            self.view.move_to(float(x))

    def close(self) -> None:
        if self.job is not None:
            self.job.cancel()
        self.synthesis.cancel()
        if self.atlas is not None:
            self.atlas.close()


def serve(files: dict, *, port: int = 5006, host: str = ADDRESS, open_browser: bool = False,
          atlases=(), threshold: float = 40.0, ready=None) -> None:
    """Serve the workbench until interrupted (Panel/Bokeh server, every asset served by it).

    ``files`` maps names to mechanisms read before serving; ``ready(url)`` is called
    once the server listens (the command prints the address).
    """
    os.environ["BOKEH_RESOURCES"] = "server"      # Bokeh's and Panel's JS from this server, no CDN
    import panel as pn

    pn.config.inline = False
    pn.extension(design="native", notifications=False)

    from panel.io.resources import LOCAL_DIST

    def page():
        # every stylesheet of this document from this server (Panel defaults to its CDN
        # for models made outside the page's first render, e.g. a tab opened later)
        pn.state.curdoc._template_variables["dist_url"] = LOCAL_DIST
        imported.wait(timeout=60)
        wb = Workbench(files, atlases, threshold)
        cb = pn.state.add_periodic_callback(wb.poll, period=150)

        def closed(_ctx):
            cb.stop()
            wb.close()
        pn.state.on_session_destroyed(closed)
        return wb.panel

    import threading
    imported = threading.Event()
    threading.Thread(target=warm_up, args=(files, imported), name="multiloop-web-warm-up", daemon=True).start()
    server = pn.serve({"/": page}, port=port, address=host, show=False, start=False, title="multiloop",
                      websocket_origin=[f"{host}:{port}", f"localhost:{port}", f"127.0.0.1:{port}"],
                      verbose=False, check_unused_sessions=1000, unused_session_lifetime=15000)
    url = f"http://{host}:{server.port}/"
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
