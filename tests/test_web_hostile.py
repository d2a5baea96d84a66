"""``multiloop serve`` opened as someone who was sent a hostile file, in headless
chromium (tests/test_web.py's way): names that are markup stay text, forged menu values
open no file, a closed tab stops its work, a huge upload never reaches the socket.

The hostile mechanism (:func:`hostile_document`) puts a script, an ``<img onerror>``, an
``<svg onload>``, a ``'``-quoted handler, a very long, a right-to-left and an emoji name
in every field of a mechanism file.  Each script, if it ran, would open a dialog, change
the page's title and count itself in ``window.__mlPwned``."""
from __future__ import annotations

import json
import os
import time

import pytest

from multiloop.web.menus import QUOTED
from tests.test_web import CHROMIUM, DEEP_JS, FORGE_JS, _pick, _wait_frames, sync_api, upload
from tests.test_web import browser  # noqa: F401 - the fixture, one chromium per module
from tests.common import six_bar_chain_atlas, start_serve, stderr_of, stop

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(CHROMIUM is None and not os.environ.get("CI"),
                                 reason="chromium not installed (install.sh installs it)")]

SCRIPT = "document.title='pwned';window.__mlPwned=(window.__mlPwned||0)+1;alert(1)"

#: one name of each kind
HOSTILE = {
    "img": f'<img src=x onerror="{SCRIPT}">',
    "script": f"<script>{SCRIPT}</script>",
    "svg": f'"><svg onload="{SCRIPT}">',
    "quote": f"' onmouseover='{SCRIPT}' x='",
    "long": "L" * 3000,
    "rtl": "\u202eevil\u202c name \u05e9\u05dc\u05d5\u05dd",
    "emoji": "crank 🦾⚙️👩‍🔧",
}


def hostile_document() -> dict:
    """A four-bar (the catalogue's dimensions) whose every name and text is hostile."""
    h = HOSTILE
    frame, crank, coupler, rocker = h["script"], h["svg"], h["quote"], h["emoji"]
    return {
        "name": h["img"], "description": h["script"], "source": h["svg"], "notes": h["quote"],
        "link": [{"name": frame, "frame": True}, {"name": crank}, {"name": coupler}, {"name": rocker}],
        "joint": [{"name": h["img"], "kind": "R", "links": [frame, crank], "at": [0.0, 0.0]},
                  {"name": h["quote"], "kind": "R", "links": [crank, coupler], "at": [0.02, 0.034641]},
                  {"name": h["long"], "kind": "R", "links": [coupler, rocker], "at": [0.133881, 0.072471]},
                  {"name": h["rtl"], "kind": "R", "links": [rocker, frame], "at": [0.1, 0.0]}],
        "driver": [{"joint": h["img"]}],
        "point": [{"name": h["svg"] + " P", "link": coupler, "at": [0.061178, 0.101007]}],
        "force": [{"name": h["emoji"] + " F", "link": rocker, "at": [0.1, 0.05], "value": [0.0, -10.0]}],
    }


#: what a script that ran would have left, and every element that a name could have made
TRACES_JS = """() => { const deep = %s;
  const handlers = deep('*').flatMap(e => [...e.attributes].filter(a => a.name.startsWith('on'))
    .map(a => e.tagName + ' ' + a.name));
  const made = deep('img, svg[onload], script').filter(e => e.tagName != 'SCRIPT' || e.textContent.includes('pwned'))
    .map(e => e.outerHTML.slice(0, 60));
  return {title: document.title, pwned: window.__mlPwned || 0, handlers: handlers, made: made}; }""" % DEEP_JS

#: the joints of the drawing on the screen: [name, x, y] (page pixels)
JOINTS_JS = """() => { const doc = Bokeh.documents[0];
  const view = Bokeh.index.find_one(doc.get_model_by_name('ml-mechanism'));
  const src = doc.get_model_by_name('ml-joints'), box = view.canvas_view.el.getBoundingClientRect();
  return src.data.name.map((n, i) => [n, box.left + view.frame.x_scale.compute(src.data.x[i]),
                                      box.top + view.frame.y_scale.compute(src.data.y[i])]); }"""

