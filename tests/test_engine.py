"""Engine module (kin/engine/, catalogue/engines.py, `multiloop engine`).

Oracles: docs/forces.md (offset stroke 0.100133624 m for e = 0.01 m,
λ-approximation error 40.5 m/s² = 0.66 % at λ = 0.25 and 3000 rpm, V-twin firing
intervals 270/450 and 315/405 deg), Pozhbelko & Kuts 2020 example 2 (radial engine numbers),
Vasilenko et al. 2018 (the program's rod centre-of-mass formulas).
"""
from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from multiloop.catalogue.engines import (ENGINE_FILES, engine_path, radial, radial_spec, single_cylinder_spec,
                               v_twin, v_twin_spec)
from multiloop.kin.engine import (Cylinder, EngineSpec, analyse_engine, cyclogram, engine_mechanism,
                        engine_reactions, engine_state, lambda_approximation, load_engine,
                        piston_kinematics, seed004_rod_com)
from multiloop.kin.forces import PointLoad, forces, kinetic_energy, potential_energy
from multiloop.kin.engine.gas import IndicatorDiagram
from multiloop.cli import main

RNG = np.random.default_rng(20181116)


def _specs():
    return {"single": single_cylinder_spec(), "v_twin": v_twin_spec(), "radial": radial_spec()}


# ----------------------------------------------------------------------------- kinematics
@pytest.mark.parametrize("e", [0.0, 0.01, -0.007])
def test_exact_kinematics_match_central_differences(e):
    r, l = 0.05, 0.2
    th = RNG.uniform(0, 2 * np.pi, 200)
    h = 1e-5
    k0, kp, km = (piston_kinematics(t, r, l, e) for t in (th, th + h, th - h))
    np.testing.assert_allclose(k0["x1"], (kp["x"] - km["x"]) / (2 * h), rtol=0, atol=1e-9)
    np.testing.assert_allclose(k0["x2"], (kp["x1"] - km["x1"]) / (2 * h), rtol=0, atol=1e-9)
    np.testing.assert_allclose(k0["alpha1"], (kp["alpha"] - km["alpha"]) / (2 * h), rtol=0, atol=1e-9)
    np.testing.assert_allclose(k0["alpha2"], (kp["alpha1"] - km["alpha1"]) / (2 * h), rtol=0, atol=1e-8)
    # geometry: |B - A| = l in the cylinder frame
    A = np.stack([r * np.cos(th), r * np.sin(th)], -1)
    B = np.stack([k0["x"], np.full_like(th, e)], -1)
    np.testing.assert_allclose(np.linalg.norm(B - A, axis=-1), l, rtol=1e-14)


def test_offset_stroke_reference_value():
    """reference §4.2: e = 0.01 m (r = 0.05, l = 0.2): stroke 0.100133624 m."""
    spec = EngineSpec(0.05, 0.2, 0.08, (Cylinder("1", 90.0),), offset=0.01)
    assert spec.stroke == pytest.approx(0.100133624, abs=5e-10)
    th = np.linspace(-0.2, 0.2, 400001)
    x = piston_kinematics(th, 0.05, 0.2, 0.01)["x"]
    assert th[np.argmax(x)] == pytest.approx(math.asin(0.01 / 0.25), abs=2e-6)
    assert x.max() == pytest.approx(spec.x_tdc, rel=1e-13)


def test_lambda_approximation_error_reference_case():
    """reference §4.2: λ = 0.25, 3000 rpm: |a_approx − a| up to 40.5 m/s², 0.66 % of rω²(1+λ) = 6168.5."""
    r, l, w = 0.05, 0.2, 3000 * math.pi / 30
    th = np.linspace(0, 2 * np.pi, 200001)
    exact = -piston_kinematics(th, r, l)["x2"] * w * w
    approx = lambda_approximation(th, r, l)["s2"] * w * w
    err = np.abs(approx - exact).max()
    assert r * w * w * (1 + r / l) == pytest.approx(6168.5, abs=0.05)
    assert err == pytest.approx(40.5, abs=0.05)
    assert err / 6168.5 == pytest.approx(0.0066, abs=5e-5)


