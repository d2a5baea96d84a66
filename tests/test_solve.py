"""Whole-mechanism kinematics (kin.solve): two routes for every number.

* closed form (dyad kernels, triad tracker) vs generic Newton — per group and of the
  whole mechanism as one system;
* velocities / accelerations vs central differences of positions;
* closure residual of every pair at the solved poses;
* branches: no jump over a full turn of Grashof mechanisms, change points kept by
  prediction, reach limits reported.
"""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from multiloop.kin.groups.newton import ConstraintSystem, track
from multiloop.kin.solve import compile_plan, solve
from multiloop.kin.state import KinematicState
from tests.common import slide_driven
from test_assur import (class4_mechanism, crank_slider, dyad_mechanism, four_bar, knitting_needle,
                        six_bar_slider, stephenson3_triad, vtwin)
from multiloop.topo.assur import Constraint
from multiloop.topo.errors import AssemblyError, InputError, SingularityError
from multiloop.topo.mobility import pair_constraints
from multiloop.topo.model import MechanismBuilder

MECHS = {
    "four_bar": four_bar, "crank_slider": crank_slider, "vtwin": vtwin,
    "knitting": knitting_needle, "six_bar_slider": six_bar_slider,
    "triad": stephenson3_triad, "class4": class4_mechanism,
    **{f"dyad_{k}": (lambda k=k: dyad_mechanism(k)) for k in ["RRR", "RRP", "RPR", "PRP", "RPP"]},
}


def _closure(m, st: KinematicState) -> float:
    """Max residual of every pair and driver at the solved poses, relative to size."""
    cons = pair_constraints(m) + [
        Constraint("drive_R" if m.joint(d.joint).kind.value == "R" else "drive_P", d.joint,
                   d.links[0], d.links[1], i) for i, d in enumerate(m.drivers)]
    sysm = ConstraintSystem.compile(m, cons)
    ok = st.ok
    F = sysm.residual(st.poses[ok], st.inputs[ok])
    size = np.ptp(np.array([j.at for j in m.joints]), axis=0).max()
    return float(np.max(np.abs(F)) / size)


def _cycle(n=73):
    return np.linspace(0.0, 2 * np.pi, n)


@pytest.mark.parametrize("name", sorted(MECHS))
@pytest.mark.parametrize("method", ["closed_form", "newton"])
def test_joint_positions_agree_with_every_link_pose(name, method):
    """Second route to the reported joint points: carry each R joint's reference point
    by the pose of every link on it (the solver reuses points it met while solving)."""
    m = MECHS[name]()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = solve(m, _cycle(), method=method)
    origins = compile_plan(m).origins
    size = np.ptp(np.array([j.at for j in m.joints]), axis=0).max()
    ok = st.ok
    for i, j in enumerate(m.joints):
        for lk in (j.links if j.kind.value == "R" else ()):
            k = m.link_names.index(lk)
            r = np.asarray(j.at, float) - origins[k]
            th = st.poses[ok, k, 2]
            P = st.poses[ok, k, :2] + np.stack([np.cos(th) * r[0] - np.sin(th) * r[1],
                                                  np.sin(th) * r[0] + np.cos(th) * r[1]], -1)
            assert np.max(np.abs(P - st.positions[ok, i])) <= 1e-12 * size, (j.name, lk)


@pytest.mark.parametrize("name", sorted(MECHS))
@pytest.mark.parametrize("method", ["closed_form", "newton"])
def test_full_cycle_closure_to_round_off(name, method):
    m = MECHS[name]()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = solve(m, _cycle(), method=method)
    assert st.ok[0], st.status[0]
    assert st.ok.mean() > 0.5, st.message
    assert _closure(m, st) <= 1e-12
    # the first position is the reference configuration itself
    ref = np.array([j.at for j in m.joints])
    assert np.allclose(st.positions[0], ref, atol=1e-13)


