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
from operator import itemgetter

import networkx as nx
import numpy as np
import rustworkx as rx

from .errors import TopologyError, explain
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
        Complete embeddings examined over all blocks by the branch-and-bound search
        (1 for a block with a single embedding).
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

    A chain without a cycle (``K = 0``, e.g. two links on one joint) has no loops:
    ``sizes == ()`` and ``outer is None``.

    Examples
    --------
    >>> from multiloop.topo.model import chain_from_joint_lists
    >>> watt = [["a", "b"], ["a", "c"], ["c", "d"], ["d", "b"], ["a", "e"], ["e", "f"],
    ...         ["f", "b"]]
    >>> loop_assortment(chain_from_joint_lists(watt)).sizes
    (4, 4, 6)
    >>> la = loop_assortment(chain_from_joint_lists([["a", "b"]]))
    >>> la.sizes, la.outer
    ((), None)
    """
    adjacency = _incidence_adjacency(m)
    blocks = _blocks(adjacency)
    if not blocks:                   # a tree: no loop at all
        return LoopAssortment(True, (), None, 0)
    inner: list[int] = []
    outer_total = 0
    n_emb = 0
    for block in blocks:
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
    total_corners = sum(len(j.links) for j in m.joints)   # every incidence is one link corner
    outer_total += total_corners - (sum(inner) + outer_total)
    sizes = tuple(sorted(inner + [outer_total]))
    return LoopAssortment(True, sizes, max(sizes), n_emb)


def _incidence_adjacency(m: Mechanism) -> dict[tuple, list[tuple]]:
    """The link–joint incidence graph (:func:`topo.graphs.incidence_graph`) as a plain
    adjacency mapping (no attributes: the search only needs the structure)."""
    adj: dict[tuple, list[tuple]] = {("L", x): [] for x in m.link_names}
    for j in m.joints:
        jv = ("J", j.name)
        adj[jv] = [("L", x) for x in j.links]
        for x in j.links:
            adj[("L", x)].append(jv)
    return adj


def _blocks(adjacency) -> list[set]:
    """Vertex sets of the 2-connected blocks with a cycle (three or more vertices)."""
    index = {v: i for i, v in enumerate(adjacency)}
    order = list(adjacency)
    g = rx.PyGraph(multigraph=False)
    g.add_nodes_from(range(len(order)))
    g.add_edges_from_no_data([(index[u], index[v]) for u in adjacency for v in adjacency[u]
                              if index[u] < index[v]])
    comps: dict[int, set] = {}
    for (a, b), c in rx.biconnected_components(g).items():
        comps.setdefault(c, set()).update((order[a], order[b]))
    return [b for _, b in sorted(comps.items()) if len(b) >= 3]


def _planar(n: int, edges) -> bool:
    """Planarity of a (multi)graph on vertices ``0 … n−1`` (rustworkx's compiled
    left-right test; the same answer as networkx's ``check_planarity``).  Parallel
    edges never change planarity and are merged first: rustworkx 0.18's test can
    answer "not planar" for a planar multigraph, depending on the edge order."""
    g = rx.PyGraph(multigraph=False)
    g.add_nodes_from(range(n))
    g.add_edges_from_no_data(list(edges))
    return rx.is_planar(g)


def _is_link(v) -> bool:
    return v[0] == "L"


@dataclass(frozen=True, slots=True)
class _ReducedBlock:
    """A block with its degree-2 vertices suppressed.

    ``keep`` are the vertices of degree >= 3; ``edges[e] = (u, v, weight, interior)``
    with ``weight`` the number of link vertices strictly inside the suppressed path;
    ``pairs[e]`` is the same edge between indices into ``keep``.
    """

    keep: tuple
    edges: tuple
    pairs: tuple[tuple[int, int], ...]

    @property
    def n_faces(self) -> int:
        """Faces of every embedding (Euler): ``E − V + 2``."""
        return len(self.edges) - len(self.keep) + 2


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


def _reduced_block(block) -> _ReducedBlock:
    keep, edges = _reduce(block)
    kidx = {v: i for i, v in enumerate(keep)}
    return _ReducedBlock(tuple(keep), tuple(edges), tuple((kidx[u], kidx[v]) for u, v, *_r in edges))


#: reduced blocks with more vertices list their cycles with networkx (output-sensitive)
DFS_CYCLES_MAX = 10


#: larger blocks with at most this cyclomatic number (and 64 edges) list their cycles
#: from the cycle space (2**beta elements, vectorised)
CYCLE_SPACE_MAX = 14


def _simple_cycles(vertices, edges):
    """All simple cycles of a multigraph as (edge bitmask, vertex tuple)."""
    if len(vertices) <= DFS_CYCLES_MAX:
        return _simple_cycles_dfs(vertices, edges)
    if len(edges) <= 64 and len(edges) - len(vertices) + 1 <= CYCLE_SPACE_MAX:
        return _simple_cycles_space(vertices, edges)
    return _simple_cycles_nx(vertices, edges)


def _simple_cycles_space(vertices, edges):
    """The same list from the cycle space of a connected multigraph (Welch 1966; Mateti
    & Deo 1976 survey the method): every element is an edge-disjoint union of cycles;
    one with every vertex degree at most 2 is a vertex-disjoint union, and it is one
    simple cycle iff it holds no smaller simple cycle (taken by increasing size).  The
    ``2**beta`` elements (beta = E - V + 1) are built from the fundamental cycles of a
    BFS tree and tested as 64-bit edge masks in NumPy.  Vertex tuples are in index
    order."""
    n = len(vertices)
    if n == 0:
        return []
    ends, adj = _indexed_adjacency(vertices, edges)
    to_root = [0] * n                        # edge mask of the tree path to vertex 0
    seen, order, tree = [False] * n, [0], 0
    seen[0] = True
    for x in order:
        for y, e in adj[x]:
            if not seen[y]:
                seen[y] = True
                to_root[y] = to_root[x] | 1 << e
                tree |= 1 << e
                order.append(y)
    space = np.zeros(1, np.uint64)
    for e, (a, b) in enumerate(ends):
        if not tree >> e & 1:
            space = np.concatenate([space, space ^ np.uint64(to_root[a] ^ to_root[b] | 1 << e)])
    incident = np.array([sum(1 << e for _, e in adj[v]) for v in range(n)], np.uint64)
    space = space[1:]
    thin = np.ones(len(space), bool)
    for v in range(n):
        thin &= np.bitwise_count(space & incident[v]) <= 2
    F = space[thin]
    size = np.bitwise_count(F)
    order_ = np.argsort(size, kind="stable")
    F, size = F[order_], size[order_]
    cuts = np.flatnonzero(np.diff(size)) + 1
    simple = np.zeros(0, np.uint64)
    for level in np.split(F, cuts):          # by size: a union of cycles holds a smaller one
        holds = ((simple[None, :] & ~level[:, None]) == 0).any(axis=1)
        simple = np.concatenate([simple, level[~holds]])
    F = simple
    on = np.bitwise_count(F[:, None] & incident[None, :]) == 2
    return [(int(mk), tuple(np.flatnonzero(row).tolist())) for mk, row in zip(F, on)]


def _simple_cycles_nx(vertices, edges):
    """The same list by networkx's output-sensitive ``simple_cycles`` (Gupta & Suzumura
    2021) on the graph with every edge subdivided (parallel edges stay distinct); a
    plain path search is exponential in the paths, e.g. on a ladder."""
    index = {v: i for i, v in enumerate(vertices)}
    g = nx.Graph()
    for e, (u, v, *_rest) in enumerate(edges):
        g.add_edge(index[u], ("s", e))
        g.add_edge(("s", e), index[v])
    out = []
    for cyc in nx.simple_cycles(g):
        mask = sum(1 << x[1] for x in cyc if isinstance(x, tuple))
        out.append((mask, tuple(x for x in cyc if not isinstance(x, tuple))))
    return out


def _indexed_adjacency(vertices, edges):
    """Edge ends as vertex indices and, per vertex index, its ``(neighbour, edge)`` pairs."""
    index = {v: i for i, v in enumerate(vertices)}
    ends = [(index[u], index[v]) for u, v, *_rest in edges]
    adj: list[list[tuple[int, int]]] = [[] for _ in vertices]
    for e, (a, b) in enumerate(ends):
        adj[a].append((b, e))
        adj[b].append((a, e))
    return ends, adj


def _simple_cycles_dfs(vertices, edges):
    """All simple cycles by a path search from each vertex through larger vertices."""
    _ends, adj = _indexed_adjacency(vertices, edges)
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


def _can_be_face(n_keep: int, pairs, mask: int, path) -> bool:
    """Cycle C is a face of some planar embedding iff the graph plus an apex joined to
    every vertex of C is planar (the apex sits inside the face).  Reduced edges of C
    keep one subdivision vertex (``n_keep + e``) so that parallel edges stay apart."""
    apex = n_keep + len(pairs)
    edges = []
    for e, (u, v) in enumerate(pairs):
        if (mask >> e) & 1:
            edges += [(u, n_keep + e), (n_keep + e, v), (apex, n_keep + e)]
        else:
            edges.append((u, v))
    edges += [(apex, v) for v in path]
    return _planar(apex + 1, edges)


@dataclass(frozen=True, slots=True)
class _FaceCandidates:
    """The cycles that may be faces, with what the exact-cover search needs.

    ``sizes[c]`` is the cycle's size in links; ``masks[c]`` its reduced edges as a bit
    mask and ``cycle_edges[c]`` the same as a tuple; ``by_edge[e]`` the cycles through
    edge ``e`` (smallest first); ``corners[c]`` the ``(vertex, edge in, edge out)``
    corners of the cycle at the reduced vertices.
    """

    sizes: tuple[int, ...]
    masks: tuple[int, ...]
    cycle_edges: tuple[tuple[int, ...], ...]
    by_edge: tuple[tuple[int, ...], ...]
    corners: tuple[tuple[tuple[int, int, int], ...], ...]


def _face_candidates(rb: _ReducedBlock, use_filter: bool) -> _FaceCandidates:
    """Every simple cycle of the reduced block (that passes the apex test when
    ``use_filter``), with its size in links and its corners."""
    keep, edges = rb.keep, rb.edges
    inside = [w for _u, _v, w, *_rest in edges]              # link vertices inside each edge
    is_link = [_is_link(v) for v in keep]
    at_vertex = [0] * len(keep)                               # edge mask at each vertex
    for e, (a, b) in enumerate(rb.pairs):
        at_vertex[a] |= 1 << e
        at_vertex[b] |= 1 << e
    sizes, masks, corners, cycle_edges = [], [], [], []
    by_edge: list[list[int]] = [[] for _ in edges]
    for mask, path in _simple_cycles(keep, edges):
        if use_filter and not _can_be_face(len(keep), rb.pairs, mask, path):
            continue
        ce = _bits(mask)
        for e in ce:
            by_edge[e].append(len(masks))
        cycle_edges.append(ce)
        # interior link vertices of its edges + link vertices of the cycle
        sizes.append(sum(inside[e] for e in ce) + sum(is_link[v] for v in path))
        masks.append(mask)
        # the corner at v: its lowest and highest edge on the cycle (two parallel edges
        # closing a 2-cycle both sit at v)
        corners.append(tuple((v, (m & -m).bit_length() - 1, m.bit_length() - 1)
                             for v in path for m in (mask & at_vertex[v],)))
    by_edge = tuple(tuple(sorted(cs, key=sizes.__getitem__)) for cs in by_edge)
    cycle_edges = tuple(cycle_edges)
    return _FaceCandidates(tuple(sizes), tuple(masks), cycle_edges, by_edge, tuple(corners))


def _bits(mask: int) -> tuple[int, ...]:
    """The positions of the set bits of ``mask``, ascending."""
    out = []
    while mask:
        low = mask & -mask
        out.append(low.bit_length() - 1)
        mask ^= low
    return tuple(out)


class _BudgetExceeded(Exception):
    pass


class _FaceSearch:
    """Exact-cover search over the candidate faces of a reduced block.

    A face set is an embedding when it covers every reduced edge exactly twice, has
    ``E − V + 2`` faces, and at every vertex the corners close into one wheel (the
    rotation).  The corners chosen so far at ``v`` join its edges into chains:
    ``end[v][e]`` is the other end of the chain ending at edge ``e`` and ``size[v][e]``
    its number of edges (kept for chain ends only, undone in stack order; an edge that
    is not a chain end already has its two faces and is never asked).  ``lower[e]`` is
    the first face chosen *for* edge ``e`` while it was uncovered: the other face
    through ``e`` must come later in the candidate order, so every face set is reached
    along exactly one branch.
    """

    def __init__(self, rb: _ReducedBlock, cand: _FaceCandidates, limit: int,
                 node_budget: int | None):
        self.cand, self.limit, self.node_budget = cand, limit, node_budget
        self.n_faces, self.n_edges = rb.n_faces, len(rb.edges)
        self.full = (1 << self.n_edges) - 1
        self.degree = [0] * len(rb.keep)
        for u, v in rb.pairs:
            self.degree[u] += 1
            self.degree[v] += 1
        self.end: list[dict[int, int]] = [{} for _ in rb.keep]
        self.size: list[dict[int, int]] = [{} for _ in rb.keep]
        for e, (u, v) in enumerate(rb.pairs):
            self.end[u][e] = self.end[v][e] = e
            self.size[u][e] = self.size[v][e] = 1
        self.undo: list[tuple] = []
        self.lower = [-1] * self.n_edges
        self._lower_of = [itemgetter(*edges, edges[0]) for edges in cand.cycle_edges]
        self.count = 0
        self.nodes = 0
        # branch and bound (minimum mode only): best list so far, smallest candidate,
        # sum of the face sizes of every embedding (the block's link corners)
        self.best: tuple[int, ...] | None = None
        self.smin = min(cand.sizes, default=0)
        self.total = 0

    def _corners_ok(self, c: int) -> bool:
        """Adding cycle c must not close a wheel early at any vertex: a corner joining
        the two ends of one chain closes it, allowed only when the chain holds every
        edge of the vertex."""
        end, size, degree = self.end, self.size, self.degree
        for v_idx, e1, e2 in self.cand.corners[c]:
            if end[v_idx][e1] == e2 and size[v_idx][e1] < degree[v_idx] and degree[v_idx] >= 3:
                return False
        return True

    def _toggle(self, c: int, on: bool) -> None:
        """Join (``on``) the chains at cycle c's corners, or undo the last join of c."""
        if not on:
            for _ in self.cand.corners[c]:
                v_idx, a, b, end_a, end_b, size_a, size_b = self.undo.pop()
                end, size = self.end[v_idx], self.size[v_idx]
                end[a], end[b], size[a], size[b] = end_a, end_b, size_a, size_b
            return
        for v_idx, e1, e2 in self.cand.corners[c]:
            end, size = self.end[v_idx], self.size[v_idx]
            a, b = end[e1], end[e2]
            self.undo.append((v_idx, a, b, end[a], end[b], size[a], size[b]))
            n = size[e1] if a == e2 else size[e1] + size[e2]      # a closed wheel keeps its size
            end[a], end[b] = b, a
            size[a] = size[b] = n

    def _branch_edge(self, used1: int, used2: int) -> tuple[int, list[int]]:
        """The uncovered edge with the fewest candidate faces (edges covered once need
        exactly one more face: most constrained, looked at first)."""
        masks, by_edge, lower_of, lower = self.cand.masks, self.cand.by_edge, self._lower_of, self.lower
        best_e, best_opts, cap = -1, None, len(masks) + 1
        once = used1 & ~used2
        for e in (range(self.n_edges) if not once else [e for e in range(self.n_edges) if (once >> e) & 1]):
            if (used2 >> e) & 1:
                continue
            # a face c is allowed when it comes after the first face chosen for each of its
            # edges (lower[e] >= 0 only for edges covered once: no test of used1 needed);
            # the scan stops as soon as this edge cannot beat the best
            opts = []
            for c in by_edge[e]:
                if not (masks[c] & used2) and max(lower_of[c](lower)) < c:
                    opts.append(c)
                    if len(opts) >= cap:
                        break
            if len(opts) < cap:
                best_e, best_opts, cap = e, opts, len(opts)
                if cap <= 1:
                    break
        return best_e, best_opts or []

    def _tick(self) -> None:
        if self.count >= self.limit:   # the minimum over a truncated enumeration is not canonical
            raise TopologyError(explain(
                "loop assortment", expected=f"at most {self.limit} planar embeddings of a block",
                got="more", hint="[La] cannot be chosen canonically here; use loops=False"))
        self.nodes += 1
        if self.node_budget is not None and self.nodes > self.node_budget:
            raise _BudgetExceeded

    def _hopeless(self, chosen: list[int]) -> bool:
        """True when no completion of ``chosen`` can beat ``best``.  Every remaining face
        has at least ``smin`` links and all faces add up to ``total``; the ascending list
        ``chosen + [smin] * (r − 1) + [rest]`` is a lexicographic lower bound of every
        completion (any other completion has fewer faces of size ``smin`` and agrees
        below it), so a bound >= best prunes."""
        if self.best is None:
            return False
        sizes = [self.cand.sizes[c] for c in chosen]
        r = self.n_faces - len(chosen)
        if r <= 0:
            return False
        rest = self.total - sum(sizes) - (r - 1) * self.smin
        bound = sorted(sizes + [self.smin] * (r - 1) + [max(rest, self.smin)])
        return tuple(bound) >= self.best

    def minimum(self, unique: bool = False) -> tuple[int, ...] | None:
        """The lexicographically smallest ascending face-size list, by branch and bound
        (the same answer as the minimum over :meth:`search`, tested).  ``unique``: the
        block has one embedding (3-connected, Whitney), the first one found is it."""
        for faces in self.search():
            if self.best is None:
                self.total = sum(faces)
            if self.best is None or faces < self.best:
                self.best = faces
            if unique:
                break
        return self.best

    def search(self, used1: int = 0, used2: int = 0, chosen: list[int] | None = None):
        """Yield the sorted face sizes of every embedding below this node (in minimum
        mode, only those that may beat the best so far)."""
        chosen = [] if chosen is None else chosen
        self._tick()
        if self._hopeless(chosen):
            return
        if used2 == self.full or len(chosen) == self.n_faces:
            # every edge twice and no wheel closed early: each rotation is one cycle
            if used2 == self.full and len(chosen) == self.n_faces:
                self.count += 1
                yield tuple(sorted(self.cand.sizes[c] for c in chosen))
            return
        e, opts = self._branch_edge(used1, used2)
        uncovered = not (used1 >> e) & 1
        for c in [c for c in opts if self._corners_ok(c)]:
            mask = self.cand.masks[c]
            chosen.append(c)
            self._toggle(c, True)
            if uncovered:
                self.lower[e] = c
            yield from self.search(used1 | mask, used2 | (mask & used1), chosen)
            if uncovered:
                self.lower[e] = -1
            self._toggle(c, False)
            chosen.pop()


