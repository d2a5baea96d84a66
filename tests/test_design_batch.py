"""One solver for many designs (kin.design): the batch over designs against solve, design
by design, to the bit; outputs; bad input; and synthesis on the same solver."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from multiloop.catalogue.dimensional import Evaluator, design_space
from multiloop.catalogue.named import load_named
from multiloop.kin import kernel
from multiloop.kin.design import branch_signs, design_mechanism, solve_designs, unbatched_steps
from multiloop.kin.geometry import design_names
from multiloop.kin.solve import plan_of, solve
from multiloop.topo.errors import InputError
from multiloop.topo.model import JointKind

#: one-driver mechanisms whose plans are all dyads (every dyad kind, the actuator)
DYAD_MECHANISMS = ["four_bar", "crank_slider", "stephenson_2", "watt_1", "dyad_rpr", "dyad_rrp", "dyad_prp",
                   "dyad_rpp", "linkage_24", "knitting_needle_drive"]


def _designs(m, D=40, rel=0.01, seed=1):
    """The start's design vector and D − 1 random neighbours (row 0 = the start)."""
    names = design_names(m, [p.name for p in m.points])
    space = design_space(m, [p.name for p in m.points])
    assert space.names == names
    size = float(np.ptp(np.array([j.at for j in m.joints]), axis=0).max())
    rng = np.random.default_rng(seed)
    X = space.x0 + rel * size * rng.standard_normal((D, len(names)))
    X[0] = space.x0
    return names, X


def _inputs(m, n=16):
    j = m.joint(m.drivers[0].joint)
    return np.radians(np.linspace(0.0, 40.0, n)) if j.kind is JointKind.R else np.linspace(0.0, 0.05, n)


@pytest.mark.parametrize("name", DYAD_MECHANISMS)
def test_batch_equals_solve_to_the_bit(name):
    """Each design of a batch gives the same bits as solve of that design alone (its NumPy
    path: the compiled plan agrees to rounding, tests/test_kernels.py), at every position
    where both assemble, and fails exactly where solve fails."""
    m = load_named(name)
    names, X = _designs(m, D=8 if m.n_links > 8 else 40)     # (solve of each design: the slow side)
    x = _inputs(m)
    r = solve_designs(m, names, X, x)
    assert not unbatched_steps(m)
    compared = 0
    for d in range(X.shape[0]):
        md = design_mechanism(r.geometry, d)
        try:
            with kernel.using("off"):
                st = solve(md, x)
        except Exception:                       # noqa: BLE001 - a design that does not compile
            assert not r.ok[d].any()
            continue
        ok = np.asarray(st.status == "ok")
        if ok.all():                            # solve stayed on the reference branch everywhere
            np.testing.assert_array_equal(r.ok[d], ok)
        both = ok & r.ok[d]
        for i, j in enumerate(m.joint_names):
            np.testing.assert_array_equal(r.point(j)[d][both], st.positions[both, i])
        for i, p in enumerate(m.points):
            np.testing.assert_array_equal(r.point(p.name)[d][both], st.point_positions[both, i])
        compared += int(both.sum())
    assert compared > 0.25 * X.shape[0] * len(x)


@pytest.mark.parametrize("name", ["stephenson_3_triad", "stephenson_3"])
def test_triad_and_class_iv_designs_follow_solve(name):
    """Plans with a triad or a class IV group agree with solve to rounding (solve reaches
    the inputs along its own sampled path), and a design's result does not depend on the
    batch it is in, to the bit."""
    m = load_named(name)
    names, X = _designs(m, D=6, rel=0.005)
    x = np.radians(np.linspace(0.0, 30.0, 80))
    r = solve_designs(m, names, X, x)
    assert not unbatched_steps(m)
    for d in range(X.shape[0]):
        st = solve(design_mechanism(r.geometry, d), x)
        ok = np.asarray(st.status == "ok") & r.ok[d]
        assert ok.sum() > 60
        alone = solve_designs(m, names, X[d:d + 1], x)
        np.testing.assert_array_equal(alone.ok[0], r.ok[d])
        for i, j in enumerate(m.joint_names):
            np.testing.assert_allclose(r.point(j)[d][ok], st.positions[ok, i], atol=1e-12)
            np.testing.assert_array_equal(alone.point(j)[0], r.point(j)[d])


