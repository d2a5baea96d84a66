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
* **Windows** (open targets): an open target is compared with sub-arcs of the stored
  closed curves: windows of each stored shape of several lengths (fractions of its
  arc length), at every start sample, in both directions, each resampled to the
  target's number of points, centred and scaled to unit RMS radius like the target;
  the distance is the RMS distance after the best rotation with the points in order
  (arc-length correspondence, both ends fixed: free timing along the arc).
* **Chamfer score** (Nobari et al. 2024, LInK, its evaluation): both curves resampled
  to 200 points, centred, scaled to unit RMS radius, the best of 360 rotations, and
  ``mean_a min_b |a − b| + mean_b min_a |a − b|``.
"""
from __future__ import annotations

import numpy as np

__all__ = ["resample", "is_closed", "normalise", "normalise_closed", "descriptor", "reversed_descriptor",
           "aligned_distance", "aligned_distances", "normalise_open", "window_distances", "WINDOW_FRACTIONS",
           "similarity_to", "chamfer_score", "polyline_distance", "DESCRIPTOR_HARMONICS", "CURVE_POINTS"]

#: harmonics per sign in a descriptor (its length is twice this)
DESCRIPTOR_HARMONICS = 16
#: points of a stored normalised curve
CURVE_POINTS = 64
#: window lengths, as fractions of a stored closed curve's arc length, that an open
#: target is compared with (:func:`window_distances`)
WINDOW_FRACTIONS = (0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875, 0.95)
#: the second, finer pass over the nearest curves (:func:`.open_targets.ranked_windows`):
#: lengths every 1/32 of the arc and starts every quarter of a sample
FINE_FRACTIONS = tuple(np.round(np.arange(3, 31) / 32.0, 6)) + (0.95, 0.98)
FINE_OFFSETS = (0.0, 0.25, 0.5, 0.75)
#: points of an open target and of every window in that comparison
WINDOW_POINTS = 32


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


def _arc_resample(P: np.ndarray, m: int, endpoint: bool) -> np.ndarray:
    """Polylines ``P`` (K, n, 2) resampled at ``m`` points equally spaced by arc length
    (the last vertex included when ``endpoint``), all rows at once: ``(K, m, 2)``."""
    seg = np.linalg.norm(np.diff(P, axis=1), axis=2)
    s = np.concatenate([np.zeros((len(P), 1)), np.cumsum(seg, axis=1)], axis=1)
    if np.any(s[:, -1] <= 0):
        raise ValueError("a curve of zero length")
    t = np.linspace(0.0, 1.0, m, endpoint=endpoint)[None, :] * s[:, -1:]
    off = 2.0 * np.arange(len(P))[:, None] * (s[:, -1:].max() + 1.0)      # rows apart on one axis
    i = np.searchsorted((s + off).ravel(), (t + off).ravel(), side="right").reshape(t.shape) - 1
    i = np.clip(i - np.arange(len(P))[:, None] * s.shape[1], 0, s.shape[1] - 2)
    s0 = np.take_along_axis(s, i, axis=1)
    w = np.clip((t - s0) / np.maximum(np.take_along_axis(seg, i, axis=1), 1e-300), 0.0, 1.0)[..., None]
    a = np.take_along_axis(P, i[..., None], axis=1)
    b = np.take_along_axis(P, i[..., None] + 1, axis=1)
    return a + w * (b - a)


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
    return _arc_resample(P[None], m, not closed)[0]


def normalise(path, m: int = CURVE_POINTS, closed: bool = True) -> tuple[np.ndarray, complex, float]:
    """The resampled curve as complex numbers, centred and of unit RMS radius, with
    the centre and the radius it had: ``z = (x + iy − centre) / radius``.  An open
    curve is retraced (forward then back, ``2m − 2`` points) so that it is closed."""
    R = resample(path, m, closed)
    z = R[:, 0] + 1j * R[:, 1]
    if not closed:
        z = np.concatenate([z, z[-2:0:-1]])
    zn, c, r = _centred(z[None])
    if r[0] <= 0:
        raise ValueError("a curve of zero size")
    return zn[0], complex(c[0]), float(r[0])


def normalise_open(path, m: int = WINDOW_POINTS) -> tuple[np.ndarray, complex, float]:
    """An open curve resampled at ``m`` points by arc length (both ends kept, not
    retraced), centred and of unit RMS radius, with the centre and radius it had."""
    R = resample(path, m, closed=False)
    zn, c, r = _centred((R[:, 0] + 1j * R[:, 1])[None])
    if r[0] <= 0:
        raise ValueError("a curve of zero size")
    return zn[0], complex(c[0]), float(r[0])


def _window_maps(a: np.ndarray, n: int, fraction: float, offset: float = 0.0) -> tuple[np.ndarray, ...]:
    """Linear maps from a closed curve's ``n`` samples (equally spaced by arc length) to
    its windows of ``fraction`` of the arc, one per start sample (moved on by ``offset``
    of a sample), each of ``len(a)``
    points interpolated linearly between the samples: ``(n, n)`` matrices whose column
    ``s`` gives, for the window starting at sample ``s``, the sum ``Σ conj(a_j) w_j`` and
    the same with ``a`` reversed (``G``, ``Gr``), the mean ``Σ w_j / m`` (``C``), and the
    mean square ``Σ |w_j|² / m`` as ``|B_k|² @ U + Re(conj(B_k) B_{k+1}) @ V``."""
    m = len(a)
    t = np.arange(n)[:, None] + offset + fraction * n * np.linspace(0.0, 1.0, m)[None, :]     # (starts, m)
    i0 = np.floor(t).astype(int)
    w = t - i0
    i0, i1, s = i0 % n, (i0 + 1) % n, np.broadcast_to(np.arange(n)[:, None], t.shape)
    out = []
    for coef in (np.conj(a), np.conj(a[::-1]), np.full(m, 1.0 / m)):
        M = np.zeros((n, n), complex)
        np.add.at(M, (i0, s), (1.0 - w) * coef[None, :])
        np.add.at(M, (i1, s), w * coef[None, :])
        out.append(M)
    U, V = np.zeros((n, n)), np.zeros((n, n))
    np.add.at(U, (i0, s), (1.0 - w) ** 2 / m)
    np.add.at(U, (i1, s), w ** 2 / m)
    np.add.at(V, (i0, s), 2.0 * (1.0 - w) * w / m)     # (i1 = i0 + 1: the pair's cross term)
    return (*out, U, V)


def window_distances(a: np.ndarray, B: np.ndarray, fractions=WINDOW_FRACTIONS, offsets=(0.0,)) -> dict[str, np.ndarray]:
    """The window of each stored closed shape (rows of ``B``, (K, n), complex) nearest
    to the open target ``a`` (centred, unit RMS radius, e.g. from
    :func:`normalise_open`, (m,)), over the window lengths ``fractions``, the start
    samples (each moved on by every fraction of a sample in ``offsets``) and both
    directions (module docstring).  A window is linear in the samples, so every start
    of a length is one matrix product (:func:`_window_maps`).

    Returns a dict of (K,) arrays: ``distance`` (RMS after the best rotation, in units
    of the normalised target), ``rotation`` (``a ≈ rotation · (w − centre) / radius``),
    ``centre`` and ``radius`` of the window in the stored shape's coordinates,
    ``fraction``, ``start`` (in samples) and ``reversed``.  Cost: 2 K n² per length,
    offset and direction.
    """
    a, B = np.asarray(a, complex), np.atleast_2d(np.asarray(B, complex))
    m, n, k = len(a), B.shape[1], np.arange(len(B))
    sq, cross = np.abs(B) ** 2, np.real(np.conj(B) * np.roll(B, -1, axis=1))
    best = {"distance": np.full(len(B), np.inf)}
    for f, off in ((f, o) for f in fractions for o in offsets):
        G, Gr, C, U, V = _window_maps(a, n, f, off)
        c = B @ C
        r = np.sqrt(np.maximum(sq @ U + cross @ V - np.abs(c) ** 2, 0.0))
        ok = r > 1e-9
        for rev, g in ((0.0, G), (1.0, Gr)):
            top = (B @ g - c * np.sum(g, axis=0)) / np.where(ok, r, 1.0)     # Σ conj(a_j)(w_j − c) / r
            d = np.where(ok, np.sqrt(np.maximum(2.0 - 2.0 * np.abs(top) / m, 0.0)), np.inf)
            s = np.argmin(d, axis=1)
            better = d[k, s] < best["distance"]
            t = top[k, s]
            found = {"distance": d[k, s], "rotation": np.conj(t) / np.maximum(np.abs(t), 1e-300), "centre": c[k, s],
                     "radius": r[k, s], "fraction": np.full(len(B), f), "start": s + off,
                     "reversed": np.full(len(B), rev)}
            best = {key: np.where(better, v, best[key]) if key in best else np.where(better, v, np.nan * v)
                    for key, v in found.items()}
    return best


def _centred(z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows of complex samples ``z`` (K, m) centred and scaled to unit RMS radius, with
    their centres and radii (K,) (a row of zero size is only centred)."""
    c = z.mean(axis=1)
    r = np.sqrt(np.mean(np.abs(z - c[:, None]) ** 2, axis=1))
    return (z - c[:, None]) / np.where(r > 0, r, 1.0)[:, None], c, r


