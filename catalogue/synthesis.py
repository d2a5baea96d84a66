"""Number and type synthesis of planar chains with simple and multiple joints.

A **chain** here is a connected hypergraph on ``n`` links whose hyperedges are the
joints (a pin on ``n'`` links has multiplicity ``j = n' − 1`` and counts ``n' − 1``
pairs); every link lies on two or more joints, the mobility is
``F = 3(n − 1) − 2p`` and the chain is **non-degenerate**: no link subset ``S``,
``2 <= |S| < n``, has ``3(|S| − 1) − 2c(S) <= 0`` (the structural definitions (README), Pozhbelko & Kuts 2020).

Number synthesis (:func:`number_synthesis`)
    Every link assortment [LA] = (n2, n3, …) and multiple-joint assortment
    [MJA] = (V2, V3, …) that satisfies the structural equations
    ``Σ n_i = n``, ``Σ i n_i = 2p − V`` (the link corners ``SL``), ``m = p − V`` joints,
    and the existence domain of Pozhbelko & Kuts 2020 fig. 10 (``j <= K``, ``V <= 2(K − 1)``),
    flagged by the number of non-degenerate chains that realise it (the
    "universal structural table").

Type synthesis (:func:`iter_chains`, :func:`type_synthesis`)
    The enumeration is split into independent :class:`Task` objects, one per
    number of joints ``m = p − V`` (i.e. per MJ factor ``V``) and per residue class
    ``res/mod`` of nauty's generators, so that any partition gives the same chains.

    * ``V = 0`` (simple joints): ``geng -c -d2 -t n p:p`` lists the connected
      triangle-free graphs of minimum degree 2 (a triangle is a rigid sub-chain);
    * ``V > 0``: ``genbg -c -d2:2 -Z1 n m e:e`` lists the connected bicoloured
      graphs (links × joints, ``e = 2p − V`` incidences); ``-Z1`` (two joints share at
      most one link) is implied by non-degeneracy (two links on two common joints
      are over-constrained).

    Both generators are isomorph-free (colour classes fixed), so the surviving
    graphs are the non-isomorphic chains.  Degeneracy is tested exactly for all
    ``2^n`` link subsets at once, in NumPy batches: with ``D(S)`` the sum of the link
    degrees in ``S`` and ``t(S)`` the number of joints touching ``S``,
    ``c(S) = D(S) − t(S)``, and ``t(S) = m − #{J ⊆ complement(S)}`` is a subset-sum
    (zeta) transform.

    An independent route, :func:`brute_force_chains`, adds joints one at a time to
    ``n`` labelled links (every subset of size 2…j+1 as a candidate), drops
    degenerate partial chains (degeneracy is monotone: adding a joint only raises
    ``c(S)``) and removes isomorphs by pynauty certificates after every step; it
    does not use nauty's generators and checks degeneracy by the definition.

Mechanisms from a chain (:func:`mechanism_choices`)
    The distinct frames (link orbits of the automorphism group) and the distinct
    (frame, driver joint, driven link) choices, by iterated stabilisers (pynauty).

References
----------
.. [1] T. S. Mruthyunjaya, "Kinematic structure of mechanisms revisited", Mechanism
   and Machine Theory 38 (2003) 279–320 (counts of 1-DOF simple-jointed chains:
   1, 2, 16, 230, 6856 for 4…12 links).
.. [2] L.-W. Tsai, *Mechanism Design: Enumeration of Kinematic Structures According
   to Function*, CRC Press, 2001, table 4.x (same counts).
.. [3] B. D. McKay, A. Piperno, "Practical graph isomorphism, II", J. Symbolic
   Computation 60 (2014) 94–112 (geng, genbg).
.. [4] V. A. Pozhbelko, E. N. Kuts (2020): existence domain (fig. 10) and
   the universal structural table.
"""
from __future__ import annotations

import itertools
import shutil
import subprocess
from dataclasses import dataclass
from functools import lru_cache
from typing import Iterable, Iterator, Sequence

import numpy as np
import pynauty

from multiloop.topo.errors import InputError, explain

