"""The design-check panel: verdict, events, transmission / pressure plot, the JSON.

It shows :func:`multiloop.kin.check.check`'s report: the JSON is
``CheckReport.as_dict()``, the document ``multiloop check --json`` prints, in the
element ``#ml-check-json``.  Events are marked on the input axis of the angle plot and
on the drawing; a click (tap) on the plot moves the mechanism to that input.
"""
from __future__ import annotations

import html
import json

import numpy as np
from bokeh.events import Tap
from bokeh.models import Button, Column, ColumnDataSource, Range1d, Row, Span
from bokeh.plotting import figure

from .glue import div
from .scene import PALETTE, Sweep

__all__ = ["CheckView", "events_of"]


def events_of(doc: dict, joint: str) -> list[tuple[float, str]]:
    """(driver value, label) of every event of driver ``joint`` in a check JSON document:
    limits, branch (change) points, dead centres, transmission extremes."""
    d = doc["drivers"].get(joint)
    if d is None:
        return []
    ev = [(x, "limit") for x in d["limits"]]
    ev += [(b["at"], f"branch point {b['group']}") for b in d["branch_points"]]
    ev += [(x, f"dead centre {lk}") for lk, xs in d["dead_centres"].items() for x in xs]
    for name, a in d["angles"].items():
        if a.get("min") is not None:
            ev.append((a["at_min"], f"{a['quantity']} {name} min {a['min']:.1f}°"))
            ev.append((a["at_max"], f"{a['quantity']} {name} max {a['max']:.1f}°"))
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
        self.curves = ColumnDataSource(dict(xs=[], ys=[], name=[], colour=[]))
        self.events = ColumnDataSource(dict(x=[], label=[]))
        self.cursor = Span(location=0, dimension="height", line_color="#333", line_dash="dashed")
        self.fig = figure(width=620, height=260, tools="pan,wheel_zoom,reset,tap", toolbar_location="above",
                          x_range=Range1d(0, 360),
                          x_axis_label="input", y_axis_label="angle (deg)", name="ml-angles")
        self.fig.multi_line("xs", "ys", source=self.curves, line_color="colour", line_width=2, legend_field="name")
        self.fig.scatter("x", 0, source=self.events, marker="inverted_triangle", size=10, color="#d62728")
        self.fig.add_layout(self.cursor)
        self.fig.on_event(Tap, lambda e: self.move_to(e.x))
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
        self.stop.disabled = not running
        self.verdict.text = f'<p id="ml-check-status">{html.escape(text)}</p>'
        self.json.text = self.table.text = ""
        self.events.data = dict(x=[], label=[])
        self.curves.data = dict(xs=[], ys=[], name=[], colour=[])

    def show(self, doc: dict | None, sw: Sweep | None, threshold: float) -> list[tuple[float, str]]:
        """Fill the panel from a check JSON document (None: nothing to check); returns the
        events of the current driver on its axis."""
        self.doc = doc
        self.stop.disabled = True
        if doc is None:
            self.busy("no check: the mechanism has no drivers")
            return []
        ok = "ok" if doc["ok"] else "faults found"
        items = "".join(f"<li>{html.escape(v)}</li>" for v in doc["verdict"]) or "<li>no fault found</li>"
        self.verdict.text = (f'<h3 id="ml-check-status" data-ok="{str(doc["ok"]).lower()}">Verdict: {ok}</h3>'
                             f"<ul>{items}</ul>")
        self.json.text = (f'<details><summary>check --json</summary><pre id="ml-check-json" '
                          f'data-mechanism="{html.escape(doc["mechanism"])}">'
                          f"{html.escape(json.dumps(doc, indent=1, allow_nan=False))}</pre></details>")
        if sw is None:
            return []
        ev = [(on_axis(x, sw), label) for x, label in events_of(doc, sw.joint)]
        self.events.data = dict(x=[x for x, _ in ev], label=[lb for _, lb in ev])
        self.fig.xaxis.axis_label = f"{sw.joint} ({sw.unit})"
        lo, hi = float(sw.x.min()), float(sw.x.max())
        self.fig.x_range.update(start=lo, end=hi, reset_start=lo, reset_end=hi)
        A = np.where(np.isfinite(sw.angles), sw.angles, np.nan)
        self.curves.data = dict(xs=[sw.x.tolist()] * A.shape[1], ys=[A[:, c].tolist() for c in range(A.shape[1])],
                                name=list(sw.angle_names),
                                colour=[PALETTE[c % len(PALETTE)] for c in range(A.shape[1])])
        rows = "".join(f"<tr><td>{x:.4g}</td><td>{html.escape(lb)}</td></tr>" for x, lb in sorted(ev))
        self.table.text = (f'<table id="ml-check-events"><tr><th>{html.escape(sw.joint)} ({sw.unit})</th>'
                           f"<th>event</th></tr>{rows}</table>"
                           f"<p>flagged below {threshold:g}° (or above {180 - threshold:g}°)</p>")
        return ev
