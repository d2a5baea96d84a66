"""Dimensional synthesis (multiloop.catalogue.dimensional) and ``multiloop synthesise``."""
from __future__ import annotations

import numpy as np
import pytest

from multiloop.catalogue.dimensional import Evaluator, design_space
from multiloop.catalogue.named import load_named
from multiloop.kin.solve import solve


@pytest.mark.parametrize("name", ["four_bar", "watt_1", "stephenson_1", "crank_slider", "dyad_rpr",
                                  "knitting_needle_drive", "stephenson_3_triad",
                                  "stephenson_3", "dyad_prp", "dyad_rpp"])       # the last three: slow path
def test_batched_evaluator_equals_solve(name):
    """Two routes: the parameterised batch evaluator and kin.solve agree at the start design."""
    m = load_named(name)
    sp = design_space(m, [p.name for p in m.points])
    ev = Evaluator(m, sp)
    phi = np.linspace(0.0, 0.6, 13)
    st = solve(m, phi)
    for i, j in enumerate(m.joint_names):
        w, ok = ev.point(np.vstack([sp.x0, sp.x0]), phi, j)
        assert ok.all()
        np.testing.assert_allclose(w[1], st.positions[:, i], atol=1e-12)


# ---------------------------------------------------------------------------------
# exactness: targets traced by a known mechanism are met again from a perturbed start
from dataclasses import replace  # noqa: E402

from multiloop.catalogue.dimensional import Problem, path_target, synthesise  # noqa: E402
from multiloop.topo.model import JointKind, TracerPoint  # noqa: E402


def _with_point(m, link, name="T"):
    """``m`` with a tracer point at the centroid of ``link``'s joints (when it has none)."""
    if any(p.link == link for p in m.points):
        return m, next(p.name for p in m.points if p.link == link)
    at = tuple(np.mean([j.at for j in m.joints if link in j.links], axis=0) + [0.003, 0.004])
    return replace(m, points=m.points + (TracerPoint(name, link, at),)), name


def _perturbed(m, rel, seed=1):
    rng = np.random.default_rng(seed)
    size = float(np.max(np.ptp(np.array([j.at for j in m.joints]), axis=0)))
    js = [replace(j, at=tuple(np.asarray(j.at) + rng.normal(0.0, rel * size, 2))) for j in m.joints]
    return replace(m, joints=tuple(js))


CASES = [("four_bar", "coupler", np.arange(7.0, 360.0, 33.0), 0.03),          # four-bar
         ("watt_1", "link_5", np.arange(7.0, 360.0, 33.0), 0.01),              # Watt six-bar
         ("stephenson_1", "link_4", np.arange(7.0, 300.0, 29.0), 0.01),        # Stephenson six-bar
         ("knitting_needle_drive", "link_9", np.arange(7.0, 300.0, 29.0), 0.002),  # multiple joints
         ("crank_slider", "rod", np.arange(7.0, 360.0, 33.0), 0.02)]           # slider


@pytest.mark.parametrize("name,link,deg,rel", CASES, ids=[c[0] for c in CASES])
def test_known_mechanism_targets_are_met(name, link, deg, rel):
    m, pt = _with_point(load_named(name), link)
    st = solve(m, np.radians(deg))
    assert (st.status == "ok").all()
    target = st.point_positions[:, st.point_index(pt)]
    start = _perturbed(m, rel)
    res = synthesise(start, path=target, point=pt, evaluations=15000, seed=0)
    assert res.error_max < 1e-3, (res.error_max, res.notes)
    # the output, solved from its reference by kin.solve (continuation), meets the targets
    out = res.mechanism
    st2 = solve(out, res.inputs)
    assert (st2.status == "ok").all()
    size = float(np.max(np.ptp(target, axis=0)))
    got = st2.point_positions[:, st2.point_index(pt)]
    assert np.max(np.hypot(*(got - target).T)) / size < 1e-3
    assert [j.name for j in out.joints] == [j.name for j in m.joints]
    assert [lk.name for lk in out.links] == [lk.name for lk in m.links]


# ---------------------------------------------------------------------------------
# command line: a good run and bad input (exit 2, one message, nothing written)
from multiloop.catalogue.named import path as named_path  # noqa: E402
from multiloop.cli import main  # noqa: E402


def _four_bar_path(tmp_path, rows=None, header=True):
    m = load_named("four_bar")
    P = solve(m, np.radians(np.arange(7.0, 360.0, 33.0))).point_positions[:, 0]
    P = P if rows is None else rows
    f = tmp_path / "target.csv"
    f.write_text(("x,y\n" if header else "") + "\n".join(",".join(repr(float(v)) for v in r) for r in P) + "\n")
    return f