#: the text of every tooltip shown
TOOLTIPS_JS = "() => (%s)('[class*=ooltip]').map(e => e.textContent).join(' ')" % DEEP_JS


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """The hostile file, an atlas, and a design nobody gave the page (secret.toml)."""
    from multiloop.inputs import resolve
    folder = tmp_path_factory.mktemp("hostile")
    hostile = folder / "hostile.json"
    hostile.write_text(json.dumps(hostile_document(), ensure_ascii=False), encoding="utf-8")
    secret = folder / "secret.toml"
    secret.write_text(resolve("four_bar").read_text().replace('name = "four_bar"', 'name = "SECRET-design"'))
    return hostile, six_bar_chain_atlas(folder / "atlas.sqlite"), secret


@pytest.fixture(scope="module")
def served(files):
    hostile, atlas, _ = files
    os.chdir(hostile.parent)                # 'secret.toml' names a file in the server's folder
    try:
        url, proc = start_serve(str(hostile), "--atlas", str(atlas))
    finally:
        os.chdir(os.path.dirname(os.path.dirname(__file__)))
    yield url, proc
    stop(proc)


def _open(browser, url):
    """A new tab on ``url``; its dialogs recorded (and dismissed) in ``page.dialogs``, the
    sizes of the websocket messages it sends in ``page.sent``, its websockets closed in
    ``page.closed``."""
    page = browser.new_page(viewport={"width": 1400, "height": 1000})
    page.dialogs, page.sent, page.closed = [], [], []
    page.on("dialog", lambda d: (page.dialogs.append(d.message), d.dismiss()))
    page.on("websocket", lambda ws: (ws.on("framesent", lambda f: page.sent.append(len(f))),
                                     ws.on("close", lambda _: page.closed.append(ws.url))))
    page.goto(url)
    _wait_frames(page)
    return page


def _assert_clean(page) -> None:
    assert page.dialogs == []
    assert page.evaluate(TRACES_JS) == {"title": "multiloop", "pwned": 0, "handlers": [], "made": []}


def _hover_every_joint(page) -> None:
    """The mouse over each joint: its tooltip names it, as text."""
    for name, x, y in page.evaluate(JOINTS_JS):
        page.mouse.move(x, y)
        page.wait_for_function(f"() => ({TOOLTIPS_JS})().includes({json.dumps('joint: ' + name)})", timeout=120000)
    page.mouse.move(5, 5)


def _names_are_text(page) -> None:
    """The driver's name in the readout, every name in the check's JSON, the links in the
    structure tab: as the file has them."""
    # the check of this mechanism, not the one shown before it (the page's state, not a delay)
    page.wait_for_function(f"""(name) => {{ const e = ({DEEP_JS})('#ml-check-json')[0];
        try {{ return e && JSON.parse(e.textContent).mechanism === name; }} catch (err) {{ return false; }} }}""",
                           arg=HOSTILE["img"], timeout=120000)
    doc = json.loads(page.locator("#ml-check-json").text_content())
    assert doc["mechanism"] == HOSTILE["img"] and list(doc["drivers"]) == [HOSTILE["img"]]
    assert page.locator("#ml-positions").text_content().startswith(HOSTILE["img"] + " = ")
    assert set(json.loads(page.locator("#ml-positions").get_attribute("data-positions"))) == {
        HOSTILE["img"], HOSTILE["quote"], HOSTILE["long"], HOSTILE["rtl"], HOSTILE["svg"] + " P"}
    page.get_by_text("Structure", exact=True).click()
    groups = page.locator("#ml-groups").text_content()
    assert all(HOSTILE[k] in groups for k in ("quote", "emoji", "long", "rtl"))
    page.get_by_text("Mechanism", exact=True).first.click()


def test_hostile_names_of_a_served_file_stay_text(browser, served):
    """Before: the driver's name went into the page as markup (the <img> ran at once) and
    a ``'`` ended the readout's JSON attribute (an onmouseover handler)."""
    page = _open(browser, served[0])
    try:
        _names_are_text(page)
        _assert_clean(page)
        _hover_every_joint(page)
        _assert_clean(page)
    finally:
        page.close()


