"""Isomorphism of chains and mechanisms: canonical form, exact tests, cheap invariants.

The exact test works on the **coloured link–joint incidence graph**: link vertices
and joint vertices are different colours; a joint's kind (R/P) is a colour.  In
``mode="mechanism"`` the frame link, the driven joints and the guide side of every
P joint are colours too, and so is the pair of links each driver turns (a driver on a
multiple joint turns one pair of its links), so two mechanisms are equal only if they
are the same inversion with the same inputs (up to the sign of an input).

* :func:`canonical_form` — nauty's canonical labelling (pynauty) of the coloured
  graph, written out as a string: the colour-class sizes, then the upper triangle of
  the canonical adjacency matrix in hexadecimal.  It is equal for every relabelling
  and different for non-isomorphic chains (it *is* the canonical graph).
* :func:`are_isomorphic` — compares canonical forms; :func:`are_isomorphic_vf2`
  is the independent route (networkx VF2 with categorical node matching), used to
  cross-check in the tests.
* :func:`invariant_signature` — the Pozhbelko & Kuts 2020 comparison: [LA], [MJA], [La] and the
  link degrees of each multiple joint.  **Necessary, not sufficient**: equal
  signatures do NOT guarantee isomorphism (how often they merge non-isomorphic
  chains is measured on the atlas).

References
----------
.. [1] B. D. McKay, A. Piperno, "Practical graph isomorphism, II", J. Symbolic
   Computation 60 (2014) 94–112.
.. [2] L. P. Cordella et al., "A (sub)graph isomorphism algorithm for matching large
   graphs", IEEE TPAMI 26 (2004) 1367–1372.
.. [3] V. A. Pozhbelko, E. N. Kuts, structural analysis of multi-loop linkages with
   multiple joints (2020) — Pozhbelko & Kuts 2020.
"""
from __future__ import annotations

from typing import Sequence

import networkx as nx
import pynauty

from .errors import InputError, explain
from .model import JointKind, Mechanism

__all__ = ["canonical_form", "canonical_form_of_joints", "canonical_labelling", "are_isomorphic", "are_isomorphic_vf2",
           "invariant_signature", "could_be_isomorphic", "automorphism_orbits"]

_MODES = ("chain", "mechanism")


def _coloured(m: Mechanism, mode: str):
    """Vertices in colour order, colour classes, adjacency (vertex indices)."""
    if mode not in _MODES:
        raise InputError(explain("mode", expected="'chain' or 'mechanism'", got=repr(mode)))
    mech = mode == "mechanism"
    driven = {d.joint for d in m.drivers} if mech else set()
    frame = m.frame if mech else None
    classes: list[list[tuple]] = []
    links = [("L", x) for x in m.link_names if x != frame]
    classes.append(links)
    classes.append([("L", frame)] if frame is not None else [])
    for kind in (JointKind.R, JointKind.P):
        classes.append([("J", j.name) for j in m.joints if j.kind is kind and j.name not in driven])
        classes.append([("J", j.name) for j in m.joints if j.kind is kind and j.name in driven])
    markers = []
    if mech:  # a marker vertex on the P joint – guide link incidence
        markers = [("G", j.name) for j in m.joints if j.kind is JointKind.P]
    classes.append(markers)
    # a marker per driver joined to its joint and to the two links it turns relative to each
    # other (on a multiple joint the joint alone does not say which pair; which of the two is
    # the reference is only the sign of the input)
    drivers = list(enumerate(m.drivers)) if mech else []
    if mech:                                   # (chain mode keeps its seven classes)
        classes.append([("D", k) for k, _ in drivers])
    order = [v for cls in classes for v in cls]
    index = {v: i for i, v in enumerate(order)}
    adj: dict[int, list[int]] = {i: [] for i in range(len(order))}
    for j in m.joints:
        jv = index[("J", j.name)]
        for k, x in enumerate(j.links):
            lv = index[("L", x)]
            if mech and j.kind is JointKind.P and k == 0:
                gv = index[("G", j.name)]
                adj[jv].append(gv)
                adj[gv].append(lv)
            else:
                adj[jv].append(lv)
    for k, d in drivers:
        adj[index[("D", k)]] += [index[("J", d.joint)]] + [index[("L", x)] for x in d.links]
    return order, classes, adj


def _nauty_graph(order, classes, adj) -> pynauty.Graph:
    coloring = []
    start = 0
    for cls in classes:
        coloring.append(set(range(start, start + len(cls))))
        start += len(cls)
    coloring = [c for c in coloring if c]
    return pynauty.Graph(len(order), directed=False, adjacency_dict=adj,
                         vertex_coloring=coloring)


def canonical_labelling(m: Mechanism, mode: str = "chain") -> list[tuple]:
    """Vertices (``("L", name)`` / ``("J", name)``) in canonical order."""
    order, classes, adj = _coloured(m, mode)
    lab = pynauty.canon_label(_nauty_graph(order, classes, adj))
    return [order[i] for i in lab]


