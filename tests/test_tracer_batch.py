"""A tracer point of a few designs straight from the design matrix by the compiled kernels
(kin.tracer_batch) against the pose store's route (solve_designs and pose_sensitivity) to
the bit, its derivatives against central differences, the plans it refuses, and the
polish's residuals and Jacobian by both routes."""
from __future__ import annotations

import numpy as np
import pytest

from multiloop.catalogue.dimensional.objective import Problem
from multiloop.catalogue.named import load_named
from multiloop.kin import kernel
from multiloop.kin.design import solve_designs
from multiloop.kin.sensitivity import pose_sensitivity
from multiloop.kin.tracer_batch import TracerBatch

from test_design_batch import DYAD_MECHANISMS, _designs

pytestmark = pytest.mark.skipif(not kernel.compiled_batches(),
                                reason="design batches do not run compiled (no numba, or MULTILOOP_KERNEL=off)")


def _case(name, D=3, N=12, seed=2, span=None):
    m = load_named(name)
    names, X = _designs(m, D=D, rel=0.01, seed=seed)
    rng = np.random.default_rng(seed)
    rotary = m.is_rotary(0)
    span = span or (np.pi if rotary else 0.3 * m.size)
    PHI = np.sort(rng.uniform(-span, span, (D, N)), axis=1)
    return m, names, X, PHI


@pytest.mark.parametrize("name", [*DYAD_MECHANISMS, "stephenson_3_triad", "stephenson_3"])
def test_the_point_and_its_derivatives_are_the_pose_stores_to_the_bit(name):
    m, names, X, PHI = _case(name)
    pts = [p.name for p in m.points] or [next(j.name for j in m.joints[::-1] if m.frame not in j.links)]
    with kernel.for_batches():
        st = solve_designs(m, names, X, PHI)
        sens = pose_sensitivity(st)
    for pt in pts:
        tb = TracerBatch.of(m, names, pt)
        assert tb is not None
        W, dW = tb.solve(X, PHI, jacobian=True)
        assert np.array_equal(W, st.point(pt), equal_nan=True)
        assert np.array_equal(dW, sens.point(pt), equal_nan=True)
        assert np.array_equal(tb.solve(X, PHI)[0], W, equal_nan=True) and tb.solve(X, PHI)[1] is None


@pytest.mark.parametrize("name", ["watt_1", "stephenson_3_triad", "stephenson_3"])
def test_the_derivatives_are_central_differences_of_the_point(name):
    m, names, X, PHI = _case(name, D=2, N=6, span=0.5)       # (every input assembles: the triad's too)
    tb = TracerBatch.of(m, names, m.points[0].name)
    W, dW = tb.solve(X, PHI, jacobian=True)
    assert np.all(np.isfinite(W))
    h = 1e-6 * m.size
    for c in range(len(names) + 1):
        Xp, Xm, Pp, Pm = X.copy(), X.copy(), PHI.copy(), PHI.copy()
        if c < len(names):
            Xp[:, c] += h
            Xm[:, c] -= h
            step = h
        else:
            Pp += 1e-6
            Pm -= 1e-6
            step = 1e-6
        fd = (tb.solve(Xp, Pp)[0] - tb.solve(Xm, Pm)[0]) / (2 * step)
        assert np.allclose(dW[..., c], fd, atol=1e-6 * max(1.0, np.abs(fd).max())), names[c] if c < len(names) else "input"


def test_plans_without_a_compiled_route_and_frame_points_are_refused():
    two = load_named("excavator")
    names, _ = _designs(two, D=2)
    pt = two.points[0].name if two.points else two.joints[-1].name
    assert TracerBatch.of(two, names, pt) is None                          # (two drivers)
    m = load_named("four_bar")
    names, _ = _designs(m, D=2)
    ground = next(j.name for j in m.joints if m.frame in j.links)
    assert TracerBatch.of(m, names, ground) is None                         # (on the frame: nothing to solve)


def test_a_kind_without_a_batched_form_has_no_tracer_batch(monkeypatch):
    """A kind that declares no batched form is solved design by design by ``solve_designs``;
    the tracer batch refuses it too (it had served the class IV group's compiled step, so
    the slow path's synthesis test ran its search on the kernel for 80 s: its simulated
    clock, advanced by each design solved, stood still)."""
    from multiloop.kin.groups.class4 import Class4Step
    m = load_named("stephenson_3")
    names, _ = _designs(m, D=2)
    pt = m.points[0].name
    assert TracerBatch.of(m, names, pt) is not None
    monkeypatch.setattr(Class4Step, "batched", False)
    assert TracerBatch.of(m, names, pt) is None


