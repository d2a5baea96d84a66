"""Editing the open design in the workbench (``multiloop/web/editing.py``), at the level
of :class:`multiloop.web.app.Workbench`: typed coordinates, undo and redo (the buttons
and the page's Ctrl-Z / Ctrl-Shift-Z message), and bad values as one line."""
from __future__ import annotations

import pytest

pytest.importorskip("bokeh")

from multiloop.inputs import load_mechanism  # noqa: E402
from multiloop.kin.solve import solve  # noqa: E402
from multiloop.topo.io import dumps_toml  # noqa: E402
from multiloop.web.app import Workbench  # noqa: E402
from multiloop.web.editing import History, moved  # noqa: E402


def _message(wb) -> str:
    import html
    import re
    return html.unescape(re.sub(r"<[^>]+>", "", wb.message.text))


def _edit(wb, name, x, y):
    wb.editor.point.select.value = name          # as the page's menu sets it
    wb.editor.x.value, wb.editor.y.value = str(x), str(y)
    wb.editor.edit(name, (wb.editor.x.value, wb.editor.y.value))


@pytest.fixture
def wb():
    w = Workbench(requested="four_bar")
    yield w
    w.close()


def test_undo_three_edits_three_times_gives_the_original_byte_for_byte(wb):
    original = dumps_toml(wb.mechanism)
    edits = [("B", 0.11, 0.07), ("A", 0.012, 0.021), ("O4", 0.095, 0.0)]
    for name, x, y in edits:
        _edit(wb, name, x, y)
        assert wb.mechanism.joint(name).at == (x, y) and wb.mechanism_name == "edited: four_bar"
        assert wb.view.scene.mechanism is wb.mechanism            # the drawing is the edited design's
    third = dumps_toml(wb.mechanism)
    for _ in edits:
        wb.editor.step(-1)
    assert dumps_toml(wb.mechanism) == original and wb.editor.undo.disabled and not wb.editor.redo.disabled
    for _ in edits:
        wb.editor.step(+1)
    assert dumps_toml(wb.mechanism) == third and wb.editor.redo.disabled


def test_the_pages_undo_keys_step_the_history(wb):
    _edit(wb, "B", 0.12, 0.08)
    edited = dumps_toml(wb.mechanism)
    wb.editor.undo.tags = [1, -1]                               # Ctrl-Z in the page
    assert wb.mechanism.joint("B").at == load_mechanism("four_bar").joint("B").at
    wb.editor.undo.tags = [2, 1]                                # Ctrl-Shift-Z
    assert dumps_toml(wb.mechanism) == edited
    wb.editor.undo.tags = [3, "rm -rf"]                         # written by hand: ignored
    assert dumps_toml(wb.mechanism) == edited


def test_an_edited_design_solves_as_the_library_solves_it(wb):
    _edit(wb, "A", 0.015, 0.02)
    m = moved(load_mechanism("four_bar"), "A", (0.015, 0.02))
    assert dumps_toml(wb.mechanism) == dumps_toml(m)
    ref = solve(m, [0.0])
    assert ref.success


def test_bad_values_and_forged_points_are_one_line(wb):
    before = dumps_toml(wb.mechanism)
    wb.editor.edit("B", ("abc", "0.1"))
    assert "position of B: expected two finite numbers" in _message(wb)
    wb.editor.edit("B", ("nan", "0.1"))
    assert "position of B: expected two finite numbers" in _message(wb)
    wb.editor.point.select.value = "../../etc/passwd"
    assert "edited point: expected one of its entries" in _message(wb)
    wb.editor.edit("nowhere", (0, 0))
    assert "edited point: expected a joint or tracer point of the design, got 'nowhere'" in _message(wb)
    assert dumps_toml(wb.mechanism) == before and not wb.editor.history.can_undo


def test_opening_another_design_starts_a_new_history(wb):
    _edit(wb, "B", 0.12, 0.08)
    wb.pick.value = "crank_slider"
    assert wb.editor.history.designs == (wb.mechanism,) and wb.editor.undo.disabled
    assert "A" in wb.editor.point.choices


def test_history_drops_what_was_undone_after_a_new_edit():
    h = History.of("m0").edited("m1").edited("m2").undone().edited("m3")
    assert h.designs == ("m0", "m1", "m3") and h.current == "m3" and not h.can_redo
    assert History.of("m0").undone().at == 0 and History.of("m0").redone().at == 0


def _drag(wb, name, x, y):
    """The handles' data as the page's point-draw tool sends it at the end of a drag."""
    data = {k: list(v) for k, v in wb.view.handles.data.items()}
    i = data["name"].index(name)
    data["x"][i], data["y"][i] = x, y
    wb.view.handles.data = data


