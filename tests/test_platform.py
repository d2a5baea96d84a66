"""Six-strut platforms (kin.platform, `multiloop platform`).

Published oracles: F. A. Doronin, "Применение теории винтов в статике и динамике
пространственных механизмов параллельной структуры", Izvestiya PGUPS 2015/3,
pp. 130-137 (Doronin 2015): strut forces p. 134, frequencies and mode matrix p. 136,
Plücker rows pp. 132 and 135, V1-V3 p. 133.  The missing figure's geometry is the
reconstruction in docs/platform.md; the bundled file
catalogue/platforms/doronin_platform.toml encodes it.
"""
from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from multiloop.kin.spatial.platform import (Platform, PointLoad, RigidBody, SingularStrutsError, Strut, condition_numbers,
                          load_platform, loads_platform, platform_modes, platform_statics, plucker_matrices,
                          strut_forces_equilibrium, strut_forces_screws, symmetric_struts)
from multiloop.kin.spatial.screws import Twist, reciprocal
from multiloop.cli import main
from multiloop.topo.errors import InputError, LinkageError, SingularityError, SingularityWarning

CATALOGUE = Path(__file__).resolve().parents[1] / "catalogue" / "platforms"
DORONIN = CATALOGUE / "doronin_platform.toml"
GOUGH = CATALOGUE / "gough_stewart.toml"

# --- Doronin 2015, as printed (Doronin 2015) -------------------------------------------
PUBLISHED_FORCES = (-1550.0, 894.43, -700.0, -721.11, -850.0, 0.0)          # p. 134, N
PUBLISHED_K = (6.54, 11.35, 16.49, 31.06, 35.84, 62.44)                    # p. 136, "с⁻¹" = rad/s
PUBLISHED_MASS = dict(m=254.84, Jx=191.34, Jy=340.0, Jz=530.92)            # p. 136
# mode matrix M, p. 136, rows (x, y, z, φx, φy, φz); columns as printed, which follow
# k = 62.44, 35.84, 31.06, 6.54, 11.35, 16.49 (docs/platform.md, "Mode shapes")
PUBLISHED_M = np.array([
    [1, 1, 1, 1, 1, 1],
    [75.734, 0.001, -0.856, -3.222, 0.296, 2.095],
    [-174.373, 0.898, -3.986, 0.065, 0.207, -3.255],
    [1297.895, -2.497, -0.479, 0.157, 0.318, -1.800],   # 1297.895: misprint of 1287.895
    [-944.475, -2.084, -0.091, 0.026, 0.228, -0.401],
    [73.128, -0.370, -1.853, 0.891, -0.057, 3.336],
])
PUBLISHED_M_COLUMN_K = (62.44, 35.84, 31.06, 6.54, 11.35, 16.49)
MISPRINT = (3, 0)          # row φx, column 1

# article data (p. 132, p. 134): dimensions and loads; angles fixed by the text
a, b, c, f = 2.0, 3.0, 4.0, 0.1
G, Q, P = 2500.0, 600.0, 1000.0
gam = math.atan2(a, c)          # tan γ = a/c
bet = math.atan2(a, b)          # tan β = a/b
alp = math.atan2(c, b)          # tan α = c/b
STATICS_O = (0.0, 0.0, -f / 2)  # the statics origin O (hinge plane) in the file's frame


@pytest.fixture(scope="module")
def doronin() -> Platform:
    return load_platform(DORONIN)


@pytest.fixture(scope="module")
def statics(doronin):
    return platform_statics(doronin)


@pytest.fixture(scope="module")
def modes(doronin):
    return platform_modes(doronin)


# --- Doronin 2015: statics ------------------------------------------------------------------
def test_doronin_forces_match_publication(statics):
    np.testing.assert_allclose(statics.forces, PUBLISHED_FORCES, atol=0.01, rtol=0)
    np.testing.assert_allclose(statics.forces_screws, PUBLISHED_FORCES, atol=0.01, rtol=0)
    assert statics.success and statics.discrepancy < 1e-9


def test_doronin_forces_closed_form(statics):
    """Second route: the hand solution of the six equilibrium equations (docs/platform.md)."""
    S4 = -P * math.cos(alp) / math.cos(bet)
    S2 = P * c * math.cos(alp) / (b * math.cos(gam))
    S6 = S2 - P * math.sin(alp) / math.cos(gam)
    S1 = -(G + Q) / 2 - S6 * math.sin(gam)
    S3 = -S1 - S2 * math.sin(gam) - G / 2 - Q
    S5 = -G - Q - (S1 + S3) - (S2 + S6) * math.sin(gam) - S4 * math.sin(bet)   # ΣFz
    np.testing.assert_allclose(statics.forces, [S1, S2, S3, S4, S5, S6], atol=1e-9)
    assert statics.forces[1] == pytest.approx(400 * math.sqrt(5), abs=1e-9)
    assert statics.forces[3] == pytest.approx(-200 * math.sqrt(13), abs=1e-9)


