"""Generic realisations of atlas mechanisms and their coupler curves.

For a mechanism of the atlas (:class:`~.inversions.InversionRecord`), a realisation
is a set of joint positions in a normalised frame: the driver's pin at the origin,
the other joints of the driven link at a distance in ``[0.15, 0.45]`` from it (a
short input link, Grashof's condition favours it; Grashof 1883), every other joint
uniform in the square ``[−1, 1]²`` — so every link length is bounded by ``2√2``.
Positions given this way assemble by construction at the reference.

A sample is **kept** when the driver turns fully with every monitored angle (the
transmission angle of each RRR dyad, the triad angles; Artobolevsky's and Hain's
convention) at least ``min_transmission`` from 0° and 180°.  The sample is screened on a
grid of driver values, a batch of samples at once (16, then 32, then 64:
:func:`kin.design.solve_designs`, one pass over the mechanism's compiled plan for all of
them, by the compiled kernels and the triad's compiled tracker when numba is installed:
:func:`kin.kernel.for_batches`); the samples it keeps are then **certified** in order by the design check's
motion and angle extremes (:func:`kin.check.driver_angles`), whose continuation and
event search find limits and angle extremes between grid points (no claim rests on the
grid alone).

Coupler curves: a few random points on every moving link other than the driven
one (whose points trace circles), traced over one turn of the driver.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from multiloop.topo.assur import decompose
from multiloop.topo.errors import LinkageError
from multiloop.topo.model import Mechanism
from multiloop.kin.check import driver_angles
from multiloop.kin.check.angle_types import angle_type
from multiloop.kin.check.transmission import angle_specs, spec_value
from multiloop.kin import kernel
from multiloop.kin.design import solve_designs
from multiloop.kin.geometry import design_matrix, design_names
from multiloop.kin.solve import solve

from .inversions import InversionRecord, inversion

__all__ = ["Realisation", "sample_positions", "realise", "coupler_curves", "CurveSample"]

#: driver samples of the screen and of a traced curve (one turn)
TURN_SAMPLES = 181


@dataclass(frozen=True, slots=True)
class Realisation:
    """A kept realisation: the mechanism (with geometry), the seed that drew it and
    the smallest monitored angle the check certified (degrees, folded to ``[0, 90]``)."""

    inversion: InversionRecord
    mechanism: Mechanism
    seed: int
    min_angle: float
    tries: int


@dataclass(frozen=True, slots=True)
class CurveSample:
    """A coupler curve: the link and the reference position of the traced point, and
    the curve over one turn, ``(TURN_SAMPLES − 1, 2)`` (the last sample repeats the first)."""

    link: str
    at: tuple[float, float]
    points: np.ndarray


def sample_positions(inv: InversionRecord, rng: np.random.Generator) -> dict[str, tuple[float, float]]:
    """Joint positions of one random realisation (module docstring)."""
    driver = inv.joint
    on_driven = {a for a, j in enumerate(inv.joints) if inv.driven in j and a != driver}
    at = {}
    for a in range(len(inv.joints)):
        if a == driver:
            p = (0.0, 0.0)
        elif a in on_driven:
            r, t = rng.uniform(0.15, 0.45), rng.uniform(0, 2 * np.pi)
            p = (r * np.cos(t), r * np.sin(t))
        else:
            p = tuple(rng.uniform(-1.0, 1.0, 2))
        at[f"J{a + 1}"] = (float(p[0]), float(p[1]))
    return at


def _turn() -> np.ndarray:
    return np.linspace(0.0, 2 * np.pi, TURN_SAMPLES)


def _screen(m: Mechanism, samples: list, specs, min_angle: float) -> np.ndarray:
    """For each sample (joint positions of ``m``'s topology), whether every grid position
    assembles (each design on its reference's branches, in one pass over ``m``'s plan for
    all samples: :func:`kin.design.solve_designs`) and every monitored angle is within
    bounds: a quick necessary test."""
    names = design_names(m)
    X = design_matrix(names, samples)
    with warnings.catch_warnings(), kernel.for_batches():
        warnings.simplefilter("ignore")
        st = solve_designs(m, names, X, _turn())
    keep = np.all(st.ok, axis=1)
    for sp in specs:
        a = spec_value(st, sp)
        folded = np.minimum(a, 180.0 - a)
        keep &= np.all(np.isfinite(folded) & (folded >= min_angle), axis=1)
    return keep


def _certified(m: Mechanism, min_angle: float) -> float | None:
    """The smallest folded monitored angle when the driver turns fully and no angle is
    flagged at ``min_angle`` (the check's motion and exact angle extremes,
    :func:`kin.check.driver_angles`); None otherwise."""
    try:
        with kernel.for_batches():
            dc = driver_angles(m)
    except (LinkageError, ValueError, FloatingPointError):
        return None
    if not dc.full_rotation or dc.flagged(min_angle):
        return None
    lows = [angle_type(a.quantity).margin(a.extreme.min, a.extreme.max) for a in dc.angles if a.extreme is not None]
    return float(min(lows, default=90.0))


def realise(inv: InversionRecord, seed: int, tries: int = 400, min_transmission: float = 20.0,
            batch: int = 64, first: int = 16) -> Realisation | None:
    """The first sample (seeds ``seed``, ``seed + 1``, …, at most ``tries``) that the
    screen keeps and :func:`kin.check.driver_angles` certifies; None when none does.  The samples
    are drawn in order and screened in batches of ``first``, twice as many, … up to
    ``batch`` (the result is the one the samples give one by one)."""
    base = inv.as_mechanism()
    specs = angle_specs(decompose(base))
    rng = np.random.default_rng(seed)
    done, size = 0, min(first, batch)
    while done < tries:
        drawn = [sample_positions(inv, rng) for _ in range(min(size, tries - done))]
        size = min(2 * size, batch)
        first = next(((k, m) for k, m in ((k, _built(inv, at)) for k, at in enumerate(drawn)) if m is not None), None)
        if first is not None:
            # each sample's screen is its own (design by design): only the samples it keeps
            # are built as mechanisms, in order (one that does not build is skipped, as before)
            keep = _screen(first[1], drawn[first[0]:], specs, min_transmission)
            for k in first[0] + np.flatnonzero(keep):
                m = first[1] if k == first[0] else _built(inv, drawn[k])
                low = None if m is None else _certified(m, min_transmission)
                if low is not None:
                    return Realisation(inv, m, seed, low, done + int(k) + 1)
        done += len(drawn)
    return None


def _built(inv: InversionRecord, at: dict) -> Mechanism | None:
    """The mechanism of ``inv`` with the joint positions ``at``, or None when they make no
    valid mechanism."""
    try:
        return inversion(inv.joints, inv.frame, inv.joint, inv.driven, name=f"atlas-n{inv.n}", at=at)
    except LinkageError:
        return None


def coupler_curves(m: Mechanism, frame_driven: tuple[str, str], per_link: int,
                   rng: np.random.Generator) -> list[CurveSample]:
    """``per_link`` random points on every moving link other than the driven one,
    traced over one turn (``TURN_SAMPLES`` driver values)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = solve(m, _turn())
    out = []
    for link in m.link_names:
        if link in frame_driven:
            continue
        for _ in range(per_link):
            at = tuple(float(v) for v in rng.uniform(-1.0, 1.0, 2))
            p = np.asarray(st.point_on_link(link, at)[0][:-1])
            length = float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)))
            if np.isfinite(length) and length > 1e-6:      # a link at rest traces no curve
                out.append(CurveSample(link, at, p))
    return out
