"""Design sensitivities (kin.sensitivity): the velocity analogue of every step against
central differences of re-solved designs, and its input column against the velocities
of ``solve``."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings, strategies as hs

from multiloop.catalogue.dimensional.evaluator import design_space
from multiloop.catalogue.named import load_named, names
from multiloop.kin.design import solve_designs
from multiloop.kin.geometry import design_names
from multiloop.kin.sensitivity import pose_sensitivity
from multiloop.kin.solve import solve


def _setup(m):
    pts = [p.name for p in m.points]
    dn = design_names(m, pts)
    return pts, dn, design_space(m, pts).x0


def _inputs(m, span=0.6, n=7):
    """Inputs from the reference: ``span`` rad (or 0.2 ``span`` sizes) of one driver;
    a sixth of that of each of several."""
    nd = len(m.drivers)
    t = np.linspace(0.0, span if nd == 1 else span / 6, n)
    scale = np.array([1.0 if m.is_rotary(d) else 0.2 * m.size for d in range(nd)])
    return t[:, None] * scale[None, :]


def _central(m, dn, x, inputs, col, h):
    """Every joint's and point's central difference along design column ``col``
    (or input ``col - len(dn)``)."""
    X = np.repeat(x[None], 2, axis=0)
    P = np.repeat(inputs[None], 2, axis=0)
    if col < len(dn):
        X[0, col] += h
        X[1, col] -= h
    else:
        P[0, :, col - len(dn)] += h
        P[1, :, col - len(dn)] -= h
    st = solve_designs(m, dn, X, P)
    return st, lambda name: (st.point(name)[0] - st.point(name)[1]) / (2 * h)


def _agree(m, x, inputs, rtol=1e-6):
    pts, dn, _ = _setup(m)
    st = solve_designs(m, dn, x[None], inputs)
    assert st.ok.all()
    S = pose_sensitivity(st)
    assert S.names[:len(dn)] == dn and len(S.names) == len(dn) + len(m.drivers)
    every = pts + list(m.joint_names)
    scale = max(float(np.max(np.abs(S.point(n)))) for n in every)
    for col in range(len(S.names)):
        h = 1e-6 * (m.size if col < len(dn) and not dn[col].endswith(".angle") else 1.0)
        pert, fd = _central(m, dn, x, inputs, col, h)
        assert pert.ok.all()
        for n in every:
            np.testing.assert_allclose(S.point(n)[0, :, :, col], fd(n), rtol=0, atol=rtol * scale,
                                       err_msg=f"{m.name} {n} d/d{S.names[col]}")


@pytest.mark.parametrize("name", names())
def test_every_catalogue_mechanism_agrees_with_central_differences(name):
    """Dyads of every kind, a triad, a class IV group (Stephenson III driven so), sliders,
    guides' angles, several drivers: the exact columns equal re-solved central
    differences to the differences' own error."""
    m = load_named(name)
    _agree(m, _setup(m)[2], _inputs(m))


def test_a_multiple_joint_agrees():
    """A six-bar whose pin B joins three links (pair form: two constraints at one pin)."""
    from multiloop.topo.model import MechanismBuilder
    b = MechanismBuilder()
    b.add_link("g", frame=True)
    for j, links, at in (("O", ("g", "a"), (0, 0)), ("A", ("a", "b"), (0.3, 0.9)),
                         ("B", ("b", "c", "d"), (1.4, 1.1)), ("C", ("c", "g"), (1.6, 0.0)),
                         ("D", ("d", "e"), (2.3, 1.6)), ("E", ("e", "g"), (2.6, 0.2))):
        b.add_joint(j, "R", links, at=at)
    b.add_point("T", "d", at=(1.9, 1.9))
    b.add_driver("O", ("g", "a"))
    m = b.build()
    _agree(m, _setup(m)[2], _inputs(m, span=0.5, n=9))


