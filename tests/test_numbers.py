"""Structural numbers (Pozhbelko & Kuts 2020): published oracles, cross-checks by two/three routes,
relabelling invariance."""
from __future__ import annotations

import pytest
from hypothesis import given, strategies as st

from multiloop.topo.model import chain_from_joint_lists
from multiloop.topo.numbers import format_counts, spatial_mobility, structural_report
from tests.common import chains, relabel

# Structures of the Pozhbelko & Kuts 2020 examples, written as bare chains (the catalogue files add
# geometry; see tests/test_catalogue.py).  Published values: V. A. Pozhbelko,
# E. N. Kuts (2020), examples 1-4 and the fig. 9 remark (the structural numbers (README) table).
EXCAVATOR = [["fr", "boom"], ["fr", "c1b"], ["c1b", "c1r"], ["c1r", "boom"], ["boom", "c2b"],
             ["c2b", "c2r"], ["c2r", "st"], ["boom", "st"], ["st", "c3b"], ["c3b", "c3r"],
             ["c3r", "rk", "cl"], ["st", "rk"], ["cl", "bk"], ["st", "bk"]]
RADIAL_5 = ([["fr", "crank"], ["crank"] + [f"rod{i}" for i in range(5)]]
            + [[f"rod{i}", f"pis{i}"] for i in range(5)] + [["fr", f"pis{i}"] for i in range(5)])
# crank + four RRR dyads, three pins joining three links (example 1)
KNITTING = [["fr", "crank"], ["crank", "l2"], ["l2", "l3", "l4"], ["l3", "fr"],
            ["l4", "l5", "l6"], ["l5", "fr"], ["l6", "l7", "l8"], ["l7", "fr"],
            ["l8", "l9"], ["l9", "l3"]]


def test_format_counts_seed_examples():
    # Pozhbelko & Kuts 2020: codes [8110], [11.0001], [10.011], [8001]
    assert format_counts([8, 1, 1, 0]) == "8110"
    assert format_counts([11, 0, 0, 0, 1]) == "11.0001"
    assert format_counts([10, 0, 1, 1]) == "10.011"
    assert format_counts([8, 0, 0, 1]) == "8001"
    assert format_counts([0, 0, 0, 1], sep="-") == "0-0-0-1"


def test_excavator_structure_matches_seed_example_3():
    # Pozhbelko & Kuts 2020, example 3: n=12, [LA] n2=10 n4=1 n5=1, V2=1, K=4, L=5, F=3,
    # SL=29, [La] 4-4-4-4-13 (L0 = 13), code [10.011]/1
    r = structural_report(chain_from_joint_lists(EXCAVATOR), n_drivers=3)
    assert (r.n, r.LA, r.MJA, r.V, r.K, r.L, r.F, r.SL) == (12, (10, 0, 1, 1), (1,), 1, 4, 5, 3, 29)
    assert r.La == (4, 4, 4, 4, 13) and r.L0 == 13
    assert r.code == "[10.011]/1" and r.rc == 0
    assert r.consistent and not r.degenerate
    # its loops hang in series: boom and stick are cut links (a fractionated chain),
    # and L0 = 13 is the sum of the outer loops of the three blocks (4 + 4 + 5)
    assert r.fractionated and set(r.cut_links) == {"boom", "st"}


def test_radial_engine_structure_matches_seed_example_2():
    # Pozhbelko & Kuts 2020, example 2: n=12, n2=11 n6=1, V5=1, V=4, K=5, L=6, F=1, SL=28,
    # [La] 4-4-5-5-5-5, code [11.0001]/4, code* [11.0001]/[0-0-0-1]
    r = structural_report(chain_from_joint_lists(RADIAL_5), n_drivers=1)
    assert (r.n, r.LA, r.MJA, r.V, r.K, r.L, r.F, r.SL) == (12, (11, 0, 0, 0, 1), (0, 0, 0, 1), 4, 5, 6, 1, 28)
    assert r.La == (4, 4, 5, 5, 5, 5)
    assert r.code == "[11.0001]/4" and r.code_star == "[11.0001]/[0-0-0-1]"
    assert r.rc == 0 and r.existence_ok


def test_knitting_structure_matches_seed_example_1():
    # Pozhbelko & Kuts 2020, example 1: n=10, n2=8 n3=1 n4=1, V2=3, K=4, L=5, F=1, SL=23
    # (the seed prints 2·8 + 3·3 + 4·1 by a typo), [La] 4-4-5-5-5 (L0=5), code [8110]/3
    r = structural_report(chain_from_joint_lists(KNITTING), n_drivers=1)
    assert (r.n, r.LA, r.MJA, r.V, r.K, r.L, r.F, r.SL) == (10, (8, 1, 1), (3,), 3, 4, 5, 1, 23)
    assert r.code == "[8110]/3" and r.code_star == "[8110]/[3-0-0]"
    assert r.La == (4, 4, 5, 5, 5) and r.L0 == 5


def test_four_bar_designer_redundancy_in_space():
    fb = chain_from_joint_lists([["a", "b"], ["b", "c"], ["c", "d"], ["d", "a"]])
    assert spatial_mobility(fb, 3) == 1
    # a planar four-bar built with revolute pairs in space: F6 = -2, so 3 redundant
    # constraints for the designer (Dobrovolsky/Malyshev count)
    assert spatial_mobility(fb, 6) == -2
    r = structural_report(fb, n_drivers=1, lam=6)
    assert r.rc_space == 3


