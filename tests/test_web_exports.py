"""The workbench's exports, share-by-name address, Structure tab names and menus, at the
level of :class:`multiloop.web.app.Workbench` (no browser; the address is also opened
in a real browser by ``test_web.py``)."""
from __future__ import annotations

import io
import json
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest

pytest.importorskip("bokeh")

from multiloop.inputs import load_mechanism, load_upload  # noqa: E402
from multiloop.topo.io import dumps_toml  # noqa: E402
from multiloop.web.app import Workbench, catalogue_names, requested_mechanism  # noqa: E402
from multiloop.web.exports import EXPORTS  # noqa: E402
from multiloop.web.menus import file_entries  # noqa: E402

MULTILOOP = [sys.executable, "-m", "multiloop"]


def _message(wb) -> str:
    import html
    import re
    return html.unescape(re.sub(r"<[^>]+>", "", wb.message.text))


def _export(wb, fmt: str):
    """Choose ``fmt`` in the export menu as the page does, click Download: (name, body)."""
    wb.exports.menu.select.value = fmt
    wb.exports.download.click()
    return wb.exports.download.payload()


def _finish_check(wb, timeout: float = 120.0) -> None:
    import time
    t0 = time.monotonic()
    while wb.job is not None and time.monotonic() - t0 < timeout:
        time.sleep(0.05)
        wb.poll()
    assert wb.job is None and wb.check_doc is not None


@pytest.fixture(scope="module")
def wb():
    w = Workbench()
    w.pick.value = "four_bar"
    _finish_check(w)
    yield w
    w.close()


def test_export_every_format_is_written_named_after_the_design_and_reads_back(wb, tmp_path):
    """Each export, named after the design, read back by the library or a parser: the
    mechanism (.toml, .pyslvs) opens as the same mechanism, the motion CSV is
    ``multiloop solve --csv``'s, the SVG and DXF parse, the GIF has frames, the check
    JSON is ``multiloop check --json``'s."""
    m = load_mechanism("four_bar")
    files = {}
    for fmt in EXPORTS:
        name, body = _export(wb, fmt)
        assert name == f"four_bar.{fmt}"
        files[fmt] = body
    assert dumps_toml(load_upload("x.toml", files["toml"].encode())) == dumps_toml(m)
    back = load_upload("x.pyslvs", files["pyslvs"].encode())
    assert len(back.links) == len(m.links) and len(back.joint_names) == len(m.joint_names)
    cli = subprocess.run([*MULTILOOP, "solve", "four_bar", "--csv"], capture_output=True, text=True, check=True)
    assert files["csv"].strip() == cli.stdout.strip()
    svg = ET.fromstring(files["svg"].encode())
    assert svg.tag.endswith("svg") and svg.findall(".//{http://www.w3.org/2000/svg}circle")
    path = tmp_path / "d.dxf"
    path.write_bytes(files["dxf"])
    import ezdxf
    assert len(ezdxf.readfile(path).modelspace()) > 0
    from PIL import Image
    gif = Image.open(io.BytesIO(files["gif"]))
    assert gif.format == "GIF" and gif.n_frames > 1
    cli = subprocess.run([*MULTILOOP, "check", "four_bar", "--json"], capture_output=True, text=True, check=True)
    assert json.loads(files["json"]) == json.loads(cli.stdout)


def test_export_of_a_bad_format_or_no_design_is_one_line(wb):
    wb.exports.menu.select.value = "../../etc/passwd"          # set by a script, not a click
    assert wb.exports.menu.value in EXPORTS and "export menu: expected one of its entries" in _message(wb)
    empty = Workbench()
    empty.mechanism = None
    empty.exports.download.click()
    assert empty.exports.download.payload() is None and "export: expected an open design" in _message(empty)
    empty.close()


def test_export_file_names_are_never_paths():
    from types import SimpleNamespace

    from multiloop.web.exports import file_stem
    for name, stem in (("../../x y", "x_y"), ("", "design"), ("a/b\\c", "a_b_c"), ("ok-1.2", "ok-1.2"),
                       ("<img src=x>", "img_src_x")):
        assert file_stem(SimpleNamespace(name=name)) == stem


@pytest.mark.parametrize("name", catalogue_names())
def test_share_by_name_opens_every_catalogue_mechanism(name):
    """``?mechanism=NAME`` opens that catalogue mechanism first."""
    w = Workbench(requested=name)
    try:
        assert w.mechanism_name == name and w.menu.value == name and not _message(w)
    finally:
        w.close()


def test_share_by_an_unknown_name_is_one_line_and_the_page_works():
    w = Workbench(requested="../../../etc/passwd")
    try:
        assert w.mechanism_name == "four_bar"
        assert "mechanism (the address's ?mechanism=): expected one of its entries, got '../../../etc/passwd'" \
            in _message(w)
        w.pick.value = "crank_slider"
        assert w.mechanism_name == "crank_slider"
    finally:
        w.close()


