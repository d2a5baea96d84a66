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
  S contains such a pair; a disconnected degenerate S has a degenerate component).

A chain is **fractionated** when its incidence graph has an articulation vertex:
a *cut link* or a *cut joint*.
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import networkx as nx
import numpy as np

from .graphs import incidence_graph
from .model import Mechanism

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
    size = np.bitwise_count(masks).astype(np.int64)
    c = np.zeros(1 << n, dtype=np.int64)
    for jm in joint_masks:
        c += np.maximum(np.bitwise_count(masks & np.uint32(int(jm))).astype(np.int64) - 1, 0)
    bad = (3 * (size - 1) - 2 * c <= 0) & (size >= 2) & (size < n)
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


def _mincut_best(m: Mechanism, forced_in: tuple[str, ...], forced_out: tuple[str, ...] = ()):
    """Maximise 2c(S) − 3|S| over S ⊇ forced_in, S ∩ forced_out = ∅ by a minimum cut.

    With binary s_l (link chosen) and y_J (joint active), minimise the submodular
    ``E = Σ_l 3 s_l + Σ_J (2 − 2|J|) y_J + 2 Σ_J Σ_{l∈J} y_J (1 − s_l)``, whose minimum
    over y is ``3|S| − 2c(S)``: source side = value 1; edge J→l (capacity 2) is cut
    when the joint is active and its link is not; unary costs go to the terminals.
    Returns (max value, chosen links).
    """
    g = nx.DiGraph()
    src, snk = "__s", "__t"
    big = 10 ** 6
    # variables: link nodes ("l", x), joint nodes ("j", name); source side = value 1.
    # objective to minimise: Σ_l 3 s_l + Σ_J 2 y_J − 2 Σ_J Σ_{l∈J} y_J s_l
    # rewrite −2 y s = 2 y (1 − s) − 2 y  → cost 2 when y=1, s=0 (edge y→s cap 2),
    # and the −2 y term per incidence is a unary reward on y.
    unary: dict = {}
    for lk in m.link_names:
        unary[("l", lk)] = 3.0
    for j in m.joints:
        unary[("j", j.name)] = 2.0 - 2.0 * len(j.links)
        for x in j.links:
            g.add_edge(("j", j.name), ("l", x), capacity=2.0)
    const = 0.0
    for v, w in unary.items():
        g.add_node(v)
        if w >= 0:   # cost w when v = 1 (source side): edge v→t
            g.add_edge(v, snk, capacity=w)
        else:        # cost −w when v = 0: edge s→v; constant w
            g.add_edge(src, v, capacity=-w)
            const += w
    for x in forced_in:
        g.add_edge(src, ("l", x), capacity=big)
    for x in forced_out:
        g.add_edge(("l", x), snk, capacity=big)
    g.add_node(src)
    g.add_node(snk)
    cut, (side_s, _) = nx.minimum_cut(g, src, snk)
    chosen = tuple(x for x in m.link_names if ("l", x) in side_s)
    value = -(cut + const)   # = max 2c(S) − 3|S|
    return value, chosen


def _mincut(m: Mechanism) -> tuple[str, ...] | None:
    n = m.n_links
    pairs = set()
    for j in m.joints:
        for a, b in combinations(sorted(j.links), 2):
            pairs.add((a, b))
    best = None
    for a, b in sorted(pairs):
        value, chosen = _mincut_best(m, (a, b))
        if value + 3 < 0:      # no subset containing a and b is rigid
            continue
        candidates = [(value, chosen)]
        if len(chosen) == n:   # the whole chain qualifies (F <= 0): force one link out
            candidates = [_mincut_best(m, (a, b), (c,)) for c in m.link_names if c not in (a, b)]
        for value, chosen in candidates:
            if value + 3 >= 0 and 2 <= len(chosen) < n:
                if best is None or (len(chosen), chosen) < (len(best), best):
                    best = chosen
    if best is None:
        return None
    return _minimise(m, best)


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


def find_rigid_subchain(m: Mechanism, method: str = "auto") -> tuple[str, ...] | None:
    """A rigid or over-constrained proper sub-chain (link names), or None.

    Parameters
    ----------
    m : Mechanism
    method : {"auto", "exhaustive", "mincut"}
        ``auto`` uses the exhaustive bit-mask search up to 16 links, min-cut above.

    Returns
    -------
    tuple of str or None
        For ``exhaustive`` the smallest offending subset; for ``mincut`` a
        greedily minimised one.

    Examples
    --------
    >>> from multiloop.topo.model import chain_from_joint_lists
    >>> tri = [["a", "b"], ["b", "c"], ["c", "a"], ["a", "d"], ["d", "e"], ["e", "c"]]
    >>> find_rigid_subchain(chain_from_joint_lists(tri))
    ('a', 'b', 'c')
    """
    if method == "auto":
        method = "exhaustive" if m.n_links <= 16 else "mincut"
    if method == "exhaustive":
        return _exhaustive(m)
    if method == "mincut":
        return _mincut(m)
    raise ValueError(f"method: expected 'auto', 'exhaustive' or 'mincut', got {method!r}")


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
    g = incidence_graph(m)
    arts = set(nx.articulation_points(g))
    links = tuple(x for x in m.link_names if ("L", x) in arts)
    joints = tuple(j.name for j in m.joints if ("J", j.name) in arts)
    return Fractionation(links, joints)
