"""Structure edits of the open design (``multiloop/web/structure_edits.py``), without a
browser: a dyad added at every place of every catalogue mechanism decomposes with one
more dyad and removing the last group gives the file back byte for byte; the edits go
into the editor's history; refusals are one line (``tests/test_web.py::test_structure_*``
drives the page)."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

pytest.importorskip("bokeh")

from multiloop.inputs import load_mechanism  # noqa: E402
from multiloop.kin.solve import solve  # noqa: E402
from multiloop.topo.assur import decompose  # noqa: E402
from multiloop.topo.errors import InputError  # noqa: E402
from multiloop.topo.io import dumps_toml  # noqa: E402
from multiloop.web.app import catalogue_names  # noqa: E402
from multiloop.web.structure_edits import attach_places, with_dyad, without_last_group  # noqa: E402


@pytest.mark.parametrize("name", catalogue_names())
def test_structure_a_dyad_added_then_removed_gives_the_file_back(name):
    m = load_mechanism(name)
    for place in attach_places(m):
        d = with_dyad(m, place, reach=m.size)                # the reach only places the dyad
        plan = decompose(d)
        assert d.n_links == m.n_links + 2 and plan.groups[-1].kind_name == "RRR"
        assert dumps_toml(without_last_group(d)) == dumps_toml(m)


@pytest.mark.parametrize("name", ["four_bar", "stephenson_3", "crank_slider", "dyad_prp"])
def test_structure_the_added_dyad_assembles_over_the_motion(name):
    """The page's sweeps of the design with a dyad at each place assemble wherever the
    design's own sweeps do (the dyad never limits the motion)."""
    from multiloop.web.scene import sweep_driver
    m = load_mechanism(name)
    before = sweep_driver(m, 0)
    for place in attach_places(m):
        d = with_dyad(m, place)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            st = solve(d, before.api_inputs())
        assert np.all(st.ok[before.ok]), place


def test_structure_refusals_are_one_line():
    m = load_mechanism("four_bar")
    for bad in ("O2", "nowhere", "<img src=x>"):            # a frame pivot, no such place
        with pytest.raises(InputError, match="dyad place: expected a moving joint or tracer point"):
            with_dyad(m, bad)
    bare = without_last_group(m)
    assert bare.n_links == 2 and bare.points == () and attach_places(bare) == []
    with pytest.raises(InputError, match="got a design without one"):
        with_dyad(bare, "")
    with pytest.raises(InputError, match="got only driver links"):
        without_last_group(bare)
    with pytest.raises(InputError, match="got a driven group"):
        without_last_group(load_mechanism("excavator_bucket"))


def test_structure_edits_are_edits_of_the_history():
    from multiloop.web.app import Workbench
    wb = Workbench(requested="four_bar")
    try:
        bar = wb.editor.structure
        assert bar.places.choices == tuple(attach_places(wb.mechanism))
        bar.places.select.value = "B"                      # as the page's menu sets it
        bar._apply(lambda m: with_dyad(m, bar.places.value))
        assert wb.mechanism_name == "edited: four_bar" and "dyad1_M" in wb.mechanism.joint_names
        assert "dyad1_M" in bar.places.choices             # the menu follows the design
        bar._apply(without_last_group)
        bar._apply(without_last_group)
        assert wb.mechanism.n_links == 2
        for _ in range(3):
            wb.editor.step(-1)
        assert dumps_toml(wb.mechanism) == dumps_toml(load_mechanism("four_bar"))
        bar.places.select.value = "../../etc/passwd"
        assert "dyad place menu: expected one of its entries" in wb.message.text
    finally:
        wb.close()
