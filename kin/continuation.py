"""Branch-safe continuation along an input path: step control, limits, crossings.

The closed-form dyads are exact for a *fixed* assembly sign; what can go wrong is
the sign itself.  Between two positions a continuous motion keeps a dyad's sign
unless the path meets the singular set, where the two assembly branches meet:

* a **limit** (turning point): past it the group cannot be assembled, so the
  motion stops there;
* a **crossing** (a change point or bifurcation, e.g. the flat positions of a
  parallelogram or a crank-slider with crank = rod): both branches go on, and the
  motion continues on the one whose tangent continues the incoming tangent (for a
  parallelogram: it keeps the parallelogram mode of the reference).

:func:`walk` follows a path of inputs with a step control that is scale-aware: an
interval between two samples is *certified* when the distance between the two
branches at both ends (the branch gap) exceeds ``kappa`` times the motion of the
group's points over the interval; every other interval is bisected, so the step
shrinks in proportion to the distance from the singular set, down to ``floor``.
An interval at the floor whose far end cannot be assembled is a limit (the walk
stops); one whose two ends assemble is a crossing, resolved by the tangent rule
from three probes at ``±delta`` (linear prediction from the two probes before
against the two candidates after).  This is the predictor–corrector with
step-size control of Allgower & Georg 1990 (Numerical Continuation Methods,
ch. 6) specialised to closed-form correctors.

The path is given as samples ``P`` (K, n_drivers) of the inputs in *scaled*
units (rad for R drivers, m / size for P drivers) and parametrised by its
cumulative arclength ``s``; ``evaluate(X, signs)`` solves the mechanism at the
inputs ``X`` (n, n_drivers) (unscaled) with the given per-group sign factors and
returns one :class:`Probe` per group.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

__all__ = ["Probe", "Walk", "walk", "sign_factor", "path_parameter"]

#: largest step of a walk (scaled input units: 0.02 rad ≈ 1.15°, or 2 % of the size)
MAX_STEP = 0.02
#: smallest bisected step: an uncertified interval this short holds a singular point
FLOOR = 1e-10
#: half-width of the probes that resolve a crossing by the tangent rule
DELTA = 1e-6
#: certification margin: branch gap > KAPPA × motion of the group's points
KAPPA = 4.0
#: the bound on |margin''| over an interval: CURV_SAFETY × the larger of its ends' values
CURV_SAFETY = 2.0
#: an uncertified interval is split into this many parts a round
REFINE_SPLIT = 4
#: a bracket of a limit is split into this many parts a round (a zoom search) ...
LIMIT_ZOOM = 128
#: ... and sampled at the secant root of its reach margin ± the bracket × 10⁻ᵏ, k = 1…
#: LIMIT_DIGITS: a margin crosses zero linearly at a limit, so the bracket that holds
#: the root shrinks to about the secant's error (quadratic in the bracket) a round
LIMIT_DIGITS = 12


@dataclass(frozen=True)
class Probe:
    """One group evaluated at a batch of inputs.

    ``ok`` (n,): assembled (the group and everything upstream); ``gap`` (n,): distance
    between the group's two assembly branches (``None`` for a group without
    branches); ``pts`` (n, k, 2): the group's signature points (first) and the known
    points it hangs from (the tangent rule predicts the first).

    ``refined``: a group without a margin whose tracker refines its own steps down to
    where it fails (Newton's continuation halves its step up to 12 times), so that a walk
    needing only the samples on either side of a limit need not zoom it.

    ``margin`` (n,): the group's reach margin, positive where the group assembles with
    its two branches apart and zero on its singular set (limits and crossings alike);
    ``lip`` (n, k, 2): points whose displacement bounds the change of ``margin``: it is
    1-Lipschitz in them, or, when ``lip_scale`` (their length) is given, quadratic in
    them (an RRR dyad: ``margin = min((l₂ + l₃)² − d², d² − (l₂ − l₃)²)`` with
    ``d = |lip| = |C − A|``, smooth even where A meets C).  ``curv``: |margin''| along
    the path; ``tol``: the margin's rounding.
    """

    ok: np.ndarray
    gap: np.ndarray | None = None
    pts: np.ndarray | None = None
    up: np.ndarray | None = None        # (n,) everything upstream assembled (default: all)
    margin: np.ndarray | None = None
    lip: np.ndarray | None = None
    curv: np.ndarray | None = None      # (n,) |d²margin/ds²| along the path, where known
    tol: np.ndarray | None = None       # (n,) rounding of ``margin``
    lip_scale: np.ndarray | None = None  # (n,) |lip| when the margin is quadratic in ``lip``
    refined: bool = False               # a failure is where the group's own continuation stopped


@dataclass(frozen=True)
class Walk:
    """Result of :func:`walk` (parameters ``s`` along the path)."""

    s: np.ndarray                               # final samples
    flips: dict = field(default_factory=dict)   # group -> tuple of s where its sign flips
    crossings: tuple = ()                       # (s, group) of crossings met
    block: tuple | None = None                  # (s_last_ok, s_first_bad, group) or None
    rounds: int = 0


def path_parameter(P: np.ndarray) -> np.ndarray:
    """Cumulative arclength of the polyline through the samples ``P`` (K, d)."""
    P = np.asarray(P, float)
    if P.shape[0] == 0:
        return np.zeros(0)
    d = np.sqrt(np.sum(np.square(np.diff(P, axis=0)), axis=1))
    return np.concatenate([[0.0], np.cumsum(d)])


def sign_factor(flips, s: np.ndarray) -> np.ndarray:
    """``(−1)^(number of flips at parameters < s)`` for each ``s``."""
    f = np.asarray(sorted(flips), float)
    if f.size == 0:
        return np.ones(np.shape(s))
    return np.where(np.searchsorted(f, s, side="left") % 2 == 0, 1.0, -1.0)


def _at(P: np.ndarray, s_nodes: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Inputs on the polyline at parameters ``s``."""
    if P.shape[0] == 1:
        return np.repeat(P, len(s), axis=0)
    return np.stack([np.interp(s, s_nodes, P[:, j]) for j in range(P.shape[1])], axis=1)


def _problems(pr: Probe, s: np.ndarray, handled: list, kappa: float):
    """Per interval: (limit mask, uncertified mask, flat mask), cut after the first limit.

    An interval is certified when its group's reach margin stays positive over it: the
    smaller end value exceeds both ``kappa`` × the displacement of the points the margin
    is 1-Lipschitz in, or the interpolation bound ``M w²/8`` (M bounds |margin''|), and
    the margin's rounding ``tol``.  ``flat``: both ends within ``tol`` of zero (the
    group is numerically on its singular set there; refining further cannot help).
    """
    ok = pr.ok
    ds = np.diff(s)
    lim = ok[:-1] & ~ok[1:]
    if pr.up is not None:
        lim &= pr.up[1:]
    unc = np.zeros_like(lim)
    flat = np.zeros_like(lim)
    if pr.margin is not None or pr.gap is not None:
        both = ok[:-1] & ok[1:] & (ds > 0)
        value, pts = (pr.margin, pr.lip) if pr.margin is not None else (pr.gap, pr.pts)
        mot = np.sum(np.sqrt(np.sum(np.square(np.diff(pts, axis=0)), axis=-1)), axis=-1)
        if pr.margin is not None and pr.lip_scale is not None:      # | |r|² change | ≤ |Δr| (|r_a| + |r| )
            mot = mot * (2.0 * np.fmax(pr.lip_scale[:-1], pr.lip_scale[1:]) + mot)
        g = np.minimum(value[:-1], value[1:])
        with np.errstate(invalid="ignore"):
            cert = g > kappa * mot
            if pr.margin is not None and pr.curv is not None:
                # |margin − chord| ≤ M w²/8 with M ≥ |margin''| on the interval: a touch
                # (a crossing, margin ~ c t²) is approached in O(log) bisections
                M = CURV_SAFETY * np.fmax(pr.curv[:-1], pr.curv[1:])
                cert |= g > M * ds * ds / 8.0
            if pr.tol is not None:
                cert &= g > np.fmax(pr.tol[:-1], pr.tol[1:])
                flat = both & (np.fmax(value[:-1], value[1:]) <= np.fmax(pr.tol[:-1], pr.tol[1:]))
            unc = both & ~cert
        for lo, hi in handled:          # a crossing already resolved by the tangent rule
            near = (s[:-1] <= hi) & (s[1:] >= lo)
            unc &= ~near
            flat &= ~near
    first = np.flatnonzero(lim)
    if first.size:
        lim[first[0] + 1:] = False
        unc[first[0] + 1:] = False
        flat[first[0] + 1:] = False
    return lim, unc, flat


def _zero_run(pr: Probe, s: np.ndarray, i: int) -> tuple[float, float]:
    """The parameters ``(lo, hi)`` of the run of samples around interval ``i`` where the
    margin is within its rounding of zero (the interval itself when there is none)."""
    lo, hi = i, i + 1
    if pr.margin is None or pr.tol is None:
        return s[lo], s[hi]
    z = pr.ok & (pr.margin <= pr.tol)
    while lo > 0 and z[lo - 1]:
        lo -= 1
    while hi < len(s) - 1 and z[hi + 1]:
        hi += 1
    return s[lo], s[hi]


def _probe_at(evaluate, P, s_nodes, flips, g, q: np.ndarray) -> Probe:
    """Group ``g``'s probe at path parameters ``q``, on the signs the flips so far give."""
    return evaluate(_at(P, s_nodes, q), {k: sign_factor(f, q) for k, f in flips.items()})[g]


def _vertex(evaluate, P, s_nodes, flips, g, s_star: float, h: float) -> float:
    """A crossing is a touch of the reach margin, ``margin ≈ c (s − s*)²``: ``s*`` from
    the margin at ``s_star ± h, ± 2h`` (h well outside the run where the margin is
    rounding), the centre of that run when the margin does not fit."""
    pr = _probe_at(evaluate, P, s_nodes, flips, g, s_star + h * np.array([-2.0, -1.0, 1.0, 2.0]))
    if pr.margin is None or not np.all(np.isfinite(pr.margin)):
        return s_star
    f2m, f1m, f1, f2 = pr.margin
    c = (f2 + f2m - f1 - f1m) / (6.0 * h * h)
    if not c > 0:
        return s_star
    e = -(f1 - f1m) / (4.0 * c * h)
    return s_star + e if abs(e) < h else s_star


def _toward_root(a: float, b: float, fa: float, fb: float, n: int) -> np.ndarray:
    """Sample points of a limit's bracket ``[a, b]`` (sorted, inside it): ``n − 1``
    equispaced, and, when the margin less its rounding is ``fa > 0`` at ``a`` and
    ``fb ≤ 0`` at ``b`` (finite), the secant root ``r`` and ``r ± (b − a) × 10⁻ᵏ``
    (k = 1 … :data:`LIMIT_DIGITS`).  The equispaced points alone are a zoom search
    (the bracket shrinks ``n``-fold); the cluster finds a smooth root's neighbourhood."""
    w = b - a
    q = a + w * np.arange(1, n) / n
    if np.isfinite(fa) and np.isfinite(fb) and fa > 0.0 >= fb and w > 0.0:
        r = a + w * fa / (fa - fb)
        off = w * 10.0 ** -np.arange(1, LIMIT_DIGITS + 1)
        q = np.concatenate([q, [r], r - off, r + off])
    return np.unique(q[(q > a) & (q < b)])


def _excess(pr: Probe) -> np.ndarray:
    """The reach margin less its rounding (positive: assembled with its branches apart)."""
    return pr.margin - (0.0 if pr.tol is None else pr.tol)


def _limit_root(evaluate, P, s_nodes, flips, g, a: float, b: float, ends=(np.nan, np.nan),
                n: int = LIMIT_ZOOM, rounds: int = 16):
    """The limit of group ``g`` in ``[a, b]`` (assembled at ``a``, not at ``b``) to the
    precision of its reach margin: a search on the sign of the margin less its rounding
    (``a`` stays where the margin exceeds its rounding, so that the group assembles
    there whatever the rounding of the other inputs: the end of a usable range) at the
    points of :func:`_toward_root` (``ends``: that excess at ``a`` and ``b``, when
    known), down to rounding."""
    fa, fb = ends
    for _ in range(rounds):
        if b - a <= 4.0 * np.finfo(float).eps * max(abs(a), abs(b), 1.0):
            break
        q = _toward_root(a, b, fa, fb, n)
        if q.size == 0:
            break
        pr = _probe_at(evaluate, P, s_nodes, flips, g, q)
        if pr.margin is None:
            return a, b
        f = _excess(pr)
        pos = np.flatnonzero(~(f > 0.0))
        if pos.size == 0:
            a, fa = q[-1], f[-1]
            continue
        j = int(pos[0])
        (a, fa), (b, fb) = ((q[j - 1], f[j - 1]) if j > 0 else (a, fa)), (q[j], f[j])
    return a, b


def _resolve(evaluate, P, s_nodes, flips, k, s_star, delta):
    """Tangent rule at a crossing of group ``k`` at ``s_star``: ``"flip"`` or ``"keep"``
    the sign, or ``"limit"`` when the group cannot be assembled just after it."""
    q = np.array([s_star - 2 * delta, s_star - delta, s_star + delta, s_star + delta])
    X = _at(P, s_nodes, q)
    signs = {g: sign_factor(f, q) for g, f in flips.items()}
    signs[k] = signs[k].copy()
    signs[k][3] *= -1.0
    pr = evaluate(X, signs)[k]
    if not pr.ok[2:].all():
        return "limit"
    sig = pr.pts[:, 0]
    pred = sig[1] + 2.0 * (sig[1] - sig[0])
    return "flip" if np.linalg.norm(sig[3] - pred) < np.linalg.norm(sig[2] - pred) else "keep"


def _ready_events(event, ready: dict, last: bool) -> list:
    """The events one round resolves: the first; for the last group (``last``), also its
    later ones up to its first limit and before any other group's event (its own flips
    change neither its reach margin nor any other group's probe)."""
    i0, g, is_limit = event
    out = [(i0, is_limit)]
    if not last:
        return out
    others = [at for h, (at, _) in ready.items() if h != g and at.size]
    stop = min((int(at[at > i0][0]) for at in others if (at > i0).any()), default=np.inf)
    at, lim = ready[g]
    for i, l in zip(at.tolist(), lim.tolist()):
        if i <= i0:
            continue
        if i >= stop:
            break
        out.append((i, bool(l)))
        if l:
            break
    return out


def _crossing(evaluate, P, s_nodes, flips, handled, crossings, pr, s, i, g, delta):
    """Resolve group ``g``'s crossing in interval ``i`` (a run of flat samples): locate it
    at the vertex of the margin, keep or flip the sign by the tangent rule, record it;
    returns the limit ``(a, b, g)`` when the group cannot go on there, else None."""
    lo, hi = _zero_run(pr, s, i)
    if 0.5 * (lo + hi) + max(delta, hi - lo) >= s[-1]:
        # the path ends in the touch (a range end at a reach limit): the tangent rule's
        # probes would lie past its end, and there is nothing past it to resolve
        handled[g].append((lo - delta, np.inf))
        return None
    s_star = 0.5 * (lo + hi)
    d = max(delta, hi - lo)
    d = min(d, 0.25 * (s_star - s[0])) if s_star > s[0] else d
    if pr.margin is not None and s_star - 2 * d > s[0]:
        s_star = _vertex(evaluate, P, s_nodes, flips, g, s_star, d)
    rule = _resolve(evaluate, P, s_nodes, flips, g, s_star, d)
    if rule == "limit":                  # a turning point within delta: the motion stops
        return (*_limit_root(evaluate, P, s_nodes, flips, g, lo, s_star + d), g)
    if rule == "flip":
        flips[g].append(s_star)
    handled[g].append((lo - d, hi + d))
    crossings.append((s_star, g))
    return None


def _classify(probes, groups, s, handled, kappa, floor, refine_limits, zoom_tracked):
    """One round's problems over every group (:func:`_problems`): the first event at the
    floor ``(interval, group, is_limit)`` or None, the intervals to refine, the limits'
    brackets to zoom (``at_limit``: the margin's excess at their ends), each group's
    intervals at the floor with their limit flags, and the first interval with a limit."""
    width = np.diff(s)
    event = None
    refine = np.zeros(len(s) - 1, bool)
    zoom = np.zeros(len(s) - 1, bool)
    at_limit, ready, stop = {}, {}, len(s)
    for g in groups:
        lim, unc, flat = _problems(probes[g], s, handled[g], kappa)
        tracked = probes[g].gap is None and probes[g].margin is None
        if not refine_limits and tracked:
            continue                     # a tracked group: its own tracker reports failures
        stop = min([stop, *np.flatnonzero(lim)[:1].tolist()])
        lim_floor = lim & ((width <= floor) | (tracked and probes[g].refined and not zoom_tracked))
        at_floor = np.flatnonzero(lim_floor | (unc & ((width <= floor) | flat)))
        ready[g] = (at_floor, lim[at_floor])
        if at_floor.size and (event is None or at_floor[0] < event[0]):
            event = (int(at_floor[0]), g, bool(lim[at_floor[0]]))
        refine |= (lim | unc) & (width > floor) & ~lim_floor & ~flat
        zoom_g = lim & (width > floor) & ~lim_floor
        zoom |= zoom_g
        if probes[g].margin is not None:
            f = _excess(probes[g])
            at_limit.update({i: (f[i], f[i + 1]) for i in np.flatnonzero(zoom_g).tolist() if i not in at_limit})
    return event, refine, zoom, at_limit, ready, stop


def _refined(s, refine, zoom, at_limit) -> np.ndarray:
    """The samples ``s`` with the intervals ``refine`` split :data:`REFINE_SPLIT`-fold and
    a limit's brackets (``zoom``) sampled by :func:`_toward_root` (``at_limit``)."""
    zoom = zoom[: len(s) - 1] & refine[: len(s) - 1]
    refine = refine[: len(s) - 1]
    u = np.arange(1, REFINE_SPLIT) / REFINE_SPLIT
    mid = (s[:-1][refine & ~zoom, None] + np.diff(s)[refine & ~zoom, None] * u).ravel()
    sub = np.concatenate([_toward_root(s[i], s[i + 1], *at_limit.get(i, (np.nan, np.nan)), LIMIT_ZOOM)
                          for i in np.flatnonzero(zoom)] or [s[:0]])
    return np.sort(np.concatenate([s, mid, sub]))


def walk(evaluate: Callable, P: np.ndarray, groups, *, floor: float = FLOOR,
         delta: float = DELTA, kappa: float = KAPPA, max_rounds: int = 400,
         refine_limits: bool = True, zoom_tracked: bool = True) -> Walk:
    """Follow the polyline of inputs ``P`` (K, d) from ``P[0]`` (where every group
    has its reference sign) with certified steps; see the module docstring.

    ``groups`` are the keys of :class:`Probe` returned by ``evaluate``, in solving
    order.  ``P`` must already be sampled finely enough (steps ≤ :data:`MAX_STEP`).
    Returns the sign flips, the crossings met and the first limit (``block``).
    ``refine_limits=False``: a tracked group (no reach margin) makes no event, its own
    tracker reports its failures; ``zoom_tracked=False``: the limit of a group whose
    probe is ``refined`` is the interval between its last assembled sample and the next
    (no zoom: every round follows the whole path again), which is all a path's rows need.
    """
    P = np.asarray(P, float)
    s_nodes = path_parameter(P)
    s = s_nodes.copy()
    flips = {g: [] for g in groups}
    handled: dict = {g: [] for g in groups}
    crossings = []
    tail = s[:0]                             # samples set aside past a limit (_set_aside)
    asked = None                             # the samples and flips the probes were solved at
    for rounds in range(1, max_rounds + 1):
        # a round after an event that changed no sign (a crossing kept, a touch at the
        # path's end) has the same samples and signs: its probes are the last round's
        now = (s.tobytes(), tuple(tuple(flips[g]) for g in groups))
        if now != asked:
            signs = {g: sign_factor(flips[g], s) for g in groups}
            probes, asked = evaluate(_at(P, s_nodes, s), signs), now
        event, refine, zoom, at_limit, ready, stop = _classify(probes, groups, s, handled, kappa, floor,
                                                               refine_limits, zoom_tracked)
        if stop + 2 < len(s):
            tail, s, refine, zoom, event, ready = _set_aside(stop, s, tail, refine, zoom, event, ready)
        # the last group's crossings change no other probe (nor its own reach margin): the
        # walk refines past them and resolves them all in one round
        last = event is not None and event[1] == groups[-1] and not event[2]
        if event is not None and not last:
            refine[event[0]:] = False
            if event[2] and event[0] + 2 < len(s):
                s = s[: event[0] + 2]         # nothing beyond the first limit matters
        if refine.any():
            s = _refined(s, refine, zoom, at_limit)
            continue
        if event is None:
            if tail.size:                    # the limit is gone: walk on
                s, tail = np.concatenate([s, tail]), tail[:0]
                continue
            return Walk(s, _frozen(flips), tuple(crossings), None, rounds)
        g = event[1]
        done = len(handled[g])
        for i, is_limit in _ready_events(event, ready, last):   # in order, up to a limit
            if any(a <= s[i] < b for a, b in handled[g][done:]):
                continue                     # inside a run resolved this round
            if is_limit:                     # (a tracked group has no margin to zoom on)
                a, b = (_limit_root(evaluate, P, s_nodes, flips, g, s[i], s[i + 1],
                                    tuple(_excess(probes[g])[i:i + 2]))
                        if probes[g].margin is not None else (s[i], s[i + 1]))
                return Walk(s[: i + 2], _frozen(flips), tuple(crossings), (a, b, g), rounds)
            block = _crossing(evaluate, P, s_nodes, flips, handled, crossings, probes[g], s, i, g, delta)
            if block is not None:
                return Walk(s, _frozen(flips), tuple(crossings), block, rounds)
    raise RuntimeError("continuation did not settle")  # pragma: no cover


def _set_aside(stop: int, s, tail, refine, zoom, event, ready):
    """The samples past interval ``stop`` (a limit) set aside: nothing beyond a limit is
    refined, and a probe there costs (a tracked group re-runs the whole path each round).
    They come back if the refinement finds no limit there after all."""
    keep = stop + 1
    ready = {g: (at[at < keep], lim[at < keep]) for g, (at, lim) in ready.items()}
    if event is not None and event[0] >= keep:
        event = None
    return np.concatenate([s[stop + 2:], tail]), s[: stop + 2], refine[:keep], zoom[:keep], event, ready


def _frozen(flips: dict) -> dict:
    return {g: tuple(sorted(f)) for g, f in flips.items()}