def test_doronin_printed_S1_equation(statics):
    # p. 133: −a cosβ·P sinα + cosβ(Gc/2 + Qc/2 + S1 c) + sinβ·P c cosα = 0
    S1 = (a * math.cos(bet) * P * math.sin(alp) - math.sin(bet) * P * c * math.cos(alp)) / (math.cos(bet) * c) \
        - G / 2 - Q / 2
    assert statics.forces[0] == pytest.approx(S1, abs=1e-9)


def test_doronin_printed_plucker_rows(doronin):
    # p. 132: e2..e6 about O (statics); e1 is not printed
    L = doronin.plucker_matrix(STATICS_O)
    sg, cg, sb, cb = math.sin(gam), math.cos(gam), math.sin(bet), math.cos(bet)
    printed = [
        (-cg, 0, -sg, b * sg, 0, -b * cg),
        (0, 0, -1, b, 0, 0),
        (0, -cb, -sb, 0, 0, 0),
        (0, 0, -1, 0, 0, 0),
        (cg, 0, -sg, 0, -c * sg, 0),
    ]
    np.testing.assert_allclose(L[1:], printed, atol=1e-14)


def test_doronin_printed_force_screw(doronin):
    # p. 133, with S1 = 0: (P sinα, −P cosα, −Q−G; Gb/2 + Qb, −Gc/2 − Qc/2, P c cosα)
    W = doronin.wrench().about(STATICS_O).as_array()
    printed = (P * math.sin(alp), -P * math.cos(alp), -Q - G,
               G * b / 2 + Q * b, -G * c / 2 - Q * c / 2, P * c * math.cos(alp))
    np.testing.assert_allclose(W, printed, atol=1e-9)


def _same_screw(x, y):
    x, y = np.asarray(x), np.asarray(y)
    return np.allclose(x, y, atol=1e-12) or np.allclose(x, -y, atol=1e-12)


def test_doronin_printed_kinematic_screws(statics):
    """V1, V2, V3 (p. 133), up to the sign, which a unit screw does not fix."""
    V = [t.about(STATICS_O).as_array() for t in statics.twists]
    sb, cb, sa, ca = math.sin(bet), math.cos(bet), math.sin(alp), math.cos(alp)
    assert _same_screw(V[0], (0, -cb, sb, -a * cb, 0, 0))
    assert _same_screw(V[1], (0, 0, 1, 0, 0, 0))
    assert _same_screw(V[2], (-sa, -ca, 0, -a * ca, 0, 0))
    # m3: pitch a sinα cosα, axis at distance d = ab²/(b² + c²) below O (printed formula)
    t3 = statics.twists[2].about(STATICS_O)
    assert t3.pitch == pytest.approx(a * sa * ca, abs=1e-12)
    np.testing.assert_allclose(t3.axis_point, (0, 0, -a * b * b / (b * b + c * c)), atol=1e-12)
    # V4 is a pure translation along y (not printed; docs/platform.md, misprint 5)
    assert statics.twists[3].is_infinite_pitch
    np.testing.assert_allclose(np.abs(statics.twists[3].as_array()), (0, 0, 0, 0, 1, 0), atol=1e-12)
    # the sign convention: every removed strut lengthens
    for strut, t in zip(load_platform(DORONIN).struts, statics.twists):
        assert reciprocal(t, strut.unit_wrench()) < 0


# --- Doronin 2015: vibrations ---------------------------------------------------------------
def test_doronin_mass_data(doronin):
    body = doronin.body
    assert round(body.mass, 2) == PUBLISHED_MASS["m"]
    J = np.diag(body.inertia)
    assert [round(J[0], 2), round(J[1], 2), round(J[2], 2)] == [PUBLISHED_MASS["Jx"], 340.00, PUBLISHED_MASS["Jz"]]
    m = G / 9.81
    np.testing.assert_allclose(J, [m * (f**2 + b**2) / 12, m * (f**2 + c**2) / 12, m * (b**2 + c**2) / 12])


