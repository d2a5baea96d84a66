"""The compiled plans (kin.kernel) against their oracle, the NumPy path.

Every catalogue mechanism whose plan the kernel covers, and Hypothesis-generated dyad
mechanisms (each dyad kind after a crank, dimensions perturbed, inputs over a turn and
next to the motion's limits): positions within 1e-12 of the mechanism's size, the same
statuses (the kernel's own codes, before any NumPy re-solve), the same NaN pattern.
A plan the kernel does not cover (triad, class IV) falls back to the NumPy path.  The
compiled code survives in numba's disk cache: a second process loads it without
compiling (``dispatcher.stats``; no test reads a clock).
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import warnings

import numpy as np
import pytest

numba = pytest.importorskip("numba")

from hypothesis import assume, given, strategies as st  # noqa: E402

from multiloop.catalogue.named import load_named, names  # noqa: E402
from multiloop.kin import kernel  # noqa: E402
from multiloop.kin import solve as solve_mod  # noqa: E402
from multiloop.kin.solve import motion_events, plan_of, solve  # noqa: E402
from multiloop.topo.errors import LinkageError  # noqa: E402
from multiloop.topo.formats import dumps_mechanism, loads_mechanism  # noqa: E402
from multiloop.topo.model import JointKind  # noqa: E402

DYADS = ("dyad_rrr", "dyad_rrp", "dyad_rpr", "dyad_prp", "dyad_rpp", "four_bar")


def _inputs(m, sp, n=241):
    """A sweep of every driver over ±1.5 turns (R) or ±1.5 sizes (P), drivers out of phase."""
    t = np.linspace(-1.0, 1.0, n)
    cols = [t * (3 * np.pi if m.joint(d.joint).kind is JointKind.R else 1.5 * sp.size) * (1 - 0.3 * k)
            for k, d in enumerate(m.drivers)]
    return np.stack(cols, axis=1)


def _raw_agree(m, X, signs=None):
    """The kernel's own poses and codes equal the NumPy path's (no re-solve)."""
    sp = plan_of(m)
    steps = list(range(len(sp.steps)))
    ref = solve_mod._numpy_run(sp, X, steps, signs or {}, True)
    ref.G.unset_to_nan()
    Zr = ref.G.to_Z()
    Pr = solve_mod._points(sp, ref.G, "joints")
    G = solve_mod.Poses(sp, X.shape[0])
    kr = kernel.run_positions(kernel.kernel_plan(sp), X, steps, signs or {}, G.T, points=True)
    fail, P = kr.fail, kr.points
    assert kr.failed == np.count_nonzero(fail)
    G.adopt([i for k in steps for i in sp.steps[k].unknown], kr.C, kr.S, kr.derived)
    G.unset_to_nan()
    Zk = G.to_Z()
    np.testing.assert_array_equal(fail, ref.code)
    np.testing.assert_array_equal(np.isnan(Zk), np.isnan(Zr))
    ok = ~np.isnan(Zr)
    scale = np.where(np.arange(3) < 2, sp.size, 1.0)
    assert np.all(np.abs(Zk - Zr)[ok] <= 1e-12 * np.broadcast_to(scale, Zr.shape)[ok])
    Pk = P[:, :m.n_joints]
    np.testing.assert_array_equal(np.isnan(Pk), np.isnan(Pr))
    assert np.nanmax(np.abs(Pk - Pr), initial=0.0) <= 1e-12 * sp.size


def _same_states(m, X, **kw):
    """``solve`` with and without the kernel: the same results."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with kernel.using("off"):
            a = solve(m, X, **kw)
        with kernel.using("on"):
            b = solve(m, X, **kw)
    size = plan_of(m).size
    np.testing.assert_array_equal(a.codes, b.codes)
    assert list(a.status) == list(b.status)
    assert a.notes == b.notes
    for u, v in ((a.positions, b.positions), (a.poses[..., :2], b.poses[..., :2])):
        np.testing.assert_array_equal(np.isnan(u), np.isnan(v))
        assert np.nanmax(np.abs(u - v), initial=0.0) <= 1e-12 * size
    np.testing.assert_allclose(a.angles, b.angles, rtol=0, atol=1e-12)


def _covered(m) -> bool:
    sp = plan_of(m)
    return kernel.kernel_plan(sp).covers(range(len(sp.steps)))


def _catalogue():
    out = []
    for nm in names():
        try:
            m = load_named(nm)
            plan_of(m)
        except LinkageError:
            continue
        out.append(nm)
    return out