@pytest.mark.parametrize("name,span", [("four_bar", (0.2, 2.0)), ("stephenson_3_triad", (0.1, 1.0))])
def test_the_polish_residuals_and_jacobian_are_the_same_by_both_routes(name, span, monkeypatch):
    """The polish's residuals and Jacobian by the tracer batch and by the pose store, bit
    for bit; a path-dependent plan (the triad's followed mode) solved along the walk from
    the reference to its targets by both (its population keeps the pose store: the
    grid's two paths)."""
    from multiloop.catalogue.dimensional.evaluator import Evaluator, design_space
    from multiloop.catalogue.dimensional.targets import PathTarget
    from multiloop.kin.solve import solve
    m = load_named(name)
    pt = m.points[0].name
    x = np.linspace(*span, 8)
    st = solve(m, x)
    T = st.point_positions[:, st.point_index(pt)] * 1.01
    pr = Problem(Evaluator(m, design_space(m, [pt])), PathTarget(T, pt))
    assert pr._tracer(walked=True) is not None and (pr._tracer() is None) == pr.ev.path_dependent
    rng = np.random.default_rng(0)
    Z = pr.x0[None] + 1e-3 * m.size * rng.standard_normal((3, len(pr.x0)))
    PHI = x[None] + 0.01 * rng.standard_normal((3, len(x)))
    fast = pr.residuals_batch(Z, PHI), pr.jacobian_batch(Z, PHI)
    monkeypatch.setattr(Problem, "_tracer", lambda self, walked=False: None)
    store = pr.residuals_batch(Z, PHI), pr.jacobian_batch(Z, PHI)
    assert np.isfinite(fast[0]).all()
    assert np.array_equal(fast[0], store[0], equal_nan=True)
    for a, b in zip(fast[1], store[1]):
        assert np.array_equal(a, b, equal_nan=True)


@pytest.mark.parametrize("name", ["four_bar", "crank_slider", "watt_1"])
def test_the_curve_on_shared_inputs_is_the_pose_stores_with_its_statuses(name):
    m = load_named(name)
    names, X = _designs(m, D=6, rel=0.15, seed=2)             # (some cells out of reach: four_bar, watt_1)
    phi = np.linspace(-np.pi, np.pi, 40) if m.is_rotary(0) else np.linspace(-0.5, 0.5, 40) * m.size
    pt = m.points[0].name if m.points else next(j.name for j in m.joints[::-1] if m.frame not in j.links)
    with kernel.for_batches():
        st = solve_designs(m, names, X, phi)
    W, ok = TracerBatch.of(m, names, pt).curve(X, phi)
    assert np.array_equal(W, st.point(pt), equal_nan=True) and np.array_equal(ok, st.ok)
    assert ok.all() == (name == "crank_slider")


@pytest.mark.parametrize("cons", [{}, {"full_rotation": True}, {"shape_only": True}], ids=["free", "rotation", "shape"])
def test_the_population_objective_is_the_same_by_both_routes(cons, monkeypatch):
    """Free timing's population objective on the tracer's curve (no pose store) equals
    the pose store's, bit for bit, with and without a full rotation's violation."""
    from multiloop.catalogue.dimensional.evaluator import Evaluator, design_space
    from multiloop.catalogue.dimensional.objective import Constraints
    from multiloop.catalogue.dimensional.synthesise import path_target
    from multiloop.kin.solve import solve
    m = load_named("four_bar")
    T = solve(m, np.radians(np.arange(7.0, 360.0, 33.0))).point_positions[:, 0]
    shape = cons.pop("shape_only", False)
    pr = Problem(Evaluator(m, design_space(m, ["P"], region=T)), path_target(m, T, "P", shape_only=shape),
                 Constraints(**cons), 96)
    pr.init_shape()
    rng = np.random.default_rng(5)
    Z = pr.x0 + 0.08 * (pr.upper - pr.lower) * rng.uniform(-1, 1, (60, len(pr.x0)))
    assert pr._tracer() is not None
    fast = pr.batch(Z)
    monkeypatch.setattr(Problem, "_tracer", lambda self, walked=False: None)
    slow = pr.batch(Z)
    assert np.array_equal(fast, slow) and np.isfinite(fast).sum() > 10


def test_read_only_designs_and_inputs_use_the_one_compiled_signature():
    """Read-only arrays (numba types them apart) are copied, not compiled for again."""
    from multiloop.kin import tracer_batch
    m, names, X, PHI = _case("four_bar", D=2, N=5)
    tb = TracerBatch.of(m, names, "P")
    W0 = tb.solve(X, PHI)[0]
    n = len(tracer_batch._tracer_kernel().tracer_point.signatures)
    X.flags.writeable = PHI.flags.writeable = False
    assert np.array_equal(tb.solve(X, PHI)[0], W0) and np.array_equal(tb.curve(X, PHI[0])[0], tb.curve(X.copy(), PHI[0])[0])
    assert len(tracer_batch._tracer_kernel().tracer_point.signatures) == n
