"""The workbench's Synthesis tab without a start: the atlas chooses the topology
(``catalogue.topology_synthesis``), at the level of :class:`multiloop.web.app.Workbench`
(no browser), and once in the headless browser of tests/test_web.py."""
from __future__ import annotations

import time

import numpy as np
import pytest

pytest.importorskip("panel")

from multiloop.catalogue.atlas import Atlas  # noqa: E402
from multiloop.catalogue.curve_atlas import build_curves  # noqa: E402
from multiloop.catalogue.inversions import build_mechanisms  # noqa: E402
from multiloop.catalogue.synthesis import SynthesisOptions  # noqa: E402
from multiloop.kin.check import check  # noqa: E402
from multiloop.kin.solve import solve  # noqa: E402
from multiloop.web.app import Workbench  # noqa: E402
from multiloop.web.synthesis_view import NO_START, AtlasDesign  # noqa: E402


@pytest.fixture(scope="module")
def tiny_atlas(tmp_path_factory):
    """Four-bar curves only (as tests/test_curve_index.py's atlas): 6 realisations."""
    db = tmp_path_factory.mktemp("web-atlas") / "atlas.sqlite"
    with Atlas(db) as atlas:
        opts = SynthesisOptions(4, 1, simple_joints=True)
        atlas.build(opts, progress=False, loops=False)
        build_mechanisms(atlas, opts)
        build_curves(atlas, opts, 6)
    return db


def _ellipse(n: int = 25) -> np.ndarray:
    t = np.linspace(0.0, 2 * np.pi, n)
    return np.column_stack([0.3 + 0.2 * np.cos(t), 0.5 + 0.1 * np.sin(t)])


def _finish(sv, timeout: float = 120.0) -> None:
    t0 = time.perf_counter()
    while sv.job is not None:
        assert time.perf_counter() - t0 < timeout, "synthesis did not finish"
        sv.poll()
        time.sleep(0.1)


def _no_start(wb, atlas, budget=3.0, top=2):
    sv = wb.synthesis
    sv.w["start"].value = NO_START
    sv.w["atlas"].value = str(atlas)
    sv.w["links"].value = ["4"]
    sv.w["budget"].value, sv.w["top"].value = budget, top
    sv.target = _ellipse()
    return sv


def test_the_atlas_field_defaults_to_the_served_atlas(tiny_atlas):
    assert Workbench(atlases=[str(tiny_atlas)]).synthesis.w["atlas"].value == str(tiny_atlas)
    sv = Workbench().synthesis
    assert sv.w["atlas"].value == "atlas.sqlite"
    assert sv.w["start"].value != NO_START and sv.w["start"].options[:2] == ["(open mechanism)", NO_START]
    assert not sv.atlas_box.visible
    sv.w["start"].value = NO_START
    assert sv.atlas_box.visible and sv.w["point"].value == "P"


def test_no_start_lists_designs_that_solve_pass_check_and_open_and_download(tiny_atlas):
    from multiloop.inputs import load_upload

    wb = Workbench()
    sv = _no_start(wb, tiny_atlas)
    sv.run()
    assert sv.job is not None and sv.w["cancel"].disabled is False
    _finish(sv)
    assert 'data-state="done"' in sv.status.object, sv.status.object + wb.message.object
    assert 1 <= len(sv.results) <= 2 and all(isinstance(r, AtlasDesign) for r in sv.results)
    assert sv.table.object.count("<tr data-candidate=") == len(sv.results)
    for r in sv.results:
        m = r.mechanism
        assert f"<td>{m.n_links}</td><td>{r.structure}</td>" in sv.table.object
        assert r.error_rms < 0.05 and np.isfinite(r.error_max)
        st = solve(m, np.linspace(0.0, 1.0, 5))
        assert st.ok.all()
        assert not check(m).drivers[0].unreachable
    # every design drawn over the target (its tracer's path), the chosen one in red
    assert len(sv.curves.data["xs"]) == len(sv.results)
    drawn = np.column_stack([sv.curves.data["xs"][0], sv.curves.data["ys"][0]])
    drawn = drawn[np.all(np.isfinite(drawn), axis=1)]
    gap = np.min(np.linalg.norm(_ellipse()[:, None] - drawn[None], axis=2), axis=1)
    assert gap.max() < 0.05 * 0.4, gap.max()            # 5 % of the target's size
    sv.w["pick"].value = "1"
    sv._open()
    assert wb.mechanism is sv.results[0].mechanism and wb.message.object == '<div id="ml-message"></div>'
    toml = load_upload("d.toml", sv._download("toml").read())           # read back as an upload
    pys = load_upload("d.pyslvs", sv._download("pyslvs").read())
    assert wb.message.object == '<div id="ml-message"></div>'
    ref = solve(sv.results[0].mechanism, [0.0, 0.5]).point_positions
    assert np.allclose(solve(toml, [0.0, 0.5]).point_positions, ref, atol=1e-9)
    assert pys.n_links == toml.n_links and pys.n_joints == toml.n_joints


@pytest.mark.parametrize("what", ["missing", "empty", "not sqlite"])
def test_a_missing_or_empty_atlas_is_one_line_in_the_page(tmp_path, what):
    db = tmp_path / "atlas.sqlite"
    if what == "empty":
        Atlas(db).close()
    elif what == "not sqlite":
        db.write_text("x,y\n1,2\n")
    wb = Workbench()
    sv = _no_start(wb, db)
    sv.run()
    _finish(sv, 30.0)
    msg = wb.message.object
    assert 'data-error="1"' in msg and "expected" in msg and "\n" not in msg, msg
    assert 'data-state="failed"' in sv.status.object and not sv.results
    assert sv.w["run"].disabled is False
    if what != "not sqlite":
        assert "hint: build" in msg
    wb.open_name("four_bar")                        # the page goes on
    assert wb.mechanism.name and wb.message.object == '<div id="ml-message"></div>'


def test_cancel_stops_the_page_at_once_and_the_work_at_the_next_polish(tiny_atlas):
    """The tiny atlas gives 2 starts: each polish has a quarter of the budget (half of it
    screens); the run would take the whole budget."""
    wb = Workbench()
    budget = 20.0
    sv = _no_start(wb, tiny_atlas, budget=budget)
    sv.run()
    job = sv.job
    t0 = time.perf_counter()
    while job.fraction <= 0 and time.perf_counter() - t0 < 30:     # the polish has begun
        time.sleep(0.05)
    sv.cancel()
    t1 = time.perf_counter()
    assert sv.job is None and sv.w["run"].disabled is False      # the page waits no more
    assert 'data-state="cancelled"' in sv.status.object
    job.thread.join(timeout=budget)
    stopped = time.perf_counter() - t1
    assert not job.thread.is_alive() and job.state == "cancelled"
    assert stopped < 0.5 * budget, stopped                        # one polish's share, not the budget
    sv.poll()
    assert sv.results == [] and sv.table.object == ""


def test_a_bad_links_choice_is_one_line(tiny_atlas):
    wb = Workbench()
    sv = _no_start(wb, tiny_atlas)
    sv.w["links"].value = []
    sv.run()
    assert sv.job is None and "--links: expected even numbers" in wb.message.object