def test_seed004_rod_com_formulas_match_closed_form_state():
    """Vasilenko et al. 2018's Pascal formulas (reference §4.3) vs the engine state's rod COM."""
    r, l, o, n = 0.045, 0.16, 0.35, 4200.0
    spec = EngineSpec(r, l, 0.08, (Cylinder("1", 0.0),), rpm=n, rod_mass=1.0, rod_cg=o, rod_inertia=0.01)
    f = RNG.uniform(0, 720, 300)
    seed = seed004_rod_com(f, r, l, o, n)
    st = engine_state(spec, np.radians(f), eps=0.0)
    m = st.mechanism
    _, v, a = st.point_on_link("rod1", m.link("rod1").cg)
    np.testing.assert_allclose(v[:, 0], seed["Vx"], rtol=1e-12, atol=1e-12 * abs(seed["Vx"]).max())
    np.testing.assert_allclose(v[:, 1], seed["Vy"], rtol=1e-12, atol=1e-12 * abs(seed["Vy"]).max())
    np.testing.assert_allclose(a[:, 0], seed["Wx"], rtol=1e-12, atol=1e-12 * abs(seed["Wx"]).max())
    np.testing.assert_allclose(a[:, 1], seed["Wy"], rtol=1e-12, atol=1e-12 * abs(seed["Wy"]).max())
    res = analyse_engine(replace(spec, gas=None), 720, check=False)
    seed_grid = seed004_rod_com(res.phi_deg, r, l, o, n)
    np.testing.assert_allclose(res.rod_com_radius[:, 0], seed_grid["Rcp"], rtol=1e-9)


def test_seed004_rod_com_formulas_match_general_solver():
    """The same formulas against the general solver (kin.solve) on the engine mechanism."""
    from multiloop.kin.solve import solve
    r, l, o, n = 0.045, 0.16, 0.35, 4200.0
    spec = EngineSpec(r, l, 0.08, (Cylinder("1", 0.0),), rpm=n, rod_mass=1.0, rod_cg=o, rod_inertia=0.01)
    m = engine_mechanism(spec)
    f = np.linspace(0, 720, 97)
    st = solve(m, np.radians(f), derivatives=True, input_rates=[spec.omega])
    _, v, a = st.point_on_link("rod1", m.link("rod1").cg)
    seed = seed004_rod_com(f, r, l, o, n)
    np.testing.assert_allclose(v, np.stack([seed["Vx"], seed["Vy"]], -1), atol=1e-9 * seed["Vc"].max())
    np.testing.assert_allclose(a, np.stack([seed["Wx"], seed["Wy"]], -1), atol=1e-9 * seed["Wc"].max())


def test_general_solver_matches_closed_form_state_for_every_catalogue_engine():
    from multiloop.kin.solve import solve
    for spec in _specs().values():
        m = engine_mechanism(spec)
        phi = RNG.uniform(0, 4 * np.pi, 40)
        ref = engine_state(spec, phi, eps=0.0, mechanism=m)
        st = solve(m, phi, derivatives=True, input_rates=[spec.omega])
        assert st.success
        np.testing.assert_allclose(st.positions, ref.positions, atol=1e-12)
        scale_a = np.abs(ref.accelerations).max()
        np.testing.assert_allclose(st.accelerations, ref.accelerations, atol=1e-9 * scale_a)
        np.testing.assert_allclose(st.epsilons, ref.epsilons, atol=1e-9 * np.abs(ref.epsilons).max())
        # kinetostatics on the solver's state = closed form (§4.5)
        rx = engine_reactions(spec, phi, eps=0.0)
        gas = [PointLoad(f"piston{j + 1}", rx["Fg"][:, j], at=m.joint(f"B{j + 1}").at) for j in range(spec.n_cylinders)]
        fr = forces(m, st, extra_loads=gas)
        np.testing.assert_allclose(fr.balancing[:, 0], rx["Mb"], atol=1e-8 * np.abs(rx["Mb"]).max())