__all__ = [
    "SynthesisOptions",
    "Task",
    "ChainRecord",
    "AssortmentRow",
    "MechanismChoices",
    "n_pairs",
    "nauty_available",
    "plan_tasks",
    "run_task",
    "count_task",
    "LITERATURE_SJ_F1",
    "iter_chains",
    "type_synthesis",
    "brute_force_chains",
    "number_synthesis",
    "universal_table",
    "chain_record",
    "canonical_string",
    "mechanism_choices",
    "joint_masks_degenerate",
]

#: literature counts of 1-DOF simple-jointed planar chains (Mruthyunjaya 2003; Tsai 2001)
LITERATURE_SJ_F1 = {4: 1, 6: 2, 8: 16, 10: 230, 12: 6856, 14: 318162}

_MAX_LINKS = 16


# ----------------------------------------------------------------------------- options
@dataclass(frozen=True, slots=True)
class SynthesisOptions:
    """What to enumerate.

    Attributes
    ----------
    n : int
        Number of links.
    F : int
        Degrees of freedom (``3(n − 1) − 2p``).
    simple_joints : bool
        Only simple joints (``j = 1``).
    max_multiplicity : int or None
        Largest joint multiplicity ``j`` allowed.
    max_link_degree : int or None
        Largest number of joints on one link.
    planar : bool
        Keep planar chains only (incidence graph planar).
    no_fractionated : bool
        Drop fractionated chains (with a cut link or cut joint).
    """

    n: int
    F: int = 1
    simple_joints: bool = False
    max_multiplicity: int | None = None
    max_link_degree: int | None = None
    planar: bool = False
    no_fractionated: bool = False

    def __post_init__(self):
        problems = []
        if not isinstance(self.n, int) or not 2 <= self.n <= _MAX_LINKS:
            problems.append(explain("links", expected=f"an integer 2…{_MAX_LINKS}", got=repr(self.n)))
        if not isinstance(self.F, int) or self.F < 1:
            problems.append(explain("dof", expected="an integer >= 1", got=repr(self.F)))
        if self.max_multiplicity is not None and self.max_multiplicity < 1:
            problems.append(explain("max multiplicity", expected=">= 1", got=repr(self.max_multiplicity)))
        if self.max_link_degree is not None and self.max_link_degree < 2:
            problems.append(explain("max link degree", expected=">= 2", got=repr(self.max_link_degree)))
        if not problems and (3 * (self.n - 1) - self.F) % 2:
            problems.append(explain(f"n = {self.n}, F = {self.F}",
                                    expected="3(n − 1) − F even (p = (3(n − 1) − F)/2 pairs)",
                                    got=f"3(n − 1) − F = {3 * (self.n - 1) - self.F}",
                                    hint="F = 1 and 3 need an even n, F = 2 an odd n"))
        if problems:
            raise InputError("; ".join(problems))

    @property
    def p(self) -> int:
        return n_pairs(self.n, self.F)

    @property
    def K(self) -> int:
        return self.p - self.n + 1

    @property
    def j_cap(self) -> int:
        """Largest multiplicity searched (user cap, the chain size)."""
        j = 1 if self.simple_joints else self.n - 1
        if self.max_multiplicity is not None:
            j = min(j, self.max_multiplicity)
        return j

    @property
    def i_cap(self) -> int:
        i = self.n - 1
        if self.max_link_degree is not None:
            i = min(i, self.max_link_degree)
        return i

    def key(self) -> str:
        """A stable string naming the options (used in the atlas store)."""
        return (f"n={self.n};F={self.F};sj={int(self.simple_joints)};j={self.max_multiplicity};"
                f"i={self.max_link_degree};planar={int(self.planar)};nofrac={int(self.no_fractionated)}")


def n_pairs(n: int, F: int) -> int:
    """``p = (3(n − 1) − F) / 2`` (Chebyshev–Grübler).

    Examples
    --------
    >>> n_pairs(10, 1), n_pairs(9, 2)
    (13, 11)
    """
    twice = 3 * (n - 1) - F
    if twice < 0 or twice % 2:
        raise InputError(explain(f"n = {n}, F = {F}", expected="3(n − 1) − F even and >= 0",
                                 got=str(twice)))
    return twice // 2


