"""Planar embeddings of a chain and its loop assortment [La] (Pozhbelko & Kuts 2020).

The faces of a planar embedding of the link–joint incidence graph are the chain's
loops; a face's **size** is the number of link vertices on its boundary (its number
of links), so the sizes add up to ``SL = Σ i·n_i`` and there are ``L = K + 1`` of
them (Euler).  A chain may have several planar embeddings with different face
sizes (whenever its graph has 2-vertex cuts), so [La] needs a rule to be an
invariant.

Canonical rule (documented in the README and reported by ``analyse``)
---------------------------------------------------------------------
1. Each 2-connected block of the incidence graph is embedded in every possible
   way; the embedding chosen is the one whose **ascending list of face sizes is
   lexicographically smallest** (as many small loops as possible); its largest
   face is the block's outer loop.
2. Blocks of a fractionated chain are joined at their cut vertices in their outer
   loops, so the chain's outer loop ``L0`` is the sum of the blocks' outer loops and
   the inner loops are the blocks' inner loops.
3. ``L0`` is the largest face.  Non-planar chains have no [La].

Every rule above depends only on the graph, so [La] is invariant under relabelling
(tested).  It reproduces the published assortments of Pozhbelko & Kuts 2020 (4-4-5-5-5 for
example 1, 4-4-4-4-13 for the excavator, 4-4-4-9 for the bucket drive).

Method
------
A planar embedding of a 2-connected graph is a set of ``E − V + 2`` simple cycles
covering every edge exactly twice such that at every vertex the faces close into a
single wheel (the rotation).  Degree-2 vertices are suppressed first (a binary link
or simple joint only adds weight to an edge); all simple cycles of the reduced
multigraph are listed, and an exact-cover search (edge with fewest candidates
first) enumerates the face sets.  Two exact filters keep it fast: a cycle can be a
face of *some* embedding only if the graph plus an apex joined to the whole cycle
is still planar, and a face may close the rotation at a vertex only when it
completes it.
"""
from __future__ import annotations

from dataclasses import dataclass

import networkx as nx

from .errors import TopologyError, explain
from .graphs import incidence_graph
from .model import Mechanism

__all__ = ["LoopAssortment", "loop_assortment", "block_embeddings"]

#: search budget per block (number of complete embeddings examined)
MAX_EMBEDDINGS = 200_000


@dataclass(frozen=True, slots=True)
class LoopAssortment:
    """Result of :func:`loop_assortment`.

    Attributes
    ----------
    planar : bool
    sizes : tuple of int or None
        Face sizes in links, ascending (``None`` when non-planar).
    outer : int or None
        ``L0``, the outer loop (largest face).
    n_embeddings : int
        Distinct face-size lists found over all blocks (1 when every embedding of every
        block has the same loop sizes, e.g. a rigidly embedded chain).
    rule : str
        The canonical rule used.
    """

    planar: bool
    sizes: tuple[int, ...] | None
    outer: int | None
    n_embeddings: int = 0
    rule: str = "lexicographically smallest ascending face sizes per block; L0 = largest face"

    def as_code(self) -> str | None:
        """``4-4-5-5-5`` style string."""
        return None if self.sizes is None else "-".join(map(str, self.sizes))