# ----------------------------------------------------------------------------- forces
@pytest.mark.parametrize("name", ["single", "v_twin", "radial"])
def test_balancing_moment_three_routes(name):
    """Closed form (§4.5) = general kinetostatics (groups and global) = virtual power, with
    a non-zero crank acceleration; reactions per pair agree."""
    spec = replace(_specs()[name], crank_acceleration=-850.0)
    phi = RNG.uniform(0, 4 * np.pi, 64)
    rx = engine_reactions(spec, phi)
    m = engine_mechanism(spec)
    st = engine_state(spec, phi, mechanism=m)
    loads = [PointLoad(f"piston{j + 1}", rx["Fg"][:, j], at=m.joint(f"B{j + 1}").at) for j in range(spec.n_cylinders)]
    scale = np.abs(rx["Mb"]).max()
    # virtual power of the closed form
    assert np.max(np.abs(rx["residual"]) / rx["scale"]) < 1e-12
    vp = -rx["power"] / spec.omega
    np.testing.assert_allclose(rx["Mb"], vp, atol=1e-11 * scale)
    for method in ("groups", "global"):
        fr = forces(m, st, extra_loads=loads, method=method)
        assert fr.success and fr.method == method
        np.testing.assert_allclose(fr.balancing[:, 0], rx["Mb"], atol=1e-11 * scale)
        fscale = np.abs(rx["R12"]).max()
        for j in range(spec.n_cylinders):
            np.testing.assert_allclose(fr.reaction("A", "crank", f"rod{j + 1}"), rx["R12"][:, j], atol=1e-11 * fscale)
            np.testing.assert_allclose(fr.reaction(f"B{j + 1}", f"rod{j + 1}", f"piston{j + 1}"), rx["R23"][:, j],
                                       atol=1e-11 * fscale)
            np.testing.assert_allclose(fr.normal_forces[:, fr.pair_index(f"S{j + 1}:frame->piston{j + 1}")],
                                       rx["N"][:, j], atol=1e-11 * fscale)
        np.testing.assert_allclose(fr.reaction("O", "frame", "crank"), rx["R01"], atol=1e-11 * fscale)
        assert np.max(fr.relative_residual) < 1e-12


@pytest.mark.parametrize("name", ["single", "v_twin", "radial"])
def test_balancing_moment_equals_energy_rate(name):
    """M_b ω = dT/dt + dU/dt − P_gas (reference §4.6 check 2), dT/dt and dU/dt by central
    differences in time along φ(t) = φ0 + ω0 t + ½ ε t², ω(t) = ω0 + ε t."""
    spec = replace(_specs()[name], crank_acceleration=1200.0)
    m = engine_mechanism(spec)
    phi0 = RNG.uniform(0, 4 * np.pi, 50)
    w0, eps = spec.omega, spec.crank_acceleration
    h = 1e-7

    def energy(t):
        st = engine_state(spec, phi0 + w0 * t + 0.5 * eps * t * t, omega=w0 + eps * t, eps=eps, mechanism=m)
        return kinetic_energy(st) + potential_energy(st)

    dE = (energy(h) - energy(-h)) / (2 * h)
    rx = engine_reactions(spec, phi0)
    st = engine_state(spec, phi0, mechanism=m)
    p_gas = sum(np.einsum("ni,ni->n", rx["Fg"][:, j], st.velocities[:, 2 + 2 * j]) for j in range(spec.n_cylinders))
    lhs = rx["Mb"] * w0
    np.testing.assert_allclose(lhs, dE - p_gas, atol=2e-7 * np.abs(lhs).max())


@pytest.mark.parametrize("name", ["single", "v_twin", "radial"])
def test_cycle_integral_equals_minus_indicated_work(name):
    spec = _specs()[name]
    res = analyse_engine(spec, 14400, check=False)
    W = res.indicated_work.sum()
    assert W > 0
    tol = 2e-4 if spec.offset else 2e-6   # the pressure jump at ψ = 360 meets dV ≠ 0 with an offset
    assert res.cycle_integral == pytest.approx(-W, rel=tol)


def test_cycle_integral_converges_with_offset():
    spec = single_cylinder_spec()
    errs = [abs(analyse_engine(spec, n, check=False).cycle_integral + analyse_engine(spec, n, check=False)
                .indicated_work.sum()) for n in (1440, 5760)]
    assert errs[1] < errs[0] / 3.0


def test_indicated_work_closed_form_against_pv_polygon():
    spec = v_twin_spec()
    res = analyse_engine(spec, 72000, check=False)
    for j in range(2):
        order = np.argsort(res.psi_deg[:, j])
        p = np.append(res.pressure[order, j], res.pressure[order[0], j])
        v = np.append(res.volume[order, j], res.volume[order[0], j])
        w_num = np.sum(0.5 * (p[1:] + p[:-1]) * np.diff(v))
        assert w_num == pytest.approx(res.indicated_work[j], rel=1e-4)