@pytest.mark.parametrize("name", _catalogue())
def test_catalogue_against_numpy(name):
    m = load_named(name)
    sp = plan_of(m)
    X = _inputs(m, sp)
    if not _covered(m):                    # a triad or class IV group: the NumPy path solves it
        kp = kernel.kernel_plan(sp)         # (a triad's compiled tracker serves batches of designs only)
        assert kp.codes.min() == -1 or kp.tracked.any()
        with kernel.using("on"):
            assert solve_mod._compiled_run(sp, X, range(len(sp.steps)), {}, True) is None
        return
    _raw_agree(m, X)
    x = X if len(m.drivers) > 1 else X[:, 0]
    _same_states(m, x)
    _same_states(m, x, assemble=True)
    _same_states(m, x, outputs=[m.joint_names[-1], m.link_names[-1], *(p.name for p in m.points[:1])])


def test_catalogue_coverage():
    """Every catalogue mechanism of closed-form dyads, drivers and actuators is covered."""
    covered = {nm: _covered(load_named(nm)) for nm in _catalogue()}
    assert {nm for nm, c in covered.items() if not c} <= {"stephenson_3", "stephenson_3_triad"}
    assert sum(covered.values()) >= 15


def test_branch_factors_per_row():
    """Per-row branch factors (the continuation's sign flips) reach each step."""
    m = load_named("four_bar")
    sp = plan_of(m)
    X = _inputs(m, sp)
    k = next(i for i, s in enumerate(sp.steps) if s.solver == "dyad")
    _raw_agree(m, X, {k: np.where(np.arange(len(X)) % 3 == 0, -1.0, 1.0)})


def _perturbed(base: str, moves, turns):
    """The catalogue mechanism ``base`` with its joints moved by ``moves`` (× its size) and
    its guides turned by ``turns`` (rad)."""
    m = load_named(base)
    doc = json.loads(dumps_mechanism(m, "x.json"))
    size = plan_of(m).size
    for j, (dx, dy), a in zip(doc["joint"], moves, turns):
        if j["name"] != m.joint_names[0]:        # the driver's pivot stays
            j["at"] = [j["at"][0] + dx * size, j["at"][1] + dy * size]
        if "axis" in j:
            c, s = np.cos(a), np.sin(a)
            j["axis"] = [c * j["axis"][0] - s * j["axis"][1], s * j["axis"][0] + c * j["axis"][1]]
    return loads_mechanism(json.dumps(doc), "x.json")


_move = st.tuples(st.floats(-0.3, 0.3), st.floats(-0.3, 0.3))


@given(st.sampled_from(DYADS), st.lists(_move, min_size=8, max_size=8),
       st.lists(st.floats(-0.6, 0.6), min_size=8, max_size=8))
def test_dyad_mechanisms_against_numpy(base, moves, turns):
    try:
        m = _perturbed(base, moves, turns)
        sp = plan_of(m)
    except LinkageError:                      # a singular or degenerate reference
        assume(False)
    X = _inputs(m, sp, 181)
    _raw_agree(m, X)
    _same_states(m, X[:, 0], assemble=True)
    ev = motion_events(m)
    ends = [v for v in (ev.lo, ev.hi) if np.isfinite(v)] if ev is not None else []
    near = np.concatenate([e + s * np.array([0.0, 1e-13, 1e-10, 1e-7, 1e-4, 1e-2]) for e in ends
                           for s in (-1.0, 1.0)]) if ends else np.zeros(1)
    _raw_agree(m, near[:, None])              # next to the limits: in and out of reach
    _same_states(m, near)


def test_cache_survives_a_second_process(tmp_path):
    """The second process loads the kernel from numba's disk cache, compiling nothing."""
    code = ("import numpy as np; from multiloop.kin import kernel, _kernel_nb as nb;"
            "from multiloop.kin.solve import solve; from multiloop.catalogue.named import load_named;"
            "\nwith kernel.using('on'): solve(load_named('four_bar'), np.linspace(0, 6, 50))\n"
            "s = nb.solve_positions.stats; print(sum(s.cache_hits.values()), sum(s.cache_misses.values()))")
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    runs = [subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
            for _ in range(2)]
    first, second = ([int(v) for v in r.stdout.split()] for r in runs)
    assert first == [0, 1]                    # compiled (and written to the cache)
    assert second == [1, 0]                   # loaded from it
    assert any(p.suffix == ".nbc" for p in tmp_path.rglob("*"))


