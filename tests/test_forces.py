"""General kinetostatics (kin/forces.py) and `multiloop forces`.

Three routes must agree to round-off on random positions of every catalogue mechanism
with masses: reactions group by group (and the global system), virtual power, and the
energy rate d(T + U)/dt − P_external (central differences in time).
"""
from __future__ import annotations

import dataclasses
import json
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from multiloop.catalogue.engines import radial_spec, single_cylinder_spec, v_twin_spec
from multiloop.kin.engine import Cylinder, EngineSpec, engine_mechanism, engine_state
from multiloop.kin.forces import (ForceResult, PointLoad, forces, kinetic_energy, link_loads, potential_energy,
                        solve_batched)
from multiloop.kin.state import KinematicState
from multiloop.cli import main
from multiloop.topo.errors import MobilityError
from multiloop.topo.io import load
from multiloop.topo.model import Link, MechanismBuilder

RNG = np.random.default_rng(4)
LOADED = Path(str(resources.files("multiloop.catalogue") / "mechanisms" / "crank_slider_loaded.toml"))


def _massless(m):
    b = MechanismBuilder.from_mechanism(m)
    b.links = [Link(lk.name, lk.is_frame, None, lk.cg, None, lk.color) for lk in b.links]
    return b.build()


def _external_power(state: KinematicState) -> np.ndarray:
    """Power of the file's applied loads only (no weight, no inertia)."""
    st = dataclasses.replace(state, mechanism=_massless(state.mechanism))
    return link_loads(st)[2].sum(axis=1)


def _loaded_state(phi, omega=None, eps=None) -> KinematicState:
    """Closed-form state of crank_slider_loaded.toml: same link/joint order as the engine
    mechanism of a one-cylinder engine with r = 0.05, l = 0.2, axis +x."""
    m = load(LOADED)
    spec = EngineSpec(0.05, 0.2, 0.08, (Cylinder("1", 0.0),), rpm=m.drivers[0].speed * 30 / np.pi)
    return engine_state(spec, phi, omega, eps, mechanism=m)


# ----------------------------------------------------------------------------- linear algebra
def test_solve_batched_matches_lapack_and_marks_singular():
    A = RNG.normal(size=(50, 6, 6)) * RNG.uniform(0.01, 100, size=(50, 1, 6))
    b = RNG.normal(size=(50, 6))
    x, det = solve_batched(A, b)
    np.testing.assert_allclose(x, np.linalg.solve(A, b[..., None])[..., 0], rtol=1e-9, atol=1e-12)
    assert np.all((det > 0) & (det <= 1 + 1e-12))
    A[3, :, 2] = A[3, :, 1] * 7.0           # dependent columns
    A[5, 0, 0] = np.nan
    x, det = solve_batched(A, b)
    assert det[3] < 1e-10 and np.all(np.isnan(x[3])) and np.all(np.isnan(x[5]))
    assert np.all(np.isfinite(np.delete(x, [3, 5], axis=0)))


# ----------------------------------------------------------------------------- three routes
def _cases():
    """(name, mechanism, state maker(phi0, t) with constant driver speed)."""
    out = []
    m = load(LOADED)
    w = m.drivers[0].speed
    out.append(("crank_slider_loaded", m, lambda q, t: _loaded_state(q + w * t, eps=0.0)))
    for name, spec in (("single", single_cylinder_spec()), ("v_twin", v_twin_spec()), ("radial", radial_spec())):
        me = engine_mechanism(spec)
        out.append((name, me, lambda q, t, spec=spec, me=me: engine_state(spec, q + spec.omega * t, eps=0.0,
                                                                           mechanism=me)))
    return out


