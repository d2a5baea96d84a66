"""The synthesis's drawn target: strokes, an open or closed path of points, undo, dragged
points and a prescribed timing.

The strokes drawn with the freehand tool are joined in the order drawn into one
polyline, and :data:`TARGET_POINTS` points are put on it equally spaced by arc length
(:func:`resample`, the library's arc-length resampling).  An **open** target runs from the first stroke's start to the last
stroke's end; a **closed** one goes on back to its start, and its points are spaced
around the whole loop without repeating the first (the gap from the last point to the
first is one step, so the library reads it as closed: :func:`multiloop.catalogue.curves.is_closed`).
The points are drawn, and the point-draw tool drags them one at a time; a dragged point
is part of the target until the strokes change.  **Undo** steps back one change (a
stroke, a drag, a switch between open and closed).  With **prescribed** timing, point *k*
gets the driver value ``first + (last − first)·k/(N − 1)`` (deg or m from the
reference; a closed target ``…·k/N``): the third column of ``synthesise --path``.  The
first and last input are typed in the page's units (:meth:`TargetDrawing.use_units`).

Everything the page sends is data checked here: strokes that are not numbers, or
points that are not the points shown with one of them moved, are the one-line message,
and the drawing goes back to what it was.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from multiloop.topo.errors import InputError, explain

__all__ = ["TargetDrawing", "TargetState", "resample", "target_points", "TARGET_POINTS", "SHAPES", "TIMINGS"]

TARGET_POINTS = 24      # points of a drawn target
#: the target's shapes and timings (menus)
SHAPES = ("open", "closed")
TIMINGS = ("free", "prescribed")


def resample(xs, ys, n: int = TARGET_POINTS, closed: bool = False) -> np.ndarray:
    """``n`` points equally spaced along a drawn polyline (arc length), (n, 2); a
    ``closed`` one is spaced around the loop back to its start (the start not repeated):
    the library's :func:`multiloop.catalogue.curves.resample`, on the finite points.

    Raises
    ------
    InputError
        Fewer than 2 finite points, or a polyline of no length.
    """
    from multiloop.catalogue.curves import resample as arc_resample
    P = np.column_stack([np.asarray(xs, float), np.asarray(ys, float)])
    P = P[np.all(np.isfinite(P), axis=1)]
    if len(P) < 2:
        raise InputError(explain("drawn target", expected="a stroke of at least 2 points", got=f"{len(P)}",
                                 hint="drag the mouse over the plot with the freehand tool"))
    if not np.any(P != P[0]):
        raise InputError(explain("drawn target", expected="a stroke of some length", got="a dot"))
    return arc_resample(P, n, closed)


def target_points(strokes_xs, strokes_ys, closed: bool, n: int = TARGET_POINTS) -> np.ndarray:
    """The target points of strokes (lists of x and y lists), joined in order.

    Raises
    ------
    InputError
        The strokes are not lists of numbers, or :func:`resample` refuses them.
    """
    try:
        xs = [float(v) for s in strokes_xs for v in s]
        ys = [float(v) for s in strokes_ys for v in s]
    except (TypeError, ValueError):
        raise InputError(explain("drawn strokes", expected="lists of numbers", got="other data")) from None
    if len(xs) != len(ys):
        raise InputError(explain("drawn strokes", expected="as many x as y", got=f"{len(xs)} and {len(ys)}"))
    return resample(xs, ys, n, closed)


@dataclass(frozen=True, slots=True)
class TargetState:
    """One state of the drawing: the strokes (tuples of x and y tuples), closed or not,
    and the target points (None: none drawn)."""

    xs: tuple = ()
    ys: tuple = ()
    closed: bool = False
    points: np.ndarray | None = None

    def with_strokes(self, xs, ys) -> TargetState:
        xs = tuple(tuple(s) for s in xs)
        ys = tuple(tuple(s) for s in ys)
        return TargetState(xs, ys, self.closed, target_points(xs, ys, self.closed) if xs else None)

    def with_shape(self, closed: bool) -> TargetState:
        return replace(self, closed=closed).with_strokes(self.xs, self.ys)


def _strokes_of(data) -> tuple:
    """The strokes of a ``ml-strokes`` data dict as ``(xs, ys)`` tuples of tuples, to
    compare with a :class:`TargetState`'s."""
    return tuple(tuple(v) for v in data.get("xs", [])), tuple(tuple(v) for v in data.get("ys", []))