def test_doronin_frequencies_to_printed_precision(modes):
    assert np.round(modes.frequencies, 2).tolist() == list(PUBLISHED_K)
    assert np.all(np.diff(modes.frequencies) > 0)


def test_doronin_frequencies_second_route(doronin, modes):
    """k = sqrt(eigenvals(A⁻¹C)) as in the article (non-symmetric route) vs eigh."""
    A, C = modes.inertia_matrix, modes.stiffness_matrix
    k = np.sort(np.sqrt(np.linalg.eigvals(np.linalg.solve(A, C)).real))
    np.testing.assert_allclose(k, modes.frequencies, rtol=1e-12)


def test_doronin_printed_pluck_matrix(modes):
    # p. 135: rows of `Pluck` about the centre of mass
    sg, cg, sb, cb = math.sin(gam), math.cos(gam), math.sin(bet), math.cos(bet)
    printed = np.array([
        (0, 0, -1, 0.5 * b, -0.5 * c, 0),
        (-cg, 0, -sg, 0.5 * b * sg, 0.5 * c * sg + 0.5 * f * cg, -0.5 * b * cg),
        (0, 0, -1, 0.5 * b, 0.5 * c, 0),
        (0, -cb, -sb, -0.5 * b * sb - 0.5 * f * cb, 0.5 * c * sb, -0.5 * c * cb),
        (0, 0, -1, -0.5 * b, 0.5 * c, 0),
        (cg, 0, -sg, -0.5 * b * sg, -0.5 * c * sg - 0.5 * f * cg, -0.5 * b * cg),
    ])
    np.testing.assert_allclose(modes.plucker, printed, atol=1e-14)


def test_doronin_mode_shapes(modes):
    M = modes.shapes("first")
    order = [PUBLISHED_K.index(k) for k in PUBLISHED_M_COLUMN_K]
    computed = M[:, order]
    mask = np.ones_like(PUBLISHED_M, dtype=bool)
    mask[MISPRINT] = False
    assert np.max(np.abs(computed - PUBLISHED_M)[mask]) <= 0.0005 + 1e-9
    # the one printed entry that is off: 1297.895 should read 1287.895
    assert round(computed[MISPRINT], 3) == 1287.895


def test_mode_normalisations(modes):
    A = modes.inertia_matrix
    np.testing.assert_allclose(modes.modes.T @ A @ modes.modes, np.eye(6), atol=1e-12)
    mx = modes.shapes("max")
    assert np.allclose(np.max(np.abs(mx), axis=0), 1.0)
    assert len(modes.labels) == 6 and modes.labels[0].startswith("k1 = 6.537 rad/s")
    np.testing.assert_allclose(modes.energy_fractions.sum(axis=0), 1.0)
    with pytest.raises(InputError, match="normalise"):
        modes.shapes("bogus")


def test_stiffness_matrix_by_finite_differences(doronin, modes):
    """Second route for C: strut elongations of the exactly displaced platform."""
    centre = np.asarray(doronin.body.center)
    P0, B0 = doronin.platform_points, doronin.base_points

    def lengths(q):
        phi = q[3:]
        th = np.linalg.norm(phi)
        K = np.array([[0, -phi[2], phi[1]], [phi[2], 0, -phi[0]], [-phi[1], phi[0], 0]])
        R = np.eye(3) if th == 0 else np.eye(3) + np.sin(th) / th * K + (1 - np.cos(th)) / th**2 * K @ K
        Pq = centre + q[:3] + (P0 - centre) @ R.T
        return np.linalg.norm(B0 - Pq, axis=1)

    h = 1e-6
    J = np.column_stack([(lengths(h * e) - lengths(-h * e)) / (2 * h) for e in np.eye(6)])
    C = J.T @ np.diag(doronin.stiffnesses) @ J
    np.testing.assert_allclose(C, modes.stiffness_matrix, rtol=1e-6, atol=1e-3)


def test_issue_format_with_rounded_mass_data():
    """The literal format of issue 5 (mass/center/inertia as printed, rounded): frequencies unchanged."""
    doc = DORONIN.read_text()
    start = doc.index("[body]")
    text = doc[:start] + "[body]\nmass = 254.84\ncenter = [-2.0, -1.5, 0.0]\ninertia = [191.34, 340.0, 530.92]\n"
    p = loads_platform(text)
    assert np.round(platform_modes(p).frequencies, 2).tolist() == list(PUBLISHED_K)