def descriptor(path, closed: bool | None = None, harmonics: int = DESCRIPTOR_HARMONICS,
               m: int = 2 * CURVE_POINTS) -> np.ndarray:
    """Fourier magnitude descriptor ``(|Z_1|…|Z_H|, |Z_−1|…|Z_−H|)`` (float32), invariant
    to translation, scale, rotation and start point (module docstring)."""
    if closed is None:
        closed = is_closed(path)
    return _magnitudes(normalise(path, m, closed)[0], harmonics)


def descriptors_closed(curves, harmonics: int = DESCRIPTOR_HARMONICS, m: int = 2 * CURVE_POINTS) -> np.ndarray:
    """:func:`descriptor` of a batch of closed curves ``(K, n, 2)`` at once, ``(K, 2H)``."""
    return _magnitudes(normalise_closed(curves, m)[0], harmonics)


def _magnitudes(z: np.ndarray, harmonics: int) -> np.ndarray:
    """``|Z_k|``, k = 1…H then −1…−H, of the discrete Fourier coefficients of the rows of
    ``z`` (complex samples, last axis), float32."""
    Z = np.fft.fft(z, axis=-1) / z.shape[-1]
    k = np.arange(1, harmonics + 1)
    return np.concatenate([np.abs(Z[..., k]), np.abs(Z[..., -k])], axis=-1).astype(np.float32)


