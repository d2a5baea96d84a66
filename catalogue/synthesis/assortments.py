"""The link and multiple-joint assortments [LA] and [MJA] of a batch of chains given by
joint bit masks (Pozhbelko & Kuts 2020: ``n_i`` links on ``i`` joints, ``V_j`` joints of
multiplicity ``j``), as count arrays, and a batch's rows tallied."""
from __future__ import annotations

from collections import Counter

import numpy as np

from .options import SynthesisOptions

__all__ = ["batch_assortments", "in_row", "tally_rows"]


def batch_assortments(masks: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``(LA, MJA)`` of every chain of a batch ``(B, m)`` of joint masks: ``LA[b, i − 2]``
    links on ``i`` joints (``i = 2 … n``), ``MJA[b, j − 2]`` joints of multiplicity ``j``
    (``j = 2 … n − 1``), trailing zeros kept (width ``n − 1`` and ``n − 2``).

    Examples
    --------
    >>> la, mja = batch_assortments(np.array([[0b0011, 0b0110, 0b1100, 0b1001]]), 4)
    >>> la.tolist(), mja.tolist()
    ([[4, 0, 0]], [[0, 0]])
    """
    masks = np.asarray(masks, dtype=np.int64)
    B = len(masks)
    bits = (masks[:, :, None] >> np.arange(n)[None, None, :]) & 1          # (B, m, n)
    degree = bits.sum(axis=1)                                               # joints per link
    size = bits.sum(axis=2)                                                 # links per joint
    la = np.zeros((B, n + 1), dtype=np.int64)
    mja = np.zeros((B, n + 1), dtype=np.int64)
    rows = np.arange(B)[:, None]
    np.add.at(la, (np.broadcast_to(rows, degree.shape), degree), 1)
    np.add.at(mja, (np.broadcast_to(rows, size.shape), size - 1), 1)
    return la[:, 2:], mja[:, 2:n]


def _padded(counts: tuple[int, ...], width: int) -> np.ndarray:
    """``counts`` with zeros to ``width`` (a joint has at most ``n`` links and a link at
    most ``n`` joints, so a valid row never reaches past the batch's width)."""
    out = np.zeros(width, dtype=np.int64)
    out[:len(counts)] = counts[:width]
    return out


def in_row(masks: np.ndarray, opts: SynthesisOptions) -> np.ndarray:
    """True for the chains of the batch whose [LA] and [MJA] are the options' restricted
    row (every chain when no row is set)."""
    keep = np.ones(len(masks), dtype=bool)
    if opts.la is None and opts.mja is None or not len(masks):
        return keep
    la, mja = batch_assortments(masks, opts.n)
    for want, have in ((opts.la, la), (opts.mja, mja)):
        if want is not None:
            keep &= (have == _padded(want, have.shape[1])).all(axis=1)
    return keep


def _strip(row: np.ndarray) -> tuple[int, ...]:
    nz = np.flatnonzero(row)
    return tuple(int(c) for c in row[:nz[-1] + 1]) if len(nz) else ()


def tally_rows(masks: np.ndarray, n: int) -> Counter:
    """The chains of a batch counted by their row: ``{(LA, MJA): chains}`` with both
    assortments as tuples without trailing zeros (the table's convention)."""
    if not len(masks):
        return Counter()
    la, mja = batch_assortments(masks, n)
    both = np.concatenate([la, mja], axis=1)
    uniq, counts = np.unique(both, axis=0, return_counts=True)
    w = la.shape[1]
    return Counter({(_strip(u[:w]), _strip(u[w:])): int(c) for u, c in zip(uniq, counts)})
