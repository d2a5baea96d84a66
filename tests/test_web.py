"""``multiloop serve``: the web workbench in a real headless browser (Debian's chromium
driven by Playwright), plus the background job's cancel without a browser.

The server runs as ``multiloop serve`` in a subprocess on a free port; every request the
page makes is recorded and must stay on 127.0.0.1 (the page works offline).  Set
``MULTILOOP_SCREENSHOTS=DIR`` to keep the screenshots (docs/figures/web_*.png are
these, the later ones reduced to 128 colours).
"""
from __future__ import annotations

import contextlib
import json
import math
import os
import re
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

# in CI (install.sh installs the [web] and [browser-test] extras and chromium) these
# tests must run: a missing piece is a failure there, a skip elsewhere
if os.environ.get("CI"):
    import bokeh  # noqa: F401
    import playwright.sync_api as sync_api
else:
    pytest.importorskip("bokeh")
    sync_api = pytest.importorskip("playwright.sync_api")

from multiloop.inputs import load_mechanism  # noqa: E402
from multiloop.kin.solve import solve  # noqa: E402
from multiloop.topo.assur import decompose  # noqa: E402
from tests.common import QUANTITY, start_serve, stderr_of, stop  # noqa: E402

CATALOGUE = Path(__file__).resolve().parents[1] / "catalogue" / "mechanisms"

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser") or ("/usr/bin/chromium" if os.environ.get("CI") else None)
MULTILOOP = [sys.executable, "-m", "multiloop"]

#: every element of the page, also inside Bokeh's shadow roots
DEEP_JS = """(sel) => { const out = []; const walk = (root) => {
  root.querySelectorAll(sel).forEach(e => out.push(e));
  root.querySelectorAll('*').forEach(e => { if (e.shadowRoot) walk(e.shadowRoot); }); };
  walk(document); return out; }"""

#: set a property of a model of the page, found by its name, its CSS class or its title,
#: as a script in the page (or a message written by hand) could: ([key, attribute, value])
FORGE_JS = """([key, attr, value]) => { const doc = Bokeh.documents[0];
  const m = doc.get_model_by_name(key) || [...doc.all_models].find(m =>
    (m.css_classes || []).includes(key) || (m.title === key && attr in m));
  m[attr] = value; return m.type; }"""

#: the player's frame slider (a Bokeh Slider, model name ml-frame) in the browser
SLIDER_JS = "Bokeh.documents[0].get_model_by_name('ml-frame')"

#: move the player to frame i (the slider's value, as a drag sets it) and time it until
#: the drawing shows frame i (the animation frame in which Bokeh paints it), and until
#: the frame after that one (the page's own work after the move, e.g. its message to
#: the server)
MOVE_JS = """async ([i]) => {
  const deep = %s;
  const slider = """ + SLIDER_JS + """;
  const frame = () => new Promise(res => requestAnimationFrame(() => res()));
  const t0 = performance.now();
  slider.value = i;
  for (;;) {      // the glue runs in the input event; Bokeh paints in the next animation frame
    const r = deep('#ml-positions')[0];
    await frame();
    if (r && r.getAttribute('data-index') == String(i)) break;
  }
  const t1 = performance.now();
  await frame();
  return [t1 - t0, performance.now() - t0]; }"""
MOVE_JS = MOVE_JS % DEEP_JS

#: time every key press in the page: from its keydown (capture phase, before the slider
#: handles it) to the animation frame in which the readout shows another frame (the frame
#: in which Bokeh paints the drawing); the latencies go to window.__mlKeyLatency
KEY_TIMER_JS = """() => {
  const deep = %s;
  window.__mlKeyLatency = [];
  if (window.__mlKeyTimer) { return; }
  window.__mlKeyTimer = true;
  document.addEventListener('keydown', () => {
    const t0 = performance.now();
    const before = deep('#ml-positions')[0].getAttribute('data-index');
    const tick = () => requestAnimationFrame(() => {
      const r = deep('#ml-positions')[0];
      if (r && r.getAttribute('data-index') !== before) { window.__mlKeyLatency.push(performance.now() - t0); }
      else if (performance.now() - t0 < 5000) { tick(); }
    });
    tick();
  }, true); }""" % DEEP_JS

#: the synthesis tab's target figure is drawn: the start's traced path is in it (the server
#: has handled the choice of the start) and its view has painted everything it holds
TARGET_READY_JS = """() => { const fig = Bokeh.documents[0].get_model_by_name('ml-target');
  if (fig == null || fig.renderers[0].data_source.data.xs.length == 0) { return false; }
  const view = Bokeh.index.find_one(fig);
  return view != null && view.has_finished(); }"""

#: the strokes drawn on the target figure, in the page
STROKES_JS = "() => Bokeh.documents[0].get_model_by_name('ml-strokes').data.xs.length"


def _clear_target(page) -> None:
    """No stroke on the target figure. "Clear target" is pressed only when there is one, and
    the wait is for the count to drop: pressed on an empty target, the server's clear could
    arrive after the next stroke and wipe it (a stroke then "never reached the page")."""
    if page.evaluate(STROKES_JS) != 0:
        page.get_by_role("button", name="Clear target").click()
        page.wait_for_function(f"() => ({STROKES_JS})() == 0", timeout=120000)

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(CHROMIUM is None and not os.environ.get("CI"),
                                 reason="chromium not installed (install.sh installs it)")]


def _shot(page, name: str, tmp_path_factory) -> Path:
    folder = Path(os.environ.get("MULTILOOP_SCREENSHOTS") or tmp_path_factory.mktemp("shots"))
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    page.screenshot(path=str(path))
    return path


@pytest.fixture(scope="module")
def atlas_db(tmp_path_factory):
    from tests.common import six_bar_chain_atlas
    return six_bar_chain_atlas(tmp_path_factory.mktemp("atlas") / "a.sqlite")


@pytest.fixture(scope="module")
def server(atlas_db):
    """``multiloop serve`` on a free port; yields (url, the time it started, the process)."""
    t0 = time.perf_counter()
    url, proc = start_serve("--atlas", str(atlas_db))
    yield url, t0, proc
    stop(proc)


@pytest.fixture(scope="module")
def browser():
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox", "--disable-gpu"])
        yield b
        b.close()


@pytest.fixture(scope="module")
def requests_seen():
    return []


def _page(browser, url, requests_seen):
    page = browser.new_page(viewport={"width": 1400, "height": 1000}, accept_downloads=True)
    page.on("request", lambda r: requests_seen.append(r.url))
    page.goto(url)
    _wait_frames(page)
    return page


def _wait_frames(page, timeout=60000):
    page.wait_for_selector("#ml-positions[data-index]", state="attached", timeout=timeout)


def upload(page, css: str, path) -> None:
    """Choose the file ``path`` with the upload button of CSS class ``css`` (it opens a
    file chooser of its own)."""
    with page.expect_file_chooser() as chooser:
        page.locator(f".{css} button").click()
    chooser.value.set_files(str(path))


def _readout(page) -> dict:
    el = page.locator("#ml-positions")
    return {"index": int(el.get_attribute("data-index")), "input": float(el.get_attribute("data-input")),
            "positions": json.loads(el.get_attribute("data-positions"))}


def _pick(page, name: str, timeout: int = 60000) -> None:
    page.locator(".ml-pick select").select_option(name)
    page.wait_for_function(f"""() => {{ const r = ({DEEP_JS})('#ml-positions')[0];
        return r && r.getAttribute('data-positions') && r.getAttribute('data-mechanism') == '{name}'; }}""",
                           timeout=timeout)


