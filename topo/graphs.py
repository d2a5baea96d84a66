"""Views of a mechanism as graphs.

The structural graph is the **link–joint incidence graph** (bipartite): one vertex per
link, one per joint, an edge when a link lies on a joint.  It represents a multiple
joint exactly (a link–link graph cannot say which pairs a triple pin forms).
Vertices are tuples ``("L", name)`` and ``("J", name)`` so that a link and a joint
may share a name.
"""
from __future__ import annotations

from typing import Any, Callable, Sequence

import networkx as nx

from .model import Mechanism

__all__ = ["incidence_graph", "link_vertex", "joint_vertex", "link_adjacency_graph", "pin_pairs",
           "n_pairs"]


def pin_pairs(links: Sequence[str], key: Callable[[str], Any] | None = None) -> tuple[tuple[str, str], ...]:
    """The kinematic pairs of a pin: a pin on k links is k − 1 pairs around a host link.

    Pozhbelko & Kuts 2020 count a multiple joint of ``k`` links as ``k − 1`` pairs
    (multiplicity ``j = k − 1``).  The pairs join one *host* link to each other link;
    which link hosts is the caller's choice and changes no count.

    Parameters
    ----------
    links : sequence of str
        The links on the pin, in file order.
    key : callable, optional
        Ordering of the links (a stable sort); the first link after sorting is the
        host and the others follow in that order.  Default: file order, so the host
        is the pin's first link.

    Returns
    -------
    tuple of (host, other)
        ``k − 1`` pairs.

    Examples
    --------
    >>> pin_pairs(("frame", "crank", "rocker"))
    (('frame', 'crank'), ('frame', 'rocker'))
    >>> rank = {"frame": 0, "crank": 2, "rocker": 1}
    >>> pin_pairs(("crank", "frame", "rocker"), key=rank.get)
    (('frame', 'rocker'), ('frame', 'crank'))
    """
    order = list(links) if key is None else sorted(links, key=key)
    host = order[0]
    return tuple((host, x) for x in order[1:])


def n_pairs(m: Mechanism) -> int:
    """Number of kinematic pairs ``p``: a joint on k links counts k − 1.

    Examples
    --------
    >>> from multiloop.topo.model import chain_from_joint_lists
    >>> n_pairs(chain_from_joint_lists([["a", "b", "c"], ["b", "c"], ["c", "a"]]))
    4
    """
    return sum(j.n_pairs for j in m.joints)


def link_vertex(name: str) -> tuple[str, str]:
    return ("L", name)


def joint_vertex(name: str) -> tuple[str, str]:
    return ("J", name)


def incidence_graph(m: Mechanism) -> nx.Graph:
    """The bipartite link–joint incidence graph.

    Node attributes: ``part`` (``"link"``/``"joint"``), ``frame`` (links),
    ``kind`` (joints: ``"R"``/``"P"``), ``driver`` (joints that carry a driver).

    Examples
    --------
    >>> from multiloop.topo.model import chain_from_joint_lists
    >>> g = incidence_graph(chain_from_joint_lists([["a", "b"], ["b", "c"], ["c", "a"]]))
    >>> g.number_of_nodes(), g.number_of_edges()
    (6, 6)
    """
    g = nx.Graph()
    driven = {d.joint for d in m.drivers}
    for lk in m.links:
        g.add_node(link_vertex(lk.name), part="link", frame=lk.is_frame, name=lk.name)
    for j in m.joints:
        g.add_node(joint_vertex(j.name), part="joint", kind=j.kind.value,
                   driver=j.name in driven, name=j.name)
        for x in j.links:
            g.add_edge(joint_vertex(j.name), link_vertex(x))
    return g


def link_adjacency_graph(m: Mechanism) -> nx.MultiGraph:
    """Links as vertices, one edge per kinematic pair (a pin with k links is a star of
    k − 1 edges from its first link).  Lossy for multiple joints; for display only."""
    g = nx.MultiGraph()
    g.add_nodes_from(m.link_names)
    for j in m.joints:
        for host, x in pin_pairs(j.links):
            g.add_edge(host, x, joint=j.name)
    return g
