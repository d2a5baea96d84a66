"""Straight-line layouts of bare chains in which no two links cross.

A chain is drawn as its **link polygons**: a bar between the two joints of a binary
link, a polygon through the joints of a link with three or more.  The graph that is
laid out (the *drawing graph*) therefore has the joints as vertices and the polygon
sides as edges, plus one hidden centre vertex inside every polygon, joined to its
joints by spokes.  The cyclic order of a polygon's joints is taken from a planar
embedding of the link–joint incidence graph, so a planar chain has a planar drawing
graph in which every polygon is a face.

Layout of a planar chain:

1. Tutte's barycentric embedding [1]_ with the longest face fixed on a regular
   polygon; when the drawing graph is not 3-connected the result may have
   coincident vertices, and then the straight-line grid drawing of Chrobak & Payne
   (networkx) is the start instead;
2. a force-directed refinement (Fruchterman & Reingold [2]_ forces, plus a
   vertex–edge repulsion) in which a vertex move is accepted only when the motion
   crosses nothing (the idea of Bertault's PrEd [3]_), so planarity and the faces are
   kept while the joints spread out, polygons fill out and degree-2 joints bend.

Non-planar chains get the Kamada–Kawai spring layout of the same graph.

References
----------
.. [1] W. T. Tutte, "How to draw a graph", Proc. London Math. Soc. 13 (1963) 743–767.
.. [2] T. M. J. Fruchterman, E. M. Reingold, "Graph drawing by force-directed
   placement", Software: Practice and Experience 21 (1991) 1129–1164.
.. [3] F. Bertault, "A force-directed algorithm that preserves edge crossing
   properties", Information Processing Letters 74 (2000) 7–13.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import networkx as nx
import numpy as np

__all__ = ["ChainLayout", "chain_layout", "link_cycles", "drawn_segments", "crossing_pairs",
           "has_crossings", "spread"]


@dataclass(frozen=True, slots=True)
class ChainLayout:
    """Positions in the unit square (y up).

    Attributes
    ----------
    links : tuple of (x, y)
        Layout point of every link (inside its polygon; the middle of a bar).
    joints : tuple of (x, y)
        Position of every joint.
    method : str
        ``"tutte"``, ``"planar"`` (Chrobak–Payne start) or ``"spring"`` (non-planar).
    polygons : tuple of tuple of int
        The joints of every link in drawing order (a cycle for three or more).
    """

    links: tuple[tuple[float, float], ...]
    joints: tuple[tuple[float, float], ...]
    method: str
    polygons: tuple[tuple[int, ...], ...] = ()


def _incidence(n: int, joints: Sequence[Sequence[int]]) -> nx.Graph:
    g = nx.Graph()
    g.add_nodes_from(range(n + len(joints)))
    g.add_edges_from((x, n + a) for a, j in enumerate(joints) for x in j)
    return g


def link_cycles(n: int, joints: Sequence[Sequence[int]]) -> tuple[tuple[tuple[int, ...], ...], bool]:
    """The joints of every link in a cyclic order of a planar embedding, and planarity.

    For a non-planar chain the order is the joints' index order.
    """
    g = _incidence(n, joints)
    planar, emb = nx.check_planarity(g)
    cycles = []
    for x in range(n):
        if planar and g.degree(x):
            cycles.append(tuple(v - n for v in emb.neighbors_cw_order(x)))
        else:
            cycles.append(tuple(a for a, j in enumerate(joints) if x in j))
    return tuple(cycles), planar


def _drawing_graph(n: int, n_joints: int, cycles) -> nx.Graph:
    """Joints 0…J−1, polygon sides, and a centre vertex J+x with spokes for polygons."""
    h = nx.Graph()
    h.add_nodes_from(range(n_joints))
    for x, cyc in enumerate(cycles):
        if len(cyc) == 2:
            h.add_edge(*cyc)
        elif len(cyc) >= 3:
            h.add_edges_from((cyc[i], cyc[(i + 1) % len(cyc)]) for i in range(len(cyc)))
            h.add_edges_from((n_joints + x, a) for a in cyc)
    return h


def _tutte(h: nx.Graph, outer: list) -> dict:
    pos = {v: (math.cos(2 * math.pi * i / len(outer) + math.pi / 2),
               math.sin(2 * math.pi * i / len(outer) + math.pi / 2)) for i, v in enumerate(outer)}
    inner = [v for v in h if v not in pos]
    if inner:
        idx = {v: i for i, v in enumerate(inner)}
        A = np.zeros((len(inner), len(inner)))
        b = np.zeros((len(inner), 2))
        for v in inner:
            A[idx[v], idx[v]] = h.degree(v)
            for w in h[v]:
                if w in idx:
                    A[idx[v], idx[w]] -= 1
                else:
                    b[idx[v]] += pos[w]
        sol = np.linalg.solve(A, b)
        pos.update({v: tuple(sol[idx[v]]) for v in inner})
    return pos


def _orient(a, b, c):
    return (b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1]) - (b[..., 1] - a[..., 1]) * (c[..., 0] - a[..., 0])


def _cross(p1, p2, q1, q2, eps: float = 1e-12) -> np.ndarray:
    """Proper crossings of segments p1p2 and q1q2 (broadcast over leading axes)."""
    d1, d2 = _orient(q1, q2, p1), _orient(q1, q2, p2)
    d3, d4 = _orient(p1, p2, q1), _orient(p1, p2, q2)
    return (d1 * d2 < -eps) & (d3 * d4 < -eps)


def _point_segment_distance(p, a, b) -> np.ndarray:
    ab = b - a
    t = np.clip(np.einsum("...i,...i", p - a, ab) / np.maximum(np.einsum("...i,...i", ab, ab), 1e-300), 0, 1)
    return np.linalg.norm(p - (a + t[..., None] * ab), axis=-1)


def _in_triangle(p, a, b, c) -> np.ndarray:
    d1, d2, d3 = _orient(a, b, p), _orient(b, c, p), _orient(c, a, p)
    neg = (d1 < 0) | (d2 < 0) | (d3 < 0)
    pos = (d1 > 0) | (d2 > 0) | (d3 > 0)
    return ~(neg & pos)


class _Refiner:
    """Force-directed rounds that never create a crossing (PrEd-like, Bertault 2000).

    Every round moves all vertices at once along their Fruchterman–Reingold force
    plus a vertex–edge repulsion; a move is capped by the temperature, and a round
    that would create a crossing (or make two links on one joint overlap) is retried
    with smaller steps, then skipped.
    """

    def __init__(self, h: nx.Graph, pos: dict):
        self.nodes = list(h)
        self.index = {v: i for i, v in enumerate(self.nodes)}
        self.P = np.array([pos[v] for v in self.nodes], float)
        self.E = np.array([(self.index[a], self.index[b]) for a, b in h.edges()], int).reshape(-1, 2)
        V = len(self.nodes)
        self.A = np.zeros((V, V))
        self.A[self.E[:, 0], self.E[:, 1]] = self.A[self.E[:, 1], self.E[:, 0]] = 1.0
        self.on = np.zeros((V, len(self.E)), bool)          # vertex is an end of edge
        self.on[self.E[:, 0], np.arange(len(self.E))] = True
        self.on[self.E[:, 1], np.arange(len(self.E))] = True
        self.pairs = _edge_pairs(self.E)

    def _step(self, k: float) -> tuple[np.ndarray, np.ndarray]:
        P = self.P
        V = len(P)
        d = P[:, None] - P[None]
        r = np.linalg.norm(d, axis=2) + np.eye(V)
        f = (d * (k * k / r ** 2)[..., None]).sum(axis=1)
        f -= (d * (self.A * r / k)[..., None]).sum(axis=1)
        a, b = P[self.E[:, 0]], P[self.E[:, 1]]
        ab = b - a
        t = np.clip(np.einsum("vei,ei->ve", P[:, None] - a[None], ab)
                    / np.maximum(np.einsum("ei,ei->e", ab, ab), 1e-300), 0, 1)
        dv = P[:, None] - (a[None] + t[..., None] * ab[None])
        rv = np.linalg.norm(dv, axis=2)
        rv = np.where(self.on, np.inf, np.maximum(rv, 1e-9))
        f += (dv * (k * k / rv ** 2)[..., None]).sum(axis=1)
        return f, rv.min(axis=1)

    def run(self, rounds: int = 100) -> np.ndarray:
        span = float(np.max(np.ptp(self.P, axis=0))) or 1.0
        self.P = (self.P - self.P.min(axis=0)) / span
        k = 1.0 / math.sqrt(len(self.P))
        for r in range(rounds):
            temp = 0.1 * (1 - r / rounds) + 0.002
            f, room = self._step(k)
            nf = np.maximum(np.linalg.norm(f, axis=1), 1e-12)
            new = self.P + f / nf[:, None] * np.minimum(nf, temp)[:, None]
            moved = 0.0
            for _ in range(4):              # put back the vertices of offending edges
                bad = _offenders(new, self.E, self.pairs)
                if not bad.size:
                    moved = float(np.abs(new - self.P).max())
                    self.P = new
                    break
                new[bad] = self.P[bad]
            if r > 20 and moved < 1e-3 * temp:
                break                       # settled: the forces are in balance
        return self.P


def _valid(h: nx.Graph, pos: dict) -> bool:
    P = np.array([pos[v] for v in h], float)
    if len(P) > 1:
        d = np.linalg.norm(P[:, None] - P[None], axis=2) + np.eye(len(P))
        if d.min() < 1e-6 * (np.ptp(P, axis=0).max() or 1.0):
            return False
    return not has_crossings(h, pos)


def _planar_start(h: nx.Graph) -> tuple[dict, str]:
    planar, emb = nx.check_planarity(h)
    faces, seen = [], set()
    for u, v in emb.edges():
        if (u, v) not in seen:
            faces.append(emb.traverse_face(u, v, mark_half_edges=seen))
    faces.sort(key=lambda f: (-len(f), sorted(f)))
    for outer in faces[:6]:
        try:
            pos = _tutte(h, outer)
        except np.linalg.LinAlgError:
            continue
        if _valid(h, pos):
            return pos, "tutte"
    return nx.combinatorial_embedding_to_pos(emb), "planar"


def chain_layout(n: int, joints: Sequence[Sequence[int]], rounds: int = 100) -> ChainLayout:
    """Layout of a chain given as joints (tuples of link indices ``0…n−1``).

    Examples
    --------
    >>> lay = chain_layout(4, [(0, 1), (1, 2), (2, 3), (3, 0)])
    >>> lay.method, len(lay.links), len(lay.joints), lay.polygons
    ('tutte', 4, 4, ((0, 3), (0, 1), (1, 2), (2, 3)))
    """
    J = len(joints)
    cycles, planar = link_cycles(n, joints)
    h = _drawing_graph(n, J, cycles)
    if planar and nx.check_planarity(h)[0]:
        pos, method = _planar_start(h)
        ref = _Refiner(h, pos)
        P = ref.run(rounds)
        pos = {v: P[ref.index[v]] for v in h}
    else:
        pos, method = nx.kamada_kawai_layout(h), "spring"
    P = np.array([pos[v] for v in h], float)
    lo, hi = P.min(axis=0), P.max(axis=0)
    span = float(max(hi - lo)) or 1.0
    centre = (lo + hi) / 2

    def norm(p):
        return tuple(float(c) for c in (np.asarray(p) - centre) / span + 0.5)
    jpos = tuple(norm(pos[a]) for a in range(J))
    lpos = []
    for x, cyc in enumerate(cycles):
        if len(cyc) >= 3:
            lpos.append(norm(pos[J + x]))
        elif cyc:
            lpos.append(tuple(float(c) for c in np.mean([jpos[a] for a in cyc], axis=0)))
        else:
            lpos.append((0.5, 0.5))
    return ChainLayout(tuple(lpos), jpos, method, cycles)


def drawn_segments(layout: ChainLayout) -> list[tuple[int, int, int]]:
    """The drawn sides ``(link, joint a, joint b)``: one per bar, one per polygon side."""
    segs = []
    for x, cyc in enumerate(layout.polygons):
        if len(cyc) == 2:
            segs.append((x, cyc[0], cyc[1]))
        elif len(cyc) >= 3:
            segs += [(x, cyc[i], cyc[(i + 1) % len(cyc)]) for i in range(len(cyc))]
    return segs


def crossing_pairs(layout: ChainLayout) -> list[tuple[tuple, tuple]]:
    """Pairs of drawn sides of different links that cross or touch away from a shared joint."""
    P = np.array(layout.joints, float)
    segs = drawn_segments(layout)
    bad = []
    for i, s in enumerate(segs):
        for t in segs[i + 1:]:
            if s[0] == t[0] or len({s[1], s[2], t[1], t[2]}) < 4:
                continue
            if _cross(P[s[1]], P[s[2]], P[t[1]], P[t[2]], eps=-1e-15) or any(
                    _point_segment_distance(P[q], P[a], P[b]) < 1e-9
                    for q, (a, b) in ((t[1], s[1:]), (t[2], s[1:]), (s[1], t[1:]), (s[2], t[1:]))):
                bad.append((s, t))
    return bad


def _edge_pairs(E: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Edge index pairs: disjoint ones ``(2, m)``, and ones sharing one end as
    ``(3, k)`` rows (shared vertex, other end of the first, other end of the second)."""
    i, j = np.triu_indices(len(E), 1)
    same = E[i][:, :, None] == E[j][:, None, :]
    disjoint = ~same.any(axis=(1, 2))
    one = same.sum(axis=(1, 2)) == 1
    hit = np.argwhere(same[one])
    ii, jj = i[one][hit[:, 0]], j[one][hit[:, 0]]
    shared = E[ii, hit[:, 1]]
    return (np.stack([i[disjoint], j[disjoint]]),
            np.stack([shared, E[ii, 1 - hit[:, 1]], E[jj, 1 - hit[:, 2]]]).reshape(3, -1))


