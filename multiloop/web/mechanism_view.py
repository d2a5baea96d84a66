"""The mechanism view: the drawing, a player per driver, and the motion's frames.

The whole motion of the chosen driver is sent to the page once (:class:`~.scene.Sweep`);
a move of the slider redraws in the browser by indexing those frames (a few lines of
BokehJS glue, :data:`REDRAW_JS`), so no round trip to the server and no solving happens
per frame.  The glue also writes the displayed positions into the element
``#ml-positions`` (``data-index``, ``data-input``, ``data-positions`` as JSON), which
the browser tests read.

A ring (:attr:`MechanismView.handles`) marks each joint and tracer point at the
design's reference configuration; Bokeh's point-draw tool (drag only, no adding) moves
one with the mouse, the handle following the pointer, and once the drag ends the server
gets the new position (:meth:`MechanismView._dragged`) and hands it to ``on_drag`` (the
editor: the design re-solves on the drop).
"""
from __future__ import annotations

import json

import numpy as np
from bokeh.models import (Column, ColumnDataSource, CustomJS, CustomJSTickFormatter, Div, HoverTool, PointDrawTool,
                          Range1d, Row)
from bokeh.plotting import figure

from .glue import Player, div, floats, held
from .markup import Html, html
from .menus import Menu
from .scene import Scene, Sweep
from .units import Units

__all__ = ["MechanismView", "REDRAW_JS", "FOLLOW_JS", "TICKS_JS", "readout_html"]

#: the drawing's tick labels in the display length unit (``scale`` per metre)
TICKS_JS = "return String(Number((tick * scale).toPrecision(6)));"

#: the drawing's ranges hold the positions within this many sizes of the reference's
#: centre: a slider whose motion runs off towards an asymptote (dyad_prp's, 4.9e5 sizes
#: away at its limits) does not shrink the mechanism to a dot (every catalogue
#: mechanism else stays within 1.11 sizes)
FIT_SIZES = 4.0

#: an edited design keeps the view when its motion fills at least this share of it on one axis
KEEP_FILL = 0.5

#: a drag in the drawing (the point-draw tool active): at its start the player goes to
#: the reference frame (``handles.tags[0]``, where the handles are); then the joints
#: and links follow the handles (in the browser only: the server re-solves on the drop)
FOLLOW_JS = """
if (!drag.active || handles.data.name.length == 0) { return; }
if (cb_obj.event_name == 'panstart') {
  const ref = handles.tags[0];
  if (ref != null && slider.value != ref) { slider.value = ref; }
  // no tooltip while a joint is dragged and its design re-solved: one kept over the
  // dragged joint was inspected and laid out again at every change of the drawing
  for (const h of hovers) { h.active = false; }
  return;
}
if (cb_obj.event_name == 'panend') {       // the tooltips are back at the pointer's next move
  document.addEventListener('pointermove', () => { for (const h of hovers) { h.active = true; } },
                            {once: true, capture: true});
}
const names = joints.data.name, jx = Array.from(joints.data.x), jy = Array.from(joints.data.y);
handles.data.name.forEach((n, k) => {
  const j = names.indexOf(n);
  if (j >= 0) { jx[j] = handles.data.x[k]; jy[j] = handles.data.y[k]; }
});
const xs = [], ys = [];
for (const ix of links.data.idx) {
  const cx = ix.map(j => jx[j]), cy = ix.map(j => jy[j]);
  if (ix.length > 2) { cx.push(jx[ix[0]]); cy.push(jy[ix[0]]); }
  xs.push(cx); ys.push(cy);
}
links.data.xs = xs; links.data.ys = ys; links.change.emit();
joints.data.x = jx; joints.data.y = jy; joints.change.emit();
"""