# ----------------------------------------------------------------------------- tasks
@dataclass(frozen=True, slots=True, order=True)
class Task:
    """One independent piece of a type synthesis: ``m`` joints, residue ``res`` of ``mod``."""

    n: int
    F: int
    m: int
    res: int = 0
    mod: int = 1

    @property
    def V(self) -> int:
        return n_pairs(self.n, self.F) - self.m

    @property
    def key(self) -> str:
        return f"n{self.n}F{self.F}m{self.m}r{self.res}of{self.mod}"


def nauty_available() -> bool:
    """True when nauty's ``geng`` and ``genbg`` are on the PATH."""
    return _tool("geng") is not None and _tool("genbg") is not None


@lru_cache(maxsize=None)
def _tool(name: str) -> str | None:
    for cand in (name, f"nauty-{name}"):
        path = shutil.which(cand)
        if path:
            return path
    return None


def _split(m: int, p: int, n: int) -> int:
    """Default number of residue classes for a task (balances the big tasks)."""
    if n <= 10:
        return 1
    if m == p:
        return 1
    return 8 if n <= 12 else 64


def plan_tasks(opts: SynthesisOptions, split: int | None = None) -> list[Task]:
    """The independent tasks of a type synthesis, one per joint count and residue.

    ``m`` runs over the joint counts allowed by the options: ``m = p`` (simple joints
    only) down to the fewest joints that give every link two joints
    (``2p − V = p + m >= 2n``) and respect the multiplicity cap.
    """
    p = opts.p
    tasks = []
    for m in range(p, 0, -1):
        V = p - m
        if p + m < 2 * opts.n:            # not enough corners for degree >= 2
            break
        if V > 0 and opts.j_cap < 2:
            continue
        # a joint of multiplicity j takes j pairs: m joints carry p pairs only if
        # the largest joint reaches ceil(p / m) − 1 … at most j_cap
        if -(-p // m) > opts.j_cap:
            continue
        mod = split if split is not None else _split(m, p, opts.n)
        for r in range(mod):
            tasks.append(Task(opts.n, opts.F, m, r, mod))
    return tasks


# ------------------------------------------------------------------ graph6 decoding
def _graph6_bits(lines: Sequence[bytes], N: int) -> np.ndarray:
    """Upper-triangle adjacency bits of same-order graph6 lines, shape (B, N(N−1)/2)."""
    width = len(lines[0])
    arr = np.frombuffer(b"".join(lines), dtype=np.uint8).reshape(len(lines), width)
    data = arr[:, 1:] - 63
    bits = np.unpackbits(data[:, :, None], axis=2)[:, :, 2:].reshape(len(lines), -1)
    return bits[:, : N * (N - 1) // 2]


def _pos(i: int, j: int) -> int:
    """graph6 bit index of the pair (i, j), i < j."""
    return j * (j - 1) // 2 + i


def _decode_bipartite(lines: Sequence[bytes], n: int, m: int) -> np.ndarray:
    """Joint masks (B, m) of genbg output (links 0…n−1, joints n…n+m−1)."""
    bits = _graph6_bits(lines, n + m)
    idx = np.array([[_pos(i, n + a) for i in range(n)] for a in range(m)])
    sel = bits[:, idx].astype(np.int64)                    # (B, m, n)
    return sel @ (np.int64(1) << np.arange(n, dtype=np.int64))


def _decode_simple(lines: Sequence[bytes], n: int, p: int) -> np.ndarray:
    """Joint (edge) masks (B, p) of geng output."""
    bits = _graph6_bits(lines, n)
    pairs = [(i, j) for j in range(1, n) for i in range(j)]
    pm = np.array([(1 << i) | (1 << j) for i, j in pairs], dtype=np.int64)
    rows, cols = np.nonzero(bits)
    if len(rows) != len(lines) * p:  # pragma: no cover - geng was asked for p edges
        raise RuntimeError("geng returned graphs with an unexpected number of edges")
    return pm[cols].reshape(len(lines), p)


# ------------------------------------------------------------ exact degeneracy test
@lru_cache(maxsize=None)
def _subset_tables(n: int):
    size = np.array([bin(s).count("1") for s in range(1 << n)], dtype=np.int16)
    proper = (size >= 2) & (size <= n - 1)
    # rigid iff D(S) + #{J ⊆ ~S} >= ceil((3|S| − 3) / 2) + m; impossible thresholds
    # (|S| < 2 or |S| = n) are pushed out of reach
    base = np.where(proper, (3 * size - 3 + 1) // 2, 10_000).astype(np.int16)
    return size, base


def joint_masks_degenerate(masks: np.ndarray, n: int) -> np.ndarray:
    """For a batch of chains given by joint masks ``(B, m)`` (bit ``i`` = link ``i``),
    True where some link subset ``2 <= |S| < n`` has ``3(|S| − 1) − 2c(S) <= 0``.

    Exact over all ``2^n`` subsets: ``c(S) = D(S) − t(S)`` with ``D`` the sum of link
    degrees in S and ``t(S) = m − #{J ⊆ complement(S)}`` (zeta transform).  The joints
    of one chain must be distinct masks.

    Examples
    --------
    >>> tri = np.array([[0b011, 0b110, 0b101]])      # the whole chain: not a proper subset
    >>> joint_masks_degenerate(tri, 3).tolist()
    [False]
    >>> four = np.array([[0b0011, 0b0110, 0b1100, 0b1001]])
    >>> joint_masks_degenerate(four, 4).tolist()
    [False]
    >>> tri_tail = np.array([[0b00011, 0b00110, 0b00101, 0b01001, 0b11000, 0b10100]])
    >>> joint_masks_degenerate(tri_tail, 5).tolist()
    [True]
    """
    masks = np.asarray(masks, dtype=np.int64)
    B, m = masks.shape
    _, base = _subset_tables(n)
    thr = base + np.int16(m)
    full = 1 << n
    out = np.zeros(B, dtype=bool)
    step = max(1, (1 << 20) // full)
    for a in range(0, B, step):
        mk = masks[a:a + step]
        b = len(mk)
        cnt = np.zeros((full, b), dtype=np.int8)     # subsets × chains (chains contiguous)
        cnt[mk.ravel(), np.repeat(np.arange(b), m)] = 1
        for i in range(n):                       # zeta transform: #{J ⊆ T}
            view = cnt.reshape(full >> (i + 1), 2, 1 << i, b)
            view[:, 1] += view[:, 0]
        deg = ((mk.T[:, None, :] >> np.arange(n)[None, :, None]) & 1).sum(axis=0).astype(np.int8)  # (n, b)
        D = np.zeros((1, b), dtype=np.int8)      # D(S) by doubling over the bits
        for i in range(n):
            D = np.concatenate([D, D + deg[i]], axis=0)
        total = D.astype(np.int16)
        total += cnt[::-1]                        # #{J ⊆ complement(S)}
        out[a:a + b] = (total >= thr[:, None]).any(axis=0)
    return out


def _degenerate_by_definition(joints: Sequence[int], n: int) -> bool:
    """The definition subset by subset (:func:`topo.degeneracy.rigid_subset_mask`): the
    independent route for :func:`joint_masks_degenerate`."""
    from multiloop.topo.degeneracy import rigid_subset_mask
    return rigid_subset_mask(n, joints) is not None


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


# -------------------------------------------------------------------- generation
def _generator_command(task: Task, opts: SynthesisOptions) -> list[str]:
    p = opts.p
    if task.m == p:   # simple joints: triangle-free graphs, min degree 2
        cmd = [_tool("geng"), "-cq", "-d2", "-t", f"-D{opts.i_cap}", str(opts.n), f"{p}:{p}"]
    else:
        e = p + task.m
        cmd = [_tool("genbg"), "-cq", "-d2:2", f"-D{opts.i_cap}:{opts.j_cap + 1}", "-Z1",
               str(opts.n), str(task.m), f"{e}:{e}"]
    if task.mod > 1:
        cmd.append(f"{task.res}/{task.mod}")
    return cmd


def _raw_task(task: Task, opts: SynthesisOptions, batch: int = 20000) -> Iterator[np.ndarray]:
    """Joint masks of the non-degenerate chains of one task, in batches."""
    if not nauty_available():
        raise InputError(explain("type synthesis", expected="nauty's geng/genbg on the PATH",
                                 got="neither geng nor nauty-geng found",
                                 hint="apt-get install nauty (or pip install passagemath-nauty), "
                                      "or use method='brute-force' for small n"))
    cmd = _generator_command(task, opts)
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    p = opts.p
    try:
        buf: list[bytes] = []
        assert proc.stdout is not None
        for line in proc.stdout:
            buf.append(line.rstrip(b"\n"))
            if len(buf) >= batch:
                yield _filter_batch(buf, task, opts, p)
                buf = []
        if buf:
            yield _filter_batch(buf, task, opts, p)
    finally:
        proc.stdout.close()  # type: ignore[union-attr]
        proc.wait()


def _filter_batch(lines: list[bytes], task: Task, opts: SynthesisOptions, p: int) -> np.ndarray:
    if task.m == p:
        masks = _decode_simple(lines, opts.n, p)
    else:
        masks = _decode_bipartite(lines, opts.n, task.m)
    keep = ~joint_masks_degenerate(masks, opts.n)
    return masks[keep]


def run_task(task: Task, opts: SynthesisOptions, loops: bool = True) -> list[ChainRecord]:
    """All chains of one task with their numbers (after the option filters)."""
    out = []
    for masks in _raw_task(task, opts):
        for row in masks.tolist():
            rec = _record_if_kept(row, opts, loops)
            if rec is not None:
                out.append(rec)
    return out


def count_task(task: Task, opts: SynthesisOptions) -> int:
    """Number of chains of one task (fast path when no per-chain filter is set)."""
    if opts.planar or opts.no_fractionated:
        return len(run_task(task, opts, loops=False))
    return sum(len(masks) for masks in _raw_task(task, opts))


def _record_if_kept(joints: Sequence[int], opts: SynthesisOptions, loops: bool) -> ChainRecord | None:
    rec = chain_record(opts.n, opts.F, joints, loops=loops)
    if opts.planar and not rec.planar:
        return None
    if opts.no_fractionated and rec.fractionated:
        return None
    return rec


def iter_chains(opts: SynthesisOptions, loops: bool = True) -> Iterator[ChainRecord]:
    """Every chain of the options, task after task (serial)."""
    for task in plan_tasks(opts):
        yield from run_task(task, opts, loops)


def type_synthesis(opts: SynthesisOptions, loops: bool = True, workers: int | None = 1,
                   scheduler: str | None = None) -> list[ChainRecord]:
    """All non-isomorphic chains, sorted by canonical form.

    ``workers`` > 1 uses local processes, ``scheduler`` a Dask cluster
    (:mod:`catalogue.distributed`).
    """
    if (workers or 1) == 1 and scheduler is None:
        recs = list(iter_chains(opts, loops))
    else:
        from .distributed import map_tasks
        recs = [r for part in map_tasks(plan_tasks(opts), opts, loops, workers=workers,
                                        scheduler=scheduler) for r in part[1]]
    return sorted(recs, key=lambda r: r.canonical)


# ------------------------------------------------------------------ brute force
def brute_force_chains(opts: SynthesisOptions) -> list[tuple[int, ...]]:
    """Independent route: add joints to ``n`` labelled links one at a time, drop
    degenerate partial chains (by the definition), dedupe by pynauty certificates.

    Returns sorted joint-mask tuples of the surviving chains (connected, every link on
    two or more joints, the options' filters applied except planarity).
    Exponential: meant for ``n <= 8``.
    """
    n, p = opts.n, opts.p
    cands = [sum(1 << x for x in c) for size in range(2, opts.j_cap + 2)
             for c in itertools.combinations(range(n), size) if size - 1 <= p]
    level = {_certificate(n, ()): ()}
    results: dict[bytes, tuple[int, ...]] = {}
    for _ in range(p):
        nxt: dict[bytes, tuple[int, ...]] = {}
        for joints in level.values():
            used = sum(bin(j).count("1") - 1 for j in joints)
            for c in cands:
                if c in joints or used + bin(c).count("1") - 1 > p:
                    continue
                new = tuple(sorted(joints + (c,)))
                if any(bin(c & j).count("1") >= 2 for j in joints):
                    continue   # two links on two common joints: over-constrained
                deg = [sum(1 for j in new if j >> x & 1) for x in range(n)]
                if max(deg) > opts.i_cap:
                    continue
                cert = _certificate(n, new)
                if cert in nxt or cert in results:
                    continue
                if _degenerate_by_definition(new, n):
                    continue
                if used + bin(c).count("1") - 1 == p:
                    if min(deg) >= 2 and _connected(n, new):
                        results[cert] = new
                else:
                    nxt[cert] = new
        level = nxt
        if not level:
            break
    out = []
    for joints in results.values():
        if opts.no_fractionated:
            cl, cj = _fractionation(n, joints)
            if cl or cj:
                continue
        out.append(joints)
    return sorted(out)


# ------------------------------------------------------------- number synthesis
@dataclass(frozen=True, slots=True)
class AssortmentRow:
    """One row of the universal structural table.

    ``chains`` is the number of non-degenerate non-isomorphic chains realising
    ([LA], [MJA]) (``None`` when type synthesis was not run).
    """

    LA: tuple[int, ...]
    MJA: tuple[int, ...]
    V: int
    K: int
    n_joints: int
    chains: int | None = None
    in_domain: bool = True

    @property
    def realisable(self) -> bool | None:
        return None if self.chains is None else self.chains > 0

    @property
    def code_star(self) -> str:
        from multiloop.topo.numbers import structural_codes
        degrees = [i for i, c in enumerate(self.LA, 2) for _ in range(c)]
        mult = [j for j, c in enumerate(self.MJA, 2) for _ in range(c)]
        mult += [1] * (self.n_joints - len(mult))          # the simple joints
        codes = structural_codes(degrees, mult)
        assert codes.K == self.K   # the row satisfies the structural equations
        return codes.code_star

    def as_dict(self) -> dict:
        return {"LA": list(self.LA), "MJA": list(self.MJA), "V": self.V, "K": self.K,
                "n_joints": self.n_joints, "code_star": self.code_star,
                "chains": self.chains, "realisable": self.realisable, "in_domain": self.in_domain}


def _compositions(total_items: int, total_weight: int, weights: Sequence[int]) -> Iterator[tuple[int, ...]]:
    """Non-negative (c_k) with Σ c_k = total_items and Σ c_k w_k = total_weight."""
    if not weights:
        if total_items == 0 and total_weight == 0:
            yield ()
        return
    w, rest = weights[0], weights[1:]
    for c in range(total_items + 1):
        if c * w > total_weight:
            break
        for tail in _compositions(total_items - c, total_weight - c * w, rest):
            yield (c,) + tail


def _strip(t: tuple[int, ...]) -> tuple[int, ...]:
    t = list(t)
    while t and t[-1] == 0:
        t.pop()
    return tuple(t)


def number_synthesis(opts: SynthesisOptions) -> list[AssortmentRow]:
    """All ([LA], [MJA]) satisfying the structural equations and the existence domain.

    Equations: ``m = p − V`` joints with ``Σ_j j V_j <= p`` (simple joints take the
    rest), ``Σ n_i = n`` and ``Σ i n_i = 2p − V``; link degrees ``2 <= i <= m``;
    existence domain ``j <= K`` and ``V <= 2(K − 1)`` (Pozhbelko & Kuts 2020 fig. 10).
    """
    n, p, K = opts.n, opts.p, opts.K
    jtop = min(opts.j_cap, K)
    rows = []
    mjas: list[tuple[int, ...]] = []
    # multiple joints: V_j for j = 2..jtop with V = Σ (j − 1) V_j <= 2(K − 1), Σ j V_j <= p
    def rec(j: int, acc: tuple[int, ...], V: int, pairs: int):
        if j > jtop:
            mjas.append(acc)
            return
        c = 0
        while V + c * (j - 1) <= 2 * (K - 1) and pairs + c * j <= p:
            rec(j + 1, acc + (c,), V + c * (j - 1), pairs + c * j)
            c += 1
    rec(2, (), 0, 0)
    for mja in mjas:
        V = sum((j - 1) * c for j, c in zip(range(2, jtop + 1), mja))
        if V > 2 * max(K - 1, 0):
            continue
        m = p - V
        corners = 2 * p - V
        itop = min(opts.i_cap, m)
        for la in _compositions(n, corners, list(range(2, itop + 1))):
            rows.append(AssortmentRow(_strip(la), _strip(mja), V, K, m))
    return sorted(rows, key=lambda r: (r.V, r.MJA, r.LA))


def universal_table(opts: SynthesisOptions, records: Iterable[ChainRecord]) -> list[AssortmentRow]:
    """:func:`number_synthesis` rows with the number of chains realising each.

    A chain whose assortments lie outside the existence domain gets an extra row with
    ``in_domain = False`` (none for F = 1 and 2 in the atlases computed; for F = 3 a
    fractionated chain with a cut joint of multiplicity ``j = K + 1`` exists, e.g.
    n = 10: four loops hung on one 5-link pin).
    """
    counts: dict[tuple, int] = {}
    for r in records:
        key = (_strip(r.LA), _strip(r.MJA))
        counts[key] = counts.get(key, 0) + 1
    rows = [AssortmentRow(r.LA, r.MJA, r.V, r.K, r.n_joints, counts.pop((r.LA, r.MJA), 0))
            for r in number_synthesis(opts)]
    # chains outside the existence domain (found for F >= 3: cut joints of high
    # multiplicity) are listed too, flagged in_domain = False
    K = opts.K
    for (LA, MJA), c in sorted(counts.items()):
        V = sum((j - 1) * v for j, v in zip(range(2, 2 + len(MJA)), MJA))
        rows.append(AssortmentRow(LA, MJA, V, K, opts.p - V, c, in_domain=False))
    return rows


# ------------------------------------------------------------ mechanisms from chains
@dataclass(frozen=True, slots=True)
class MechanismChoices:
    """Distinct inversions of a chain up to its automorphisms.

    Attributes
    ----------
    frames : tuple of int
        One link index per orbit of links (the distinct frames).
    drivers : tuple of (int, int, int)
        One ``(frame, joint, driven link)`` per orbit: the driver is the rotation
        of the driven link relative to the frame at a joint on the frame.
    group_order : float
        Order of the automorphism group of the chain.
    """

    frames: tuple[int, ...]
    drivers: tuple[tuple[int, int, int], ...]
    group_order: float

    @property
    def n_frames(self) -> int:
        return len(self.frames)

    @property
    def n_drivers(self) -> int:
        return len(self.drivers)


def _orbit_reps(n: int, joints: Sequence[int], fixed: Sequence[int], candidates: Iterable[int]) -> list[int]:
    g = _nauty_incidence(n, joints, [{v} for v in fixed])
    _, order, _, orbits, _ = pynauty.autgrp(g)
    reps: dict[int, int] = {}
    for v in candidates:
        reps.setdefault(orbits[v], v)
    return sorted(reps.values())


def mechanism_choices(n: int, joints: Sequence[int]) -> MechanismChoices:
    """Distinct frames and (frame, driver) choices of a chain up to symmetry.

    Examples
    --------
    >>> four_bar = [0b0011, 0b0110, 0b1100, 0b1001]
    >>> c = mechanism_choices(4, four_bar)
    >>> c.n_frames, c.n_drivers, c.group_order
    (1, 1, 8.0)
    """
    joints = list(joints)
    _, order, _, _, _ = pynauty.autgrp(_nauty_incidence(n, joints))
    frames = _orbit_reps(n, joints, (), range(n))
    drivers = []
    for f in frames:
        on_f = [n + a for a, jm in enumerate(joints) if jm >> f & 1]
        for jv in _orbit_reps(n, joints, (f,), on_f):
            others = [x for x in _mask_links(joints[jv - n]) if x != f]
            for x in _orbit_reps(n, joints, (f, jv), others):
                drivers.append((f, jv - n, x))
    return MechanismChoices(tuple(frames), tuple(drivers), float(order))
