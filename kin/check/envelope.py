"""The exact boundary of a tracer point's workspace over a box of driver values.

A point ``p(s)`` driven by ``n >= 2`` drivers over a box ``B`` (every driver value
assembling on the reference's modes) has an image ``p(B)`` whose boundary lies on the
images of the box's faces and of the *singular curves*, where the Jacobian ``∂p/∂s``
loses rank (the fold curves of the planar map; Whitney 1955, "On singularities of
mappings of Euclidean spaces. I. Mappings of the plane into the plane", Ann. Math. 62(3)
374-410).  For ``n = 3`` a boundary point of ``p(B)`` has its preimages on the box's
faces or where ``∂p/∂s`` (2 × 3) has rank one inside the box (elsewhere ``p`` is a
submersion, an open map); that critical set is generically a curve whose image can bound
the workspace (an arm stretched straight reaches farther than any face), so it is
searched for and, if found, the construction refuses.  Without it, ``p(B)`` is the union
of the images of the box's two-dimensional faces (each handled as a two-driver box) and
of any hole of that union that closed fibres inside the box fill, which an interior grid
checks.  Four drivers or more are refused (their three-dimensional faces would need the
same search).

On a face (drivers ``i``, ``j``) the determinant ``D = det ∂p/∂(s_i, s_j)`` is sampled on
a Chebyshev grid (the seed only); every grid edge where ``D`` changes sign is *bracketed*
and bisected to machine precision (marching squares; Lorensen & Cline 1987, "Marching
cubes", Comput. Graph. 21(4) 163-169, in two dimensions), and each piece of the singular
curve is refined by bracketing the root on its perpendicular bisector.  The face
splits into regions of constant ``sign D``; on each the map is a local diffeomorphism, so
the number of preimages of a point ``y`` is the winding number of the image of the
region's oriented boundary about ``y`` (Milnor 1965, "Topology from the differentiable
viewpoint", §5, the degree).  Summed over the face: ``N(y) = w(p(E+), y) - w(p(E-), y)``
with ``E±`` the region boundaries (box edges and singular curves, the region on the left).

The candidate arcs (box edges, sampled at Chebyshev points so that a driver end at an
assembly limit, where ``p`` grows like the square root of the distance to it, is as
densely sampled as the rest, and singular curves) are cut at their crossings; a piece lies
on the boundary iff ``N > 0`` on exactly one side of it, and the area is Green's theorem
``∮ x dy`` over the boundary pieces, each oriented with the workspace on its left.
"""
from __future__ import annotations

import itertools
import warnings
from dataclasses import dataclass

import numpy as np

from multiloop.kin.solve import solve

__all__ = ["Envelope", "BoundaryArc", "envelope", "edge_fractions"]

_SEED = 65          # seed grid per face (Chebyshev points per driver)
_EDGE = 4097        # Chebyshev points per box edge
_NUDGE = 1e-9       # D at a box edge is read this far (of the range) inside it
_CHORDS = 4000      # a singular curve's chords are refined below the corners' spread / this
_FLAT = 1e-8        # a face whose columns' median sine is below this has rank one throughout
_INNER = 17         # three drivers: the interior's seed grid (Chebyshev points per driver)


@dataclass(frozen=True, slots=True)
class BoundaryArc:
    """A piece of the workspace boundary: what sets it and its (K, 2) polyline.

    ``kind`` is ``"edge"`` (``ends``: the drivers held at an end, as (driver index,
    ``"low"`` or ``"high"``) pairs) or ``"singular"`` (the Jacobian of the face's two
    drivers has rank one; ``ends``: the other drivers' ends, which fix the face)."""

    kind: str
    ends: tuple
    points: np.ndarray


@dataclass(frozen=True, slots=True)
class Envelope:
    """Boundary arcs, the outer boundary loop (K, 2), the area of a workspace and the
    box edges' solved samples (driver values (M, n), positions (M, 2))."""

    arcs: tuple
    boundary: np.ndarray
    area: float
    edge_inputs: np.ndarray
    edge_points: np.ndarray


