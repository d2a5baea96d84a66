"""The page's display units (``multiloop/web/units.py``): a frozen value, conversions
both ways, and the workbench's edit row, readout and check table in mm and rad (no
browser; ``tests/test_web.py::test_units_*`` drives the page)."""
from __future__ import annotations

import dataclasses
import html
import math
import re

import numpy as np
import pytest

pytest.importorskip("bokeh")

from multiloop.topo.errors import InputError  # noqa: E402
from multiloop.web.units import Units  # noqa: E402
from tests.common import QUANTITY  # noqa: E402


def test_units_are_frozen_hashable_and_checked():
    u = Units("in", "rad")
    with pytest.raises(dataclasses.FrozenInstanceError):
        u.length = "m"
    assert hash(u) == hash(Units("in", "rad")) and u != Units()
    with pytest.raises(InputError, match="length unit: expected mm or m or in, got 'ft'"):
        Units("ft")
    with pytest.raises(InputError, match="angle unit"):
        Units("m", "grad")


def test_units_convert_shown_and_typed_values_both_ways():
    u = Units("in", "rad")
    assert u.shown(0.0254, "m") == pytest.approx(1.0) and u.typed("1", "m") == pytest.approx(0.0254)
    assert u.shown(180.0, "deg") == pytest.approx(math.pi) and u.typed(str(math.pi), "deg") == pytest.approx(180)
    assert Units().shown(0.12, "m") == 0.12 and Units("mm").typed("120", "m") == 0.12
    for bad in ("abc", "nan", "inf", None):
        with pytest.raises(InputError, match=r"expected a finite number \(in in\)"):
            u.typed(bad, "m")


def test_units_reach_the_edit_row_readout_and_check_table():
    import time

    from multiloop.inputs import load_mechanism
    from multiloop.web.app import Workbench
    wb = Workbench(requested="four_bar")
    try:
        t = time.monotonic()
        while wb.check_doc is None and time.monotonic() - t < 120:   # a bound on a hang only
            wb.poll()
            time.sleep(0.05)
        wb.units.lengths.select.value = "mm"          # as the page's menus set them
        wb.units.angles.select.value = "rad"
        wb.editor.point.select.value = "B"
        b = load_mechanism("four_bar").joint("B").at
        assert (wb.editor.x.title, wb.editor.x.value) == ("x (mm)", format(1000 * b[0], ".12g"))
        assert wb.view.readout.text.endswith(" rad</span>") and "rad" in wb.view.status.text
        assert wb.view.ticks.args == {"scale": 1000.0} and wb.view.fig.xaxis[0].axis_label == "x (mm)"
        table = html.unescape(re.sub(r"<[^>]+>", " ", wb.check.table.text))
        assert "O2 (rad)" in table and "flagged below 0.6981 rad" in table
        # the verdict's lines: the document's (m, deg) with every angle in rad
        lines = [html.unescape(v) for v in re.findall(r"<li>(.*?)</li>", wb.check.verdict.text)]
        assert len(lines) == len(wb.check_doc["verdict"]) == 1
        for mine, si in zip(lines, wb.check_doc["verdict"]):
            assert re.sub(QUANTITY, "#", mine) == re.sub(QUANTITY, "#", si)       # the words are the same
            got, want = ([(float(v), u) for v, u in re.findall(QUANTITY, t)] for t in (mine, si))
            assert [u for _, u in got] == [" rad"] * len(want) and {u for _, u in want} == {"°"}
            np.testing.assert_allclose([v for v, _ in got], [math.radians(v) for v, _ in want], atol=5e-4)
        wb.editor.typed("B", ("120", "80"))
        assert wb.mechanism.joint("B").at == (0.12, 0.08)
        wb.editor.typed("B", ("12o", "80"))
        assert "position of B: expected two finite numbers (x, y in mm), got ('12o', '80')" in html.unescape(
            wb.message.text)
        wb.units.lengths.select.value = "km"                # forged: the menu refuses it
        assert wb.units.units.length == "mm" and "length unit menu: expected one of its entries" in wb.message.text
    finally:
        wb.close()