def test_outputs_solve_only_the_steps_they_need():
    """outputs=: the links upstream of the named point are solved, the others stay NaN;
    the point is the same as in the full solve."""
    m = load_named("four_bar")
    names, X = _designs(m, D=8)
    x = _inputs(m)
    full = solve_designs(m, names, X, x)
    p = "A"                                     # on the crank: the driver step only
    part = solve_designs(m, names, X, x, outputs=[p])
    np.testing.assert_array_equal(part.point(p), full.point(p))
    assert np.isnan(part.th).any() and not np.isnan(full.th[:, full.ok]).any()


def test_per_design_inputs_and_shapes():
    """Inputs (D, N) per design give (D, N) results; each row equals that design's call."""
    m = load_named("four_bar")
    names, X = _designs(m, D=5)
    x = np.stack([_inputs(m) + 0.01 * d for d in range(5)])
    r = solve_designs(m, names, X, x)
    assert r.ok.shape == (5, 16) and r.point("B").shape == (5, 16, 2)
    for d in range(5):
        np.testing.assert_array_equal(solve_designs(m, names, X[d:d + 1], x[d]).point("B")[0], r.point("B")[d])


def test_bad_shapes_are_named():
    m = load_named("four_bar")
    names, X = _designs(m, D=3)
    with pytest.raises(InputError, match="designs"):
        solve_designs(m, names, X[:, :-1], _inputs(m))
    with pytest.raises(InputError, match="inputs"):
        solve_designs(m, names, X, np.full(4, np.nan))


def test_branch_signs_are_the_solvers():
    """The evaluator's branches are the signs the steps use; a mirrored design flips them."""
    m = load_named("four_bar")
    space = design_space(m, ["P"])
    ev = Evaluator(m, space)
    s0 = ev.branches(space.x0[None])
    X = space.x0.copy()[None]
    for i, n in enumerate(space.names):
        if n.endswith(".y"):
            X[0, i] = -X[0, i]                  # mirror in the x-axis: every RRR flips
    np.testing.assert_array_equal(branch_signs(m, space.names, X), -s0)


def test_synthesis_scores_what_solve_gives():
    """The synthesiser's tracer positions of a design are solve's, bit for bit."""
    m = load_named("four_bar")
    space = design_space(m, ["P"])
    ev = Evaluator(m, space)
    rng = np.random.default_rng(3)
    X = space.x0 + 0.002 * rng.standard_normal((6, space.size))
    phi = np.linspace(0.0, 2 * np.pi, 96, endpoint=False)
    w, ok = ev.point(X, phi, "P")
    for d in range(6):
        st = solve(ev.with_design(X[d]), phi)
        good = np.asarray(st.status == "ok") & ok[d]
        np.testing.assert_array_equal(w[d][good], st.point_positions[good, 0])


def test_solve_outputs_compute_only_what_is_asked():
    """solve(outputs=): the named joint and tracer point equal the full solve's bits;
    nothing else is computed (other positions and angles NaN), statuses are all given."""
    m = load_named("stephenson_2")
    x = np.radians(np.linspace(0.0, 360.0, 73))
    full = solve(m, x)
    j = m.joint_names[2]
    part = solve(m, x, outputs=[j])
    i = m.joint_names.index(j)
    np.testing.assert_array_equal(part.positions[:, i], full.positions[:, i])
    np.testing.assert_array_equal(part.status, full.status)
    others = [k for k in range(m.n_joints) if k != i]
    assert np.isnan(part.positions[:, others]).all()
    skipped = np.flatnonzero(np.isnan(part.angles).all(axis=0))   # angles a dyad would compute
    assert len(skipped) >= m.n_links - 2                           # all but the frame's and the crank's
    link = m.link_names[skipped[0]]
    with_angle = solve(m, x, outputs=[j, link])
    np.testing.assert_array_equal(with_angle.angles[:, skipped[0]], full.angles[:, skipped[0]])
    moved = solve(m, x, outputs=[j], derivatives=True)   # derivatives still work when asked
    np.testing.assert_allclose(moved.velocities[:, i], solve(m, x, derivatives=True).velocities[:, i])