def edge_fractions() -> np.ndarray:
    """Where a box edge is solved, as fractions of the driver's range from its low end:
    the Chebyshev points ``(1 - cos πw)/2``, ``w`` in ``_EDGE`` equal steps."""
    return 0.5 * (1.0 - np.cos(np.pi * np.linspace(0.0, 1.0, _EDGE)))


def _solve_p(m, ip, S, rate=None):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if rate is None:
            st = solve(m, S, assemble=True)
            return np.where(st.ok[:, None], st.point_positions[:, ip], np.nan)
        st = solve(m, S, assemble=True, derivatives=True, input_rates=rate)
        return np.where(st.ok[:, None], st.point_velocities[:, ip], np.nan)


class _Face:
    """A two-driver face of the box: ``(u, v)`` in [0, 1]² mapped to driver values at
    Chebyshev spacing, ``s = lo + (hi - lo)(1 - cos πu)/2``."""

    def __init__(self, m, ip, box, i, j, fixed, rest=()):
        self.m, self.ip, self.box, self.i, self.j, self.fixed = m, ip, box, i, j, fixed
        self.rest = rest                # the other drivers' ends: ((driver, 0 or 1), ...)

    def drivers(self, UV):
        UV = np.atleast_2d(UV)
        S = np.tile(self.fixed, (len(UV), 1))
        for c, k in enumerate((self.i, self.j)):
            lo, hi = self.box[k]
            S[:, k] = lo + (hi - lo) * 0.5 * (1.0 - np.cos(np.pi * UV[:, c]))
        return S

    def det(self, UV, normalised: bool = False):
        """``D`` at ``UV``, read ``_NUDGE`` inside the box at its edges; ``normalised``:
        divided by the columns' lengths (the sine of the angle between them)."""
        S = self.drivers(np.clip(UV, _NUDGE, 1.0 - _NUDGE))
        n = len(self.fixed)
        Ji = _solve_p(self.m, self.ip, S, np.eye(n)[self.i])
        Jj = _solve_p(self.m, self.ip, S, np.eye(n)[self.j])
        D = Ji[:, 0] * Jj[:, 1] - Ji[:, 1] * Jj[:, 0]
        if normalised:
            return D, np.abs(D) / np.maximum(np.hypot(*Ji.T) * np.hypot(*Jj.T), 1e-300)
        return D

    def points(self, UV):
        return _solve_p(self.m, self.ip, self.drivers(UV))


def _bisect(f, a, b, fa, iters: int = 60):
    """Roots of ``f`` on the segments ``a``-``b`` (rows), ``sign f(a) != sign f(b)``:
    the Illinois method (a bracketing regula falsi; Dowell & Jarratt 1971, BIT 11
    168-174), which keeps every root inside its bracket, to a bracket of 1e-12 in (u, v)."""
    a, b = np.array(a, float), np.array(b, float)
    fa = np.array(fa, float)
    fb = f(b)
    tol = np.full(len(a), 1e-12)                     # in (u, v): well below a driver's 1e-9
    live = np.ones(len(a), bool)
    side = np.zeros(len(a))
    for _ in range(iters):
        if not live.any():
            break
        k = np.flatnonzero(live)
        den = fb[k] - fa[k]
        w = np.where(np.isfinite(den) & (den != 0), fb[k] / np.where(den == 0, 1, den), 0.5)
        w = np.where((w > 0) & (w < 1), w, 0.5)
        c = b[k] + w[:, None] * (a[k] - b[k])
        fc = f(c)
        left = np.sign(fc) == np.sign(fa[k])          # the root is in [c, b]
        kk = k[left]
        a[kk], fa[kk] = c[left], fc[left]
        fb[kk] = np.where(side[kk] == 1, 0.5 * fb[kk], fb[kk])
        side[kk] = 1
        kk = k[~left]
        b[kk], fb[kk] = c[~left], fc[~left]
        fa[kk] = np.where(side[kk] == -1, 0.5 * fa[kk], fa[kk])
        side[kk] = -1
        live[k] = (np.hypot(*(b[k] - a[k]).T) > tol[k]) & (fc != 0)
    return 0.5 * (a + b)