# --- general platforms ---------------------------------------------------------------
def _random_platform(seed: int, n_loads: int = 3) -> Platform:
    rng = np.random.default_rng(seed)
    ang_p = rng.uniform(0, 2 * np.pi, 6)
    ang_b = rng.uniform(0, 2 * np.pi, 6)
    Pp = np.column_stack([np.cos(ang_p), np.sin(ang_p), rng.normal(0, 0.2, 6)]) * rng.uniform(0.3, 2)
    Bp = np.column_stack([np.cos(ang_b), np.sin(ang_b), -rng.uniform(0.5, 2, 6)]) * rng.uniform(0.5, 3)
    struts = tuple(Strut(tuple(p), tuple(q), float(k)) for p, q, k in zip(Pp, Bp, rng.uniform(1e3, 1e5, 6)))
    loads = tuple(PointLoad(tuple(rng.normal(size=3)), tuple(rng.normal(0, 500, 3)), tuple(rng.normal(0, 50, 3)))
                  for _ in range(n_loads))
    body = RigidBody.from_box(rng.uniform(5, 50), rng.uniform(0.1, 2, 3), tuple(rng.normal(0, 0.3, 3)))
    return Platform(struts, loads, body, name=f"random {seed}")


@given(st.integers(0, 100_000))
def test_screw_method_equals_equilibrium(seed):
    p = _random_platform(seed)
    cond = condition_numbers(p.platform_points, p.base_points)
    assume(cond < 1e4)
    st_ = platform_statics(p)
    scale = max(1.0, np.max(np.abs(st_.forces_screws)))
    np.testing.assert_allclose(st_.forces, st_.forces_screws, atol=1e-9 * scale * cond)
    # and the forces balance the loads: Lᵀ S + W = 0, virtual power zero for any twist
    L = p.plucker_matrix()
    W = p.wrench().as_array()
    np.testing.assert_allclose(L.T @ st_.forces + W, 0.0, atol=1e-8 * scale * cond)
    T = Twist.from_array(np.random.default_rng(seed).normal(size=6))
    power = sum(s * reciprocal(T, strut.unit_wrench()) for s, strut in zip(st_.forces, p.struts)) \
        + reciprocal(T, p.wrench())
    assert abs(power) < 1e-8 * scale * cond
    # each removed-strut twist is reciprocal to the five other struts
    for i, t in enumerate(st_.twists):
        for j, strut in enumerate(p.struts):
            if j != i:
                assert abs(reciprocal(t, strut.unit_wrench())) < 1e-9


@given(st.integers(0, 100_000), st.integers(0, 100_000))
def test_rigid_motion_leaves_forces_and_frequencies(seed, seed2):
    p = _random_platform(seed)
    assume(condition_numbers(p.platform_points, p.base_points) < 1e4)
    rng = np.random.default_rng(seed2)
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    R = q * np.sign(np.diag(r))
    R = R if np.linalg.det(R) > 0 else -R
    moved = p.transformed(R, rng.normal(0, 5, 3))
    s0, s1 = platform_statics(p), platform_statics(moved)
    scale = max(1.0, np.max(np.abs(s0.forces)))
    np.testing.assert_allclose(s1.forces, s0.forces, atol=1e-8 * scale)
    assert s1.condition_number == pytest.approx(s0.condition_number, rel=1e-6)
    np.testing.assert_allclose(platform_modes(moved).frequencies, platform_modes(p).frequencies, rtol=1e-7)
    # the screw axes move with the platform: same pitch
    np.testing.assert_allclose(s1.pitches, s0.pitches, atol=1e-7)


@given(st.integers(0, 100_000), st.floats(0.01, 100.0))
def test_frequencies_scale_as_sqrt_of_stiffness(seed, lam):
    p = _random_platform(seed)
    stiffer = dataclasses.replace(p, struts=tuple(dataclasses.replace(s, stiffness=lam * s.stiffness)
                                                  for s in p.struts))
    np.testing.assert_allclose(platform_modes(stiffer).frequencies,
                               math.sqrt(lam) * platform_modes(p).frequencies, rtol=1e-7)


def test_batch_functions_match_single_queries():
    plats = [_random_platform(s) for s in range(8)]
    Pp = np.stack([p.platform_points for p in plats])
    Bp = np.stack([p.base_points for p in plats])
    W = np.stack([p.wrench().as_array() for p in plats])
    L = plucker_matrices(Pp, Bp)
    S_eq = strut_forces_equilibrium(L, W)
    S_sc, V = strut_forces_screws(L, W)
    assert S_eq.shape == S_sc.shape == (8, 6) and V.shape == (8, 6, 6)
    for k, p in enumerate(plats):
        st_ = platform_statics(p)
        np.testing.assert_allclose(S_eq[k], st_.forces)
        np.testing.assert_allclose(S_sc[k], st_.forces_screws)