def _encode(mode: str, sizes: list[int], adj: dict[int, list[int]]) -> str:
    """Canonical string of a coloured graph whose colour classes are consecutive vertex
    ranges of the given sizes: the class sizes, then the upper triangle of the
    canonically labelled adjacency matrix, row by row, packed into hex."""
    n = sum(sizes)
    coloring, start = [], 0
    for s in sizes:
        if s:
            coloring.append(set(range(start, start + s)))
        start += s
    lab = pynauty.canon_label(pynauty.Graph(n, directed=False, adjacency_dict=adj,
                                            vertex_coloring=coloring))
    pos = {v: i for i, v in enumerate(lab)}
    nbits = n * (n - 1) // 2
    value = 0
    for u, nbs in adj.items():
        for v in nbs:
            i, k = sorted((pos[u], pos[v]))
            value |= 1 << (nbits - 1 - (i * n - i * (i + 1) // 2 + (k - i - 1)))
    width = (nbits + 3) // 4
    return f"{mode[0]}{'.'.join(map(str, sizes))}:" + (f"{value:0{width}x}" if width else "")


def canonical_form(m: Mechanism, mode: str = "chain") -> str:
    """A string equal for isomorphic chains (mechanisms) and only for them.

    Format: ``"<mode initial><class sizes>:<hex>"`` where the hex string is the upper
    triangle of the adjacency matrix of the canonically labelled coloured incidence
    graph, row by row, packed into bits.

    Examples
    --------
    >>> from multiloop.topo.model import chain_from_joint_lists
    >>> a = chain_from_joint_lists([["a", "b"], ["b", "c"], ["c", "d"], ["d", "a"]])
    >>> b = chain_from_joint_lists([["x", "y"], ["z", "w"], ["y", "z"], ["w", "x"]])
    >>> canonical_form(a) == canonical_form(b)
    True
    """
    _, classes, adj = _coloured(m, mode)
    return _encode(mode, [len(c) for c in classes], adj)


def canonical_form_of_joints(n_links: int, joints: Sequence[Sequence[int]]) -> str:
    """:func:`canonical_form` (mode ``"chain"``) of a bare chain of pins given as link
    indices ``0 … n_links − 1`` per joint, without building a :class:`Mechanism`
    (the atlas calls it for every generated chain).

    Examples
    --------
    >>> from multiloop.topo.model import chain_from_joint_lists
    >>> canonical_form_of_joints(4, [(0, 1), (1, 2), (2, 3), (3, 0)]) == canonical_form(
    ...     chain_from_joint_lists([["a", "b"], ["b", "c"], ["c", "d"], ["d", "a"]]))
    True
    """
    adj = {n_links + a: list(j) for a, j in enumerate(joints)}
    # chain-mode classes: links, frame, R, driven R, P, driven P, guide markers
    return _encode("chain", [n_links, 0, len(joints), 0, 0, 0, 0], adj)


def are_isomorphic(a: Mechanism, b: Mechanism, mode: str = "chain") -> bool:
    """Exact isomorphism test by canonical forms (nauty)."""
    return canonical_form(a, mode) == canonical_form(b, mode)


def _vf2_graph(m: Mechanism, mode: str) -> nx.Graph:
    order, classes, adj = _coloured(m, mode)
    g = nx.Graph()
    for c, cls in enumerate(classes):
        for v in cls:
            g.add_node(v, colour=c)
    for u, nbs in adj.items():
        for v in nbs:
            g.add_edge(order[u], order[v])
    return g


def are_isomorphic_vf2(a: Mechanism, b: Mechanism, mode: str = "chain") -> bool:
    """Exact isomorphism test by VF2 (networkx) on the same coloured graph."""
    ga, gb = _vf2_graph(a, mode), _vf2_graph(b, mode)
    return nx.is_isomorphic(ga, gb, node_match=nx.algorithms.isomorphism.categorical_node_match("colour", None))


def automorphism_orbits(m: Mechanism, mode: str = "chain") -> dict[tuple, int]:
    """Orbit id of every vertex under the automorphism group (nauty)."""
    order, classes, adj = _coloured(m, mode)
    _, _, _, orbits, _ = pynauty.autgrp(_nauty_graph(order, classes, adj))
    return {order[i]: int(o) for i, o in enumerate(orbits)}


def invariant_signature(m: Mechanism, with_loops: bool = True) -> tuple:
    """The Pozhbelko & Kuts 2020 invariants: ([LA], [MJA], [La], multiset of the link-degree
    multisets of every multiple joint).

    **Necessary, not sufficient**: non-isomorphic chains may share a signature.
    """
    from .loops import loop_assortment

    deg = {x: m.degree(x) for x in m.link_names}
    imax = max(deg.values())
    la = tuple(sum(1 for d in deg.values() if d == i) for i in range(2, imax + 1))
    jmax = max(j.multiplicity for j in m.joints)
    mja = tuple(sum(1 for j in m.joints if j.multiplicity == k) for k in range(2, jmax + 1))
    mj_sets = tuple(sorted(tuple(sorted(deg[x] for x in j.links)) for j in m.joints if j.is_multiple))
    loops = loop_assortment(m).sizes if with_loops else None
    return (la, mja, loops, mj_sets)


def could_be_isomorphic(a: Mechanism, b: Mechanism) -> bool:
    """Cheap pre-filter on :func:`invariant_signature`.

    ``False`` proves the chains differ; ``True`` does NOT guarantee isomorphism.
    """
    return invariant_signature(a) == invariant_signature(b)
