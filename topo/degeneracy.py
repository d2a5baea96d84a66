"""Degenerate (rigid or over-constrained) sub-chains and fractionation.

A chain is **degenerate** when some link subset S with ``2 <= |S| < n`` satisfies

    3(|S| − 1) − 2 c(S) <= 0,

where ``c(S)`` counts the pairs inside S: a pin with m links of S contributes
``m − 1`` (the structural numbers (README); Pozhbelko & Kuts 2020 calls such sub-chains rigid "trusses").  Two exact
routes are provided and cross-checked in the tests:

* :func:`find_rigid_subchain` with ``method="exhaustive"``: every subset as a bit
  mask, vectorised with NumPy (n <= 20);
* ``method="mincut"``: ``c(S) = Σ_J max(0, |S∩J| − 1) = max_y Σ_J y_J (|S∩J| − 1)``
  turns ``max_S 2c(S) − 3|S|`` into a supermodular maximisation, i.e. a minimum
  s–t cut, solved once for every pair of links that share a joint (any connected
  S contains such a pair; a disconnected degenerate S has a degenerate component);
* ``method="pebble"``: the (2, 3) pebble game of Jacobs & Hendrickson (1997) on the
  bar framework that stands for the links (:mod:`topo.pebble`; the count above is
  Laman's count of that framework), O(n²); where it does not settle the question
  (F <= 0, a link on one joint) the min-cut route answers.

``method="auto"``: the exhaustive search up to 16 links (the fastest there); above,
the pebble game first, and a chain it proves non-degenerate is done, while a
degenerate one is named by the min-cut route (so the subset named does not depend on
the pebble game).

A chain is **fractionated** when its incidence graph has an articulation vertex:
a *cut link* or a *cut joint*.
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np
import rustworkx as rx

from .model import Mechanism
from .pebble import rigid_links

__all__ = ["find_rigid_subchain", "is_degenerate", "rigid_subset_mask", "Fractionation", "fractionation",
           "subchain_deficit"]


def subchain_deficit(m: Mechanism, subset) -> int:
    """``3(|S| − 1) − 2c(S)`` for a link subset (<= 0 means rigid or over-constrained)."""
    s = set(subset)
    c = sum(max(0, sum(1 for x in j.links if x in s) - 1) for j in m.joints)
    return 3 * (len(s) - 1) - 2 * c


def _joint_masks(m: Mechanism) -> tuple[list[str], list[int]]:
    names = list(m.link_names)
    index = {x: i for i, x in enumerate(names)}
    return names, [sum(1 << index[x] for x in j.links) for j in m.joints]


def rigid_subset_mask(n: int, joint_masks) -> int | None:
    """The definition, subset by subset: the smallest link subset S (bit mask over links
    ``0 … n−1``, ties by mask value) with ``2 <= |S| < n`` and ``3(|S| − 1) − 2c(S) <= 0``,
    where ``c(S) = Σ_J max(0, |S ∩ J| − 1)``; None when there is none (n <= 20).

    Examples
    --------
    >>> rigid_subset_mask(5, [0b00011, 0b00110, 0b00101, 0b01001, 0b11000, 0b10100])
    7
    """
    if n > 20:
        raise ValueError("exhaustive search is limited to 20 links; use method='mincut'")
    masks = np.arange(1 << n, dtype=np.uint32)
    size = np.bitwise_count(masks)
    small = np.int16 if len(joint_masks) * n < 2 ** 15 else np.int32    # bounds the sum below
    c = np.zeros(1 << n, dtype=small)
    meet = np.empty(1 << n, np.uint32)
    for jm in joint_masks:
        np.bitwise_and(masks, np.uint32(int(jm)), out=meet)
        c += np.maximum(np.bitwise_count(meet), np.uint8(1))
    c -= len(joint_masks)                     # sum over J of max(|S ∩ J|, 1) − 1 is c(S)
    bad = (3 * (size.astype(small) - 1) - 2 * c <= 0) & (size >= 2) & (size < n)
    idx = np.flatnonzero(bad)
    if idx.size == 0:
        return None
    return int(idx[np.lexsort((idx, size[idx]))[0]])


def _exhaustive(m: Mechanism) -> tuple[str, ...] | None:
    names, jmasks = _joint_masks(m)
    best = rigid_subset_mask(len(names), jmasks)
    if best is None:
        return None
    return tuple(names[i] for i in range(len(names)) if (best >> i) & 1)


@dataclass(frozen=True, slots=True)
class _CutNetwork:
    """The s–t network of the min-cut route, as integer COO arrays.

    Vertices: source 0, sink 1, links ``2 … n+1``, joints after them.  With binary
    ``s_l`` (link chosen) and ``y_J`` (joint active), the submodular energy
    ``E = Σ_l 3 s_l + Σ_J (2 − 2|J|) y_J + 2 Σ_J Σ_{l∈J} y_J (1 − s_l)`` has minimum
    over y equal to ``3|S| − 2c(S)``: source side = value 1; edge J→l (capacity 2) is
    cut when the joint is active and its link is not; unary costs go to the
    terminals (a negative one becomes a source edge plus the constant ``const``).
    """

    n_vertices: int
    rows: np.ndarray
    cols: np.ndarray
    caps: np.ndarray
    const: int
    link_index: dict


def _cut_network(m: Mechanism) -> _CutNetwork:
    link_index = {x: 2 + i for i, x in enumerate(m.link_names)}
    n_links = len(link_index)
    rows, cols, caps = [], [], []
    const = 0
    for x, v in link_index.items():          # cost 3 when chosen: edge l→t
        rows.append(v), cols.append(1), caps.append(3)
    for k, j in enumerate(m.joints):
        jv = 2 + n_links + k
        for x in j.links:
            rows.append(jv), cols.append(link_index[x]), caps.append(2)
        w = 2 - 2 * len(j.links)             # <= −2: reward when active: edge s→J
        rows.append(0), cols.append(jv), caps.append(-w)
        const += w
    return _CutNetwork(2 + n_links + m.n_joints, np.array(rows, np.int32), np.array(cols, np.int32),
                       np.array(caps, np.int32), const, link_index)


def _mincut_best(m: Mechanism, forced_in: tuple[str, ...], forced_out: tuple[str, ...] = (),
                 net: _CutNetwork | None = None):
    """Maximise 2c(S) − 3|S| over S ⊇ forced_in, S ∩ forced_out = ∅ by a minimum cut
    (the network of :class:`_CutNetwork`; SciPy's compiled Dinic max-flow, the source
    side read off the residual graph).  Returns (max value, chosen links)."""
    from scipy.sparse import csr_array   # (SciPy loads in ~0.3 s: only when a cut is needed)
    from scipy.sparse.csgraph import breadth_first_order, maximum_flow

    net = _cut_network(m) if net is None else net
    big = 10 ** 6
    extra = [(0, net.link_index[x]) for x in forced_in] + [(net.link_index[x], 1) for x in forced_out]
    rows = np.concatenate([net.rows, np.array([r for r, _ in extra], np.int32)])
    cols = np.concatenate([net.cols, np.array([c for _, c in extra], np.int32)])
    caps = np.concatenate([net.caps, np.full(len(extra), big, np.int32)])
    nv = net.n_vertices
    cap = csr_array((caps, (rows, cols)), shape=(nv, nv))
    cap.sum_duplicates()
    res = maximum_flow(cap, 0, 1)
    residual = (cap - res.flow).tocsr()
    residual.data[residual.data < 0] = 0
    residual.eliminate_zeros()
    side_s = set(breadth_first_order(residual, 0, directed=True, return_predecessors=False).tolist())
    chosen = tuple(x for x, v in net.link_index.items() if v in side_s)
    return -(int(res.flow_value) + net.const), chosen   # = max 2c(S) − 3|S|


def _plain_links(m: Mechanism) -> set[str]:
    """Binary links whose two joints are simple."""
    deg: dict[str, int] = {}
    on_multiple: set[str] = set()
    for j in m.joints:
        for x in j.links:
            deg[x] = deg.get(x, 0) + 1
        if len(j.links) > 2:
            on_multiple.update(j.links)
    return {x for x in m.link_names if deg.get(x, 0) == 2 and x not in on_multiple}


def _link_pairs(m: Mechanism, skip_plain: bool) -> list[tuple[str, str]]:
    """Pairs of links on a common joint, sorted; ``skip_plain`` drops the pairs of two
    plain links (binary, on simple joints).

    Why that is exact for the existence of a rigid sub-chain: in an inclusion-minimal
    rigid S every link carries at least two of its pairs (removing a link that carries
    d pairs changes ``3(|S| − 1) − 2c(S)`` by ``2d − 3``); with ``|S| >= 4`` the
    average is ``2c/|S| >= 3 − 3/|S| > 2``, so S holds a link with three pairs, not a
    plain one; with ``|S| <= 3`` and only plain links, S is a 2- or 3-link loop whose
    links have no other joint, i.e. the whole (connected) chain, which is not proper.
    A minimal S is connected, so it holds a joint pair with a non-plain link.
    """
    plain = _plain_links(m) if skip_plain else set()
    pairs = set()
    for j in m.joints:
        for a, b in combinations(sorted(j.links), 2):
            if not (a in plain and b in plain):
                pairs.add((a, b))
    return sorted(pairs)


def _mincut_search(m: Mechanism, pairs, net: _CutNetwork) -> tuple[str, ...] | None:
    """The smallest rigid set over the min cuts forced through each pair."""
    n = m.n_links
    best = None
    for a, b in pairs:
        value, chosen = _mincut_best(m, (a, b), net=net)
        if value + 3 < 0:      # no subset containing a and b is rigid
            continue
        candidates = [(value, chosen)]
        if len(chosen) == n:   # the whole chain qualifies (F <= 0): force one link out
            candidates = [_mincut_best(m, (a, b), (c,), net=net) for c in m.link_names if c not in (a, b)]
        for value, chosen in candidates:
            if value + 3 >= 0 and 2 <= len(chosen) < n:
                if best is None or (len(chosen), chosen) < (len(best), best):
                    best = chosen
    return best


def _mincut(m: Mechanism) -> tuple[str, ...] | None:
    """Existence over the pairs with a non-plain link (:func:`_link_pairs`); when a rigid
    set exists, the search over every pair names the same set as before the pruning."""
    net = _cut_network(m)
    if _mincut_search(m, _link_pairs(m, skip_plain=True), net) is None:
        return None
    return _minimise(m, _mincut_search(m, _link_pairs(m, skip_plain=False), net))


def _minimise(m: Mechanism, subset: tuple[str, ...]) -> tuple[str, ...]:
    """Shrink a degenerate subset greedily while it stays degenerate (for a short name)."""
    cur = list(subset)
    changed = True
    while changed and len(cur) > 2:
        changed = False
        for x in list(cur):
            trial = [y for y in cur if y != x]
            if len(trial) >= 2 and subchain_deficit(m, trial) <= 0:
                cur = trial
                changed = True
                break
    order = {x: i for i, x in enumerate(m.link_names)}
    return tuple(sorted(cur, key=order.__getitem__))


def _pebble(m: Mechanism) -> tuple[str, ...] | None:
    """The pebble game's subset, greedily minimised; the min-cut route where the game
    does not settle it."""
    found = rigid_links(m)
    if found is None:
        return None
    if found == "unknown" or not (2 <= len(found) < m.n_links and subchain_deficit(m, found) <= 0):
        return _mincut(m)
    return _minimise(m, tuple(found))


def find_rigid_subchain(m: Mechanism, method: str = "auto") -> tuple[str, ...] | None:
    """A rigid or over-constrained proper sub-chain (link names), or None.

    Parameters
    ----------
    m : Mechanism
    method : {"auto", "exhaustive", "mincut", "pebble"}
        ``auto``: the exhaustive bit-mask search up to 16 links; above, the pebble
        game decides and the min-cut route names a degenerate chain's subset.

    Returns
    -------
    tuple of str or None
        For ``exhaustive`` (and ``auto`` up to 16 links) the smallest offending
        subset; for ``mincut`` and ``pebble`` a greedily minimised one.

    Examples
    --------
    >>> from multiloop.topo.model import chain_from_joint_lists
    >>> tri = [["a", "b"], ["b", "c"], ["c", "a"], ["a", "d"], ["d", "e"], ["e", "c"]]
    >>> find_rigid_subchain(chain_from_joint_lists(tri))
    ('a', 'b', 'c')
    """
    if method == "auto":
        if m.n_links <= 16:           # the bit-mask search is the fastest there (2^n masks)
            return _exhaustive(m)
        if rigid_links(m) is None:
            return None
        method = "mincut"
    if method == "exhaustive":
        return _exhaustive(m)
    if method == "mincut":
        return _mincut(m)
    if method == "pebble":
        return _pebble(m)
    raise ValueError(f"method: expected 'auto', 'exhaustive', 'mincut' or 'pebble', got {method!r}")


def is_degenerate(m: Mechanism, method: str = "auto") -> bool:
    """True when the chain contains a rigid or over-constrained proper sub-chain."""
    return find_rigid_subchain(m, method) is not None


@dataclass(frozen=True, slots=True)
class Fractionation:
    """Cut links and cut joints of a chain (articulation vertices of its incidence graph)."""

    cut_links: tuple[str, ...]
    cut_joints: tuple[str, ...]

    @property
    def is_fractionated(self) -> bool:
        return bool(self.cut_links or self.cut_joints)


def fractionation(m: Mechanism) -> Fractionation:
    """Cut links and cut joints (a chain is fractionated when it has either).

    Examples
    --------
    >>> from multiloop.topo.model import chain_from_joint_lists
    >>> two_loops = [["a", "b"], ["b", "c"], ["c", "a"], ["a", "d"], ["d", "e"], ["e", "a"]]
    >>> fractionation(chain_from_joint_lists(two_loops)).cut_links
    ('a',)
    """
    n = m.n_links
    index = {x: i for i, x in enumerate(m.link_names)}
    g = rx.PyGraph(multigraph=False)          # the incidence graph (links, then joints)
    g.add_nodes_from(range(n + m.n_joints))
    g.add_edges_from_no_data([(index[x], n + k) for k, j in enumerate(m.joints) for x in j.links])
    arts = set(rx.articulation_points(g))
    links = tuple(x for x in m.link_names if index[x] in arts)
    joints = tuple(j.name for k, j in enumerate(m.joints) if n + k in arts)
    return Fractionation(links, joints)
