"""The workbench's Synthesis tab without a start: the atlas chooses the topology
(``catalogue.topology_synthesis``), at the level of :class:`multiloop.web.app.Workbench`
(no browser), and once in the headless browser of tests/test_web.py."""
from __future__ import annotations

import time

import numpy as np
import pytest

pytest.importorskip("bokeh")

from multiloop.catalogue.atlas import Atlas  # noqa: E402
from multiloop.catalogue.synthesis import nauty_available  # noqa: E402
from multiloop.kin.check import check  # noqa: E402
from multiloop.kin.solve import solve  # noqa: E402
from multiloop.web.app import Workbench  # noqa: E402
from multiloop.web.synthesis_view import NO_START, AtlasDesign  # noqa: E402
from tests.common import four_bar_curve_atlas  # noqa: E402


@pytest.fixture(scope="module")
def tiny_atlas(tmp_path_factory):
    """Four-bar curves only (as tests/test_curve_index.py's atlas): 6 realisations."""
    if not nauty_available():
        pytest.skip("nauty's geng/genbg not installed")
    return four_bar_curve_atlas(tmp_path_factory.mktemp("web-atlas") / "atlas.sqlite")


def _ellipse(n: int = 25) -> np.ndarray:
    t = np.linspace(0.0, 2 * np.pi, n)
    return np.column_stack([0.3 + 0.2 * np.cos(t), 0.5 + 0.1 * np.sin(t)])


@pytest.fixture
def evaluations(monkeypatch):
    """The page's runs without a start under an evaluation budget, in place of the page's
    seconds (the page offers seconds only): the same designs on a loaded machine.  Set
    the budget with ``evaluations.n`` (default 3000)."""
    import multiloop.catalogue.topology_synthesis as ts
    original = ts.synthesise

    def run(*args, budget=None, **kw):
        return original(*args, evaluations=run.n, **kw)
    run.n = 3000
    monkeypatch.setattr(ts, "synthesise", run)
    return run


def _finish(sv, timeout: float = 300.0) -> None:
    t0 = time.perf_counter()
    while sv.job is not None:
        assert time.perf_counter() - t0 < timeout, "synthesis did not finish"
        sv.poll()
        time.sleep(0.1)


def _message(wb) -> str:
    """The text of the page's message line."""
    import html
    return html.unescape(wb.message.text)


def _synthesis(wb):
    """The workbench's Synthesis view (the tab is built when first shown)."""
    wb.tabs.active = 2
    return wb.synthesis


def _no_start(wb, atlas, budget=3.0, top=2):
    """The Synthesis tab of ``wb`` (served with the atlas ``atlas``) set for a run without a start."""
    sv = _synthesis(wb)
    sv.w["start"].value = NO_START
    sv.w["atlas"].value = str(atlas)
    assert sv.menus["atlas"].value == str(atlas)
    sv.w["links"].active = [0]                  # 4 links
    sv.w["budget"].value, sv.w["top"].value = budget, top
    sv.target = _ellipse()
    return sv


def test_the_atlas_menu_holds_the_served_atlases_only(tiny_atlas, tmp_path):
    """The atlas box was a text field: any path typed (or set by a script) was opened.
    It is a menu of the atlases given to serve; without one, a run says so."""
    other = tmp_path / "other.sqlite"
    wb = Workbench(atlases=[str(tiny_atlas), str(other)])
    sv = _synthesis(wb)
    assert sv.w["atlas"].value == str(tiny_atlas) and sv.w["atlas"].options == [str(tiny_atlas), str(other)]
    sv.w["atlas"].value = str(tmp_path / "elsewhere.sqlite")          # a value the page was not given
    assert sv.w["atlas"].value == sv.menus["atlas"].value == str(tiny_atlas)
    assert "atlas menu: expected one of its entries" in wb.message.text
    wb = Workbench()
    sv = _synthesis(wb)
    assert sv.w["atlas"].value == "" and sv.w["atlas"].options == []
    assert sv.w["start"].value != NO_START and sv.w["start"].options[:2] == ["(open mechanism)", NO_START]
    assert not sv.atlas_box.visible
    sv.w["start"].value = NO_START
    assert sv.atlas_box.visible and sv.w["point"].value == "P"
    sv.target = _ellipse()
    sv.run()
    assert sv.job is None and "atlas: expected an atlas given to serve, got none" in _message(wb)


