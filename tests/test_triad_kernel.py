"""The batched triad tracker's compiled route (``kin/groups/_triad_nb.py``) against its
oracle, the NumPy route (:func:`kin.groups.triad.track_designs` with ``jit=False``).

* :func:`kin.design.solve_designs` with ``kernel.using("off")`` and ``"on"`` for the
  catalogue's Stephenson III triad and Stephenson III (class IV, reduced to a triad):
  designs perturbed around the start, near and far (some out of reach, some through a
  turning point), on short and long input ranges: the same ``ok`` pattern, poses within
  1e-12 of the size.
* :func:`track_designs` itself on random triads whose pins move and whose lengths vary
  along the inputs (class IV's reduction), a non-finite pin among them: the same status
  codes, points and angles within 1e-12.
* The compiled companion eigenvalues (balanced Hessenberg QR) against LAPACK's on
  random degree-6 polynomials, with and without a double root.
* The plan kernel's whole tracker (``_triad_nb.track_path``) against ``triad_track``.
* The wiring: batches of designs take the plan kernel's compiled steps with the kernel
  on, the NumPy route with it off; ``solve`` keeps the NumPy step.
"""
from __future__ import annotations

import numpy as np
import pytest

numba = pytest.importorskip("numba")

from hypothesis import given, settings, strategies as st  # noqa: E402

from multiloop.catalogue.named import load_named  # noqa: E402
from multiloop.kin import kernel  # noqa: E402
from tests.common import both_routes, design_population, routes_agree  # noqa: E402
from multiloop.kin.design import solve_designs  # noqa: E402
from multiloop.kin.groups.triad import track_designs, triad_modes  # noqa: E402

NAMES = ["stephenson_3_triad", "stephenson_3"]








@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("rel,span,N", [(0.003, 1.0, 96), (0.15, 1.0, 96), (0.05, 2 * np.pi, 200)])
def test_designs_against_numpy(name, rel, span, N):
    """Near designs on the benchmark's range; far ones (some never assemble, some lose
    their mode); a whole turn (turning points on the way)."""
    m = load_named(name)
    cols, X = design_population(m, 60, rel, 1)
    a, b = both_routes(m, cols, X, np.linspace(0.0, span, N))
    routes_agree(m, a, b)
    assert a.ok.any()
    if rel >= 0.1:
        assert not a.ok.all()


@settings(max_examples=20, deadline=None)
@given(st.sampled_from(NAMES), st.floats(0.0, 0.1), st.floats(0.2, 2 * np.pi), st.integers(20, 130),
       st.integers(0, 10_000))
def test_design_populations_against_numpy(name, rel, span, N, seed):
    m = load_named(name)
    cols, X = design_population(m, 12, rel, seed)
    routes_agree(m, *both_routes(m, cols, X, np.linspace(0.0, span, N)))