#: the redraw glue: frame ``i`` of the sweep (its readout arguments in its tags) into the link and
#: joint models and the readout element
REDRAW_JS = """
const frames = sweep.data.input.length;
if (frames == 0) { return; }                     // the motion is not solved yet
const i = Math.max(0, Math.min(cb_obj.value, frames - 1));
// nx, ny: (frames, nodes) arrays, sent as binary and flat here: frame i is row i (copied by
// index: Bokeh's n-d arrays do not take subarray or slice)
const n = sweep.data.nx.length / frames, nx = new Array(n), ny = new Array(n);
for (let j = 0; j < n; j++) { nx[j] = sweep.data.nx[i * n + j]; ny[j] = sweep.data.ny[i * n + j]; }
const nj = joints.data.name.length;
const idx = links.data.idx, xs = [], ys = [];
for (const ix of idx) {
  const cx = ix.map(j => nx[j]), cy = ix.map(j => ny[j]);
  if (ix.length > 2) { cx.push(nx[ix[0]]); cy.push(ny[ix[0]]); }
  xs.push(cx); ys.push(cy);
}
// in place, then one change signal each: a redraw in the browser, no patch to the server
links.data.xs = xs; links.data.ys = ys; links.change.emit();
joints.data.x = nx.slice(0, nj); joints.data.y = ny.slice(0, nj); joints.change.emit();
const [label, unit, names, mech, scale] = sweep.tags;
for (const c of cursors) { c.location = sweep.data.input[i] * scale; }
const pos = {};
names.forEach((n, j) => { pos[n] = [nx[j], ny[j]]; });
// the readout's element itself (a new Div text would re-lay out the whole page)
let el = window.__mlReadout;
if (!el || !el.isConnected) {
  el = null;
  const walk = (root) => { el = el || root.querySelector('#ml-positions');
    for (const e of root.querySelectorAll('*')) { if (el) return; if (e.shadowRoot) walk(e.shadowRoot); } };
  walk(document);
  window.__mlReadout = el;
}
if (el) {
  el.setAttribute('data-mechanism', mech); el.setAttribute('data-index', i);
  el.setAttribute('data-input', sweep.data.input[i]); el.setAttribute('data-positions', JSON.stringify(pos));
  el.textContent = label + ' = ' + (sweep.data.input[i] * scale).toFixed(3) + ' ' + unit;
}
"""


#: marks closer than this share of the drawing's width + height are one cluster of labels
LABEL_GAP = 0.03
#: screen pixels between the lines of a cluster's labels (9 px text)
LABEL_LINE = 11


def stacked_offsets(xs, ys, near: float) -> list[float]:
    """Screen y offsets (px) of event labels: a label whose mark lies within ``near``
    (data units) of an earlier label's mark goes one line below the last of that cluster,
    so that labels of events at nearly the same place do not overlap."""
    out: list[float] = []
    for i, (x, y) in enumerate(zip(xs, ys)):
        below = [out[k] for k in range(i) if abs(xs[k] - x) <= near and abs(ys[k] - y) <= near]
        out.append(max(below) + LABEL_LINE if below else -4.0)
    return out


def readout_html(sw: Sweep, i: int, names, mech: str, units: Units = Units()) -> Html:
    """The readout element of frame ``i`` (the same text as :data:`REDRAW_JS` writes):
    its data attributes in the command line's units, its text in the display ``units``."""
    pos = {n: [float(v) for v in sw.nodes[i, j]] for j, n in enumerate(names)}
    return html('<span id="ml-positions" data-mechanism="{mech}" data-index="{i}" data-input="{x}" '
                'data-positions="{pos}">{joint} = {v:.3f} {unit}</span>', mech=mech, i=i,
                x=repr(float(sw.x[i])), pos=json.dumps(pos), joint=sw.joint, v=units.shown(sw.x[i], sw.unit),
                unit=units.label(sw.unit))


def _frame_links(scene: Scene, nodes: np.ndarray) -> tuple[list, list]:
    xs, ys = [], []
    for _, idx, _, _ in scene.links:
        P = nodes[list(idx) + ([idx[0]] if len(idx) > 2 else [])]
        xs.append(P[:, 0].tolist())
        ys.append(P[:, 1].tolist())
    return xs, ys


