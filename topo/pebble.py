"""The (2, 3) pebble game on the bar framework of a chain: rigid sub-chains in O(n²).

A chain's links are rigid bodies and its joints pins (a joint on m links is m − 1
pairs).  Replace every link by a rigid bar framework on its own joints: the joints
``p1 … pm`` of a link (m >= 2), in the chain's joint order, get the bars ``p1p2`` and
``p1pi, p2pi`` for ``i >= 3`` (``2m − 3`` bars, a triangulated fan).  For a link set S
touching the joint set V(S),

    2|V(S)| − Σ_{L∈S} (2 m_L − 3) = 3|S| − 2c(S),    c(S) = Σ_J (|S ∩ J| − 1),

so S is rigid or over-constrained in the sense of Pozhbelko & Kuts 2020 (3(|S| − 1) −
2c(S) <= 0) exactly when its bars number at least 2|V(S)| − 3: by Laman's theorem
(Laman 1970), when the bars of S contain a redundant bar or span a rigid component.
The pebble game of Jacobs & Hendrickson (1997) — each joint holds two pebbles, a bar
is independent when four pebbles can be gathered on its ends — finds both, and the
rigid components are unions of whole links (a joint with bars to two joints of a rigid
set belongs to it).

:func:`rigid_links` returns a link set found this way (the caller checks it against
the count), or None when there is none; it answers ``"unknown"`` where the game does
not settle it here (a link with fewer than two joints, or the whole chain as the only
rigid set, i.e. F <= 0), and the caller uses another route.

References
----------
Laman G. On graphs and rigidity of plane skeletal structures. J. Eng. Math. 4 (1970).
Jacobs D.J., Hendrickson B. An algorithm for two-dimensional rigidity percolation:
the pebble game. J. Comput. Phys. 137 (1997) 346–365.
Lee A., Streinu I. Pebble game algorithms and sparse graphs. Discrete Math. 308 (2008).
"""
from __future__ import annotations

from .model import Mechanism

__all__ = ["link_bars", "PebbleGame", "rigid_links"]


def link_bars(m: Mechanism) -> list[tuple[int, int, int]] | None:
    """The bars ``(joint a, joint b, link)`` of every link's fan, or None when a link has
    fewer than two joints (no bar framework stands for it)."""
    pins: dict[str, list[int]] = {x: [] for x in m.link_names}
    for k, j in enumerate(m.joints):
        for x in j.links:
            pins[x].append(k)
    bars = []
    for li, x in enumerate(m.link_names):
        p = pins[x]
        if len(p) < 2:
            return None
        bars.append((p[0], p[1], li))
        for q in p[2:]:
            bars += [(p[0], q, li), (p[1], q, li)]
    return bars


class PebbleGame:
    """Jacobs & Hendrickson's (2, 3) pebble game on ``n`` vertices (a multigraph).

    ``pebbles[v]`` free pebbles on v; ``out[v]`` the bars v's pebbles cover (as the
    other ends, with multiplicity).
    """

    def __init__(self, n: int):
        self.pebbles = [2] * n
        self.out: list[list[int]] = [[] for _ in range(n)]

    def _find(self, v: int, blocked: set[int]) -> bool:
        """Bring one free pebble to v along the covered bars (reversing the path), never
        taking one from ``blocked``; False (and the set searched in ``self.seen``) if none."""
        seen = {v} | blocked
        stack = [(v, iter(self.out[v]))]
        parent = {}
        while stack:
            u, it = stack[-1]
            w = next(it, None)
            if w is None:
                stack.pop()
                continue
            if w in seen:
                continue
            seen.add(w)
            parent[w] = u
            if self.pebbles[w] > 0:
                self.pebbles[w] -= 1
                while w != v:          # reverse the path: w now covers the bar to its parent
                    u = parent[w]
                    self.out[u].remove(w)
                    self.out[w].append(u)
                    w = u
                self.pebbles[v] += 1
                return True
            stack.append((w, iter(self.out[w])))
        self.seen = seen - blocked
        return False

    def gather(self, v: int, want: int, blocked: set[int]) -> bool:
        """Free pebbles on v up to ``want``, holding the pebbles of ``blocked``."""
        while self.pebbles[v] < want:
            if not self._find(v, blocked):
                return False
        return True

    def insert(self, a: int, b: int) -> bool:
        """Insert bar ab if independent (True); False if redundant (``self.seen`` is
        then the over-constrained region found, both ends included)."""
        if not (self.gather(a, 2, {b}) and self.gather(b, 2, {a})):
            self.seen = self.seen | {a, b}
            return False
        self.pebbles[a] -= 1
        self.out[a].append(b)
        return True

    def hold(self, a: int, b: int) -> None:
        """Hold three pebbles on the ends of an inserted bar ab (two on a, one on b)."""
        self.gather(a, 2, {b})
        self.gather(b, 1, {a})

    def rigid(self, w: int, a: int, b: int) -> bool:
        """Whether vertex w is rigid with bar ab, whose three pebbles are held: it is
        when no free pebble can be brought to it."""
        return self.pebbles[w] == 0 and not self._find(w, {a, b})


def rigid_links(m: Mechanism) -> list[str] | None | str:
    """Candidate link set S, 2 <= |S| < n, with 3(|S| − 1) − 2c(S) <= 0 (the caller checks
    the count); None when none exists; ``"unknown"`` when the game does not settle it
    (a link with fewer than two joints, or the whole chain as the only rigid set)."""
    bars = link_bars(m)
    if bars is None:
        return "unknown"
    n_j, names = m.n_joints, m.link_names
    game = PebbleGame(n_j)
    pins_of: dict[int, set[int]] = {}
    first: dict[int, tuple[int, int]] = {}
    for a, b, li in bars:
        pins_of.setdefault(li, set()).update((a, b))
        first.setdefault(li, (a, b))
    for a, b, li in bars:
        if not game.insert(a, b):
            region = [names[x] for x, p in pins_of.items() if len(p & game.seen) >= 2]
            return region if len(region) < len(names) else "unknown"
    # a rigid component is connected: if it holds link a and another link, it holds a
    # link that shares a joint with a, with all of that link's joints
    links_at: list[list[int]] = [[] for _ in range(n_j)]
    for li, p in pins_of.items():
        for v in p:
            links_at[v].append(li)
    for li, (a, b) in first.items():
        game.hold(a, b)
        for other in sorted({x for v in pins_of[li] for x in links_at[v]} - {li}):
            if all(v in pins_of[li] or game.rigid(v, a, b) for v in pins_of[other]):
                return _component(game, a, b, n_j, pins_of, names)
    return None


def _component(game: PebbleGame, a: int, b: int, n: int, pins_of: dict, names) -> list[str] | str:
    """The links of the rigid component of bar ab (its three pebbles held): a vertex that
    cannot get a free pebble is rigid with ab, and so is every vertex its search reached."""
    comp = {a, b}
    for w in range(n):
        if w not in comp and game.rigid(w, a, b):
            comp |= game.seen
    inside = [names[x] for x, p in pins_of.items() if p <= comp]
    return inside if len(inside) < len(names) else "unknown"
