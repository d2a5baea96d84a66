"""Values derived from a frozen object on first use, kept beside it, never in it.

A :class:`~kin.solve.SolvePlan` is frozen: no field of it changes after
:func:`~kin.solve.compile_plan`.  What is worth computing once per plan but only on
demand (the certified chart of a driver's motion, the plan lowered for the compiled
kernel, the steps needed for a set of outputs) is kept here, keyed by the plan's
identity, and goes away with the plan (a weak reference), as :func:`functools.cache`
keeps a function's results beside its arguments.

>>> class Plan:
...     pass
>>> owner = Plan()
>>> cached(owner, "twice", lambda o, a: 2 * a, 21)
42
>>> cached(owner, "twice", lambda o, a: 0, 21)     # kept: not computed again
42
"""
from __future__ import annotations

import weakref

__all__ = ["memo_of", "cached", "MEMO_KEPT"]

#: largest number of keys kept per owner before the oldest argument-keyed half is dropped
MEMO_KEPT = 64

_MEMOS: "weakref.WeakKeyDictionary[object, dict]" = weakref.WeakKeyDictionary()


def memo_of(owner) -> dict:
    """The memo of ``owner`` (hashable, weakly referenceable): a dict made on first use."""
    memo = _MEMOS.get(owner)
    if memo is None:
        memo = _MEMOS[owner] = {}
    return memo


def cached(owner, key, f, arg=None):
    """``f(owner, arg)`` kept in the memo of ``owner`` under ``key``.  Past
    :data:`MEMO_KEPT` keys, the oldest 32 keys that are tuples (values for one argument,
    e.g. ``("needed", outputs)``) are dropped first."""
    memo = memo_of(owner)
    hit = memo.get(key)
    if hit is None:
        if len(memo) > MEMO_KEPT:
            for k in [k for k in memo if isinstance(k, tuple)][:32]:
                del memo[k]
        hit = memo[key] = f(owner, arg)
    return hit