def test_cli_path_writes_a_mechanism_that_solves(tmp_path, capsys):
    import json
    from multiloop.topo.io import load
    tgt = _four_bar_path(tmp_path)
    out = tmp_path / "out.toml"
    png = tmp_path / "fit.png"
    rc = main(["synthesise", str(named_path("four_bar")), "--path", str(tgt), "--point", "P",
               "--out", str(out), "--evaluations", "3000", "--json", "--plot", str(png)])
    assert rc == 0
    assert png.stat().st_size > 1000
    doc = json.loads(capsys.readouterr().out)
    assert doc["error_max"] < 1e-3 and doc["evaluations"] > 0
    m = load(out)
    assert "target.csv" in m.source
    assert main(["analyse", str(out)]) == 0
    assert main(["solve", str(out), "--steps", "8"]) == 0
    assert main(["check", str(out)]) == 0          # read like any other mechanism file


@pytest.mark.parametrize("case", ["few", "nan", "point", "budget", "evaluations", "unassembled", "output", "link"])
def test_cli_bad_input_exit_2(tmp_path, capsys, case):
    start = str(named_path("four_bar"))
    out = tmp_path / "out.toml"
    tgt = _four_bar_path(tmp_path)
    args = ["synthesise", start, "--path", str(tgt), "--point", "P", "--out", str(out), "--evaluations", "3000"]
    if case == "few":
        args[3] = str(_four_bar_path(tmp_path, rows=[[0.0, 0.0], [0.01, 0.02]]))
    elif case == "nan":
        args[3] = str(_four_bar_path(tmp_path, rows=[[0.0, 0.0], [0.01, float("nan")], [0.02, 0.0]]))
    elif case == "point":
        args[5] = "nowhere"
    elif case == "budget":
        args += ["--budget", "0"]
    elif case == "evaluations":
        args[-1] = "0"
    elif case == "unassembled":
        bad = tmp_path / "bad.toml"
        # an RRR dyad whose pins cannot meet: |O4 A| > |AB| + |B O4| is impossible in a
        # reference configuration, so make the start singular instead (B on the line A-O4)
        text = named_path("four_bar").read_text().replace("[0.133881, 0.072471]", "[0.06, 0.0173205]")
        bad.write_text(text.replace("[0.02, 0.034641]", "[0.02, 0.034641]"))
        args[1] = str(bad)
    elif case == "output":
        args = ["synthesise", start, "--function", str(tgt), "--output", "nowhere", "--out", str(out)]
    elif case == "link":
        args = ["synthesise", start, "--motion", str(tgt), "--link", "coupler", "--out", str(out)]
    rc = main(args)
    err = capsys.readouterr().err
    assert rc == 2, err
    assert "error" in err and "Traceback" not in err
    assert not out.exists()


# ---------------------------------------------------------------------------------
# closed forms: Freudenstein 1955 (three precision pairs), Burmester 1888 (three poses)
from multiloop.catalogue.dimensional.closedform import (burmester_four_bar, burmester_points,  # noqa: E402
                                                        centre_point, circle_point_curve, concyclic,
                                                        freudenstein, freudenstein_four_bar, pose_positions)


def _angle(v):
    return np.arctan2(v[..., 1], v[..., 0])


def test_freudenstein_recovers_the_catalogue_four_bar():
    """Two routes: lengths from the catalogue's coordinates, and Freudenstein's equation
    solved on three (φ, ψ) pairs that kin.solve reads off the same four-bar."""
    m = load_named("four_bar")
    st = solve(m, np.radians([0.0, 40.0, 80.0]))
    J = {n: st.positions[:, i] for i, n in enumerate(m.joint_names)}
    phi, psi = _angle(J["A"] - J["O2"]), _angle(J["B"] - J["O4"])
    at = {j.name: np.asarray(j.at) for j in m.joints}
    a, b, c = freudenstein(phi, psi, d=np.hypot(*(at["O4"] - at["O2"])))
    assert a == pytest.approx(np.hypot(*(at["A"] - at["O2"])), abs=1e-12)
    assert b == pytest.approx(np.hypot(*(at["B"] - at["A"])), abs=1e-12)
    assert c == pytest.approx(np.hypot(*(at["B"] - at["O4"])), abs=1e-12)


def test_freudenstein_four_bar_meets_its_three_points_exactly():
    phi = np.radians([30.0, 60.0, 90.0])
    psi = np.radians([70.0, 85.0, 105.0])
    fb = freudenstein_four_bar(phi, psi, d=1.0)
    st = solve(fb, phi - phi[0])
    assert (st.status == "ok").all()
    k = fb.link_names.index("rocker")
    np.testing.assert_allclose(st.angles[:, k], psi - psi[0], atol=1e-9)


def test_burmester_three_poses_exact():
    poses = np.array([[0.0, 0.0, 0.0], [0.05, 0.02, 0.3], [0.09, 0.01, 0.7]])
    m1, m2 = (0.0, -0.03), (0.04, -0.02)
    fb = burmester_four_bar(poses, m1, m2)
    O1 = np.asarray(fb.joint("O1").at)
    A = pose_positions(poses, m1)
    ang = _angle(A - O1)
    st = solve(fb, ang - ang[0])
    assert (st.status == "ok").all()
    np.testing.assert_allclose(st.point_positions[:, 0], poses[:, :2], atol=1e-9)
    np.testing.assert_allclose(st.angles[:, fb.link_names.index("coupler")], poses[:, 2], atol=1e-9)
    # the centre point is equidistant from the three positions (two routes)
    c = centre_point(A)
    assert np.ptp(np.hypot(*(A - c).T)) < 1e-12


