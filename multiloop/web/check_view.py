"""The design-check panel: verdict, events, transmission / pressure plot, the JSON.

It shows :func:`multiloop.kin.check.check`'s report (its verdict's lines and the
events in the page's units: :func:`~multiloop.kin.check.verdict.verdict` given the
:class:`~.units.Units`): the JSON is
``CheckReport.as_dict()``, the document ``multiloop check --json`` prints, in the
element ``#ml-check-json``.  Events are marked on the input axis of the angle plot and
on the drawing; a click (tap) on the plot moves the mechanism to that input.
"""
from __future__ import annotations

import json

import numpy as np
from bokeh.events import Tap
from bokeh.models import Button, Column, ColumnDataSource, PlainText, Range1d, Row, Span
from bokeh.plotting import figure

from multiloop.kin.check.verdict import verdict

from .glue import div, floats
from .markup import html, join
from .scene import PALETTE, Sweep
from .units import Units

__all__ = ["CheckView", "events_of"]


def events_of(doc: dict, joint: str, units: Units = Units()) -> list[tuple[float, str]]:
    """(driver value, label) of every event of driver ``joint`` in a check JSON document:
    limits, branch (change) points, dead centres, transmission extremes (their angles
    in the labels in the display ``units``; the values stay in the document's)."""
    d = doc["drivers"].get(joint)
    if d is None:
        return []
    ev = [(x, "limit") for x in d["limits"]]
    ev += [(b["at"], f"branch point {b['group']}") for b in d["branch_points"]]
    ev += [(x, f"dead centre {lk}") for lk, xs in d["dead_centres"].items() for x in xs]
    def angle(v):
        return f"{v:.1f}°" if units.angle == "deg" else f"{units.shown(v, 'deg'):.4g} {units.angle}"
    for name, a in d["angles"].items():
        if a.get("min") is not None:
            ev.append((a["at_min"], f"{a['quantity']} {name} min {angle(a['min'])}"))
            ev.append((a["at_max"], f"{a['quantity']} {name} max {angle(a['max'])}"))
    return ev


def on_axis(x: float, sw: Sweep) -> float:
    """A report value (deg in [0, 360) for R drivers) on the sweep's axis (signed range)."""
    if not sw.rotary or sw.full_rotation:
        return float(x)
    cands = [x + 360.0 * k for k in (-2, -1, 0, 1)]
    inside = [c for c in cands if sw.x.min() - 1e-6 <= c <= sw.x.max() + 1e-6]
    return float(inside[0] if inside else min(cands, key=lambda c: abs(c)))