def test_the_facade_solves_designs():
    """ml.solve(m, x, designs=X): the batch through the façade, (D, N) results equal to
    solve_designs with the default column names (joints, then tracer points)."""
    import multiloop as ml
    m = load_named("four_bar")
    names, X = _designs(m, D=4)
    x = _inputs(m)
    r = ml.solve("four_bar", x, designs=X, outputs=["P"])
    assert r.ok.shape == (4, len(x))
    np.testing.assert_array_equal(r.point("P"), solve_designs(m, names, X, x).point("P"))


def _python_lowering(m, names, X):
    """The numbers of designs ``X`` by the adapters bound in NumPy (the oracle) and by the
    compiled lowering (:func:`kin.kernel.lower_designs`), with the links' reference points."""
    from multiloop.kin.design import _bind
    from multiloop.kin.geometry import Geometry
    sp = plan_of(m)
    kp, steps = kernel.kernel_plan(sp), list(range(len(sp.steps)))
    assert kp.covers(steps, tracked=True) and kp.lowered(steps)
    geo = Geometry(m, names, X)
    with np.errstate(all="ignore"):
        oracle = kernel.design_floats(kp, [_bind(st, m, sp.size, geo) for st in sp.steps], steps, geo.origins(),
                                      geo.D)
    mine = Geometry(m, names, X)
    got = kernel.lower_designs(sp, kp, mine, steps)
    P, U, _ = mine.joint_table
    for i, j in enumerate(m.joints):                    # the gathered table is the geometry's
        np.testing.assert_array_equal(P[:, i], geo.at(j.name)[:, 0])
        if j.kind is JointKind.P:
            np.testing.assert_array_equal(U[:, i], geo.axis(j.name)[:, 0])
    return oracle, got, geo.origins(), mine.origins()


def _slider_driven(point: bool = False):
    """A crank driven through its slider (a P driver: the one closed-form step no
    catalogue mechanism has), with a tracer point ``T`` on the crank when ``point``."""
    from multiloop.topo.model import MechanismBuilder
    b = MechanismBuilder()
    b.add_link("ground", frame=True)
    b.add_joint("S", "P", ("ground", "slider"), at=(3.0, 0.0), axis=(1.0, 0.0))
    b.add_joint("B", "R", ("slider", "rod"), at=(3.0, 0.0))
    b.add_joint("A", "R", ("rod", "crank"), at=(1.0, 1.5))
    b.add_joint("O", "R", ("crank", "ground"), at=(0.0, 0.0))
    if point:
        b.add_point("T", "crank", at=(0.5, 1.2))
    b.add_driver("S")
    return b.build()


@pytest.mark.parametrize("name", DYAD_MECHANISMS + ["slider driven", "stephenson_3_triad", "stephenson_3"])
def test_compiled_lowering_is_the_adapters_to_the_bit(name):
    """Every closed-form step's numbers for a batch of designs (guide angles among the
    variables) come from its compiled lowering with the same bits as the adapter bound in
    NumPy gives, NaN (a branch boundary) where it gives NaN, and the links' reference
    points are the geometry's."""
    pytest.importorskip("numba")
    m = _slider_driven() if name == "slider driven" else load_named(name)
    names, X = _designs(m, D=12, rel=0.05)
    X = np.vstack([X, X[:1]])
    rrr = next((st.step.layout for st in plan_of(m).steps if str(getattr(st.step, "kind", "")) == "RRR"), None)
    if rrr is not None and f"{rrr.inner}.x" in names:     # its inner pin on the outer pins' line: a branch boundary
        mid = 0.5 * (np.asarray(m.joint(rrr.outer1).at) + np.asarray(m.joint(rrr.outer2).at))
        X[-1, names.index(f"{rrr.inner}.x")], X[-1, names.index(f"{rrr.inner}.y")] = mid
    oracle, got, o_oracle, o_got = _python_lowering(m, names, X)
    np.testing.assert_array_equal(got, oracle)
    np.testing.assert_array_equal(o_got, o_oracle)
    assert rrr is None or np.isnan(got[-1]).sum() > np.isnan(got[0]).sum()      # (the boundary's sign)