@pytest.mark.parametrize("name", sorted(MECHS))
def test_closed_form_equals_newton_on_random_positions(name):
    m = MECHS[name]()
    rng = np.random.default_rng(7)
    full = solve(m, _cycle(361))
    reach = full.inputs[full.ok, 0]
    lo, hi = reach.min(), reach.max()
    # random inputs inside the first reachable interval (sorted: a motion path)
    x = np.sort(rng.uniform(lo, min(hi, lo + 2 * np.pi), 40))
    a = solve(m, x, method="closed_form", derivatives=True)
    b = solve(m, x, method="newton", derivatives=True)
    ok = a.ok & b.ok
    assert ok.mean() > 0.8
    size = np.ptp(np.array([j.at for j in m.joints]), axis=0).max()
    # relative to the magnitude: near a PRP change point the slider is tens of metres away
    pmax = max(size, np.abs(a.positions[ok]).max())
    assert np.max(np.abs(a.positions[ok] - b.positions[ok])) <= 1e-12 * pmax
    vmax = max(size, np.abs(a.velocities[ok]).max())
    amax = max(size, np.abs(a.accelerations[ok]).max())
    assert np.max(np.abs(a.velocities[ok] - b.velocities[ok])) <= 1e-10 * vmax
    assert np.max(np.abs(a.accelerations[ok] - b.accelerations[ok])) <= 1e-9 * amax


@pytest.mark.parametrize("name", ["four_bar", "knitting", "six_bar_slider", "triad", "vtwin"])
def test_closed_form_equals_whole_mechanism_newton(name):
    """Route 2: one Newton system for ALL links at once, tracked from the reference."""
    m = MECHS[name]()
    x = np.linspace(0, 1.5, 31)
    st = solve(m, x)
    plan = compile_plan(m)
    cons = [c for s in plan.assur.steps for c in s.constraints]
    sysm = ConstraintSystem.compile(m, cons)
    unknown = [i for i, lk in enumerate(m.link_names) if lk != m.frame]
    Z = np.zeros((len(x), m.n_links, 3))
    Z[:, :, :2] = plan.origins
    tr = track(sysm, Z, x[:, None], unknown)
    ok = tr.ok & st.ok
    assert ok.all()
    assert np.max(np.abs(tr.Z[ok] - st.poses[ok])) <= 1e-11


@pytest.mark.parametrize("name", sorted(MECHS))
def test_derivatives_match_central_differences(name):
    m = MECHS[name]()
    x = np.linspace(0.05, 2 * np.pi - 0.05, 25)
    st = solve(m, x, derivatives=True)
    size = np.ptp(np.array([j.at for j in m.joints]), axis=0).max()
    h = 1e-6
    p, q = solve(m, x + h), solve(m, x - h)
    ok = st.ok & p.ok & q.ok
    fd = (p.positions - q.positions) / (2 * h)
    assert np.max(np.abs(fd[ok] - st.velocities[ok])) <= 1e-7 * size * max(1, np.abs(st.velocities[ok]).max())
    fdw = (p.angles - q.angles) / (2 * h)
    assert np.max(np.abs(fdw[ok] - st.omegas[ok])) <= 1e-7 * max(1, np.abs(st.omegas[ok]).max())
    h = 1e-4
    p, q = solve(m, x + h), solve(m, x - h)
    fda = (p.positions - 2 * st.positions + q.positions) / h ** 2
    amax = max(1e-3, np.abs(st.accelerations[ok]).max())
    assert np.max(np.abs(fda[ok] - st.accelerations[ok])) <= 1e-4 * amax
    fde = (p.angles - 2 * st.angles + q.angles) / h ** 2
    assert np.max(np.abs(fde[ok] - st.epsilons[ok])) <= 1e-4 * max(1e-3, np.abs(st.epsilons[ok]).max())
    if m.points:
        fdp = (p.point_positions - q.point_positions) / (2 * h)
        assert np.max(np.abs(fdp[ok] - st.point_velocities[ok])) <= 1e-4 * max(1, np.abs(st.point_velocities[ok]).max())


def test_input_rates_scale_velocities_and_accelerations():
    m = four_bar()
    x = np.linspace(0, 1, 5)
    a = solve(m, x, derivatives=True)
    b = solve(m, x, derivatives=True, input_rates=[3.0])
    assert np.allclose(b.velocities, 3 * a.velocities, atol=1e-13)
    assert np.allclose(b.accelerations, 9 * a.accelerations, atol=1e-12)


def test_point_on_link_agrees_with_tracer_points():
    m = four_bar()
    st = solve(m, _cycle(37), derivatives=True)
    p, v, a = st.point_on_link("coupler", m.points[0].at)
    assert np.allclose(p, st.point_positions[:, 0], atol=1e-13)
    assert np.allclose(v, st.point_velocities[:, 0], atol=1e-12)
    assert np.allclose(a, st.point_accelerations[:, 0], atol=1e-12)


