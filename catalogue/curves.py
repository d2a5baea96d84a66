"""Curve shape descriptors for retrieval: arc-length resampling, normalisation for
position, size and orientation, Fourier descriptors, the aligned distance that ranks
candidates, and LInK's chamfer score.

A planar curve is read as complex numbers ``z_i = x_i + i y_i``.

* **Resampling** by arc length (``M`` points, closed curves without repeating the first
  point), so the sampling of the input does not matter.
* **Normalisation** (Zahn & Roskies 1972; Kuhl & Giardina 1982): subtract the centroid,
  divide by the RMS radius ``sqrt(mean |z|²)``.
* **Descriptor**: the magnitudes ``|Z_k|`` of the discrete Fourier coefficients
  ``Z_k = M⁻¹ Σ z_i e^{-2πi k i/M}`` for ``k = 1…H`` and ``k = −1…−H``.  A rotation
  multiplies every ``Z_k`` by ``e^{iφ}`` and a change of start point by ``e^{ikτ}``,
  so the magnitudes are invariant to both; traversing the curve backwards swaps
  ``Z_k`` and ``Z_{−k}`` (:func:`reversed_descriptor`).  An **open** curve is made
  closed by retracing it (there and back), whose descriptor is the same for both
  directions.
* **Aligned distance** (the ranking after retrieval): the RMS distance between two
  normalised curves minimised over the start shift, the rotation and the direction,
  for all shifts at once by an FFT cross-correlation: for a shift ``s``,
  ``min_φ Σ|a_i − e^{iφ} b_{i+s}|² = Σ|a|² + Σ|b|² − 2 |Σ conj(a_i) b_{i+s}|``
  (Procrustes with a fixed correspondence; Kendall 1984).
* **Chamfer score** (Nobari et al. 2024, LInK, its evaluation): both curves resampled
  to 200 points, centred, scaled to unit RMS radius, the best of 360 rotations, and
  ``mean_a min_b |a − b| + mean_b min_a |a − b|``.
"""
from __future__ import annotations

import numpy as np

__all__ = ["resample", "is_closed", "normalise", "descriptor", "reversed_descriptor",
           "aligned_distance", "similarity_to", "chamfer_score", "DESCRIPTOR_HARMONICS",
           "CURVE_POINTS"]

#: harmonics per sign in a descriptor (its length is twice this)
DESCRIPTOR_HARMONICS = 16
#: points of a stored normalised curve
CURVE_POINTS = 64


def _as_points(path) -> np.ndarray:
    P = np.asarray(path, float)
    if P.ndim != 2 or P.shape[1] < 2 or len(P) < 3:
        raise ValueError(f"a curve needs at least 3 rows of x, y; got shape {P.shape}")
    return P[:, :2]


def is_closed(path, ratio: float = 1.1) -> bool:
    """Whether a sampled curve closes: the gap between its last and first points is at
    most ``ratio`` times its longest step.  (LInK's rule, Nobari et al. 2024, compares
    the gap with the first step; a curve sampled at a uniform driver step has steps of
    uneven length, so the longest one is used here.)"""
    P = _as_points(path)
    steps = np.linalg.norm(np.diff(P, axis=0), axis=1)
    return bool(np.linalg.norm(P[-1] - P[0]) <= ratio * float(steps.max()))