def block_embeddings(block, limit: int = MAX_EMBEDDINGS, use_filter: bool = True,
                     node_budget: int | None = None):
    """Yield the distinct face-size lists of the planar embeddings of a 2-connected block.

    Raises ``TopologyError`` rather than truncate when the block has more than ``limit``
    embeddings (a minimum over part of them would not be an invariant).

    Every embedding is enumerated; each yielded value is a sorted tuple of face sizes
    (in links), and embeddings with the same sizes are yielded once.  ``use_filter``
    applies the apex planarity test to every cycle first (slower per cycle, but it
    keeps dense blocks tractable); ``node_budget`` aborts the search with
    ``_BudgetExceeded`` after that many search nodes.  ``block`` is a networkx graph
    or an adjacency mapping.

    Phases: reduce (suppress degree-2 vertices, :class:`_ReducedBlock`) → planarity
    of the reduced graph → candidate faces (:class:`_FaceCandidates`) → exact-cover
    search (:class:`_FaceSearch`).
    """
    if isinstance(block, nx.Graph):
        block = {v: list(block[v]) for v in block}
    rb = _reduced_block(block)
    if not rb.keep:   # the block is a single cycle
        s = sum(1 for v in block if _is_link(v))
        yield (s, s)
        return
    if len(rb.keep) > 4 and not _planar(len(rb.keep), rb.pairs):
        return   # (every graph on at most 4 vertices is planar)
    search = _FaceSearch(rb, _face_candidates(rb, use_filter), limit, node_budget)
    seen = set()
    for faces in search.search():
        if faces not in seen:
            seen.add(faces)
            yield faces


