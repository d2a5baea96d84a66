"""The synthesis panel: a target path drawn freehand or uploaded, a start, the options of
``multiloop synthesise``, a background run with progress and cancel, the candidates.

Each candidate is one :func:`multiloop.catalogue.dimensional.synthesise` run (seeds
``seed``, ``seed + 1``, …, each with its share of the budget), or, with no start, one
design of :func:`multiloop.catalogue.topology_synthesis.synthesise` (the atlas chooses
the topology: retrieval of stored coupler curves, then local polish; Nobari et al.
2024).  A candidate is drawn over the target, opens in the mechanism view, and
downloads as ``.toml`` or ``.pyslvs`` (:mod:`multiloop.topo.pyslvs`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from bokeh.models import (Button, Checkbox, CheckboxGroup, Column, ColumnDataSource, CustomJSTickFormatter, NumericInput,
                          Row, TextInput)
from bokeh.plotting import figure

from multiloop.catalogue.dimensional.optimise import METHODS
from multiloop.topo.errors import InputError, LinkageError, explain

from .glue import Download, Upload, div, progress_html
from .jobs import Job
from .markup import Html, html, join
from .mechanism_view import TICKS_JS
from .menus import Menu, refusal
from .target_drawing import TargetDrawing
from .units import Units, table_in_si

#: what a target upload is, in the hint of its size refusal
TARGET_UPLOAD = "upload a target table of x, y rows (a few hundred points are plenty)"

__all__ = ["SynthesisView", "AtlasDesign", "run_candidates", "run_atlas", "NO_START"]
#: the start menu's entry for synthesis without a start
NO_START = "none: the atlas chooses the topology"


@dataclass(frozen=True)
class AtlasDesign:
    """A design of the synthesis without a start, as a candidate of the list: the
    mechanism, its errors, its structure formula and ``achieved``, its tracer's path over
    the driver's motion (drawn over the target); ``deviation``: the retrieved curve's
    largest deviation from the target (m), shown in the list's ``stopped`` column, with
    ``fit`` (``"curve"`` when the design was refined by the distance between the curves,
    :class:`multiloop.catalogue.topology_synthesis.Design`)."""

    mechanism: object
    error_max: float
    error_rms: float
    structure: str
    achieved: np.ndarray
    seed: str = "atlas"
    stopped: str = ""
    deviation: float | None = None
    fit: str = "points"


def traced(m) -> np.ndarray:
    """The path of every tracer point of ``m`` over its first driver's motion,
    (points, frames, 2); NaN where the motion does not reach."""
    from .scene import sweep_driver
    sw = sweep_driver(m, 0)
    P = np.array(sw.nodes[:, len(m.joints):len(m.joints) + len(m.points)], float).transpose(1, 0, 2)
    P[:, ~np.asarray(sw.ok, bool)] = np.nan
    return P


def run_candidates(job: Job, start, target: np.ndarray, n: int, options: dict) -> list:
    """``n`` synthesis runs (seeds ``seed``…) in the worker of ``job``; the finished ones
    are in ``job.partial`` as they come.  Cancelling stops the current run."""
    from multiloop.catalogue.dimensional import synthesise

    out = job.partial = []
    seed, budget = int(options.pop("seed")), float(options.pop("budget"))
    for c in range(n):
        res = synthesise(start, path=target, seed=seed + c, budget=budget / n,
                         progress=lambda f, b, c=c: job.report((c + f) / n, b), **options)
        out.append(res)
        job.report((c + 1) / n, min(r.error_rms for r in out))
    return out


def run_atlas(job: Job, target: np.ndarray, options: dict) -> list:
    """The synthesis without a start in the worker of ``job``: its designs, each with its
    traced path, in ``job.partial``.  The library reports the share of the budget spent
    before every polish (not inside one): a cancel ends the run at the next polish, and
    the page stops waiting at once (:meth:`SynthesisView.cancel`)."""
    from multiloop.catalogue.topology_synthesis import synthesise

    job.partial = []
    res = synthesise(path=target, progress=lambda f: job.report(0.95 * f), **options)
    out = []
    for d in res.designs:
        P = traced(d.mechanism)
        i = [p.name for p in d.mechanism.points].index(options["point"])
        out.append(AtlasDesign(d.mechanism, d.error_max, d.error_rms, d.structure, P[i],
                               deviation=float(d.deviation_max), fit=d.fit))
    if not out:
        raise InputError(explain("target path", expected="a design that passes check",
                                 got=f"none of {res.polished} polished candidates",
                                 hint="a larger budget, more links, or more curves in the atlas"))
    job.partial = out
    job.report(1.0, min(d.error_rms for d in out))
    return out


def stopped_text(r, units: Units) -> str:
    """The ``stopped`` column of candidate ``r``: why its run stopped, or an atlas
    design's deviation in the page's length unit (and "curve fit" for a design refined by
    the distance between the curves)."""
    dev = getattr(r, "deviation", None)
    if dev is None:
        return r.stopped
    return f"deviation {units.shown(dev, 'm'):.3g} {units.length}" + (", curve fit" if r.fit == "curve" else "")


def csv_label(units: Units) -> str:
    """The target upload's label: the units its table is read in (x and y in the length
    unit; a third column, the input, in the angle unit, or the length unit for a slider)."""
    return f"target CSV in {units.length}, {units.angle}…"


def status_html(text: str, state: str | None = None) -> Html:
    """The status line of the synthesis (``#ml-synthesis-status``, ``data-state`` once a run began)."""
    if state is None:
        return html('<p id="ml-synthesis-status">{text}</p>', text=text)
    return html('<p id="ml-synthesis-status" data-state="{state}">{text}</p>', state=state, text=text)


def _float_or_none(text: str, what: str):
    text = (text or "").strip()
    if not text:
        return None
    try:
        v = float(text)
    except ValueError:
        raise InputError(explain(what, expected="a number or nothing", got=repr(text))) from None
    if not np.isfinite(v):
        raise InputError(explain(what, expected="a finite number", got=repr(text)))
    return v


#: the hint of the message when no atlas was given to serve, or another was asked for
ATLAS_HINT = "the atlases given to 'multiloop serve --atlas DB' (built by 'multiloop atlas')"

#: the link counts offered to the synthesis without a start (``--links``)
LINK_CHOICES = ("4", "6", "8")


def _widgets() -> dict:
    def number(title, value, mode="float", width=100, **kw):
        return NumericInput(title=title, value=value, mode=mode, width=width, **kw)
    return dict(
        seed=number("seed", 0, "int", 90, css_classes=["ml-seed"]),
        budget=number("budget (s)", 4.0, low=0.1, css_classes=["ml-budget"]),
        tol=number("tol", 1e-6),
        candidates=number("candidates", 1, "int", low=1, high=8),
        shape_only=Checkbox(label="shape only", active=False),
        full_rotation=Checkbox(label="full rotation", active=False),
        min_transmission=TextInput(title="min transmission (deg)", value="", width=150),
        max_ratio=TextInput(title="max ratio", value="", width=100),
        length_low=TextInput(title="length ≥ (m)", value="", width=100),
        length_high=TextInput(title="length ≤ (m)", value="", width=100),
        run=Button(label="Run", button_type="primary", width=90),
        cancel=Button(label="Cancel", button_type="warning", width=90, disabled=True),
        clear=Button(label="Clear target", width=110),
        links=CheckboxGroup(labels=list(LINK_CHOICES), active=list(range(len(LINK_CHOICES))), inline=True),
        top=number("designs (--top)", 3, "int", 110, low=1, high=10),
        ties=number("ties (--tol)", 1e-4, low=0.0),
        open=Button(label="Open in mechanism view", width=190),
    )


def _menus(say, starts: list[str], atlases) -> dict:
    """The panel's menus: each holds only the choices the server gives it."""
    return dict(
        start=Menu("start menu", say, [*starts[:1], NO_START, *starts[1:]], title="start mechanism", width=200,
                   css_classes=["ml-start"]),
        point=Menu("tracer point menu", say, title="tracer point (--point)", width=160),
        method=Menu("method menu", say, METHODS, METHODS[0], title="method", width=90),
        atlas=Menu("atlas menu", say, [str(a) for a in atlases], hint=ATLAS_HINT, title="atlas (--db)",
                   width=260, css_classes=["ml-atlas"]),
        pick=Menu("candidate menu", say, title="candidate", width=120),
    )


class SynthesisView:
    """The synthesis panel of one session.  ``load_start(name)`` gives a start mechanism
    (a catalogue name, or the open one), ``open_design(m)`` shows a candidate, ``say``
    shows a one-line message.  The start :data:`NO_START` lets the atlas choose the
    topology; its atlas is one of ``atlases`` (``multiloop serve --atlas``), the first
    at first."""

    def __init__(self, starts: list[str], load_start, open_design, say, atlases=()):
        self.load_start, self.open_design, self.say = load_start, open_design, say
        self.menus = _menus(say, starts, atlases)
        self.w = w = _widgets() | {k: menu.select for k, menu in self.menus.items()}
        self.target = None
        self.job: Job | None = None
        self.results: list = []
        self.uploaded = ColumnDataSource(dict(x=[], y=[]), name="ml-target-upload")     # in m
        self.start_src = ColumnDataSource(dict(xs=[], ys=[]))
        self.curves = ColumnDataSource(dict(xs=[], ys=[], colour=[]))
        self.fig = self._figure()
        self.drawing = TargetDrawing(self.fig, say)
        self.menus["start"].on_choice(lambda name: self._start_changed())
        self.csv = Upload(csv_label(Units()), ".csv,.txt", self._upload, say, "ml-csv", hint=TARGET_UPLOAD)
        self.target_units = Units()         # the units the uploaded target was read in
        w["run"].on_click(lambda: self.run())
        w["cancel"].on_click(lambda: self.cancel())
        w["clear"].on_click(lambda: self._clear())
        w["open"].on_click(lambda: self._open())
        self.menus["pick"].on_choice(lambda i: self._draw_candidates())
        self.units = Units()
        self.status = div(status_html("draw a target path or upload a CSV"))
        self.progress = div(progress_html(0.0))
        self.table = div("")
        self.downloads = [Download(f"Download .{f}", lambda f=f: self._download(f)) for f in ("toml", "pyslvs")]
        self.atlas_box = Column(w["atlas"], Row(div("links (--links):", width=100), w["links"]),
                                Row(w["top"], w["ties"]), visible=False)
        self.panel = Row(
            Column(w["start"], self.atlas_box, w["point"], Row(self.csv.button, self.csv.target), Row(w["method"], w["seed"], w["budget"]),
                   Row(w["tol"], w["candidates"]), Row(w["shape_only"], w["full_rotation"]),
                   Row(w["min_transmission"], w["max_ratio"]), Row(w["length_low"], w["length_high"]),
                   Row(w["run"], w["cancel"], w["clear"]), self.progress, self.status, width=380),
            Column(*self.drawing.widgets, width=130),
            Column(self.fig, self.table, Row(w["pick"], w["open"]), Row(*(d.button for d in self.downloads))))

    def _figure(self):
        f = figure(width=560, height=440, match_aspect=True, tools="pan,wheel_zoom,reset", name="ml-target",
                   toolbar_location="above", title="draw the target path (freehand tool)")
        f.multi_line("xs", "ys", source=self.start_src, line_color="#bbbbbb", line_dash="dotted")
        f.scatter("x", "y", source=self.uploaded, size=7, color="black")
        f.multi_line("xs", "ys", source=self.curves, line_color="colour", line_width=2)
        self.ticks = CustomJSTickFormatter(args=dict(scale=1.0), code=TICKS_JS)
        f.xaxis.formatter = f.yaxis.formatter = self.ticks
        f.xaxis.axis_label, f.yaxis.axis_label = "x (m)", "y (m)"
        return f

    def use_units(self, units: Units) -> None:
        """Show and read the panel's lengths and angles in ``units`` (the page's menus):
        the candidates' errors, the target's axes, the length bounds and the transmission
        threshold typed (the values typed are converted), the timing's first and last
        input.  Targets, runs and files stay in m and deg."""
        old, self.units = self.units, units
        w = self.w
        for k, unit, title in (("length_low", "m", "length ≥"), ("length_high", "m", "length ≤"),
                               ("min_transmission", "deg", "min transmission")):
            w[k].title = f"{title} ({units.label(unit)})"
            try:
                v = _float_or_none(w[k].value, title)
            except InputError:
                continue                     # left as typed: Run names it
            if v is not None:
                w[k].value = format(units.shown(old.typed(v, unit), unit), ".12g")
        self.ticks.args = dict(scale=units.scale("m"))
        self.fig.xaxis.axis_label, self.fig.yaxis.axis_label = f"x ({units.length})", f"y ({units.length})"
        self.drawing.use_units(units)
        self.csv.button.label = csv_label(units)
        self._table()

    def choose_start(self, name: str) -> None:
        """The server's choice of the start ``name`` (an entry of the start menu)."""
        self.menus["start"].set(value=name)
        self._start_changed()

    def _start_changed(self) -> None:
        none = self.menus["start"].value == NO_START
        self.atlas_box.visible = none
        for k in ("method", "candidates"):
            self.w[k].disabled = none
        if none:                    # the designs' tracer point is named by the run
            self.menus["point"].set(["P"], "P")
            self.start_src.data = dict(xs=[], ys=[])
            return
        try:
            m = self.load_start(self.menus["start"].value)
        except LinkageError as exc:
            self.say(str(exc))
            return
        self.menus["point"].set([p.name for p in m.points])
        if m.drivers:                       # the timing's inputs: the start's first driver's
            self.drawing.use_units(self.units, "deg" if m.is_rotary(0) else "m")
        if len(m.drivers) == 1 and m.points:
            P = traced(m)
            self.start_src.data = dict(xs=[p[:, 0].tolist() for p in P], ys=[p[:, 1].tolist() for p in P])

    def _upload(self, name: str, data: bytes) -> None:
        from multiloop.catalogue.dimensional.targets import parse_table
        from multiloop.inputs import upload_text
        try:
            a = parse_table(upload_text(name, data, hint=TARGET_UPLOAD), (2, 3), "path", name)
        except LinkageError as exc:
            self.say(str(exc))
            return
        self.target, self.target_units = a, self.units      # read in the page's units
        xy = table_in_si(a[:, :2], self.units)
        self.uploaded.data = dict(x=xy[:, 0].tolist(), y=xy[:, 1].tolist())
        self.drawing.clear()
        self.status.text = status_html(f"target: {name}, {len(a)} rows (read in {self.units.length})")

    def _clear(self) -> None:
        self.target = None
        self.uploaded.data = dict(x=[], y=[])
        self.drawing.clear()

    def _target(self, start=None) -> np.ndarray:
        """The target in m (and deg): the stroke drawn, else the table uploaded (read in
        the page's units then; its input in the angle unit unless ``start``'s first
        driver is a slider)."""
        drawn = self.drawing.target()
        if drawn is not None:
            return drawn
        if self.target is not None:
            rotary = start is None or not start.drivers or start.is_rotary(0)
            return table_in_si(self.target, self.target_units, rotary)
        raise InputError(explain("target path", expected="a drawn stroke or an uploaded CSV", got="none"))

    def _options(self) -> dict:
        w, u = self.w, self.units

        def typed(k, what, unit):           # a number typed in the page's units, or None
            v = _float_or_none(w[k].value, what)
            return None if v is None else u.typed(v, unit, what)
        lo, hi = typed("length_low", "length ≥", "m"), typed("length_high", "length ≤", "m")
        if (lo is None) != (hi is None):
            raise InputError(explain("length bounds", expected="both LOW and HIGH, or neither", got="one of them"))
        return dict(point=self.menus["point"].value or None, shape_only=w["shape_only"].active,
                    method=self.menus["method"].value,
                    seed=w["seed"].value or 0, budget=w["budget"].value, tol=w["tol"].value,
                    full_rotation=w["full_rotation"].active,
                    min_transmission=typed("min_transmission", "min transmission", "deg"),
                    max_ratio=_float_or_none(w["max_ratio"].value, "max ratio"),
                    length_bounds=None if lo is None else (lo, hi))

    def run(self) -> None:
        """Start a background run (one job at a time per page)."""
        if self.job is not None and self.job.running:
            return
        try:
            options = self._options()
            if not options["budget"] or options["budget"] <= 0:
                raise InputError(explain("budget", expected="a positive number of seconds", got=str(options["budget"])))
            none = self.menus["start"].value == NO_START
            atlas = self._atlas_options(options) if none else None
            start = None if none else self.load_start(self.menus["start"].value)
            target = self._target(start)
        except LinkageError as exc:
            self.say(str(exc))
            return
        n = int(self.w["candidates"].value or 1)
        self.results = []
        self._list()                        # the last run's candidates go
        if none:
            self.job = Job(lambda job: run_atlas(job, target, atlas), "synthesis")
            self.job.detach = True          # cancel: stops at the next polish, the page at once
        else:
            self.job = Job(lambda job: run_candidates(job, start, target, n, dict(options)), "synthesis")
        self.w["run"].disabled, self.w["cancel"].disabled = True, False
        self.status.text = status_html("running…", "running")

    def _atlas_options(self, options: dict) -> dict:
        """The keywords of the synthesis without a start (as ``multiloop synthesise``
        without START: ``--db``, ``--links``, ``--top``, ``--tol``, ``--budget``, ``--seed``)."""
        from multiloop.catalogue.topology_synthesis import parse_links
        w = self.w
        if not self.menus["atlas"].value:
            raise InputError(explain("atlas", expected="an atlas given to serve", got="none", hint=ATLAS_HINT))
        if not set(w["links"].active) <= set(range(len(LINK_CHOICES))):
            raise InputError(refusal("links (--links)", w["links"].active, "tick the boxes 4, 6, 8"))
        links = ",".join(LINK_CHOICES[i] for i in sorted(w["links"].active))
        return dict(atlas=self.menus["atlas"].value, links=parse_links(links),
                    top=int(w["top"].value or 0), budget=float(options["budget"]), point="P",
                    tol=float(w["ties"].value or 0.0), seed=int(options["seed"] or 0))

    def cancel(self) -> None:
        """Stop the run.  A run without a start stops at its next polish (one share of the
        budget at most); the page stops waiting for it at once, its designs discarded."""
        job = self.job
        if job is None:
            return
        job.cancel()
        if getattr(job, "detach", False) and job.running:
            self.job = None
            self.w["run"].disabled, self.w["cancel"].disabled = False, True
            self.status.text = status_html("cancelled: the atlas search stops at its next polish", "cancelled")

    def poll(self) -> None:
        """Called by the session's periodic callback: progress, then the candidates."""
        job = self.job
        if job is None:
            return
        self.progress.text = progress_html(job.fraction)
        done = list(getattr(job, "partial", []))
        if len(done) != len(self.results):
            self.results = done
            self._list()
        if job.running:
            best = "" if not np.isfinite(job.best) else f", best objective {job.best:.3g}"
            self.status.text = status_html(f"running {100 * job.fraction:.0f} %{best}", "running")
            return
        self.job = None
        self.w["run"].disabled, self.w["cancel"].disabled = False, True
        if job.state == "failed":
            self.say(job.error)
        self.status.text = status_html(f"{job.state}: {len(self.results)} candidate(s)", job.state)

    def _list(self) -> None:
        """The candidates' table and menu (the best chosen), and their paths drawn."""
        self._table()
        best = min(range(len(self.results)), key=lambda i: self.results[i].error_rms, default=-1)
        self.menus["pick"].set([str(i) for i in range(1, len(self.results) + 1)], str(best + 1))
        self._draw_candidates()

    def _table(self) -> None:
        """The candidates' table, their errors in the page's length unit (``data-error-max``
        and ``data-error-rms``: the values shown, unrounded)."""
        from multiloop.topo.assur import decompose
        u = self.units
        rows = []
        for i, r in enumerate(self.results, 1):
            m = r.mechanism
            try:
                formula = r.structure if isinstance(r, AtlasDesign) else decompose(m).formula
            except LinkageError as exc:
                formula = str(exc)
            rows.append(html('<tr data-candidate="{i}" data-error-max="{emax!r}" data-error-rms="{erms!r}"><td>{i}'
                             "</td><td>{emax:.3g}</td><td>{erms:.3g}</td><td>{links}</td><td>{formula}</td>"
                             "<td>{seed}</td><td>{stopped}</td></tr>",
                             i=i, emax=u.shown(r.error_max, "m"), erms=u.shown(r.error_rms, "m"), links=len(m.links),
                             formula=formula, seed=r.seed, stopped=stopped_text(r, u)))
        self.table.text = "" if not rows else html(
            '<table id="ml-candidates" data-unit="{unit}"><tr><th>#</th><th>error max ({unit})</th>'
            "<th>error RMS ({unit})</th><th>links</th><th>structure</th><th>seed</th><th>stopped</th></tr>{rows}"
            "</table>", unit=u.length, rows=join(rows))

    def _chosen(self):
        v = self.menus["pick"].value
        if not v or int(v) > len(self.results):
            running = self.job is not None and self.job.running
            raise InputError(explain("candidate", expected="a candidate of a synthesis run",
                                     got="a run still searching" if running else "none",
                                     hint="wait for its first candidate" if running else "press Run"))
        return self.results[int(v) - 1]

    def _draw_candidates(self) -> None:
        xs, ys, colours = [], [], []
        pick = self.menus["pick"].value
        for i, r in enumerate(self.results, 1):
            a = np.asarray(r.achieved, float)
            xs.append(a[:, 0].tolist())
            ys.append(a[:, 1].tolist())
            colours.append("#e15759" if str(i) == pick else "#f1a7a8")
        self.curves.data = dict(xs=xs, ys=ys, colour=colours)

    def _open(self) -> None:
        try:
            self.open_design(self._chosen().mechanism)
        except LinkageError as exc:
            self.say(str(exc))

    def _download(self, fmt: str):
        """(file name, text) of the chosen candidate as ``.toml`` or ``.pyslvs``, made in
        memory (nothing kept on the server); None, with the message shown, if it fails."""
        from .exports import file_stem
        try:
            m = self._chosen().mechanism
            stem = f"{file_stem(m, 'design')}-candidate-{self.menus['pick'].value}"
            if fmt == "toml":
                from multiloop.topo.io import dumps_toml
                text = dumps_toml(m)
            else:
                from multiloop.topo.pyslvs import dumps_pyslvs, with_pyslvs_names
                text = dumps_pyslvs(with_pyslvs_names(m))
        except LinkageError as exc:
            self.say(str(exc))
            return None
        return f"{stem}.{fmt}", text
