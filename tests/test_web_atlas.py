"""From an atlas card to a design (``multiloop/web/atlas_design.py``), without a browser:
the library's generic dimensions assemble and turn fully, the atlas view's menus open
a chain's mechanism in the mechanism view or as the synthesis's start, and forged
menu values are one line (``tests/test_web.py::test_atlas_card_*`` drives the page)."""
from __future__ import annotations

import time

import numpy as np
import pytest

pytest.importorskip("bokeh")

from multiloop.kin.solve import solve  # noqa: E402


@pytest.fixture(scope="module")
def atlas_db(tmp_path_factory):
    from tests.common import six_bar_chain_atlas
    return six_bar_chain_atlas(tmp_path_factory.mktemp("atlas") / "a.sqlite")


def _wait(wb, done, limit=120):
    t = time.monotonic()
    while not done() and time.monotonic() - t < limit:      # a bound on a hang only
        wb.poll()
        time.sleep(0.05)
    assert done()


def test_atlas_generic_design_of_every_six_bar_mechanism_turns_fully(atlas_db):
    from multiloop.catalogue.atlas import Atlas
    from multiloop.catalogue.synthesis import SynthesisOptions
    from multiloop.kin.check import check
    from multiloop.web.atlas_design import generic_design, mechanisms_of
    with Atlas(atlas_db, readonly=True) as a:
        rec = next(iter(a.chains(SynthesisOptions(6, 1), None, limit=1)))
    invs = mechanisms_of(rec)
    assert invs
    m = generic_design(invs[0], "atlas: #1")
    assert m.name == "atlas: #1" and [p.name for p in m.points] == ["P"] and len(m.links) == 6
    st = solve(m, np.radians(np.linspace(0, 360, 37)))
    assert st.success and np.isfinite(st.point_positions).all()
    assert check(m).as_dict()["drivers"][m.drivers[0].joint]["full_rotation"]
    assert generic_design(invs[0], "again").joints == m.joints        # the same dimensions each time


def test_atlas_card_opens_in_the_mechanism_view_and_as_a_synthesis_start(atlas_db):
    from multiloop.web.app import Workbench
    wb = Workbench({}, [str(atlas_db)], 40.0)
    try:
        wb.pages.build(3)
        opener = wb.atlas.opener
        assert opener.chains.choices and opener.mechanisms.choices
        opener.make(wb.open_candidate)
        _wait(wb, lambda: wb.mechanism_name.startswith("atlas: #1 1."))
        assert wb.tabs.active == 0 and wb.view.scene.mechanism is wb.mechanism
        opener.mechanisms.select.value = opener.mechanisms.choices[-1]
        opener.make(wb.start_synthesis)
        last = opener.mechanisms.choices[-1].split(":", 1)[0]
        _wait(wb, lambda: wb.mechanism_name == f"atlas: #1 {last}")
        assert wb.tabs.active == 2 and wb.synthesis.menus["start"].value == "(open mechanism)"
        assert wb.synthesis.menus["point"].value == "P" and wb.synthesis.start_src.data["xs"]
        opener.chains.select.value = "../../etc/passwd"                  # forged
        assert "chain menu: expected one of its entries" in wb.message.text
        opener.mechanisms.select.value = "9. anything"
        assert "atlas mechanism menu: expected one of its entries" in wb.message.text
    finally:
        wb.close()