def test_drag_of_one_handle_is_an_edit_with_undo(wb):
    original = dumps_toml(wb.mechanism)
    assert wb.view.handles.data["name"] == list(wb.view.scene.node_names)
    _drag(wb, "B", 0.11, 0.075)
    m = moved(load_mechanism("four_bar"), "B", (0.11, 0.075))
    assert dumps_toml(wb.mechanism) == dumps_toml(m) and wb.mechanism_name == "edited: four_bar"
    # the handles are the edited design's reference, the edit row shows the dragged point
    i = wb.view.handles.data["name"].index("B")
    assert (wb.view.handles.data["x"][i], wb.view.handles.data["y"][i]) == (0.11, 0.075)
    assert wb.editor.point.value == "B" and float(wb.editor.x.value) == 0.11
    _drag(wb, "O2", 0.001, -0.002)                              # a frame pivot too
    assert wb.mechanism.joint("O2").at == (0.001, -0.002)
    wb.editor.step(-1)
    wb.editor.step(-1)
    assert dumps_toml(wb.mechanism) == original


def test_drag_of_a_tracer_point(wb):
    wb.pick.value = "crank_slider"
    points = [p.name for p in wb.mechanism.points]
    if not points:
        pytest.skip("crank_slider has no tracer point")
    _drag(wb, points[0], 0.05, 0.03)
    assert next(p.at for p in wb.mechanism.points if p.name == points[0]) == (0.05, 0.03)


def test_a_server_side_redraw_of_the_handles_is_not_a_drag(wb):
    before = dumps_toml(wb.mechanism)
    wb.view._put_handles()
    wb.view.show(wb.view.scene, wb.view.sweeps, wb.mechanism_name)
    if wb.view.sweeps:
        wb.view.draw_frame(0)
    assert dumps_toml(wb.mechanism) == before and not wb.editor.history.can_undo
    assert "data-error" not in wb.message.text


def test_forged_handles_are_one_line_and_change_nothing(wb):
    before = dumps_toml(wb.mechanism)
    good = {k: list(v) for k, v in wb.view.handles.data.items()}
    forged = [dict(good, name=["../../etc/passwd"] + good["name"][1:], x=[9.0] + good["x"][1:]),
              dict(good, x=[float("nan")] + good["x"][1:]),
              dict(good, x=["abc"] + good["x"][1:]),
              dict(good, x=[v + 1 for v in good["x"]]),           # every handle at once
              dict(good, x=good["x"][:-1], y=good["y"][:-1], name=good["name"][:-1])]
    for data in forged:
        wb.clear()
        wb.view.handles.data = data
        assert _message(wb).count("\n") == 0 and ": expected" in _message(wb), data
        assert dumps_toml(wb.mechanism) == before and not wb.editor.history.can_undo
        assert wb.view.handles.data == good                     # the handles went back


def test_an_edits_motion_and_check_wake_the_page_when_ready(wb):
    """The job of an edited design calls the page's ``wake`` (the server's
    ``add_next_tick_callback(poll)``) when its motion is solved and when its check ends,
    so the page shows them without waiting for its periodic callback."""
    woken = []
    wb.wake = lambda: woken.append(wb.job.state if wb.job is not None else None)
    _edit(wb, "B", 0.12, 0.08)
    job = wb.job
    job.thread.join(timeout=600)
    assert not job.thread.is_alive() and job.state == "done" and len(woken) == 2
    wb.poll()                                   # what the woken page runs
    assert wb.check_doc == job.result and wb.job is None


def _settled(wb):
    while wb.job is not None:
        wb.job.thread.join(timeout=600)
        wb.poll()
    r = wb.view.fig.x_range, wb.view.fig.y_range
    return r[0].start, r[0].end, r[1].start, r[1].end


def test_an_edit_keeps_the_view_it_was_dragged_in_while_its_motion_fits_it():
    """A small drag leaves the drawing's ranges as they are (the handle stays under the
    pointer); an edit whose motion leaves the view, or another design opened, fits the
    view again."""
    w = Workbench(requested="four_bar")
    try:
        view = _settled(w)
        _drag(w, "B", 0.135, 0.0735)
        assert w.mechanism_name == "edited: four_bar" and _settled(w) == view
        _drag(w, "B", 0.30, 0.20)                       # its motion now runs out of the view
        grown = _settled(w)
        assert grown[1] > view[1] and grown[3] > view[3]
        x0, x1, y0, y1 = grown
        assert x0 <= 0.30 <= x1 and y0 <= 0.20 <= y1
        w.pick.value = "four_bar"                       # the catalogue design again: fitted again
        assert _settled(w) == view
    finally:
        w.close()


@pytest.mark.parametrize("name, point", [("excavator", "stick_cyl_base"), ("stephenson_3_triad", "O2"),
                                         ("four_bar", "B"), ("crank_slider", None)])