def test_units_reach_the_synthesis_tab_its_errors_bounds_and_timing():
    """In mm and rad the Synthesis tab shows a candidate's errors in mm (its table's
    numbers are the library's times 1000), reads the length bounds typed in mm and the
    transmission threshold in rad, and the prescribed timing's inputs in rad; the values
    typed before the switch are converted, the run's options stay in m and deg."""
    from types import SimpleNamespace

    from multiloop.web.app import Workbench
    wb = Workbench(requested="four_bar")
    try:
        wb.tabs.active = 2                            # the tab is built when first shown
        sv = wb.synthesis
        sv.w["length_low"].value, sv.w["length_high"].value = "0.02", "0.5"
        sv.w["min_transmission"].value = "30"
        wb.units.lengths.select.value = "mm"          # as the page's menus set them
        wb.units.angles.select.value = "rad"
        assert (sv.w["length_low"].title, sv.w["length_low"].value) == ("length ≥ (mm)", "20")
        assert sv.w["length_high"].value == "500" and sv.w["min_transmission"].title == "min transmission (rad)"
        assert float(sv.w["min_transmission"].value) == pytest.approx(math.radians(30), rel=1e-12)
        opts = sv._options()
        assert opts["length_bounds"] == pytest.approx((0.02, 0.5), rel=1e-12)
        assert opts["min_transmission"] == pytest.approx(30.0, rel=1e-12)
        assert sv.fig.xaxis[0].axis_label == "x (mm)" and sv.ticks.args == {"scale": 1000.0}
        d = sv.drawing
        assert (d.first.title, d.last.title) == ("first input (rad)", "last input (rad)")
        assert d.last.value == pytest.approx(2 * math.pi, rel=1e-12)
        d.history = d.history + (dataclasses.replace(d.state, points=np.zeros((3, 2))),)
        d.timing.select.value = "prescribed"
        np.testing.assert_allclose(d.target()[:, 2], [0.0, 180.0, 360.0], rtol=1e-12)   # deg, as synthesise
        m = wb.mechanism
        sv.results = [SimpleNamespace(mechanism=m, error_max=0.00123, error_rms=0.000456, seed=0, stopped="",
                                  achieved=np.zeros((2, 2)))]
        sv._list()
        row = re.search(r'data-error-max="([^"]+)" data-error-rms="([^"]+)"', sv.table.text)
        assert [float(v) for v in row.groups()] == pytest.approx([1.23, 0.456], rel=1e-12)
        assert 'data-unit="mm"' in sv.table.text and "error max (mm)" in sv.table.text
        wb.units.lengths.select.value = "in"
        row = re.search(r'data-error-max="([^"]+)"', sv.table.text)
        assert float(row.group(1)) == pytest.approx(0.00123 / 0.0254, rel=1e-12)
    finally:
        wb.close()


def test_units_reach_an_atlas_designs_deviation_and_an_uploaded_target_table():
    """In mm an atlas design's deviation is shown in mm (the library's m times 1000); a
    target table uploaded in mm is read in mm: the run's target is the SI file's (its
    input column in deg for the four-bar's crank), the uploaded points drawn in m, and
    the line beside the upload says so."""
    from multiloop.catalogue.dimensional.targets import parse_table
    from multiloop.web.app import Workbench
    from multiloop.web.synthesis_view import AtlasDesign
    si = np.array([[0.05 + 0.002 * i, 0.07 + 0.001 * (i % 5), 18.0 * i] for i in range(20)])
    text_si = "x,y,input\n" + "\n".join(",".join(repr(float(v)) for v in r) for r in si)
    text_mm = "x,y,input\n" + "\n".join(",".join(repr(float(v)) for v in (1000 * r[0], 1000 * r[1], r[2])) for r in si)
    wb = Workbench(requested="four_bar")
    try:
        wb.tabs.active = 2                            # the tab is built when first shown
        sv = wb.synthesis
        sv.choose_start("four_bar")
        wb.units.lengths.select.value = "mm"          # as the page's menus set them
        assert sv.csv.button.label == "target CSV in mm, deg…"
        sv._upload("mm.csv", text_mm.encode())
        assert "read in mm" in sv.status.text
        want = parse_table(text_si, (2, 3), "path", "si.csv")
        np.testing.assert_allclose(sv._target(wb._start("four_bar")), want, rtol=1e-12)
        np.testing.assert_allclose(np.c_[sv.uploaded.data["x"], sv.uploaded.data["y"]], want[:, :2], rtol=1e-12)
        wb.units.lengths.select.value = "m"           # read once: a later switch changes nothing
        np.testing.assert_allclose(sv._target(wb._start("four_bar")), want, rtol=1e-12)
        assert sv.csv.button.label == "target CSV in m, deg…"
        m = wb.mechanism
        sv.results = [AtlasDesign(m, 0.00123, 0.000456, "RRR", np.zeros((2, 2)), deviation=0.0042)]
        sv._list()
        assert "<td>deviation 0.0042 m</td>" in sv.table.text
        wb.units.lengths.select.value = "mm"
        assert "<td>deviation 4.2 mm</td>" in sv.table.text
        sv.results = [AtlasDesign(m, 0.00123, 0.000456, "RRR", np.zeros((2, 2)), deviation=0.0042, fit="curve")]
        sv._list()                                    # (a design refined by the curve distance says so)
        assert "<td>deviation 4.2 mm, curve fit</td>" in sv.table.text
    finally:
        wb.close()