def test_hostile_names_of_an_uploaded_file_stay_text(browser, served, files, tmp_path):
    """The same file uploaded under a hostile name, after a bad file of that name; its
    check's angles computed by the server's second process (multiloop.web.second_core:
    the hostile design pickled to it by the server, its names text there too)."""
    page = _open(browser, served[0])
    try:
        for _ in range(1200):               # (a hang guard: the child's start and warm-up)
            if "second core: ready" in stderr_of(served[1]):
                break
            time.sleep(0.1)
        _pick(page, "four_bar")
        # its check done (the second core free again before the upload's)
        page.wait_for_selector("#ml-check-json[data-mechanism=four_bar]", state="attached", timeout=120000)
        bad = tmp_path / f"{HOSTILE['img']}.toml"
        bad.write_text("x = [")
        upload(page, "ml-open", bad)
        sync_api.expect(page.locator("#ml-message")).to_contain_text(f"{bad.name}: TOML syntax error", timeout=120000)
        mine = tmp_path / f"{HOSTILE['svg']}.json"
        mine.write_bytes(files[0].read_bytes())
        before = len(stderr_of(served[1]))
        upload(page, "ml-open", mine)
        sync_api.expect(page.locator(".ml-pick select")).to_have_value(f"upload: {mine.name}", timeout=120000)
        _names_are_text(page)
        assert f"job check: the angles of {HOSTILE['img']} on the second core" in stderr_of(served[1])[before:]
        _hover_every_joint(page)
        _assert_clean(page)
    finally:
        page.close()


#: every menu of the page: its title, and its name in a message
MENUS = {"mechanism": "mechanism menu", "driver": "driver menu", "start mechanism": "start menu",
         "tracer point (--point)": "tracer point menu", "method": "method menu", "atlas (--db)": "atlas menu",
         "candidate": "candidate menu", "atlas": "atlas menu", "n, F": "n, F menu"}

#: the value of the menu titled ``title``, in the browser
VALUE_JS = "(title) => [...Bokeh.documents[0].all_models].find(m => m.title === title && 'value' in m).value"


def test_forged_menu_values_open_no_file(browser, served, files):
    """Each menu set, as a script in the page could, to the path of a design nobody gave
    the page: before, the mechanism menu, the start menu and the atlas box opened it.
    Now: the one-line message, the menu back at its choice, the design nowhere, and
    the page goes on."""
    _, _, secret = files
    page = _open(browser, served[0])
    try:
        _pick(page, "four_bar")
        for tab in ("Synthesis", "Atlas", "Mechanism"):
            page.get_by_text(tab, exact=True).first.click()
            page.wait_for_timeout(300)
        page.get_by_text("Synthesis", exact=True).click()
        page.locator(".ml-start select").select_option("four_bar")
        page.get_by_text("Mechanism", exact=True).first.click()
        for title, what in MENUS.items():
            for forged in (str(secret), "secret.toml", "../" * 12 + "etc/passwd"):
                before = page.evaluate(VALUE_JS, title)
                page.evaluate(FORGE_JS, [title, "value", forged])
                shown = forged if len(forged) <= QUOTED else forged[:QUOTED] + "…"
                sync_api.expect(page.locator("#ml-message")).to_contain_text(
                    f"{what}: expected one of its entries, got {shown!r}", timeout=120000)
                page.wait_for_function(f"() => ({VALUE_JS})({json.dumps(title)}) === {json.dumps(before)}",
                                       timeout=120000)
        text = page.evaluate(f"() => ({DEEP_JS})('*').map(e => e.textContent).join(' ')")
        assert "SECRET-design" not in text and "root:" not in text
        _pick(page, "crank_slider")                                          # the page goes on
        sync_api.expect(page.locator("#ml-message")).not_to_have_attribute("data-error", "1")
        _assert_clean(page)
    finally:
        page.close()


def _cpu_seconds(pid: int) -> float:
    """User + system CPU time of process ``pid`` (its threads; not its children)."""
    fields = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _cpu_rates(pid: int, n: int, dt: float = 0.25) -> list[float]:
    """``n`` readings of the share of a core ``pid`` used over the last 0.5 s, one every ``dt`` s."""
    t = [_cpu_seconds(pid)]
    out = []
    for _ in range(n):
        time.sleep(dt)
        t.append(_cpu_seconds(pid))
        if len(t) >= 3:
            out.append((t[-1] - t[-3]) / (2 * dt))
    return out


