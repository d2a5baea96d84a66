"""The triad's modes' numbers shared by its NumPy route (:mod:`kin.groups.triad`) and its
compiled one (:mod:`kin.groups._triad_nb`, which numba freezes as constants): the
16-point DFT that reads the coefficients of the modes' polynomial on the unit circle,
the half-angle basis that makes it a real polynomial (Hunt 1983), and the tracker's
tolerances and stride."""
from __future__ import annotations

import numpy as np

__all__ = ["ACCEPT", "ON_CIRCLE", "NEWTON_ITERS", "STRIDE", "BASIS", "GRID", "Z16", "DFT"]

#: relative residual for an accepted mode
ACCEPT = 1e-9
#: | |z| - 1 | below which a root is tried as a real mode
ON_CIRCLE = 1e-3
#: Newton iterations of a mode's polish
NEWTON_ITERS = 8
#: the tracker's coarse stride: all modes every ``STRIDE`` inputs of a longer path
STRIDE = 32


def _tan_half_basis():
    """Rows j = 3..-3: ascending coefficients in t of (1+it)^(3+j) (1-it)^(3-j),
    i.e. ``e^{ijψ}(1+t²)³`` with ``t = tan(ψ/2)``."""
    from numpy.polynomial import polynomial as npp
    rows = []
    for j in range(3, -4, -1):
        rows.append(npp.polymul(npp.polypow([1, 1j], 3 + j), npp.polypow([1, -1j], 3 - j)))
    return np.array(rows)                                # (7, 7) complex


BASIS = _tan_half_basis()
GRID = np.exp(1j * np.outer(np.arange(3, -4, -1), 2 * np.pi * np.arange(16) / 16))  # (7, 16)
Z16 = np.exp(2j * np.pi * np.arange(16) / 16)                                        # (16,)
DFT = np.exp(-2j * np.pi * np.outer(np.arange(3, -4, -1), np.arange(16)) / 16)       # (7, 16)
