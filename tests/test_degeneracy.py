"""Rigid sub-chains by two exact routes (exhaustive bit masks vs minimum cut)."""
from __future__ import annotations

from hypothesis import given

from multiloop.topo.degeneracy import find_rigid_subchain, fractionation, subchain_deficit
from multiloop.topo.model import chain_from_joint_lists
from tests.common import chains


@given(chains(min_links=3, max_links=10))
def test_exhaustive_and_mincut_agree(m):
    a = find_rigid_subchain(m, "exhaustive")
    b = find_rigid_subchain(m, "mincut")
    assert (a is None) == (b is None)
    for sub in (a, b):
        if sub is not None:
            assert 2 <= len(sub) < m.n_links and subchain_deficit(m, sub) <= 0


def test_two_links_on_two_joints_are_rigid():
    m = chain_from_joint_lists([["a", "b"], ["a", "b"], ["b", "c"], ["c", "d"], ["d", "a"]])
    assert find_rigid_subchain(m) == ("a", "b")


def test_pin_with_three_links_counts_two_pairs():
    # links a, b, c on one pin plus a joint a-b: c(S={a,b}) = 1 + 1 = 2 -> rigid pair
    m = chain_from_joint_lists([["a", "b", "c"], ["a", "b"], ["c", "d"], ["d", "e"], ["e", "a"]])
    assert find_rigid_subchain(m, "exhaustive") == ("a", "b")
    assert find_rigid_subchain(m, "mincut") == ("a", "b")


def test_cut_joint_found():
    # a triple pin shared by two loops is a cut joint
    m = chain_from_joint_lists([["a", "b", "x"], ["b", "c"], ["c", "d"], ["d", "a"],
                                ["x", "y"], ["y", "z"], ["z", "w"], ["w", "x"]])
    fr = fractionation(m)
    assert fr.is_fractionated and fr.cut_joints == ("J1",) and fr.cut_links == ("x",)