class MechanismView:
    """Drawing + player of one session; :meth:`show` puts a scene and its sweeps on it.
    ``say`` shows the page's one-line message; ``cursors`` are the input cursors of the
    plots against the input; ``on_drag(name, (x, y))`` is called with a handle dragged
    in the page (a joint or tracer point moved in the reference), and returns whether
    it made an edit (its drawing may come later: the handles then stay where dropped)."""

    def __init__(self, say, cursors=(), on_drag=None):
        self.scene: Scene | None = None
        self.keep_view = False           # the design shown is an edit: its view kept when it fits
        self.say, self.on_drag = say, on_drag
        self.units = Units()
        #: the drag handles, at the reference; what the server set last (names, x, y)
        self.handles = ColumnDataSource(dict(x=[], y=[], name=[]), name="ml-handles")
        self.handles_set: tuple = ((), (), ())
        self.handles.on_change("data", lambda attr, old, new: self._dragged(new))
        self.sweeps: list[Sweep] = []
        self.links = ColumnDataSource(dict(xs=[], ys=[], colour=[], name=[], group=[], idx=[]), name="ml-links")
        self.joints = ColumnDataSource(dict(x=[], y=[], name=[], fill=[], size=[], marker=[], links=[]), name="ml-joints")
        self.paths = ColumnDataSource(dict(xs=[], ys=[]))
        self.marks = ColumnDataSource(dict(x=[], y=[], label=[], dy=[]))
        self.sweep = ColumnDataSource(dict(nx=[], ny=[], input=[]))
        # fixed size: a new text then repaints the readout alone, not the whole layout
        self.readout = Div(text=html('<span id="ml-positions"></span>'), name="ml-readout", width=560, height=22)
        self.cursors = list(cursors)     # the input cursors of the plots against the input
        self.player = Player(interval=40, width=380)
        self.fig = self._figure()
        self.drivers = Menu("driver menu", say, title="driver", width=160, visible=False)
        self.driver = self.drivers.select
        self.player.slider.js_on_change("value", CustomJS(
            args=dict(sweep=self.sweep, links=self.links, joints=self.joints, cursors=self.cursors),
            code=REDRAW_JS))
        self.drivers.on_choice(lambda label: self.use_driver(self.drivers.choices.index(label)))
        self.status = div("")
        self.panel = Column(Row(self.driver, self.player.play, self.player.slider), self.status,
                            self.readout, self.fig)

    def _figure(self):
        # fixed ranges (set from the whole sweep): a frame repaints the glyphs, never the axes
        f = figure(width=620, height=480, x_range=Range1d(-1, 1), y_range=Range1d(-1, 1),
                   tools="pan,wheel_zoom,reset,save",
                   toolbar_location="above", name="ml-mechanism")
        f.multi_line("xs", "ys", source=self.paths, line_color="#bbbbbb", line_width=1)
        r = f.patches("xs", "ys", source=self.links, fill_color="colour", fill_alpha=0.25,
                      line_color="colour", line_width=3)
        j = f.scatter("x", "y", source=self.joints, marker="marker", size="size", fill_color="fill",
                      line_color="black", line_width=1.5)
        hovers = [HoverTool(renderers=[r], tooltips=[("link", "@name"), ("group", "@group")]),
                  HoverTool(renderers=[j], tooltips=[("joint", "@name"), ("links", "@links")])]
        f.add_tools(*hovers)
        f.scatter("x", "y", source=self.marks, marker="diamond", size=11, color="#d62728", alpha=0.8)
        f.text("x", "y", text="label", source=self.marks, text_font_size="9px", text_color="#d62728",
               x_offset=6, y_offset="dy")
        h = f.scatter("x", "y", source=self.handles, size=17, fill_alpha=0.0, line_color="#1f77b4",
                      line_alpha=0.6, line_width=1.5, line_dash="dotted", name="ml-handle-glyphs")
        drag = PointDrawTool(renderers=[h], add=False, drag=True, name="ml-drag",
                             description="Drag a joint or tracer point (moves it in the reference)")
        f.add_tools(drag)
        f.toolbar.active_multi = drag
        self.ticks = CustomJSTickFormatter(args=dict(scale=1.0), code=TICKS_JS)
        f.xaxis.formatter = f.yaxis.formatter = self.ticks
        f.xaxis.axis_label, f.yaxis.axis_label = "x (m)", "y (m)"
        follow = CustomJS(args=dict(drag=drag, handles=self.handles, joints=self.joints, links=self.links,
                                    slider=self.player.slider, hovers=hovers), code=FOLLOW_JS)
        for event in ("panstart", "pan", "panend"):
            f.js_on_event(event, follow)
        return f

    # ------------------------------------------------------------------ dragging
    def _put_handles(self) -> None:
        """The handles at the shown design's reference (those positions that are known)."""
        sc = self.scene
        keep = [] if sc is None else [i for i in range(len(sc.node_names)) if np.all(np.isfinite(sc.reference[i]))]
        names = tuple(sc.node_names[i] for i in keep)
        xs = tuple(float(sc.reference[i, 0]) for i in keep)
        ys = tuple(float(sc.reference[i, 1]) for i in keep)
        self.handles_set = (names, xs, ys)        # first: the change below is the server's own
        self.handles.data = dict(x=list(xs), y=list(ys), name=list(names))

    def _dragged(self, data) -> None:
        """A change of the handles: the server's own is ignored; from the page, the one
        handle moved goes to ``on_drag`` (anything else is the one-line message, and the
        handles go back)."""
        from multiloop.topo.errors import explain
        names, xs, ys = self.handles_set
        try:
            got = (tuple(str(n) for n in data["name"]), tuple(float(v) for v in data["x"]),
                   tuple(float(v) for v in data["y"]))
        except (KeyError, TypeError, ValueError):
            got = None
        if got == (names, xs, ys):
            return
        moved = [] if got is None or got[0] != names or len(got[1]) != len(xs) or len(got[2]) != len(ys) else [
            i for i in range(len(names)) if (got[1][i], got[2][i]) != (xs[i], ys[i])]
        scene, made = self.scene, False
        if len(moved) == 1 and self.on_drag is not None:
            i = moved[0]
            with held(self.handles.document):      # the new design's changes in one batch
                made = self.on_drag(names[i], (got[1][i], got[2][i]))
        else:
            self.say(explain("dragged handles", expected="one handle of the design moved",
                             got=f"{len(moved)} moved" if got is not None and got[0] == names else "other handles"))
        if self.scene is not scene:
            return
        if made:                           # an edit whose drawing comes later: the handles stay
            self.handles_set = got
        else:                              # nothing new shown: the handles go back
            self._put_handles()

    # ------------------------------------------------------------------ content
    def show(self, scene: Scene, sweeps: list[Sweep], name: str = "", keep_view: bool = False) -> None:
        """Draw ``scene`` (named ``name`` on the page) and make its sweeps the player's
        frames (driver 0 first); ``keep_view`` (an edit): in the drawing's view as it is
        when the new motion fits it well (:meth:`_fit`)."""
        self.scene, self.sweeps, self.name, self.keep_view = scene, sweeps, name, keep_view
        self._put_handles()
        if not sweeps:
            self.readout.text = html('<span id="ml-positions" data-mechanism="{name}"></span>', name=name)
            self.marks.data = dict(x=[], y=[], label=[], dy=[])
            self.paths.data = dict(xs=[], ys=[])
            self.sweep.data = dict(nx=[], ny=[], input=[])
            self.player.disabled = True
            self.handles.tags = []
            self._fit(scene.reference, min_fill=0.0)      # (the motion, once solved, fills the view)
        m = scene.mechanism
        self.links.data = dict(xs=[[] for _ in scene.links], ys=[[] for _ in scene.links],
                               colour=[c for _, _, c, _ in scene.links], name=[n for n, _, _, _ in scene.links],
                               group=[g for _, _, _, g in scene.links],
                               idx=[list(ix) for _, ix, _, _ in scene.links])
        n_pts = len(scene.node_names) - scene.n_joints
        fill = ["gold" if k > 2 else "white" for k in scene.multiplicity] + ["crimson"] * n_pts
        marker = ["square" if k == "P" else "triangle" if k == "frame" else "circle" for k in scene.joint_kind]
        self.joints.data = dict(
            x=[0.0] * len(scene.node_names), y=[0.0] * len(scene.node_names), name=list(scene.node_names),
            fill=fill, size=[11 + 3 * (k - 2) if k > 2 else 9 for k in scene.multiplicity] + [10] * n_pts,
            marker=marker + ["x"] * n_pts,
            links=[", ".join(j.links) for j in m.joints] + [f"tracer point on {p.link}" for p in m.points])
        labels = self._labels()
        self.drivers.set(labels, labels[0] if labels else "")
        self.driver.visible = len(labels) > 1
        if labels:
            self.use_driver(0)
        else:
            self._draw_nodes(scene.reference)

    def sweeps_of(self, m) -> list[Sweep] | None:
        """The sweeps shown when they are design ``m``'s motion, else None."""
        return self.sweeps if self.sweeps and self.scene is not None and self.scene.mechanism is m else None

    def use_driver(self, k: int) -> None:
        """Make driver ``k``'s sweep the player's frames and draw its reference frame."""
        if not self.sweeps:
            return
        sw = self.sweeps[k]
        self.current = sw
        self._unit_texts()                  # first: the glue redraws with these tags once the slider moves
        names = list(self.scene.node_names)
        # arrays, not lists: Bokeh sends them as binary buffers (lists of a 5-cylinder engine's
        # motion took 30 ms to write as JSON, and the page as long to read)
        self.sweep.data = dict(nx=floats(sw.nodes[:, :, 0]), ny=floats(sw.nodes[:, :, 1]), input=floats(sw.x))
        n_pts = len(names) - self.scene.n_joints
        self.paths.data = dict(xs=[floats(sw.nodes[:, self.scene.n_joints + p, 0]) for p in range(n_pts)],
                               ys=[floats(sw.nodes[:, self.scene.n_joints + p, 1]) for p in range(n_pts)])
        self.player.disabled = False
        self._fit(sw.nodes)
        i = sw.reference_index
        self.player.frames(len(sw.x), i)
        self.handles.tags = [i]                       # the frame of the handles (FOLLOW_JS)
        self.draw_frame(i)

    def _labels(self) -> list[str]:
        return [f"{sw.joint} ({self.units.label(sw.unit)})" for sw in self.sweeps]

    def _unit_texts(self) -> None:
        """The readout's glue arguments and the status line, in the display units."""
        sw, u = self.current, self.units
        # on the sweep's model, not the readout's: a change of a Div's tags renders it again
        self.sweep.tags = [sw.joint, u.label(sw.unit), list(self.scene.node_names), self.name, u.scale(sw.unit)]
        self.status.text = html("{kind} of {joint}: {lo:.4g} … {hi:.4g} {unit}, {n} frames",
                                kind="full rotation" if sw.full_rotation else "limited motion", joint=sw.joint,
                                lo=u.shown(sw.x.min(), sw.unit), hi=u.shown(sw.x.max(), sw.unit),
                                unit=u.label(sw.unit), n=len(sw.x))

    def use_units(self, units: Units) -> None:
        """Show the drawing's axes, the readout, status line and driver menu in ``units``
        (the frames stay)."""
        self.units = units
        self.ticks.args = dict(scale=units.scale("m"))
        self.fig.xaxis.axis_label, self.fig.yaxis.axis_label = f"x ({units.length})", f"y ({units.length})"
        if not self.sweeps:
            return
        labels = self._labels()
        self.drivers.set(labels, labels[min(self.current.k, len(labels) - 1)])
        self._unit_texts()
        self.draw_frame(int(self.player.slider.value))

    def _fit(self, nodes: np.ndarray, min_fill: float | None = None) -> None:
        """Ranges around every finite position of ``nodes`` within :data:`FIT_SIZES` sizes of
        the reference's centre (still drawn beyond), equal scales on both axes; for an
        edited design (``keep_view``) the view as it is when they fit it (:meth:`_fits`,
        ``min_fill`` :data:`KEEP_FILL` unless given)."""
        P = nodes.reshape(-1, 2)
        P = P[np.all(np.isfinite(P), axis=1)]
        ref = self.scene.reference[np.all(np.isfinite(self.scene.reference), axis=1)] if self.scene else P[:0]
        if len(ref):
            c0 = (ref.min(axis=0) + ref.max(axis=0)) / 2
            near = np.hypot(*(P - c0).T) <= FIT_SIZES * self.scene.mechanism.size
            P = np.concatenate([ref, P[near]])
        if not len(P):
            return
        lo, hi = P.min(axis=0), P.max(axis=0)
        if self.keep_view and self._fits(lo, hi, KEEP_FILL if min_fill is None else min_fill):
            return
        c, half = (lo + hi) / 2, max(float(np.max(hi - lo)) * 0.55, 1e-9)
        aspect = (self.fig.width - 60) / (self.fig.height - 70)        # plot area, about
        hx, hy = (half * aspect, half) if aspect >= 1 else (half, half / aspect)
        self.fig.x_range.update(start=c[0] - hx, end=c[0] + hx, reset_start=c[0] - hx, reset_end=c[0] + hx)
        self.fig.y_range.update(start=c[1] - hy, end=c[1] + hy, reset_start=c[1] - hy, reset_end=c[1] + hy)

    def _fits(self, lo: np.ndarray, hi: np.ndarray, min_fill: float) -> bool:
        """Whether the box ``lo``–``hi`` lies in the view and fills at least ``min_fill``
        of it on one axis: an edited design then stays in the view it was dragged in (the
        handle stays under the pointer, and the page lays out nothing again for new axes)."""
        xr, yr = self.fig.x_range, self.fig.y_range
        inside = xr.start <= lo[0] and hi[0] <= xr.end and yr.start <= lo[1] and hi[1] <= yr.end
        fill = max((hi[0] - lo[0]) / (xr.end - xr.start), (hi[1] - lo[1]) / (yr.end - yr.start))
        return bool(inside and fill >= min_fill)

    def draw_frame(self, i: int) -> None:
        """Server-side redraw of frame ``i`` (loading, a click on a plot); the same output as the glue."""
        sw = self.current
        self._draw_nodes(sw.nodes[i])
        for c in self.cursors:
            c.location = self.units.shown(sw.x[i], sw.unit)
        self.readout.text = readout_html(sw, i, self.scene.node_names, self.name, self.units)

    def _draw_nodes(self, nodes: np.ndarray) -> None:
        xs, ys = _frame_links(self.scene, nodes)
        self.links.patch({"xs": [(slice(0, len(xs)), xs)], "ys": [(slice(0, len(ys)), ys)]}) if xs else None
        nj = len(self.scene.node_names)
        self.joints.patch({"x": [(slice(0, nj), nodes[:nj, 0].tolist())],
                           "y": [(slice(0, nj), nodes[:nj, 1].tolist())]})

    def move_to(self, x: float) -> None:
        """Move the player to the frame nearest driver value ``x`` (deg or m)."""
        i = int(np.argmin(np.abs(self.current.x - x)))
        self.player.slider.value = i
        self.draw_frame(i)

    def mark(self, events: list[tuple[float, str]]) -> None:
        """Mark events (driver value, label) on the drawing at the driver link's moving
        joints in the frame of each event (where the input is when it happens)."""
        sw, sc = self.current, self.scene
        m = sc.mechanism
        dj = m.joint(sw.joint)
        link = dj.links[1] if dj.links[0] == m.frame else dj.links[0]
        idx = [i for i, j in enumerate(m.joints) if link in j.links and m.frame not in j.links] or [0]
        xs, ys, labels = [], [], []
        for x, label in events:
            f = int(np.argmin(np.abs(sw.x - x)))
            xs.append(float(sw.nodes[f, idx[0], 0]))
            ys.append(float(sw.nodes[f, idx[0], 1]))
            labels.append(label)
        near = LABEL_GAP * float(np.ptp(sw.nodes[..., 0]) + np.ptp(sw.nodes[..., 1]) or 1.0)
        self.marks.data = dict(x=xs, y=ys, label=labels, dy=stacked_offsets(xs, ys, near))