@pytest.mark.parametrize("case", _cases(), ids=lambda c: c[0])
def test_reactions_virtual_power_energy_rate_agree(case):
    name, m, state_at = case
    q = RNG.uniform(0, 4 * np.pi, 40)
    st = state_at(q, 0.0)
    fr = forces(m, st)
    fg = forces(m, st, method="global")
    assert fr.success and fg.success and fr.method == "groups" and fg.method == "global"
    scale = np.nanmax(np.abs(fr.balancing))
    np.testing.assert_allclose(fr.balancing, fg.balancing, atol=1e-11 * scale)
    np.testing.assert_allclose(fr.reactions, fg.reactions, atol=1e-11 * np.abs(fr.reactions).max())
    # virtual power
    assert np.max(fr.relative_residual) < 1e-12
    # energy rate: M_b ω = d(T + U)/dt − P_ext
    h = 1e-4 / m.drivers[0].speed
    dE = ((kinetic_energy(state_at(q, h)) + potential_energy(state_at(q, h)))
          - (kinetic_energy(state_at(q, -h)) + potential_energy(state_at(q, -h)))) / (2 * h)
    p_ext = _external_power(st)
    lhs = fr.balancing[:, 0] * fr.driver_rates[:, 0]
    np.testing.assert_allclose(lhs, dE - p_ext, atol=1e-6 * np.abs(lhs).max())


def test_catalogue_mechanisms_with_masses_through_the_general_solver():
    """Every catalogue mechanism file with masses, solved by kin.solve from driver inputs."""
    files = sorted(Path(str(resources.files("multiloop.catalogue") / "mechanisms")).glob("*.toml"))
    done = 0
    for f in files:
        m = load(f)
        if not m.drivers or not any(lk.mass for lk in m.links) or not m.has_geometry:
            continue
        nd = len(m.drivers)
        w = np.array([d.speed or 1.0 for d in m.drivers])
        q0 = RNG.uniform(-0.2, 0.2, (12, nd))
        for k, d in enumerate(m.drivers):          # inside a driver's own range (a cylinder's stroke)
            if d.range is not None:
                lo, hi = max(d.range[0], -0.2) + 1e-3, min(d.range[1], 0.2) - 1e-3
                q0[:, k] = lo + (q0[:, k] + 0.2) / 0.4 * (hi - lo)
        from multiloop.kin.solve import solve
        fr = forces(m, q0, accelerations=np.zeros(nd))
        ok = fr.ok
        assert ok.sum() >= 6, f.name
        fg = forces(m, fr.state, method="global")
        np.testing.assert_allclose(fr.balancing[ok], fg.balancing[ok], atol=1e-10 * np.nanmax(np.abs(fr.balancing)))
        assert np.nanmax(fr.relative_residual[ok]) < 1e-10, f.name
        h = 1e-4 / np.abs(w).max()

        def energy(t):
            s = solve(m, q0 + w * t, derivatives=True, input_rates=w)
            return kinetic_energy(s) + potential_energy(s)
        dE = (energy(h) - energy(-h)) / (2 * h)
        lhs = np.sum(fr.balancing * fr.driver_rates, axis=1)
        rhs = dE - _external_power(fr.state)
        np.testing.assert_allclose(lhs[ok], rhs[ok], atol=1e-5 * np.nanmax(np.abs(lhs)) + 1e-9)
        done += 1
    assert done >= 1


def test_driver_acceleration_from_the_file_enters_the_inertia_loads():
    m = load(LOADED)
    q = RNG.uniform(0, 2 * np.pi, 20)
    fr = forces(m, q, accelerations=[-500.0])
    ref = forces(m, _loaded_state(q, eps=-500.0))
    np.testing.assert_allclose(fr.balancing, ref.balancing, atol=1e-9 * np.abs(ref.balancing).max())


# ----------------------------------------------------------------------------- pairs and loads
def test_p_pair_couple_and_line_of_action():
    m = load(LOADED)
    q = RNG.uniform(0, 2 * np.pi, 10)
    st = _loaded_state(q, eps=0.0)
    base = forces(m, st)
    c = 37.5
    fr = forces(m, st, extra_loads=[PointLoad("piston", (0.0, 0.0), moment=c)])
    i = fr.pair_index("S:frame->piston")
    np.testing.assert_allclose(base.pair_moments[:, i], 0.0, atol=1e-9)
    np.testing.assert_allclose(fr.pair_moments[:, i], -c, rtol=1e-12)
    np.testing.assert_allclose(fr.line_of_action("S:frame->piston"), -c / fr.normal_forces[:, i], rtol=1e-12)
    # a couple on the piston does no work: the balancing moment is unchanged
    np.testing.assert_allclose(fr.balancing, base.balancing, atol=1e-9 * np.abs(base.balancing).max())


