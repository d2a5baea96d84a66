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
"""
from __future__ import annotations

__all__ = ["Recent"]


class Recent:
    """The values made for the last ``kept`` objects, by identity (and an optional key)."""

    def __init__(self, kept: int):
        self.kept = int(kept)
        self._items: dict = {}

    def get(self, obj, make, *key):
        """The value kept for ``obj`` (and ``key``), else ``make()``, kept."""
        k = (id(obj), *key)
        hit = self._items.get(k)
        if hit is not None and hit[0] is obj:
            return hit[1]
        value = make()
        if len(self._items) >= self.kept:
            del self._items[next(iter(self._items))]
        self._items[k] = (obj, value)       # holds obj: its id stays unique while kept
        return value
