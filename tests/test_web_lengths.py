"""A binary link's length typed in the workbench (``multiloop/web/lengths.py``): the
free end's rule, the edit through the editor's history (undo gives the file back byte for
byte), the display unit, and the lengths refused with one line naming the link (no
browser; ``tests/test_web.py::test_edit_length_*`` types one in the page)."""
from __future__ import annotations

import html
import math
import re

import numpy as np
import pytest

pytest.importorskip("bokeh")

from multiloop.inputs import load_mechanism  # noqa: E402
from multiloop.kin.solve import solve  # noqa: E402
from multiloop.topo.errors import InputError  # noqa: E402
from multiloop.topo.io import dumps_toml  # noqa: E402
from multiloop.web.app import Workbench  # noqa: E402
from multiloop.web.lengths import binary_links, free_end, with_length  # noqa: E402


def _message(wb) -> str:
    return html.unescape(re.sub(r"<[^>]+>", "", wb.message.text))


@pytest.fixture
def wb():
    w = Workbench(requested="four_bar")
    yield w
    w.close()


def _type(wb, link, text):
    wb.editor.lengths.link.select.value = link          # as the page's menu sets it
    wb.editor.lengths.length.value = text
    wb.editor.lengths.typed(link, text)


def test_the_free_end_is_the_pin_the_plan_knows_later():
    m = load_mechanism("four_bar")
    # A is known with the crank (step 0), B with the dyad (step 1), a frame pivot first
    assert {lk: free_end(m, lk) for lk in binary_links(m)} == {
        "crank": ("O2", "A"), "coupler": ("A", "B"), "rocker": ("O4", "B")}
    # the piston's joints are a pin and a slider: its length is not typed
    assert binary_links(load_mechanism("crank_slider")) == ["crank", "rod"]
    with pytest.raises(InputError, match="edited link: expected a binary link of the design"):
        free_end(load_mechanism("crank_slider"), "piston")


def test_a_typed_length_moves_the_free_end_along_the_link_and_undo_gives_the_file_back(wb):
    original = dumps_toml(wb.mechanism)
    m0 = load_mechanism("four_bar")
    wb.units.lengths.select.value = "mm"
    assert wb.editor.lengths.length.title == "length (mm)"
    wb.editor.lengths.link.select.value = "coupler"
    a, b = (np.array(m0.joint(n).at) for n in ("A", "B"))
    assert float(wb.editor.lengths.length.value) == pytest.approx(1000 * np.linalg.norm(b - a), rel=1e-11)
    _type(wb, "coupler", "150")
    m = wb.mechanism
    assert wb.mechanism_name == "edited: four_bar" and "data-error" not in wb.message.text
    got = np.array(m.joint("B").at)
    assert np.linalg.norm(got - a) == pytest.approx(0.150, rel=1e-12)
    np.testing.assert_allclose((got - a) / 0.150, (b - a) / np.linalg.norm(b - a), atol=1e-12)   # same direction
    assert [j.at for j in m.joints if j.name != "B"] == [j.at for j in m0.joints if j.name != "B"]
    assert dumps_toml(m) == dumps_toml(with_length(m0, "coupler", 0.150))
    assert solve(m, [0.0]).ok[0] and float(wb.editor.lengths.length.value) == pytest.approx(150.0, rel=1e-12)
    wb.editor.step(-1)
    assert dumps_toml(wb.mechanism) == original
    wb.editor.step(+1)
    assert dumps_toml(wb.mechanism) == dumps_toml(m)


def _toggle_crank(m):
    """The crank length at which A lies on the line O4-B: the dyad (coupler, rocker) at a
    dead centre in the reference."""
    a, b, o4 = (np.array(m.joint(n).at) for n in ("A", "B", "O4"))
    u, d = a / np.linalg.norm(a), b - o4                  # A = t u; O4 + s d
    t, _ = np.linalg.solve(np.column_stack([u, -d]), o4)
    return float(t)


def test_a_length_at_which_the_design_no_longer_assembles_is_one_line_naming_the_link(wb):
    before = dumps_toml(wb.mechanism)
    toggle = _toggle_crank(wb.mechanism)
    assert toggle > 0
    for text, want in (("0", "length of link 'crank': expected a finite length > 0, got 0 m"),
                       ("-0.02", "length of link 'crank': expected a finite length > 0, got -0.02 m"),
                       ("abc", "length of link 'crank': expected a finite number (in m), got 'abc'"),
                       (repr(toggle), "length of link 'crank': expected a length at which the design still "
                                      "assembles, got ")):
        wb.clear()
        _type(wb, "crank", text)
        assert _message(wb).startswith(want) and "\n" not in _message(wb), _message(wb)
        assert dumps_toml(wb.mechanism) == before and not wb.editor.history.can_undo
    assert "singular" in _message(wb)
    wb.editor.lengths.link.select.value = "../frame"
    assert "edited link: expected one of its entries" in _message(wb)


def test_a_pin_moved_onto_another_pin_is_refused():
    m = load_mechanism("four_bar")
    a, b = (np.array(m.joint(n).at) for n in ("A", "B"))
    # a design whose coupler points at O4: the coupler's length |A O4| puts B on O4
    from multiloop.web.editing import moved
    o4 = np.array(m.joint("O4").at)
    m = moved(m, "B", tuple(a + 0.5 * (o4 - a)))
    with pytest.raises(InputError, match="length of link 'coupler': expected a length at which the design "
                                         "still assembles, got .* m, where link 'rocker'"):
        with_length(m, "coupler", math.dist(a, o4))