@pytest.mark.parametrize("sign", [1, -1])
@pytest.mark.parametrize("dims", [(1.0, 4.0, 3.5, 4.0), (0.5, 1.2, 0.8, 1.0), (1.0, 3.0, 2.5, 3.2)])
def test_no_branch_jump_over_a_full_turn_of_grashof_four_bars(dims, sign):
    r, l, c, g = dims
    assert min(dims) + max(dims) < sum(dims) - min(dims) - max(dims)   # Grashof, crank shortest
    m = four_bar(r, l, c, g, sign=sign)
    st = solve(m, np.linspace(0, 2 * np.pi, 3601))
    assert st.success and not st.notes
    A, B, C = st.positions[:, 1], st.positions[:, 2], st.positions[:, 3]
    cross = (C - A)[:, 0] * (B - A)[:, 1] - (C - A)[:, 1] * (B - A)[:, 0]
    assert np.all(np.sign(cross) == np.sign(cross[0]))        # one assembly branch
    assert np.max(np.linalg.norm(np.diff(B, axis=0), axis=1)) < 0.02 * g   # continuous
    assert np.allclose(st.positions[-1], st.positions[0], atol=1e-12)      # closes the cycle
    nt = solve(m, np.linspace(0, 2 * np.pi, 721), method="newton")
    assert np.max(np.abs(nt.positions - st.positions[::5])) <= 1e-11