def _crossing_segments(face, t, D):
    """Singular-curve segments of the face (K, 2, 2) in (u, v), each with the region
    ``D > 0`` on its left, by marching squares on the seed grid ``t`` × ``t``, and the
    crossings on the face's edges ({side: [w, ...]}, sides as in :func:`_edge_uv`)."""
    n = len(t)
    U, V = np.meshgrid(t, t, indexing="ij")
    pos = D > 0
    bx = {0: [], 1: [], 2: [], 3: []}
    # crossing points on the grid edges: along u (a, b)-(a+1, b) and along v (a, b)-(a, b+1)
    cross = {}
    for axis in (0, 1):
        sl0 = (slice(0, n - 1), slice(None)) if axis == 0 else (slice(None), slice(0, n - 1))
        sl1 = (slice(1, n), slice(None)) if axis == 0 else (slice(None), slice(1, n))
        idx = np.argwhere(pos[sl0] != pos[sl1])
        if len(idx) > n * n // 8:
            # D changes sign on most grid edges: the face is degenerate (two drivers move
            # the point along one line everywhere, rank one throughout), not a fold
            raise ValueError("the Jacobian has rank one over much of a face")
        if not len(idx):
            continue
        a = np.stack([U[sl0][tuple(idx.T)], V[sl0][tuple(idx.T)]], axis=1)
        b = np.stack([U[sl1][tuple(idx.T)], V[sl1][tuple(idx.T)]], axis=1)
        r = _bisect(face.det, a, b, D[sl0][tuple(idx.T)])
        for (p, q), x in zip(idx.tolist(), r):
            cross[(axis, p, q)] = x
            if axis == 0 and q in (0, n - 1):        # on the edge v = 0 (side 0) or v = 1 (side 2)
                bx[0 if q == 0 else 2].append(x[0])
            if axis == 1 and p in (0, n - 1):        # on the edge u = 0 (side 3) or u = 1 (side 1)
                bx[3 if p == 0 else 1].append(x[1])
    segs = []
    for a in range(n - 1):
        for b in range(n - 1):
            corners = [(a, b), (a + 1, b), (a + 1, b + 1), (a, b + 1)]
            edges = [(0, a, b), (1, a + 1, b), (0, a, b + 1), (1, a, b)]
            hit = [k for k, e in enumerate(edges) if e in cross]
            if not hit:
                continue
            if len(hit) == 4:               # a saddle: the centre's sign decides
                c = face.det(np.array([[0.5 * (t[a] + t[a + 1]), 0.5 * (t[b] + t[b + 1])]]))[0]
                pairs = [(0, 1), (2, 3)] if (c > 0) == pos[a, b] else [(3, 0), (1, 2)]
            else:
                pairs = [tuple(hit)]
            for e0, e1 in pairs:
                p, q = cross[edges[e0]], cross[edges[e1]]
                ref = corners[(e0 + 1) % 4]    # a corner on the far side of the chord from e0's start
                side = np.array([t[ref[0]], t[ref[1]]])
                left = (q - p)[0] * (side - p)[1] - (q - p)[1] * (side - p)[0] > 0
                if left != bool(pos[ref]):
                    p, q = q, p
                segs.append((p, q))
    return np.array(segs, float).reshape(-1, 2, 2), bx


def _refine_segments(face, segs, rounds: int, chord: float):
    """Halve each singular-curve segment ``rounds`` times, then each whose image is
    longer than ``chord`` (at most 6 more times): the new point is bracketed on the
    segment's perpendicular bisector; a segment with no bracket there is kept whole (a
    point off the curve would map inside the fold, not on it)."""
    for r in range(rounds + 6):
        if not len(segs):
            return segs
        if r < rounds:
            split = np.ones(len(segs), bool)
        else:
            P, Q = face.points(segs[:, 0]), face.points(segs[:, 1])
            split = np.hypot(*(Q - P).T) > chord
            if not split.any():
                return segs
        keep, segs = segs[~split], segs[split]
        p, q = segs[:, 0], segs[:, 1]
        mid, d = 0.5 * (p + q), q - p
        nrm = np.stack([-d[:, 1], d[:, 0]], axis=1)
        a, b = np.clip(mid - nrm, 0, 1), np.clip(mid + nrm, 0, 1)
        fa, fb = face.det(a), face.det(b)
        ok = np.sign(fa) * np.sign(fb) < 0
        if not ok.any():
            return np.concatenate([keep, segs])
        c = _bisect(face.det, a[ok], b[ok], fa[ok])
        segs = np.concatenate([keep, segs[~ok], np.stack([p[ok], c], axis=1), np.stack([c, q[ok]], axis=1)])
    return segs


