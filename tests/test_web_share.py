"""The open design in the page's address (``multiloop/web/share.py``): a code that
round-trips through the mechanism file's parser, damaged codes as one line, and the
workbench that opens a code and puts the code of each edit in the address (no browser;
``tests/test_web.py::test_share_*`` opens the address in a fresh browser context)."""
from __future__ import annotations

import base64
import zlib

import pytest

pytest.importorskip("bokeh")

from multiloop.inputs import load_mechanism  # noqa: E402
from multiloop.topo.errors import InputError  # noqa: E402
from multiloop.topo.io import dumps_toml  # noqa: E402
from multiloop.web.app import catalogue_names  # noqa: E402
from multiloop.web.editing import moved  # noqa: E402
from multiloop.web.share import MAX_CODE, design_code, design_from_code, requested_design  # noqa: E402


def _code(data: bytes) -> str:
    return base64.urlsafe_b64encode(zlib.compress(data)).decode()


@pytest.mark.parametrize("name", catalogue_names())
def test_share_code_of_every_catalogue_mechanism_round_trips(name):
    m = load_mechanism(name)
    code = design_code(m)
    assert code is not None and len(code) <= MAX_CODE and code.isascii() and "=" not in code
    assert dumps_toml(design_from_code(code)) == dumps_toml(m)


def test_share_damaged_codes_are_one_line():
    good = design_code(load_mechanism("four_bar"))
    for bad, fault in ((good[:-12], "got a cut-off code"), ("abc", "got a damaged code"),
                       ("../../etc/passwd", "got not base64url"), ("<img src=x>", "got not base64url"),
                       ("A" * (MAX_CODE + 1), f"expected a code of at most {MAX_CODE} characters"),
                       (_code(b" " * (3 << 20)), "got more than 1048576 bytes"),
                       (_code(b"[[link]]\nname = 1\n"), "design (the address's ?design=): ")):
        with pytest.raises(InputError) as exc:
            design_from_code(bad)
        text = str(exc.value)
        assert fault in text and "\n" not in text and text.startswith("design (the address's ?design=): ")
    assert design_from_code(good + "=") == load_mechanism("four_bar")      # padding is allowed


def test_share_the_workbench_puts_each_edit_in_the_address_and_opens_a_code():
    from multiloop.web.app import Workbench
    wb = Workbench(requested="four_bar")
    try:
        assert wb.address.model.tags == ["", "four_bar"]              # a menu name: ?mechanism=
        wb.editor.edit("B", (0.12, 0.08))
        code = wb.address.model.tags[0]
        assert design_from_code(code) == moved(load_mechanism("four_bar"), "B", (0.12, 0.08))
    finally:
        wb.close()
    other = Workbench(shared=code)
    try:
        assert other.mechanism_name == "shared: four_bar" and other.mechanism.joint("B").at == (0.12, 0.08)
        assert other.address.model.tags[0] == code
    finally:
        other.close()
    bad = Workbench(shared=code[:-30])
    try:
        assert bad.mechanism_name == "four_bar" and "got a cut-off code" in bad.message.text
    finally:
        bad.close()


def test_share_requested_design_reads_text_only():
    class Doc:
        def __init__(self, args):
            self.session_context = type("C", (), {"request": type("R", (), {"arguments": args})()})()
    assert requested_design(Doc({"design": [b"abc"], "token": [b"t"]})) == "abc"
    assert requested_design(Doc({"token": [b"t"]})) is None
    assert len(requested_design(Doc({"design": [b"\xff" * 9000]}))) == MAX_CODE + 1
    assert requested_design(object()) is None


def test_share_a_hostile_design_name_stays_text():
    from dataclasses import replace

    from multiloop.web.app import Workbench
    evil = "<img src=x onerror=alert(1)>'\"&"
    code = design_code(replace(load_mechanism("four_bar"), name=evil))
    wb = Workbench(shared=code)
    try:
        assert wb.mechanism_name == f"shared: {evil}" and wb.mechanism.name == evil
        assert "<img" not in wb.view.readout.text and "&lt;img src=x onerror=alert(1)&gt;" in wb.view.readout.text
        assert wb.address.model.tags[0] == code
    finally:
        wb.close()
