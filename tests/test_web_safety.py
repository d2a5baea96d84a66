"""``multiloop serve``'s safety without a browser: HTML built by one escaping function,
menus that name choices (never files), the token and host checks of the server, the
command's options and messages.  The same holes seen from headless chromium:
tests/test_web_hostile.py."""
from __future__ import annotations

import ast
import os
import re
import time
from pathlib import Path

import pytest

if os.environ.get("CI"):
    import bokeh  # noqa: F401
else:
    pytest.importorskip("bokeh")

import multiloop.web  # noqa: E402

WEB = Path(multiloop.web.__file__).parent

#: text that opens or closes an HTML tag, or an entity
TAG = re.compile(r"<\s*/?\s*[A-Za-z!]|&[a-z]+;")

#: the names of tests/data/hostile.toml, each a way out of text into markup
HOSTILE = ["<img src=x onerror=alert(1)>", "<script>alert(2)</script>", '"><svg onload=alert(3)>',
           "' onmouseover='alert(4)", "x" * 5000, "\u202eevil\u202c", "🦾⚙️"]


def _is_markup(node) -> bool:
    return isinstance(node, ast.Constant) and isinstance(node.value, str) and bool(TAG.search(node.value))


def _html_built_by_hand(tree: ast.AST) -> list[int]:
    """Lines where a string with a tag gets values other than through markup.html:
    an f-string, ``%``, ``+`` or ``.format`` on a literal with a tag."""
    lines = []
    for node in ast.walk(tree):
        if isinstance(node, ast.JoinedStr) and any(isinstance(v, ast.FormattedValue) for v in node.values) \
                and any(_is_markup(v) for v in node.values):
            lines.append(node.lineno)
        elif isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Mod, ast.Add)) \
                and (_is_markup(node.left) or _is_markup(node.right)):
            lines.append(node.lineno)
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "format" \
                and _is_markup(node.func.value):
            lines.append(node.lineno)
    return lines


def test_the_walker_finds_html_built_by_hand():
    """The check itself: each way of building HTML by hand is found, markup.html is not."""
    bad = ['f"<b>{x}</b>"', '"<b>%s</b>" % x', '"<b>" + x', '"<b>{}</b>".format(x)', "f'<p id=\"a\">{x:.3f}'"]
    for src in bad:
        assert _html_built_by_hand(ast.parse(src)), src
    good = ['html("<b>{x}</b>", x=x)', 'f"{a} of {b}"', '"<b>x</b>"', 'f"<b>x</b>"', 'REDRAW = "a < b"']
    for src in good:
        assert not _html_built_by_hand(ast.parse(src)), src


def test_every_html_fragment_of_the_page_is_built_by_one_function():
    """No module of multiloop/web puts a value into HTML except through markup.html (and
    markup.join); only the atlas view wraps text as HTML itself: the gallery's cards of
    catalogue.html, which escapes what it shows."""
    found, wrapped = {}, set()
    for path in sorted(WEB.glob("*.py")):
        if path.name == "markup.py":
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        lines = _html_built_by_hand(tree)
        if lines:
            found[path.name] = lines
        if any(isinstance(n, ast.Call) and getattr(n.func, "id", None) == "Html" for n in ast.walk(tree)):
            wrapped.add(path.name)
    assert found == {}, f"HTML built without markup.html: {found}"
    assert wrapped == {"atlas_view.py"}


@pytest.mark.parametrize("name", HOSTILE)
def test_html_keeps_every_value_text(name):
    from multiloop.web.markup import html, join
    frag = html('<p title="{t}" data-x=\'{t}\'>{t}</p>{more}', t=name, more=join([name]))
    for ch in "<>\"'":
        assert frag.count(ch) == '<p title="" data-x=\'\'></p>'.count(ch)