def test_no_start_lists_designs_that_solve_pass_check_and_open_and_download(tiny_atlas, evaluations):
    from multiloop.inputs import load_upload

    wb = Workbench(atlases=[str(tiny_atlas)])
    sv = _no_start(wb, tiny_atlas)
    sv.run()
    assert sv.job is not None and sv.w["cancel"].disabled is False
    _finish(sv)
    assert 'data-state="done"' in sv.status.text, sv.status.text + wb.message.text
    assert 1 <= len(sv.results) <= 2 and all(isinstance(r, AtlasDesign) for r in sv.results)
    assert sv.table.text.count("<tr data-candidate=") == len(sv.results)
    for r in sv.results:
        m = r.mechanism
        assert f"<td>{m.n_links}</td><td>{r.structure}</td>" in sv.table.text
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
    assert wb.mechanism is sv.results[0].mechanism and wb.message.text == '<div id="ml-message"></div>'
    toml = load_upload("d.toml", sv._download("toml")[1].encode())           # read back as an upload
    pys = load_upload("d.pyslvs", sv._download("pyslvs")[1].encode())
    assert wb.message.text == '<div id="ml-message"></div>'
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
    wb = Workbench(atlases=[str(db)])
    sv = _no_start(wb, db)
    sv.run()
    _finish(sv, 30.0)
    msg = wb.message.text
    assert 'data-error="1"' in msg and "expected" in msg and "\n" not in msg, msg
    assert 'data-state="failed"' in sv.status.text and not sv.results
    assert sv.w["run"].disabled is False
    if what != "not sqlite":
        assert "hint: build" in msg
    wb.open_name("four_bar")                        # the page goes on
    assert wb.mechanism.name and wb.message.text == '<div id="ml-message"></div>'


def test_cancel_stops_the_page_at_once_and_the_work_at_the_next_polish(tiny_atlas, evaluations, monkeypatch):
    """The tiny atlas gives 2 starts, each polished twice (screen, refine), under a budget
    of a million evaluations: a cancel during the first polish ends the page's wait at
    once, and the work before the next polish (none begins after the cancel)."""
    import threading

    import multiloop.catalogue.topology_synthesis as ts
    evaluations.n = 10 ** 6
    jobs, began, cancelled_at_start = [], threading.Event(), []
    original = ts._local

    def polish(*args, **kw):
        cancelled_at_start.append(bool(jobs) and jobs[0].cancelled)
        began.set()
        return original(*args, **kw)
    monkeypatch.setattr(ts, "_local", polish)
    wb = Workbench(atlases=[str(tiny_atlas)])
    sv = _no_start(wb, tiny_atlas)
    sv.run()
    job = sv.job
    jobs.append(job)
    assert began.wait(300)                                          # the first polish has begun
    sv.cancel()
    assert sv.job is None and sv.w["run"].disabled is False      # the page waits no more
    assert 'data-state="cancelled"' in sv.status.text
    job.thread.join(timeout=600)                                  # (a safety bound: one polish)
    assert not job.thread.is_alive() and job.state == "cancelled"
    assert cancelled_at_start and not any(cancelled_at_start)       # no polish began after the cancel
    sv.poll()
    assert sv.results == [] and sv.table.text == ""