def loop_assortment(m: Mechanism) -> LoopAssortment:
    """Loop assortment [La] of a chain under the canonical rule (module docstring).

    Examples
    --------
    >>> from multiloop.topo.model import chain_from_joint_lists
    >>> watt = [["a", "b"], ["a", "c"], ["c", "d"], ["d", "b"], ["a", "e"], ["e", "f"],
    ...         ["f", "b"]]
    >>> loop_assortment(chain_from_joint_lists(watt)).sizes
    (4, 4, 6)
    """
    g = incidence_graph(m)
    adjacency = {v: list(g[v]) for v in g}
    inner: list[int] = []
    outer_total = 0
    n_emb = 0
    for block in nx.biconnected_components(g):
        if len(block) < 3:           # a bridge: no face of its own
            continue
        sub = {v: [w for w in adjacency[v] if w in block] for v in block}
        best = _best_block_faces(sub)
        if best is None:
            return LoopAssortment(False, None, None, n_emb)
        faces, count = best
        n_emb += count
        faces = sorted(faces)
        outer_total += faces[-1]
        inner.extend(faces[:-1])
    # bridges (dangling links) add their link corners to the outer face
    corners_in_blocks = sum(inner) + outer_total
    total_corners = sum(1 for u, v in g.edges())  # every incidence is one link corner
    outer_total += total_corners - corners_in_blocks
    if outer_total == 0 and not inner:
        return LoopAssortment(True, (), None, n_emb)
    sizes = tuple(sorted(inner + [outer_total]))
    return LoopAssortment(True, sizes, max(sizes), n_emb)


def _is_link(v) -> bool:
    return v[0] == "L"


def _reduce(block):
    """Suppress degree-2 vertices: reduced vertices, edges (u, v, weight, interior)
    where weight is the number of link vertices strictly inside the path.  ``block``
    is an adjacency mapping (vertex -> neighbours)."""
    deg = {v: len(nb) for v, nb in block.items()}
    keep = [v for v in block if deg[v] >= 3]
    keep_set = set(keep)
    edges = []
    seen_paths = set()
    for u in keep:
        for nb in block[u]:
            prev, cur, weight, path = u, nb, 0, [u, nb]
            while cur not in keep_set:
                if _is_link(cur):
                    weight += 1
                nxt = [w for w in block[cur] if w != prev][0]
                prev, cur = cur, nxt
                path.append(cur)
            key = tuple(path) if (path[0], path[1]) < (path[-1], path[-2]) else tuple(reversed(path))
            if key in seen_paths:
                continue
            seen_paths.add(key)
            edges.append((u, cur, weight, tuple(path[1:-1])))
    return keep, edges


def _simple_cycles(vertices, edges):
    """All simple cycles of a multigraph as (edge bitmask, vertex tuple)."""
    index = {v: i for i, v in enumerate(vertices)}
    adj: dict[int, list[tuple[int, int]]] = {i: [] for i in range(len(vertices))}
    for e, (u, v, *_rest) in enumerate(edges):
        adj[index[u]].append((index[v], e))
        adj[index[v]].append((index[u], e))
    cycles = []
    for s in range(len(vertices)):
        # paths from s through vertices > s, closing back at s
        stack = [(s, 0, (s,), -1)]
        while stack:
            v, mask, path, last_e = stack.pop()
            for w, e in adj[v]:
                if e == last_e or (mask >> e) & 1:
                    continue
                if w == s:
                    if path != (s,):      # (s,) would be a self-loop: none in a block
                        cycles.append((mask | (1 << e), path))
                    continue
                if w < s or w in path:
                    continue
                stack.append((w, mask | (1 << e), path + (w,), e))
    # each cycle found twice (both directions): dedupe by edge mask
    unique = {}
    for mask, path in cycles:
        unique.setdefault(mask, path)
    return list(unique.items())


def _reduced_graph(n_keep: int, edges, subdivide: int = 0) -> nx.Graph:
    """The reduced block as a simple graph (planarity is unchanged by suppressing
    degree-2 vertices and merging parallel paths); reduced edges in the bit mask
    ``subdivide`` keep one subdivision vertex so that they stay distinct."""
    g = nx.Graph()
    g.add_nodes_from(range(n_keep))
    for e, (u, v, *_r) in enumerate(edges):
        if (subdivide >> e) & 1:
            g.add_edge(u, ("s", e))
            g.add_edge(("s", e), v)
        else:
            g.add_edge(u, v)
    return g