def test_kernel_not_loaded_for_small_batches():
    """In mode "auto" a small batch in a fresh process does not import numba (the command
    line's cold start)."""
    code = ("import sys, numpy as np; from multiloop.kin.solve import solve;"
            "from multiloop.catalogue.named import load_named;"
            "solve(load_named('four_bar'), np.linspace(0, 6, 360)); print('numba' in sys.modules)")
    env = {k: v for k, v in os.environ.items() if k != "MULTILOOP_KERNEL"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False"]


def test_arctan2_within_one_ulp():
    """The kernel's arctan2 (fdlibm's) against NumPy's, with the signed zeros."""
    from multiloop.kin.groups.base import arctan2
    rng = np.random.default_rng(3)
    y, x = (rng.standard_normal(3000) * 10.0 ** rng.uniform(-6, 6, 3000) for _ in range(2))
    ours = np.array([arctan2(a, b) for a, b in zip(y, x)])
    ref = np.arctan2(y, x)
    assert np.all(np.abs(ours - ref) <= np.spacing(np.abs(ref)))
    for a, b in ((0.0, -1.0), (-0.0, -1.0), (0.0, 0.0), (-0.0, -0.0), (1.0, 0.0), (-2.0, -0.0), (1.0, -1.0)):
        assert arctan2(a, b) == np.arctan2(a, b)
    assert np.isnan(arctan2(np.nan, 1.0))


def _sincos_cases():
    """Inputs for the kernel's sincos: a turn and more, far arguments, the multiples of
    pi/2 to 2**20 (where the reduction cancels) with their neighbours, signed zeros,
    subnormals, the range's end and beyond, infinities and NaN."""
    rng = np.random.default_rng(5)
    k = np.concatenate([np.arange(-3000, 3001), rng.integers(1, 2 ** 20, 4000), -rng.integers(1, 2 ** 20, 4000)])
    near = (k * (np.pi / 2))[:, None] + np.spacing(k * (np.pi / 2))[:, None] * np.arange(-2, 3)
    return np.concatenate([rng.uniform(-7, 7, 20000), rng.uniform(-1.7e6, 1.7e6, 20000), near.ravel(),
                           [0.0, -0.0, 5e-324, -5e-324, 1e-300, np.pi / 4, -np.pi / 4, 1647099.0, -1647099.0,
                            1647100.0, 1e22, -1e300, np.inf, -np.inf, np.nan]])


def test_sincos_within_one_ulp_compiled_and_in_python():
    """The solve route's cos and sin (fdlibm's reduction and polynomials, in SIMD
    registers) against NumPy's within 1 ulp, the signed zeros and NaN kept; the compiled
    row and the plain Python function give the same bits (one algorithm)."""
    from multiloop.kin import _kernel_nb as nb
    from multiloop.kin.groups.base import SINCOS_MEDIUM, sincos_medium
    x = _sincos_cases()
    c, s = np.empty_like(x), np.empty_like(x)
    for sign in (1.0, -1.0):
        nb._sincos_row(x, sign, c, s)
        with np.errstate(invalid="ignore"):                   # (cos and sin of infinities)
            rc, rs = np.cos(sign * x), np.sin(sign * x)
        assert np.array_equal(np.isnan(c), np.isnan(rc)) and np.array_equal(np.isnan(s), np.isnan(rs))
        ok = np.isfinite(rc)
        assert np.all(np.abs(c[ok] - rc[ok]) <= np.spacing(np.abs(rc[ok])))
        assert np.all(np.abs(s[ok] - rs[ok]) <= np.spacing(np.abs(rs[ok])))
        assert np.array_equal(np.signbit(s[x == 0]), np.signbit(rs[x == 0]))   # sin(-0.0) is -0.0
    nb._sincos_row(x, 1.0, c, s)
    inside = np.flatnonzero(np.abs(x) <= SINCOS_MEDIUM)
    pick = np.random.default_rng(6).choice(inside, 3000, replace=False)
    py = np.array([sincos_medium(float(v)) for v in x[pick]])
    np.testing.assert_array_equal(py, np.stack([c[pick], s[pick]], axis=1))


@given(st.floats(-1647099.0, 1647099.0))
def test_sincos_property(x):
    """Hypothesis: any argument in its range, the plain Python sincos within 1 ulp of libm's."""
    from multiloop.kin.groups.base import sincos_medium
    c, s = sincos_medium(x)
    assert abs(c - np.cos(x)) <= np.spacing(abs(np.cos(x))) and abs(s - np.sin(x)) <= np.spacing(abs(np.sin(x)))


def test_the_compiled_route_refuses_what_the_numpy_path_refuses():
    """The lean compiled route (a full turn's chart) checks its inputs in the kernel: NaN
    and infinities get the NumPy path's messages, the first bad index named; so do a
    slider's, and its runaway slide."""
    from multiloop.topo.errors import InputError
    from multiloop.kin.solve import MAX_SLIDE
    from tests.common import slide_driven
    slider = slide_driven()
    for m, x in ((load_named("four_bar"), np.linspace(0.0, 6.0, 360)), (slider, np.linspace(-0.2, 0.2, 50))):
        with kernel.using("on"):
            solve(m, x)                                   # the chart cached: the lean route next
            lean = solve_mod._compiled_motion(plan_of(m), x.reshape(-1, 1)) is not None
            assert lean == (m is not slider)              # (a stroke's chart has its limits)
            for bad, got in ((np.nan, "nan"), (np.inf, "inf"), (-np.inf, "-inf")):
                y = x.copy()
                y[7] = bad
                want = rf"^inputs\[7, 0\] \(driver '{m.drivers[0].joint}'\): expected finite numbers, got {got}$"
                with pytest.raises(InputError, match=want):
                    solve(m, y)
            assert np.array_equal(solve(m, x).positions, solve(m, x.copy()).positions)
    with kernel.using("on"), pytest.raises(InputError, match="input of the P driver S: expected a slide of at most"):
        solve(slider, [0.0, 2 * MAX_SLIDE * plan_of(slider).size])


def test_modes():
    with pytest.raises(ValueError):
        with kernel.using("fast"):
            pass
    with kernel.using("off"):
        assert not kernel.wanted(10 ** 9)
    with kernel.using("on"):
        assert kernel.wanted(1)
        with kernel.using("off"):                        # nested blocks restore their outer mode
            assert kernel.mode() == "off" and not kernel.is_default()
        assert kernel.mode() == "on"
    assert kernel.is_default() == ("MULTILOOP_KERNEL" not in os.environ)


def test_a_mode_block_is_its_threads_own():
    """Two threads in overlapping ``using`` blocks, left in the order that restored the
    other's mode when the mode was one for the process (a Dask worker's two tasks, the
    page's check beside a synthesis): each sees its own mode, the rest the default, and
    the default is back once both have left."""
    import threading
    default = kernel.mode(), kernel.compiled_batches()
    a_in, b_in, a_out, main_read = threading.Event(), threading.Event(), threading.Event(), threading.Event()
    seen = {}

    def a():
        with kernel.using("on"):
            a_in.set()
            b_in.wait(10)
            seen["a"] = kernel.mode()
        a_out.set()

    def b():
        a_in.wait(10)
        with kernel.using("off"):
            b_in.set()
            a_out.wait(10)
            main_read.wait(10)          # the main thread's mode read inside both blocks (not raced)
            seen["b"] = kernel.mode(), kernel.compiled_batches()
            seen["main"] = main_mode[0]
    main_mode = [None]
    ta, tb = threading.Thread(target=a), threading.Thread(target=b)
    ta.start(), tb.start()
    b_in.wait(10)
    main_mode[0] = kernel.mode()
    main_read.set()
    ta.join(10), tb.join(10)
    assert seen == {"a": "on", "b": ("off", False), "main": default[0]}
    assert (kernel.mode(), kernel.compiled_batches()) == default


def test_by_default_a_loaded_kernel_changes_no_bit():
    """The kernel agrees with the NumPy path to rounding only, so it is opt-in: with it
    loaded in the process, the default mode still gives the NumPy path's bits (the same
    as a fresh process, the command line and the page)."""
    assert kernel.load() is not None
    m = load_named("four_bar")
    x = np.radians(np.arange(0.0, 360.0, 0.5))
    assert kernel.mode() == os.environ.get("MULTILOOP_KERNEL", "off") == "off"
    default = solve(m, x)
    with kernel.using("off"):
        numpy_path = solve(m, x)
    with kernel.using("on"):
        compiled = solve(m, x)
    assert np.array_equal(default.positions, numpy_path.positions, equal_nan=True)
    np.testing.assert_allclose(compiled.positions, numpy_path.positions, rtol=0, atol=1e-12 * plan_of(m).size)


def test_the_compiled_routes_state_is_frozen_all_the_way_down():
    """The compiled route builds its state with ``KinematicState.frozen_from`` (arrays
    frozen in place, a shared read-only "ok" status): every array is read-only, none can
    be made writable again, and a missing field is refused."""
    from multiloop.kin.state import KinematicState
    m = load_named("four_bar")
    x = np.linspace(0.0, 2 * np.pi, 360, endpoint=False)
    with kernel.using("on"):
        solve(m, x)
        a, b = solve(m, x), solve(m, x, outputs=["B"])
    assert a.status is b.status                              # shared, so it must stay read-only
    for st in (a, b):
        for name, v in vars(st).items():
            if isinstance(v, np.ndarray):
                assert not v.flags.writeable, name
                if name == "inputs":         # a view of the caller's own array, as on every route
                    continue
                with pytest.raises(ValueError):
                    v.flags.writeable = True
    assert np.isnan(b.positions[:, m.joint_names.index("A")]).all() and np.isfinite(b.positions[:, 2]).all()
    with pytest.raises(TypeError, match="expected the fields"):
        KinematicState.frozen_from(mechanism=m, inputs=x[:, None])