def test_v_twin_is_the_sum_of_two_single_cylinder_engines():
    vt = v_twin_spec()
    c1, c2 = vt.cylinders
    gamma = math.radians(c2.bank - c1.bank)
    e1 = replace(vt, cylinders=(c1,))
    e2 = replace(vt, cylinders=(Cylinder("2", c2.bank, c2.firing),), crank_mass=0.0, crank_inertia=0.0)
    phi = RNG.uniform(0, 4 * np.pi, 80)
    rv = engine_reactions(vt, phi)
    r1 = engine_reactions(e1, phi)
    r2 = engine_reactions(e2, phi - gamma)
    scale = np.abs(rv["Mb"]).max()
    np.testing.assert_allclose(rv["Mb"], r1["Mb"] + r2["Mb"], atol=1e-12 * scale)
    np.testing.assert_allclose(rv["R01"], r1["R01"] + r2["R01"], atol=1e-12 * np.abs(rv["R01"]).max())
    np.testing.assert_allclose(rv["R12"][:, 1], r2["R12"][:, 0], atol=1e-12 * np.abs(rv["R12"]).max())


@pytest.mark.parametrize("angle, intervals", [(90.0, [270.0, 450.0]), (45.0, [315.0, 405.0])])
def test_v_twin_firing_intervals(angle, intervals):
    cyc = cyclogram(v_twin_spec(angle))
    assert sorted(cyc["firing_intervals"]) == intervals
    assert sum(cyc["firing_intervals"]) == 720.0


def test_radial_cyclogram_equal_intervals_and_order():
    cyc = cyclogram(radial_spec())
    assert cyc["firing_intervals"] == [144.0] * 5
    order = cyc["firing_order"]
    k = order.index("1")
    assert order[k:] + order[:k] == ["1", "3", "5", "2", "4"]
    for row in cyc["cylinders"]:
        names = [s[0] for s in row["strokes"]]
        assert names == ["intake", "compression", "power", "exhaust"]
        assert (row["strokes"][2][1] - row["firing"]) % 720.0 == 0.0


def test_radial_engine_is_seed002_example2():
    from multiloop.topo.numbers import structural_report
    r = structural_report(radial())
    assert (r.n, tuple(r.LA), tuple(r.MJA), r.V, r.K, r.F, r.SL) == (12, (11, 0, 0, 0, 1), (0, 0, 0, 1), 4, 5, 1, 28)
    assert r.code == "[11.0001]/4"
    a = radial().joint("A")
    assert a.links[0] == "crank" and a.multiplicity == 5


def test_multiple_joint_carries_one_reaction_per_pair():
    spec = radial_spec()
    m = engine_mechanism(spec)
    st = engine_state(spec, np.radians([10.0, 100.0]), mechanism=m)
    fr = forces(m, st)
    pin = [p for p in fr.pairs if p.joint == "A"]
    assert [(p.a, p.b) for p in pin] == [("crank", f"rod{j}") for j in range(1, 6)]
    assert len(fr.pairs) == 1 + 5 + 5 + 5


def test_dead_centres_regular_when_crank_drives():
    spec = replace(single_cylinder_spec(), offset=0.0)
    m = engine_mechanism(spec)
    phi = np.radians([0.0, 180.0, 360.0, 540.0])
    st = engine_state(spec, phi, mechanism=m)
    fr = forces(m, st)
    assert fr.success and np.all(np.isfinite(fr.balancing))
    rx = engine_reactions(spec, phi)
    assert np.all(np.isfinite(rx["Mb"]))
    # at the dead centres the gas force has no arm: M_b comes from inertia and weight only
    no_gas = engine_reactions(spec, phi, gauge=np.zeros((4, 1)))
    arm = np.abs(rx["Fg"]).max() * spec.crank_radius      # M_b if the gas force had the arm r
    assert arm > 100.0
    np.testing.assert_allclose(rx["Mb"], no_gas["Mb"], atol=1e-14 * arm)


def test_dead_centres_singular_when_piston_drives():
    """Driven by the piston, crank + rod form an RRR dyad that is singular at the dead
    centres: marked in the status, NaN, no exception."""
    from multiloop.topo.model import Driver
    spec = replace(single_cylinder_spec(), offset=0.0)
    m = engine_mechanism(spec).with_drivers([Driver("S1", ("frame", "piston1"))])
    phi = np.radians([0.0, 45.0, 180.0, 300.0])
    st = engine_state(spec, phi, mechanism=m)
    from multiloop.topo.errors import SingularityWarning
    for method in ("groups", "global"):
        with pytest.warns(SingularityWarning, match="2 singular"):
            fr = forces(m, st, method=method)
        assert list(fr.ok) == [False, True, False, True]
        assert "singular" in fr.status[0]
        assert np.isnan(fr.balancing[0, 0]) and np.isfinite(fr.balancing[1, 0])
        assert np.max(fr.relative_residual[fr.ok]) < 1e-12