def test_non_grashof_reports_its_reach_limits():
    m = four_bar(1.5, 2.0, 2.0, 3.0, sign=-1)   # s + l = 4.5 > p + q = 4
    x = np.radians(np.arange(0, 361.0, 1.0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = solve(m, x)
    assert not st.success and st.ok[0]
    first = int(np.flatnonzero(~st.ok)[0])
    assert "unreachable: limit at" in st.status[first] and "II1(2,3)" in st.status[first]
    assert "first at input" in st.message
    assert np.isnan(st.positions[first]).any()
    # the limit is where the coupler and rocker are stretched: |AC| = l + c
    A = st.positions[first - 1, 1]
    assert abs(np.hypot(*(A - st.positions[0, 3])) - 4.0) < 0.1
    with pytest.raises(AssemblyError, match="unreachable: limit at"):
        solve(m, x[first])
    with pytest.raises(AssemblyError):
        solve(m, x[first], method="newton")


def _parallelogram():
    b = MechanismBuilder(name="parallelogram")
    b.add_link("g", frame=True)
    for n, lk, at in [("O", ("g", "c1"), (0, 0)), ("A", ("c1", "cp"), (0, 1)),
                      ("B", ("cp", "c2"), (2, 1)), ("C", ("c2", "g"), (2, 0))]:
        b.add_joint(n, "R", lk, at=at)
    b.add_driver("O")
    return b.build()


def test_parallelogram_change_points_keep_the_branch_and_say_so():
    m = _parallelogram()
    x = np.radians(np.arange(0, 361.0, 5.0))     # flat positions at 90° and 270° are on the grid
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = solve(m, x)
    ok = st.ok
    i_cp, i_c2 = m.link_names.index("cp"), m.link_names.index("c2")
    # parallelogram branch: coupler translates, rocker turns with the crank
    assert np.allclose(st.angles[ok, i_cp], 0.0, atol=1e-9)
    assert np.allclose(np.unwrap(st.angles[ok, i_c2]), x[ok], atol=1e-9)
    assert st.notes and "keeps the mode of the reference" in st.notes[0]
    # at the exact flat positions the dyad is singular: marked, not hidden
    assert all(("singular" in s) for s in st.status[~ok])


def test_only_solves_the_groups_upstream():
    m = vtwin()
    st = solve(m, _cycle(13), only=["B1"])
    j = m.joint_names.index
    assert np.all(np.isfinite(st.positions[:, j("B1")]))
    assert np.all(np.isnan(st.positions[:, j("B2")]))
    sd = solve(m, _cycle(13), only=["B1"], derivatives=True)
    assert np.all(np.isfinite(sd.velocities[:, j("B1")])) and np.all(np.isnan(sd.velocities[:, j("B2")]))
    with pytest.raises(InputError, match="unknown name"):
        solve(m, [0.0], only=["nope"])


def test_positions_only_unless_asked():
    st = solve(four_bar(), _cycle(5))
    assert st.velocities is None and st.accelerations is None and st.omegas is None


def test_two_drivers_five_bar():
    b = MechanismBuilder(name="five-bar")
    b.add_link("g", frame=True)
    for n, lk, at in [("O1", ("g", "a"), (0, 0)), ("A", ("a", "b"), (0, 1)), ("B", ("b", "c"), (1.2, 2.0)),
                      ("C", ("c", "d"), (2.5, 1.0)), ("O2", ("d", "g"), (2.5, 0))]:
        b.add_joint(n, "R", lk, at=at)
    b.add_driver("O1")
    b.add_driver("O2")
    m = b.build()
    t = np.linspace(0, 1, 21)
    X = np.stack([0.4 * t, -0.3 * t], axis=1)
    a = solve(m, X, derivatives=True, input_rates=[1.0, 2.0])
    n = solve(m, X, method="newton")
    assert a.success and np.max(np.abs(a.positions - n.positions)) <= 1e-12
    h = 1e-6
    p, q = solve(m, X + h * np.array([1.0, 2.0])), solve(m, X - h * np.array([1.0, 2.0]))
    assert np.allclose((p.positions - q.positions) / (2 * h), a.velocities, atol=1e-7)


def test_prismatic_driver():
    m = slide_driven()
    st = solve(m, np.linspace(-0.2, 0.2, 9), derivatives=True)
    assert st.success
    assert np.allclose(st.positions[:, 1, 0], np.linspace(-0.2, 0.2, 9), atol=1e-14)
    assert np.allclose(st.velocities[:, 1], [1.0, 0.0], atol=1e-14)


def test_structurally_singular_designs_rejected_when_the_plan_is_built():
    b = MechanismBuilder(name="prp-parallel")
    b.add_link("frame", frame=True)
    b.add_joint("O", "R", ("frame", "crank"), at=(0.0, 0.0))
    b.add_joint("S1", "P", ("crank", "l2"), at=(0.5, 0.2), axis=(1.0, 0.0))
    b.add_joint("B", "R", ("l2", "l3"), at=(0.5, 0.2))
    b.add_joint("S2", "P", ("frame", "l3"), at=(0.5, 0.2), axis=(-2.0, 0.0))
    b.add_driver("O")
    with pytest.raises(SingularityError, match="parallel guides"):
        compile_plan(b.build())
    b = MechanismBuilder(name="rpp-alpha0")
    b.add_link("frame", frame=True)
    b.add_joint("O", "R", ("frame", "crank"), at=(0.0, 0.0))
    b.add_joint("A", "R", ("crank", "l2"), at=(0.3, 0.1))
    b.add_joint("S1", "P", ("l3", "l2"), at=(0.3, 0.1), axis=(1.0, 0.0))
    b.add_joint("S2", "P", ("frame", "l3"), at=(0.6, -0.2), axis=(1.0, 0.0))
    b.add_driver("O")
    with pytest.raises(SingularityError, match="α = 0"):
        solve(b.build(), [0.0])


def test_bad_inputs():
    m = four_bar()
    with pytest.raises(InputError, match="shape"):
        solve(m, np.zeros((3, 2)))
    with pytest.raises(InputError, match="method"):
        solve(m, [0.0], method="magic")
    with pytest.raises(InputError, match="finite"):
        solve(m, [np.nan])


def test_plan_reuse_and_lead_in():
    m = knitting_needle()
    plan = compile_plan(m)
    a = solve(m, [math.pi], plan=plan)           # reached from the reference by a lead-in
    b = solve(m, np.linspace(0, math.pi, 181))
    assert np.allclose(a.positions[0], b.positions[-1], atol=1e-12)



def test_a_solved_plan_stays_as_compiled():
    """Solving never writes into the frozen plan: its fields are the same objects, its
    arrays read-only, and what it derived on demand (the chart of the motion, the
    kernel plan) is kept beside it (kin.memo) with read-only mappings."""
    import dataclasses
    from types import MappingProxyType

    from multiloop.kin import kernel
    from multiloop.kin.memo import memo_of
    from multiloop.kin.solve import motion_events
    m = knitting_needle()
    plan = compile_plan(m)
    before = {f.name: getattr(plan, f.name) for f in dataclasses.fields(plan)}
    assert not any(isinstance(v, (dict, list, set)) for v in before.values())
    solve(m, np.linspace(-7.0, 7.0, 50), plan=plan, derivatives=True)
    solve(m, np.linspace(0.0, 1.0, 5), plan=plan, outputs=("B",))
    kernel.kernel_plan(plan)
    ev = motion_events(m, plan)
    assert all(getattr(plan, k) is v for k, v in before.items())
    assert not plan.origins.flags.writeable
    with pytest.raises(dataclasses.FrozenInstanceError):
        plan.size = 2.0
    chart = memo_of(plan)["chart"]
    assert isinstance(chart.limits, MappingProxyType) and isinstance(chart.flips, MappingProxyType)
    assert isinstance(ev.limits, MappingProxyType)
    with pytest.raises(dataclasses.FrozenInstanceError):
        chart.lo_req = 0.0

# ---------------------------------------------------------------- the catalogue
_CAT = sorted((__import__("pathlib").Path(__file__).resolve().parents[1] / "catalogue" / "mechanisms").glob("*.toml"))


def _cycle_for(m):
    kinds = {m.joint(d.joint).kind.value for d in m.drivers}
    size = np.ptp(np.array([j.at for j in m.joints]), axis=0).max()
    if kinds == {"R"} and len(m.drivers) == 1:
        return np.linspace(0.0, 2 * np.pi, 181)
    t = np.linspace(0.0, 1.0, 61)
    cols = [t * (0.3 if m.joint(d.joint).kind.value == "R" else 0.05 * size) for d in m.drivers]
    cols = [c if d.range is None else np.clip(c, *d.range) for c, d in zip(cols, m.drivers)]  # its stroke
    return np.stack(cols, axis=1) if len(cols) > 1 else cols[0]


def test_the_size_is_the_mechanism_s_and_the_plan_s():
    """One size: ``Mechanism.size`` (the larger spread of the joints in x and y), which
    the compiled plan carries; no other module of the library computes it again."""
    import pathlib
    import re

    from multiloop.topo.io import load
    for path in _CAT:
        m = load(path)
        xy = np.array([j.at for j in m.joints], float)
        assert compile_plan(m).size == m.size == max(float(np.max(np.ptp(xy, axis=0))), 1e-12)
    root = pathlib.Path(__file__).resolve().parents[1]
    again = re.compile(r"ptp\(.*j\.at|j\.at for j in m\.joints.*\n.*ptp|def mechanism_size")
    found = [str(p.relative_to(root)) for pkg in ("topo", "kin", "catalogue", "multiloop")
             for p in sorted((root / pkg).rglob("*.py")) if again.search(p.read_text())]
    assert found == []


@pytest.mark.parametrize("path", _CAT, ids=[p.stem for p in _CAT])
def test_every_catalogue_mechanism_decomposes_and_solves_or_reports_its_limit(path):
    from multiloop.topo.assur import decompose
    from multiloop.topo.io import load
    m = load(path)
    if m.frame is None or not m.drivers or not m.has_geometry:
        pytest.skip("a bare chain / no drivers / no geometry")
    plan = decompose(m)
    assert plan.groups or plan.drivers
    x = _cycle_for(m)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = solve(m, x, derivatives=True)
        nt = solve(m, x, method="newton")
    assert st.ok[0], st.status[0]
    if not st.success:                      # an honest limit: named group and reason
        bad = st.status[~st.ok][0]
        assert "group" in bad or "driver" in bad
        assert ("out of reach" in bad) or ("singular" in bad) or ("no assembly" in bad)
    assert _closure(m, st) <= 1e-12
    ok = st.ok & nt.ok
    scale = max(1.0, np.abs(st.positions[ok]).max())
    assert np.max(np.abs(st.positions[ok] - nt.positions[ok])) <= 1e-11 * scale
    # the motion is continuous (no silent branch jump): each step is what the analytic
    # velocities predict, to first order
    size = np.ptp(np.array([j.at for j in m.joints]), axis=0).max()
    X = st.inputs if st.inputs.ndim == 2 else st.inputs[:, None]
    dx = np.linalg.norm(np.diff(X, axis=0), axis=1)
    dP = np.linalg.norm(np.diff(st.positions, axis=0), axis=2).max(axis=1)
    v = np.linalg.norm(st.velocities, axis=2).max(axis=1)
    a = np.linalg.norm(st.accelerations, axis=2).max(axis=1)
    bound = np.fmax(v[1:], v[:-1]) * dx + np.fmax(a[1:], a[:-1]) * dx ** 2 + 1e-9 * size
    both = st.ok[1:] & st.ok[:-1] & (np.abs(st.positions).max(axis=(1, 2))[1:] < 10 * size)
    assert np.all(dP[both] <= 2.0 * bound[both])


def test_slide_driver_on_a_moving_guide_rates():
    """Crank (R driver) carrying a slider (P driver on the crank): Coriolis terms."""
    b = MechanismBuilder(name="slide-on-crank")
    b.add_link("f", frame=True)
    b.add_joint("O", "R", ("f", "crank"), at=(0.0, 0.0))
    b.add_joint("S", "P", ("crank", "block"), at=(0.5, 0.1), axis=(1.0, 0.2))
    b.add_point("T", "block", (0.6, 0.3))
    b.add_driver("O")
    b.add_driver("S")
    m = b.build()
    t = np.linspace(0, 1, 11)
    X = np.stack([1.3 * t, 0.2 * t], axis=1)
    r = np.array([1.0, 0.5])
    st = solve(m, X, derivatives=True, input_rates=r)
    nt = solve(m, X, derivatives=True, input_rates=r, method="newton")
    assert np.allclose(st.accelerations, nt.accelerations, atol=1e-12)
    h = 1e-4
    p, q = solve(m, X + h * r), solve(m, X - h * r)
    assert np.allclose((p.point_positions - q.point_positions) / (2 * h), st.point_velocities, atol=1e-7)
    assert np.allclose((p.point_positions - 2 * st.point_positions + q.point_positions) / h ** 2,
                       st.point_accelerations, atol=1e-6)


def test_prp_change_point_is_marked_singular_not_far_away():
    # dyad_prp: the two guides become parallel at 120 deg of the crank; the position
    # there must be marked singular (before the fix it came back "ok" at 4e5 m)
    import warnings

    from multiloop.catalogue.named import load_named
    m = load_named("dyad_prp")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = solve(m, np.radians([110.0, 120.0, 130.0]))
    assert st.ok[0] and st.ok[2] and not st.ok[1]
    assert "singular" in st.status[1]


def test_several_drivers_out_of_phase_continue_without_failure():
    # excavator: three cylinders moving out of phase; the continuation predictor must
    # follow the direction of each step (Euler tangent), not the previous step's
    import warnings

    from multiloop.catalogue.named import load_named
    m = load_named("excavator")
    t = np.linspace(0.0, 1.0, 37)[1:]
    vals = np.stack([a * np.sin(2 * np.pi * t + 2.1 * k) for k, a in enumerate((0.35, 0.40, 0.35))], axis=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = solve(m, vals)
    assert st.success, st.message


@pytest.mark.parametrize("name", ["four_bar", "crank_slider", "dyad_prp", "dyad_rpp", "dyad_rpr", "dyad_rrp",
                                  "stephenson_3_triad", "excavator", "knitting_needle_drive", "linkage_24"])
def test_velocities_alone_are_the_full_derivatives_velocities_bit_for_bit(name):
    """``derivatives="velocities"`` skips the accelerations (None) and gives the very
    velocities, angular velocities and point velocities of ``derivatives=True`` (every
    group kind's rates, the driver's, an actuated cylinder's, a triad's Jacobian), also
    for several drivers moving and with ``rows=``."""
    from multiloop.catalogue.named import load_named
    m = load_named(name)
    rng = np.random.default_rng(5)
    nd = len(m.drivers)
    span = np.array([0.6 if m.is_rotary(k) else 0.05 * m.size for k in range(nd)])
    X = np.cumsum(rng.uniform(-1, 1, (40, nd)) * span / 20, axis=0)
    rates = rng.uniform(0.5, 2.0, nd)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for rows in (None, [3, 17, 39]):
            a = solve(m, X, derivatives=True, input_rates=rates, rows=rows)
            b = solve(m, X, derivatives="velocities", input_rates=rates, rows=rows)
            assert b.accelerations is None and b.epsilons is None and b.pose_accelerations is None
            for f in ("velocities", "omegas", "point_velocities", "pose_rates", "positions"):
                x, y = getattr(a, f), getattr(b, f)
                assert (x is None and y is None) or np.array_equal(x, y, equal_nan=True), f
            assert np.any(np.isfinite(b.velocities))