def resample(path, m: int = CURVE_POINTS, closed: bool = True) -> np.ndarray:
    """``m`` points equally spaced by arc length, shape ``(m, 2)``.  A closed curve
    wraps from its last point to its first (which is not repeated).

    Examples
    --------
    >>> resample([[0, 0], [1, 0], [1, 1], [0, 1]], 4).round(6).tolist()
    [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
    """
    P = _as_points(path)
    if closed:
        P = np.vstack([P, P[:1]])
    seg = np.linalg.norm(np.diff(P, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    if s[-1] <= 0:
        raise ValueError("a curve of zero length")
    t = np.linspace(0.0, s[-1], m, endpoint=not closed)
    return np.stack([np.interp(t, s, P[:, 0]), np.interp(t, s, P[:, 1])], axis=1)


def normalise(path, m: int = CURVE_POINTS, closed: bool = True) -> tuple[np.ndarray, complex, float]:
    """The resampled curve as complex numbers, centred and of unit RMS radius, with
    the centre and the radius it had: ``z = (x + iy − centre) / radius``.  An open
    curve is retraced (forward then back, ``2m − 2`` points) so that it is closed."""
    R = resample(path, m, closed)
    z = R[:, 0] + 1j * R[:, 1]
    if not closed:
        z = np.concatenate([z, z[-2:0:-1]])
    c = complex(z.mean())
    r = float(np.sqrt(np.mean(np.abs(z - c) ** 2)))
    if r <= 0:
        raise ValueError("a curve of zero size")
    return (z - c) / r, c, r


def descriptor(path, closed: bool | None = None, harmonics: int = DESCRIPTOR_HARMONICS,
               m: int = 2 * CURVE_POINTS) -> np.ndarray:
    """Fourier magnitude descriptor ``(|Z_1|…|Z_H|, |Z_−1|…|Z_−H|)`` (float32), invariant
    to translation, scale, rotation and start point (module docstring)."""
    if closed is None:
        closed = is_closed(path)
    z, _, _ = normalise(path, m, closed)
    Z = np.fft.fft(z) / len(z)
    k = np.arange(1, harmonics + 1)
    return np.concatenate([np.abs(Z[k]), np.abs(Z[-k])]).astype(np.float32)


def reversed_descriptor(d: np.ndarray) -> np.ndarray:
    """The descriptor of the same curve traversed backwards (``Z_k ↔ Z_−k``)."""
    d = np.asarray(d)
    h = d.shape[-1] // 2
    return np.concatenate([d[..., h:], d[..., :h]], axis=-1)


def aligned_distance(a: np.ndarray, b: np.ndarray) -> tuple[float, int, complex, bool]:
    """RMS distance between normalised closed curves ``a`` and ``b`` (complex, same
    length), minimised over the start shift, the rotation and the direction of ``b``.

    Returns ``(distance, shift, rotation, reversed)``: ``a ≈ rotation · b'[i + shift]``
    with ``b' = b`` or ``b`` reversed, ``|rotation| = 1``.
    """
    best = (np.inf, 0, 1.0 + 0j, False)
    na = float(np.sum(np.abs(a) ** 2))
    for rev in (False, True):
        bb = b[::-1] if rev else b
        corr = np.fft.ifft(np.conj(np.fft.fft(a)) * np.fft.fft(bb))   # Σ conj(a_i) b_{i+s}
        s = int(np.argmax(np.abs(corr)))
        d2 = na + float(np.sum(np.abs(bb) ** 2)) - 2.0 * abs(corr[s])
        dist = float(np.sqrt(max(d2, 0.0) / len(a)))
        if dist < best[0]:
            rot = np.conj(corr[s]) / abs(corr[s]) if abs(corr[s]) > 0 else 1.0 + 0j
            best = (dist, s, complex(rot), rev)
    return best


def similarity_to(target_centre: complex, target_radius: float, cand_centre: complex,
                  cand_radius: float, rotation: complex):
    """The map ``w ↦ target_centre + target_radius · rotation · (w − cand_centre) /
    cand_radius`` that carries a candidate's curve (and its mechanism) onto the target."""
    k = target_radius * rotation / cand_radius

    def apply(xy):
        w = np.asarray(xy, float)
        q = target_centre + k * ((w[..., 0] + 1j * w[..., 1]) - cand_centre)
        return np.stack([q.real, q.imag], axis=-1)

    return apply


def _unit(path, closed: bool, n: int) -> np.ndarray:
    R = resample(path, n, closed)
    R = R - R.mean(axis=0)
    return R / np.sqrt(np.mean(np.sum(R ** 2, axis=1)))


def chamfer_score(target, curve, closed: bool | None = None, n: int = 200, angles: int = 360) -> float:
    """LInK's chamfer distance between a target and an achieved curve (Nobari et al.
    2024): both resampled by arc length to ``n`` points, centred, scaled to unit RMS
    radius, the achieved curve turned by the best rotation (``angles / 5`` turns, then
    11 around the best); the sum of
    the two mean nearest-point distances.  ``closed`` defaults to :func:`is_closed` of
    the target (an open target is compared with the achieved arc as given)."""
    if closed is None:
        closed = is_closed(target)
    A = _unit(target, closed, n)
    B = _unit(curve, closed, n)

    def scores(th):
        c, s = np.cos(th), np.sin(th)
        Bx = c[:, None] * B[None, :, 0] - s[:, None] * B[None, :, 1]
        By = s[:, None] * B[None, :, 0] + c[:, None] * B[None, :, 1]
        D = np.hypot(A[None, :, None, 0] - Bx[:, None, :], A[None, :, None, 1] - By[:, None, :])
        return D.min(axis=2).mean(axis=1) + D.min(axis=1).mean(axis=1)

    coarse = np.linspace(0.0, 2 * np.pi, angles // 5, endpoint=False)    # then refine around the best
    best = coarse[int(np.argmin(scores(coarse)))]
    step = 2 * np.pi / (angles // 5)
    fine = best + np.linspace(-step, step, 11)
    return float(min(scores(coarse).min(), scores(fine).min()))