def test_the_pages_check_of_an_edit_is_the_librarys_check_of_that_design_alone(name, point):
    """The page's motion frames are solved on the check's own plan (its drivers' charts
    walked once); its check of an edited design is still ``check`` of a fresh copy of
    that design, solved alone, to the bit."""
    import json
    from dataclasses import replace

    from multiloop.kin.check import check
    w = Workbench(requested=name)
    try:
        _settled(w)
        point = point or w.mechanism.joints[-1].name
        x, y = w.mechanism.joint(point).at
        _drag(w, point, x + 0.02 * w.mechanism.size, y - 0.01 * w.mechanism.size)
        _settled(w)
        alone = replace(w.mechanism)
        assert alone == w.mechanism and alone is not w.mechanism
        want = check(alone, min_transmission=w.threshold).as_dict()
        assert json.dumps(w.check_doc, sort_keys=True) == json.dumps(want, sort_keys=True)
    finally:
        w.close()


def test_a_slider_running_off_to_an_asymptote_does_not_shrink_the_drawing():
    """dyad_prp's slider is 4.9e5 sizes away at the ends of its motion: the drawing's
    ranges stay around the mechanism (before, ±40 km: every ring on one pixel, and a drag
    of one moved all four)."""
    w = Workbench(requested="dyad_prp")
    try:
        while w.job is not None:
            w.job.thread.join(timeout=600)
            w.poll()
        assert w.view.sweeps
        size = w.mechanism.size
        for r in (w.view.fig.x_range, w.view.fig.y_range):
            assert r.end - r.start < 12 * size, (r.start, r.end)
    finally:
        w.close()


def test_changes_held_in_a_callback_are_written_as_two_messages_data_first():
    """glue.held: the changes made inside reach each connection of the session as two
    PATCH-DOC messages at most, the data sources' changes first, then the others
    (Bokeh's session writes one per change), a property changed twice once; without a
    session, Bokeh's own unhold."""
    import asyncio
    from types import SimpleNamespace

    from bokeh.document import Document
    from bokeh.models import ColumnDataSource, Div
    from bokeh.protocol import Protocol
    from bokeh.server.session import ServerSession

    from multiloop.web.glue import held
    doc = Document()
    a, b = Div(text="a"), ColumnDataSource(dict(x=[1]))
    doc.add_root(a)
    doc.add_root(b)
    written, single = [], []

    class Connection:
        protocol = Protocol()
        _socket = SimpleNamespace(send_message=lambda msg: written.append(msg) or asyncio.sleep(0))

        def send_patch_document(self, event):
            single.append(event)
            return asyncio.sleep(0)
    session = ServerSession("s", doc)
    conn = Connection()
    session._subscribed_connections = {conn}
    session._pending_writes = []
    context = SimpleNamespace(_session=session)
    doc._session_context = lambda: context     # as Bokeh's server sets it (a weak reference)
    with held(doc):
        a.text = "b"
        a.text = "c"
        b.data = dict(x=[2])
    assert single == [] and len(written) == 2          # two messages, none per change
    first, second = (w.content["events"] for w in written)
    assert [e["kind"] for e in first] == ["ColumnDataChanged"]          # the data first, though made last
    assert [e["kind"] for e in second] == ["ModelChanged"] and second[0]["new"] == "c"
    async def written_out():                  # every write awaited, as the session does
        for p in session._pending_writes:
            await p
    asyncio.run(written_out())
    written.clear()
    session._pending_writes = []
    with held(doc):                          # only a Div changed: one message
        a.text = "e"
    assert len(written) == 1 and [e["kind"] for e in written[0].content["events"]] == ["ModelChanged"]
    asyncio.run(written_out())
    session._pending_writes = None            # no callback running: Bokeh's unhold
    with pytest.raises(RuntimeError):        # (its session refuses a change outside a callback)
        with held(doc):
            a.text = "d"


def test_a_held_edit_shows_only_the_newest_design_and_its_own_check(wb):
    """With the server's timer (``hold.later``) an edit's showing waits for its job: a
    second edit before it is shown drops the first (its timer then does nothing), the
    first's job is cancelled, and the page shows the second design with its own check
    once its job ends; a units change meanwhile reaches the design shown."""
    from multiloop.web.units import Units
    timers = []
    wb.hold.later = lambda ms, fn: timers.append(fn)
    shown = wb.view.scene
    _edit(wb, "B", 0.12, 0.08)
    first_job, first = wb.job, wb.mechanism
    _edit(wb, "B", 0.11, 0.07)
    second_job, second = wb.job, wb.mechanism
    assert first_job.cancelled and wb.view.scene is shown and len(timers) == 2
    wb.view.use_units(Units("m", "rad"))
    timers[0]()                                  # the first edit's timer: not the one held
    assert wb.view.scene is shown
    second_job.thread.join(timeout=600)
    wb.poll()                                    # the job ended: the held design with its check
    assert wb.view.scene.mechanism is second and wb.view.sweeps and wb.check_doc == second_job.result
    assert wb.view.readout.text.endswith(" rad</span>") and wb.view.sweep.tags[1] == "rad" and first is not second
    timers[1]()                                  # its own timer, after: nothing more
    assert wb.view.scene.mechanism is second and wb.hold.show is None
