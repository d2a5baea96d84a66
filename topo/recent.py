"""Values made for the last few frozen objects, kept by the objects' identity.

A :class:`~topo.model.Mechanism` is frozen, so what is derived from one (its Assur
plan, its compiled solve plan, the check's plan) stays valid as long as it lives.  A
caller that meets the same mechanism object again (the page drawing, solving and
checking one design; a script solving it in a loop) gets the value made the first time.
Each entry holds its object, so the object's ``id`` cannot be reused while the entry
lives; the oldest entry goes first once ``kept`` are held.

>>> class Frozen:
...     pass
>>> recent, a = Recent(2), Frozen()
>>> recent.get(a, lambda: 42), recent.get(a, lambda: 0)
(42, 42)

:class:`Kept` keeps values by an equal key instead (a design's coordinate-free form):

>>> kept = Kept(2)
>>> kept.get(("crank", 1), lambda: 42), kept.get(("crank", 1), lambda: 0)
(42, 42)
"""
from __future__ import annotations

__all__ = ["Recent", "Kept"]


class Kept:
    """The values made for the last ``kept`` keys, by value (equal keys share one value;
    a key must be hashable)."""

    def __init__(self, kept: int):
        self.kept = int(kept)
        self._items: dict = {}

    def get(self, key, make):
        """The value kept for ``key``, else ``make()``, kept (the oldest goes first)."""
        hit = self._items.get(key)
        if hit is None:
            hit = self._keep(key, make())
        return hit

    def _keep(self, key, value):
        if len(self._items) >= self.kept:
            del self._items[next(iter(self._items))]
        self._items[key] = value
        return value


class Recent(Kept):
    """The values made for the last ``kept`` objects, by identity (and an optional key)."""

    def get(self, obj, make, *key):
        """The value kept for ``obj`` (and ``key``), else ``make()``, kept."""
        k = (id(obj), *key)
        hit = self._items.get(k)
        if hit is not None and hit[0] is obj:
            return hit[1]
        return self._keep(k, (obj, make()))[1]     # holds obj: its id stays unique while kept