def _random_triads(D, N, seed, move):
    """D triads with six real modes at their start (Hunt 1983's example, perturbed),
    pins moving along a random smooth path, lengths varying; started on a random mode."""
    rng = np.random.default_rng(seed)
    A0 = np.array([[0.250191, 0.794428], [0.551371, -0.549586], [-0.399667, 0.747107]])
    b0 = np.array([[0, 0], [-0.989469, 0.642457], [0.594139, -0.06413]])
    l0 = np.array([0.593942, 0.561953, 0.53133])
    A = A0 + 0.02 * rng.standard_normal((D, 1, 3, 2))
    b = b0 + 0.02 * rng.standard_normal((D, 3, 2))
    l = l0 + 0.01 * rng.standard_normal((D, 1, 3))
    t = np.linspace(0.0, 1.0, N)[None, :, None]
    A = A + move * np.sin(t[..., None] * rng.uniform(1, 4, (D, 1, 3, 2)) + rng.uniform(0, 6, (D, 1, 3, 2)))
    L = l + 0.3 * move * np.sin(t * rng.uniform(1, 4, (D, 1, 3)))
    start = np.empty((D, 3, 2))
    for d in range(D):
        mm = triad_modes(A[d, 0], b[d], L[d, 0])
        k = rng.integers(max(int(mm.n_modes), 1))
        start[d] = mm.P[k] if mm.n_modes else b[d]
    return A, b, L, start


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 10_000), st.floats(0.0, 0.3), st.integers(3, 140))
def test_track_designs_against_numpy(seed, move, N):
    A, b, L, start = _random_triads(16, N, seed, move)
    A[3, N // 2, 1, 0] = np.nan                  # a design with a non-finite pin
    P0, th0, s0 = track_designs(A, b, L, start)
    P1, th1, s1 = track_designs(A, b, L, start, jit=True)
    np.testing.assert_array_equal(s0, s1)
    np.testing.assert_array_equal(np.isnan(P0), np.isnan(P1))
    assert np.nanmax(np.abs(P0 - P1), initial=0.0) <= 1e-12
    assert np.nanmax(np.abs(th0 - th1), initial=0.0) <= 1e-12
    assert (s0[3] != 0).any()


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 10_000), st.floats(0.0, 0.3), st.integers(2, 140), st.sampled_from([1, 3, 8, 32]))
def test_the_plan_kernels_tracker_against_numpy(seed, move, N, stride):
    """The plan kernel's whole tracker (``_triad_nb.track_path``, a triad's step in a batch
    of designs) against the NumPy tracker alone (``triad_track``) from the reference
    points or a random mode, the legs varying along the inputs: the same statuses,
    points and angles within 1e-12, on every route of the
    tracker (all modes at every input; coarse inputs with their neighbours accepted or
    refused and refollowed; a lost mode and its tail)."""
    from multiloop.kin.groups import _triad_nb
    from multiloop.kin.groups.triad import triad_track
    A, b, L, start = _random_triads(6, N, seed, move)
    for d in range(len(A)):
        first = b[d] if d % 2 else start[d]          # (the reference's points, or a random mode)
        ref = triad_track(A[d], b[d], L[d], first, stride=stride)
        P, th, status = np.empty((N, 3, 2)), np.empty(N), np.empty(N, np.int64)
        _triad_nb.track_path(np.ascontiguousarray(A[d]), b[d].copy(), np.ascontiguousarray(L[d]), first.copy(), stride,
                             P, th, status)
        np.testing.assert_array_equal(status, ref.status)
        np.testing.assert_array_equal(np.isnan(P), np.isnan(ref.P))
        assert np.nanmax(np.abs(P - ref.P), initial=0.0) <= 1e-12
        assert np.nanmax(np.abs(th - ref.theta), initial=0.0) <= 1e-12


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 10_000), st.booleans())
def test_companion_roots_against_lapack(seed, double):
    """The compiled balanced Hessenberg QR against LAPACK's eigenvalues (numpy): simple
    roots to rounding, a double root (a turning point's) about as well as LAPACK."""
    from multiloop.kin.groups import _triad_nb as nb
    rng = np.random.default_rng(seed)
    K = 50
    roots = rng.standard_normal((K, 6)) * np.exp(rng.uniform(-2, 2, (K, 1)))
    if double:
        roots[:, 1] = roots[:, 0]
    q = np.array([np.poly(r)[::-1] for r in roots]) * rng.uniform(0.5, 2, (K, 1))   # ascending
    comp = np.zeros((K, 6, 6))
    comp[:, 0, :] = -q[:, 5::-1] / q[:, 6:7]
    comp[:, np.arange(1, 6), np.arange(5)] = 1.0
    good = np.ones(K, bool)
    good[0] = False
    re, im = np.empty((K, 6)), np.empty((K, 6))
    nb.companion_roots(comp, good, re, im)
    assert (re[0] == 10.0).all() and (im[0] == 0.0).all()
    ref = np.linalg.eigvals(comp[1:])
    ours = re[1:] + 1j * im[1:]

    def err(z):                                  # the farthest true root from the computed ones
        return np.abs(roots[1:, :, None] - z[:, None, :]).min(axis=2).max(axis=1)

    scale = np.abs(roots[1:]).max(axis=1)
    # close random roots are ill-conditioned (LAPACK's error x 100); a double root's error is
    # the square root of rounding for any QR (LAPACK's is sometimes luckily smaller)
    assert (err(ours) <= 100 * err(ref) + (1e-6 if double else 1e-12) * scale).all()


def test_the_compiled_tracker_is_taken_only_when_wanted(monkeypatch):
    """With the kernel on, ``solve_designs`` solves a triad's and a class IV group's
    designs by the plan kernel's compiled steps (``_triad_nb.triad_place``,
    ``class4_place``: no NumPy step runs), with it off by the NumPy route, whose tracker
    takes no compiled phase; ``solve`` (one design, its kernel routes re-solve a failed row
    alone) keeps the NumPy step, its tracker's phases compiled with the kernel on."""
    from multiloop.kin.groups import class4, triad
    from multiloop.kin.solve import solve
    numpy_steps, phases = [], []
    real_kernel = triad._kernel
    for cls in (triad.TriadStep, class4.Class4Step):
        real = cls._designs
        monkeypatch.setattr(cls, "_designs", lambda self, G, real=real: numpy_steps.append(1) or real(self, G))
    monkeypatch.setattr(triad, "_kernel", lambda: phases.append(1) or real_kernel())
    monkeypatch.setattr(class4, "_kernel", triad._kernel)
    x = np.linspace(0.0, 1.0, 96)
    for name in NAMES:
        m = load_named(name)
        cols, X = design_population(m, 4, 0.003, 0)
        numpy_steps.clear()
        phases.clear()
        with kernel.using("off"):
            solve_designs(m, cols, X, x)
        assert numpy_steps and not phases
        numpy_steps.clear()
        with kernel.using("on"):
            solve_designs(m, cols, X, x)
            assert not numpy_steps and not phases
            solve(m, x)
        assert phases


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 10_000), st.floats(0.0, 0.3), st.integers(3, 140), st.booleans())
def test_designs_near_the_first_are_polished_from_it(seed, move, N, jit):
    """Designs within 1e-9 of the first (a finite-difference Jacobian's rows) are
    Newton-polished from the first design's poses, input by input, and kept only well
    inside its mode: the same statuses as each design tracked alone, poses within 1e-10
    (turning points, lost modes and a far design among them)."""
    A, b, L, start = _random_triads(1, N, seed, move)
    rng = np.random.default_rng(seed)
    k = 6
    A = np.repeat(A, k, axis=0) + 1e-9 * rng.standard_normal((k, 1, 3, 2))
    b = np.repeat(b, k, axis=0) + 1e-9 * rng.standard_normal((k, 3, 2))
    L = np.repeat(L, k, axis=0)
    start = np.repeat(start, k, axis=0)
    A[0] -= 1e-9 * rng.standard_normal((3, 2))   # (the first one is tracked as it is)
    A[-1] += 0.01                               # one far design: tracked
    P, th, s = track_designs(A, b, L, start, jit=jit)
    for d in range(k):
        Pd, thd, sd = track_designs(A[d:d + 1], b[d:d + 1], L[d:d + 1], start[d:d + 1], jit=jit)
        np.testing.assert_array_equal(s[d], sd[0])
        assert np.nanmax(np.abs(P[d] - Pd[0]), initial=0.0) <= 1e-10
        assert np.nanmax(np.abs(th[d] - thd[0]), initial=0.0) <= 1e-10


