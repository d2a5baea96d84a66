"""One chain of an atlas with its structural numbers (:class:`ChainRecord`): canonical
string, codes (Pozhbelko & Kuts 2020), fractionation, planarity and [La]."""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Sequence

import pynauty

__all__ = ["ChainRecord", "chain_record", "canonical_string"]


# --------------------------------------------------------------- chain properties
@lru_cache(maxsize=1 << 17)
def _mask_links(mask: int) -> tuple[int, ...]:
    return tuple(i for i in range(mask.bit_length()) if mask >> i & 1)


def _connected(n: int, joints: Sequence[int], skip_link: int | None = None) -> bool:
    alive = ((1 << n) - 1) & ~(0 if skip_link is None else 1 << skip_link)
    js = [jm & alive for jm in joints]
    js = [jm for jm in js if jm]
    if not alive:
        return True
    seen = alive & -alive
    changed = True
    while changed:
        changed = False
        for jm in js:
            if jm & seen and jm & ~seen:
                seen |= jm
                changed = True
    return seen == alive


def _fractionation(n: int, joints: Sequence[int], F: int | None = None) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """Cut links and cut joints (indices) of the incidence graph.

    With ``F`` given the chain is taken to be non-degenerate, and the searches that
    cannot succeed are skipped: splitting at a cut link gives ``F = F_A + F_B``, at a
    cut joint ``F = F_A + F_B + 1``, with ``F_A, F_B >= 1`` for proper non-degenerate
    parts, so cut links need ``F >= 2`` and cut joints ``F >= 3``.
    """
    if F is not None and F < 2:
        return (), ()
    if F is not None and F < 3:
        return tuple(x for x in range(n) if not _connected(n, joints, skip_link=x)), ()
    cut_links = tuple(x for x in range(n) if not _connected(n, joints, skip_link=x))
    cut_joints = tuple(a for a in range(len(joints))
                       if not _connected(n, [jm for b, jm in enumerate(joints) if b != a]))
    return cut_links, cut_joints


def _nauty_incidence(n: int, joints: Sequence[int], extra_colours: Sequence[set] = ()) -> pynauty.Graph:
    """Coloured incidence graph (links 0…n−1, joints n…n+m−1), as topo.isomorphism."""
    m = len(joints)
    adj = {n + a: list(_mask_links(jm)) for a, jm in enumerate(joints)}
    taken = set().union(*extra_colours) if extra_colours else set()
    colouring = [set(range(n)) - taken, set(range(n, n + m)) - taken, *extra_colours]
    colouring = [c for c in colouring if c]
    return pynauty.Graph(n + m, directed=False, adjacency_dict=adj, vertex_coloring=colouring)


def canonical_string(n: int, joints: Sequence[int]) -> str:
    """:func:`topo.isomorphism.canonical_form` (mode ``chain``) of a chain given by
    joint masks."""
    from multiloop.topo.isomorphism import canonical_form_of_joints
    return canonical_form_of_joints(n, [_mask_links(int(jm)) for jm in joints])


def _certificate(n: int, joints: Sequence[int]) -> bytes:
    return pynauty.certificate(_nauty_incidence(n, joints)) + bytes([len(joints)])


@dataclass(frozen=True, slots=True)
class ChainRecord:
    """One chain of an atlas with its structural numbers.

    ``joints`` lists each joint as a tuple of link indices ``0…n−1`` (links are
    named ``"1"…"n"`` and joints ``J1…Jm`` in :meth:`as_mechanism`).
    """

    n: int
    F: int
    joints: tuple[tuple[int, ...], ...]
    canonical: str
    LA: tuple[int, ...]
    MJA: tuple[int, ...]
    V: int
    K: int
    j_max: int
    code: str
    code_star: str
    fractionated: bool
    planar: bool | None = None
    La: tuple[int, ...] | None = None
    L0: int | None = None

    @property
    def joint_lists(self) -> list[list[str]]:
        return [[str(x + 1) for x in j] for j in self.joints]

    def as_mechanism(self):
        """The chain as a :class:`topo.model.Mechanism` (bare chain)."""
        from multiloop.topo.model import chain_from_joint_lists
        return chain_from_joint_lists(self.joint_lists)

    def as_dict(self) -> dict:
        return {"canonical": self.canonical, "LA": list(self.LA), "MJA": list(self.MJA),
                "V": self.V, "K": self.K, "n": self.n, "F": self.F, "j_max": self.j_max,
                "code": self.code, "code_star": self.code_star, "planar": self.planar,
                "fractionated": self.fractionated,
                "La": None if self.La is None else list(self.La), "L0": self.L0,
                "joints": self.joint_lists}