def test_circle_point_curve_and_burmester_points():
    poses = np.array([[0.0, 0.0, 0.0], [0.05, 0.02, 0.3], [0.09, 0.01, 0.7], [0.1, -0.02, 1.0],
                      [0.08, -0.05, 1.3]])
    pts = circle_point_curve(poses[:4], ((-0.1, -0.1), (0.1, 0.1)), n=40)
    assert len(pts) > 20
    for q in pts:     # the four positions of a circle point lie on one circle
        X = pose_positions(poses[:4], q)
        c = centre_point(X[:3])
        r0 = np.hypot(*(X[0] - c))
        assert abs(np.hypot(*(X[3] - c)) - r0) < 1e-8 * max(r0, 1.0)
    bp = burmester_points(poses, ((-0.2, -0.2), (0.2, 0.2)), n=12)
    assert len(bp) >= 1
    for q in bp:      # all five positions on one circle
        X = pose_positions(poses, q)
        r = np.hypot(*(X - centre_point(X[:3])).T)
        assert np.ptp(r) < 1e-9
        assert abs(concyclic(X[:4])) < 1e-12


# ---------------------------------------------------------------------------------
# every design variable reaches the solver; function, motion, timing, shape, CMA-ES
from multiloop.catalogue.dimensional import function_target, motion_target  # noqa: E402


@pytest.mark.parametrize("name,link", [("four_bar", "coupler"), ("watt_1", "link_5"), ("crank_slider", "rod"),
                                       ("stephenson_3_triad", "T2")])
def test_every_design_variable_changes_the_objective(name, link):
    m, pt = _with_point(load_named(name), link)
    st = solve(m, np.radians(np.arange(5.0, 60.0, 6.0)))
    ok = st.status == "ok"
    target = st.point_positions[ok, st.point_index(pt)] + 1e-3
    t = path_target(m, target, pt)
    sp = design_space(m, [pt], region=target)
    pr = Problem(Evaluator(m, sp), t)
    z0 = pr.x0
    phi = pr.match(z0)
    r0 = pr.residuals(z0, phi)
    for i, n in enumerate(pr.names):
        z = z0.copy()
        z[i] += 1e-4 * (1.0 + abs(z[i]))
        assert np.max(np.abs(pr.residuals(z, phi) - r0)) > 1e-9, n


@pytest.mark.parametrize("name,link", [("four_bar", "coupler"), ("watt_1", "link_5"), ("crank_slider", "rod"),
                                       ("stephenson_3_triad", "T2"), ("stephenson_3", "T2")])
@pytest.mark.parametrize("timing", ["free", "reference", "absolute", "step", "shape", "shape-step"])
def test_the_exact_jacobian_equals_central_differences(name, link, timing):
    """Point matching's exact Jacobian (the poses' design sensitivities; each target's
    driver value by the velocity analogue, free or moved by the timing's offset or the
    design's own zero; a shape-only target's similarity; a triad's and a class IV
    group's along the walk) equals central differences of its residuals."""
    m, pt = _with_point(load_named(name), link)
    x = np.radians(np.arange(5.0, 60.0, 6.0))
    st = solve(m, x)
    ok = np.asarray(st.status == "ok")
    target = st.point_positions[ok, st.point_index(pt)] + 1e-3
    shape = timing.startswith("shape")
    mode = {"free": None, "shape": None}.get(timing, timing.replace("shape-", ""))
    path = target if mode is None else np.c_[target, np.degrees(x[ok]) + (30.0 if mode == "absolute" else 0.0)]
    t = path_target(m, path, pt, shape_only=shape, **({} if mode is None else {"timing": mode}))
    pr = Problem(Evaluator(m, design_space(m, [pt], region=target)), t)
    pr.init_offset()
    pr.init_shape()
    assert pr.exact_jacobian and pr.free_timing == (mode is None)
    z = pr.x0
    free = pr.free_timing
    phi = pr.match(z) if free else pr.timing_for(z[None])[0]
    R, J = pr.jacobian_batch(z[None], phi[None])
    np.testing.assert_array_equal(R[0], pr.residuals(z, phi))
    w = np.concatenate([z, phi]) if free else z
    n = len(pr.names)
    fd = []
    for i in range(len(w)):
        h = 1e-6 * (m.size if i < pr.nx else 1.0)
        up, down = w.copy(), w.copy()
        up[i] += h
        down[i] -= h
        res = [pr.residuals(v[:n], v[n:] if free else pr.timing_for(v[None])[0]) for v in (up, down)]
        fd.append((res[0] - res[1]) / (2 * h))
    np.testing.assert_allclose(J[0], np.stack(fd, axis=1), rtol=0, atol=1e-6 * np.abs(J).max())