def test_near_designs_skip_the_tracker(monkeypatch):
    """The rows of a Jacobian of the Stephenson III triad over a whole turn's grid: only
    the first and a far row go through the tracker, the near rows agree with it."""
    import multiloop.kin.groups.triad as triad
    m = load_named("stephenson_3_triad")
    cols, X = design_population(m, 1, 0.0, 1)
    h = 1e-7 * m.size * np.eye(len(cols))
    far = X[0] + 0.01 * m.size * np.random.default_rng(0).standard_normal(len(cols))
    X = np.vstack([X, X[0] + h, far])
    tracked = []
    real = triad._track_all
    monkeypatch.setattr(triad, "_track_all", lambda A, *a: tracked.append(A.shape[0]) or real(A, *a))
    x = np.linspace(0.0, 1.0, 96)
    r = solve_designs(m, cols, X, x)
    assert tracked == [2]
    monkeypatch.setattr(triad, "_track_all", real)
    for d in range(X.shape[0]):
        alone = solve_designs(m, cols, X[d:d + 1], x)
        np.testing.assert_array_equal(alone.ok[0], r.ok[d])
        assert np.nanmax(np.abs(alone.point("P")[0] - r.point("P")[d]), initial=0.0) <= 1e-10 * m.size
    assert r.ok.all()


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 10_000), st.floats(0.1, 0.6), st.integers(70, 140), st.booleans())
def test_lost_designs_are_tracked_together_as_alone(seed, move, N, jit):
    """Designs whose mode is lost (or that do not assemble) on the way, tracked together
    by ``track_designs`` (``_track_partial``: their prefix filled from the coarse
    inputs, the tail followed in chunks), give what the single-design tracker
    (``_track``) gives each of them: the same statuses, NaNs and poses (to rounding;
    bit for bit on the compiled route)."""
    from multiloop.kin.groups import triad
    A, b, L, start = _random_triads(24, N, seed, move)
    P, th, s = track_designs(A, b, L, start, jit=jit)
    nb = triad._kernel() if jit else None
    for d in range(24):
        P1, th1, s1 = triad._track(A[d], b[d], L[d], start[d], 32, nb)
        np.testing.assert_array_equal(s[d], s1)
        np.testing.assert_array_equal(np.isnan(P[d]), np.isnan(P1))
        assert np.nanmax(np.abs(P[d] - P1), initial=0.0) <= (0.0 if jit else 1e-12)
        assert np.nanmax(np.abs(th[d] - th1), initial=0.0) <= (0.0 if jit else 1e-12)


def test_lost_designs_take_the_batched_route(monkeypatch):
    """The case the test above is about occurs: of 120 random triads moved far (five
    seeds), most lose their mode on the way and nearly all of those are tracked by
    ``_track_partial``, not one by one."""
    from multiloop.kin.groups import triad
    seen = {"partial": 0, "done": 0}
    real = triad._track_partial

    def counted(A, *a):
        out = real(A, *a)
        seen["partial"] += A.shape[0]
        seen["done"] += int(out[0].sum())
        return out
    monkeypatch.setattr(triad, "_track_partial", counted)
    for seed in range(5):
        track_designs(*_random_triads(24, 100, seed, 0.4), jit=True)
    assert seen["partial"] >= 60 and seen["done"] >= 0.9 * seen["partial"]


@pytest.mark.parametrize("name", NAMES)
def test_no_input_gives_an_empty_batch(name):
    """Designs at no input: an empty batch by both routes (the compiled step once wrote
    past its arrays, the NumPy tracker raised an IndexError)."""
    m = load_named(name)
    cols, X = design_population(m, 3, 0.003, 0)
    for mode in ("off", "on"):
        with kernel.using(mode):
            st = solve_designs(m, cols, X, np.zeros(0))
        assert st.ok.shape == (3, 0)
