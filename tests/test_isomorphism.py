"""Canonical form (nauty) vs VF2; relabelling invariance; the paper's cheap invariants."""
from __future__ import annotations

import random

from hypothesis import given, strategies as st

from multiloop.topo.isomorphism import (are_isomorphic, are_isomorphic_vf2, canonical_form,
                              could_be_isomorphic, invariant_signature)
from multiloop.topo.model import MechanismBuilder, chain_from_joint_lists
from tests.common import chains, random_joint_lists, relabel


@given(chains(), st.integers(0, 10 ** 6))
def test_canonical_form_invariant_under_relabelling(m, seed):
    r = relabel(m, seed)
    assert canonical_form(m) == canonical_form(r)
    assert are_isomorphic_vf2(m, r)


def test_canonical_form_agrees_with_vf2_on_random_pairs():
    # pairs with equal n and equal joint-size multiset: often non-isomorphic, sometimes
    # isomorphic; nauty's canonical form and VF2 must agree on every pair
    rng = random.Random(7)
    agree_iso = agree_non = 0
    for _ in range(150):
        n = rng.randint(4, 7)
        a = chain_from_joint_lists(random_joint_lists(rng, n, 2, 0.3))
        b = chain_from_joint_lists(random_joint_lists(rng, n, 2, 0.3))
        same = canonical_form(a) == canonical_form(b)
        assert same == are_isomorphic_vf2(a, b)
        agree_iso += same
        agree_non += not same
    assert agree_iso > 0 and agree_non > 0   # both outcomes exercised


def test_watt_vs_stephenson_same_cheap_invariants_except_loops():
    watt = chain_from_joint_lists([["a", "b"], ["a", "c"], ["c", "d"], ["d", "b"], ["a", "e"], ["e", "f"], ["f", "b"]])
    steph = chain_from_joint_lists([["a", "b"], ["b", "c"], ["c", "d"], ["d", "a"], ["a", "e"], ["e", "f"], ["f", "c"]])
    assert not are_isomorphic(watt, steph)
    assert invariant_signature(watt, with_loops=False) == invariant_signature(steph, with_loops=False)
    assert not could_be_isomorphic(watt, steph)     # [La] separates them: 4-4-6 vs 4-5-5


def test_cheap_invariants_are_not_sufficient():
    # Two non-isomorphic 8-link chains with identical [LA], [MJA], [La] and MJ sets exist;
    # search a few random chains for such a pair: invariants equal, canonical forms differ.
    rng = random.Random(3)
    seen: dict = {}
    found = False
    for _ in range(3000):
        m = chain_from_joint_lists(random_joint_lists(rng, 8, 3, 0.0))
        sig = invariant_signature(m)
        cf = canonical_form(m)
        other = seen.setdefault(sig, cf)
        if other != cf:
            found = True
            break
    assert found, "expected the paper's invariants to merge some non-isomorphic chains"


def test_multiple_joint_differs_from_two_simple_joints():
    # a triple pin (b, c, d) vs the same links with two simple joints b-c and b-d
    a = chain_from_joint_lists([["a", "b"], ["b", "c", "d"], ["c", "e"], ["d", "e"], ["e", "a"]])
    b = chain_from_joint_lists([["a", "b"], ["b", "c"], ["b", "d"], ["c", "e"], ["d", "e"], ["e", "a"]])
    assert canonical_form(a) != canonical_form(b)
    # which pairs a pin forms is not a question: the pin is one vertex of the incidence graph
    c = chain_from_joint_lists([["a", "b"], ["d", "b", "c"], ["c", "e"], ["d", "e"], ["e", "a"]])
    assert canonical_form(a) == canonical_form(c)


def _four_bar(frame: str, driver_joint: str):
    b = MechanismBuilder()
    b.add_link(frame, frame=True)
    for name, links in [("O", ("a", "b")), ("A", ("b", "c")), ("B", ("c", "d")), ("C", ("d", "a"))]:
        b.add_joint(name, "R", links)
    b.add_driver(driver_joint)
    return b.build()


def test_mechanism_mode_sees_frame_and_driver():
    m1 = _four_bar("a", "O")
    m2 = _four_bar("a", "C")      # symmetric: driver at the other frame pivot
    m3 = _four_bar("a", "A")      # driver on a moving pivot: a different mechanism
    assert canonical_form(m1, "chain") == canonical_form(m3, "chain")
    assert canonical_form(m1, "mechanism") == canonical_form(m2, "mechanism")
    assert canonical_form(m1, "mechanism") != canonical_form(m3, "mechanism")
    assert are_isomorphic_vf2(m1, m2, "mechanism") and not are_isomorphic_vf2(m1, m3, "mechanism")


def test_mechanism_mode_sees_the_driven_link_of_a_multiple_joint():
    """Frame 3, driver on the triple pin (3, 4, 5): driving 4 leaves two RRR dyads,
    driving 5 one triad (Assur 1914); the forms must differ, as VF2 says."""
    from multiloop.catalogue.inversions import classify, inversion
    joints = [(0, 1), (0, 2), (1, 3), (0, 4), (2, 5), (3, 4, 5)]
    four, five = inversion(joints, 3, 5, 4), inversion(joints, 3, 5, 5)
    assert classify(four)[3] == ("RRR", "RRR") and classify(five)[3] == ("triad",)
    assert canonical_form(four, "chain") == canonical_form(five, "chain")
    assert canonical_form(four, "mechanism") != canonical_form(five, "mechanism")
    assert not are_isomorphic_vf2(four, five, "mechanism")
    # links renamed by s and joints reordered (the pin moves to position 0): still the triad
    s = [4, 2, 0, 5, 1, 3]
    moved = [tuple(s[x] for x in joints[a]) for a in (5, 0, 1, 2, 3, 4)]
    back = inversion(moved, s[3], 0, s[5])
    assert classify(back)[3] == ("triad",)
    assert canonical_form(back, "mechanism") == canonical_form(five, "mechanism")
    assert are_isomorphic_vf2(back, five, "mechanism")


def test_slider_kind_is_a_colour():
    r = MechanismBuilder()
    for name, kind, links in [("O", "R", ("f", "c")), ("A", "R", ("c", "r")), ("B", "R", ("r", "p")), ("S", "P", ("f", "p"))]:
        r.add_joint(name, kind, links)
    all_r = chain_from_joint_lists([["f", "c"], ["c", "r"], ["r", "p"], ["f", "p"]])
    assert canonical_form(r.build()) != canonical_form(all_r)