def test_a_bad_links_choice_is_one_line(tiny_atlas):
    wb = Workbench(atlases=[str(tiny_atlas)])
    sv = _no_start(wb, tiny_atlas)
    sv.w["links"].active = []
    sv.run()
    assert sv.job is None and "links: expected even numbers" in wb.message.text     # (the library names the parameter)
    sv.w["links"].active = [0, 7]                   # no box 7: set by a script, not a click
    sv.run()
    assert sv.job is None and "links (--links): expected one of its entries, got '[0, 7]'" in _message(wb)


@pytest.fixture(scope="module")
def served(tiny_atlas):
    """``multiloop serve --atlas TINY`` on a free port (tests/test_web.py's way)."""
    from tests.common import start_serve, stop
    url, proc = start_serve("--atlas", str(tiny_atlas))
    yield url
    stop(proc)


def _on_synthesis_tab(page, locator):
    """``locator`` once shown: the Synthesis tab clicked until it is (the server's switch
    to the mechanism tab, after a page load or an open, may come after a click)."""
    for _ in range(40):
        if locator.is_visible():
            return locator
        page.get_by_text("Synthesis", exact=True).click()
        page.wait_for_timeout(250)
    raise AssertionError(f"{locator} never shown")


@pytest.mark.browser
def test_browser_no_start_runs_from_the_served_atlas(served, tiny_atlas, tmp_path, tmp_path_factory):
    """In headless chromium: choose no start, upload a target CSV, run; the designs are
    listed, one downloads as .pyslvs and opens; a missing atlas is one line."""
    web = pytest.importorskip("tests.test_web")
    if web.CHROMIUM is None:
        pytest.skip("chromium not installed (install.sh installs it)")
    from multiloop.kin.solve import solve
    from multiloop.topo.pyslvs import read_pyslvs

    csv = tmp_path / "ellipse.csv"
    csv.write_text("x,y\n" + "\n".join(f"{x:.6f},{y:.6f}" for x, y in _ellipse()) + "\n")
    with web.sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=web.CHROMIUM, args=["--no-sandbox", "--disable-gpu"])
        try:
            page = web._page(browser, served, [])
            _on_synthesis_tab(page, page.locator(".ml-start select")).select_option(NO_START)
            field = page.locator(".ml-atlas select")
            sync_api = web.sync_api
            sync_api.expect(field).to_have_value(str(tiny_atlas))
            web.upload(page, "ml-csv", csv)
            sync_api.expect(page.locator("#ml-synthesis-status")).to_contain_text("25 rows", timeout=120000)
            page.locator(".ml-budget input").fill("3")
            page.locator(".ml-budget input").press("Enter")
            _on_synthesis_tab(page, page.get_by_role("button", name="Run")).click()
            page.wait_for_selector("#ml-synthesis-status[data-state=done]", state="attached", timeout=90000)
            assert page.locator("#ml-candidates tr[data-candidate]").count() >= 1
            web._shot(page, "web_synthesis_atlas.png", tmp_path_factory)
            with page.expect_download() as dl:
                page.get_by_text("Download .pyslvs").click()
            path = tmp_path / "design.pyslvs"
            dl.value.save_as(path)
            m = read_pyslvs(path)
            assert m.n_links == 4 and solve(m, np.linspace(0.0, 1.0, 5)).ok.all()
            page.get_by_role("button", name="Open in mechanism view").click()
            web._wait_frames(page)
            # an atlas the page was not given, set as a script in the page could: refused
            page.evaluate(web.FORGE_JS, ["ml-atlas", "value", str(tmp_path / "missing.sqlite")])
            sync_api.expect(page.locator("#ml-message")).to_contain_text("atlas menu: expected one of its entries",
                                                                         timeout=120000)
            sync_api.expect(_on_synthesis_tab(page, field)).to_have_value(str(tiny_atlas))
            web._pick(page, "crank_slider")                       # the page goes on
            sync_api.expect(page.locator("#ml-message")).not_to_have_attribute("data-error", "1")
        finally:
            browser.close()
