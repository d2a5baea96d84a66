"""The synthesis's drawn target (``multiloop/web/target_drawing.py``), without a browser:
strokes joined and resampled by the library, open or closed, undo, one dragged point,
a prescribed timing, and forged data as one line (``tests/test_web.py::test_target_*``
draws in the page)."""
from __future__ import annotations

import html
import re

import numpy as np
import pytest

pytest.importorskip("bokeh")

from multiloop.catalogue.curves import is_closed  # noqa: E402
from multiloop.catalogue.curves import resample as library_resample  # noqa: E402
from multiloop.web.target_drawing import TARGET_POINTS, resample  # noqa: E402


@pytest.fixture
def drawing():
    from bokeh.plotting import figure

    from multiloop.web.target_drawing import TargetDrawing
    said = []
    d = TargetDrawing(figure(), said.append)
    d.said = said
    return d


def _arc(t0, t1, n=30):
    t = np.linspace(t0, t1, n)
    return (0.1 + 0.05 * np.cos(t)).tolist(), (0.05 * np.sin(t)).tolist()


def _stroke(d, *arcs):
    """The strokes as the freehand tool sends them: every stroke so far."""
    d.strokes.data = dict(xs=[a[0] for a in arcs], ys=[a[1] for a in arcs])


def test_target_strokes_join_and_resample_open_or_closed(drawing):
    a, b = _arc(0, 2), _arc(2, 5)
    _stroke(drawing, a)
    _stroke(drawing, a, b)
    P = drawing.target()
    want = library_resample(np.column_stack([a[0] + b[0], a[1] + b[1]]), TARGET_POINTS, False)
    np.testing.assert_array_equal(P, want)
    assert P.shape == (TARGET_POINTS, 2) and not is_closed(P)
    drawing.shape.select.value = "closed"                     # as the page's menu sets it
    Q = drawing.target()
    assert is_closed(Q) and len(Q) == TARGET_POINTS
    assert drawing.points.data["x"] == Q[:, 0].tolist()      # the points drawn are the target


def test_target_undo_steps_back_a_stroke_a_drag_and_the_shape(drawing):
    a, b = _arc(0, 2), _arc(2, 5)
    _stroke(drawing, a)
    one = drawing.target()
    _stroke(drawing, a, b)
    x, y = list(drawing.points.data["x"]), list(drawing.points.data["y"])
    x[3] += 0.01
    drawing.points.data = dict(x=x, y=y)                      # one point dragged
    assert drawing.target()[3, 0] == x[3]
    drawing.shape.select.value = "closed"
    for _ in range(2):
        drawing.step_back()                                   # the shape, then the drag
    assert drawing.shape.value == "open" and drawing.target()[3, 0] != x[3]
    drawing.step_back()                                       # the second stroke
    np.testing.assert_array_equal(drawing.target(), one)
    assert len(drawing.strokes.data["xs"]) == 1 and not drawing.undo.disabled
    drawing.step_back()
    assert drawing.target() is None and drawing.undo.disabled


def test_target_prescribed_timing_is_a_third_column(drawing):
    _stroke(drawing, _arc(0, 3))
    drawing.timing.select.value = "prescribed"
    assert drawing.first.visible and drawing.last.visible
    drawing.first.value, drawing.last.value = 10.0, 240.0
    T = drawing.target()
    np.testing.assert_allclose(T[:, 2], np.linspace(10, 240, TARGET_POINTS))
    drawing.shape.select.value = "closed"
    np.testing.assert_allclose(drawing.target()[:, 2], 10 + 230 * np.arange(TARGET_POINTS) / TARGET_POINTS)
    drawing.last.value = 10.0
    with pytest.raises(Exception, match="prescribed timing: expected two different finite inputs"):
        drawing.target()


def test_target_forged_strokes_and_points_are_one_line(drawing):
    _stroke(drawing, _arc(0, 3))
    before = drawing.target()
    drawing.strokes.data = dict(xs=[["<img src=x>", 1]], ys=[[0, 1]])
    drawing.strokes.data = dict(xs=[[0.1, 0.1]], ys=[[0.2, 0.2]])
    drawing.points.data = dict(x=[0.0] * 3, y=[0.0] * 3)
    x = list(drawing.points.data["x"])
    drawing.points.data = dict(x=[v + 1 for v in x], y=list(drawing.points.data["y"]))
    assert [re.sub(r":.*", "", m) for m in drawing.said] == [
        "drawn strokes", "drawn target", "dragged target points", "dragged target points"]
    assert all("\n" not in m for m in drawing.said) and "got 2 moved" not in html.unescape(drawing.said[-1])
    np.testing.assert_array_equal(drawing.target(), before)      # the drawing went back
    assert drawing.points.data["x"] == before[:, 0].tolist()
    with pytest.raises(Exception, match="a stroke of at least 2 points"):
        resample([0.0], [0.0])


def test_a_stroke_from_the_page_is_not_echoed_back(drawing):
    """The page's own strokes are not sent back (the server sets the source only when its
    strokes differ from the page's by value): strokes that arrive as NumPy arrays were
    echoed as lists, and an echo of stroke 1 reaching the page after its stroke 2 would
    wipe stroke 2 for good (the server, given strokes 1 and 2, then sees its own value
    and sends nothing).  Undo and Clear, which change the strokes, still set them."""
    changes = []
    drawing.strokes.on_change("data", lambda attr, old, new: changes.append(len(new["xs"])))
    # (as the page's typed arrays arrive: NumPy arrays, which the server's lists never equal)
    a, b = ([np.array(v) for v in _arc(0.0, 2.0)]), ([np.array(v) for v in _arc(2.2, 4.5)])
    _stroke(drawing, a)
    _stroke(drawing, a, b)
    assert changes == [1, 2] and len(drawing.state.xs) == 2          # the page's two changes only
    drawing.step_back()
    assert changes == [1, 2, 1] and len(drawing.strokes.data["xs"]) == 1
    drawing.clear()
    assert changes == [1, 2, 1, 0]