def _offenders(P: np.ndarray, E: np.ndarray, pairs) -> np.ndarray:
    """Vertices of disjoint edges that cross and of edges on one vertex that overlap
    (angle below 0.5°); empty when the drawing is clean."""
    (i, j), (v, a, b) = pairs
    out = []
    if i.size:
        c = _cross(P[E[i, 0]], P[E[i, 1]], P[E[j, 0]], P[E[j, 1]])
        out += [E[i[c]].ravel(), E[j[c]].ravel()]
    if v.size:
        u, w = P[a] - P[v], P[b] - P[v]
        nu, nw = np.linalg.norm(u, axis=1), np.linalg.norm(w, axis=1)
        sin = np.abs(u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]) / np.maximum(nu * nw, 1e-300)
        o = (sin < 0.009) & (np.einsum("ij,ij->i", u, w) > 0)
        out += [v[o], a[o], b[o]]
    return np.unique(np.concatenate(out)) if out else np.zeros(0, int)


def _bad_pairs(P: np.ndarray, E: np.ndarray, pairs) -> bool:
    return bool(_offenders(P, E, pairs).size)


def has_crossings(g: nx.Graph, pos: dict) -> bool:
    """True when two edges of ``g`` without a common end cross at ``pos``, or two edges
    with one common end overlap."""
    nodes = list(g)
    index = {v: i for i, v in enumerate(nodes)}
    E = np.array([(index[a], index[b]) for a, b in g.edges()], int).reshape(-1, 2)
    if len(E) < 2:
        return False
    P = np.array([pos[v] for v in nodes], float)
    return _bad_pairs(P, E, _edge_pairs(E))