#: search nodes allowed to the unfiltered search before the apex filter is switched on
NODE_BUDGET = 2_000


def _minimum_faces(block, use_filter: bool, node_budget: int | None = None, whitney: bool = True
                   ) -> tuple[tuple[int, ...] | None, int]:
    """Branch-and-bound minimum of :func:`block_embeddings` and the number of complete
    embeddings it examined (one for a 3-connected block unless ``whitney`` is off)."""
    rb = _reduced_block(block)
    if not rb.keep:
        s = sum(1 for v in block if _is_link(v))
        return (s, s), 1
    if len(rb.keep) > 4 and not _planar(len(rb.keep), rb.pairs):
        return None, 0
    if whitney and _three_connected(rb):
        return _unique_faces(rb), 1
    search = _FaceSearch(rb, _face_candidates(rb, use_filter), MAX_EMBEDDINGS, node_budget)
    return search.minimum(), search.count


def _unique_faces(rb: _ReducedBlock) -> tuple[int, ...]:
    """Face sizes (in links, ascending) of a planar 3-connected reduced block: its
    embedding is unique (Whitney 1932), so no search.  Small blocks read the faces as
    the peripheral cycles (:func:`_peripheral_faces`, Tutte 1963), larger ones off
    networkx's planarity embedding; the tests compare both routes."""
    faces = _peripheral_faces(rb) if len(rb.keep) <= DFS_CYCLES_MAX else None
    return faces if faces is not None else _embedding_faces(rb)