class TargetDrawing:
    """The drawn target of the synthesis figure ``fig``: its sources, tools and widgets
    (``widgets``: shape and timing menus, first and last input, Undo).  ``say`` shows the
    one-line message."""

    def __init__(self, fig, say):
        from bokeh.models import Button, ColumnDataSource, FreehandDrawTool, NumericInput, PointDrawTool

        from .menus import Menu
        self.say = say
        self.history: tuple[TargetState, ...] = (TargetState(),)
        self.strokes = ColumnDataSource(dict(xs=[], ys=[]), name="ml-strokes")
        self.points = ColumnDataSource(dict(x=[], y=[]), name="ml-target-points")
        r = fig.multi_line("xs", "ys", source=self.strokes, line_color="black", line_width=3)
        free = FreehandDrawTool(renderers=[r], num_objects=0, name="ml-freehand")
        dots = fig.scatter("x", "y", source=self.points, size=8, color="#4e79a7", line_color="white")
        drag = PointDrawTool(renderers=[dots], add=False, drag=True, name="ml-target-drag",
                             description="Drag a target point")
        fig.add_tools(free, drag)
        fig.toolbar.active_drag = free
        self.shape = Menu("target shape menu", say, SHAPES, "open", title="target", width=90,
                          css_classes=["ml-target-shape"])
        self.timing = Menu("timing menu", say, TIMINGS, "free", title="timing", width=110,
                           css_classes=["ml-timing"])
        from .units import Units
        self.units, self.input_unit = Units(), "deg"     # the timing shown in units.label(input_unit)
        self.first = NumericInput(title="first input (deg)", value=0.0, mode="float", width=90, visible=False,
                                  css_classes=["ml-timing-first"])
        self.last = NumericInput(title="last input (deg)", value=360.0, mode="float", width=90, visible=False,
                                 css_classes=["ml-timing-last"])
        self.undo = Button(label="↶ Undo stroke", width=120, disabled=True, css_classes=["ml-target-undo"])
        self.shape.on_choice(lambda v: self._push(self.state.with_shape(v == "closed")))
        self.timing.on_choice(lambda v: self._timing())
        self.undo.on_click(lambda: self.step_back())
        self.strokes.on_change("data", lambda attr, old, new: self._stroked(new))
        self.points.on_change("data", lambda attr, old, new: self._dragged(new))
        self.widgets = (self.shape.select, self.timing.select, self.first, self.last, self.undo)

    @property
    def state(self) -> TargetState:
        return self.history[-1]

    def target(self) -> np.ndarray | None:
        """The drawn target: (N, 2) points, or (N, 3) with the driver values of a
        prescribed timing; None when nothing is drawn."""
        P = self.state.points
        if P is None:
            return None
        if self.timing.value != "prescribed":
            return P.copy()
        a, b = (float(v) if v is not None else np.nan for v in (self.first.value, self.last.value))
        if not (np.isfinite(a) and np.isfinite(b)) or a == b:
            raise InputError(explain("prescribed timing", expected="two different finite inputs (first, last)",
                                     got=f"{self.first.value}, {self.last.value}"))
        a, b = a / self.units.scale(self.input_unit), b / self.units.scale(self.input_unit)
        n = len(P)
        k = np.arange(n) / (n if self.state.closed else n - 1)
        return np.column_stack([P, a + (b - a) * k])

    def use_units(self, units, input_unit: str | None = None) -> None:
        """Show and read the first and last input in ``units`` (a :class:`~.units.Units`);
        ``input_unit``: the start's driver's command-line unit (``"deg"`` or ``"m"``), if
        it changed.  The values shown are converted: the timing stays the same."""
        old = self.units.scale(self.input_unit)
        self.units, self.input_unit = units, input_unit or self.input_unit
        new = self.units.scale(self.input_unit)
        for box, what in ((self.first, "first"), (self.last, "last")):
            if box.value is not None and input_unit is None:
                box.value = float(box.value) / old * new
            box.title = f"{what} input ({units.label(self.input_unit)})"

    # ------------------------------------------------------------------ changes
    def clear(self) -> None:
        self._push(TargetState(closed=self.state.closed))

    def step_back(self) -> None:
        """Undo the last change (a stroke, a drag, the shape)."""
        if len(self.history) > 1:
            self.history = self.history[:-1]
            self._show()

    def _push(self, s: TargetState) -> None:
        self.history = self.history + (s,)
        self._show()

    def _timing(self) -> None:
        self.first.visible = self.last.visible = self.timing.value == "prescribed"

    def _stroked(self, data) -> None:
        """Strokes from the page (the freehand tool): the new target, or the message."""
        s = self.state
        try:
            xs, ys = list(data.get("xs", [])), list(data.get("ys", []))
            if _strokes_of(data) == (s.xs, s.ys):
                return                       # the server's own change
            new = s.with_strokes(xs, ys)
        except (InputError, TypeError, AttributeError) as exc:
            self.say(str(exc) if isinstance(exc, InputError) else
                     explain("drawn strokes", expected="lists of numbers", got="other data"))
            self._show()
            return
        self._push(new)

    def _dragged(self, data) -> None:
        """Points from the page (the point-draw tool): one point of those shown moved."""
        s = self.state
        shown = (np.empty((0, 2)) if s.points is None else s.points)
        try:
            P = np.column_stack([np.asarray(data["x"], float), np.asarray(data["y"], float)])
        except (KeyError, TypeError, ValueError):
            P = None
        if P is not None and P.shape == shown.shape and np.array_equal(P, shown):
            return                           # the server's own change
        moved = None if P is None or P.shape != shown.shape or not np.isfinite(P).all() else \
            np.flatnonzero(np.any(P != shown, axis=1))
        if moved is None or len(moved) != 1:
            self.say(explain("dragged target points", expected="one target point moved",
                             got="other points" if moved is None else f"{len(moved)} moved"))
            self._show()
            return
        self._push(replace(s, points=P))

    def _show(self) -> None:
        s = self.state
        self.undo.disabled = len(self.history) < 2
        self.shape.set(value="closed" if s.closed else "open")
        if _strokes_of(self.strokes.data) != (s.xs, s.ys):
            # (set only when the page's strokes differ by value: an echo of a stroke the
            # page itself drew, arriving after the page's next stroke, would wipe that one
            # for good, the server then seeing its own value again and sending nothing)
            self.strokes.data = dict(xs=[list(v) for v in s.xs], ys=[list(v) for v in s.ys])
        P = np.empty((0, 2)) if s.points is None else s.points
        self.points.data = dict(x=P[:, 0].tolist(), y=P[:, 1].tolist())
