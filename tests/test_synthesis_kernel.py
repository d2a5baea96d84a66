"""Design batches and the synthesis objective on the compiled kernels, against their
oracle, the NumPy route.

* :func:`kin.design.solve_designs` by the kernel (``kin.kernel.run_designs``): every
  catalogue mechanism the kernel covers, designs perturbed around the start (some
  failing), and Hypothesis populations of each dyad kind: poses within 1e-12 of the
  size, the same ``ok`` pattern.
* The free-timing matching (``catalogue/dimensional/_match_nb.py``) against
  :meth:`Problem.free_costs`'s NumPy route: path (one turn; a slider's two-sided
  grid), function (an angle, wrapped) and motion targets, every walk, reached and
  unreached samples: equal costs.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

numba = pytest.importorskip("numba")

from hypothesis import given, settings, strategies as st  # noqa: E402

from multiloop.catalogue.dimensional import Constraints, Evaluator, Problem, design_space  # noqa: E402
from multiloop.catalogue.dimensional.targets import FunctionTarget, MotionTarget  # noqa: E402
from multiloop.catalogue.dimensional.synthesise import path_target  # noqa: E402
from multiloop.catalogue.named import load_named, names  # noqa: E402
from multiloop.kin import kernel  # noqa: E402
from tests.common import both_routes, design_population, routes_agree  # noqa: E402
from multiloop.kin.design import solve_designs  # noqa: E402
from multiloop.kin.solve import plan_of, solve  # noqa: E402
from multiloop.topo.errors import LinkageError  # noqa: E402
from multiloop.topo.formats import loads_mechanism  # noqa: E402


def _covered():
    out = []
    for nm in names():
        try:
            sp = plan_of(load_named(nm))
        except LinkageError:
            continue
        if kernel.kernel_plan(sp).covers(range(len(sp.steps))):
            out.append(nm)
    return out


def _at(s, name):
    """The positions (N, 2) of joint or tracer point ``name`` in a solved state."""
    if name in s.point_names:
        return s.point_positions[:, s.point_index(name)]
    return s.positions[:, s.joint_index(name)]


def _inputs(m, N):
    t = np.linspace(-1.0, 1.0, N)
    cols = [t * (np.pi if m.is_rotary(k) else 0.5 * m.size) * (1 - 0.3 * k) for k in range(len(m.drivers))]
    return np.stack(cols, axis=1)


@pytest.mark.parametrize("name", _covered())
def test_design_batch_against_numpy(name):
    """Every covered catalogue mechanism: 40 designs (5 % of the size around the start,
    so that some fail to assemble somewhere) at 60 inputs shared, then per design."""
    m = load_named(name)
    cols, X = design_population(m, 40, 0.05, 1)
    x = _inputs(m, 60)
    a, b = both_routes(m, cols, X, x)
    routes_agree(m, a, b)
    per = x[None] + 0.01 * np.arange(40)[:, None, None]
    routes_agree(m, *both_routes(m, cols, X, per))
    last = m.points[0].name if m.points else m.joint_names[-1]
    a, b = both_routes(m, cols, X, x, outputs=[last])
    routes_agree(m, a, b)
    np.testing.assert_allclose(a.point(last), b.point(last), rtol=0, atol=1e-12 * m.size)


def test_the_start_design_matches_solve():
    """The start design of a batch by the kernel is ``solve``'s motion (a third route)."""
    m = load_named("stephenson_1")
    cols, X = design_population(m, 3, 0.0, 0)
    x = np.linspace(0.0, 2.0, 50)
    with kernel.using("on"):
        b = solve_designs(m, cols, X, x)
    with kernel.using("off"):
        s = solve(m, x)
    for j in m.joint_names:
        np.testing.assert_allclose(b.point(j)[0], _at(s, j), rtol=0, atol=1e-12 * m.size)


@settings(max_examples=25, deadline=None)
@given(st.sampled_from(["dyad_rrr", "dyad_rrp", "dyad_rpr", "dyad_prp", "dyad_rpp", "four_bar", "crank_slider"]),
       st.floats(0.0, 0.3), st.integers(0, 10_000))