@pytest.mark.parametrize("name", HOSTILE)
def test_the_readout_keeps_a_hostile_name_text(name):
    """The readout escaped the driver joint's name not at all and the JSON attribute
    with quote=False: ``'`` ended the attribute."""
    from html.parser import HTMLParser

    import numpy as np

    from multiloop.web.mechanism_view import readout_html
    from multiloop.web.scene import Sweep
    sw = Sweep(0, name, True, True, np.array([0.0, 1.0]), np.zeros((2, 2, 2)), np.ones(2, bool),
               np.zeros((2, 0)), ())
    seen = []

    class Parser(HTMLParser):
        def handle_starttag(self, tag, attrs):
            seen.append((tag, dict(attrs)))

        def handle_data(self, data):
            seen.append(("text", data))

    Parser().feed(readout_html(sw, 1, [name, "B"], name))
    (tag, attrs), (_, text) = seen
    assert tag == "span" and set(attrs) == {"id", "data-mechanism", "data-index", "data-input", "data-positions"}
    assert attrs["data-mechanism"] == name and text == f"{name} = 1.000 deg"
    import json
    assert list(json.loads(attrs["data-positions"])) == [name, "B"]


# ---------------------------------------------------------------------- menus
_OPENED: list[tuple[str, list]] = []


def _audit(event, args):
    if event == "open" and _OPENED and isinstance(args[0], (str, bytes, os.PathLike)):
        path = os.fsdecode(args[0])
        for root, seen in _OPENED:
            if path.startswith(root):
                seen.append(path)


@pytest.fixture
def secret(tmp_path, monkeypatch):
    """A design the page was not given (tmp_path/secret.toml, named SECRET), the working
    directory beside it; yields (its path, the files under tmp_path the process opens)."""
    import sys

    from multiloop.inputs import resolve
    if not getattr(sys, "_multiloop_audit", False):
        sys.addaudithook(_audit)
        sys._multiloop_audit = True
    path = tmp_path / "secret.toml"
    path.write_text(resolve("four_bar").read_text().replace('name = "four_bar"', 'name = "SECRET"'))
    monkeypatch.chdir(tmp_path)
    seen: list = []
    _OPENED.append((str(tmp_path), seen))
    yield path, seen
    _OPENED.clear()


def _widgets(wb, atlas):
    """Every menu of a workbench served with the atlas ``atlas``, by name: (Select, its choices)."""
    wb.tabs.active = 2
    wb.tabs.active = 3
    sv, av = wb.synthesis, wb.atlas
    sv.w["start"].value = "four_bar"
    menus = {"mechanism": wb.menu, "driver": wb.view.drivers, "atlas view": av.files, "n, F": av.pairs}
    menus.update({f"synthesis {k}": m for k, m in sv.menus.items()})
    return menus


@pytest.fixture(scope="module")
def small_atlas(tmp_path_factory):
    from tests.common import six_bar_chain_atlas
    return six_bar_chain_atlas(tmp_path_factory.mktemp("atlas") / "a.sqlite")


def test_every_menu_refuses_a_value_it_was_not_given_and_opens_nothing(secret, small_atlas):
    """Bokeh does not check a menu's value against its options: a script in the page set
    the mechanism menu, the start menu or the atlas box to a path and the server opened
    it.  Each menu now holds the server's list; a forged value is one line, the menu
    goes back, no file outside the list is opened and the page goes on."""
    import html

    from multiloop import inputs
    from multiloop.web.app import Workbench
    path, opened = secret
    asked = []
    resolve = inputs.resolve
    inputs.resolve = lambda arg, *a: asked.append(str(arg)) or resolve(arg, *a)
    try:
        wb = Workbench({}, [str(small_atlas)], 40.0)
        menus = _widgets(wb, small_atlas)
        for label, menu in menus.items():
            before = (menu.select.value, menu.value, wb.mechanism, wb.mechanism_name)
            for forged in (str(path), "secret.toml", "secret", "../" * 8 + "etc/passwd", "four_bar/../secret"):
                menu.select.value = forged
                message = html.unescape(wb.message.text)
                assert f"{menu.what}: expected one of its entries, got " in message and "\n" not in message, label
                assert (menu.select.value, menu.value, wb.mechanism, wb.mechanism_name) == before, label
                wb.clear()
        assert opened == [] and not [a for a in asked if "secret" in a or "passwd" in a], (opened, asked)
        assert "SECRET" not in wb.structure.text and wb.mechanism.name != "SECRET"
        wb.pick.value = "crank_slider"                              # the page goes on
        assert wb.mechanism_name == "crank_slider" and wb.message.text == '<div id="ml-message"></div>'
        assert set(menus) == {"mechanism", "driver", "atlas view", "n, F", "synthesis start", "synthesis point",
                              "synthesis method", "synthesis atlas", "synthesis pick"}
    finally:
        inputs.resolve = resolve
        wb.close()


