"""Actual mobility from the rank of the constraint Jacobian (topo.mobility)."""
from __future__ import annotations

import pytest

from test_assur import crank_slider, four_bar, knitting_needle, vtwin
from multiloop.topo.errors import InputError
from multiloop.topo.mobility import MobilityReport, actual_mobility
from multiloop.topo.model import MechanismBuilder, chain_from_joint_lists


def parallelogram(redundant=True, skew=0.0):
    b = MechanismBuilder(name="parallelogram")
    b.add_link("g", frame=True)
    J = [("O", ("g", "c1"), (0, 0)), ("A", ("c1", "cp"), (0, 1)),
         ("B", ("cp", "c2"), (2, 1)), ("C", ("c2", "g"), (2, 0))]
    if redundant:
        J += [("D", ("g", "c3"), (1, 0)), ("E", ("c3", "cp"), (1 + skew, 1))]
    for n, lk, at in J:
        b.add_joint(n, "R", lk, at=at)
    return b.build()


def test_parallelogram_with_redundant_link_formula_zero_actual_one():
    r = actual_mobility(parallelogram())
    assert isinstance(r, MobilityReport)
    assert (r.formula_F, r.actual_F, r.n_redundant) == (0, 1, 1)
    assert r.redundant == ("E (c3–cp)",)
    assert r.as_dict()["redundant"] == ["E (c3–cp)"]


def test_non_parallel_extra_link_is_a_structure():
    r = actual_mobility(parallelogram(skew=0.3))
    assert (r.formula_F, r.actual_F, r.n_redundant) == (0, 0, 0)


@pytest.mark.parametrize("make, F", [(four_bar, 1), (crank_slider, 1), (vtwin, 1), (knitting_needle, 1)])
def test_regular_mechanisms_have_no_redundant_constraint(make, F):
    r = actual_mobility(make())
    assert (r.formula_F, r.actual_F, r.n_redundant, r.redundant) == (F, F, 0, ())


def test_flat_four_bar_is_instantaneously_more_mobile():
    b = MechanismBuilder()
    b.add_link("g", frame=True)
    for n, lk, at in [("O", ("g", "a"), (0, 0)), ("A", ("a", "b"), (1, 0)),
                      ("B", ("b", "c"), (3, 0)), ("C", ("c", "g"), (4, 0))]:
        b.add_joint(n, "R", lk, at=at)
    r = actual_mobility(b.build())
    assert r.formula_F == 1 and r.actual_F == 2 and r.n_redundant == 1


def test_needs_geometry():
    with pytest.raises(InputError, match="geometry"):
        actual_mobility(chain_from_joint_lists([["a", "b"], ["b", "c"], ["c", "a"]]))