def test_dyad_populations_against_numpy(name, rel, seed):
    m = load_named(name)
    cols, X = design_population(m, 12, rel, seed)
    routes_agree(m, *both_routes(m, cols, X, _inputs(m, 33)))


# -- the compiled matching ------------------------------------------------------
def _costs(pb, Z):
    with kernel.using("off"):
        a = pb.batch(Z)
    with kernel.using("on"):
        b = pb.batch(Z)
    return a, b


def _path_problem(name, n=10, direction="any", closed=True):
    m = load_named(name)
    pt = m.points[0].name
    s = solve(m, np.linspace(0.0, 2 * np.pi if closed else 1.0, n, endpoint=not closed))
    T = _at(s, pt)[s.status == "ok"]
    ev = Evaluator(m, design_space(m, [pt]))
    return Problem(ev, path_target(m, T, pt), Constraints(direction=direction))


def _population_of(pb, P, seed, near=0.02):
    rng = np.random.default_rng(seed)
    Z = pb.x0 + near * (pb.upper - pb.lower) * rng.standard_normal((P, len(pb.x0)))
    Z[P // 2:] = pb.lower + rng.random((P - P // 2, len(pb.x0))) * (pb.upper - pb.lower)
    return Z


@pytest.mark.parametrize("name,direction", [("four_bar", "any"), ("four_bar", "ccw"), ("four_bar", "cw"),
                                            ("watt_1", "any"), ("linkage_24", "cw"), ("crank_slider", "any")])
def test_free_timing_path_costs_equal(name, direction):
    pb = _path_problem(name, direction=direction)
    Z = _population_of(pb, 60, 3)
    a, b = _costs(pb, Z)
    np.testing.assert_array_equal(a, b)
    assert np.isfinite(a).all() and (a < 1e3).sum() >= 30     # most candidates reach the curve


def _piston_driven():
    """The catalogue's crank-slider driven at its piston (a sliding driver)."""
    text = (Path(__file__).resolve().parents[1] / "catalogue" / "mechanisms" / "crank_slider.toml").read_text()
    return loads_mechanism(text.replace('[[driver]]\njoint = "O"', '[[driver]]\njoint = "S"'), "piston.toml")


def test_free_timing_slider_driver_costs_equal():
    """A sliding driver's grid: half forward, half backward from the reference."""
    m = _piston_driven()
    assert not m.is_rotary(0)
    s = solve(m, np.linspace(-0.06, 0.005, 8))
    T = _at(s, "G")[s.status == "ok"]
    assert len(T) == 8
    pb = Problem(Evaluator(m, design_space(m, ["G"])), path_target(m, T, "G"))
    Z = _population_of(pb, 60, 5)
    a, b = _costs(pb, Z)
    np.testing.assert_array_equal(a, b)
    assert (a < 1e3).sum() >= 20


def test_free_timing_motion_costs_equal():
    """A pose target: two lengths and an angle (wrapped), every walk."""
    m = load_named("four_bar")
    s = solve(m, np.linspace(0.0, 2.0, 9))
    lk = next(x for x in m.link_names if x != m.frame and not any(
        x in j.links and m.frame in j.links for j in m.joints))
    j = next(j.name for j in m.joints if lk in j.links)
    poses = np.column_stack([_at(s, j), s.angles[:, s.link_index(lk)] + 2.9])
    for direction in ("any", "ccw"):
        pb = Problem(Evaluator(m, design_space(m, [])), MotionTarget(poses, lk), Constraints(direction=direction))
        pb.init_motion_frame()
        Z = _population_of(pb, 40, 7)
        np.testing.assert_array_equal(*_costs(pb, Z))


def test_prescribed_timing_costs_agree():
    """A function target (prescribed timing: the kernel's solve only) to rounding."""
    m = load_named("four_bar")
    out = next(j.name for j in m.joints if m.frame in j.links and j.name != m.drivers[0].joint)
    x = np.linspace(0.0, 1.5, 7)
    s = solve(m, x)
    lk = next(x for x in m.joint(out).links if x != m.frame)
    pb = Problem(Evaluator(m, design_space(m, [])), FunctionTarget(x, s.angles[:, s.link_index(lk)], out))
    Z = _population_of(pb, 40, 9)
    a, b = _costs(pb, Z)
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=0)