def _edge_uv(side, w):
    """(u, v) on a face edge: ``side`` 0 bottom (v = 0), 1 right (u = 1), 2 top (v = 1),
    3 left (u = 0); ``w`` the coordinate along it (u or v)."""
    w = np.asarray(w, float)
    fixed = np.full_like(w, 0.0 if side in (0, 3) else 1.0)
    return np.stack([w, fixed] if side in (0, 2) else [fixed, w], axis=1)


def _winding(Q, A, B, weight):
    """Σ weight × winding number of the segments ``A``→``B`` about each point of ``Q``."""
    out = np.zeros(len(Q))
    for c in range(0, len(Q), 256):
        q = Q[c: c + 256, None, :]
        ya, yb = A[None, :, 1], B[None, :, 1]
        cr = (B[None, :, 0] - A[None, :, 0]) * (q[..., 1] - ya) - (q[..., 0] - A[None, :, 0]) * (yb - ya)
        up = (ya <= q[..., 1]) & (yb > q[..., 1]) & (cr > 0)
        down = (ya > q[..., 1]) & (yb <= q[..., 1]) & (cr < 0)
        out[c: c + 256] = np.sum((up.astype(float) - down) * weight[None, :], axis=1)
    return out


def _intersections(A, B, arc):
    """Proper crossings of the segments ``A``→``B``: (segment, t, point) triples, each
    crossing listed for both segments with the same point."""
    from scipy.spatial import cKDTree

    L = np.hypot(*(B - A).T)
    pairs = cKDTree(0.5 * (A + B)).query_pairs(float(L.max()) * 1.0001, output_type="ndarray")
    if not len(pairs):
        return np.empty(0, int), np.empty(0), np.empty((0, 2))
    i, j = pairs[:, 0], pairs[:, 1]
    d1, d2, r = B[i] - A[i], B[j] - A[j], A[j] - A[i]
    den = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (r[:, 0] * d2[:, 1] - r[:, 1] * d2[:, 0]) / den
        u = (r[:, 0] * d1[:, 1] - r[:, 1] * d1[:, 0]) / den
    tol = 1e-12
    ok = (den != 0) & (t > tol) & (t < 1 - tol) & (u > tol) & (u < 1 - tol)
    i, j, t, u = i[ok], j[ok], t[ok], u[ok]
    P = A[i] + t[:, None] * (B[i] - A[i])
    return np.concatenate([i, j]), np.concatenate([t, u]), np.concatenate([P, P])


def _faces(m, ip, box):
    """Every two-driver face of the box: (face, its four edge keys)."""
    n = len(box)
    out = []
    for i, j in itertools.combinations(range(n), 2):
        others = [k for k in range(n) if k not in (i, j)]
        for ends in itertools.product((0, 1), repeat=len(others)):
            fixed = np.zeros(n)
            for k, e in zip(others, ends):
                fixed[k] = box[k][e]
            rest = tuple(zip(others, ends))
            keys = [(i, tuple(sorted(rest + ((j, 0),)))), (j, tuple(sorted(rest + ((i, 1),)))),
                    (i, tuple(sorted(rest + ((j, 1),)))), (j, tuple(sorted(rest + ((i, 0),))))]
            out.append((_Face(m, ip, box, i, j, fixed, rest), keys))
    return out


def _edge_points(m, ip, box, key, extra):
    """Driver values (K, n) and point positions (K, 2) along the box edge ``key`` =
    (varying driver, ((driver, end), ...)), at Chebyshev spacing plus ``extra`` (in w)."""
    k, rest = key
    w = np.unique(np.concatenate([np.linspace(0.0, 1.0, _EDGE), extra]))
    S = np.zeros((len(w), len(box)))
    for d, e in rest:
        S[:, d] = box[d][e]
    lo, hi = box[k]
    S[:, k] = lo + (hi - lo) * 0.5 * (1.0 - np.cos(np.pi * w))
    P = _solve_p(m, ip, S)
    if not np.isfinite(P).all():
        raise ValueError("a box edge does not assemble")
    return w, S, P