def _central_residuals(pr, z, phi, free, h_design):
    """Central differences of ``pr``'s residuals by its variables (and free driver values)."""
    w = np.concatenate([z, phi]) if free else z
    n = len(pr.names)
    out = []
    for i in range(len(w)):
        h = h_design if i < pr.nx else 1e-6
        up, down = w.copy(), w.copy()
        up[i] += h
        down[i] -= h
        res = [pr.residuals(v[:n], v[n:] if free else pr.timing_for(v[None])[0]) for v in (up, down)]
        out.append((res[0] - res[1]) / (2 * h))
    return np.stack(out, axis=1)


@pytest.mark.parametrize("task,name,what", [("motion", "four_bar", "coupler"), ("motion", "watt_1", "link_5"),
                                            ("motion", "stephenson_3_triad", "T2"),
                                            ("function", "four_bar", "O4"), ("function", "crank_slider", "S"),
                                            ("function", "watt_2", "O6")])
def test_the_exact_jacobian_of_motion_and_function_targets(task, name, what):
    """Motion generation (a frame on the link: its point and angle, the frame's offset as
    variables, free timing) and function generation (a relative angle, or a P joint's
    slide, at prescribed inputs): the exact Jacobian equals central differences."""
    m = load_named(name)
    x = np.radians(np.arange(5.0, 60.0, 6.0))
    st = solve(m, x)
    ok = np.asarray(st.status == "ok")
    if task == "motion":
        xy, th = st.point_on_link(what, np.mean([j.at for j in m.joints if what in j.links], axis=0))[0], \
            st.angles[:, st.link_index(what)]
        t = motion_target(m, np.c_[xy[ok] + 1e-3, np.degrees(th[ok]) + 0.5], what)
    else:
        j = m.joint(what)
        out = (st.angles[:, st.link_index(j.links[1])] - st.angles[:, st.link_index(j.links[0])]) \
            if j.kind is JointKind.R else st.positions[:, st.joint_index("B"), 0]
        out = np.degrees(out) if j.kind is JointKind.R else out - out[0]
        t = function_target(m, np.c_[np.degrees(x[ok]) - np.degrees(x[ok][0]), out[ok] * 1.01], what)
    ev = Evaluator(m, design_space(m, []))
    pr = Problem(ev, t)
    pr.init_motion_frame()
    assert pr.exact_jacobian
    z = pr.x0
    free = pr.free_timing
    phi = pr.match(z) if free else pr.timing_for(z[None])[0]
    R, J = pr.jacobian_batch(z[None], phi[None])
    np.testing.assert_array_equal(R[0], pr.residuals(z, phi))
    fd = _central_residuals(pr, z, phi, free, 1e-6 * m.size)
    np.testing.assert_allclose(J[0], fd, rtol=0, atol=1e-6 * np.abs(J).max())


def test_the_jacobian_is_differenced_where_it_is_not_exact():
    """The constraints other than full rotation keep the forward differences (no exact
    Jacobian is claimed); a shape-only target has one."""
    m, pt = _with_point(load_named("four_bar"), "coupler")
    st = solve(m, np.radians(np.arange(5.0, 60.0, 6.0)))
    target = st.point_positions[:, st.point_index(pt)]
    ev = Evaluator(m, design_space(m, [pt], region=target))
    from multiloop.catalogue.dimensional.objective import Constraints
    assert Problem(ev, path_target(m, target, pt, shape_only=True)).exact_jacobian
    assert not Problem(ev, path_target(m, target, pt), Constraints(max_ratio=3.0)).exact_jacobian


def test_the_exact_polish_converges_fast_despite_the_timing_symmetry():
    """Free timing has a symmetry (the reference pose slid along the motion, every driver
    value moved back), so the exact Jacobian is singular at every design; with its
    singular values floored (``optimise._floored``) the trust region takes Gauss-Newton
    steps and reaches rounding in no more evaluations than the forward differences,
    where it had crept at a linear rate (426 evaluations against 137)."""
    from multiloop.catalogue.dimensional import optimise
    m = load_named("four_bar")
    P = solve(m, np.radians(np.arange(7.0, 360.0, 33.0))).point_positions[:, 0]
    start = _perturbed(m, 0.03, seed=4)
    pr = Problem(Evaluator(start, design_space(start, ["P"], region=P)), path_target(start, P, "P"))
    z, phi = pr.x0, pr.match(pr.x0)
    R, J = pr.jacobian_batch(z[None], phi[None])
    s = np.linalg.svd(J[0], compute_uv=False)
    assert s[-1] < 1e-12 * s[0]                      # (the symmetry)
    z2, p2, n = optimise.polish(pr, z, phi, max_nfev=100)
    assert np.sqrt(np.mean(pr.residuals(z2, p2) ** 2)) < 1e-13 and n <= 250