class CheckView:
    """The check panel of one session."""

    def __init__(self, move_to, cancel=None):
        self.move_to = move_to
        self.mark = None               # mark(events) on the drawing, once a report is shown
        self.shown: tuple | None = None    # (doc, sweep, threshold, report) of the report shown
        self.units = Units()
        self.scale = 1.0               # display units of the plot's input axis per the sweep's
        self.curves = ColumnDataSource(dict(xs=[], ys=[], name=[], colour=[]))
        self.events = ColumnDataSource(dict(x=[], label=[]))
        self.cursor = Span(location=0, dimension="height", line_color="#333", line_dash="dashed")
        self.fig = figure(width=620, height=260, tools="pan,wheel_zoom,reset,tap", toolbar_location="above",
                          x_range=Range1d(0, 360),
                          x_axis_label="input", y_axis_label="angle", name="ml-angles")
        self.fig.multi_line("xs", "ys", source=self.curves, line_color="colour", line_width=2, legend_field="name")
        # the axis labels: plain text (a name between $$ would otherwise be read as TeX),
        # one model each whose text changes (a new model per report made Bokeh collect
        # every model of the document again: 0.14 s per re-check)
        self.labels = PlainText(text="input"), PlainText(text="angle")
        self.fig.xaxis.axis_label, self.fig.yaxis.axis_label = self.labels
        self.fig.scatter("x", 0, source=self.events, marker="inverted_triangle", size=10, color="#d62728")
        self.fig.add_layout(self.cursor)
        self.fig.on_event(Tap, lambda e: self.move_to(None if e.x is None else e.x / self.scale))
        self.verdict = div("", width=480)
        self.table = div("")
        self.json = div("")            # the JSON document, folded (<details>)
        # stops the running motion / check job (``cancel``), enabled while one runs
        self.stop = Button(label="Cancel check", button_type="warning", width=130, disabled=True,
                           css_classes=["ml-check-cancel"])
        if cancel is not None:
            self.stop.on_click(lambda: cancel())
        self.panel = Column(Row(self.verdict, self.stop), self.fig, self.table, self.json)
        self.doc: dict | None = None

    def busy(self, text: str, running: bool = False) -> None:
        """A status line instead of a report; ``running``: a job computes it (Cancel enabled)."""
        self.shown = self.doc = None
        self.stop.disabled = not running
        self.verdict.text = html('<p id="ml-check-status">{text}</p>', text=text)
        self.json.text = self.table.text = html("")
        self.events.data = dict(x=[], label=[])
        self.curves.data = dict(xs=[], ys=[], name=[], colour=[])

    def _json(self, doc: dict) -> None:
        """The JSON document, folded, of the report still shown (``doc``)."""
        if self.doc is doc:
            self.json.text = html('<details><summary>check --json</summary><pre id="ml-check-json" '
                                  'data-mechanism="{name}">{text}</pre></details>', name=doc["mechanism"],
                                  text=json.dumps(doc, indent=1, allow_nan=False))

    def _later(self, fn) -> None:
        """``fn()`` in the session's next tick, its changes in a message of their own: the
        report's verdict, events and angles reach the page first, and the folded JSON (some
        50 KB to write, send and lay out) after them, not on their way."""
        document = self.json.document
        if document is None:
            fn()
        else:
            document.add_next_tick_callback(fn)

    def use_units(self, units: Units) -> None:
        """Show the report shown (if any) again in ``units``."""
        self.units = units
        if self.shown is not None:
            self.show(*self.shown)

    def show(self, doc: dict | None, sw: Sweep | None, threshold: float, report=None) -> list[tuple[float, str]]:
        """Fill the panel from a check JSON document (None: nothing to check) and its
        ``report`` (the :class:`~multiloop.kin.check.report.CheckReport`: the verdict's
        lines in the display units; without it, the document's in m and deg); returns the
        events of the current driver on its axis (also given to :attr:`mark`)."""
        self.doc = doc
        self.shown = (doc, sw, threshold, report) if sw is not None else None
        self.stop.disabled = True
        if doc is None:
            self.busy("no check: the mechanism has no drivers")
            return []
        ok = "ok" if doc["ok"] else "faults found"
        lines = doc["verdict"] if report is None else verdict(report, self.units)
        items = join(html("<li>{v}</li>", v=v) for v in lines) or html("<li>no fault found</li>")
        self.verdict.text = html('<h3 id="ml-check-status" data-ok="{flag}">Verdict: {ok}</h3><ul>{items}</ul>',
                                 flag=str(doc["ok"]).lower(), ok=ok, items=items)
        self._later(lambda: self._json(doc))
        if sw is None:
            return []
        u = self.units
        ev = [(on_axis(x, sw), label) for x, label in events_of(doc, sw.joint, u)]
        self._plot(sw, ev)
        # data-x: the value shown, unrounded (the browser tests compare it with check --json)
        rows = join(html('<tr data-x="{x!r}"><td>{x:.4g}</td><td>{label}</td></tr>', x=u.shown(x, sw.unit), label=lb)
                    for x, lb in sorted(ev))
        self.table.text = html('<table id="ml-check-events" data-unit="{unit}"><tr><th>{joint} ({unit})</th>'
                               "<th>event</th></tr>{rows}</table><p>flagged below {lo:.4g} {a} (or above {hi:.4g} {a})"
                               "</p>", joint=sw.joint, unit=u.label(sw.unit), rows=rows, a=u.angle,
                               lo=u.shown(threshold, "deg"), hi=u.shown(180 - threshold, "deg"))
        if self.mark is not None:
            self.mark(ev)
        return ev

    def _plot(self, sw: Sweep, ev) -> None:
        """The angle plot of ``sw`` and its events ``ev``, in the display units."""
        u = self.units
        self.scale, sa = u.scale(sw.unit), u.scale("deg")
        self.events.data = dict(x=[x * self.scale for x, _ in ev], label=[lb for _, lb in ev])
        self.labels[0].text = f"{sw.joint} ({u.label(sw.unit)})"
        self.labels[1].text = f"angle ({u.angle})"
        lo, hi = u.shown(sw.x.min(), sw.unit), u.shown(sw.x.max(), sw.unit)
        self.fig.x_range.update(start=lo, end=hi, reset_start=lo, reset_end=hi)
        A = np.where(np.isfinite(sw.angles), sw.angles, np.nan) * sa
        x = floats(sw.x * self.scale)
        self.curves.data = dict(xs=[x] * A.shape[1], ys=[floats(A[:, c]) for c in range(A.shape[1])],
                                name=list(sw.angle_names),
                                colour=[PALETTE[c % len(PALETTE)] for c in range(A.shape[1])])
