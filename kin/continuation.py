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


@dataclass(frozen=True)
class Probe:
    """One group evaluated at a batch of inputs.

    ``ok`` (n,): assembled (the group and everything upstream); ``gap`` (n,): distance
    between the group's two assembly branches (``None`` for a group without
    branches); ``pts`` (n, k, 2): the group's signature points (first) and the known
    points it hangs from, whose motion bounds the change of ``gap``.
    """

    ok: np.ndarray
    gap: np.ndarray | None = None
    pts: np.ndarray | None = None
    up: np.ndarray | None = None        # (n,) everything upstream assembled (default: all)


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
    """Per interval: (limit mask, uncertified mask), cut after the first limit."""
    ok = pr.ok
    ds = np.diff(s)
    lim = ok[:-1] & ~ok[1:]
    if pr.up is not None:
        lim &= pr.up[1:]
    unc = np.zeros_like(lim)
    if pr.gap is not None:
        both = ok[:-1] & ok[1:] & (ds > 0)
        mot = np.sum(np.sqrt(np.sum(np.square(np.diff(pr.pts, axis=0)), axis=-1)), axis=-1)
        g = np.minimum(pr.gap[:-1], pr.gap[1:])
        with np.errstate(invalid="ignore"):
            unc = both & ~(g > kappa * mot)
        for h in handled:               # a crossing already resolved by the tangent rule
            near = (s[:-1] <= h + DELTA) & (s[1:] >= h - DELTA)
            unc &= ~near
    first = np.flatnonzero(lim)
    if first.size:
        lim[first[0] + 1:] = False
        unc[first[0] + 1:] = False
    return lim, unc


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


def walk(evaluate: Callable, P: np.ndarray, groups, *, floor: float = FLOOR,
         delta: float = DELTA, kappa: float = KAPPA, max_rounds: int = 400,
         refine_limits: bool = True) -> Walk:
    """Follow the polyline of inputs ``P`` (K, d) from ``P[0]`` (where every group
    has its reference sign) with certified steps; see the module docstring.

    ``groups`` are the keys of :class:`Probe` returned by ``evaluate``, in solving
    order.  ``P`` must already be sampled finely enough (steps ≤ :data:`MAX_STEP`).
    Returns the sign flips, the crossings met and the first limit (``block``).
    """
    P = np.asarray(P, float)
    s_nodes = path_parameter(P)
    s = s_nodes.copy()
    flips = {g: [] for g in groups}
    handled: dict = {g: [] for g in groups}
    crossings = []
    for rounds in range(1, max_rounds + 1):
        signs = {g: sign_factor(flips[g], s) for g in groups}
        probes = evaluate(_at(P, s_nodes, s), signs)
        width = np.diff(s)
        event = None                         # (interval, group, is_limit)
        refine = np.zeros(len(s) - 1, bool)
        for g in groups:
            lim, unc = _problems(probes[g], s, handled[g], kappa)
            if not refine_limits and probes[g].gap is None:
                continue                     # a tracked group: its own tracker reports failures
            else:
                lim_floor = lim & (width <= floor)
            bad = lim | unc
            at_floor = np.flatnonzero(lim_floor | (unc & (width <= floor)))
            if at_floor.size and (event is None or at_floor[0] < event[0]):
                event = (int(at_floor[0]), g, bool(lim[at_floor[0]]))
            refine |= bad & (width > floor) & ~lim_floor
        if event is not None:
            refine[event[0]:] = False
        if refine.any():
            mid = 0.5 * (s[:-1] + s[1:])[refine]
            s = np.sort(np.concatenate([s, mid]))
            continue
        if event is None:
            return Walk(s, _frozen(flips), tuple(crossings), None, rounds)
        i, g, is_limit = event
        if is_limit:
            return Walk(s, _frozen(flips), tuple(crossings), (s[i], s[i + 1], g), rounds)
        s_star = 0.5 * (s[i] + s[i + 1])
        d = min(delta, 0.25 * (s_star - s[0])) if s_star > s[0] else delta
        rule = _resolve(evaluate, P, s_nodes, flips, g, s_star, d)
        if rule == "limit":                  # a turning point within delta: the motion stops
            return Walk(s, _frozen(flips), tuple(crossings), (s[i + 1], s_star + d, g), rounds)
        if rule == "flip":
            flips[g].append(s_star)
        handled[g].append(s_star)
        crossings.append((s_star, g))
    raise RuntimeError("continuation did not settle")  # pragma: no cover


def _frozen(flips: dict) -> dict:
    return {g: tuple(sorted(f)) for g, f in flips.items()}