def _face_size(rb: _ReducedBlock, corners, edge_mask: int) -> int:
    """Links on a face: the link vertices on its corners and inside its reduced edges."""
    inside = sum(rb.edges[e][2] for e in range(len(rb.edges)) if edge_mask >> e & 1)
    return sum(1 for x in corners if _is_link(rb.keep[x])) + inside


def _peripheral_faces(rb: _ReducedBlock) -> tuple[int, ...] | None:
    """Face sizes of a 3-connected planar reduced block from its cycles alone.

    In a 3-connected planar graph the face boundaries are exactly the peripheral
    cycles: induced (chordless) cycles whose removal leaves the graph connected
    (Tutte 1963, Theorem 2.5).  Returns None when their number is not Euler's
    ``E − V + 2`` (the block is then not 3-connected planar; the caller falls back).
    """
    n = len(rb.keep)
    near = [0] * n
    for a, b in rb.pairs:
        near[a] |= 1 << b
        near[b] |= 1 << a
    everyone = (1 << n) - 1
    sizes = []
    for edge_mask, path in _simple_cycles_dfs(range(n), rb.pairs):
        on = sum(1 << v for v in path)
        if sum(1 for a, b in rb.pairs if on >> a & 1 and on >> b & 1) != len(path):
            continue                                  # a chord
        rest = everyone & ~on
        reach = rest & -rest
        while True:                                   # grow one component of the rest
            grown = reach
            for v in range(n):
                if reach >> v & 1:
                    grown |= near[v] & rest
            if grown == reach:
                break
            reach = grown
        if reach == rest:
            sizes.append(_face_size(rb, path, edge_mask))
    return tuple(sorted(sizes)) if len(sizes) == rb.n_faces else None