def test_a_full_rotation_penalty_has_its_gradient():
    """With ``full_rotation`` (topology synthesis's closed targets) the Jacobian stays
    exact and carries the penalty row: zero where the penalty is flat, and the
    reference-margin hinge's gradient where the reference is within 1e-3 of singular
    (the rocker nearly in line with the coupler), both equal to central differences."""
    from multiloop.catalogue.dimensional.objective import Constraints
    m = load_named("four_bar")
    P = solve(m, np.radians(np.arange(7.0, 360.0, 33.0))).point_positions[:, 0]
    A, B = (np.array(m.joint(n).at) for n in ("A", "B"))
    d = (B - A) / np.linalg.norm(B - A)
    for off in (None, 3e-5):                     # O4 on line AB beyond B, 3e-5 off it: margin 3.75e-4
        start = m if off is None else _moved_joint(m, "O4", tuple(B + 0.08 * d + off * np.array([-d[1], d[0]])))
        pr = Problem(Evaluator(start, design_space(start, ["P"], region=P)), path_target(start, P, "P"),
                     Constraints(full_rotation=True))
        assert pr.exact_jacobian and pr.constrained
        z = pr.x0
        phi = pr.match(z)
        R, J = pr.jacobian_batch(z[None], phi[None])
        active = pr.reference_margin(z[None, :pr.nx])[0] < 1e-3
        assert active == (off is not None) and R.shape[1] == 2 * len(P) + 1 and R[0, -1] == pr.penalty_batch(z[None])[0]
        fd = []
        for i in range(pr.nx):
            h = 1e-8 * m.size
            up, down = z.copy(), z.copy()
            up[i] += h
            down[i] -= h
            fd.append((pr.penalty_batch(up[None])[0] - pr.penalty_batch(down[None])[0]) / (2 * h))
        np.testing.assert_allclose(J[0, -1, :pr.nx], fd, rtol=1e-4, atol=1e-6 * max(1.0, np.abs(fd).max()))
        assert np.any(J[0, -1] != 0) == active


def _moved_joint(m, name, at):
    return replace(m, joints=tuple(replace(j, at=at) if j.name == name else j for j in m.joints))


def test_function_generation_freudenstein_start_is_exact():
    m = load_named("four_bar")
    table = np.array([[0.0, 0.0], [30.0, 15.0], [60.0, 30.0]])
    res = synthesise(m, function=table, output="O4", evaluations=3000)
    assert res.error_max < 1e-9
    assert any("Freudenstein" in n for n in res.notes)
    out = res.mechanism
    st = solve(out, np.radians(table[:, 0]))
    j = out.joint("O4")
    rel = st.angles[:, out.link_names.index(j.links[1])] - st.angles[:, out.link_names.index(j.links[0])]
    np.testing.assert_allclose(np.degrees(rel), table[:, 1], atol=1e-7)


def test_function_generation_of_a_known_four_bar():
    """The output of a known four-bar is met again from a perturbed start (7 points)."""
    m = load_named("four_bar")
    x = np.arange(0.0, 91.0, 15.0)
    st = solve(m, np.radians(x))
    j = m.joint("O4")
    y = np.degrees(st.angles[:, m.link_names.index(j.links[1])] - st.angles[:, m.link_names.index(j.links[0])])
    res = synthesise(_perturbed(m, 0.03), function=np.column_stack([x, y]), output="O4", evaluations=12000)
    assert res.error_max < 1e-3


def test_motion_generation_of_a_known_coupler():
    m = load_named("four_bar")
    deg = np.arange(10.0, 300.0, 40.0)
    st = solve(m, np.radians(deg))
    k = m.link_names.index("coupler")
    poses = np.column_stack([st.point_positions[:, 0], np.degrees(st.angles[:, k])])
    res = synthesise(_perturbed(m, 0.02), motion=poses, link="coupler", evaluations=5000)
    assert res.error_max < 1e-3 and res.angle_error_max < 0.06


def test_prescribed_timing_and_shape_only():
    m = load_named("four_bar")
    deg = np.arange(10.0, 300.0, 40.0)
    P = solve(m, np.radians(deg)).point_positions[:, 0]
    res = synthesise(_perturbed(m, 0.02), path=np.column_stack([P, deg]), point="P", evaluations=12000)
    assert res.error_max < 1e-3
    np.testing.assert_allclose(res.inputs, np.radians(deg))
    # shape only: a scaled, rotated, shifted copy of the curve is met by a similar mechanism
    c, s = np.cos(0.4), np.sin(0.4)
    Q = 1.7 * P @ np.array([[c, s], [-s, c]]) + [0.3, -0.2]
    res2 = synthesise(_perturbed(m, 0.01), path=Q, point="P", shape_only=True, evaluations=12000)
    assert res2.error_max < 1e-3


def test_cmaes_and_seed_reproducible():
    m = load_named("four_bar")
    P = solve(m, np.radians(np.arange(7.0, 360.0, 33.0))).point_positions[:, 0]
    start = _perturbed(m, 0.05, seed=3)
    a = synthesise(start, path=P, point="P", evaluations=8000, method="cmaes", seed=4, tol=0.0)
    assert a.error_max < 1e-3
    kw = dict(path=P, point="P", method="de", seed=5, tol=0.0, popsize=5, evaluations=1000)
    r1, r2 = (synthesise(start, **kw) for _ in range(2))
    # same seed and evaluations: the same generations, evaluations and design
    assert len(r1.history) > 1 and [h[1:] for h in r1.history] == [h[1:] for h in r2.history]
    assert r1.design == r2.design and r1.evaluations == r2.evaluations <= 1000