def test_the_address_is_read_as_text():
    class Request:
        def __init__(self, arguments):
            self.arguments = arguments

    class Context:
        def __init__(self, arguments):
            self.request = Request(arguments)

    class Doc:
        def __init__(self, arguments):
            self.session_context = Context(arguments)
    assert requested_mechanism(Doc({"mechanism": [b"watt_1"], "token": [b"t"]})) == "watt_1"
    assert requested_mechanism(Doc({"token": [b"t"]})) is None
    assert requested_mechanism(Doc({"mechanism": [b"\xff" * 500]})) == "\ufffd" * 200
    assert requested_mechanism(object()) is None


def test_structure_tab_names_each_number_as_analyse_does():
    w = Workbench(requested="knitting_needle_drive")
    try:
        text = w.structure.text
        analyse = subprocess.run([*MULTILOOP, "analyse", "knitting_needle_drive"], capture_output=True, text=True,
                                 check=True).stdout
        for label in ("links n", "loops K (graph / formula)", "mobility F (3 routes)", "MJ factor V", "code*"):
            assert f"<td>{label}</td>" in text.replace("&amp;", "&") and label in analyse
        for raw in ("<td>actual_F</td>", "<td>code_star</td>", "<td>True</td>", "<td>False</td>"):
            assert raw not in text
    finally:
        w.close()


def test_opening_a_mechanism_keeps_the_tab_and_a_candidate_shows_the_mechanism_tab():
    w = Workbench()
    try:
        w.tabs.active = 1                                   # the Structure tab
        w.pick.value = "watt_1"
        assert w.mechanism_name == "watt_1" and w.tabs.active == 1
        w.open_candidate(load_mechanism("crank_slider"))
        assert w.tabs.active == 0
    finally:
        w.close()


def test_menu_entries_of_served_files_show_no_folder():
    assert file_entries(["/home/u/designs/a.toml", "rel/b.json", "/x/a.toml", "four_bar"]) == \
        ["a.toml", "b.json", "a.toml (2)", "four_bar"]
    w = Workbench({e: load_mechanism("four_bar") for e in file_entries(["/tmp/deep/x/mine.toml"])})
    try:
        assert w.menu.choices[0] == "mine.toml" and not any("/" in c for c in w.menu.choices)
    finally:
        w.close()


def test_a_new_run_clears_the_last_candidates_and_a_big_target_gets_a_target_hint():
    from types import SimpleNamespace

    import numpy as np
    w = Workbench()
    try:
        w.tabs.active = 2                                   # builds the Synthesis tab
        sv = w.synthesis
        sv.csv.target.tags = [1, "big.csv", 50 << 20]        # the browser's notice of a large file
        assert "upload a target table" in _message(w) and "mechanism file" not in _message(w)
        rows = "\n".join(f"{0.05 + 0.01 * np.cos(t):.5f},{0.07 + 0.01 * np.sin(t):.5f}"
                         for t in np.linspace(0, 6, 20))
        sv._upload("t.csv", ("x,y\n" + rows + "\n").encode())
        m = load_mechanism("four_bar")
        sv.results = [SimpleNamespace(mechanism=m, error_max=0.1, error_rms=0.05, seed=1, stopped="budget",
                                      achieved=np.zeros((3, 2)))]
        sv._list()
        assert 'data-candidate="1"' in sv.table.text
        assert sv._download("toml")[0] == "four_bar-candidate-1.toml"
        sv.menus["start"].select.value = "four_bar"
        sv.run()
        assert sv.results == [] and sv.table.text == ""     # the old candidates are gone at once
        sv._open()
        assert "candidate: expected a candidate of a synthesis run, got " in _message(w)
        sv.cancel()
    finally:
        w.close()


def test_event_labels_at_nearly_the_same_place_are_stacked():
    """Event labels whose marks nearly coincide (the excavator's limits) go one line apart
    instead of overlapping."""
    from multiloop.web.mechanism_view import LABEL_LINE, stacked_offsets
    assert stacked_offsets([0, 0.001, 5, 0.0005], [0, 0, 5, 0.001], 0.01) == \
        [-4.0, -4.0 + LABEL_LINE, -4.0, -4.0 + 2 * LABEL_LINE]
    w = Workbench(requested="excavator")
    try:
        _finish_check(w, timeout=600)
        d = w.view.marks.data
        assert len(d["label"]) >= 2
        pairs = {(round(x, 9), round(y, 9), dy) for x, y, dy in zip(d["x"], d["y"], d["dy"])}
        assert len(pairs) == len(d["label"])                 # no two labels drawn at one place
    finally:
        w.close()