def reversed_descriptor(d: np.ndarray) -> np.ndarray:
    """The descriptor of the same curve traversed backwards (``Z_k ↔ Z_−k``)."""
    d = np.asarray(d)
    h = d.shape[-1] // 2
    return np.concatenate([d[..., h:], d[..., :h]], axis=-1)


def normalise_closed(curves, m: int = CURVE_POINTS) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`normalise` for a batch of closed curves ``(K, n, 2)`` at once: ``z`` (K, m),
    the centres (K,) and the radii (K,)."""
    P = np.asarray(curves, float)
    R = _arc_resample(np.concatenate([P, P[:, :1]], axis=1), m, False)
    return _centred(R[..., 0] + 1j * R[..., 1])


def aligned_distances(a: np.ndarray, B: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`aligned_distance` of ``a`` (m,) to every row of ``B`` (K, m): distances,
    shifts, rotations and reversal flags, each (K,)."""
    B = np.atleast_2d(B)
    na = float(np.sum(np.abs(a) ** 2))
    fa = np.conj(np.fft.fft(a))
    out = []
    for bb in (B, B[:, ::-1]):
        corr = np.fft.ifft(fa[None, :] * np.fft.fft(bb, axis=1), axis=1)     # Σ conj(a_i) b_{i+s}
        s = np.argmax(np.abs(corr), axis=1)
        top = corr[np.arange(len(B)), s]
        d2 = na + np.sum(np.abs(bb) ** 2, axis=1) - 2.0 * np.abs(top)
        rot = np.where(np.abs(top) > 0, np.conj(top) / np.maximum(np.abs(top), 1e-300), 1.0 + 0j)
        out.append((np.sqrt(np.maximum(d2, 0.0) / B.shape[1]), s, rot))
    rev = out[1][0] < out[0][0]
    return (np.where(rev, out[1][0], out[0][0]), np.where(rev, out[1][1], out[0][1]),
            np.where(rev, out[1][2], out[0][2]), rev)


def aligned_distance(a: np.ndarray, b: np.ndarray) -> tuple[float, int, complex, bool]:
    """RMS distance between normalised closed curves ``a`` and ``b`` (complex, same
    length), minimised over the start shift, the rotation and the direction of ``b``.

    Returns ``(distance, shift, rotation, reversed)``: ``a ≈ rotation · b'[i + shift]``
    with ``b' = b`` or ``b`` reversed, ``|rotation| = 1``.
    """
    d, s, rot, rev = aligned_distances(a, np.asarray(b)[None, :])
    return float(d[0]), int(s[0]), complex(rot[0]), bool(rev[0])


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
    """A chamfer distance after LInK's (Nobari et al. 2024) between a target and an
    achieved curve: both resampled by arc length to ``n`` points, centred, scaled to
    unit RMS radius, the achieved curve turned by the best rotation (``angles / 5``
    turns, then 11 around the best); the sum of the two mean nearest-point distances.
    ``closed`` defaults to :func:`is_closed` of the target (an open target is compared
    with the achieved arc as given).

    Not LInK's final metric to the digit: LInK (``LInK/OptimJax.py``,
    ``PathSynthesis.synthesize``) resamples to 2000 points, chooses the rotation among
    100 by its *ordered* distance, multiplies by the target's RMS radius and scores an
    open stroke in the frame of the stroke closed by half an ellipse.  That metric,
    ported exactly and checked against LInK's stored per-letter values, is in
    ``benchmarks/bench_link_abc.py`` (``link_cd``)."""
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


def polyline_distance(points, curve, block: int = 256) -> np.ndarray:
    """The distance from each of ``points`` (n, 2) to the polyline ``curve`` (m, 2): to
    its nearest segment, not its nearest vertex, so the answer does not depend on how
    densely the curve is sampled (the error of a chord is second order in the step).

    Examples
    --------
    >>> polyline_distance([[0.5, 1.0], [2.0, 0.0]], [[0, 0], [1, 0]]).tolist()
    [1.0, 1.0]
    """
    P = np.asarray(points, float)[:, None, :2]
    C = _as_points(curve) if len(curve) >= 3 else np.asarray(curve, float)
    a, v = C[:-1], np.diff(C, axis=0)
    vv = np.maximum(np.sum(v * v, axis=1), 1e-300)
    out = np.empty(len(P))
    for i in range(0, len(P), block):
        w = P[i:i + block] - a
        t = np.clip(np.sum(w * v, axis=2) / vv, 0.0, 1.0)
        out[i:i + block] = np.min(np.linalg.norm(w - t[..., None] * v, axis=2), axis=1)
    return out