@pytest.fixture(scope="module")
def page(browser, server, requests_seen, tmp_path_factory):
    url, t0, _ = server
    p = _page(browser, url, requests_seen)
    p.usable_after = time.perf_counter() - t0           # seconds from `serve` to a movable drawing
    print(f"\npage usable {p.usable_after:.2f} s after multiloop serve started")
    return p


def test_slider_positions_are_those_of_solve(page, tmp_path_factory):
    """Pick a catalogue mechanism, move the slider, read the displayed positions: they are
    the solver's along the same path from the reference."""
    _pick(page, "stephenson_3")
    m = load_mechanism("stephenson_3")
    ref = solve(m, np.radians(np.linspace(0.0, 360.0, 361)))
    names = list(m.joint_names) + [p.name for p in m.points]
    latencies = []
    for i in (37, 180, 299, 0):
        latencies.append(page.evaluate(MOVE_JS, [i])[0])
        r = _readout(page)
        assert r["index"] == i and r["input"] == pytest.approx(float(i))
        want = np.concatenate([ref.positions[i], ref.point_positions[i]])
        got = np.array([r["positions"][n] for n in names])
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    print(f"redraw after a slider move: max {max(latencies):.1f} ms")
    # the 50-ms goal is measured (printed here, and by `-m benchmark -k latency`), not asserted: no outcome on wall time
    page.wait_for_selector("#ml-check-json[data-mechanism=stephenson_3]", state="attached", timeout=60000)
    page.evaluate(MOVE_JS, [37])
    _shot(page, "web_mechanism.png", tmp_path_factory)


def test_a_limited_motion_gets_its_own_slider_range(page):
    """dyad_prp's crank does not turn fully: the slider spans both sides of the reference."""
    _pick(page, "dyad_prp")
    # the motion and the check have landed (a busy machine may bring them after the pick)
    page.wait_for_selector("#ml-check-json[data-mechanism=dyad_prp]", state="attached", timeout=120000)
    n = int(page.evaluate(f"() => {SLIDER_JS}.end"))
    assert n + 1 == 201
    page.evaluate(MOVE_JS, [n])
    r = _readout(page)
    assert r["index"] == n and 0 < r["input"] < 360


def test_check_panel_shows_the_numbers_of_check_json(page):
    _pick(page, "four_bar")
    page.wait_for_selector("#ml-check-json[data-mechanism=four_bar]", state="attached", timeout=60000)
    shown = json.loads(page.locator("#ml-check-json").text_content())
    cli = subprocess.run(MULTILOOP + ["check", "four_bar", "--json"], capture_output=True, text=True, check=True)
    assert shown == json.loads(cli.stdout)
    assert page.locator("#ml-check-events tr").count() > 1     # the events listed, each on the axis


def test_click_on_the_angle_plot_moves_the_mechanism(page):
    _pick(page, "four_bar")
    page.wait_for_selector("#ml-check-json[data-mechanism=four_bar]", state="attached", timeout=60000)
    before = _readout(page)["index"]
    canvas = page.locator(".bk-Canvas").nth(1) if page.locator(".bk-Canvas").count() > 1 else None
    box = page.locator("canvas").nth(1).bounding_box() if canvas is None else canvas.bounding_box()
    page.mouse.click(box["x"] + 0.6 * box["width"], box["y"] + 0.5 * box["height"])
    page.wait_for_function(f"() => ({DEEP_JS})('#ml-positions')[0].getAttribute('data-index') != '{before}'",
                           timeout=120000)
    assert _readout(page)["index"] != before