def _bipartite(adj: dict[int, set[int]]) -> bool:
    side: dict[int, int] = {}
    for start in adj:
        if start in side:
            continue
        side[start] = 0
        stack = [start]
        while stack:
            v = stack.pop()
            for w in adj[v]:
                if w not in side:
                    side[w] = 1 - side[v]
                    stack.append(w)
                elif side[w] == side[v]:
                    return False
    return True


def _is_planar(n: int, joints: Sequence[Sequence[int]]) -> bool:
    """Planarity of the incidence graph.

    Vertices of degree <= 2 are suppressed first (subdivisions, parallel edges and
    pendant vertices do not change planarity); a reduced graph with at most 4
    vertices or 8 edges is planar (K3,3 has 9 edges), one with more than
    ``3v − 6`` edges is not; the rest goes to networkx's LR test.
    """
    import networkx as nx

    adj: dict[int, set[int]] = {x: set() for x in range(n)}
    for a, j in enumerate(joints):
        adj[n + a] = set(j)
        for x in j:
            adj[x].add(n + a)
    stack = [v for v in adj if len(adj[v]) <= 2]
    while stack:
        v = stack.pop()
        if v not in adj or len(adj[v]) > 2:
            continue
        nbs = adj.pop(v)
        for u in nbs:
            adj[u].discard(v)
        if len(nbs) == 2:
            u, w = nbs
            adj[u].add(w)
            adj[w].add(u)
        stack.extend(u for u in nbs if len(adj[u]) <= 2)
    nv = len(adj)
    ne = sum(len(s) for s in adj.values()) // 2
    if nv <= 4 or ne <= 8:
        return True
    if ne > 3 * nv - 6:
        return False
    if ne - nv + 1 <= 4:
        # connected, min degree 3, cyclomatic number <= 4: K5 (cyclomatic 6) is out
        # of reach and a K3,3 subdivision would be all of it (cyclomatic 4), i.e. the
        # reduced graph is 3-regular on 6 vertices and bipartite
        if ne - nv + 1 < 4 or nv != 6 or any(len(s) != 3 for s in adj.values()):
            return True
        return not _bipartite(adj)
    g = nx.Graph()
    g.add_edges_from((u, w) for u, s in adj.items() for w in s if u < w)
    return nx.check_planarity(g)[0]


def chain_record(n: int, F: int, joints: Sequence[int], loops: bool = True) -> ChainRecord:
    """Numbers of a chain given by joint masks.

    Planarity always (incidence graph); the loop assortment [La] and ``L0`` via
    :func:`topo.loops.loop_assortment` when ``loops`` (the slow part: ~10 ms a chain).
    """
    from multiloop.topo.numbers import structural_codes

    joints = sorted(int(j) for j in joints)
    deg = [sum(1 for j in joints if j >> x & 1) for x in range(n)]
    codes = structural_codes(deg, [bin(j).count("1") - 1 for j in joints])
    cl, cj = _fractionation(n, joints, F)
    tuples = tuple(_mask_links(j) for j in joints)
    La = L0 = None
    if loops:
        from multiloop.topo.loops import loop_assortment
        from multiloop.topo.model import chain_from_joint_lists
        la = loop_assortment(chain_from_joint_lists([[str(x + 1) for x in j] for j in tuples]))
        planar, La, L0 = la.planar, la.sizes, la.outer
    else:
        planar = _is_planar(n, tuples)
    return ChainRecord(n=n, F=F, joints=tuples, canonical=canonical_string(n, joints), LA=codes.LA,
                       MJA=codes.MJA, V=codes.V, K=codes.K, j_max=codes.j_max, code=codes.code,
                       code_star=codes.code_star, fractionated=bool(cl or cj),
                       planar=planar, La=La, L0=L0)
