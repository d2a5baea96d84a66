"""Dimensional synthesis (multiloop.catalogue.dimensional) and ``multiloop synthesise``."""
from __future__ import annotations

import numpy as np
import pytest

from multiloop.catalogue.dimensional import Evaluator, design_space
from multiloop.catalogue.named import load_named
from multiloop.kin.solve import solve


@pytest.mark.parametrize("name", ["four_bar", "watt_1", "stephenson_1", "crank_slider", "dyad_rpr",
                                  "knitting_needle_drive", "stephenson_3_triad"])
def test_batched_evaluator_equals_solve(name):
    """Two routes: the parameterised batch evaluator and kin.solve agree at the start design."""
    m = load_named(name)
    sp = design_space(m, [p.name for p in m.points])
    ev = Evaluator(m, sp)
    phi = np.linspace(0.0, 0.6, 13)
    st = solve(m, phi)
    for i, j in enumerate(m.joint_names):
        w, ok = ev.point(np.vstack([sp.x0, sp.x0]), phi, j)
        assert ok.all()
        np.testing.assert_allclose(w[1], st.positions[:, i], atol=1e-12)