def test_malformed_upload_shows_the_cli_message_and_the_page_goes_on(page, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[[link]]\nname = 1\n")
    cli = subprocess.run(MULTILOOP + ["analyse", "bad.toml"], capture_output=True, text=True, cwd=tmp_path)
    assert cli.returncode == 2
    message = cli.stderr.strip().removeprefix("multiloop analyse: error: ")
    upload(page, "ml-open", bad)
    page.wait_for_selector("#ml-message[data-error]", state="attached", timeout=120000)
    assert page.locator("#ml-message").text_content().strip() == message
    _pick(page, "watt_1")                       # the server still serves this page
    assert "P" in _readout(page)["positions"] or _readout(page)["positions"]


def test_two_tabs_do_not_share_state(browser, server, requests_seen, page):
    other = _page(browser, server[0], requests_seen)
    try:
        _pick(other, "crank_slider")
        _pick(page, "stephenson_2")
        assert set(_readout(other)["positions"]) == set(load_mechanism("crank_slider").joint_names) | {
            p.name for p in load_mechanism("crank_slider").points}
        assert page.locator("#ml-positions").get_attribute("data-mechanism") == "stephenson_2"
        assert other.locator("#ml-positions").get_attribute("data-mechanism") == "crank_slider"
    finally:
        other.close()


def _slow_to_check(tmp_path) -> Path:
    """stephenson_3_triad with its rocker on a slide: the triad with a P joint has no
    closed form (a general group, tracked by Newton), and its check takes seconds (the
    excavator's took that long once; now it takes a tenth of a second)."""
    text = (CATALOGUE / "stephenson_3_triad.toml").read_text()
    old = 'name = "O2"\nkind = "R"\nlinks = ["rocker_b4", "frame"]\nat = [0.15, 0.02]'
    assert old in text
    path = tmp_path / "slider_triad.toml"
    path.write_text(text.replace(old, old.replace('"R"', '"P"') + "\naxis = [0.0, 1.0]"))
    assert [g.kind.value for g in decompose(load_mechanism(path)).groups] == ["group"]
    return path


def test_cancel_check_stops_a_running_check(page, tmp_path):
    # a general group's motion and check take seconds: cancel them from the page
    upload(page, "ml-open", _slow_to_check(tmp_path))
    button = page.locator(".ml-check-cancel button")
    sync_api.expect(button).to_be_enabled(timeout=120000)
    button.click()
    # "check cancelled" is shown only once the worker thread has ended (Job._run)
    sync_api.expect(page.locator("#ml-check-status")).to_have_text("check cancelled", timeout=120000)
    sync_api.expect(button).to_be_disabled()
    _pick(page, "four_bar")                     # the page goes on


def test_drawn_curve_gives_a_design_that_solves(page, tmp_path, tmp_path_factory):
    """Every step waits on the page's state, never on a fixed time: the stroke is drawn
    once the target figure shows the chosen start, and Run is pressed once the page holds
    the stroke (under load, a stroke drawn 500 ms after the choice was lost: "expected a
    drawn stroke")."""
    page.get_by_text("Synthesis", exact=True).click()
    page.locator(".ml-start select").select_option("four_bar", timeout=120000)
    page.wait_for_function(TARGET_READY_JS, timeout=120000)
    page.locator(".ml-budget input").fill("3")            # budget (s)
    page.locator(".ml-budget input").press("Enter")
    _clear_target(page)
    box = page.evaluate(TARGET_BOX_JS)
    cx, cy, r = box["x"] + 0.5 * box["width"], box["y"] + 0.5 * box["height"], 0.18 * box["height"]
    _drag(page, "ml-target", [(cx + r * math.cos(t) * 1.4, cy + r * math.sin(t))
                              for t in np.linspace(0, 1.6 * math.pi, 40)])
    page.wait_for_function(f"() => ({STROKES_JS})() == 1", timeout=120000)
    page.get_by_role("button", name="Run").click()
    page.wait_for_selector("#ml-synthesis-status[data-state=done]", state="attached", timeout=300000)
    assert page.locator("#ml-candidates tr[data-candidate]").count() == 1
    _shot(page, "web_synthesis.png", tmp_path_factory)
    with page.expect_download() as dl:
        page.get_by_text("Download .toml").click()
    path = tmp_path / "design.toml"
    dl.value.save_as(path)
    m = load_mechanism(path)
    st = solve(m, np.radians(np.linspace(0.0, 360.0, 73)))
    assert st.ok[0] and np.isfinite(st.point_positions[0]).all()
    page.get_by_role("button", name="Open in mechanism view").click()
    _wait_frames(page)
    # the mechanism menu names the candidate shown, not the catalogue entry opened before
    sync_api.expect(page.locator(".ml-pick select")).to_have_value(re.compile(r"^design: "), timeout=120000)
    page.get_by_text("Mechanism", exact=True).first.click()


def test_atlas_tab_lists_the_stored_chains(page, atlas_db):
    from multiloop.catalogue.atlas import Atlas
    from multiloop.catalogue.synthesis import SynthesisOptions
    page.get_by_text("Atlas", exact=True).click()
    page.wait_for_selector("#ml-atlas-count", state="attached", timeout=120000)
    with Atlas(atlas_db, readonly=True) as a:
        n = a.count(SynthesisOptions(6, 1))
    assert page.locator("#ml-atlas-count").text_content().startswith(f"{n} chains")
    assert page.locator(".card[data-search]").count() == n


def test_page_is_usable_soon_and_asks_nothing_from_the_internet(page, requests_seen):
    print(f"usable after {page.usable_after:.2f} s; {len(requests_seen)} requests")
    assert requests_seen and all(u.startswith(("http://127.0.0.1:", "ws://127.0.0.1:", "data:", "blob:"))
                                 for u in requests_seen), [u for u in requests_seen if "127.0.0.1" not in u]
    # the goal is 3 s on an idle machine: measured by benchmarks/bench_web.py (docs/web.md), not asserted
    # here, so that no outcome depends on the machine's load


def test_cancel_stops_the_synthesis_worker():
    """Not a browser test: the cancel of a job ends its thread within a generation."""
    from multiloop.web.jobs import Job
    from multiloop.web.synthesis_view import run_candidates
    m = load_mechanism("four_bar")
    target = np.column_stack([0.05 + 0.03 * np.cos(np.linspace(0, 5, 20)), 0.07 + 0.02 * np.sin(np.linspace(0, 5, 20))])
    job = Job(lambda j: run_candidates(j, m, target, 1, dict(seed=0, budget=60.0, evaluations=10 ** 6, tol=1e-12)),
              "test")
    while job.fraction == 0 and job.thread.is_alive():          # waits on the job's state
        time.sleep(0.05)
    job.cancel()
    job.thread.join(timeout=600)                                 # a net: a generation takes seconds
    assert not job.thread.is_alive() and job.state == "cancelled"
    assert threading.active_count() >= 1


@pytest.mark.benchmark
def test_redraw_latency_of_every_catalogue_mechanism(page):
    """Redraw latency in the browser after a slider move, for every catalogue mechanism
    (the goal is 50 ms; every catalogue mechanism opened in turn, hence a benchmark):
    a real key press (ArrowRight) on the slider's focused handle at 11 places along the
    motion, timed in the page from its keydown to the painted frame (KEY_TIMER_JS).
    Run: ``python -m pytest tests/test_web.py -m benchmark -s -k latency``."""
    from multiloop.web.app import catalogue_names
    worst = {}
    for name in catalogue_names():
        _pick(page, name, timeout=600000)
        n = int(page.evaluate(f"() => {SLIDER_JS}.end"))
        page.evaluate(KEY_TIMER_JS)
        handle = page.locator(".ml-frame .noUi-handle").first
        for k, i in enumerate(np.linspace(0, n - 1, 11).round()):
            page.evaluate(MOVE_JS, [int(i)])
            handle.focus()
            page.keyboard.press("ArrowRight")
            page.wait_for_function(f"() => window.__mlKeyLatency.length > {k}", timeout=120000)
            assert _readout(page)["index"] == int(i) + 1
        times = np.array(page.evaluate("() => window.__mlKeyLatency"))
        worst[name] = (float(np.median(times)), float(times.max()), n + 1)
        print(f"{name:24s} frames {n + 1:4d}  key press to painted frame: median {worst[name][0]:6.1f} ms, "
              f"max {worst[name][1]:6.1f} ms")
    assert max(w[0] for w in worst.values()) <= 50      # the goal, on the median of 11 key presses


def test_share_by_name_opens_the_mechanism_in_a_fresh_browser_context(browser, server):
    """``?mechanism=NAME`` beside the page's token opens that mechanism in a fresh
    context (no cookie); a name that is not in the menu is the one-line message over
    the default mechanism, and the page keeps working."""
    url, _, _ = server
    ctx = browser.new_context(viewport={"width": 1400, "height": 1000})
    try:
        page = ctx.new_page()
        page.goto(url + ("&" if "?" in url else "?") + "mechanism=stephenson_2")
        page.wait_for_function(f"""() => {{ const r = ({DEEP_JS})('#ml-positions')[0];
            return r && r.getAttribute('data-mechanism') == 'stephenson_2'; }}""", timeout=60000)
        page.goto(url + ("&" if "?" in url else "?") + "mechanism=%3Cimg%20src%3Dx%3E")
        page.wait_for_selector("#ml-message[data-error]", state="attached", timeout=60000)
        assert "expected one of its entries, got '<img src=x>'" in page.locator("#ml-message").text_content()
        _wait_frames(page)
        _pick(page, "crank_slider")
    finally:
        ctx.close()



def _at_joint_js(name: str, tol: float) -> str:
    """A page function ``([x, y]) => bool``: the readout puts joint ``name`` at (x, y) within ``tol``."""
    return """([x, y]) => { const r = (%s)('#ml-positions')[0];
        if (!r || !r.getAttribute('data-positions')) return false;
        const b = JSON.parse(r.getAttribute('data-positions'))[%s];
        return Math.abs(b[0] - x) < %r && Math.abs(b[1] - y) < %r; }""" % (DEEP_JS, json.dumps(name), tol, tol)

def test_undo_a_typed_edit_with_ctrl_z_in_the_page(page):
    """Type B's coordinates, Apply: the drawing is the edited design at its reference;
    Ctrl-Z in the page gives the original back, Ctrl-Shift-Z the edit."""
    page.get_by_text("Mechanism", exact=True).first.click()      # (an earlier test may have left another tab)
    _pick(page, "four_bar")
    original = load_mechanism("four_bar").joint("B").at
    page.locator(".ml-edit-point select").select_option("B")
    # the server fills in B's coordinates: wait for them before typing over them
    sync_api.expect(page.locator(".ml-edit-x input")).to_have_value(repr(float(original[0])), timeout=60000)
    for css, v in ((".ml-edit-x input", "0.12"), (".ml-edit-y input", "0.08")):
        page.locator(css).fill(v)
        page.locator(css).press("Enter")
    page.locator(".ml-edit-apply button").click()
    at_b = _at_joint_js("B", 1e-12)
    page.wait_for_function(at_b, arg=[0.12, 0.08], timeout=60000)
    page.mouse.click(5, 5)                      # the focus leaves the text field
    page.keyboard.press("Control+z")
    page.wait_for_function(at_b, arg=list(original), timeout=60000)
    page.keyboard.press("Control+Shift+z")
    page.wait_for_function(at_b, arg=[0.12, 0.08], timeout=60000)


#: the screen position (page pixels) of the drag handle of joint or tracer point NAME:
#: its data position mapped by the drawing's scales, plus the canvas's place in the page
HANDLE_JS = """([name]) => { const doc = Bokeh.documents[0];
  const src = doc.get_model_by_name('ml-handles'), fig = doc.get_model_by_name('ml-mechanism');
  const view = Bokeh.index.find_one(fig), i = src.data.name.indexOf(name);
  if (view == null || i < 0) { return null; }
  view.el.scrollIntoView({block: 'center'});
  const r = view.canvas_view.el.getBoundingClientRect();
  return [r.left + view.frame.x_scale.compute(src.data.x[i]), r.top + view.frame.y_scale.compute(src.data.y[i]),
          src.data.x[i], src.data.y[i]]; }"""


def test_drag_a_joint_with_the_mouse_then_ctrl_z(page, tmp_path_factory):
    """Drag B's handle with the mouse: the page opens the edited design, whose drawing
    (at the reference frame) is the library's solve of ``moved(four_bar, B, new)``;
    Ctrl-Z gives the original back."""
    from multiloop.web.editing import moved
    _pick(page, "four_bar")
    page.get_by_text("Mechanism", exact=True).first.click()
    original = load_mechanism("four_bar")
    page.evaluate(MOVE_JS, [90])                             # the player away from the reference
    sx, sy, x0, y0 = page.evaluate(HANDLE_JS, ["B"])
    assert (x0, y0) == tuple(original.joint("B").at)
    _drag(page, "ml-mechanism", [(sx + 3 * k, sy + 2 * k) for k in range(9)], release=False)
    # during the drag the drawing is at the reference frame and its joint B follows the handle
    following = """() => { const doc = Bokeh.documents[0];
      const h = doc.get_model_by_name('ml-handles'), j = doc.get_model_by_name('ml-joints');
      const k = h.data.name.indexOf('B'), i = j.data.name.indexOf('B');
      return h.data.x[k] != %r && j.data.x[i] == h.data.x[k] && j.data.y[i] == h.data.y[k]
        && doc.get_model_by_name('ml-frame').value == h.tags[0]; }""" % x0
    page.wait_for_function(following, timeout=60000)
    _shot(page, "web_drag.png", tmp_path_factory)              # during the drag: the links stretch
    layouts = "() => Object.assign({}, window.__mlLayoutBatch)"
    before = page.evaluate(layouts)
    t0 = time.perf_counter()
    page.mouse.up()
    edited = f"""() => {{ const r = ({DEEP_JS})('#ml-positions')[0];
        return r && r.getAttribute('data-mechanism') == 'edited: four_bar' && r.getAttribute('data-positions')
          && ({DEEP_JS})('#ml-check-status[data-ok]').length > 0; }}"""
    page.wait_for_function(edited, timeout=60000)
    print(f"\ndrop to the re-solved drawing: {1000 * (time.perf_counter() - t0):.0f} ms")
    # no tooltip while the dragged design is re-solved; the tooltips are back at the next move
    hovers = """() => Bokeh.documents[0].get_model_by_name('ml-mechanism').toolbar.tools
        .filter(t => t.type == 'HoverTool').map(t => t.active)"""
    assert page.evaluate(hovers) == [False, False]
    page.mouse.move(sx + 30, sy + 10)
    page.wait_for_function(f"() => ({hovers})().every(a => a)", timeout=60000)
    # the new drawing and its check changed several texts, laid out once per message (layout_batch)
    after = page.evaluate(layouts)
    laid, deferred = after["laid"] - before["laid"], after["deferred"] - before["deferred"]
    assert 1 <= laid < deferred, (before, after)
    _, _, x1, y1 = page.evaluate(HANDLE_JS, ["B"])        # the server's handles: the new reference
    assert x1 > x0 and y1 < y0                              # right and down on the screen
    r = _readout(page)
    m = moved(original, "B", (x1, y1))
    st = solve(m, [math.radians(r["input"])])
    names = list(m.joint_names) + [p.name for p in m.points]
    want = np.concatenate([st.positions[0], st.point_positions[0]]) if m.points else st.positions[0]
    np.testing.assert_allclose(np.array([r["positions"][n] for n in names]), want, rtol=0, atol=1e-12)
    assert r["positions"]["B"] == pytest.approx([x1, y1], abs=1e-12)
    page.mouse.click(5, 5)
    page.keyboard.press("Control+z")
    at_b = _at_joint_js("B", 1e-12)
    page.wait_for_function(at_b, arg=list(original.joint("B").at), timeout=60000)


@pytest.mark.parametrize("name, joint, share", [
    ("excavator_bucket", "bucket_link_pin", "drivers thumb_cyl_slide moved on the second core"),
    ("stephenson_3_triad", "P1", "the angles of O1 on the second core")])
def test_drag_is_checked_on_two_cores_as_check_json(page, server, name, joint, share):
    """Drag a joint of a design: the page's check of the edited design is ``check``'s
    document of ``moved(design, joint, new)``, bit for bit, with a share of its work
    done by the server's second process (multiloop.web.second_core: the second
    cylinder of excavator_bucket, the triad six-bar's angles; the server's log names it)."""
    from multiloop.kin.check import check
    from multiloop.web.editing import moved
    _, _, proc = server
    _pick(page, name)
    page.get_by_text("Mechanism", exact=True).first.click()
    page.wait_for_selector(f"#ml-check-json[data-mechanism={name}]", state="attached", timeout=120000)
    original = load_mechanism(name)
    sx, sy, x0, y0 = page.evaluate(HANDLE_JS, [joint])
    before = len(stderr_of(proc))
    _drag(page, "ml-mechanism", [(sx + k, sy + k) for k in range(9)])
    edited = f"""() => {{ const r = ({DEEP_JS})('#ml-positions')[0];
        return r && r.getAttribute('data-mechanism') == 'edited: {name}' && r.getAttribute('data-positions')
          && ({DEEP_JS})('#ml-check-status[data-ok]').length > 0; }}"""
    page.wait_for_function(edited, timeout=120000)
    _, _, x1, y1 = page.evaluate(HANDLE_JS, [joint])
    assert (x1, y1) != (x0, y0)
    shown = json.loads(page.locator("#ml-check-json").text_content())
    assert shown == check(moved(original, joint, (x1, y1))).as_dict()
    log = stderr_of(proc)[before:]
    assert f"job check: {share}" in log, log[-2000:]


@contextlib.contextmanager
def _four_bar_in_mm_and_rad(page):
    """The catalogue four-bar open and checked, the page in mm and rad (the check's events
    shown in rad), and back to m, deg and the Mechanism tab afterwards whatever happens."""
    page.get_by_text("Mechanism", exact=True).first.click()
    _pick(page, "four_bar")
    page.wait_for_selector("#ml-check-json[data-mechanism=four_bar]", state="attached", timeout=120000)
    try:
        page.locator(".ml-length-unit select").select_option("mm")
        page.locator(".ml-angle-unit select").select_option("rad")
        page.wait_for_selector("#ml-check-events[data-unit=rad]", state="attached", timeout=120000)
        yield
    finally:
        page.locator(".ml-length-unit select").select_option("m")
        page.locator(".ml-angle-unit select").select_option("deg")
        page.get_by_text("Mechanism", exact=True).first.click()


def test_units_mm_and_rad_show_and_read_check_json_scaled(page, tmp_path_factory):
    """Switch the page to mm and rad: the check's events shown are ``check --json``'s
    (deg) in rad, the readout's input too, the edit row shows B's coordinates in mm, and
    120, 80 typed in mm put B at (0.12, 0.08) m; back to m and deg afterwards."""
    from multiloop.kin.check import check
    with _four_bar_in_mm_and_rad(page):
        _shot(page, "web_units_mm.png", tmp_path_factory)
        d = check(load_mechanism("four_bar")).as_dict()["drivers"]["O2"]
        want = sorted([*d["limits"], *(x for xs in d["dead_centres"].values() for x in xs),
                       *(a[k] for a in d["angles"].values() for k in ("at_min", "at_max"))])
        shown = sorted(float(v) for v in page.locator("#ml-check-events tr[data-x]").evaluate_all(
            "rows => rows.map(r => r.getAttribute('data-x'))"))
        np.testing.assert_allclose(shown, np.radians(want), rtol=1e-12)
        r = _readout(page)
        assert page.locator("#ml-positions").text_content() == f"O2 = {math.radians(r['input']):.3f} rad"
        axis = page.evaluate("""() => { const f = Bokeh.documents[0].get_model_by_name('ml-mechanism');
            const a = f.below[0]; return [a.axis_label, a.formatter.args.scale]; }""")
        assert axis == ["x (mm)", 1000.0]
        page.locator(".ml-edit-point select").select_option("B")
        b = load_mechanism("four_bar").joint("B").at
        sync_api.expect(page.locator(".ml-edit-x input")).to_have_value(format(1000 * b[0], ".12g"), timeout=120000)
        sync_api.expect(page.locator(".ml-edit-y input")).to_have_value(format(1000 * b[1], ".12g"))
        for css, v in ((".ml-edit-x input", "120"), (".ml-edit-y input", "80")):
            page.locator(css).fill(v)
            page.locator(css).press("Enter")
        page.locator(".ml-edit-apply button").click()
        at_b = _at_joint_js("B", 1e-15)
        page.wait_for_function(at_b, arg=[0.12, 0.08], timeout=120000)


def test_share_an_edited_design_and_a_damaged_code_in_a_fresh_browser_context(page, browser, server,
                                                                             tmp_path_factory):
    """After an edit the address holds ``?design=CODE`` beside the unchanged token; that
    address in a fresh context (no cookie) shows the edited design; a damaged code is the
    one-line message over the default mechanism, and the page keeps working."""
    from urllib.parse import parse_qs, urlsplit
    url = server[0]
    page.get_by_text("Mechanism", exact=True).first.click()
    _pick(page, "four_bar")
    page.wait_for_function("() => location.search.includes('mechanism=four_bar')", timeout=120000)
    page.locator(".ml-edit-point select").select_option("B")
    sync_api.expect(page.locator(".ml-edit-x input")).to_have_value(
        repr(float(load_mechanism("four_bar").joint("B").at[0])), timeout=120000)
    for css, v in ((".ml-edit-x input", "0.12"), (".ml-edit-y input", "0.08")):
        page.locator(css).fill(v)
        page.locator(css).press("Enter")
    page.locator(".ml-edit-apply button").click()
    page.wait_for_function("() => location.search.includes('design=')", timeout=120000)
    shared = page.url
    token = parse_qs(urlsplit(url).query).get("token")
    assert parse_qs(urlsplit(shared).query).get("token") == token        # the token as it was
    assert "mechanism=" not in shared
    ctx = browser.new_context(viewport={"width": 1400, "height": 1000})
    try:
        fresh = ctx.new_page()
        fresh.goto(shared)
        fresh.wait_for_function(f"""() => {{ const r = ({DEEP_JS})('#ml-positions')[0];
            return r && r.getAttribute('data-mechanism') == 'shared: four_bar' && r.getAttribute('data-positions'); }}""",
                                timeout=120000)
        r = _readout(fresh)
        _shot(fresh, "web_share.png", tmp_path_factory)
        m = load_mechanism("four_bar")
        st = solve(_edited_four_bar(), [math.radians(r["input"])])
        np.testing.assert_allclose(r["positions"]["B"], st.positions[0][list(m.joint_names).index("B")], atol=1e-12)
        assert r["positions"]["B"] == pytest.approx([0.12, 0.08], abs=1e-15)
        code = parse_qs(urlsplit(shared).query)["design"][0]
        fresh.goto(shared.replace(code, code[:-20]))
        fresh.wait_for_selector("#ml-message[data-error]", state="attached", timeout=120000)
        text = fresh.locator("#ml-message").text_content()
        assert text.startswith("design (the address's ?design=): expected a design code") and "cut-off" in text
        _wait_frames(fresh)
        _pick(fresh, "crank_slider")                                       # the page goes on
        fresh.wait_for_function("() => location.search.includes('mechanism=crank_slider')", timeout=120000)
        assert parse_qs(urlsplit(fresh.url).query).get("token") == token
    finally:
        ctx.close()


def test_share_the_address_names_the_first_design_once_the_page_is_ready(browser, server):
    """A page opened with its token alone shows the first mechanism, and its address
    names it (``?mechanism=NAME``) once the page is ready: the first design's tags come
    with the page, not as a change (picking that same mechanism again changed nothing, and
    the address stayed without it)."""
    from urllib.parse import parse_qs, urlsplit
    url, _, _ = server
    ctx = browser.new_context(viewport={"width": 1400, "height": 1000})
    try:
        fresh = ctx.new_page()
        fresh.goto(url)
        _wait_frames(fresh)
        name = fresh.locator("#ml-positions").get_attribute("data-mechanism")
        fresh.wait_for_function(f"() => location.search.includes('mechanism={name}')", timeout=120000)
        query = parse_qs(urlsplit(fresh.url).query)
        assert query.get("mechanism") == [name] and query.get("token") == parse_qs(urlsplit(url).query).get("token")
    finally:
        ctx.close()


def _edited_four_bar():
    from multiloop.web.editing import moved
    return moved(load_mechanism("four_bar"), "B", (0.12, 0.08))


def test_atlas_card_opens_in_the_mechanism_view_and_solves(page, tmp_path_factory):
    """Atlas tab: a click on a card chooses its chain; chain #1's first mechanism opens
    with the library's generic dimensions;
    the drawing is the library's solve of the design in the page's address, and the
    same card then becomes the synthesis's start (its traced path in the target figure)."""
    from urllib.parse import parse_qs, urlsplit

    from multiloop.web.share import design_from_code
    page.get_by_text("Atlas", exact=True).click()
    page.wait_for_selector("#ml-atlas-count", state="attached", timeout=120000)
    chain = page.locator(".ml-atlas-chain select")
    for k in (2, 1):                                       # a click on a card chooses its chain
        page.locator(".card[data-search]").nth(k - 1).click()
        sync_api.expect(chain).to_have_value(re.compile(rf"^#{k} "), timeout=120000)
    sync_api.expect(page.locator(".ml-atlas-mechanism select")).to_have_value(re.compile(r"^1\. "), timeout=120000)
    page.locator(".ml-atlas-open button").click()
    page.wait_for_function(f"""() => {{ const r = ({DEEP_JS})('#ml-positions')[0];
        return r && r.getAttribute('data-mechanism').startsWith('atlas: #1 1.') && r.getAttribute('data-positions')
          && location.search.includes('design='); }}""", timeout=120000)
    m = design_from_code(parse_qs(urlsplit(page.url).query)["design"][0])
    r = _readout(page)
    st = solve(m, [math.radians(r["input"])])
    want = np.concatenate([st.positions[0], st.point_positions[0]])
    names = list(m.joint_names) + [p.name for p in m.points]
    np.testing.assert_allclose(np.array([r["positions"][n] for n in names]), want, rtol=0, atol=1e-12)
    _shot(page, "web_atlas_design.png", tmp_path_factory)
    page.get_by_text("Atlas", exact=True).click()
    page.locator(".ml-atlas-start button").click()
    page.wait_for_function(TARGET_READY_JS, timeout=120000)
    sync_api.expect(page.locator(".ml-start select")).to_have_value("(open mechanism)", timeout=120000)
    page.get_by_text("Mechanism", exact=True).first.click()


#: the screen position of target point K and its data position (as HANDLE_JS)
#: the target figure's canvas on the screen (not "the last canvas": the lazily built tabs
#: add theirs after it in whatever order the tests opened them)
TARGET_BOX_JS = """() => { const view = Bokeh.index.find_one(Bokeh.documents[0].get_model_by_name('ml-target'));
  view.el.scrollIntoView({block: 'center'});
  const r = view.canvas_view.el.getBoundingClientRect();
  return {x: r.left, y: r.top, width: r.width, height: r.height}; }"""

TARGET_POINT_JS = """([k]) => { const doc = Bokeh.documents[0];
  const src = doc.get_model_by_name('ml-target-points'), fig = doc.get_model_by_name('ml-target');
  const view = Bokeh.index.find_one(fig);
  if (view == null || src.data.x.length <= k) { return null; }
  view.el.scrollIntoView({block: 'center'});
  const r = view.canvas_view.el.getBoundingClientRect();
  return [r.left + view.frame.x_scale.compute(src.data.x[k]), r.top + view.frame.y_scale.compute(src.data.y[k]),
          src.data.x[k], src.data.y[k], src.data.x.length]; }"""


#: the target figure's canvas box once the page is ready for :func:`_stroke_in`'s stroke
#: starting at angle t0, else null: the figure drawn, the freehand tool active, the box
#: where the previous poll measured it (the layout settled), and the canvas itself on top
#: at the stroke's first point (no other element, tooltip or panel over it)
STROKE_READY_JS = """([t0, rf, ax]) => { const doc = Bokeh.documents[0];
  const view = Bokeh.index.find_one(doc.get_model_by_name('ml-target'));
  const tool = doc.get_model_by_name('ml-freehand');
  if (view == null || !view.has_finished()) { return null; }
  if (!tool.active) { tool.active = true; return null; }
  view.el.scrollIntoView({block: 'center'});
  const r = view.canvas_view.el.getBoundingClientRect();
  const box = {x: r.left, y: r.top, width: r.width, height: r.height};
  const last = window.__mlStrokeBox; window.__mlStrokeBox = box;
  if (last == null || JSON.stringify(last) != JSON.stringify(box)) { return null; }
  const r0 = rf * box.height;
  const x = box.x + 0.5 * box.width + ax * r0 * Math.cos(t0), y = box.y + 0.5 * box.height + r0 * Math.sin(t0);
  let el = document.elementFromPoint(x, y);
  while (el != null && el.shadowRoot != null) {
    const inner = el.shadowRoot.elementFromPoint(x, y);
    if (inner == null || inner === el) { break; }
    el = inner; }
  for (let n = el; n != null; n = n.parentNode || n.host) { if (n === view.canvas_view.el) { return box; } }
  return null; }"""


#: the stroke's ellipse: its half-height (a fraction of the canvas's height) and its width
#: over its height
STROKE_RADIUS, STROKE_ASPECT = 0.18, 1.4


#: the phase of BokehJS's gesture recogniser on the canvas of the figure named ``name``
GESTURE_PHASE_JS = """(name) => Bokeh.index.find_one(Bokeh.documents[0].get_model_by_name(name))
  .canvas_view.ui_event_bus.ui_gestures.phase"""


def _drag(page, figure: str, path, attempts: int = 3, release: bool = True) -> None:
    """Press the mouse at ``path[0]`` on the figure named ``figure``, move it through the
    other points, and release it (``release``; else the caller does).

    BokehJS takes a pointer held still for 300 ms after it went down for a press, not a
    pan (``UIGestures.press_threshold``), and on a loaded machine the first move can
    arrive later than that (CI's failure: a stroke never drawn, the count never grew).
    The recogniser's own phase tells at once whether the gesture became a pan; one that
    did not is let go and made again, at most ``attempts`` times (waits on the page's
    state, not on time)."""
    phases = []
    for _ in range(attempts):
        page.mouse.move(*path[0])
        page.mouse.down()
        for p in path[1:]:
            page.mouse.move(*p)
        phases.append(page.evaluate(GESTURE_PHASE_JS, figure))
        if phases[-1] == "panning":
            break
        page.mouse.up()
    else:
        raise AssertionError(f"{attempts} drags on {figure}, none became a pan: the gesture's phases {phases}")
    if release:
        page.mouse.up()


def _stroke_in(page, t0, t1):
    """A freehand stroke on the synthesis target, an arc of angles ``t0`` to ``t1`` (rad)
    about the figure's centre, drawn once the page is ready for it (:data:`STROKE_READY_JS`:
    waits on the page's state, so a stroke is not drawn on a figure that is still moving),
    by :func:`_drag` (a gesture taken for a press is made again)."""
    page.evaluate("() => { window.__mlStrokeBox = null; }")
    box = page.wait_for_function(STROKE_READY_JS, arg=[t0, STROKE_RADIUS, STROKE_ASPECT],
                                 timeout=120000).json_value()
    cx, cy, r = box["x"] + 0.5 * box["width"], box["y"] + 0.5 * box["height"], STROKE_RADIUS * box["height"]
    _drag(page, "ml-target", [(cx + STROKE_ASPECT * r * math.cos(t), cy + r * math.sin(t))
                              for t in np.linspace(t0, t1, 20)])


def test_target_two_strokes_undo_closed_drag_and_prescribed_timing(page, tmp_path_factory):
    """Draw two strokes, undo one, make the target closed (the library reads it as
    closed), drag a target point with the mouse and undo the drag, then run with a
    prescribed timing: one candidate."""
    from multiloop.catalogue.curves import is_closed
    page.get_by_text("Synthesis", exact=True).click()
    page.locator(".ml-start select").select_option("four_bar", timeout=120000)
    page.wait_for_function(TARGET_READY_JS, timeout=120000)
    # the freehand tool active whatever an earlier test on this page left (tests run in any order)
    page.evaluate("() => { Bokeh.documents[0].get_model_by_name('ml-freehand').active = true; }")
    _clear_target(page)
    n0 = page.evaluate(STROKES_JS)
    _stroke_in(page, 0.0, 2.0)
    page.wait_for_function(f"() => ({STROKES_JS})() == {n0 + 1}", timeout=120000)
    # the server's answer to the first stroke (its target points) before the second: the
    # page's figure settles (its ranges follow the data) before the mouse draws on it
    page.wait_for_function("() => Bokeh.documents[0].get_model_by_name('ml-target-points').data.x.length > 0",
                           timeout=120000)
    _stroke_in(page, 2.2, 4.5)
    page.wait_for_function(f"() => ({STROKES_JS})() == {n0 + 2}", timeout=120000)
    page.locator(".ml-target-undo button").click()
    page.wait_for_function(f"() => ({STROKES_JS})() == {n0 + 1}", timeout=120000)
    points = "() => { const d = Bokeh.documents[0].get_model_by_name('ml-target-points').data; return [d.x, d.y]; }"
    page.locator(".ml-target-shape select").select_option("closed")
    # wait on the page's state: the points the server sends for the closed shape (the
    # undo's open points may arrive after the switch; a wait for "the points changed"
    # took those once, under load)
    page.wait_for_function("""() => { const d = Bokeh.documents[0].get_model_by_name('ml-target-points').data;
        const n = d.x.length; if (n < 3) { return false; }
        let step = 0;
        for (let i = 1; i < n; i++) { step = Math.max(step, Math.hypot(d.x[i] - d.x[i - 1], d.y[i] - d.y[i - 1])); }
        return Math.hypot(d.x[n - 1] - d.x[0], d.y[n - 1] - d.y[0]) <= 1.1 * step; }""", timeout=120000)
    x, y = page.evaluate(points)
    assert len(x) == 24 and is_closed(np.column_stack([x, y]))
    _shot(page, "web_target.png", tmp_path_factory)
    page.evaluate("() => { Bokeh.documents[0].get_model_by_name('ml-target-drag').active = true; }")
    sx, sy, x0, y0, _ = page.evaluate(TARGET_POINT_JS, [5])
    _drag(page, "ml-target", [(sx + 4 * k, sy) for k in range(7)])
    page.wait_for_function(f"() => ({points})()[0][5] > {x0!r}", timeout=120000)
    page.locator(".ml-target-undo button").click()                  # the server undoes the drag
    page.wait_for_function(f"() => ({points})()[0][5] == {x0!r}", timeout=120000)
    page.evaluate("() => { Bokeh.documents[0].get_model_by_name('ml-freehand').active = true; }")
    page.locator(".ml-timing select").select_option("prescribed")
    sync_api.expect(page.locator(".ml-timing-first input")).to_be_visible(timeout=120000)
    for css, v in ((".ml-budget input", "2"), (".ml-seed input", "7")):       # seed 7: this run's row
        page.locator(css).fill(v)
        page.locator(css).press("Enter")
    page.get_by_role("button", name="Run").click()
    page.wait_for_function(f"""() => {{ const rows = ({DEEP_JS})('#ml-candidates tr[data-candidate]');
        const s = ({DEEP_JS})('#ml-synthesis-status')[0];
        return rows.length == 1 && rows[0].children[5].textContent == '7' && s.getAttribute('data-state') == 'done'; }}""",
                           timeout=300000)
    page.locator(".ml-timing select").select_option("free")         # as the other tests expect it
    page.locator(".ml-target-shape select").select_option("open")
    _clear_target(page)
    page.get_by_text("Mechanism", exact=True).first.click()


def test_structure_add_a_dyad_then_remove_the_last_group(page):
    """Add a dyad at four_bar's tracer point P: the drawing is the library's solve of
    ``with_dyad(four_bar, P)``; Remove last group gives four_bar's joints back."""
    from multiloop.web.structure_edits import with_dyad
    page.get_by_text("Mechanism", exact=True).first.click()
    _pick(page, "four_bar")
    page.wait_for_selector("#ml-check-json[data-mechanism=four_bar]", state="attached", timeout=120000)
    page.locator(".ml-dyad-at select").select_option("P")
    page.locator(".ml-add-dyad button").click()
    has = """([name, want]) => { const r = (%s)('#ml-positions')[0];
        return r && r.getAttribute('data-mechanism') == 'edited: four_bar' && r.getAttribute('data-positions')
          && (name in JSON.parse(r.getAttribute('data-positions'))) == want; }""" % DEEP_JS
    page.wait_for_function(has, arg=["dyad1_M", True], timeout=120000)
    m = with_dyad(load_mechanism("four_bar"), "P")
    r = _readout(page)
    st = solve(m, [math.radians(r["input"])])
    names = list(m.joint_names) + [p.name for p in m.points]
    want = np.concatenate([st.positions[0], st.point_positions[0]])
    np.testing.assert_allclose(np.array([r["positions"][n] for n in names]), want, rtol=0, atol=1e-9)
    page.locator(".ml-remove-group button").click()
    page.wait_for_function(has, arg=["dyad1_M", False], timeout=120000)
    assert set(_readout(page)["positions"]) == set(load_mechanism("four_bar").joint_names) | {"P"}


def test_an_edit_that_removes_links_leaves_the_readout_alive(browser, server, requests_seen):
    """Add a dyad, then remove it (the drawing's links 5, then 3): the page throws
    nothing, and a switch to rad afterwards shows the readout in rad (a Div changed in
    the message that resized the drawing's sources once painted half-updated glyphs,
    threw, and the readout never changed again)."""
    page = _page(browser, server[0], requests_seen)           # a page of its own: no earlier test's state
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    try:
        _pick(page, "four_bar")
        page.wait_for_selector("#ml-check-json[data-mechanism=four_bar]", state="attached", timeout=120000)
        has = """([name, want]) => { const r = (%s)('#ml-positions')[0];
            return r && r.getAttribute('data-mechanism') == 'edited: four_bar' && r.getAttribute('data-positions')
              && (name in JSON.parse(r.getAttribute('data-positions'))) == want; }""" % DEEP_JS
        page.locator(".ml-dyad-at select").select_option("P")
        page.locator(".ml-add-dyad button").click()
        page.wait_for_function(has, arg=["dyad1_M", True], timeout=120000)
        page.locator(".ml-remove-group button").click()
        page.wait_for_function(has, arg=["dyad1_M", False], timeout=120000)
        sync_api.expect(page.locator("#ml-positions")).to_have_text(re.compile(r"^O2 = -?\d+\.\d{3} deg$"))
        page.locator(".ml-angle-unit select").select_option("rad")
        sync_api.expect(page.locator("#ml-positions")).to_have_text(re.compile(r"^O2 = -?\d+\.\d{3} rad$"),
                                                                    timeout=120000)
        assert errors == []
    finally:
        page.close()


def test_units_mm_show_a_slider_drivers_check_json_in_mm(page):
    """A cylinder-driven crane in mm: every event of its first driver shown equals
    ``check --json``'s (m) times 1000, and the readout's input is in mm."""
    from multiloop.kin.check import check
    page.get_by_text("Mechanism", exact=True).first.click()
    _pick(page, "knuckle_boom_crane", timeout=300000)
    page.wait_for_selector("#ml-check-json[data-mechanism=knuckle_boom_crane]", state="attached", timeout=300000)
    try:
        page.locator(".ml-length-unit select").select_option("mm")
        page.wait_for_selector("#ml-check-events[data-unit=mm]", state="attached", timeout=120000)
        m = load_mechanism("knuckle_boom_crane")
        d = check(m).as_dict()["drivers"][m.drivers[0].joint]
        want = sorted([*d["limits"], *(b["at"] for b in d["branch_points"]),
                       *(x for xs in d["dead_centres"].values() for x in xs),
                       *(a[k] for a in d["angles"].values() if a.get("min") is not None for k in ("at_min", "at_max"))])
        shown = sorted(float(v) for v in page.locator("#ml-check-events tr[data-x]").evaluate_all(
            "rows => rows.map(r => r.getAttribute('data-x'))"))
        np.testing.assert_allclose(shown, 1000 * np.array(want), rtol=1e-12)
        r = _readout(page)
        assert page.locator("#ml-positions").text_content() == f"{m.drivers[0].joint} = {1000 * r['input']:.3f} mm"
    finally:
        page.locator(".ml-length-unit select").select_option("m")


def test_units_mm_and_rad_reach_the_verdict_and_the_synthesis_tab(page):
    """In mm and rad: the check's verdict lines are the library's (``check --json``'s)
    with every angle in rad, the words the same; in the Synthesis tab the length bounds
    are titled in mm, the timing's inputs in rad, and a run's candidate errors shown in
    mm are those shown in m times 1000."""
    from multiloop.kin.check import check
    with _four_bar_in_mm_and_rad(page):
        lines = page.locator("#ml-check-status + ul li").all_text_contents()
        si = check(load_mechanism("four_bar")).verdict
        assert len(lines) == len(si) >= 1
        for mine, want in zip(lines, si):
            assert re.sub(QUANTITY, "#", mine) == re.sub(QUANTITY, "#", want)
            got, lib = ([(float(v), u) for v, u in re.findall(QUANTITY, t)] for t in (mine, want))
            assert [u for _, u in got] == [" rad"] * len(lib) and {u for _, u in lib} == {"°"}
            np.testing.assert_allclose([v for v, _ in got], [math.radians(v) for v, _ in lib], atol=5e-4)
        page.get_by_text("Synthesis", exact=True).click()
        page.locator(".ml-start select").select_option("four_bar", timeout=120000)
        page.wait_for_function(TARGET_READY_JS, timeout=120000)
        sync_api.expect(page.get_by_text("length ≥ (mm)")).to_be_attached(timeout=120000)
        sync_api.expect(page.get_by_text("min transmission (rad)")).to_be_attached()
        page.locator(".ml-timing select").select_option("prescribed")
        sync_api.expect(page.get_by_text("last input (rad)")).to_be_attached(timeout=120000)
        page.locator(".ml-timing select").select_option("free")
        # (the page's layout settles first: the prescribed timing's fields leave, so the
        # target's box is measured where the stroke will be drawn, whatever the load)
        sync_api.expect(page.get_by_text("last input (rad)")).to_be_hidden(timeout=120000)
        page.locator(".ml-budget input").fill("2")
        page.locator(".ml-budget input").press("Enter")
        page.evaluate("() => { Bokeh.documents[0].get_model_by_name('ml-freehand').active = true; }")
        _clear_target(page)
        n0 = page.evaluate(STROKES_JS)
        _stroke_in(page, 0.0, 5.0)
        page.wait_for_function(f"() => ({STROKES_JS})() == {n0 + 1}", timeout=120000)
        page.get_by_role("button", name="Run").click()
        # this run's: an earlier test's run left its status done and its candidates listed
        page.wait_for_selector("#ml-synthesis-status[data-state=running]", state="attached", timeout=120000)
        page.wait_for_selector("#ml-synthesis-status[data-state=done]", state="attached", timeout=300000)
        row = "#ml-candidates[data-unit={u}] tr[data-candidate]"
        mm = [float(page.locator(row.format(u="mm")).first.get_attribute(a)) for a in ("data-error-max", "data-error-rms")]
        page.locator(".ml-length-unit select").select_option("m")
        page.wait_for_selector(row.format(u="m"), state="attached", timeout=120000)
        m = [float(page.locator(row.format(u="m")).first.get_attribute(a)) for a in ("data-error-max", "data-error-rms")]
        np.testing.assert_allclose(mm, 1000 * np.array(m), rtol=1e-12)
        assert m[1] > 0


def test_units_mm_read_an_uploaded_target_csv_as_the_si_file(browser, server, requests_seen, tmp_path):
    """In mm the target upload's button says the table is read in mm; a table of
    the SI file's numbers times 1000 is then the same target: the points the page holds
    (in m) are the SI file's, and the status line says mm.  The Structure tab has no
    length to convert: its text is the same in m and in mm."""
    from multiloop.catalogue.dimensional.targets import parse_table
    si = np.array([[0.05 + 0.002 * i, 0.07 + 0.001 * (i % 5)] for i in range(20)])
    mm = tmp_path / "target_mm.csv"
    mm.write_text("x,y\n" + "\n".join(f"{1000 * x!r},{1000 * y!r}" for x, y in si.tolist()) + "\n")
    want = parse_table("x,y\n" + "\n".join(f"{x!r},{y!r}" for x, y in si.tolist()), (2, 3), "path", "si")
    structure = "() => (%s)('#ml-structure')[0].textContent" % DEEP_JS
    page = _page(browser, server[0], requests_seen)           # a page of its own: no earlier test's state
    _pick(page, "four_bar")
    page.get_by_text("Structure", exact=True).click()
    page.wait_for_function(structure, timeout=120000)
    before = page.evaluate(structure)
    try:
        page.locator(".ml-length-unit select").select_option("mm")
        page.get_by_text("Synthesis", exact=True).click()
        page.locator(".ml-start select").select_option("four_bar", timeout=120000)
        sync_api.expect(page.locator(".ml-csv button")).to_have_text("target CSV in mm, deg…", timeout=120000)
        page.get_by_text("Structure", exact=True).click()
        assert page.evaluate(structure) == before
        page.get_by_text("Synthesis", exact=True).click()
        upload(page, "ml-csv", mm)
        sync_api.expect(page.locator("#ml-synthesis-status")).to_contain_text("20 rows (read in mm)",
                                                                             timeout=120000)
        got = page.evaluate("""() => { const d = Bokeh.documents[0].get_model_by_name('ml-target-upload').data;
            return [Array.from(d.x), Array.from(d.y)]; }""")
        np.testing.assert_allclose(np.array(got).T, want, rtol=1e-12)
    finally:
        page.close()


def _address_text(page) -> str:
    """The mechanism file in the page's address (``?design=CODE``: zlib + base64url)."""
    import base64
    import zlib
    from urllib.parse import parse_qs, urlsplit
    code = parse_qs(urlsplit(page.url).query)["design"][0]
    return zlib.decompress(base64.urlsafe_b64decode(code + "=" * (-len(code) % 4))).decode("utf-8")


def test_edit_length_typed_in_mm_solves_as_the_library_and_undo_gives_the_file_back(page, tmp_path_factory):
    """Type the coupler's length in mm: B moves along A→B, the page's drawing is the
    library's solve of ``with_length(four_bar, coupler, 0.15)``; a length of 0 is the
    one-line message naming the link; Ctrl-Z gives the original design, its file in the
    address byte for byte that of four_bar."""
    from multiloop.topo.io import dumps_toml
    from multiloop.web.lengths import with_length
    page.get_by_text("Mechanism", exact=True).first.click()
    _pick(page, "four_bar")
    original = load_mechanism("four_bar")
    try:
        page.locator(".ml-length-unit select").select_option("mm")
        sync_api.expect(page.locator(".ml-edit-length input")).to_have_value(re.compile(r"^\d"), timeout=120000)
        page.locator(".ml-edit-link select").select_option("coupler")
        a, b = (np.array(original.joint(n).at) for n in ("A", "B"))
        sync_api.expect(page.locator(".ml-edit-length input")).to_have_value(
            format(1000 * math.dist(a, b), ".12g"), timeout=120000)
        for text in ("0", "150"):
            page.locator(".ml-edit-length input").fill(text)
            page.locator(".ml-edit-length input").press("Enter")
            page.locator(".ml-edit-length-apply button").click()
            if text == "0":
                page.wait_for_selector("#ml-message[data-error]", state="attached", timeout=120000)
                assert page.locator("#ml-message").text_content().strip() == (
                    "length of link 'coupler': expected a finite length > 0, got 0 mm")
        m = with_length(original, "coupler", 0.150)
        want_b = list(m.joint("B").at)
        at_b = """([x, y]) => { const r = (%s)('#ml-positions')[0];
            if (!r || !r.getAttribute('data-positions') || r.getAttribute('data-mechanism') != 'edited: four_bar') return false;
            const b = JSON.parse(r.getAttribute('data-positions'))['B'];
            return Math.abs(b[0] - x) < 1e-12 && Math.abs(b[1] - y) < 1e-12; }""" % DEEP_JS
        page.wait_for_function(at_b, arg=want_b, timeout=120000)
        page.wait_for_function("() => location.search.includes('design=')", timeout=120000)
        assert _address_text(page) == dumps_toml(m)
        r = _readout(page)
        st = solve(m, [math.radians(r["input"])])
        names = list(m.joint_names) + [p.name for p in m.points]
        want = np.concatenate([st.positions[0], st.point_positions[0]])
        np.testing.assert_allclose(np.array([r["positions"][n] for n in names]), want, rtol=0, atol=1e-12)
        _shot(page, "web_edit_length.png", tmp_path_factory)
        edited_url = page.url
        page.mouse.click(5, 5)                      # the focus leaves the text field
        page.keyboard.press("Control+z")
        page.wait_for_function(at_b, arg=list(original.joint("B").at), timeout=120000)
        page.wait_for_function("([u]) => location.href != u", arg=[edited_url], timeout=120000)
        assert _address_text(page) == dumps_toml(original)
    finally:
        page.locator(".ml-length-unit select").select_option("m")