@given(st.sampled_from(DYAD_MECHANISMS + ["stephenson_3_triad", "stephenson_3"]), st.floats(1e-4, 0.3),
       st.integers(0, 2**31))
@settings(max_examples=25, deadline=None)
def test_compiled_lowering_of_random_designs(name, rel, seed):
    """Hypothesis: random designs of every dyad kind, lowered compiled and in NumPy, bit for bit."""
    pytest.importorskip("numba")
    m = load_named(name)
    names, X = _designs(m, D=5, rel=rel, seed=seed)
    oracle, got, _, _ = _python_lowering(m, names, X)
    np.testing.assert_array_equal(got, oracle)


def test_a_population_read_at_once_reuses_its_work_arrays():
    """``reuse``: the same poses, in this thread's work arrays (the next such call writes
    over them, so a population's pose store is not allocated, and faulted in, afresh)."""
    pytest.importorskip("numba")
    m = load_named("four_bar")
    names, X = _designs(m, D=30, rel=0.02)
    x = _inputs(m, 24)
    with kernel.using("on"):
        own = solve_designs(m, names, X, x)
        first = solve_designs(m, names, X, x, reuse=True)
        np.testing.assert_array_equal(first.store.T, own.store.T)
        np.testing.assert_array_equal(first.th, own.th)
        np.testing.assert_array_equal(first.point("B"), own.point("B"))
        store = first.store.T
        again = solve_designs(m, names, X[::-1].copy(), x, reuse=True)
        assert again.store.T is store or np.shares_memory(again.store.T, store)
        np.testing.assert_array_equal(again.point("B")[::-1], own.point("B"))


@pytest.mark.parametrize("name", DYAD_MECHANISMS)
def test_sensitivities_read_the_lowerings_joint_table_to_the_bit(name):
    """The compiled sensitivity's offsets gathered from the lowering's joint table give
    the same derivatives, bit for bit, as the offsets from the geometry joint by joint."""
    pytest.importorskip("numba")
    from multiloop.kin.sensitivity import pose_sensitivity
    m = load_named(name)
    names, X = _designs(m, D=6, rel=0.03)
    with kernel.using("on"):
        st = solve_designs(m, names, X, _inputs(m, 12))
        assert st.geometry.joint_table is not None
        gathered = pose_sensitivity(st).dZ
        st.geometry.joint_table = None
        np.testing.assert_array_equal(gathered, pose_sensitivity(st).dZ)


def test_an_adapter_that_lowers_otherwise_is_bound_in_numpy():
    """A subclass that changes ``lower`` but not ``compiled_lower`` is not lowered by the
    compiled function it inherits: its steps are bound and lowered by the adapter."""
    from multiloop.kin.groups.rrr import RRRStep
    from multiloop.kin.kernel import _lowers

    class Other(RRRStep):
        def lower(self, origins):
            return super().lower(origins)

    step = plan_of(load_named("four_bar")).steps[1].closed
    assert _lowers(step, step.lower(plan_of(load_named("four_bar")).origins).key)
    step.__class__ = Other
    try:
        assert not _lowers(step, "RRR") and not _lowers(step, step.kind)
    finally:
        step.__class__ = RRRStep


def test_the_kernels_cos_and_sin_rows_are_kept_whole_while_they_are_the_links():
    """The compiled route keeps the kernel's cos and sin arrays (the sensitivities read them
    without stacking): equal to every link's rows; none kept for a partial solve (its
    unsolved links' rows are NaN, not the kernel's) or once a link's rows change."""
    pytest.importorskip("numba")
    m = load_named("watt_1")
    names, X = _designs(m, D=5, rel=0.02)
    with kernel.using("on"):
        st = solve_designs(m, names, X, _inputs(m, 9))
        C, S = st.store.stacked_rows()
        np.testing.assert_array_equal(C, np.stack(st.store.c))
        np.testing.assert_array_equal(S, np.stack(st.store.s))
        part = solve_designs(m, names, X, _inputs(m, 9), outputs=[m.joint_names[1]])
        assert part.store.stacked_rows() is None
        bad = np.zeros(st.store.shape, bool)
        bad[0, 0] = True
        st.store.invalidate([1], bad)
        assert st.store.stacked_rows() is None