def test_a_file_given_to_serve_or_an_upload_is_a_choice_a_path_is_not(secret):
    from multiloop.inputs import load_mechanism
    from multiloop.web.app import load_choice
    from multiloop.topo.errors import InputError
    path, opened = secret
    files = {"given.toml": load_mechanism("watt_1")}
    assert load_choice(files, "given.toml") is files["given.toml"]
    assert load_choice(files, "four_bar").name == "four_bar"
    for name in (str(path), "secret.toml", "given.toml/../secret.toml"):
        with pytest.raises(InputError, match="mechanism menu: expected one of its entries"):
            load_choice(files, name)
    assert opened == []


# ---------------------------------------------------------------------- access
def _request(url: str, path: str = "/", host: str | None = None, headers: dict | None = None):
    """A GET of ``path`` (with its query) to the server of ``url``: (status, headers)."""
    import http.client
    from urllib.parse import urlsplit
    u = urlsplit(url)
    conn = http.client.HTTPConnection(u.hostname, u.port, timeout=60)
    try:
        conn.putrequest("GET", path, skip_host=True, skip_accept_encoding=True)
        conn.putheader("Host", host or u.netloc)
        for k, v in (headers or {}).items():
            conn.putheader(k, v)
        conn.endheaders()
        r = conn.getresponse()
        return r.status, r.headers
    finally:
        conn.close()


def _websocket(url: str, host: str | None = None, origin: str | None = None, cookie: str | None = None) -> int:
    """The status of a websocket handshake with Bokeh's own subprotocol and a session
    token made up by the client (as a page of another site could)."""
    import base64

    from bokeh.util.token import generate_jwt_token, generate_session_id
    token = generate_jwt_token(generate_session_id(), signed=False)
    headers = {"Upgrade": "websocket", "Connection": "Upgrade", "Sec-WebSocket-Version": "13",
               "Sec-WebSocket-Key": base64.b64encode(os.urandom(16)).decode(),
               "Sec-WebSocket-Protocol": f"bokeh, {token}"}
    if origin is not None:
        headers["Origin"] = origin
    if cookie is not None:
        headers["Cookie"] = cookie
    return _request(url, "/ws", host, headers)[0]


@pytest.fixture(scope="module")
def served():
    from tests.common import start_serve, stop
    url, proc = start_serve()
    yield url, proc
    stop(proc)


def test_serve_prints_the_address_with_a_fresh_token(served):
    url, _ = served
    from urllib.parse import parse_qs, urlsplit
    token = parse_qs(urlsplit(url).query)["token"][0]
    assert re.fullmatch(r"[A-Za-z0-9_-]{43}", token), url