def _sheets(m, ip, box):
    """The oriented segments of ``E±`` over every face (A, B, weight) and the candidate
    arcs: a list of (label, (K, 2) polyline, split flags per vertex)."""
    faces = _faces(m, ip, box)
    t = 0.5 * (1.0 - np.cos(np.linspace(0.0, np.pi, _SEED)))
    corners = _solve_p(m, ip, np.array(list(itertools.product(*box))))
    chord = float(np.hypot(*(np.nanmax(corners, axis=0) - np.nanmin(corners, axis=0)))) / _CHORDS
    splits, crit, seeds = {}, [], []
    UV = np.stack(np.meshgrid(t, t, indexing="ij"), axis=-1).reshape(-1, 2)
    for face, keys in faces:
        if not np.isfinite(face.points(UV)).all():
            raise ValueError("the box does not assemble everywhere")
        D, sine = face.det(UV, normalised=True)
        if np.median(sine) < _FLAT:
            # two drivers move the point along one line (they turn the same link): the
            # face's image is a curve, rank one throughout, not a region bounded by folds
            raise ValueError(f"the Jacobian has rank one throughout the face of "
                             f"{m.drivers[face.i].joint} and {m.drivers[face.j].joint}")
        D = D.reshape(_SEED, _SEED)
        segs, bx = _crossing_segments(face, t, D)
        for side, key in enumerate(keys):
            splits.setdefault(key, []).extend(bx[side])
        crit.append(_refine_segments(face, segs, 4, chord))
        seeds.append({0: D[:, 0], 1: D[-1, :], 2: D[:, -1], 3: D[0, :]})
    edges = {key: _edge_points(m, ip, box, key, np.array(x)) for key, x in splits.items()}
    A, B, W, arcs = [], [], [], []
    for key, (w, _, P) in edges.items():
        flags = np.isin(w, splits[key])
        arcs.append((("edge", key), P, flags))
    for (face, keys), segs, seed in zip(faces, crit, seeds):
        for side, key in enumerate(keys):
            w, _, P = edges[key]
            sg = _edge_signs(face, side, w, np.sort(splits[key]), t, seed[side])
            a, b = (P[:-1], P[1:]) if side in (0, 1) else (P[1:], P[:-1])
            A.append(a)
            B.append(b)
            W.append(sg)
        if len(segs):
            Pp = face.points(segs[:, 0])
            Pq = face.points(segs[:, 1])
            A.append(Pp)          # in E+ (D > 0 on its left) and, reversed, in E-: weight 2
            B.append(Pq)
            W.append(np.full(len(segs), 2.0))
            for loop in _loops(segs[:, 0], segs[:, 1]):
                P = face.points(loop)
                flags = np.zeros(len(P), bool)
                flags[[0, -1]] = True
                arcs.append((("singular", face.rest), P, flags))
    S = np.concatenate([e[1] for e in edges.values()])
    P = np.concatenate([e[2] for e in edges.values()])
    return np.concatenate(A), np.concatenate(B), np.concatenate(W), arcs, (S, P)


def _edge_signs(face, side, w, cuts, t, Dseed):
    """``sign D`` of each segment of an edge polyline ``w``: constant between the
    crossings ``cuts``, read at the seed node nearest each interval's middle (the value
    marching squares used), or at the middle of an interval with no seed node."""
    bounds = np.concatenate([[0.0], cuts, [1.0]])
    sg_int = np.empty(len(bounds) - 1)
    for k, (lo, hi) in enumerate(zip(bounds[:-1], bounds[1:])):
        inside = np.flatnonzero((t > lo) & (t < hi))
        if len(inside):
            sg_int[k] = np.sign(Dseed[inside[np.argmin(abs(t[inside] - 0.5 * (lo + hi)))]])
        else:
            sg_int[k] = np.sign(face.det(_edge_uv(side, [0.5 * (lo + hi)]))[0])
    mid = 0.5 * (w[1:] + w[:-1])
    return sg_int[np.clip(np.searchsorted(bounds, mid) - 1, 0, len(sg_int) - 1)]