def test_cli_function_and_motion(tmp_path, capsys):
    f = tmp_path / "f.csv"
    f.write_text("input,output\n0,0\n30,15\n60,30\n")
    out = tmp_path / "f.toml"
    assert main(["synthesise", str(named_path("four_bar")), "--function", str(f), "--output", "O4",
                 "--out", str(out), "--evaluations", "3000", "--plot", str(tmp_path / "f.png")]) == 0
    assert "function generation" in capsys.readouterr().out
    assert (tmp_path / "f.png").exists()
    poses = tmp_path / "p.csv"
    poses.write_text("0.05,0.1,0\n0.03,0.11,10\n0.0,0.1,25\n")
    out2 = tmp_path / "p.toml"
    assert main(["synthesise", str(named_path("four_bar")), "--motion", str(poses), "--link", "coupler",
                 "--out", str(out2), "--evaluations", "3000"]) == 0
    assert "pose angle error" in capsys.readouterr().out
    assert main(["solve", str(out2), "--steps", "4"]) == 0


@pytest.mark.parametrize("name", ["six_bar_slider", "dyad_rpr", "watt_1"])
def test_transmission_angles_agree_with_check(name):
    """Two routes: the batched penalty's angles and multiloop check's definitions."""
    from multiloop.catalogue.dimensional import transmission_angles
    from multiloop.kin.check.transmission import angle_specs, angle_values
    from multiloop.kin.solve import compile_plan
    m = load_named(name)
    sp = design_space(m, [])
    ev = Evaluator(m, sp)
    phi = np.linspace(0.0, 0.5, 11)
    ours = transmission_angles(ev, sp.x0[None, :], ev.poses(sp.x0[None, :], phi))[0]
    plan = compile_plan(m)
    st = solve(m, phi)
    specs = [s_ for s_ in angle_specs(plan.assur) if s_.quantity != "triad"]
    v = angle_values(st, specs)
    folded = np.column_stack([np.minimum(v[:, i], 180.0 - v[:, i]) if s_.quantity == "transmission"
                              else 90.0 - v[:, i] for i, s_ in enumerate(specs)])
    np.testing.assert_allclose(ours, folded.min(axis=1), atol=1e-9)


def test_function_generation_slider_output_in_metres():
    """A P output joint: the slide of the piston (m) against the crank angle (deg)."""
    m = load_named("crank_slider")
    x = np.arange(0.0, 181.0, 20.0)
    st = solve(m, np.radians(x))
    j = m.joint("S")
    B = st.positions[:, m.joint_names.index("B")]                  # B rides on the piston
    y = (B - B[0]) @ (np.asarray(j.axis) / np.hypot(*j.axis))
    res = synthesise(_perturbed(m, 0.02), function=np.column_stack([x, y]), output="S", evaluations=12000)
    assert res.error_max < 1e-3
    np.testing.assert_allclose(res.achieved, y, atol=1e-3 * np.ptp(y))


# ---------------------------------------------------------------------------------
# both limits bind the slow path (kin.solve per candidate): the evaluations exactly, and the
# seconds on a simulated clock on which every design solved costs 10 ms (no wall time is measured)
@pytest.mark.parametrize("method", ["de", "cmaes"])
def test_slow_path_respects_the_limits(method, monkeypatch):
    import itertools
    import time

    import multiloop.kin.design as design
    from multiloop.kin.groups.class4 import Class4Step
    # a class IV group without its batched form: the plan is solved design by design
    monkeypatch.setattr(Class4Step, "batched", False)
    m = load_named("stephenson_3")
    assert Evaluator(m, design_space(m, ["P"])).slow
    st = solve(m, np.radians(np.arange(0.0, 60.0, 10.0)))
    target = st.point_positions[:, st.point_index("P")]
    res = synthesise(m, path=target, point="P", evaluations=150, seed=0, tol=0.0, method=method)
    assert res.evaluations <= 150 and res.stopped == "evaluations" and np.isfinite(res.error_max)
    solved, readings, original = [], itertools.count(), design.design_mechanism
    monkeypatch.setattr(design, "design_mechanism", lambda geo, d: solved.append(d) or original(geo, d))
    monkeypatch.setattr(time, "perf_counter", lambda: 0.01 * len(solved) + 1e-6 * next(readings))
    budget = 1.0
    res = synthesise(m, path=target, point="P", evaluations=10 ** 6, budget=budget, seed=0, tol=0.0, method=method)
    assert res.stopped == "budget" and np.isfinite(res.error_max)
    # a population is 8 designs per variable (over a second on this clock): the loop stopped
    # inside one, and the final assessment fits in the reserve
    assert res.seconds <= 1.1 * budget, res.seconds


