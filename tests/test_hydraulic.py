"""Hydraulic machines: registry facts, actuator transmission, workspace, per-driver forces
and the catalogue machines' check verdicts.

Oracles: the law of cosines (actuator transmission of a single-cylinder boom), a
brute-force grid of the box refined by Powell's method (scipy) for the workspace extremes, a
dense sweep for the verdicts' angle extremes, the toggle of the bucket linkage found by
Brent's method on the triangle lengths for the excavator's usable bucket range, and the
moment balance of the boom about its foot for the cylinder force.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.optimize import brentq, minimize

from multiloop.catalogue.named import load_named
from multiloop.kin.check import check
from multiloop.kin.check.transmission import angle_specs, angle_values
from multiloop.kin.groups.registry import mode_count
from multiloop.kin.solve import solve
from multiloop.kin.sweep import driver_forces
from multiloop.topo.assur import GroupKind, decompose
from multiloop.topo.model import MechanismBuilder

HYDRAULIC = ["excavator", "excavator_bucket", "wheel_loader_zbar", "knuckle_boom_crane"]
C0, A0, B0 = np.array([0.0, 0.0]), np.array([1.5, -0.5]), np.array([2.0, 1.0])   # foot, base, end


def boom(load=None, rng=None):
    """A boom pinned at C0, lifted by one cylinder from A0 (barrel) to B0 (rod end)."""
    b = MechanismBuilder()
    b.add_link("frame", frame=True)
    for x in ("boom", "barrel", "rod"):
        b.add_link(x)
    u = (B0 - A0) / np.hypot(*(B0 - A0))
    b.add_joint("foot", "R", ("frame", "boom"), at=C0)
    b.add_joint("base", "R", ("frame", "barrel"), at=A0)
    b.add_joint("slide", "P", ("barrel", "rod"), at=(A0 + B0) / 2, axis=u)
    b.add_joint("end", "R", ("rod", "boom"), at=B0)
    b.add_driver("slide", range=rng)
    b.add_point("tip", "boom", (4.0, 2.5))
    if load is not None:
        b.add_load("boom", at=(4.0, 2.5), value=load)
    return b.build()


@pytest.mark.parametrize("name", HYDRAULIC)
def test_two_modes_per_actuated_triangle(name):
    m = load_named(name)
    ap = decompose(m)
    acts = [g for g in ap.groups if g.kind is GroupKind.ACTUATED]
    assert len(acts) == sum(1 for d in m.drivers)
    assert all(mode_count(m, g) == 2 for g in acts)
    circ = {c.group: c for c in check(m).circuits} if name != "excavator" else None
    if circ is not None:
        assert all(circ[g.describe()].modes == 2 for g in acts)
        assert all("not enumerated" not in c.note for c in circ.values())


def test_every_closed_form_kind_has_check_facts():
    from multiloop.kin.groups.registry import CLOSED_FORM
    from multiloop.kin.groups.step import GroupStep
    # each adapter declares its kind, its modes and its angles itself (not the base's "unknown")
    for kind, adapter in CLOSED_FORM.items():
        assert adapter.kind == kind
        assert adapter.assembly_modes.__func__ is not GroupStep.assembly_modes.__func__


def test_actuator_transmission_against_the_law_of_cosines():
    m = boom(rng=(-0.6, 0.6))
    a, lb, L0 = np.hypot(*(A0 - C0)), np.hypot(*(B0 - C0)), np.hypot(*(B0 - A0))
    (spec,) = [sp for sp in angle_specs(decompose(m)) if sp.joint == "end"]
    assert spec.quantity == "transmission" and spec.points == ("base", "end", "foot")
    s = np.linspace(-0.6, 0.6, 121)
    L = L0 + s
    hand = np.degrees(np.arccos((L * L + lb * lb - a * a) / (2 * L * lb)))   # angle at B: cylinder vs lever
    got = angle_values(solve(m, s), [spec])[:, 0]
    assert np.max(np.abs(got - hand)) < 1e-9
    # check's extremes over the range = the hand formula's, located by a bounded search
    ang = check(m).drivers[0].angles[0]
    e = ang.extreme
    hand_min = min(minimize(lambda x: np.degrees(np.arccos(((L0 + x[0]) ** 2 + lb * lb - a * a)
                                                           / (2 * (L0 + x[0]) * lb))),
                            [x0], bounds=[(-0.6, 0.6)]).fun for x0 in (-0.59, 0.0, 0.59))
    assert abs(e.min - hand_min) < 1e-7 and abs(e.max - hand.max()) < 1e-7


@pytest.mark.parametrize("name, point", [("knuckle_boom_crane", "hook"), ("wheel_loader_zbar", "bucket_tip")])
def test_workspace_extremes_against_a_refined_brute_force_grid(name, point):
    m = load_named(name)
    rep = check(m, workspace=point)
    ws = rep.workspace
    box = np.array(ws.box)
    g = [np.linspace(lo, hi, 101) for lo, hi in box]
    X = np.array(np.meshgrid(*g, indexing="ij")).reshape(2, -1).T
    P = solve(m, X, assemble=True).point_positions[:, 0]
    ok = np.isfinite(P).all(axis=1)

    def f(x, c, sgn):
        p = solve(m, np.asarray(x)[None, :], assemble=True).point_positions[0, 0]
        return -sgn * p[c] if np.isfinite(p[c]) else 1e3      # not assembled: never the optimum
    for c, (lo_hi, at) in enumerate(((ws.x, ws.x_at), (ws.y, ws.y_at))):
        for j, sgn in enumerate((-1.0, 1.0)):
            i = np.flatnonzero(ok)[np.argmax(sgn * P[ok, c])]
            ref = minimize(f, X[i], args=(c, sgn), bounds=box, method="Powell",
                           options={"xtol": 1e-12, "ftol": 1e-15, "maxfev": 20000})
            brute = max(sgn * P[i, c], -ref.fun, _zoom(m, box, X[i], c, sgn))  # (as sgn * value)
            brute = sgn * brute
            assert sgn * (lo_hi[j] - brute) > -1e-8            # at least as extreme as the refined grid
            assert abs(lo_hi[j] - brute) < 1e-6
            assert sgn * (lo_hi[j] - P[i, c]) >= -1e-12         # never worse than the grid
            # the reported driver values reach the reported extreme
            p = solve(m, np.array(at[j])[None, :], assemble=True).point_positions[0, 0]
            assert abs(p[c] - lo_hi[j]) < 1e-12
    assert ws.area > 0 and len(ws.boundary) > 10
    d = rep.as_dict()["workspace"]
    assert set(d) == {"point", "x", "y", "x_at", "y_at", "boundary", "area", "exact", "reason", "arcs"}


def _zoom(m, box, x0, c, sgn, k=21, shrink=4.0):
    """Brute-force refinement: a k × k grid around the best point, shrunk 4 times per
    round down to 1e-11 of the box; returns the best ``sgn * p[c]``."""
    h = (box[:, 1] - box[:, 0]) / 100
    x, best = np.array(x0, float), -np.inf
    t = np.linspace(-1.0, 1.0, k)
    while np.max(h) > 1e-11 * np.max(box[:, 1] - box[:, 0]):
        G = np.clip(x + np.array(np.meshgrid(t, t, indexing="ij")).reshape(2, -1).T * h, box[:, 0], box[:, 1])
        v = sgn * solve(m, G, assemble=True).point_positions[:, 0, c]
        v = np.where(np.isfinite(v), v, -np.inf)
        if v.max() > best:
            best, x = v.max(), G[np.argmax(v)]
        h = h / shrink * 2
    return best


def test_workspace_bad_point_exit_2(capsys):
    from multiloop.cli import main
    assert main(["check", "knuckle_boom_crane", "--workspace", "nowhere"]) == 2
    assert "--workspace" in capsys.readouterr().err


def _unranged(m):
    """``m`` without its drivers' ranges (to look beyond a cylinder's stroke end)."""
    b = MechanismBuilder.from_mechanism(m)
    b.drivers = [dataclasses.replace(d, range=None) for d in m.drivers]
    return b.build()


def _sweep_angle(m, k, joint, lo, hi, n=20001):
    X = np.zeros((n, len(m.drivers)))
    X[:, k] = np.linspace(lo, hi, n)
    st = solve(m, X)
    (sp,) = [s for s in angle_specs(decompose(m)) if s.joint == joint]
    return angle_values(st, [sp])[:, 0]


def test_knuckle_boom_crane_verdict_confirmed_by_a_dense_sweep():
    m = load_named("knuckle_boom_crane")
    rep = check(m)
    assert rep.verdict == ()
    dc = rep.drivers[1]                           # the outer cylinder over its range [-0.4, 0.25]
    assert dc.usable == pytest.approx((-0.4, 0.25), abs=1e-12)
    for a in dc.angles:
        if a.joint in ("R", "F"):
            v = _sweep_angle(m, 1, a.joint, -0.4, 0.25)
            assert a.extreme.min <= v.min() + 1e-9 and a.extreme.min > v.min() - 1e-4
            assert a.extreme.max >= v.max() - 1e-9 and a.extreme.max < v.max() + 1e-4
            assert a.extreme.min >= 40.0 and a.extreme.max <= 140.0
    # the range's stated reason: beyond +0.25 m the outer link pair falls below 40°
    assert _sweep_angle(_unranged(m), 1, "F", 0.25, 0.45, 201).min() < 40.0


def test_wheel_loader_verdict_and_tilt_transmission():
    m = load_named("wheel_loader_zbar")
    rep = check(m)
    assert rep.verdict == ()
    tilt = rep.drivers[1]
    (t2,) = [a for a in tilt.angles if a.joint == "T2"]
    v = _sweep_angle(m, 1, "T2", -0.12, 0.12)
    assert t2.extreme.max == pytest.approx(v.max(), abs=1e-4) and t2.extreme.max >= v.max() - 1e-9
    assert t2.extreme.max < 140.0
    assert _sweep_angle(_unranged(m), 1, "T2", -0.25, -0.12, 201).max() > 140.0   # why the range stops at -0.12 m


def test_excavator_bucket_range_cut_by_the_linkage_toggle():
    """The usable bucket-cylinder range ends where the bucket dyad (bucket_link, bucket)
    folds flat (its transmission angle tends to 0°): |T − bucket_pivot| = |T − pin| − |pin −
    pivot|, with T from the actuated triangle by the law of cosines (the rocker turning
    about its pivot)."""
    m = load_named("excavator")
    rep = check(m)
    dc = rep.drivers[2]
    assert dc.bound_at("high") == "assembly" and dc.bound_at("low") == "range"
    # the boom cylinder's angle is judged once, under the boom cylinder (it is constant
    # while the stick or bucket cylinder moves)
    lines = [v for v in rep.verdict if "at boom_cyl_end" in v]
    assert len(lines) == 1 and "at boom_cyl_slide = 0.7 m" in lines[0]
    assert any("assembly limits cut its range [-0.45, 0.6] m at the high end" in v for v in rep.verdict)
    at = {j.name: np.array(j.at) for j in m.joints}
    A, P, T0, Q, Bp = at["bucket_cyl_base"], at["rocker_pivot"], at["T"], at["bucket_link_pin"], at["bucket_pivot"]
    L0, r, ap = np.hypot(*(T0 - A)), np.hypot(*(T0 - P)), np.hypot(*(P - A))
    reach = abs(np.hypot(*(Q - T0)) - np.hypot(*(Q - Bp)))

    def T(s):           # the rod end on the rocker's circle at cylinder length L0 + s (reference side)
        L = L0 + s
        phi = np.arccos((r * r + ap * ap - L * L) / (2 * r * ap))
        base = np.arctan2(*(A - P)[::-1])
        side = np.sign((A - P)[0] * (T0 - P)[1] - (A - P)[1] * (T0 - P)[0])
        return P + r * np.array([np.cos(base + side * phi), np.sin(base + side * phi)])
    assert np.allclose(T(0.0), T0, atol=1e-5)       # the pin coordinates are given to 1e-6
    s_lim = brentq(lambda s: np.hypot(*(T(s) - Bp)) - reach, 0.3, 0.6, xtol=1e-14)
    assert dc.usable[1] == pytest.approx(s_lim, abs=1e-8)


def test_forces_each_driver_against_the_moment_balance():
    W = np.array([0.0, -1000.0])
    m = boom(load=W, rng=(-0.5, 0.5))
    df = driver_forces(m, steps=11)
    fr = df.results[0]
    st = fr.state
    B = st.positions[:, st.joint_index("end")]
    A = st.positions[:, st.joint_index("base")]
    tip = st.point_positions[:, 0]
    u = (B - A) / np.hypot(*(B - A).T)[:, None]
    cross = lambda p, q: p[:, 0] * q[:, 1] - p[:, 1] * q[:, 0]   # noqa: E731
    # the boom about its foot: the cylinder's push F u at B balances the load at the tip
    F = -cross(tip - C0, np.tile(W, (len(tip), 1))) / cross(B - C0, u)
    assert np.allclose(df.as_dict()["slide"]["input"], np.linspace(-0.5, 0.5, 11))
    assert np.max(np.abs(fr.balancing[:, 0] - F)) < 1e-9 * np.max(np.abs(F))


def test_forces_command_gives_each_driver(capsys):
    from multiloop.cli import main
    import json
    assert main(["forces", "knuckle_boom_crane", "--steps", "5", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)["per_driver"]
    assert set(d) == {"inner_cyl_slide", "outer_cyl_slide"}
    assert d["outer_cyl_slide"]["input"] == pytest.approx(np.linspace(-0.4, 0.25, 5).tolist())
    assert all(s == "ok" for s in d["inner_cyl_slide"]["status"])
    # the inner cylinder holds both booms up against gravity (masses in the file) over its
    # whole sweep: it always pushes; the outer boom's weight moment about the knuckle changes
    # sign as it swings over, and so does its cylinder's force
    b = np.array(d["inner_cyl_slide"]["balancing"])
    assert np.all(b > 1000.0)
    b = np.array(d["outer_cyl_slide"]["balancing"])
    assert b.min() < 0.0 < b.max()


def test_angles_another_cylinder_moves_are_constant_and_not_zoomed(monkeypatch):
    """The excavator's angles that the moved cylinder does not change (the stick and
    bucket linkages while the boom cylinder moves) are constant to rounding over its
    motion: they are reported as constant (max − min ≤ FLAT × size), and no zoom search
    is spent on their rounding noise (every golden-section bracket is of a column that
    varies).  The varying angles keep their exact extremes (the tests above)."""
    from multiloop.kin.check import events, sweep
    zoomed = []
    golden = sweep.Side.golden

    def counting(self, a, b, value, derivatives=False):
        zoomed.append(np.size(a))
        return golden(self, a, b, value, derivatives)
    monkeypatch.setattr(sweep.Side, "golden", counting)
    rep = check(load_named("excavator"))
    constant = [(dc.joint, a.joint) for dc in rep.drivers for a in dc.angles
                if a.extreme is not None and a.extreme.max - a.extreme.min <= 180.0 * events.FLAT]
    varying = [a for dc in rep.drivers for a in dc.angles
               if a.extreme is not None and a.extreme.max - a.extreme.min > 1e-6]
    assert ("boom_cyl_slide", "T") in constant and ("stick_cyl_slide", "bucket_link_pin") in constant
    assert varying and len(constant) + len(varying) == sum(len(dc.angles) for dc in rep.drivers)
    # brackets refined: interior grid extremes of the varying angles and the ratio only
    assert sum(zoomed) <= 2 * len(varying) + 2 * len(rep.drivers)


def test_constant_columns_to_rounding():
    """FLAT is relative to a column's size (at least 1): rounding noise is constant, a
    variation of 1e-9 is not, a column without a finite value is (it has no bracket)."""
    from multiloop.kin.check.events import FLAT, _constant
    rng = np.random.default_rng(3)
    n = 40
    V = np.column_stack([1.3 + 4e-16 * rng.standard_normal(n), 1.3 + 1e-9 * np.sin(np.arange(n)),
                         np.full(n, np.nan), 1e6 * (1 + 1e-15 * rng.standard_normal(n)),
                         1e6 + 1e-3 * np.arange(n), 2e-16 * rng.standard_normal(n)])
    V[5, 0] = np.nan
    assert _constant(V).tolist() == [True, False, True, True, False, True]
    assert FLAT < 1e-9


@pytest.mark.parametrize("name", ["excavator", "excavator_bucket"])
def test_held_cylinder_limits_come_from_the_certified_walk_and_match_the_solver(name):
    """Each cylinder of a machine with several (the others held) has its assembly limits
    from the certified walk (``motion_events(..., k=)``, over its range), named by the
    group that stops it; the same limit found the other way, by bisecting where ``solve``
    stops assembling, agrees to 1e-12 of the size, and the limit itself assembles."""
    from scipy.optimize import bisect

    from multiloop.kin.solve import motion_events
    m = load_named(name)
    rep = check(m)
    for k, dc in enumerate(rep.drivers):
        ev = motion_events(m, extent=m.drivers[k].range, k=k)
        for side, lim, bind in zip(("hi", "lo"), dc.limits, dc.binds):
            if bind != "assembly":
                continue
            assert lim == getattr(ev, side) and side in ev.limits
            assert any(ev.limits[side] in g for g in dc.limit_groups)

            def ok(x):
                X = np.zeros((1, len(m.drivers)))
                X[0, k] = x
                return 1.0 if solve(m, X).ok[0] else -1.0
            assert ok(lim) == 1.0
            far = lim + (0.1 if lim > 0 else -0.1) * m.size
            other = bisect(ok, 0.5 * lim, far, xtol=1e-14 * m.size, maxiter=200)
            assert abs(other - lim) <= 1e-12 * m.size