def _pieces(arcs):
    """Candidate segments cut at their crossings: arrays (A, B, arc index, run index)."""
    A = np.concatenate([P[:-1] for _, P, _ in arcs])
    B = np.concatenate([P[1:] for _, P, _ in arcs])
    arc = np.concatenate([np.full(len(P) - 1, k) for k, (_, P, _) in enumerate(arcs)])
    brk = np.concatenate([f[:-1] for _, _, f in arcs])          # a split at the segment's start
    good = np.isfinite(A).all(axis=1) & np.isfinite(B).all(axis=1) & np.any(A != B, axis=1)
    A, B, arc, brk = A[good], B[good], arc[good], brk[good]
    seg, tt, X = _intersections(A, B, arc)
    order = np.lexsort((tt, seg))
    seg, tt, X = seg[order], tt[order], X[order]
    pa, pb, parc, pbrk = [], [], [], []
    start = np.searchsorted(seg, np.arange(len(A)))
    stop = np.searchsorted(seg, np.arange(len(A)), side="right")
    for s in range(len(A)):
        pts = [A[s]] + [X[k] for k in range(start[s], stop[s])] + [B[s]]
        for c in range(len(pts) - 1):
            pa.append(pts[c])
            pb.append(pts[c + 1])
            parc.append(arc[s])
            pbrk.append(bool(brk[s]) if c == 0 else True)
    parc, pbrk = np.array(parc), np.array(pbrk)
    pbrk[1:] |= parc[1:] != parc[:-1]
    pbrk[0] = True
    return np.array(pa), np.array(pb), parc, np.cumsum(pbrk) - 1


def _classify(A, B, run, sheets, diam):
    """Per piece: +1 (workspace on its left), -1 (on its right) or 0 (not a boundary)."""
    SA, SB, SW = sheets
    L = np.hypot(*(B - A).T)
    # the piece halfway along each run (far from its ends, where a run may touch
    # another arc tangentially and the gap between them is thinner than any offset)
    cum = np.cumsum(L)
    first = np.flatnonzero(np.r_[True, run[1:] != run[:-1]])
    last = np.r_[first[1:], len(A)] - 1
    start = np.where(first > 0, cum[first - 1], 0.0)
    half = start + 0.5 * (cum[last] - start)
    rep = np.clip(np.searchsorted(cum, half), first, last)
    a, b = A[rep], B[rep]
    d = (b - a) / np.maximum(L[rep], 1e-300)[:, None]
    eps = np.minimum(1e-7 * diam, 0.05 * L[rep])[:, None]
    mid, nrm = 0.5 * (a + b), np.stack([-d[:, 1], d[:, 0]], axis=1)
    left = _winding(mid + eps * nrm, SA, SB, SW) > 0.5
    right = _winding(mid - eps * nrm, SA, SB, SW) > 0.5
    cls = np.where(left & ~right, 1, np.where(right & ~left, -1, 0))
    return cls[run]


def _loops(A, B):
    """Chain oriented segments ``A``→``B`` (matching ends) into polylines (lists of points)."""
    return [np.array([A[c[0]]] + [B[k] for k in c]) for c in _chains(A, B)]


def _chains(A, B):
    """Chains of segment indices, each segment's end the next one's start."""
    def key(p):
        return (round(float(p[0]), 9), round(float(p[1]), 9))
    nxt = {}
    for k, a in enumerate(A):
        nxt.setdefault(key(a), []).append(k)
    ends = {key(b) for b in B}
    used, out = np.zeros(len(A), bool), []
    starts = [k for k in range(len(A)) if key(A[k]) not in ends] + list(range(len(A)))
    for s in starts:
        if used[s]:
            continue
        chain, k = [], s
        while k is not None and not used[k]:
            used[k] = True
            chain.append(k)
            cand = [c for c in nxt.get(key(B[k]), []) if not used[c]]
            k = cand[0] if cand else None
        out.append(chain)
    return out


