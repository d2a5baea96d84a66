"""Views of a mechanism as graphs.

The structural graph is the **link–joint incidence graph** (bipartite): one vertex per
link, one per joint, an edge when a link lies on a joint.  It represents a multiple
joint exactly (a link–link graph cannot say which pairs a triple pin forms).
Vertices are tuples ``("L", name)`` and ``("J", name)`` so that a link and a joint
may share a name.
"""
from __future__ import annotations

import networkx as nx

from .model import Mechanism

__all__ = ["incidence_graph", "link_vertex", "joint_vertex", "link_adjacency_graph"]


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
        for x in j.links[1:]:
            g.add_edge(j.links[0], x, joint=j.name)
    return g
