"""One chain of an atlas with its structural numbers (:class:`ChainRecord`): canonical
string, codes (Pozhbelko & Kuts 2020), fractionation, planarity and [La]."""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Sequence

import pynauty
import rustworkx as rx

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


def _incidence_rx(n: int, tuples: Sequence[Sequence[int]]) -> rx.PyGraph:
    """The incidence graph for rustworkx (links 0…n−1, joints n…n+m−1)."""
    g = rx.PyGraph(multigraph=False)
    g.add_nodes_from(range(n + len(tuples)))
    g.add_edges_from_no_data([(x, n + a) for a, j in enumerate(tuples) for x in j])
    return g


def _fractionation(n: int, joints: Sequence[int], F: int | None = None,
                   graph: rx.PyGraph | None = None) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """Cut links and cut joints (indices): the articulation points of the incidence
    graph (rustworkx; :func:`_fractionation_by_removal` is the independent route).

    With ``F`` given the chain is taken to be non-degenerate, and the searches that
    cannot succeed are skipped: splitting at a cut link gives ``F = F_A + F_B``, at a
    cut joint ``F = F_A + F_B + 1``, with ``F_A, F_B >= 1`` for proper non-degenerate
    parts, so cut links need ``F >= 2`` and cut joints ``F >= 3``.
    """
    if F is not None and F < 2:
        return (), ()
    g = _incidence_rx(n, [_mask_links(int(jm)) for jm in joints]) if graph is None else graph
    arts = sorted(rx.articulation_points(g))
    cut_links = tuple(v for v in arts if v < n)
    if F is not None and F < 3:
        return cut_links, ()
    return cut_links, tuple(v - n for v in arts if v >= n)


def _fractionation_by_removal(n: int, joints: Sequence[int]) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """The definition: a link or joint whose removal disconnects the links."""
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


def chain_record(n: int, F: int, joints: Sequence[int], loops: bool = True) -> ChainRecord:
    """Numbers of a chain given by joint masks.

    Planarity always (incidence graph, rustworkx's compiled test); the loop assortment [La] and ``L0`` via
    :func:`topo.loops.loop_assortment` when ``loops`` (the slow part: ~10 ms a chain).
    """
    from multiloop.topo.numbers import structural_codes

    joints = sorted(int(j) for j in joints)
    tuples = tuple(_mask_links(j) for j in joints)
    deg = [0] * n
    for j in tuples:
        for x in j:
            deg[x] += 1
    codes = structural_codes(deg, [len(j) - 1 for j in tuples])
    graph = _incidence_rx(n, tuples)
    cl, cj = _fractionation(n, joints, F, graph)
    La = L0 = None
    if loops:
        from multiloop.topo.loops import loop_assortment
        from multiloop.topo.model import chain_from_joint_lists
        la = loop_assortment(chain_from_joint_lists([[str(x + 1) for x in j] for j in tuples]))
        planar, La, L0 = la.planar, la.sizes, la.outer
    else:
        planar = rx.is_planar(graph)
    return ChainRecord(n=n, F=F, joints=tuples, canonical=canonical_string(n, joints), LA=codes.LA,
                       MJA=codes.MJA, V=codes.V, K=codes.K, j_max=codes.j_max, code=codes.code,
                       code_star=codes.code_star, fractionated=bool(cl or cj),
                       planar=planar, La=La, L0=L0)
