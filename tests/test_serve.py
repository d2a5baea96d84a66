"""``multiloop serve`` without a browser: uploads read by the command line's parsers,
the read-only atlas, the sweeps the slider indexes, the command's start-up checks."""
from __future__ import annotations

import os
import time
import subprocess
import sys

import numpy as np
import pytest

from multiloop.catalogue.atlas import Atlas
from multiloop.catalogue.dimensional.targets import parse_table, read_table
from multiloop.catalogue.synthesis import SynthesisOptions
from multiloop.topo.pyslvs import dumps_pyslvs, loads_pyslvs, read_pyslvs
from multiloop.inputs import load_mechanism, load_upload, resolve
from multiloop.kin.solve import solve
from multiloop.topo.errors import InputError, LinkageError
from multiloop.topo.io import mechanism_to_dict

MULTILOOP = [sys.executable, "-m", "multiloop"]


def _cli_message(tmp_path, name: str, data: bytes, capsys, monkeypatch) -> str:
    from multiloop.cli import main
    (tmp_path / name).write_bytes(data)
    monkeypatch.chdir(tmp_path)
    capsys.readouterr()
    assert main(["analyse", name]) == 2
    return capsys.readouterr().err.strip().removeprefix("multiloop analyse: error: ")


@pytest.mark.parametrize("name, data", [
    ("bad.toml", b"x = ["),
    ("bad.toml", b"[[link]]\nname = 1\n"),
    ("bad.json", b'{"link": [], "link": []}'),
    ("bad.toml", b"\xff\xfe"),
    ("bad.pyslvs", b"mechanism: 3\n"),
])
def test_a_bad_upload_has_the_message_of_the_command_line(tmp_path, name, data, capsys, monkeypatch):
    with pytest.raises(LinkageError) as exc:
        load_upload(name, data)
    cli = _cli_message(tmp_path, name, data, capsys, monkeypatch)
    assert str(exc.value) == cli


def test_uploads_are_capped_and_need_a_known_suffix():
    with pytest.raises(InputError, match="at most 10 bytes"):
        load_upload("a.toml", b"x" * 11, max_bytes=10)
    with pytest.raises(InputError, match="suffix '.exe'"):
        load_upload("a.exe", b"")


@pytest.mark.parametrize("name", ["four_bar", "stephenson_3", "crank_slider"])
def test_an_upload_reads_as_the_file_does(name, tmp_path):
    p = resolve(name)
    m = load_upload(p.name, p.read_bytes())
    assert mechanism_to_dict(m) == mechanism_to_dict(load_mechanism(name))
    text = dumps_pyslvs(load_mechanism(name))
    (tmp_path / "m.pyslvs").write_text(text)
    assert mechanism_to_dict(loads_pyslvs(text, "m.pyslvs", "m")) == mechanism_to_dict(read_pyslvs(tmp_path / "m.pyslvs"))


def test_csv_text_and_csv_file_give_the_same_table(tmp_path):
    text = "x,y\n0,0\n1,0.5\n2,1\n3,1.5\n4,2\n5,2.5\n"
    (tmp_path / "t.csv").write_text(text)
    np.testing.assert_array_equal(parse_table(text, (2, 3), "path", "t.csv"), read_table(tmp_path / "t.csv", (2, 3), "path"))
    with pytest.raises(InputError, match="t.csv line 3"):
        parse_table("x,y\n0,0\n1,a\n", (2, 3), "path", "t.csv")


