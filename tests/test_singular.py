"""Trust at singular and limit positions: every change point kept, every dead zone found.

Oracles are closed forms written here, independent of the kernels:

* a parallelogram's coupler translates (B − A equals the frame vector O4 − O2) and its
  flat positions are where the crank is collinear with the frame;
* a four-bar's crank limits follow from the law of cosines on the triangle frame–crank–
  diagonal: the diagonal |O4 − A| equals coupler + rocker or |coupler − rocker|
  (Norton, Design of Machinery, 2012, ch. 4, the Grashof condition).
"""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from multiloop.kin.solve import solve
from multiloop.topo.model import MechanismBuilder


def four_bar(O2, A, B, O4, name="fb"):
    b = MechanismBuilder(name)
    b.add_link("frame", frame=True)
    for lk in ("crank", "coupler", "rocker"):
        b.add_link(lk)
    b.add_joint("O2", "R", ("frame", "crank"), at=tuple(O2))
    b.add_joint("A", "R", ("crank", "coupler"), at=tuple(A))
    b.add_joint("B", "R", ("coupler", "rocker"), at=tuple(B))
    b.add_joint("O4", "R", ("rocker", "frame"), at=tuple(O4))
    b.add_driver("O2")
    return b.build()


def _solve(m, x, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return solve(m, x, **kw)


def parallelogram(ratio, ref_deg, scale):
    """Frame 1 along x, crank = rocker = ``ratio``, coupler 1, crank at ``ref_deg``."""
    r, t = ratio * scale, math.radians(ref_deg)
    A = (r * math.cos(t), r * math.sin(t))
    return four_bar((0.0, 0.0), A, (A[0] + scale, A[1]), (scale, 0.0))


PARALLELOGRAMS = [(r, a, s) for r in (0.2, 0.4, 0.6, 0.8) for a in (30, 60, 90, 135) for s in (0.1, 1.0, 100.0)]


@pytest.mark.parametrize("ratio,ref,scale", PARALLELOGRAMS)
def test_parallelogram_keeps_its_mode_through_every_change_point(ratio, ref, scale):
    m = parallelogram(ratio, ref, scale)
    x = np.radians(np.arange(0.0, 721.0, 10.0))          # two turns, 36 steps a turn
    st = _solve(m, x)
    P = st.positions
    iA, iB = st.joint_index("A"), st.joint_index("B")
    ok = st.ok
    # flat positions: crank angle ref + x ≡ 0 (mod 180°); only rows exactly there may fail
    flat = np.isclose(np.mod(ref + np.degrees(x) + 1e-9, 180.0), 1e-9, atol=1e-6)
    assert ok[~flat].all(), st.status[~ok & ~flat]
    assert all("singular" in s for s in st.status[~ok])
    assert np.allclose(P[ok & ~flat, iB] - P[ok & ~flat, iA], [scale, 0.0], atol=1e-9 * scale)
    # exactly at a flat position the two modes coincide; the position is known to √eps
    assert np.allclose(P[ok & flat, iB] - P[ok & flat, iA], [scale, 0.0], atol=1e-7 * scale)
    # a full turn returns to the reference
    assert np.allclose(P[36], P[0], atol=1e-9 * scale) and np.allclose(P[72], P[0], atol=1e-9 * scale)
    # every crossing noted: two a turn
    crossings = [n for n in st.notes if "branches meet" in n]
    assert len(crossings) == 4, st.notes


@pytest.mark.parametrize("ref", [30, 60, 90, 135])
@pytest.mark.parametrize("scale", [0.1, 1.0, 100.0])
def test_kite_turns_continuously_and_returns_to_the_reference(ref, scale):
    """Deltoid: frame = crank = a, coupler = rocker = b; A passes over O4 (a change point).
    Kept in its kite mode the follower turns once for every two turns of the crank (the
    Galloway mechanism; Hartenberg & Denavit, Kinematic Synthesis of Linkages, 1964, §3),
    so the motion is periodic in 720°, not 360°."""
    a, bb = 0.5 * scale, 1.2 * scale
    t = math.radians(ref)
    A = np.array([a * math.cos(t), a * math.sin(t)])
    O4 = np.array([a, 0.0])
    d = np.hypot(*(O4 - A))
    mid, h = 0.5 * (A + O4), math.sqrt(bb * bb - d * d / 4)
    n = np.array([-(O4 - A)[1], (O4 - A)[0]]) / d
    m = four_bar((0, 0), A, mid + h * n, O4)
    x = np.radians(np.arange(0.0, 720.5, 0.5))
    st = _solve(m, x)
    P = st.positions
    ok = st.ok
    assert ok.sum() >= len(x) - 2
    assert np.allclose(P[-1], P[0], atol=1e-9 * scale)
    assert not np.allclose(P[720], P[0], atol=1e-3 * scale)
    iB = st.joint_index("B")
    rows = np.flatnonzero(ok)
    steps = np.hypot(*np.diff(P[rows, iB], axis=0).T)
    assert steps.max() < 0.1 * scale                    # continuous: no jump to the other mode
    assert any("branches meet" in n for n in st.notes)


def _limits_law_of_cosines(a, b, c, d, side_ref):
    """Crank angles (frame along +x, crank a, coupler b, rocker c, frame d) where the
    diagonal |O4 − A| = b + c or |b − c|."""
    out = []
    for L in (b + c, abs(b - c)):
        cs = (a * a + d * d - L * L) / (2 * a * d)
        if abs(cs) <= 1:
            out += [math.acos(cs), -math.acos(cs)]
    return out


@settings(max_examples=40, deadline=None)
@given(zone=st.floats(1e-4, 1.0), lo_side=st.booleans(), ref=st.floats(0.15, 0.85))
def test_dead_zones_of_any_width_are_found_with_exact_limits(zone, lo_side, ref):
    """A non-Grashof four-bar whose crank stops in a dead zone ``zone`` degrees wide
    around θ = 0 (inner limit, |O4 − A| = b − c) or θ = π (outer limit, b + c).

    A dead zone sits where the diagonal is stationary, so its depth in the reach
    condition is ``a d (w/2)² / 2``: below about 1e-5° it is under the rounding of
    binary64 coordinates (docs/kinematics.md, "certified floor") and the limits'
    condition number is ``1 / (a d sin(w/2))``: the tolerance below is that bound."""
    a, d = 0.3, 1.0
    half = math.radians(zone) / 2
    theta_lim = half if lo_side else math.pi - half
    L = math.sqrt(a * a + d * d - 2 * a * d * math.cos(theta_lim))   # diagonal at the limit
    # near θ = 0 the diagonal is shortest: b − c = L there (and b + c never binds);
    # near θ = π it is longest: b + c = L there (and |b − c| never binds)
    b, c = (1.2, 1.2 - L) if lo_side else (0.8, L - 0.8)
    th0 = ref * (2 * math.pi - 2 * half) + half if lo_side else math.pi + half + ref * (2 * math.pi - 2 * half)
    th0 = math.atan2(math.sin(th0), math.cos(th0))
    A = np.array([a * math.cos(th0), a * math.sin(th0)])
    O4 = np.array([d, 0.0])
    dd = np.hypot(*(O4 - A))
    x = (b * b + dd * dd - c * c) / (2 * dd)
    u = (O4 - A) / dd
    B = A + x * u + math.sqrt(max(b * b - x * x, 0.0)) * np.array([-u[1], u[0]])
    m = four_bar((0, 0), A, B, O4)
    st = _solve(m, np.radians(np.arange(0.0, 360.0, 10.0)))
    # the motion cannot pass the zone: some requested inputs are beyond a limit
    from multiloop.kin.solve import plan_of, _chart
    ch = _chart(plan_of(m), True, np.zeros(1))
    assert ch.period is None, "a crank with a dead zone cannot turn fully"
    lims = sorted(np.mod(np.array(_limits_law_of_cosines(a, b, c, d, 1)) - th0, 2 * np.pi))
    hi = ch.hi
    lo = ch.lo + 2 * np.pi
    tol = max(math.radians(1e-9), 64 * np.finfo(float).eps * 4.0 / (a * d * math.sin(half)))
    assert min(abs(hi - v) for v in lims) < tol
    assert min(abs(lo - v) for v in lims) < tol
    assert lo - hi == pytest.approx(math.radians(zone), abs=2 * tol)
    beyond = (np.radians(np.arange(0.0, 360.0, 10.0)) > hi) & (np.radians(np.arange(0.0, 360.0, 10.0)) < lo)
    assert not st.ok[beyond].any()
    assert st.ok[~beyond].all()
    assert all("limit" in s for s in st.status[beyond])


# --------------------------------------------------------------------------- triads
def limited_triad():
    """The catalogue's Stephenson III triad mechanism with the rocker's frame pivot moved
    to (0.2, 0.12): its crank's motion is limited on both sides (a triad turning point)."""
    from multiloop.catalogue.named import load_named
    base = load_named("stephenson_3_triad")
    b = MechanismBuilder("limited_triad")
    for lk in base.links:
        b.add_link(lk.name, frame=lk.is_frame)
    for j in base.joints:
        at = (0.2, 0.12) if j.name == "O2" else j.at
        b.add_joint(j.name, "R", j.links, at=at)
    b.add_driver("O1")
    return b.build()


def _fine_triad_path(m, lo, hi, step_deg=0.05):
    """Independent route: every mode of the triad at each crank angle (the all-modes
    kernel), followed from the reference by nearest neighbour in 0.05° steps; returns
    the angle grid and the triad's inner pins along it."""
    from multiloop.kin.groups.triad import triad_modes
    from multiloop.topo.assur import decompose
    g = decompose(m).groups[0]
    lay = g.layout
    at = {j.name: np.array(j.at, float) for j in m.joints}
    O1 = at["O1"]

    def anchors(th):
        c, s = np.cos(th), np.sin(th)
        out = []
        for o in lay.outers:
            p = at[o] - O1
            moving = "crank" in m.joint(o).links
            out.append(O1 + (np.stack([c * p[0] - s * p[1], s * p[0] + c * p[1]], -1) if moving
                             else np.broadcast_to(p, (len(th), 2))))
        return np.stack(out, axis=1)

    b = np.array([at[i] for i in lay.inners])
    lengths = np.hypot(*(b - np.array([at[o] for o in lay.outers])).T)
    out = {}
    for end in (lo, hi):
        th = np.radians(np.arange(0.0, np.degrees(end), np.sign(end) * step_deg))
        modes = triad_modes(anchors(th), b, lengths)
        P, cur = [], b
        for n in range(len(th)):
            cand = modes.P[n][np.isfinite(modes.theta[n])]
            cur = cand[np.argmin(np.sum((cand - cur) ** 2, axis=(1, 2)))]
            P.append(cur)
        out[end] = (th, np.array(P))
    return out, lay.inners


def test_triad_is_reached_from_anywhere_in_any_order():
    m = limited_triad()
    from multiloop.kin.solve import plan_of, _chart
    ch = _chart(plan_of(m), True, np.zeros(1))
    assert ch.period is None and np.isfinite(ch.lo) and np.isfinite(ch.hi)
    lo, hi = ch.lo, ch.hi
    ref, inner = _fine_triad_path(m, lo, hi)
    rng = np.random.default_rng(21)
    inside = rng.uniform(lo, hi, 25)
    near = np.array([lo + 1e-6, hi - 1e-6, lo + 1e-3, hi - 1e-3, 1e-5, -1e-5])
    outside = np.array([hi + 1e-4, lo - 1e-4, hi + 0.5, lo - 0.5])
    x = np.concatenate([inside, near, outside])
    rng.shuffle(x)
    for order in (x, x[::-1]):
        st = _solve(m, order)
        is_in = (order >= lo) & (order <= hi)
        assert st.ok[is_in].all(), st.status[is_in & ~st.ok]
        assert not st.ok[~is_in].any()
        assert all("limit" in s for s in st.status[~is_in])
    # at the fine path's own angles, asked in random order: every pin to 1e-9 of the size
    for end in (lo, hi):
        th, P = ref[end]
        pick = th[:: max(1, len(th) // 15)]
        st2 = _solve(m, pick[rng.permutation(len(pick))])
        want = P[:: max(1, len(th) // 15)]
        order2 = np.argsort(st2.inputs[:, 0]) if end > 0 else np.argsort(-st2.inputs[:, 0])
        got = np.stack([st2.positions[order2][:, st2.joint_index(i)] for i in inner], axis=1)
        assert np.allclose(got, want, atol=1e-9 * 0.2)


def test_a_batch_that_jumps_between_the_limits_costs_one_path(monkeypatch):
    """Issue 36, smaller faults: 96 triad inputs alternating between 1e-9 and 1e-2 of the
    range inside either limit.  The batch walked reference → x₀ → x₁ … and approached a
    limit 96 times, the walk re-evaluating its whole path each round (25–36 s CPU; then
    "continuation did not settle").  Within the certified range a pose depends only on
    its input: the batch equals the inputs solved one by one, and it evaluates no more
    samples than the two sorted paths to the deepest inputs solved one by one."""
    import multiloop.kin.solve as ks
    from multiloop.kin.solve import _chart, plan_of
    m = limited_triad()
    ch = _chart(plan_of(m), True, np.zeros(1))
    rng = np.random.default_rng(0)
    eps = 10 ** rng.uniform(-9, -2, 96) * (ch.hi - ch.lo)
    x = np.where(np.arange(96) % 2 == 0, ch.lo + eps, ch.hi - eps)
    rows = []
    real_run = ks._run

    def counted(sp, X, *a, **kw):
        rows.append(len(X))
        return real_run(sp, X, *a, **kw)
    monkeypatch.setattr(ks, "_run", counted)
    batch = solve(m, x)
    n_batch = sum(rows)
    rows.clear()
    ends = [solve(m, np.array([v])) for v in (x.min(), x.max())]
    n_ends = sum(rows)
    monkeypatch.setattr(ks, "_run", real_run)
    assert batch.ok.all()
    assert n_batch <= 2 * n_ends, (n_batch, n_ends)
    one = [solve(m, np.array([v])) for v in x]
    assert np.allclose(batch.positions, np.concatenate([s.positions for s in one]), atol=1e-9)
    assert all(s.ok.all() for s in ends)


def test_triad_limits_are_turning_points():
    """At a limit the triad is singular: its three leg lines are concurrent, so every
    triad transmission angle is zero there (to the bracket's √ width)."""
    m = limited_triad()
    from multiloop.kin.solve import plan_of, _chart
    from multiloop.kin.check.transmission import angle_specs, angle_values
    from multiloop.topo.assur import decompose
    ch = _chart(plan_of(m), True, np.zeros(1))
    specs = angle_specs(decompose(m))
    for x in (ch.lo, ch.hi):
        st = _solve(m, np.array([x]))
        assert st.ok.all(), st.status
        ang = angle_values(st, specs)
        assert np.all(ang < 0.01), ang


# --------------------------------------------------------------------------- check
def _check(m):
    from multiloop.kin.check import check
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return check(m)


def test_check_reads_extremes_through_change_points():
    """Parallelogram (tests/data/branches): flat positions at 120° and 300° from the
    reference, where the transmission angle is exactly 0° and 180°; crank = rod
    crank-slider: the bifurcation at 225° has the rod normal to the guide (90°)."""
    from pathlib import Path
    from multiloop.topo.io import load
    data = Path(__file__).parent / "data" / "branches"
    rep = _check(load(data / "parallelogram.toml"))
    dc = rep.drivers[0]
    e = dc.angles[0].extreme
    assert e.min == pytest.approx(0.0, abs=1e-5) and e.max == pytest.approx(180.0, abs=1e-5)
    assert math.degrees(e.at_min) == pytest.approx(300.0, abs=1e-6)
    assert math.degrees(e.at_max) == pytest.approx(120.0, abs=1e-6)
    assert sorted(round(math.degrees(x), 6) for x, _ in dc.branch_points) == [120.0, 300.0]
    assert any("transmission angle at B falls to 0.000°" in v for v in rep.verdict)
    rep = _check(load(data / "crank_equals_rod.toml"))
    e = rep.drivers[0].angles[0].extreme
    assert e.max == pytest.approx(90.0, abs=1e-5)
    assert any("pressure angle at B reaches 90.000°" in v for v in rep.verdict)


def dead_zone_at_pi(zone_deg, th0, a=0.3, d=1.0, b=0.8):
    """A non-Grashof four-bar (frame d along x, crank a at ``th0``, coupler b) whose
    rocker c makes b + c equal the diagonal at θ = π ∓ half the zone: the crank stops in
    a dead zone ``zone_deg`` wide around θ = π (law of cosines)."""
    half = math.radians(zone_deg) / 2
    c = math.sqrt(a * a + d * d + 2 * a * d * math.cos(half)) - b
    A = np.array([a * math.cos(th0), a * math.sin(th0)])
    O4 = np.array([d, 0.0])
    dd = np.hypot(*(O4 - A))
    x = (b * b + dd * dd - c * c) / (2 * dd)
    u = (O4 - A) / dd
    return four_bar((0, 0), A, A + x * u + math.sqrt(b * b - x * x) * np.array([-u[1], u[0]]), O4)


def test_check_finds_a_dead_zone_narrower_than_its_grid():
    """A 0.37° dead zone (the check's grid step is 0.5°): limited motion, limits by the
    law of cosines, the transmission angle reaches 180° there, the ratio is unbounded."""
    th0 = math.radians(40.0)
    half = math.radians(0.37) / 2
    m = dead_zone_at_pi(0.37, th0)
    dc = _check(m).drivers[0]
    assert not dc.full_rotation
    got = sorted(dc.limits)
    assert got[1] == pytest.approx(math.pi - half - th0, abs=math.radians(1e-9))
    assert got[0] == pytest.approx(math.pi + half - th0 - 2 * math.pi, abs=math.radians(1e-9))
    assert dc.angles[0].extreme.max == pytest.approx(180.0, abs=1e-4)
    assert len(dc.ratio_unbounded_at) == 2


def test_check_of_a_limited_triad_is_exact_at_its_turning_points():
    m = limited_triad()
    from multiloop.kin.solve import motion_events
    ev = motion_events(m)
    dc = _check(m).drivers[0]
    assert sorted(dc.limits) == pytest.approx(sorted([ev.lo, ev.hi]), abs=1e-10)
    for a in dc.angles:
        assert a.extreme.min < 0.01                 # singular (concurrent legs) at a limit
    assert len(dc.ratio_unbounded_at) == 2


@pytest.mark.parametrize("offset", [(1e6, 1e6), (-3e5, 7e5)])
def test_triad_mechanism_far_from_the_origin_moves_as_at_it(offset):
    """Issue of the field: the triad mechanism moved 1e6 m away failed 35 of 36 positions;
    the triad (and class IV) kernels now solve about their reference anchor."""
    from multiloop.catalogue.named import load_named
    m1 = load_named("stephenson_3_triad")
    b = MechanismBuilder("far")
    for lk in m1.links:
        b.add_link(lk.name, frame=lk.is_frame)
    for j in m1.joints:
        b.add_joint(j.name, "R", j.links, at=(j.at[0] + offset[0], j.at[1] + offset[1]))
    b.add_driver("O1")
    q = np.radians(np.arange(0.0, 360.0, 10.0))
    ref, st = _solve(m1, q), _solve(b.build(), q)
    assert st.ok.all() and ref.ok.all()
    np.testing.assert_allclose(st.positions - np.array(offset), ref.positions, atol=1e-9)


def test_check_velocity_ratio_is_exact_not_the_grids():
    """Crank = rod crank-slider: the slider's rate is |dx/dθ| = 2 r |sin θ| (x = 2 r cos θ
    on the reference mode, r = 50 and θ = 45° + input), largest exactly at the two
    bifurcations, 45° and 225° from the reference, where the crank is vertical."""
    from pathlib import Path
    from multiloop.topo.io import load
    m = load(Path(__file__).parent / "data" / "branches" / "crank_equals_rod.toml")
    r = math.hypot(*m.joint("A").at)
    dc = _check(m).drivers[0]
    e = dc.ratio_extreme
    assert e.max == pytest.approx(2 * r, rel=1e-6)
    assert min(abs(math.degrees(e.at_max) - v) for v in (45.0, 225.0)) < 1e-6
    assert e.min == pytest.approx(0.0, abs=1e-9 * r)


def test_a_dead_zone_below_the_floor_is_a_change_point():
    """The stated floor (docs/kinematics.md): a 5e-6° dead zone violates the reach by
    ~1e-18 relative, below binary64's rounding; it is reported as a change point, and
    the motion stays continuous through it."""
    th0 = math.radians(40.0)
    m = dead_zone_at_pi(5e-6, th0)
    from multiloop.kin.solve import motion_events
    ev = motion_events(m)
    assert ev.period is not None
    assert any(abs(math.remainder(x - (math.pi - th0), 2 * math.pi)) < 1e-6 for x, _ in ev.crossings)


def test_a_limit_is_bracketed_at_its_margins_secant_in_few_evaluations():
    """kin.continuation: a limit's bracket is sampled at the secant root of the reach
    margin as well as 128-fold, so a smooth margin ``(L − s)(1 + c s)`` (c in [−0.9, 3])
    walked from 0 is bracketed at L to rounding in 7.5 evaluations on average (the
    128-fold zoom alone, with its last zoom of 64 points a call, took 10.8: this test
    fails on it), and the bracket holds the root (``a`` short of L by at most the
    margin's rounding over its slope)."""
    from multiloop.kin.continuation import Probe, walk
    rng = np.random.default_rng(1)
    counts = []
    for _ in range(40):
        L, c = rng.uniform(0.05, 0.95), rng.uniform(-0.9, 3.0)
        calls = []

        def evaluate(X, signs, L=L, c=c, calls=calls):
            s = X[:, 0]
            margin = (L - s) * (1.0 + c * s)
            calls.append(s.size)
            lip = np.zeros((s.size, 1, 2))
            lip[:, 0, 0] = (1.0 + 2.0 * abs(c)) * s        # |Δ margin| ≤ |Δ lip| on [0, 1]
            return {1: Probe(margin > 0, margin=margin, lip=lip, tol=np.full(s.size, 1e-15))}
        a, b, group = walk(evaluate, np.linspace(0.0, 1.0, 51)[:, None], [1]).block
        assert group == 1 and a < b
        assert -1e-15 <= L - a <= 1e-14 and abs(b - L) <= 1e-14
        counts.append(len(calls))
    assert np.mean(counts) <= 8.5, counts


def test_a_grid_that_touches_a_limit_on_every_row_settles():
    """A multi-driver grid whose values reach an assembly limit exactly (the excavator's
    usable ranges, ends included) touches it once a row: every touch is a crossing of the
    last group, resolved in one round of the walk (it used to take one round each and
    give up with 'continuation did not settle')."""
    from multiloop.catalogue.named import load_named
    from multiloop.kin.check import check
    m = load_named("excavator")
    # 20 x 20 rows of the bucket cylinder, each from one end of its usable range to the
    # other: 400 touches of the bucket linkage's limit
    axes = [np.linspace(lo, hi, n) for (lo, hi), n in zip((dc.usable for dc in check(m).drivers), (20, 20, 2))]
    X = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        state = solve(m, X)
    from multiloop.kin.result import Status
    at_limit = X[:, 2] == axes[2][-1]          # the bucket linkage's toggle: its branches meet
    assert state.ok[~at_limit].all()
    assert set(state.codes[at_limit].tolist()) <= {int(Status.OK), int(Status.SINGULAR)}


def test_an_unreachable_slide_names_the_limit_it_lies_beyond():
    """A one-cylinder boom (s in [sqrt 2 - 2, sqrt 2]): an input past the upper end names
    the upper limit, one past the lower end the lower (the slide's limits used to be
    picked by a modular 'nearer' rule meant for turns, which swapped them)."""
    from test_ranges import BOOM, S_HI as hi, S_LO as lo     # the boom of the range tests, no range

    from multiloop.kin.result import Status
    from multiloop.topo.io import loads
    m = loads(BOOM.replace("RANGE", ""), "toml")
    state = solve(m, np.array([0.0, 1.0, 1.5, -0.7]))
    assert state.codes.tolist()[:2] == [0, 0] and set(state.codes[2:].tolist()) == {int(Status.LIMIT)}
    assert f"limit at {hi:.6g} m" in state.status[2] and f"limit at {lo:.6g} m" in state.status[3]


def _lifted_boom():
    """A boom pinned at the origin, lifted by a cylinder from (1, 0) to (1, 1) with no
    stroke range: the cylinder side L of the triangle base–end–foot reaches |AC| ± l,
    i.e. the stroke limits √2 − 2 and √2, where the triangle is flat (law of cosines)."""
    b = MechanismBuilder("boom")
    b.add_link("frame", frame=True)
    for lk in ("boom", "barrel", "rod"):
        b.add_link(lk)
    b.add_joint("foot", "R", ("frame", "boom"), at=(0.0, 0.0))
    b.add_joint("base", "R", ("frame", "barrel"), at=(1.0, 0.0))
    b.add_joint("slide", "P", ("barrel", "rod"), at=(1.0, 0.5), axis=(0.0, 1.0))
    b.add_joint("end", "R", ("rod", "boom"), at=(1.0, 1.0))
    b.add_driver("slide")
    return b.build()


def test_angles_at_located_singular_points_are_their_exact_values():
    """Issue 36 part 2, 3: at a located limit or crossing the angle is known exactly (0°
    or 180° for a flat triangle, 90° for a rod normal to its guide, 0° for a triad's
    concurrent legs), not read slightly inside it (5.8e-6°, 179.9999935°, 89.9999943°,
    1.4e-3°, 0.009° before)."""
    from pathlib import Path
    from multiloop.topo.io import load
    data = Path(__file__).parent / "data" / "branches"
    tol = 1e-9
    e = _check(load(data / "parallelogram.toml")).drivers[0].angles[0].extreme
    assert abs(e.min - 0.0) <= tol and abs(e.max - 180.0) <= tol
    assert math.degrees(e.at_min) == pytest.approx(300.0, abs=1e-6)
    e = _check(load(data / "crank_equals_rod.toml")).drivers[0].angles[0].extreme
    assert abs(e.max - 90.0) <= tol
    assert math.degrees(e.at_max) == pytest.approx(225.0, abs=1e-6)
    for a in _check(limited_triad()).drivers[0].angles:
        assert abs(a.extreme.min - 0.0) <= tol
    e = _check(dead_zone_at_pi(0.37, math.radians(40.0))).drivers[0].angles[0].extreme
    assert abs(e.max - 180.0) <= tol
    dc = _check(_lifted_boom()).drivers[0]
    low = min(dc.limits)                  # (√2 lies beyond the check's search extent)
    assert low == pytest.approx(math.sqrt(2.0) - 2.0, abs=1e-9)
    (a,) = [a for a in dc.angles if a.joint == "end"]
    assert a.extreme.min == 0.0 and a.extreme.at_min == low     # flat: the end folds onto the base


def test_a_kite_lists_its_change_point_once():
    """The kite's motion is periodic in two turns: it meets its change point at 300° on
    both, the same crank angle on the turn, listed once (was twice)."""
    a, bb, t = 0.5, 1.2, math.radians(60.0)
    A, O4 = np.array([a * math.cos(t), a * math.sin(t)]), np.array([a, 0.0])
    d = np.hypot(*(O4 - A))
    n = np.array([-(O4 - A)[1], (O4 - A)[0]]) / d
    m = four_bar((0, 0), A, 0.5 * (A + O4) + math.sqrt(bb * bb - d * d / 4) * n, O4)
    dc = _check(m).drivers[0]
    assert [round(math.degrees(x), 6) for x, _ in dc.branch_points] == [300.0]
