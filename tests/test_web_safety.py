"""``multiloop serve``'s safety without a browser: HTML built by one escaping function,
menus that name choices (never files), the token and host checks of the server, the
command's options and messages.  The same holes seen from headless chromium:
tests/test_web_hostile.py."""
from __future__ import annotations

import ast
import os
import re
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