def test_read_only_atlas_writes_nothing(tmp_path):
    db = tmp_path / "a.sqlite"
    with Atlas(db) as a:
        n = a.build(SynthesisOptions(6, 1), progress=False).count
    before = {p.name: p.stat().st_mtime_ns for p in tmp_path.iterdir()}
    with Atlas(db, readonly=True) as a:
        assert a.count(SynthesisOptions(6, 1)) == n == len(list(a.chains(SynthesisOptions(6, 1))))
    assert {p.name: p.stat().st_mtime_ns for p in tmp_path.iterdir()} == before
    with pytest.raises(InputError, match="no such file"):
        Atlas(tmp_path / "none.sqlite", readonly=True)
    (tmp_path / "junk.sqlite").write_text("not a database")
    with pytest.raises(InputError, match="atlas"):
        Atlas(tmp_path / "junk.sqlite", readonly=True)


@pytest.mark.parametrize("name", ["four_bar", "dyad_prp", "stephenson_3_triad"])
def test_the_slider_frames_are_the_solver_positions(name):
    from multiloop.web.scene import scene_of, sweep_driver
    m = load_mechanism(name)
    sc, sw = scene_of(m), sweep_driver(m, 0)
    assert sw.ok.all() and sw.x[sw.reference_index] == 0.0
    np.testing.assert_allclose(sw.nodes[sw.reference_index], sc.reference, atol=1e-9)
    # the frames after the reference are one continuous path from it
    fwd = sw.x[sw.reference_index:]
    st = solve(m, np.radians(fwd) if sw.rotary else fwd)
    np.testing.assert_allclose(sw.nodes[sw.reference_index:, : len(m.joints)], st.positions, atol=1e-12)
    assert sw.full_rotation == (name != "dyad_prp")
    # every moving link is drawn, over joints of that link
    drawn = {lk for lk, _, _, _ in sc.links}
    assert drawn == {lk for lk in m.link_names if lk != m.frame}


def test_a_limited_motion_has_its_frames_whatever_the_machine_speed():
    """The excavator's three cylinders (limited motions): P_FRAMES frames each, half on
    each side of the reference, the same in a second sweep (they were cut to a time
    budget before, and varied from run to run)."""
    from multiloop.web.scene import P_FRAMES, sweep_driver
    m = load_mechanism("excavator")
    for k in range(len(m.drivers)):
        sw, again = sweep_driver(m, k), sweep_driver(m, k)
        assert not sw.full_rotation and len(sw.x) == P_FRAMES and sw.reference_index == P_FRAMES // 2
        np.testing.assert_array_equal(sw.x, again.x)
        np.testing.assert_array_equal(sw.nodes, again.nodes)


@pytest.mark.parametrize("name, k", [("dyad_prp", 0), ("excavator", 2), ("excavator_bucket", 0),
                                     ("wheel_loader_zbar", 0), ("wheel_loader_zbar", 1)])
def test_a_limited_motion_spans_the_limits_that_check_finds(name, k):
    """The slider goes from limit to limit of the check's certified walk (end frames a
    millionth inside), every frame assembled; a reference at one limit (the wheel
    loader's lift cylinder) puts every frame on the other side.  Read off a coarse grid,
    the wheel loader's second cylinder had no motion at all and dyad_prp stopped 15°
    short of both limits."""
    from multiloop.kin.check import driver_angles
    from multiloop.web.scene import LIMIT_INSET, sweep_driver
    m = load_mechanism(name)
    sw, limits = sweep_driver(m, k), driver_angles(m, k).limits
    ends = np.radians(sw.x[[0, -1]]) if sw.rotary else sw.x[[0, -1]]
    hi, lo = max(max(limits), 0.0), min(min(limits), 0.0)
    assert sw.ok.all()
    np.testing.assert_allclose(ends, [lo, hi], rtol=2 * LIMIT_INSET, atol=1e-12)
    assert (sw.reference_index == 0) == (lo == 0.0)


def test_serve_rejects_a_bad_file_before_serving(tmp_path):
    (tmp_path / "bad.toml").write_text("x = [")
    r = subprocess.run(MULTILOOP + ["serve", "bad.toml", "--port", "0"], capture_output=True, text=True,
                       cwd=tmp_path, timeout=120)
    assert r.returncode == 2 and "bad.toml: TOML syntax error" in r.stderr and "Traceback" not in r.stderr