def test_watt_and_stephenson_are_different():
    watt = chain_from_joint_lists([["a", "b"], ["a", "c"], ["c", "d"], ["d", "b"], ["a", "e"], ["e", "f"], ["f", "b"]])
    steph = chain_from_joint_lists([["a", "b"], ["b", "c"], ["c", "d"], ["d", "a"], ["a", "e"], ["e", "f"], ["f", "c"]])
    rw, rs = structural_report(watt), structural_report(steph)
    assert rw.LA == rs.LA == (4, 2) and rw.F == rs.F == 1
    assert rw.La == (4, 4, 6) and rs.La == (4, 5, 5)
    assert rw.canonical != rs.canonical


def test_degenerate_chain_named():
    # a triangle (rigid) inside a five-link chain
    m = chain_from_joint_lists([["a", "b"], ["b", "c"], ["c", "a"], ["a", "d"], ["d", "e"], ["e", "c"]])
    r = structural_report(m)
    assert r.degenerate and set(r.rigid_subchain) == {"a", "b", "c"}


def test_fractionated_named():
    m = chain_from_joint_lists([["a", "b"], ["b", "c"], ["c", "d"], ["d", "a"],
                                ["a", "e"], ["e", "f"], ["f", "g"], ["g", "a"]])
    r = structural_report(m)
    assert r.fractionated and r.cut_links == ("a",)
    assert sum(r.La) == r.SL and len(r.La) == r.L


def test_existence_domain_violation_reported():
    # a 4-multiple pin (j = 3) in a chain with K = 2 < j
    m = chain_from_joint_lists([["a", "b", "c", "d"], ["a", "e"], ["b", "e"], ["c", "f"], ["d", "f"]])
    r = structural_report(m)
    assert r.j_max == 3
    assert r.existence_ok == (r.j_max <= r.K and r.V <= 2 * (r.K - 1))
    # n = 6, p = 3 + 4 = 7, K = 2 < j = 3: outside the domain (Pozhbelko & Kuts 2020 fig. 10)
    assert r.K == 2 and not r.existence_ok


def test_dangling_link_gives_nonzero_avc():
    m = chain_from_joint_lists([["a", "b"], ["b", "c"], ["c", "a"], ["c", "d"]])
    r = structural_report(m)
    assert r.dangling == ("d",) and r.AVC != 0 and not r.consistent
    assert any("fewer than two joints" in w for w in r.warnings)


@given(chains())
def test_routes_agree_on_random_chains(m):
    r = structural_report(m)
    # K by the graph and by the seed formula; F by three routes; SL by two routes;
    # rc by the paper's definition and as N - F
    assert r.K == r.K_formula
    assert r.AVC == 0
    assert r.F_routes[0] == r.F_routes[1] == r.F_routes[2]
    assert r.SL == r.SL_formula
    assert r.rc == r.rc_formula
    if r.planar:
        assert sum(r.La) == r.SL and len(r.La) == r.L and r.L0 == max(r.La)


@given(chains(), st.integers(0, 10 ** 6))
def test_every_number_invariant_under_relabelling(m, seed):
    a = structural_report(m).as_dict()
    b = structural_report(relabel(m, seed)).as_dict()
    for key in ("rigid_subchain", "cut_links", "cut_joints", "name", "warnings"):
        a.pop(key), b.pop(key)
    assert a == b


def test_embedding_search_with_and_without_apex_filter_agree():
    # two routes to the set of planar embeddings of every block: the plain exact-cover
    # search, and the search restricted to cycles that pass the apex-planarity test
    import random

    import networkx as nx

    from multiloop.topo.graphs import incidence_graph
    from multiloop.topo.loops import block_embeddings
    from tests.common import random_joint_lists

    rng = random.Random(11)
    checked = 0
    for _ in range(60):
        m = chain_from_joint_lists(random_joint_lists(rng, rng.randint(5, 10), rng.randint(1, 5), 0.3))
        g = incidence_graph(m)
        for block in nx.biconnected_components(g):
            if len(block) < 3:
                continue
            sub = g.subgraph(block)
            plain = sorted(set(block_embeddings(sub, use_filter=False)))
            filtered = sorted(set(block_embeddings(sub, use_filter=True)))
            assert plain == filtered
            assert bool(plain) == nx.check_planarity(sub)[0]
            checked += 1
    assert checked > 50


def test_parallelogram_with_redundant_link_is_reported_as_moving():
    # the structural numbers (README): a parallelogram with a redundant link has F = 0 by formula but moves;
    # the report gives the actual mobility from the Jacobian rank and names the pair
    from multiloop.topo.io import loads

    from tests.common import PARALLELOGRAM

    r = structural_report(loads(PARALLELOGRAM))
    assert r.F == 0 and r.actual_F == 1 and r.rc == 1
    assert r.redundant and any("moves with 1 DOF" in w for w in r.warnings)


def test_embedding_search_refuses_to_truncate():
    # a chain with two planar embeddings of different loop sizes (3-4-5-8 vs 3-5-5-7)
    # must not get a "canonical" [La] from a truncated enumeration
    import networkx as nx

    from multiloop.topo.errors import TopologyError
    from multiloop.topo.graphs import incidence_graph
    from multiloop.topo.loops import block_embeddings

    m = chain_from_joint_lists([["l6", "l3"], ["l3", "l1"], ["l1", "l0"], ["l0", "l7"], ["l7", "l2"],
                                ["l2", "l5"], ["l5", "l4"], ["l4", "l6"], ["l1", "l6"], ["l0", "l4"]])
    g = incidence_graph(m)
    (block,) = [b for b in nx.biconnected_components(g) if len(b) > 2]
    assert len(set(block_embeddings(g.subgraph(block)))) == 2
    with pytest.raises(TopologyError, match="cannot be chosen canonically"):
        list(block_embeddings(g.subgraph(block), limit=1))
