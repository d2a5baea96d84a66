"""Exact degeneracy test of a batch of chains given by joint bit masks (all ``2^n``
link subsets at once, Pozhbelko & Kuts 2020 count ``3(|S| − 1) − 2c(S) <= 0``)."""
from __future__ import annotations

from functools import lru_cache
from typing import Sequence

import numpy as np

__all__ = ["joint_masks_degenerate"]


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