def _can_be_face(n_keep: int, edges, mask: int, path) -> bool:
    """Cycle C is a face of some planar embedding iff the graph plus an apex joined to
    every vertex of C is planar (the apex sits inside the face)."""
    g = _reduced_graph(n_keep, edges, mask)
    apex = ("apex",)
    g.add_edges_from((apex, v) for v in path)
    g.add_edges_from((apex, ("s", e)) for e in range(len(edges)) if (mask >> e) & 1)
    return nx.check_planarity(g)[0]


class _BudgetExceeded(Exception):
    pass


def block_embeddings(block: nx.Graph, limit: int = MAX_EMBEDDINGS, use_filter: bool = True,
                     node_budget: int | None = None):
    """Yield the distinct face-size lists of the planar embeddings of a 2-connected block.

    Raises ``TopologyError`` rather than truncate when the block has more than ``limit``
    embeddings (a minimum over part of them would not be an invariant).

    Every embedding is enumerated; each yielded value is a sorted tuple of face sizes
    (in links), and embeddings with the same sizes are yielded once.  ``use_filter``
    applies the apex planarity test to every cycle first (slower per cycle, but it
    keeps dense blocks tractable); ``node_budget`` aborts the search with
    ``_BudgetExceeded`` after that many search nodes.
    """
    if isinstance(block, nx.Graph):
        block = {v: list(block[v]) for v in block}
    keep, edges = _reduce(block)
    if not keep:   # the block is a single cycle
        s = sum(1 for v in block if _is_link(v))
        yield (s, s)
        return
    n_faces = len(edges) - len(keep) + 2
    kidx = {v: i for i, v in enumerate(keep)}
    idx_edges = [(kidx[u], kidx[v]) for u, v, *_r in edges]
    if len(keep) > 4 and not nx.check_planarity(_reduced_graph(len(keep), idx_edges))[0]:
        return   # (every graph on at most 4 vertices is planar)
    cycles = _simple_cycles(keep, edges)
    vertex_edges = {v: [] for v in keep}
    for e, (u, v, *_rest) in enumerate(edges):
        vertex_edges[u].append(e)
        vertex_edges[v].append(e)
    # size of a cycle in links: interior link vertices of its edges + link vertices of the cycle
    sizes = []
    masks = []
    verts = []
    for mask, path in cycles:
        if use_filter and not _can_be_face(len(keep), idx_edges, mask, path):
            continue
        w = sum(edges[e][2] for e in range(len(edges)) if (mask >> e) & 1)
        w += sum(1 for v in path if _is_link(keep[v]))
        sizes.append(w)
        masks.append(mask)
        verts.append(path)
    n_edges = len(edges)
    by_edge: list[list[int]] = [[] for _ in range(n_edges)]
    for c, mask in enumerate(masks):
        for e in range(n_edges):
            if (mask >> e) & 1:
                by_edge[e].append(c)
    for lst in by_edge:
        lst.sort(key=lambda c: sizes[c])
    count = 0
    # corners of every cycle: (vertex, edge in, edge out) at each reduced vertex
    cycle_corners = []
    for c, path in enumerate(verts):
        mask = masks[c]
        cs = []
        for v_idx in path:
            v = keep[v_idx]
            pair = [e for e in vertex_edges[v] if (mask >> e) & 1]
            if len(pair) == 2:
                cs.append((v_idx, pair[0], pair[1]))
            else:   # two parallel edges closing a 2-cycle both sit at v: pair has 2 entries
                cs.append((v_idx, pair[0], pair[-1]))
        cycle_corners.append(cs)
    degree = [len(vertex_edges[v]) for v in keep]
    # partner[v][e] = edges joined to e by corners chosen so far at v
    partner: list[dict[int, list[int]]] = [{e: [] for e in vertex_edges[v]} for v in keep]

    def path_end(v_idx: int, start: int) -> tuple[int, int]:
        """Follow corners from edge ``start`` at vertex v; return (end edge, edges seen)."""
        prev, cur, seen = -1, start, 1
        while True:
            nxt = [e for e in partner[v_idx][cur] if e != prev]
            if not nxt:
                return cur, seen
            prev, cur = cur, nxt[0]
            seen += 1
            if cur == start:
                return cur, seen - 1

    def corners_ok(c: int) -> bool:
        """Adding cycle c must not close a wheel early at any vertex."""
        for v_idx, e1, e2 in cycle_corners[c]:
            if degree[v_idx] < 3:
                continue
            end, seen = path_end(v_idx, e1)
            if end == e2 and seen < degree[v_idx]:
                return False
        return True

    def add(c: int) -> None:
        for v_idx, e1, e2 in cycle_corners[c]:
            partner[v_idx][e1].append(e2)
            partner[v_idx][e2].append(e1)

    def remove(c: int) -> None:
        for v_idx, e1, e2 in cycle_corners[c]:
            partner[v_idx][e1].remove(e2)
            partner[v_idx][e2].remove(e1)

    full = (1 << n_edges) - 1
    # lower[e] = index of the first face chosen *for* edge e while e was uncovered:
    # the other face through e must have a larger index, so every face set is
    # reached along exactly one branch.
    lower = [-1] * n_edges

    cycle_edges = [tuple(e for e in range(n_edges) if (mk >> e) & 1) for mk in masks]

    def allowed(c: int, used1: int) -> bool:
        for e in cycle_edges[c]:
            if c <= lower[e] and (used1 >> e) & 1:
                return False
        return True

    nodes = 0

    def search(used1: int, used2: int, chosen: list[int]):
        nonlocal count, nodes
        if count >= limit:   # the minimum over a truncated enumeration is not canonical
            raise TopologyError(explain(
                "loop assortment", expected=f"at most {limit} planar embeddings of a block",
                got="more", hint="[La] cannot be chosen canonically here; use loops=False"))
        nodes += 1
        if node_budget is not None and nodes > node_budget:
            raise _BudgetExceeded
        if used2 == full or len(chosen) == n_faces:
            # every edge twice and no wheel closed early: each rotation is one cycle
            if used2 == full and len(chosen) == n_faces:
                count += 1
                yield tuple(sorted(sizes[c] for c in chosen))
            return
        best_e, best_opts = -1, None
        once = used1 & ~used2
        # edges covered once need exactly one more face: most constrained, look there first
        for e in (range(n_edges) if not once else [e for e in range(n_edges) if (once >> e) & 1]):
            if (used2 >> e) & 1:
                continue
            opts = [c for c in by_edge[e] if not (masks[c] & used2) and allowed(c, used1)]
            if best_opts is None or len(opts) < len(best_opts):
                best_e, best_opts = e, opts
                if len(opts) <= 1:
                    break
        if not best_opts:
            return
        best_opts = [c for c in best_opts if corners_ok(c)]
        uncovered = not (used1 >> best_e) & 1
        for c in best_opts:
            mask = masks[c]
            chosen.append(c)
            add(c)
            if uncovered:
                lower[best_e] = c
            yield from search(used1 | mask, used2 | (mask & used1), chosen)
            if uncovered:
                lower[best_e] = -1
            remove(c)
            chosen.pop()

    seen = set()
    for faces in search(0, 0, []):
        if faces not in seen:
            seen.add(faces)
            yield faces


#: search nodes allowed to the unfiltered search before the apex filter is switched on
NODE_BUDGET = 2_000


def _best_block_faces(block) -> tuple[list[int], int] | None:
    """Canonical face sizes of a block and the number of embeddings, or None when the
    block is not planar (tested on the reduced graph first)."""
    try:
        found = list(block_embeddings(block, use_filter=False, node_budget=NODE_BUDGET))
    except _BudgetExceeded:
        found = list(block_embeddings(block, use_filter=True))
    if not found:
        return None
    return list(min(found)), len(found)