# --- symmetric Gough–Stewart ---------------------------------------------------------------
def test_gough_stewart_symmetry():
    p = load_platform(GOUGH)
    assert p.stiffnesses is not None and len({round(s.length, 12) for s in p.struts}) == 1
    centred = dataclasses.replace(p, loads=(PointLoad((0, 0, 0.3), (0, 0, -1200.0)),))
    S = platform_statics(centred).forces
    np.testing.assert_allclose(S, S[0], rtol=1e-12)
    # six equal struts carry the load: 6 S e_z = 1200 N
    ez = p.directions[0, 2]
    assert S[0] * 6 * ez == pytest.approx(1200.0)
    k = platform_modes(p).frequencies
    assert k[0] == pytest.approx(k[1], rel=1e-9) and k[4] == pytest.approx(k[5], rel=1e-9)
    st_ = platform_statics(p)
    assert st_.success and st_.condition_number < 10


def test_singular_struts_raise_with_condition_number():
    struts = symmetric_struts(1.0, 0.5, 30.0, 30.0, 1.0)       # hinge angles coincide: a linear complex
    p = Platform(struts, (PointLoad((0, 0, 0), (0, 0, -100.0)),))
    with pytest.raises(SingularStrutsError, match="condition number") as info:
        platform_statics(p)
    assert info.value.condition_number > 1e10
    assert isinstance(info.value, SingularityError) and isinstance(info.value, LinkageError)
    L = p.plucker_matrix()
    with pytest.warns(SingularityWarning):
        S = strut_forces_equilibrium(L, p.wrench().as_array())
    assert np.all(np.isnan(S))


def test_value_objects_frozen_and_hashable(doronin):
    with pytest.raises(dataclasses.FrozenInstanceError):
        doronin.name = "x"
    assert hash(doronin) == hash(load_platform(DORONIN))
    with pytest.raises(InputError, match="exactly six"):
        Platform(doronin.struts[:5])
    with pytest.raises(InputError, match="J1 \\+ J2"):
        RigidBody(1.0, (0, 0, 0), (1.0, 1.0, 5.0))


# --- files and CLI ---------------------------------------------------------------------
STRUT = "[[strut]]\nplatform = [{x}, {y}, 0.0]\nbase = [{bx}, {by}, -2.0]\nstiffness = 1.0e5\n"


def _issue_text() -> str:
    pts = [(0, 0, 0, 0), (0, -3, -4, -3), (0, -3, 0, -3), (0, 0, 0, -3), (-4, 0, 0, 0), (-4, -3, -4, -3)]
    struts = "".join(STRUT.format(x=float(x), y=float(y), bx=float(bx), by=float(by)) for x, y, bx, by in pts)
    text = ('name = "six-strut platform"\n' + struts +
            "[[load]]\nat = [-2.0, -1.5, 0.0]\nforce = [0.0, 0.0, -2500.0]\n"
            "[body]\nmass = 254.84\ncenter = [-2.0, -1.5, 0.0]\ninertia = [191.34, 340.0, 530.92]\n")
    return text