def _minors(m, ip, S):
    """The 2 × 2 minors of ``∂p/∂s`` at driver values ``S`` (M, n), its columns scaled to
    unit length, one per pair of drivers (M, n(n-1)/2): the sines of the angles between
    the columns, all zero iff the Jacobian has rank below two (a column that vanishes
    counts as parallel to every other); +inf where ``S`` does not assemble."""
    n = S.shape[1]
    J = np.stack([_solve_p(m, ip, S, np.eye(n)[k]) for k in range(n)], axis=2)      # (M, 2, n)
    U = J / np.maximum(np.linalg.norm(J, axis=1), 1e-300)[:, None, :]
    i, j = np.triu_indices(n, 1)
    r = U[:, 0, i] * U[:, 1, j] - U[:, 1, i] * U[:, 0, j]
    return np.where(np.isfinite(r).all(axis=1, keepdims=True), r, np.inf)


def _critical_points(m, ip, box, r, S, k):
    """Interior points of the box where ``∂p/∂s`` has rank below two, from the minors
    ``r`` (:func:`_minors`) on the seed grid ``S`` (``k`` points per driver): from every
    local minimum of ``R = Σ r²`` on the grid (at most 16, the lowest), Gauss-Newton
    steps on ``r`` (least-squares steps, the zero set being a curve; forward differences,
    the step shortened until ``R`` decreases), at most 40; a point reached with ``R``
    below 1e-12 (sines of 1e-6) at least 1e-6 of each range inside the box is critical.
    Returns (K, n)."""
    from scipy.ndimage import minimum_filter

    n = len(box)
    span = box[:, 1] - box[:, 0]
    R = np.sum(r ** 2, axis=1).reshape((k,) * n)
    loc = (R == minimum_filter(R, size=3, mode="nearest")) & np.isfinite(R)
    idx = np.flatnonzero(loc.ravel())
    idx = idx[np.argsort(R.ravel()[idx])][:16]
    x, rx = S[idx], r[idx]
    steps = np.vstack([np.zeros(n), 1e-7 * np.diag(span)])
    for _ in range(40):
        best = np.sum(rx ** 2, axis=1)
        live = best >= 1e-14
        if not live.any():
            break
        xl = x[live]
        rr = _minors(m, ip, (xl[:, None, :] + steps[None]).reshape(-1, n)).reshape(len(xl), n + 1, -1)
        Jr = np.swapaxes((rr[:, 1:] - rr[:, :1]) / (1e-7 * span)[None, :, None], 1, 2)
        d = np.stack([np.linalg.lstsq(a, -b, rcond=None)[0] if np.isfinite(a).all() else np.zeros(n)
                      for a, b in zip(Jr, rr[:, 0])])
        trial = np.clip(xl[:, None, :] + np.array([1.0, 0.25, 1 / 16])[None, :, None] * d[:, None, :],
                        box[:, 0], box[:, 1])
        rt = _minors(m, ip, trial.reshape(-1, n)).reshape(len(xl), 3, -1)
        Rt = np.sum(rt ** 2, axis=2)
        c = np.argmin(Rt, axis=1)
        E = np.arange(len(xl))
        ok = Rt[E, c] < best[live]
        if not ok.any():
            break
        li = np.flatnonzero(live)[ok]
        x[li], rx[li] = trial[E, c][ok], rt[E, c][ok]
    R = np.sum(rx ** 2, axis=1)
    inner = np.all((x - box[:, 0] > 1e-6 * span) & (box[:, 1] - x > 1e-6 * span), axis=1)
    return x[inner & (R < 1e-12)]