@settings(max_examples=25, deadline=None, derandomize=True)
@given(name=hs.sampled_from(["four_bar", "stephenson_3_triad", "stephenson_3", "six_bar_slider", "watt_2"]),
       seed=hs.integers(0, 2 ** 31 - 1))
def test_random_designs_agree(name, seed):
    """Designs within 3 % of the catalogue's, at random inputs within 40° of the reference."""
    m = load_named(name)
    rng = np.random.default_rng(seed)
    _, dn, x0 = _setup(m)
    x = x0 + 0.03 * m.size * rng.uniform(-1, 1, len(x0)) * np.array([0 if n.endswith(".angle") else 1 for n in dn])
    inputs = np.sort(rng.uniform(0.0, np.radians(40.0), 6))[:, None]
    assume(solve_designs(m, dn, x[None], inputs).ok.all())
    _agree(m, x, inputs)


@pytest.mark.parametrize("name", ["four_bar", "stephenson_3_triad", "crank_slider", "excavator"])
def test_input_columns_are_the_velocities(name):
    """The input columns are the pose rates of solve(derivatives=True), one driver at a
    time at unit rate (two routes to the same velocity analogue)."""
    m = load_named(name)
    _, dn, x0 = _setup(m)
    inputs = _inputs(m)
    S = pose_sensitivity(solve_designs(m, dn, x0[None], inputs))
    for d in range(len(m.drivers)):
        rates = np.zeros(len(m.drivers))
        rates[d] = 1.0
        st = solve(m, inputs, derivatives=True, input_rates=rates)
        for i, j in enumerate(m.joint_names):
            np.testing.assert_allclose(S.point(j)[0, :, :, len(dn) + d], st.velocities[:, i], atol=1e-10)


def test_a_position_that_does_not_assemble_is_nan():
    m = load_named("four_bar")
    _, dn, x0 = _setup(m)
    st = solve_designs(m, dn, np.stack([x0, x0 * 0.0 + 10.0 * m.size * np.arange(len(x0))]), [0.0, 0.3])
    S = pose_sensitivity(st)
    J = S.point(m.joint_names[-1])
    assert np.all(np.isfinite(J[0])) and not st.ok[1].any() and np.all(np.isnan(J[1]))


def test_a_batch_gives_each_design_its_own():
    """A design's derivatives do not depend on the batch it is solved in."""
    m = load_named("stephenson_3_triad")
    _, dn, x0 = _setup(m)
    rng = np.random.default_rng(3)
    X = x0 + 0.01 * m.size * rng.uniform(-1, 1, (4, len(x0)))
    inputs = np.linspace(0.0, 0.4, 5)
    both = pose_sensitivity(solve_designs(m, dn, X, inputs))
    for d in range(len(X)):
        alone = pose_sensitivity(solve_designs(m, dn, X[d:d + 1], inputs))
        for j in m.joint_names:
            np.testing.assert_allclose(both.point(j)[d], alone.point(j)[0], rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", ["crank_slider", "dyad_rpp", "stephenson_3", "excavator", "linkage_24"])
def test_the_compiled_route_equals_the_numpy_route(name):
    """The compiled velocity analogues (kin._sensitivity_nb: Gaussian elimination per
    position) equal the NumPy route's (LAPACK) to rounding, NaN where it is NaN, with a
    position that does not assemble in the batch."""
    from multiloop.kin import kernel
    m = load_named(name)
    _, dn, x0 = _setup(m)
    far = x0 + 50.0 * m.size * (np.arange(len(x0)) % 3 == 0)
    st = solve_designs(m, dn, np.stack([x0, far]), _inputs(m, n=40))
    with kernel.using("off"):
        a = pose_sensitivity(st).dZ
    with kernel.using("on"):
        b = pose_sensitivity(st).dZ
    assert np.array_equal(np.isnan(a), np.isnan(b)) and np.isfinite(a).any()
    np.testing.assert_allclose(b, a, rtol=1e-9, atol=1e-12 * np.nanmax(np.abs(a)))
