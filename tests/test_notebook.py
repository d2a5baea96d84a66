"""Notebook views: Mechanism._repr_svg_, the _repr_html_ of reports and states, the scrub
widget, and docs/example.ipynb executed end to end (nbclient, when installed)."""
from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

import multiloop as ml

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("name", ["four_bar", "crank_slider", "knitting_needle_drive", "excavator"])
def test_mechanism_svg_is_valid_and_names_every_joint(name):
    m = ml.load(name)
    svg = m._repr_svg_()
    root = ET.fromstring(svg)  # well-formed XML
    texts = {t.text for t in root.iter("{http://www.w3.org/2000/svg}text")}
    assert set(m.joint_names) <= texts and {p.name for p in m.points} <= texts


def test_bare_chain_svg_says_there_is_nothing_to_draw():
    from multiloop.topo.model import chain_from_joint_lists
    chain = chain_from_joint_lists([["a", "b"], ["b", "c"], ["c", "d"], ["d", "a"]])
    assert "no positions" in chain._repr_svg_()


def test_reports_and_states_render_tables_and_plots():
    m = ml.load("four_bar")
    for obj in (ml.analyse(m), ml.solve(m, np.linspace(0, 2 * np.pi, 13)), ml.check(m)):
        html = obj._repr_html_()
        assert "<table>" in html and "<svg" in html, type(obj).__name__


def test_scrub_slider_redraws():
    pytest.importorskip("ipywidgets")
    from multiloop.notebook import scrub
    box = scrub(ml.solve("four_bar", np.linspace(0, 2 * np.pi, 13)))
    slider, view = box.children
    before = view.value
    slider.value = 6
    assert view.value != before and slider.max == 12


def test_example_notebook_runs():
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    nb = nbformat.read(ROOT / "docs" / "example.ipynb", as_version=4)
    nbclient.NotebookClient(nb, timeout=120, kernel_name="python3",
                            resources={"metadata": {"path": str(ROOT)}}).execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs]
    assert not [o for o in outputs if o.get("output_type") == "error"]
    assert any("image/svg+xml" in o.get("data", {}) for o in outputs)
    assert any("text/html" in o.get("data", {}) for o in outputs)