def test_requests_without_the_token_or_from_another_host_are_refused(served):
    """Before: any Host, any Origin, no token; every plain GET built a Bokeh session and a
    websocket whose Host and Origin named another site was answered 101."""
    from urllib.parse import urlsplit
    url, _ = served
    u = urlsplit(url)
    port, token = u.port, u.query.removeprefix("token=")
    evil = f"evil.example:{port}"
    refused = {
        "no token": _request(url, "/")[0],
        "a wrong token": _request(url, "/?token=" + "x" * 43)[0],
        "a foreign Host": _request(url, "/?" + u.query, host=evil)[0],
        "a foreign Origin": _request(url, "/?" + u.query, headers={"Origin": "http://evil.example"})[0],
        "a script without the cookie": _request(url, "/static/js/bokeh.min.js")[0],
        "websocket, foreign Host and Origin": _websocket(url, evil, f"http://{evil}"),
        "websocket, this Host, foreign Origin": _websocket(url, None, "http://evil.example",
                                                           f"multiloop-token-{port}={token}"),
        "websocket, no Origin": _websocket(url, None, None, f"multiloop-token-{port}={token}"),
        "websocket, no token": _websocket(url, None, f"http://{u.netloc}"),
    }
    assert refused == dict.fromkeys(refused, 403)
    status, headers = _request(url, "/?" + u.query)
    assert status == 200
    assert headers["Content-Security-Policy"] == "frame-ancestors 'none'" and headers["X-Frame-Options"] == "DENY"
    cookie = headers["Set-Cookie"]
    assert cookie.startswith(f"multiloop-token-{port}={token};") and "HttpOnly" in cookie and "SameSite=Strict" in cookie
    for host in (f"localhost:{port}", f"[::1]:{port}", f"LOCALHOST:{port}"):
        assert _request(url, "/?" + u.query, host=host)[0] == 200, host
    mine = {"Cookie": f"multiloop-token-{port}={token}"}
    assert _request(url, "/static/js/bokeh.min.js", headers=mine)[0] == 200
    assert _request(url, "/", headers=mine)[0] == 200
    assert _websocket(url, None, f"http://{u.netloc}", mine["Cookie"]) == 101        # the page's own


def _server_in_a_thread(page, token):
    """app._make_server in a thread of its own: (BaseServer, Access, stop())."""
    import asyncio
    import threading

    from multiloop.web.app import _make_server
    box, started = {}, threading.Event()

    def run():
        asyncio.set_event_loop(asyncio.new_event_loop())
        from tornado.ioloop import IOLoop
        box["server"], box["access"] = _make_server(page, 0, "127.0.0.1", token)
        box["server"].start()
        box["loop"] = IOLoop.current()
        started.set()
        box["loop"].start()

    threading.Thread(target=run, daemon=True).start()
    assert started.wait(60)

    def stop():
        box["loop"].add_callback(lambda: (box["server"].stop(), box["loop"].stop()))
    return box["server"], box["access"], stop


def test_no_bokeh_session_is_made_for_a_request_without_the_token():
    """100 GETs with a foreign Origin made 100 sessions (memory 63 -> 200 MB)."""
    pages = []
    server, access, stop = _server_in_a_thread(lambda doc: pages.append(doc), "t0ken-of-the-test")
    try:
        url = access.url("127.0.0.1")
        base = url.split("?")[0]
        for _ in range(100):
            assert _request(base, "/", headers={"Origin": "http://evil.example"})[0] == 403
        assert pages == [] and server.get_sessions("/") == []
        assert _request(url, "/?token=t0ken-of-the-test")[0] == 200
        assert len(pages) == 1 and len(server.get_sessions("/")) == 1
    finally:
        stop()