def test_engine_builders_and_files():
    assert set(ENGINE_FILES) == {"single_cylinder", "v_twin", "radial_5cyl_masses"}
    for name in ENGINE_FILES:
        spec = load_engine(engine_path(name))
        m = engine_mechanism(spec)
        assert all(lk.mass is not None for lk in m.links if not lk.is_frame)
        assert m.drivers[0].speed == pytest.approx(spec.omega)
    assert single_cylinder_spec().offset == 0.005
    assert v_twin().joint("A").links == ("crank", "rod1", "rod2")


def test_pressure_model_and_gas_validation():
    gas = IndicatorDiagram(10.0, 6e6)
    p = gas.pressure([90.0, 359.999, 360.0, 600.0], [5e-4, 5e-5, 5e-5, 5e-4], 5e-4, 5e-5)
    assert p[0] == gas.intake_pressure and p[3] == gas.exhaust_pressure and p[2] == 6e6
    assert p[1] == pytest.approx(gas.intake_pressure * 10.0 ** 1.35, rel=1e-3)


# ----------------------------------------------------------------------------- CLI
def test_engine_cli_text_json_and_plots(tmp_path, capsys):
    assert main(["engine", "v_twin", "--steps", "144"]) == 0
    out = capsys.readouterr().out
    assert "270/450" in out and "general kinetostatics" in out
    assert main(["engine", str(engine_path("radial_5cyl_masses")), "--steps", "72", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert len(doc["cylinders"]) == 5 and len(doc["balancing"]) == 72
    assert doc["cyclogram"]["firing_intervals"] == [144.0] * 5
    assert "A:crank->rod5" in doc["reactions"]
    assert main(["engine", "single_cylinder", "--steps", "72", "--plot", str(tmp_path / "d")]) == 0
    for f in ("kinematics", "pressure", "balancing", "cyclogram", "rod_com", "reactions"):
        assert (tmp_path / "d" / f"{f}.png").stat().st_size > 1000


BAD = [
    ("[engine]\nbore = 0.08\nrod_length = 0.2\ncrank_radius = 0.05\nbogus = 1\n", "bogus"),
    ("[engine]\nrod_length = 0.2\ncrank_radius = 0.05\n", "bore"),
    ("[engine]\nbore = 0.08\nrod_length = 0.04\ncrank_radius = 0.05\n", "rod_length"),
    ("[engine]\nbore = 0.08\nrod_length = 0.2\n", "crank_radius"),
    ("[engine]\nbore = 0.08\nrod_length = 0.2\ncrank_radius = 0.05\n[gas]\ncompression_ratio = 10\n"
     "peak_pressure = 1e5\n", "peak_pressure"),
    ("[engine]\nbore = 0.08\nrod_length = 0.2\ncrank_radius = 0.05\n[gas]\nmodel = 'wiebe'\n", "model"),
    ("[engine]\nbore = 0.08\nrod_length = 0.2\ncrank_radius = 0.05\n[[cylinder]]\nname = 'x'\n", "bank"),
    ("[engine]\nbore = 0.08\nrod_length = 0.2\ncrank_radius = 0.05\n[[cylinder]]\nbank = 0\nfiring = 90\n", "firing"),
    ("[engine]\nbore = 'big'\nrod_length = 0.2\ncrank_radius = 0.05\n", "bore"),
    ("name = 'no engine table'\n", "[engine]"),
    # physically meaningless values (issue 10)
    ("[engine]\nbore = 0.08\nrod_length = 0.2\ncrank_radius = 0.05\nrpm = 0\n", "rpm"),
    ("[engine]\nbore = 0.08\nrod_length = 0.2\ncrank_radius = 0.05\nrpm = -3000\n", "rpm"),
    ("[engine]\nbore = 0.08\nrod_length = 0.2\ncrank_radius = 0.05\nrod_mass = 1\nrod_inertia = -0.01\n",
     "rod_inertia"),
    ("[engine]\nbore = 0.08\nrod_length = 0.2\ncrank_radius = 0.05\ncrank_inertia = -1\n", "crank_inertia"),
    ("[engine]\nbore = 0.08\nrod_length = 0.2\ncrank_radius = 0.05\n[gas]\nmodel = 'table'\n"
     "table = [[0, 1e5], [90, 2e5], [90, 3e5]]\n", "distinct cycle angles"),
]


@pytest.mark.parametrize("text, key", BAD)
def test_bad_engine_files_exit_2_naming_the_key(tmp_path, capsys, text, key):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    assert main(["engine", str(f)]) == 2
    err = capsys.readouterr().err
    assert key in err and "Traceback" not in err


def test_engine_steps_capped_with_exit_2(capsys):
    assert main(["engine", "single_cylinder", "--steps", "100000000"]) == 2
    assert "from 8 to 100000" in capsys.readouterr().err      # refused before any step is solved
    with pytest.raises(Exception, match="from 8 to 100000"):
        analyse_engine(single_cylinder_spec(), 10 ** 8)


def test_engine_result_is_read_only_and_as_dict_is_json():
    res = analyse_engine(single_cylinder_spec(), 16)
    with pytest.raises(ValueError):
        res.balancing[0] = 0.0
    with pytest.raises(ValueError):
        res.reactions["R12"][0] = 0.0
    doc = json.loads(json.dumps(res.as_dict(), allow_nan=False))
    assert len(doc["phi"]) == 16 and doc["cylinders"][0]["name"] == res.spec.cylinders[0].name


def test_engine_mechanism_with_gas_tables_matches_closed_form_on_the_table_grid():
    spec = v_twin_spec()
    m = engine_mechanism(spec, gas_loads=True)
    assert [ld.name for ld in m.loads] == ["gas front", "gas rear"]
    phi = np.radians(np.arange(0.0, 1440.0, 7.0))          # also the second cycle
    fr = forces(m, engine_state(spec, phi, mechanism=m))
    rx = engine_reactions(spec, phi)
    np.testing.assert_allclose(fr.balancing[:, 0], rx["Mb"], atol=1e-11 * np.abs(rx["Mb"]).max())


def test_user_pressure_table_cycle_integral():
    base = v_twin_spec()
    psi = np.arange(0.0, 720.0, 0.5)
    # an arbitrary smooth user curve (absolute Pa), periodic over 720 deg
    p = 0.1e6 + 3.0e6 * np.exp(-((psi - 372.0) / 35.0) ** 2)
    from multiloop.kin.engine.gas import PressureTable
    spec = replace(base, gas=PressureTable(tuple(zip(psi.tolist(), p.tolist()))))
    res = analyse_engine(spec, 5760, check=False)
    W = res.indicated_work.sum()
    assert W > 0
    assert res.cycle_integral == pytest.approx(-W, rel=1e-4)


from hypothesis import given, settings, strategies as st  # noqa: E402


@settings(max_examples=25)
@given(r=st.floats(0.02, 0.08), lam=st.floats(0.15, 0.4), e_frac=st.floats(-0.5, 0.5),
       k=st.floats(0.0, 1.0), m2=st.floats(0.0, 3.0), m3=st.floats(0.0, 3.0), vee=st.floats(20.0, 160.0),
       eps=st.floats(-2000.0, 2000.0))
def test_random_engines_closed_form_equals_general_kinetostatics(r, lam, e_frac, k, m2, m3, vee, eps):
    l = r / lam
    e = e_frac * (l - r)
    spec = EngineSpec(r, l, 0.09, (Cylinder("1", 80.0), Cylinder("2", 80.0 + vee, 360.0)), offset=e, rpm=4000.0,
                      crank_acceleration=eps, rod_mass=m2, rod_cg=k, rod_inertia=m2 * (0.3 * l) ** 2,
                      piston_mass=m3, crank_mass=2.0, crank_inertia=0.02, gravity=(0.0, -9.81),
                      gas=IndicatorDiagram(10.0, 6e6))
    phi = np.linspace(0.0, 4 * np.pi, 37)
    rx = engine_reactions(spec, phi)
    m = engine_mechanism(spec)
    loads = [PointLoad(f"piston{j + 1}", rx["Fg"][:, j], at=m.joint(f"B{j + 1}").at) for j in range(2)]
    fr = forces(m, engine_state(spec, phi, mechanism=m), extra_loads=loads)
    assert fr.success
    np.testing.assert_allclose(fr.balancing[:, 0], rx["Mb"], atol=1e-10 * np.abs(rx["Mb"]).max())
    assert np.max(fr.relative_residual) < 1e-11
    assert np.max(np.abs(rx["residual"]) / np.maximum(rx["scale"], 1e-12 * rx["scale"].max())) < 1e-11
