"""The batched polish (``optimise.polish_batch``): SciPy's trust region for several
designs at once, checked against SciPy itself — its subproblem solver step for step, the
whole polish design by design — and the probes' choice of distinct good designs."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize._lsq.common import solve_lsq_trust_region

from multiloop.catalogue.dimensional import Evaluator, Problem, design_space, path_target
from multiloop.catalogue.dimensional import optimise
from multiloop.catalogue.dimensional.budget import Budget, Meter
from multiloop.catalogue.dimensional.objective import Constraints
from multiloop.catalogue.named import load_named
from multiloop.kin.solve import solve


def _four_bar_problem(**cons):
    """Ten points of the catalogue four-bar's coupler curve (free timing), from a start
    with its joints moved by 3 % of its size."""
    m = load_named("four_bar")
    P = solve(m, np.radians(np.arange(7.0, 360.0, 33.0))).point_positions[:, 0]
    rng = np.random.default_rng(4)
    js = [replace(j, at=tuple(np.asarray(j.at) + rng.normal(0.0, 0.03 * 0.3, 2))) for j in m.joints]
    start = replace(m, joints=tuple(js))
    return Problem(Evaluator(start, design_space(start, ["P"], region=P)), path_target(start, P, "P"),
                   Constraints(**cons), 96)


def _starts(pr, K, spread, seed=0):
    rng = np.random.default_rng(seed)
    Z = np.clip(pr.x0 + spread * (pr.upper - pr.lower) * rng.uniform(-1, 1, (K, len(pr.x0))), pr.lower, pr.upper)
    return Z, np.array([pr.match(z) for z in Z])


def _rms(pr, z, phi):
    return float(np.sqrt(np.mean(optimise._residuals(pr, z[None], phi[None]) ** 2)))


# ---------------------------------------------------------------------------------
# the subproblem: SciPy's solve_lsq_trust_region, for K problems at once

@settings(max_examples=60, deadline=None)
@given(m=st.integers(2, 9), n=st.integers(2, 9), rank=st.integers(1, 9), seed=st.integers(0, 2 ** 31),
       radius=st.floats(1e-4, 1e2), alpha0=st.sampled_from([0.0, 0.3, 5.0]))
def test_the_steps_are_scipys(m, n, rank, seed, radius, alpha0):
    """Each of the K steps (and its Levenberg–Marquardt parameter) is what SciPy's
    ``solve_lsq_trust_region`` returns for that problem alone, full rank or not,
    more residuals than variables or fewer, inside the radius or on it."""
    rng = np.random.default_rng(seed)
    K = 3
    J = rng.normal(size=(K, m, min(rank, m, n))) @ rng.normal(size=(K, min(rank, m, n), n))
    R = rng.normal(size=(K, m))
    svd = optimise._svd(J, False)
    compiled = lambda svd, R, r, a: optimise._tr_propose(svd, R, J, r, a)[:2]     # noqa: E731 (with numba)
    for route in (optimise._tr_steps, compiled):
        h, alpha = route(svd, R, np.full(K, radius), np.full(K, alpha0))
        for k in range(K):
            W, s, Vt = np.linalg.svd(J[k], full_matrices=False)
            ref, ref_alpha, _ = solve_lsq_trust_region(n, m, W.T @ R[k], s, Vt.T, radius, initial_alpha=alpha0)
            assert np.allclose(h[k], ref, rtol=1e-9, atol=1e-12 * max(1.0, radius)), (h[k], ref)
            assert np.isclose(alpha[k], ref_alpha, rtol=1e-9, atol=1e-14)


@pytest.mark.skipif(optimise.compiled_module("_trust_nb") is None, reason="populations do not run compiled (no numba, or off)")
@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2 ** 31), K=st.integers(1, 6), n=st.integers(1, 8))
def test_the_compiled_proposal_and_verdict_are_numpys(seed, K, n):
    """The predicted reductions and SciPy ``trf``'s verdicts (radius, parameter, stop)
    compiled against the NumPy route: ratios below 0.25, above 0.75 on the boundary and
    between, no gain, zero and negative predictions, a non-finite residual."""
    from unittest import mock
    rng = np.random.default_rng(seed)
    m = n + 2
    J, R, h = rng.normal(size=(K, m, n)), rng.normal(size=(K, m)), rng.normal(size=(K, n))
    svd = optimise._svd(J, False)
    radius = np.abs(rng.normal(size=K)) + 0.1
    alpha = np.abs(rng.normal(size=K))
    F = np.abs(rng.normal(size=K)) + 1.0
    pred = rng.choice([-1.0, 0.0, 1e-3, 0.5, 2.0], size=K)
    Fn = F - pred * rng.choice([0.0, 0.1, 0.5, 0.9, 1.0, 1.5], size=K)
    Fn[rng.random(K) < 0.15] = np.nan
    h *= (radius * rng.choice([0.5, 0.96, 1.0], size=K) / np.linalg.norm(h, axis=1))[:, None]
    U = rng.normal(size=(K, n))
    fast = optimise._tr_propose(svd, R, J, radius, alpha), optimise._tr_accept(F, Fn, pred, h, U, radius, alpha)
    with mock.patch.object(optimise, "compiled_module", lambda name: None):
        slow = optimise._tr_propose(svd, R, J, radius, alpha), optimise._tr_accept(F, Fn, pred, h, U, radius, alpha)
    for a, b in zip(fast[0], slow[0]):
        assert np.allclose(a, b, rtol=1e-12, atol=1e-14)
    (r1, a1, d1), (r2, a2, d2) = fast[1], slow[1]
    assert np.array_equal(d1, d2)                     # (the norms' sums in another order: rounding)
    assert np.allclose(r1, r2, rtol=1e-14, atol=0) and np.allclose(a1, a2, rtol=1e-14, atol=0)


def test_a_floored_step_is_the_step_of_the_floored_jacobian():
    """With ``floor`` the step is SciPy's on the Jacobian whose singular values are raised
    to SINGULAR_FLOOR of the largest (``optimise._floored``, the exact Jacobian's)."""
    rng = np.random.default_rng(7)
    J = rng.normal(size=(1, 8, 3)) @ rng.normal(size=(1, 3, 12))       # rank 3 of 8 × 12
    R = rng.normal(size=(1, 8))
    h, _ = optimise._tr_steps(optimise._svd(J, True), R, np.array([0.5]), np.zeros(1))
    W, s, Vt = np.linalg.svd(optimise._floored(J[0]), full_matrices=False)
    ref, _, _ = solve_lsq_trust_region(12, 8, W.T @ R[0], s, Vt.T, 0.5, initial_alpha=0.0)
    assert np.allclose(h[0], ref, rtol=1e-6, atol=1e-10)      # (the floored J rebuilt: rounding)


# ---------------------------------------------------------------------------------
# the polish: polish_batch of K designs against SciPy's least_squares design by design

@pytest.mark.parametrize("cons", [{}, {"max_ratio": 3.0}], ids=["exact-jacobian", "differenced"])
def test_the_batch_polishes_each_design_as_scipy_does(cons):
    """Near an exact solution (1e-3 of the box) every design of the batch reaches the
    same residual as :func:`optimise.polish` (SciPy's ``trf``) of it alone, at rounding,
    with the exact Jacobian and with forward differences (a constraint's penalty row)."""
    pr = _four_bar_problem(**cons)
    exact = pr.match(pr.x0)
    z_true = optimise.polish(pr, pr.x0, exact, max_nfev=300)[0]
    Z, PHI = _starts(replace_x0(pr, z_true), 3, 1e-3)
    Zb, Pb, n = optimise.polish_batch(pr, Z, PHI, max_nfev=150)
    for k in range(3):
        z1, p1, n1 = optimise.polish(pr, Z[k], PHI[k], max_nfev=150)
        assert _rms(pr, Zb[k], Pb[k]) <= max(1e-12, 1.01 * _rms(pr, z1, p1)), (k, _rms(pr, Zb[k], Pb[k]), _rms(pr, z1, p1))
    assert n > 0


def replace_x0(pr, z):
    pr.x0 = np.asarray(z, float).copy()
    return pr


def test_far_starts_follow_scipys_path():
    """From starts 3 % of the box away (local minima, no exact solution nearby) a
    batch of four ends where SciPy's polish of each ends: the same algorithm, step for
    step (the residuals agree to 1e-6 relative)."""
    pr = _four_bar_problem()
    Z, PHI = _starts(pr, 4, 0.03, seed=1)
    Zb, Pb, _ = optimise.polish_batch(pr, Z, PHI, max_nfev=60)
    for k in range(4):
        z1, p1, _ = optimise.polish(pr, Z[k], PHI[k], max_nfev=60)
        assert np.isclose(_rms(pr, Zb[k], Pb[k]), _rms(pr, z1, p1), rtol=1e-6, atol=1e-13)


def test_a_design_polishes_alike_alone_or_in_a_batch():
    """The batch's company does not change a design's polish (each design's numbers are
    its own; the compiled plan solves the designs independently)."""
    pr = _four_bar_problem()
    Z, PHI = _starts(pr, 3, 0.02, seed=2)
    Zb, Pb, _ = optimise.polish_batch(pr, Z, PHI, max_nfev=40)
    Z1, P1, _ = optimise.polish_batch(pr, Z[1:], PHI[1:], max_nfev=40)          # (other company)
    assert np.allclose(Zb[1], Z1[0], rtol=0, atol=1e-12) and np.allclose(Pb[1], P1[0], rtol=0, atol=1e-12)


def test_one_design_follows_scipys_path_and_polishes_as_in_a_batch():
    """A batch of one runs the batch's iteration (SciPy's ``trf``, each step one compiled
    call): it ends where :func:`optimise.polish` (SciPy's ``least_squares``) ends, and
    where the same design ends in the company of others."""
    pr = _four_bar_problem()
    Z, PHI = _starts(pr, 3, 0.02, seed=6)
    Zb, Pb, n = optimise.polish_batch(pr, Z[:1], PHI[:1], max_nfev=40)
    z1, p1, n1 = optimise.polish(pr, Z[0], PHI[0], max_nfev=40)
    assert np.isclose(_rms(pr, Zb[0], Pb[0]), _rms(pr, z1, p1), rtol=1e-6, atol=1e-13) and n > 0
    Zk, Pk, _ = optimise.polish_batch(pr, Z, PHI, max_nfev=40)
    assert np.allclose(Zb[0], Zk[0], rtol=0, atol=1e-12) and np.allclose(Pb[0], Pk[0], rtol=0, atol=1e-12)


def test_an_evaluation_budget_bounds_the_batch_and_repeats_exactly():
    """Charged to a meter of N evaluations, the batch spends at most N, keeps every
    design in its box and no worse than its start, and gives the same numbers twice."""
    pr = _four_bar_problem()
    Z, PHI = _starts(pr, 4, 0.03, seed=3)
    out = []
    for _ in range(2):
        meter = Meter.start(Budget.of(700))
        Zb, Pb, n = optimise.polish_batch(pr, Z, PHI, max_nfev=500, meter=meter)
        assert n <= 700 and meter.used <= 700
        out.append((Zb, Pb))
    assert np.array_equal(out[0][0], out[1][0]) and np.array_equal(out[0][1], out[1][1])
    for k in range(4):
        assert np.all((out[0][0][k] >= pr.lower) & (out[0][0][k] <= pr.upper))
        assert _rms(pr, out[0][0][k], out[0][1][k]) <= _rms(pr, Z[k], PHI[k])


def test_a_design_that_leaves_the_box_is_polished_within_it():
    """Bounds that cut off the exact design: the unbounded iteration leaves the box and
    the design is polished again within it (SciPy's bounded ``trf``), ending inside
    the box and better than its start."""
    pr = _four_bar_problem()
    exact = optimise.polish(pr, pr.x0, pr.match(pr.x0), max_nfev=300)[0]
    i = pr.names.index("O4.x")
    pr.upper = pr.upper.copy()
    pr.upper[i] = exact[i] - 0.01                       # the exact O4 just outside
    Z, PHI = _starts(replace_x0(pr, np.minimum(exact, pr.upper)), 2, 1e-3, seed=5)
    Zb, Pb, _ = optimise.polish_batch(pr, Z, PHI, max_nfev=100)
    for k in range(2):
        assert np.all((Zb[k] >= pr.lower) & (Zb[k] <= pr.upper))
        assert _rms(pr, Zb[k], Pb[k]) < _rms(pr, Z[k], PHI[k])


# ---------------------------------------------------------------------------------
# the probes' choice: the best designs that differ pairwise by more than the gap

def _greedy(F, A, k, gap):
    keep = []
    for i in np.argsort(F, kind="stable"):
        if not np.isfinite(F[i]):
            break
        if all(np.max(np.abs(A[i] - A[j])) > gap for j in keep):
            keep.append(int(i))
            if len(keep) == k:
                break
    return keep


@settings(max_examples=80, deadline=None)
@given(n=st.integers(0, 40), seed=st.integers(0, 2 ** 31), k=st.integers(1, 6))
def test_the_elite_is_the_greedy_choice(n, seed, k):
    """The kept designs are those of the greedy walk in order of objective (each kept
    when it differs from every kept one by more than the gap), NaN and inf left out."""
    rng = np.random.default_rng(seed)
    U = rng.choice([0.0, 0.02, 0.04, 0.5, 1.0], size=(n, 3))
    f = rng.choice([0.1, 0.2, 0.3, np.inf, np.nan], size=n)
    c = optimise._Counter.__new__(optimise._Counter)
    c.elite_f, c.elite_u = np.empty(0), np.empty((0, 3))
    c._keep(U, f, k=k)
    ref = _greedy(f, U, k, 0.05)
    assert np.array_equal(c.elite_u, U[ref]) and np.array_equal(c.elite_f, f[ref])


@given(st.integers(1, 6), st.integers(0, 25), st.integers(0, 2**31))
@settings(max_examples=40, deadline=None)
def test_row_norms_are_numpys_bit_for_bit(k, n, seed):
    """The trust region's row norms are ``np.linalg.norm(x, axis=1)``'s, bit for bit."""
    from multiloop.catalogue.dimensional.optimise import _norms
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((k, n)) * 10.0 ** rng.uniform(-150, 150, (k, n))
    np.testing.assert_array_equal(_norms(x), np.linalg.norm(x, axis=1))


# ---------------------------------------------------------------------------------
# the compiled iteration (a path target's tracer, free timing, no constraint)

def _routes(pr, Z, PHI, monkeypatch, budget=None, **kw):
    """``polish_batch`` on the compiled iteration, then on the NumPy one (each with a
    fresh meter of ``budget`` evaluations): ``[(Z, PHI, n, meter), ...]``."""
    if optimise._CompiledRegions.route(pr) is None:
        pytest.skip("no compiled route (numba absent)")
    out = []
    for compiled in (True, False):
        meter = None if budget is None else Meter.start(Budget.of(budget))
        with monkeypatch.context() as mp:
            if not compiled:
                mp.setattr(optimise._CompiledRegions, "route", staticmethod(lambda problem: None))
            out.append(optimise.polish_batch(pr, Z, PHI, meter=meter, **kw) + (meter,))
    return out


@pytest.mark.parametrize("spread,seed", [(0.002, 0), (0.02, 1), (0.03, 2)])
def test_the_compiled_iteration_is_the_numpy_iteration(spread, seed, monkeypatch):
    """The same steps, charges and end as :class:`optimise._TrustRegions` (its SVD from
    numba's LAPACK binding: rounding apart), near an exact design and far from it."""
    pr = _four_bar_problem()
    Z, PHI = _starts(pr, 3, spread, seed=seed)
    (Zc, Pc, nc, _), (Zn, Pn, nn, _) = _routes(pr, Z, PHI, monkeypatch, max_nfev=60)
    assert nc == nn > 0
    for k in range(3):
        assert np.isclose(_rms(pr, Zc[k], Pc[k]), _rms(pr, Zn[k], Pn[k]), rtol=1e-6, atol=1e-13)
        assert np.allclose(Zc[k], Zn[k], rtol=0, atol=1e-6) and np.allclose(Pc[k], Pn[k], rtol=0, atol=1e-6)


@pytest.mark.parametrize("budget", [5, 40, 700])
def test_the_compiled_iteration_spends_the_meter_as_the_numpy_one(budget, monkeypatch):
    """Charged to a meter of N evaluations (too few for the first Jacobians, a few rounds,
    many): the same evaluations on both routes, at most N, the same designs, and a refused
    charge is the meter's ``evaluations`` stop."""
    pr = _four_bar_problem()
    Z, PHI = _starts(pr, 2, 0.03, seed=3)
    (Zc, Pc, nc, mc), (Zn, Pn, nn, mn) = _routes(pr, Z, PHI, monkeypatch, budget=budget, max_nfev=500)
    assert nc == nn == mc.used == mn.used <= budget
    assert mc.stop() == mn.stop() and (mc.stop() == "evaluations") == mn.refused
    assert np.allclose(Zc, Zn, rtol=0, atol=1e-6) and np.allclose(Pc, Pn, rtol=0, atol=1e-6)


def test_the_compiled_route_is_taken_only_where_it_applies():
    """A path target with free timing and no constraint has it; a constraint (its penalty
    row), prescribed timing or a shape-only target keep the NumPy iteration."""
    if not optimise.compiled_module("_polish_nb"):
        pytest.skip("numba absent")
    assert optimise._CompiledRegions.route(_four_bar_problem()) is not None
    assert optimise._CompiledRegions.route(_four_bar_problem(full_rotation=True)) is None
    m = load_named("four_bar")
    T = solve(m, np.radians([0.0, 40.0, 80.0, 120.0])).point_positions[:, 0]
    timed = path_target(m, np.column_stack([T, [0.0, 40.0, 80.0, 120.0]]), "P")
    shape = path_target(m, T, "P", shape_only=True)
    for tgt in (timed, shape):
        pr = Problem(Evaluator(m, design_space(m, ["P"], region=T)), tgt, Constraints(), 96)
        assert optimise._CompiledRegions.route(pr) is None
