"""Rigid sub-chains by two exact routes (exhaustive bit masks vs minimum cut)."""
from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from multiloop.topo.degeneracy import find_rigid_subchain, fractionation, rigid_subset_mask, subchain_deficit
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


@given(st.integers(2, 9).flatmap(lambda n: st.tuples(
    st.just(n), st.lists(st.sets(st.integers(0, n - 1), min_size=2, max_size=4), min_size=1, max_size=2 * n))))
def test_subset_transform_matches_the_definition(case):
    """rigid_subset_mask (NumPy, all subsets at once) against a pure-Python count of c(S),
    subset by subset."""
    n, joints = case
    masks = [sum(1 << i for i in j) for j in joints]

    def deficit(S):
        c = sum(max(0, bin(S & jm).count("1") - 1) for jm in masks)
        return 3 * (bin(S).count("1") - 1) - 2 * c
    rigid = [S for S in range(1 << n) if 2 <= bin(S).count("1") < n and deficit(S) <= 0]
    expected = min(rigid, key=lambda S: (bin(S).count("1"), S)) if rigid else None
    assert rigid_subset_mask(n, masks) == expected


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


@given(chains(min_links=3, max_links=10, multiple=False))
def test_mincut_pair_pruning_is_exact(m):
    # the min-cut route decides existence on the pairs with a non-plain link only
    # (topo.degeneracy._link_pairs); the full pair set and the definition must agree
    from multiloop.topo.degeneracy import _cut_network, _link_pairs, _mincut_search

    net = _cut_network(m)
    pruned = _mincut_search(m, _link_pairs(m, skip_plain=True), net)
    full = _mincut_search(m, _link_pairs(m, skip_plain=False), net)
    assert (pruned is None) == (full is None) == (find_rigid_subchain(m, "exhaustive") is None)


def test_long_ring_and_ring_with_triangle():
    # a 40-link single loop has no rigid sub-chain; a triangle hung on it is one
    ring = [[f"l{i}", f"l{(i + 1) % 40}"] for i in range(40)]
    assert find_rigid_subchain(chain_from_joint_lists(ring)) is None
    tri = ring + [["l0", "t1"], ["t1", "t2"], ["t2", "l0"], ["l0", "t2"]]
    found = find_rigid_subchain(chain_from_joint_lists(tri))
    assert found is not None and subchain_deficit(chain_from_joint_lists(tri), found) <= 0


@given(chains(min_links=3, max_links=10))
def test_fractionation_matches_networkx_articulation_points(m):
    # rustworkx's articulation points (topo.degeneracy) vs networkx's on the incidence graph
    import networkx as nx

    from multiloop.topo.graphs import incidence_graph

    arts = set(nx.articulation_points(incidence_graph(m)))
    fr = fractionation(m)
    assert set(fr.cut_links) == {v[1] for v in arts if v[0] == "L"}
    assert set(fr.cut_joints) == {v[1] for v in arts if v[0] == "J"}


# ------------------------------------------------------------------ the pebble game
@given(chains(min_links=3, max_links=12))
def test_pebble_game_agrees_with_the_definition(m):
    """Pebble game (Jacobs & Hendrickson 1997) vs the exhaustive count, multiple joints
    included: the same verdict, and a subset it names breaks the count."""
    from multiloop.topo.pebble import rigid_links
    truth = find_rigid_subchain(m, "exhaustive")
    found = rigid_links(m)
    if found is None:
        assert truth is None
    elif found != "unknown":
        assert 2 <= len(found) < m.n_links and subchain_deficit(m, found) <= 0
        assert truth is not None
    got = find_rigid_subchain(m, "pebble")
    assert (got is None) == (truth is None)
    if got is not None:
        assert 2 <= len(got) < m.n_links and subchain_deficit(m, got) <= 0
    assert find_rigid_subchain(m) == truth          # auto names the exhaustive subset


@given(chains(min_links=3, max_links=12))
def test_pebble_game_keeps_laman_counts(m):
    """After the game: free pebbles = 2|V| − independent bars >= 3, and every bar is
    covered by a pebble of one of its ends (the invariants of the (2, 3) game)."""
    from multiloop.topo.pebble import PebbleGame, link_bars
    bars = link_bars(m)
    if bars is None:
        return
    g = PebbleGame(m.n_joints)
    accepted = [(a, b) for a, b, _ in bars if g.insert(a, b)]
    assert sum(g.pebbles) == 2 * m.n_joints - len(accepted) >= 3
    covered = sorted(tuple(sorted((u, w))) for u in range(m.n_joints) for w in g.out[u])
    assert covered == sorted(tuple(sorted(e)) for e in accepted)


def test_pebble_game_on_the_catalogue_and_an_atlas():
    """No catalogue chain and none of the 230 (n = 10, F = 1) chains without multiple
    joints is degenerate by the pebble game exactly when the min-cut route says so."""
    from multiloop.catalogue.named import load_named, names
    from multiloop.topo.pebble import rigid_links
    for name in names():
        m = load_named(name)
        assert (rigid_links(m) is None) == (find_rigid_subchain(m, "mincut") is None), name