def test_table_load_is_periodic_over_720_deg():
    m = load(LOADED)
    st = _loaded_state(np.radians([360.0, 1080.0, 0.0, 10.0]), eps=0.0)
    F = link_loads(dataclasses.replace(st, mechanism=_massless(m)))[0]
    k = m.link_names.index("piston")
    assert F[0, k, 0] == F[1, k, 0] == pytest.approx(-19603.5)
    assert F[2, k, 0] != F[0, k, 0]


def test_mobility_error_when_drivers_do_not_match():
    m = load(LOADED).with_drivers([])
    st = _loaded_state(np.array([0.3]), eps=0.0)
    with pytest.raises(MobilityError, match="drivers"):
        forces(m, dataclasses.replace(st, mechanism=m))


def test_force_result_is_frozen():
    m = load(LOADED)
    fr = forces(m, _loaded_state(np.array([0.5]), eps=0.0))
    assert isinstance(fr, ForceResult)
    with pytest.raises(dataclasses.FrozenInstanceError):
        fr.method = "x"  # type: ignore[misc]


# ----------------------------------------------------------------------------- CLI
def test_forces_cli_json_and_text(tmp_path, capsys):
    assert main(["forces", str(LOADED), "--steps", "12", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert set(doc) >= {"balancing", "reactions", "virtual_power_residual", "input", "status"}
    assert len(doc["balancing"]["O"]) == 12
    assert doc["input"][6] == pytest.approx(360.0)           # the table runs to 720 deg
    assert set(doc["reactions"]) == {"O:frame->crank", "A:crank->rod", "B:rod->piston", "S:frame->piston"}
    assert max(abs(x) for x in doc["virtual_power_residual"]) < 1e-6
    assert main(["forces", "crank_slider_loaded", "--at", "30", "--plot", str(tmp_path / "f.png")]) == 0
    out = capsys.readouterr().out
    assert "S:frame->piston" in out and (tmp_path / "f.png").exists()
    assert main(["forces", "v_twin", "--at", "90", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert {"A:crank->rod1", "A:crank->rod2"} <= set(doc["reactions"])


def test_forces_cli_bad_input_exit_2(tmp_path, capsys):
    f = tmp_path / "nodriver.toml"
    f.write_text(LOADED.read_text().replace("[[driver]]\njoint = \"O\"", "[[point]]\nname = \"P\"\nlink = \"rod\"\nat = [0.1, 0.0]")
                 .replace("speed = 314.1592653589793     # rad/s (3000 rpm)\nacceleration = 0.0\n", ""))
    assert main(["forces", str(f)]) == 2
    assert "[[driver]]" in capsys.readouterr().err
    assert main(["forces", str(LOADED), "--at", "1,2"]) == 2
    assert "--at" in capsys.readouterr().err


FIVE_BAR = """
name = "five-bar, 2 drivers, masses"
gravity = [0.0, -9.81]
[[link]]
name = "g"
frame = true
[[link]]
name = "c1"
mass = 1.0
inertia = 0.01
[[link]]
name = "c2"
mass = 1.2
inertia = 0.02
cg = [2.0, 0.6]
[[link]]
name = "l1"
mass = 0.7
inertia = 0.03
[[link]]
name = "l2"
mass = 0.9
inertia = 0.04
[[joint]]
name = "O1"
links = ["g", "c1"]
at = [0.0, 0.0]
[[joint]]
name = "O2"
links = ["g", "c2"]
at = [2.0, 0.0]
[[joint]]
name = "A"
links = ["c1", "l1"]
at = [0.0, 1.0]
[[joint]]
name = "B"
links = ["c2", "l2"]
at = [2.0, 1.2]
[[joint]]
name = "C"
links = ["l1", "l2"]
at = [1.1, 2.3]
[[driver]]
joint = "O1"
speed = 3.0
acceleration = 2.0
[[driver]]
joint = "O2"
speed = -2.0
acceleration = -1.0
[[force]]
link = "l1"
at = [0.5, 1.5]
value = [10.0, -5.0]
moment = 3.0
"""


def test_two_driver_five_bar_with_driver_accelerations():
    """Two drivers with speeds and accelerations from the file: groups = global =
    virtual power = energy rate along q(t) = q0 + ω t + ½ ε t²."""
    from multiloop.kin.solve import solve
    from multiloop.topo.io import loads
    m = loads(FIVE_BAR)
    w, e = np.array([3.0, -2.0]), np.array([2.0, -1.0])
    q0 = RNG.uniform(-0.3, 0.3, (8, 2))
    fr = forces(m, q0)
    fg = forces(m, fr.state, method="global")
    assert fr.success and fr.blocks == (("l1", "l2"), ("c2",), ("c1",))
    np.testing.assert_allclose(fr.balancing, fg.balancing, atol=1e-12 * np.abs(fr.balancing).max())
    assert np.max(fr.relative_residual) < 1e-12
    np.testing.assert_allclose(fr.driver_rates, np.broadcast_to(w, (8, 2)), rtol=1e-12)
    h = 1e-5

    def energy(t):
        s = solve(m, q0 + w * t + 0.5 * e * t * t, derivatives=True, input_rates=w + e * t)
        return kinetic_energy(s) + potential_energy(s)
    dE = (energy(h) - energy(-h)) / (2 * h)
    lhs = np.sum(fr.balancing * fr.driver_rates, axis=1)
    np.testing.assert_allclose(lhs, dE - _external_power(fr.state), atol=1e-6 * np.abs(lhs).max())


def test_check_false_gives_the_same_numbers_on_regular_positions():
    m = load(LOADED)
    st = _loaded_state(RNG.uniform(0, 4 * np.pi, 30), eps=0.0)
    a, b = forces(m, st), forces(m, st, check=False)
    np.testing.assert_array_equal(a.balancing, b.balancing)
    x, det = solve_batched(np.zeros((3, 2, 2)) + np.eye(2), np.ones((3, 2)), check=False)
    assert np.all(np.isnan(det)) and np.all(x == 1.0)
    x, det = solve_batched(np.zeros((2, 2, 2)), np.ones((2, 2)), check=False)   # exactly singular: checked path
    assert np.all(det == 0.0) and np.all(np.isnan(x))


# ----------------------------------------------------------------------------- issue 9/10/11 regressions
def test_sparse_elimination_equals_lapack_on_random_sparse_tables():
    """Two routes for the same batched solve: the sparse table elimination and LAPACK."""
    from multiloop.kin.forces.linsolve import dense, solve_sparse
    rng = np.random.default_rng(11)
    N = 400
    for _ in range(20):
        E = [[None if rng.random() < 0.3 else (float(rng.choice([-1.0, 1.0, 2.5])) if rng.random() < 0.3
                                                else rng.normal(size=N)) for _ in range(6)] for _ in range(6)]
        b = [rng.normal(size=N) for _ in range(6)]
        x1, d1 = solve_batched(dense(E, N), np.stack(b, axis=-1))
        x2, d2 = solve_sparse(E, b, N)
        ok = np.isfinite(x1).all(axis=1)
        np.testing.assert_array_equal(ok, np.isfinite(x2).all(axis=1))
        np.testing.assert_allclose(x2[ok], x1[ok], rtol=1e-7, atol=1e-9)
        np.testing.assert_allclose(d2, d1, rtol=1e-7, atol=1e-13)


def test_virtual_power_residual_feeds_the_status():
    """Velocities inconsistent with the accelerations: reactions balance the inertia
    loads but the virtual power does not vanish, so the position is not ok."""
    st = _loaded_state(np.radians([30.0, 60.0, 100.0]))
    bad = dataclasses.replace(st, velocities=st.velocities * np.array([1.0, 1.5, 1.0])[:, None, None])
    fr = forces(st.mechanism, bad)
    assert list(fr.ok) == [True, False, True]
    assert "virtual power" in fr.status[1] and "1e-06" in fr.status[1]
    assert fr.relative_residual[1] > 1e-6 and np.isnan(fr.balancing[1]).all()
    assert forces(st.mechanism, st).success


def test_force_result_arrays_are_read_only_and_as_dict_is_json():
    fr = forces(load(LOADED), np.radians([10.0, 50.0]))
    for a in (fr.reactions, fr.balancing, fr.virtual_power_residual, fr.status):
        with pytest.raises(ValueError):
            a[0] = 0
    doc = json.loads(json.dumps(fr.as_dict(), allow_nan=False))
    assert doc["input"] == [10.0, 50.0] and doc["virtual_power_tolerance"] == 1e-6


def test_forces_at_huge_angle_is_reduced_and_capped(capsys):
    assert main(["forces", "crank_slider_loaded", "--at", "1e9", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["input"][0] == pytest.approx(1e9 % 720.0)       # the gas table spans 720 deg
    ref = forces(load(LOADED), np.radians([1e9 % 720.0]))
    assert doc["balancing"]["O"][0] == pytest.approx(float(ref.balancing[0, 0]), rel=1e-9)
    for bad in ("1e300", "inf", "nan"):
        assert main(["forces", "crank_slider_loaded", "--at", bad]) == 2
        err = capsys.readouterr().err
        assert "Traceback" not in err and ("at most 1e+09 deg" in err or "finite" in err)
    assert main(["forces", "crank_slider_loaded", "--steps", "100000000"]) == 2
    assert "from 1 to 100000" in capsys.readouterr().err


def test_meaningless_mass_data_rejected(tmp_path, capsys):
    text = LOADED.read_text()
    f = tmp_path / "neg.toml"
    f.write_text(text.replace("inertia = ", "inertia = -", 1))
    assert main(["forces", str(f), "--at", "30"]) == 2
    assert "inertia" in capsys.readouterr().err
    m = load(LOADED)
    b = MechanismBuilder.from_mechanism(m)
    b.loads = [dataclasses.replace(ld, table=ld.table + (ld.table[0],)) if ld.table else ld for ld in b.loads]
    with pytest.raises(Exception, match="distinct input angles"):
        forces(b.build(), np.radians([30.0]))


def test_p_driver_default_sweep_is_the_solve_commands(capsys):
    from multiloop.kin.sweep import input_range as input_values
    m = load(Path(str(resources.files("multiloop.catalogue") / "mechanisms" / "excavator_bucket.toml")))
    assert main(["forces", "excavator_bucket", "--steps", "5", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    want = input_values(m, 5, None, None)
    np.testing.assert_allclose(np.array(doc["input"]), np.repeat(want[:, None], len(m.drivers), axis=1))


def test_forces_plot_without_loads_says_so(tmp_path, capsys):
    assert main(["forces", "four_bar", "--steps", "8", "--plot", str(tmp_path / "f.png")]) == 0
    assert "no loads" in capsys.readouterr().out and (tmp_path / "f.png").exists()


@pytest.mark.parametrize("edit, words", [
    (lambda t: t.replace("table = [", "value = [1.0, 0.0]\ntable = [", 1), "either 'value'"),
    (lambda t: t.replace("table = [", "table = [[0.0, 1.0, 0.0], [0.0, 2.0, 0.0], ", 1), "distinct input angles"),
])
def test_force_table_faults_named(tmp_path, capsys, edit, words):
    """Issue 10: a [[force]] with both value and table, repeated table angles."""
    f = tmp_path / "bad.toml"
    text = edit(LOADED.read_text())
    assert text != LOADED.read_text()
    f.write_text(text)
    assert main(["forces", str(f), "--at", "30"]) == 2
    err = capsys.readouterr().err
    assert words in err and "Traceback" not in err


def test_sparse_elimination_weak_static_pivot_falls_back_to_lapack():
    """A constant pivot 1e-12 against a column entry 1 fails the threshold test: those
    positions are re-solved with partial pivoting and match LAPACK to round-off."""
    from multiloop.kin.forces.linsolve import dense, solve_sparse
    a = np.array([1.0, 2.0, 3.0])
    E = [[1e-12, 1.0], [a, 1.0]]
    b = [np.ones(3), np.arange(3.0)]
    x, det = solve_sparse(E, b, 3)
    ref = np.linalg.solve(dense(E, 3), np.stack(b, axis=-1)[..., None])[..., 0]
    np.testing.assert_allclose(x, ref, rtol=1e-12, atol=1e-15)   # an exact 0 comes back as ~1e-17
    assert np.all(det > 0)