def _serve(*args, cwd=None):
    import subprocess
    import sys
    return subprocess.Popen([sys.executable, "-m", "multiloop", "serve", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=cwd)


def test_token_options(tmp_path):
    from tests.common import free_port
    port = free_port()
    p = _serve("--port", str(port), "--token", "my-own_token-1", cwd=tmp_path)
    try:
        assert p.stdout.readline().startswith(f"multiloop serve: http://127.0.0.1:{port}/?token=my-own_token-1 ")
        assert _request(f"http://127.0.0.1:{port}/", "/?token=my-own_token-1")[0] == 200
    finally:
        p.terminate()
        p.communicate(timeout=20)
    port = free_port()
    p = _serve("--port", str(port), "--no-token", cwd=tmp_path)
    try:
        assert "warning: --no-token" in p.stderr.readline()
        assert p.stdout.readline().startswith(f"multiloop serve: http://127.0.0.1:{port}/ ")
        url = f"http://127.0.0.1:{port}/"
        assert _request(url)[0] == 200
        assert _request(url, host=f"evil.example:{port}")[0] == 403        # the host check stays
    finally:
        p.terminate()
        p.communicate(timeout=20)
    for bad in ("short", "has space in it", "semi;colon=x"):
        r = _serve("--port", "0", "--token", bad, cwd=tmp_path)
        out, err = r.communicate(timeout=120)
        assert r.returncode == 2 and "multiloop serve: error: --token: expected 8 or more characters" in err, err
    assert list(tmp_path.iterdir()) == []


def test_a_port_in_use_is_named_with_a_hint(tmp_path):
    """Before: 'error: a file: Address already in use', no port, no hint."""
    import socket
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        r = _serve("--port", str(port), cwd=tmp_path)
        out, err = r.communicate(timeout=120)
    assert r.returncode == 2 and out == ""
    assert err.strip() == f"multiloop serve: error: port {port} is in use; hint: --port 0 picks a free one"


# ---------------------------------------------------------------------- uploads, closed tabs
def test_the_browser_s_notice_of_a_large_file_is_the_command_line_s_message():
    """The page sends only the name and size of a file over the cap (the command line's
    readers' cap, imported): the message is the one of an upload read on the server."""
    import html

    from multiloop.inputs import MAX_UPLOAD, load_upload
    from multiloop.topo.errors import InputError
    from multiloop.topo.io import MAX_INPUT_BYTES
    from multiloop.web.app import Workbench
    assert MAX_UPLOAD == MAX_INPUT_BYTES == 8 << 20
    with pytest.raises(InputError, match=r"^file 'big.toml': expected at most 8 MiB, got 8388609 bytes; hint"):
        load_upload("big.toml", bytes(MAX_UPLOAD + 1))
    wb = Workbench({}, (), 40.0)
    shown = wb.mechanism
    wb.opener.target.tags = [1, "big.toml", 50 << 20]
    assert html.unescape(wb.message.text).endswith(
        ">file 'big.toml': expected at most 8 MiB, got 52428800 bytes; hint: upload a mechanism file, not a data set</div>")
    assert wb.mechanism is shown
    wb.opener.target.tags = [2, "x", "not a size"]                  # written by hand: one line too
    assert "upload: expected a file's name and size" in html.unescape(wb.message.text)
    wb.close()


class _Session:
    def __init__(self, sid):
        self.id, self.connection_count = sid, 0


def test_a_tab_that_loses_its_connection_has_its_jobs_stopped_once():
    """A session made by the page's request has no connection yet: nothing happens until
    its websocket came and went; a reconnect and a second loss stop again."""
    from multiloop.web.tabs import TabWatch
    watch, lost = TabWatch(), []
    a, b = _Session("a"), _Session("b")
    watch.add("a", lambda: lost.append("a"))
    watch.add("b", lambda: lost.append("b"))
    watch.check([a, b])
    a.connection_count = 1
    watch.check([a, b])
    a.connection_count = 0
    watch.check([a, b])
    watch.check([a, b])
    assert lost == ["a"]
    a.connection_count = 1
    watch.check([a, b])
    a.connection_count = 0
    watch.discard("b")
    watch.check([a])
    assert lost == ["a", "a"] and set(watch.pages) == {"a"}


def test_open_opens_the_address_with_the_token(tmp_path):
    import subprocess
    import sys
    opener, seen = tmp_path / "opener.sh", tmp_path / "opened.txt"
    opener.write_text(f'#!/bin/sh\necho "$1" > {seen}\n')
    opener.chmod(0o755)
    p = subprocess.Popen([sys.executable, "-m", "multiloop", "serve", "--port", "0", "--open"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path,
                         env=dict(os.environ, BROWSER=str(opener)))
    try:
        url = re.search(r"http://\S+", p.stdout.readline()).group(0)
        for _ in range(600):                        # until the browser was called (600 looks)
            if seen.exists() and seen.read_text().strip():
                break
            assert p.poll() is None
            time.sleep(0.1)
        assert "?token=" in url and seen.read_text().strip() == url
    finally:
        p.terminate()
        p.communicate(timeout=20)