def test_serve_warns_when_bound_beyond_localhost(tmp_path):
    pytest.importorskip("bokeh") if not os.environ.get("CI") else None
    p = subprocess.Popen(MULTILOOP + ["serve", "--host", "0.0.0.0", "--port", "0"], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, cwd=tmp_path)
    try:
        assert "warning: binding 0.0.0.0" in p.stderr.readline()
        assert "http://0.0.0.0:" in p.stdout.readline()
    finally:
        p.terminate()
        p.wait(timeout=20)
    assert list(tmp_path.iterdir()) == []            # nothing written


class _Stop(Exception):
    pass


def test_the_check_stops_at_its_cancel_hook_and_a_silent_hook_changes_nothing():
    from multiloop.kin.check import check
    m = load_mechanism("four_bar")
    calls = []
    assert check(m, cancel=lambda: calls.append(1)).as_dict() == check(m).as_dict()
    assert calls                                   # the hook was polled
    # excavator_bucket's check runs for half a minute or more (Newton groups): the hook stops it at its
    # fifth poll, and the check polls no more after that (a count, not a clock)
    polls = []

    def hook():
        polls.append(1)
        if len(polls) == 5:
            raise _Stop

    with pytest.raises(_Stop):
        check(load_mechanism("excavator_bucket"), cancel=hook)
    assert len(polls) == 5


def _click(button) -> None:
    """A click on a Bokeh button, as the page's message delivers it to the server."""
    from bokeh.events import ButtonClick
    button._trigger_event(ButtonClick(button))


def _upload(file_input, name: str, data: bytes) -> None:
    """A file chosen in the page's file input, as the browser sends it (base64)."""
    import base64
    file_input.set_from_json("filename", name)
    file_input.set_from_json("value", base64.b64encode(data).decode("ascii"))


def _workbench():
    pytest.importorskip("bokeh") if not os.environ.get("CI") else None
    from multiloop.web.app import Workbench
    return Workbench({}, (), 40.0)


def _held_sweeps(monkeypatch, name: str):
    """The page's job for mechanism ``name`` held in its motions until it is cancelled
    (its ``cancel`` polled, as every solve of the real sweeps polls it): a test then acts
    on a job that is running, whatever the machine's speed.  Returns the event set once
    the job is inside."""
    import threading

    from multiloop.web import app
    inside, real = threading.Event(), app._sweeps

    def sweeps(m, key, cancel):
        if m.name != name:
            return real(m, key, cancel)
        inside.set()
        while True:
            cancel()                     # raises once the job is cancelled
            time.sleep(0.005)
    monkeypatch.setattr(app, "_sweeps", sweeps)
    return inside


def test_the_page_cancels_a_running_check_and_its_thread_ends(monkeypatch):
    inside = _held_sweeps(monkeypatch, "excavator_bucket")
    wb = _workbench()
    wb.open_name("excavator_bucket")
    job = wb.job
    assert inside.wait(120.0)            # a net: the wait is on the job's state
    assert job.running and not wb.check.stop.disabled
    _click(wb.check.stop)                          # the Cancel button
    job.thread.join(timeout=120.0)   # waits on the thread; the bound is a net
    assert not job.thread.is_alive() and job.state == "cancelled"
    wb.poll()
    assert "check cancelled" in wb.check.verdict.text and wb.check.stop.disabled and wb.job is None


def test_opening_another_mechanism_cancels_the_old_check(monkeypatch):
    inside = _held_sweeps(monkeypatch, "excavator_bucket")
    wb = _workbench()
    wb.open_name("excavator_bucket")
    old = wb.job
    assert inside.wait(120.0)
    wb.pick.value = "crank_slider"                 # the page's mechanism menu
    old.thread.join(timeout=120.0)   # waits on the thread; the bound is a net
    assert not old.thread.is_alive() and old.state == "cancelled"
    wb.job.thread.join(timeout=120.0)
    wb.poll()
    assert wb.check.doc is not None and wb.check.doc["mechanism"] == "crank_slider"