# ---------------------------------------------------------------------------------
# constraint options: full rotation, length bounds, longest / shortest ratio
def _non_grashof_four_bar():
    """The catalogue four-bar with a 0.09 crank: s + l > p + q, the crank rocks."""
    m = load_named("four_bar")
    js = [replace(j, at=(0.045, 0.0779423)) if j.name == "A" else j for j in m.joints]
    return replace(m, joints=tuple(js))


def _link_lengths(m):
    """Distances between the R joints of each link (the frame's too), from the joints."""
    from multiloop.topo.model import JointKind
    out = []
    for lk in m.link_names:
        at = [np.asarray(j.at) for j in m.joints if lk in j.links and j.kind is JointKind.R]
        out += [np.hypot(*(at[a] - at[b])) for a in range(len(at)) for b in range(a + 1, len(at))]
    return np.array(out)


def test_full_rotation_penalises_a_rocking_crank():
    from multiloop.catalogue.dimensional.objective import Constraints
    from multiloop.kin.check import check
    m0 = load_named("four_bar")
    st = solve(m0, np.radians(np.arange(10.0, 130.0, 20.0)))
    target = st.point_positions[:, st.point_index("P")]
    for m, rotates in ((load_named("four_bar"), True), (_non_grashof_four_bar(), False)):
        assert check(m).drivers[0].full_rotation is rotates
        ev = Evaluator(m, design_space(m, ["P"]))
        t = path_target(m, target, "P")
        free, full = (Problem(ev, t, c).batch(ev.space.x0[None, :])[0]
                      for c in (Constraints(), Constraints(full_rotation=True)))
        assert (full > free + 1e-3) is not rotates and full >= free


def test_full_rotation_result_turns_fully():
    from multiloop.kin.check import check
    m = load_named("four_bar")
    st = solve(m, np.radians(np.arange(10.0, 130.0, 20.0)))
    target = st.point_positions[:, st.point_index("P")]
    # (a search outcome: with 6000 evaluations 7 of 8 seeds met it, with either DE)
    res = synthesise(_non_grashof_four_bar(), path=target, point="P", full_rotation=True, evaluations=12000, seed=0)
    assert check(res.mechanism).drivers[0].full_rotation      # the output's driver turns fully
    row = next(c for c in res.constraints if c["name"] == "full_rotation")
    assert row["met"] and row["value"]["certified"] and row["violation"] == 0.0     # and the report says so
    assert np.isfinite(res.error_max)          # (the budget may not reach the true four-bar from this start)


def test_length_bounds_and_max_ratio_are_met():
    m = load_named("four_bar")                     # lengths 0.04 .. 0.12: ratio 3
    st = solve(m, np.radians(np.arange(7.0, 360.0, 33.0)))
    target = st.point_positions[:, st.point_index("P")]
    assert _link_lengths(m).max() / _link_lengths(m).min() > 2.9
    res = synthesise(m, path=target, point="P", max_ratio=2.0, evaluations=6000, seed=0)
    L = _link_lengths(res.mechanism)
    assert L.max() / L.min() <= 2.0 * (1 + 1e-6), L
    res = synthesise(m, path=target, point="P", length_bounds=(0.05, 0.2), evaluations=6000, seed=0)
    L = _link_lengths(res.mechanism)
    assert L.min() >= 0.05 * (1 - 1e-6) and L.max() <= 0.2 * (1 + 1e-6), L


def test_polish_trades_the_targets_against_the_constraints():
    """The local polish sees the constraint penalty: from the exact four-bar (zero target
    residual) with a longest/shortest ratio of 3 under ``max_ratio=2``, the polish moves
    towards the constraint; a polish of the target residuals alone would not move."""
    from multiloop.catalogue.dimensional.objective import Constraints
    from multiloop.catalogue.dimensional.optimise import polish
    m = load_named("four_bar")
    st = solve(m, np.radians(np.arange(7.0, 360.0, 33.0)))
    target = st.point_positions[:, st.point_index("P")]
    ev = Evaluator(m, design_space(m, ["P"], region=target))
    pr = Problem(ev, path_target(m, target, "P"), Constraints(max_ratio=2.0))
    z0 = pr.x0.copy()
    phi0 = np.radians(np.arange(7.0, 360.0, 33.0))             # where the targets were read
    assert np.max(np.abs(pr.residuals(z0, phi0))) < 1e-6       # the start meets the targets
    v0 = pr.penalty_batch(z0[None, :])[0]
    assert v0 > 0.1                                             # and violates the ratio
    z1, phi1, _ = polish(pr, z0, phi0, max_nfev=60)
    assert pr.penalty_batch(z1[None, :])[0] < 0.5 * v0