def _wait_for_line(proc, text: str, net: float) -> str:
    """The first line of the server's stderr that contains ``text`` (read until it comes)."""
    end = time.monotonic() + net
    while time.monotonic() < end:
        hit = [ln for ln in stderr_of(proc).splitlines() if text in ln]
        if hit:
            return hit[0]
        time.sleep(0.1)
    raise AssertionError(f"the server never logged {text!r}: {stderr_of(proc)[-2000:]}")


def test_a_tab_closed_during_a_synthesis_stops_it(browser, tmp_path):
    """Before: the session's clean-up raised under Bokeh 3.9 and came 15 s late: a
    synthesis went on for a minute after its tab closed.  Now the job's thread ends (the
    server logs "job synthesis: cancelled after … s") and the server stays idle (the share
    of a core over the last 0.5 s under 0.2); the test waits on the log, not on a time."""
    url, proc = start_serve()
    csv = tmp_path / "target.csv"
    csv.write_text("x,y\n" + "\n".join(f"{0.05 + 0.03 * i / 20:.5f},{0.07 + 0.02 * (i % 5) / 5:.5f}"
                                       for i in range(20)) + "\n")
    page = _open(browser, url)
    try:
        page.get_by_text("Synthesis", exact=True).click()
        page.locator(".ml-start select").select_option("four_bar")
        upload(page, "ml-csv", csv)
        sync_api.expect(page.locator("#ml-synthesis-status")).to_contain_text("20 rows", timeout=120000)
        page.locator(".ml-budget input").fill("120")
        page.locator(".ml-budget input").press("Enter")
        page.get_by_role("button", name="Run").click()
        page.wait_for_selector("#ml-synthesis-status[data-state=running]", state="attached", timeout=120000)
        busy = _cpu_rates(proc.pid, 4)                      # printed: a loaded machine gives it less
        page.close()
        # the job's thread ends once the close is noticed: the server's log says so (a net of
        # 10 min for a loaded machine; on an idle one it comes within a second)
        log = _wait_for_line(proc, "job synthesis: cancelled after", 600)
        after = _cpu_rates(proc.pid, 4)
        assert max(after) < 0.2, (busy, after, log)           # and the server stays idle
        print(f"\nserver CPU, a core's share: running {busy}, after the close {after}; log: {log}")
    finally:
        if not page.is_closed():
            page.close()
        stop(proc)


def test_a_50_mb_upload_is_refused_in_the_page_and_nothing_is_lost(browser, served, tmp_path):
    """Before: the file went to the socket, past Bokeh's 20 MB cap: the socket closed,
    the page reconnected to a new session and the results were gone without a word."""
    from multiloop.inputs import MAX_UPLOAD
    page = _open(browser, served[0])
    try:
        _pick(page, "four_bar")
        page.wait_for_selector("#ml-check-json[data-mechanism=four_bar]", state="attached", timeout=60000)
        page.evaluate("() => { window.__mlMark = Bokeh.documents[0]; }")
        shown = page.locator("#ml-check-json").text_content()
        for css, name in (("ml-open", "big.toml"), ("ml-csv", "big.csv")):
            big = tmp_path / name
            with open(big, "wb") as f:
                f.truncate(50 << 20)                            # 50 MiB (sparse)
            if css == "ml-csv":
                page.get_by_text("Synthesis", exact=True).click()
            upload(page, css, big)
            sync_api.expect(page.locator("#ml-message")).to_contain_text(
                f"file '{name}': expected at most {MAX_UPLOAD >> 20} MiB, got {50 << 20} bytes", timeout=120000)
        page.get_by_text("Mechanism", exact=True).first.click()
        assert page.evaluate("() => window.__mlMark === Bokeh.documents[0]") and page.closed == []
        assert page.locator("#ml-check-json").text_content() == shown
        assert page.sent and max(page.sent) < MAX_UPLOAD // 8, max(page.sent)     # nothing of the file sent
        _pick(page, "crank_slider")
    finally:
        page.close()