def test_the_mechanism_menu_follows_an_uploaded_or_opened_design():
    """After an upload or "Open in mechanism view" the menu names the design shown, and
    choosing an entry of the menu again shows that design."""
    wb = _workbench()
    p = resolve("crank_slider")
    _upload(wb.upload, "mine.toml", p.read_bytes())
    assert wb.mechanism_name.endswith("mine.toml")
    assert wb.pick.value == wb.mechanism_name and wb.pick.value in wb.pick.options
    uploaded = wb.mechanism
    wb.open_design(load_mechanism("watt_1"))                                 # a synthesised candidate
    assert wb.pick.value == wb.mechanism_name and wb.mechanism_name != "four_bar"
    assert wb.view.name == wb.mechanism_name
    wb.pick.value = "stephenson_2"
    assert wb.mechanism_name == "stephenson_2"
    wb.pick.value = [o for o in wb.pick.options if o.endswith("mine.toml")][0]   # back to the upload
    assert wb.mechanism is uploaded and wb.pick.value.endswith("mine.toml")
    _upload(wb.upload, "bad.toml", b"x = [")                                 # a bad file: nothing changes
    assert wb.mechanism is uploaded and wb.pick.value.endswith("mine.toml")
    wb.close()


def test_the_warm_up_process_sends_what_a_session_computes_itself():
    """``serve`` prepares the first page in a child process (multiloop.web.prepare): its
    drawing, structure, motion and check are those the session computes in-process."""
    pytest.importorskip("bokeh") if not os.environ.get("CI") else None
    from multiloop.kin.check import check
    from multiloop.web.prepare import results, start
    from multiloop.web.scene import scene_of, sweep_driver
    from multiloop.web.structure_view import structure_html
    m = load_mechanism("crank_slider")
    got = dict(results(start(m, 35.0)))
    assert set(got) == {"scene", "sweeps", "check"}
    scene, structure = got["scene"]
    mine = scene_of(m)
    assert (scene.node_names, scene.links, scene.joint_kind) == (mine.node_names, mine.links, mine.joint_kind)
    np.testing.assert_array_equal(scene.reference, mine.reference)
    assert structure == structure_html(m)
    (sw,) = got["sweeps"]
    own = sweep_driver(m, 0)
    assert sw.joint == own.joint and sw.full_rotation == own.full_rotation
    np.testing.assert_allclose(sw.nodes, own.nodes, rtol=0, atol=1e-12)
    doc, rep = got["check"]                          # the document and the report (the page's units)
    assert doc == rep.as_dict() == check(m, min_transmission=35.0).as_dict()


@pytest.mark.parametrize("with_child", [False, True])
def test_the_warm_up_fills_the_shared_cache(with_child):
    """serve's warm-up of the first mechanism, from the child process or in-process (one core)."""
    pytest.importorskip("bokeh") if not os.environ.get("CI") else None
    import threading
    from multiloop.web import app
    from multiloop.web.prepare import start
    m, name = load_mechanism("dyad_rrr"), f"warm-up test {with_child}"
    app._WARMING[name] = threading.Event()
    ready, shown = threading.Event(), threading.Event()
    shown.set()
    app.warm_up(name, m, 40.0, start(m, 40.0) if with_child else None, ready, shown)
    assert ready.is_set() and name not in app._WARMING
    import gc
    assert gc.get_freeze_count() > 10_000        # the imports frozen: no full collection scans them
    assert app._SCENES[name][0].node_names == tuple(m.joint_names) + tuple(p.name for p in m.points)
    assert len(app._SWEEPS[name]) == len(m.drivers)
    assert ((name, 40.0) in app._CHECKS) == with_child          # in-process the session's job checks
