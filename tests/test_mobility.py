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


# ---- the one home of pin pairs and of the constraint Jacobian ---------------------
def test_pin_pairs_k_links_give_k_minus_1_pairs_around_the_host():
    from multiloop.topo.graphs import n_pairs, pin_pairs
    assert pin_pairs(("a", "b")) == (("a", "b"),)
    assert pin_pairs(("a", "b", "c", "d")) == (("a", "b"), ("a", "c"), ("a", "d"))
    order = {"a": 2, "b": 0, "c": 1}
    assert pin_pairs(("a", "b", "c"), key=order.get) == (("b", "c"), ("b", "a"))
    # Pozhbelko & Kuts 2020: a multiple joint of multiplicity j counts j pairs
    m = chain_from_joint_lists([["a", "b", "c", "d"], ["b", "c"], ["c", "d"], ["d", "a"]])
    assert n_pairs(m) == 3 + 1 + 1 + 1


def _residual_by_hand(m, cons, Z):
    """Pin, slider and driver equations written out point by point (a second route)."""
    import numpy as np
    from multiloop.topo.constraints import link_origins
    idx = {x: i for i, x in enumerate(m.link_names)}
    org = link_origins(m)

    def point(link, r):
        X, Y, th = Z[idx[link]]
        v = np.asarray(r, float) - org[link]
        return np.array([X + np.cos(th) * v[0] - np.sin(th) * v[1], Y + np.sin(th) * v[0] + np.cos(th) * v[1]])

    out = []
    for c in cons:
        jt = m.joint(c.joint)
        ta, tb = Z[idx[c.a], 2], Z[idx[c.b], 2]
        if c.kind == "R":
            out += list(point(c.a, jt.at) - point(c.b, jt.at))
        elif c.kind == "drive_R":
            out += [tb - ta]
        else:
            u = np.asarray(jt.axis, float) / np.hypot(*jt.axis)
            d = point(c.b, jt.at) - point(c.a, jt.at)
            ca, sa = np.cos(ta), np.sin(ta)
            ug = np.array([ca * u[0] - sa * u[1], sa * u[0] + ca * u[1]])
            n = np.array([-ug[1], ug[0]])
            if c.kind == "P":
                out += [tb - ta, n @ d]
            else:
                out += [ug @ d]
    return np.array(out)


@pytest.mark.parametrize("make", [four_bar, crank_slider, vtwin])
def test_constraint_jacobian_equals_finite_differences(make):
    import numpy as np
    from multiloop.topo.assur import decompose
    from multiloop.topo.constraints import PairEquations
    m = make()
    cons = [c for s in decompose(m).steps for c in s.constraints]
    rng = np.random.default_rng(7)
    Z = rng.uniform(-1, 1, (m.n_links, 3))
    J = PairEquations.compile(m, cons).jacobian(Z[None])[0]
    h = 1e-6
    fd = np.zeros_like(J)
    for k in range(Z.size):
        dz = np.zeros(Z.size)
        dz[k] = h
        fd[:, k] = (_residual_by_hand(m, cons, Z + dz.reshape(Z.shape))
                    - _residual_by_hand(m, cons, Z - dz.reshape(Z.shape))) / (2 * h)
    assert np.allclose(J, fd, atol=1e-7)


@pytest.mark.parametrize("scale", [1e-9, 1e-3, 1.0, 1e3, 1e12])
def test_actual_mobility_does_not_depend_on_units(scale):
    from multiloop.topo.model import Joint, Mechanism
    for make in (four_bar, crank_slider, parallelogram):
        m = make()
        scaled = Mechanism(m.links, tuple(Joint(j.name, j.kind, j.links, (j.at[0] * scale, j.at[1] * scale), j.axis)
                                          for j in m.joints), m.drivers)
        assert actual_mobility(scaled).as_dict() == actual_mobility(m).as_dict()


def test_compiled_equations_are_read_only():
    import numpy as np
    from multiloop.topo.assur import decompose
    from multiloop.topo.constraints import PairEquations
    m = four_bar()
    eqs = PairEquations.compile(m, [c for s in decompose(m).steps for c in s.constraints])
    for name in ("R_a", "R_ra", "R_row", "P_dir", "A_a", "drv"):
        with pytest.raises(ValueError):
            getattr(eqs, name)[...] = 0
    assert isinstance(eqs.jacobian(np.zeros((1, m.n_links, 3))), np.ndarray)