def _embedding_faces(rb: _ReducedBlock) -> tuple[int, ...]:
    """Face sizes of a planar 3-connected reduced block read off networkx's planarity
    embedding (its faces by half-edge traversal)."""
    n = len(rb.keep)
    weight = {frozenset(p): rb.edges[e][2] for e, p in enumerate(rb.pairs)}
    g = nx.Graph()
    g.add_nodes_from(range(n))
    g.add_edges_from(rb.pairs)
    planar, emb = nx.check_planarity(g)
    assert planar, "reduced block tested planar above"
    seen: set = set()
    sizes = []
    for u, v in emb.edges():
        if (u, v) in seen:
            continue
        face = emb.traverse_face(u, v, mark_half_edges=seen)
        corners = sum(1 for x in face if _is_link(rb.keep[x]))
        inside = sum(weight[frozenset((face[i], face[(i + 1) % len(face)]))] for i in range(len(face)))
        sizes.append(corners + inside)
    return tuple(sorted(sizes))


def _three_connected(rb: _ReducedBlock) -> bool:
    """The reduced block is a simple 3-connected graph: then its planar embedding is
    unique up to reflection (Whitney 1932), and so are its faces.  Parallel reduced
    edges are a 2-vertex cut; otherwise no vertex removal may leave a cut vertex."""
    n = len(rb.keep)
    if n < 4 or len({tuple(sorted(p)) for p in rb.pairs}) < len(rb.pairs):
        return False
    for v in range(n):
        g = rx.PyGraph(multigraph=False)
        g.add_nodes_from(range(n))
        g.add_edges_from_no_data([p for p in rb.pairs if v not in p])
        g.remove_node(v)
        if rx.number_connected_components(g) != 1 or rx.articulation_points(g):
            return False
    return True


def _best_block_faces(block) -> tuple[list[int], int] | None:
    """Canonical face sizes of a block and the number of embeddings examined, or None
    when the block is not planar (tested on the reduced graph first)."""
    try:
        best, count = _minimum_faces(block, use_filter=False, node_budget=NODE_BUDGET)
    except _BudgetExceeded:
        best, count = _minimum_faces(block, use_filter=True)
    if best is None:
        return None
    return list(best), count