def _check_interior(m, ip, box, a, b, loops, diam):
    """Three drivers: raise ``ValueError`` unless the boundary of the faces' images is
    the workspace's.  A boundary point of ``p(B)`` has each preimage on a face of the
    box or where ``∂p/∂s`` has rank below two (elsewhere ``p`` is a submersion, an
    open map); with no such interior point, ``p(B)`` is the union of the faces' images
    and of the bounded holes of that union that interior fibres fill (closed loops).
    So: no interior critical point (:func:`_critical_points`) and no solved position of
    an interior grid outside the boundary (``loops``: (polygon, signed area) with the
    workspace on the left; ``a``→``b`` its segments) by more than 1e-7 of its diameter
    ``diam``."""
    k = _INNER
    t = 0.5 * (1.0 - np.cos(np.linspace(0.0, np.pi, k)))
    S = np.array(list(itertools.product(*[lo + (hi - lo) * t for lo, hi in box])))
    crit = _critical_points(m, ip, box, _minors(m, ip, S), S, k)
    if len(crit):
        at = ", ".join(f"{d.joint} = {v:.6g}" for d, v in zip(m.drivers, crit[0]))
        raise ValueError(f"the Jacobian has rank one inside the box (at {at}): a critical "
                         "curve there may bound the workspace")
    inner = np.all((S > box[:, 0]) & (S < box[:, 1]), axis=1)
    P = _solve_p(m, ip, S[inner])
    if not np.isfinite(P).all():
        raise ValueError("the box does not assemble everywhere")
    from matplotlib.path import Path

    wind = sum(np.sign(area) * Path(q).contains_points(P) for q, area in loops)
    out = np.flatnonzero(wind < 0.5)
    d = b - a
    for q in P[out]:
        u = np.clip(np.sum((q - a) * d, -1) / np.maximum(np.sum(d * d, -1), 1e-300), 0, 1)
        if np.min(np.hypot(*(q - a - u[:, None] * d).T)) > 1e-7 * diam:
            raise ValueError("a position inside the box lies outside its faces' images")


def envelope(m, ip: int, box) -> Envelope:
    """The exact boundary and area of tracer point ``ip``'s workspace over ``box``
    ((low, high) per driver, rad or m from the reference; two or three drivers).

    Returns
    -------
    Envelope
        ``arcs`` (each :class:`BoundaryArc` labelled by what sets it), ``boundary`` the
        outer loop (K, 2), counter-clockwise, and ``area`` (Green's theorem over every
        boundary piece, holes excluded).

    Raises
    ------
    ValueError
        If a position of the box does not assemble on the reference's modes (the map
        is then not defined on the whole box), a face has rank one throughout, or, for
        three drivers, ``∂p/∂s`` has rank one inside the box or an interior position
        maps outside the faces' images; for four drivers or more.  The message is the
        reason.

    Notes
    -----
    The seed grid only finds where ``det ∂p/∂s`` changes sign; every point of a singular
    curve is bisected inside a bracket, and the box edges are solved at Chebyshev points,
    so the area's error is that of the polylines' chords, O(h²) in the edge spacing h.
    """
    box = np.asarray(box, float)
    if len(box) > 3:
        raise ValueError("four drivers or more: the critical sets inside the box's "
                         "three-dimensional faces are not searched")
    SA, SB, SW, arcs, (S, P) = _sheets(m, ip, box)
    A, B, arc, run = _pieces(arcs)
    allp = np.concatenate([A, B])
    diam = float(np.hypot(*(allp.max(axis=0) - allp.min(axis=0))))
    cls = _classify(A, B, run, (SA, SB, SW), max(diam, 1e-300))
    on = cls != 0
    a = np.where((cls[on] > 0)[:, None], A[on], B[on])
    b = np.where((cls[on] > 0)[:, None], B[on], A[on])
    area = float(0.5 * np.sum(a[:, 0] * b[:, 1] - b[:, 0] * a[:, 1]))
    chains = _chains(a, b)
    labels = [arcs[k][0] for k in arc[on]]
    loops = [np.array([a[c[0]]] + [b[k] for k in c]) for c in chains]
    shoelace = [0.5 * np.sum(q[:-1, 0] * q[1:, 1] - q[1:, 0] * q[:-1, 1]) for q in loops]
    best = int(np.argmax(shoelace)) if loops else None
    if len(box) == 3:
        _check_interior(m, ip, box, a, b, list(zip(loops, shoelace)), max(diam, 1e-300))
    outer = loops[best] if loops else np.empty((0, 2))
    barcs = []
    for c in chains:
        for lab, grp in itertools.groupby(c, key=lambda k: labels[k]):
            g = list(grp)
            barcs.append(_arc(lab, np.array([a[g[0]]] + [b[k] for k in g])))
    barcs = tuple(barcs)
    return Envelope(barcs, outer, area, S, P)


def _arc(label, pts) -> BoundaryArc:
    kind, key = label
    if kind == "singular":
        return BoundaryArc("singular", tuple((int(d), ("low", "high")[e]) for d, e in key), pts)
    return BoundaryArc("edge", tuple((int(d), ("low", "high")[e]) for d, e in key[1]), pts)