def _write(tmp_path, text, name="p.toml"):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def test_issue_example_format_parses(tmp_path, capsys):
    assert main(["platform", _write(tmp_path, _issue_text()), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    for key in ("name", "forces", "forces_screws", "condition_number", "screws", "frequencies",
                "frequencies_hz", "modes", "wrench", "conventions", "coordinates"):
        assert key in rep
    assert len(rep["forces"]) == 6 and len(rep["frequencies"]) == 6
    assert rep["frequencies"] == sorted(rep["frequencies"])
    assert {"strut", "twist", "pitch", "axis_point", "axis_direction", "translation"} <= set(rep["screws"][0])


def test_cli_json_doronin(capsys):
    assert main(["platform", str(DORONIN), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    np.testing.assert_allclose(rep["forces"], PUBLISHED_FORCES, atol=0.01)
    assert np.round(rep["frequencies"], 2).tolist() == list(PUBLISHED_K)
    assert rep["screws"][3]["translation"] is True and rep["screws"][3]["pitch"] is None
    assert rep["screws"][2]["pitch"] == pytest.approx(0.96)
    assert rep["modes"][0]["shape_x1"][0] == 1.0


def test_cli_text_bundled_name_and_plot(tmp_path, capsys):
    png = tmp_path / "p.png"
    assert main(["platform", "doronin_platform", "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "-1550.0000" in out and "62.44" in out and "1287.895" in out
    assert png.stat().st_size > 10_000


def test_cli_without_vibration_data(tmp_path, capsys):
    text = _issue_text().replace("stiffness = 1.0e5\n", "").split("[body]")[0]
    assert main(["platform", _write(tmp_path, text), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["frequencies"] is None and rep["modes"] is None


@pytest.mark.parametrize("mutate, needle", [
    (lambda t: t.replace("stiffness = 1.0e5", "stifness = 1.0e5", 1), "stifness"),
    (lambda t: t.replace("platform = [0.0, 0.0, 0.0]", "platform = [0.0, 0.0]", 1), "'platform'"),
    (lambda t: t.replace("base = [0.0, 0.0, -2.0]", 'base = "O"', 1), "'base'"),
    (lambda t: t.replace("force = [0.0, 0.0, -2500.0]", "force = [0.0, 0.0, -2500.0]\nwhere = 1"), "where"),
    (lambda t: t.replace("mass = 254.84", "mass = -1.0"), "'mass'"),
    (lambda t: t.replace("inertia = [191.34, 340.0, 530.92]", "inertia = [1.0, 2.0]"), "'inertia'"),
    (lambda t: t.replace("mass = 254.84", "mass = 254.84\nweight = 2500.0"), "weight"),
    (lambda t: t.replace("stiffness = 1.0e5", "stiffness = 0.0", 1), "'stiffness'"),
    (lambda t: t.replace("stiffness = 1.0e5\n", "", 1), "stiffness"),
    (lambda t: t.replace('name = "six-strut platform"', 'name = "x"\ncolour = 1'), "colour"),
    (lambda t: t.split("[[strut]]", 2)[0] + "[[strut]]" + t.split("[[strut]]", 2)[1] + "[[load]]" +
     t.split("[[load]]")[1], "exactly six"),
    (lambda t: t + "[[strut]]\nplatform = [1.0, 1.0, 0.0]\nbase = [1.0, 1.0, -1.0]\nstiffness = 1.0\n",
     "exactly six"),
    (lambda t: t.replace("[[load]]", "[[load]\n"), "TOML syntax"),
])
def test_bad_files_exit_2_naming_the_key(tmp_path, capsys, mutate, needle):
    assert main(["platform", _write(tmp_path, mutate(_issue_text()))]) == 2
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err
    assert err.startswith("multiloop platform: error:")


def test_missing_file_and_singular_file_exit_2(tmp_path, capsys):
    assert main(["platform", str(tmp_path / "nope.toml")]) == 2
    assert "existing file" in capsys.readouterr().err
    text = GOUGH.read_text().replace("base_half_angle = 10.0", "base_half_angle = 30.0") \
        .replace("platform_half_angle = 10.0", "platform_half_angle = 30.0")
    assert main(["platform", _write(tmp_path, text)]) == 2
    assert "condition number" in capsys.readouterr().err


def test_symmetric_table_and_struts_conflict():
    text = GOUGH.read_text() + "\n" + STRUT.format(x=0.0, y=0.0, bx=0.0, by=1.0)
    with pytest.raises(InputError, match=r"\[symmetric\]"):
        loads_platform(text)


def test_bundled_files_say_where_the_geometry_comes_from():
    for path in (DORONIN, GOUGH):
        text = path.read_text()
        assert "WHERE THE GEOMETRY COMES FROM" in text and "docs/platform.md" in text
        assert load_platform(path).source


def test_statics_and_modes_own_their_json_and_are_read_only():
    """Issue 9: the results serialise themselves; the CLI only formats."""
    from multiloop.kin.spatial.report import platform_report
    p = Platform(symmetric_struts(1.0, 0.5, 10.0, 10.0, 1.0, stiffness=1e6),
                 (PointLoad((0, 0, 0.3), (0, 0, -1200.0)),),
                 RigidBody(100.0, (0.0, 0.0, 0.1), (5.0, 5.0, 8.0)))
    st = platform_statics(p)
    with pytest.raises(ValueError):
        st.forces[0] = 0.0
    doc = json.loads(json.dumps(platform_report(p, "mass").as_dict(), allow_nan=False))
    assert doc["forces"] == pytest.approx(st.forces.tolist())
    assert [s["strut"] for s in doc["screws"]] == [s.name for s in p.struts]
    assert len(doc["modes"]) == 6 and doc["modes_normalisation"] == "mass"
