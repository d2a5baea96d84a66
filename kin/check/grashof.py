"""Grashof class of every four-bar loop (four links closed by four distinct pins).

With s, l the shortest and longest of the four loop lengths and p, q the others
(Grashof 1883; Norton 2012, §2.12):

* s + l < p + q (Grashof): shortest link fixed → *double crank*; shortest adjacent to
  the fixed link → *crank-rocker* (the shortest is the crank); shortest opposite the
  fixed link → *double rocker*;
* s + l = p + q: *change point* (the loop can flatten; branches cross there);
* s + l > p + q: *non-Grashof* (triple rocker, no link turns fully).

The fixed link is the frame when the loop contains it; otherwise the loop link
solved first (nearest the frame in the Assur order), and the class then describes
the relative motion of the loop's links.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from multiloop.topo.model import JointKind, Mechanism

__all__ = ["FourBarLoop", "four_bar_loops", "grashof_class"]

_REL = 1e-9


@dataclass(frozen=True)
class FourBarLoop:
    """A four-bar loop: ``links`` in loop order, ``joints[i]`` joins links i and i+1,
    ``lengths[i]`` is link i's pin distance, ``fixed`` its reference link."""

    links: tuple[str, str, str, str]
    joints: tuple[str, str, str, str]
    lengths: tuple[float, float, float, float]
    fixed: str
    cls: str

    def as_dict(self) -> dict:
        return {"links": list(self.links), "joints": list(self.joints),
                "lengths": [float(x) for x in self.lengths], "fixed": self.fixed,
                "class": self.cls}


def grashof_class(lengths, fixed: int = 0) -> str:
    """Class of a four-bar with ``lengths`` in loop order and link ``fixed`` fixed."""
    L = np.asarray(lengths, float)
    order = np.argsort(L, kind="stable")
    s, lg = L[order[0]], L[order[-1]]
    pq = L.sum() - s - lg
    tol = _REL * L.max()
    if abs(s + lg - pq) <= tol:
        return "change point"
    if s + lg > pq:
        return "non-Grashof"
    short = [i for i in range(4) if abs(L[i] - s) <= tol]
    if fixed in short:
        return "double crank"
    if any((i - fixed) % 4 in (1, 3) for i in short):
        return "crank-rocker"
    return "double rocker"


def four_bar_loops(m: Mechanism, order: dict | None = None) -> tuple[FourBarLoop, ...]:
    """Every loop of four links joined cyclically by four distinct R pins."""
    pins: dict[frozenset, list[str]] = {}
    for j in m.joints:
        if j.kind is JointKind.R:
            for a, b in itertools.combinations(j.links, 2):
                pins.setdefault(frozenset((a, b)), []).append(j.name)
    names = m.link_names
    at = {j.name: np.asarray(j.at, float) for j in m.joints if j.at is not None}
    found: dict[tuple, FourBarLoop] = {}
    rank = order or {lk: i for i, lk in enumerate(names)}
    adj: dict[str, set] = {}
    for p in pins:
        a, b = tuple(p)
        adj.setdefault(a, set()).add(b)
        adj.setdefault(b, set()).add(a)
    idx = {lk: i for i, lk in enumerate(names)}
    near = {a: sorted(nb, key=idx.get) for a, nb in adj.items()}     # in link order: the same loops
    cycles = [(a, b, c, d) for a in names for b in near.get(a, ()) for c in near[b]  # whatever the hash seed
              for d in near[c] if a in adj[d] and len({a, b, c, d}) == 4
              and idx[a] < min(idx[b], idx[c], idx[d]) and idx[b] < idx[d]]
    for cyc in cycles:
        pairs = [frozenset((cyc[i], cyc[(i + 1) % 4])) for i in range(4)]
        if not all(p in pins for p in pairs):
            continue
        for js in itertools.product(*(pins[p] for p in pairs)):
            if len(set(js)) < 4 or any(x not in at for x in js):
                continue
            lengths = tuple(float(np.hypot(*(at[js[i]] - at[js[i - 1]]))) for i in range(4))
            fixed = m.frame if m.frame in cyc else min(cyc, key=lambda x: rank.get(x, 1 << 30))
            cls = grashof_class(lengths, cyc.index(fixed))
            key = (frozenset(cyc), frozenset(js))
            found.setdefault(key, FourBarLoop(tuple(cyc), tuple(js), lengths, fixed, cls))
    return tuple(found.values())
