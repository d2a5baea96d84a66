"""Loop assortment [La]: special cases of the canonical rule (Pozhbelko & Kuts 2020)."""
from __future__ import annotations

from multiloop.topo.loops import loop_assortment
from multiloop.topo.model import chain_from_joint_lists
from multiloop.topo.numbers import structural_report


def test_loopless_chains_have_no_loop():
    # two links on one joint: K = 0, no loop (it used to report [La] = 2 with L0 = 2)
    la = loop_assortment(chain_from_joint_lists([["a", "b"]]))
    assert la.planar and la.sizes == () and la.outer is None
    r = structural_report(chain_from_joint_lists([["a", "b"], ["b", "c"]]))
    assert r.K == 0 and r.La == () and r.L0 is None


def test_single_loop_and_dangling_link():
    # a four-bar loop: inner and outer face of four links each
    assert loop_assortment(chain_from_joint_lists([["a", "b"], ["b", "c"], ["c", "d"], ["d", "a"]])).sizes == (4, 4)
    # a triangle with a dangling link: its joint adds two link corners (c again, d) to the outer loop
    la = loop_assortment(chain_from_joint_lists([["a", "b"], ["b", "c"], ["c", "a"], ["c", "d"]]))
    assert la.sizes == (3, 5) and la.outer == 5


def test_planarity_of_multigraphs_does_not_depend_on_edge_order():
    """rustworkx 0.18's is_planar answered "not planar" for this planar multigraph (the
    apex test of a face of a block with parallel edges 3–7) in one edge order; the
    [La] filter then lost an embedding, depending on the hash seed.  _planar merges
    parallel edges first; compared with networkx on the subdivided graph in 50 orders."""
    import random

    import networkx as nx

    from multiloop.topo.loops import _planar
    pairs = ((0, 6), (0, 4), (0, 6), (1, 4), (1, 3), (1, 5), (2, 7), (2, 6), (2, 4), (3, 7), (3, 5),
             (3, 4), (3, 6), (3, 7), (5, 6))
    face, path, apex = 16427, (0, 6, 5, 1, 4), 8 + len(pairs)
    edges = [x for e, (u, v) in enumerate(pairs) for x in
             ([(u, 8 + e), (8 + e, v), (apex, 8 + e)] if face >> e & 1 else [(u, v)])]
    edges += [(apex, v) for v in path]
    rng = random.Random(0)
    for _ in range(50):
        order = rng.sample(edges, len(edges))
        simple = nx.Graph([(u, ("s", i)) for i, (u, v) in enumerate(order)] +
                          [(("s", i), v) for i, (u, v) in enumerate(order)])
        assert _planar(apex + 1, order) is nx.check_planarity(simple)[0] is True


def test_branch_and_bound_minimum_equals_the_full_enumeration():
    # two routes to the canonical face sizes of every block: the minimum over all
    # embeddings (block_embeddings) and the branch-and-bound search (loop_assortment)
    import random

    import networkx as nx

    from multiloop.topo.graphs import incidence_graph
    from multiloop.topo.loops import _minimum_faces, block_embeddings
    from tests.common import random_joint_lists

    rng = random.Random(5)
    checked = 0
    for _ in range(80):
        m = chain_from_joint_lists(random_joint_lists(rng, rng.randint(5, 12), rng.randint(1, 6), 0.3))
        g = incidence_graph(m)
        for block in nx.biconnected_components(g):
            if len(block) < 3:
                continue
            sub = {v: list(g.subgraph(block)[v]) for v in block}
            full = set(block_embeddings(sub, use_filter=False))
            for use_filter in (False, True):
                for whitney in (False, True):   # the 3-connected shortcut (Whitney) and without
                    best, _ = _minimum_faces(sub, use_filter, whitney=whitney)
                    assert best == (min(full) if full else None)
            checked += 1
    assert checked > 60


def test_three_connected_blocks_have_one_embedding():
    # Whitney: a 3-connected planar graph has one embedding; K4 as a chain of ternary links
    from multiloop.topo.graphs import incidence_graph
    from multiloop.topo.loops import _reduced_block, _three_connected

    k4 = [["a", "b"], ["a", "c"], ["a", "d"], ["b", "c"], ["b", "d"], ["c", "d"]]
    g = incidence_graph(chain_from_joint_lists(k4))
    rb = _reduced_block({v: list(g[v]) for v in g})
    assert _three_connected(rb)
    assert len(set(block_embeddings_of(k4))) == 1
    ring = [["a", "b"], ["b", "c"], ["c", "d"], ["d", "a"], ["a", "c"]]
    g = incidence_graph(chain_from_joint_lists(ring))
    assert not _three_connected(_reduced_block({v: list(g[v]) for v in g}))


def block_embeddings_of(joints):
    from multiloop.topo.graphs import incidence_graph
    from multiloop.topo.loops import block_embeddings

    g = incidence_graph(chain_from_joint_lists(joints))
    return block_embeddings({v: list(g[v]) for v in g})


def test_strip_of_quadrilaterals():
    # the catalogue's 24-link chain (Pozhbelko & Kuts 2020): eleven quadrilaterals and
    # the outer loop of 22 links
    from multiloop.catalogue.named import load_named

    assert loop_assortment(load_named("linkage_24")).sizes == (4,) * 11 + (22,)


def test_cycle_lists_three_routes():
    # the path search, the cycle space and networkx's simple_cycles list the same cycles
    import random

    import networkx as nx

    from multiloop.topo.graphs import incidence_graph
    from multiloop.topo.loops import _reduce, _simple_cycles_dfs, _simple_cycles_nx, _simple_cycles_space
    from multiloop.catalogue.named import load_named
    from tests.common import random_joint_lists

    rng = random.Random(3)
    chains = [chain_from_joint_lists(random_joint_lists(rng, rng.randint(4, 12), rng.randint(1, 6), 0.3))
              for _ in range(40)]
    for m in chains + [load_named("linkage_24")]:          # its block: 20 vertices, 66 cycles
        g = incidence_graph(m)
        for block in nx.biconnected_components(g):
            if len(block) >= 3:
                keep, edges = _reduce({v: list(g.subgraph(block)[v]) for v in block})
                a = {mask: set(p) for mask, p in _simple_cycles_dfs(keep, edges)}
                b = {mask: set(p) for mask, p in _simple_cycles_nx(keep, edges)}
                c = {mask: set(p) for mask, p in _simple_cycles_space(keep, edges)}
                assert a == b == c


def test_faces_of_three_connected_blocks_two_routes():
    # Tutte 1963: the faces of a 3-connected planar graph are its peripheral cycles;
    # against the faces read off networkx's embedding and the full enumeration
    import random

    import networkx as nx

    from multiloop.topo.graphs import incidence_graph
    from multiloop.topo.loops import (_embedding_faces, _peripheral_faces, _planar, _reduced_block,
                                      _three_connected, block_embeddings)
    from tests.common import random_joint_lists

    rng = random.Random(11)
    checked = 0
    for _ in range(300):
        m = chain_from_joint_lists(random_joint_lists(rng, rng.randint(6, 14), rng.randint(1, 6), 0.3))
        g = incidence_graph(m)
        for block in nx.biconnected_components(g):
            sub = {v: list(g.subgraph(block)[v]) for v in block}
            rb = _reduced_block(sub)
            if len(rb.keep) < 4 or not _three_connected(rb) or not _planar(len(rb.keep), rb.pairs):
                continue
            faces = _peripheral_faces(rb)
            assert faces == _embedding_faces(rb)
            assert {faces} == set(block_embeddings(sub, use_filter=False))
            checked += 1
    assert checked >= 20