def test_cli_length_bounds(tmp_path, capsys):
    from multiloop.topo.io import load
    start = str(named_path("four_bar"))
    tgt = tmp_path / "t.csv"
    m = load_named("four_bar")
    st = solve(m, np.radians(np.arange(7.0, 360.0, 45.0)))
    np.savetxt(tgt, st.point_positions[:, st.point_index("P")], delimiter=",")
    out = tmp_path / "o.toml"
    base = ["synthesise", start, "--path", str(tgt), "--point", "P", "--out", str(out), "--evaluations", "3000"]
    assert main(base + ["--length-bounds", "0.05", "0.2"]) == 0
    L = _link_lengths(load(str(out)))
    assert L.min() >= 0.05 * (1 - 1e-6) and L.max() <= 0.2 * (1 + 1e-6), L
    out.unlink()
    for bad in (["0.2", "0.05"], ["0", "0.2"], ["nan", "1"]):
        capsys.readouterr()
        assert main(base + ["--length-bounds", *bad]) == 2
        err = capsys.readouterr().err
        assert "--length-bounds" in err and "Traceback" not in err
        assert not out.exists()


def test_cli_without_a_terminal_writes_nothing_to_stderr(tmp_path, capsys):
    """The rich progress bar is shown only when stderr is a terminal."""
    import sys
    assert not sys.stderr.isatty()
    start = str(named_path("four_bar"))
    tgt = tmp_path / "t.csv"
    m = load_named("four_bar")
    st = solve(m, np.radians(np.arange(7.0, 360.0, 45.0)))
    np.savetxt(tgt, st.point_positions[:, st.point_index("P")], delimiter=",")
    assert main(["synthesise", start, "--path", str(tgt), "--point", "P", "--out", str(tmp_path / "o.toml"),
                 "--evaluations", "1500"]) == 0
    assert capsys.readouterr().err == ""


def test_progress_bar_callback_reports_fractions():
    from multiloop.catalogue.dimensional.report import progress_bar
    with progress_bar(False) as cb:                      # off: no bar, no callback
        assert cb is None
    seen = []
    m = load_named("four_bar")
    st = solve(m, np.radians(np.arange(7.0, 360.0, 45.0)))
    synthesise(m, path=st.point_positions[:, st.point_index("P")], point="P", evaluations=1500, tol=0.0,
               progress=lambda frac, best: seen.append((frac, best)))
    assert seen and all(0.0 <= f <= 1.0 for f, _ in seen)
    assert all(b2 <= b1 for (_, b1), (_, b2) in zip(seen, seen[1:]))     # the best only improves


def test_triad_targets_are_met():
    """A mechanism with a triad (class III group): targets traced by the catalogue
    stephenson_3_triad are met again from a slightly perturbed copy."""
    m = load_named("stephenson_3_triad")
    st = solve(m, np.radians(np.arange(7.0, 300.0, 29.0)))
    assert (st.status == "ok").all()
    target = st.point_positions[:, st.point_index("P")]
    res = synthesise(_perturbed(m, 0.001), path=target, point="P", evaluations=3000, seed=0)
    assert res.error_max < 1e-3, (res.error_max, res.notes)
    st2 = solve(res.mechanism, res.inputs)
    got = st2.point_positions[:, st2.point_index("P")]
    assert np.max(np.hypot(*(got - target).T)) / float(np.max(np.ptp(target, axis=0))) < 1e-3


@pytest.mark.parametrize("name,link", [("watt_1", "link_5"), ("stephenson_1", "link_4")])
def test_local_method_polishes_a_near_start_without_global_search(name, link):
    """``method="local"``: no population is drawn (the history stays empty), the start's
    own polish meets a target that the mechanism traces exactly (free timing)."""
    m, pt = _with_point(load_named(name), link)
    st = solve(m, np.radians(np.arange(7.0, 300.0, 29.0)))
    target = st.point_positions[:, st.point_index(pt)]
    res = synthesise(_perturbed(m, 0.01), path=target, point=pt, evaluations=12000, method="local", tol=1e-10)
    assert res.history == () or len(res.history) <= 1
    assert res.stopped == "tolerance"
    assert res.error_max < 1e-6, res.error_max


def test_the_evaluator_keeps_its_last_solve_only_for_the_same_call():
    """``Evaluator.poses`` returns its last poses for the same designs, inputs, outputs and
    kernel mode (the polish's Jacobian at the point of its last residual), and solves
    anew when any of them differs."""
    from multiloop.kin import kernel
    m = load_named("four_bar")
    ev = Evaluator(m, design_space(m, ["P"]))
    X = ev.space.x0[None, :]
    phi = np.linspace(0.0, 1.0, 5)
    a = ev.poses(X, phi)
    assert ev.poses(X.copy(), phi.copy()) is a
    moved = X.copy()
    moved[0, 2] += 1e-9
    for other in (ev.poses(moved, phi), ev.poses(X, phi + 1e-9), ev.poses(X, phi, outputs=["P"])):
        assert other is not a
    with kernel.using("off"):
        assert ev.poses(X, phi) is not ev.poses(moved, phi)
        b = ev.poses(X, phi)
    assert ev.poses(X, phi) is not b
    np.testing.assert_allclose(ev.poses(X, phi).point("P"), a.point("P"), atol=1e-15)