def spread(layout: ChainLayout) -> dict[str, float]:
    """Quality numbers of a layout in the unit square.

    ``joint_gap``: the smallest distance between two joints; ``edge_gap``: the
    smallest distance from a joint to a drawn side it is not on; ``roundness``: the
    smallest ``4π·area / perimeter²`` of a polygon link (1 for a circle, 0.60 for an
    equilateral triangle, 0 for a sliver; 1.0 when there are no polygons).
    """
    P = np.array(layout.joints, float)
    d = np.linalg.norm(P[:, None] - P[None], axis=2) + 10 * np.eye(len(P))
    gap = float(d.min()) if len(P) > 1 else 1.0
    egap = 1.0
    for _, a, b in drawn_segments(layout):
        for q in range(len(P)):
            if q not in (a, b):
                egap = min(egap, float(_point_segment_distance(P[q], P[a], P[b])))
    round_ = 1.0
    for cyc in layout.polygons:
        if len(cyc) >= 3:
            Q = P[list(cyc)]
            area = 0.5 * abs(np.dot(Q[:, 0], np.roll(Q[:, 1], -1)) - np.dot(Q[:, 1], np.roll(Q[:, 0], -1)))
            per = float(np.sum(np.linalg.norm(Q - np.roll(Q, -1, axis=0), axis=1)))
            round_ = min(round_, 4 * math.pi * area / per ** 2)
    return {"joint_gap": gap, "edge_gap": egap, "roundness": round_}
