"""The linear actuator as a closed-form group kind (``RRR (actuated: …)``).

Oracles: the law of cosines for a single-cylinder boom (a triangle of sides |AC|, the
boom and the cylinder ``L₀ + s``), generic Newton with continuation (``method="newton"``,
the group's full constraint Jacobian) for every catalogue machine with cylinders, and
central finite differences for the velocities.
"""
from __future__ import annotations

import numpy as np
import pytest

from multiloop.catalogue.named import load_named
from multiloop.kin.groups.actuator import ActuatorStep
from multiloop.kin.solve import plan_of, solve
from multiloop.topo.assur import GroupKind, decompose
from multiloop.topo.model import MechanismBuilder

C0, A0, B0 = np.array([0.0, 0.0]), np.array([1.5, -0.5]), np.array([2.0, 1.0])   # foot, base, end


def boom(flip_axis: bool = False, rod_on_base: bool = False):
    """A boom pinned to the frame at C0, lifted by one cylinder from A0 to B0 on it."""
    b = MechanismBuilder()
    b.add_link("frame", frame=True)
    for x in ("boom", "barrel", "rod"):
        b.add_link(x)
    near, far = ("rod", "barrel") if rod_on_base else ("barrel", "rod")
    u = (B0 - A0) / np.hypot(*(B0 - A0))
    b.add_joint("foot", "R", ("frame", "boom"), at=C0)
    b.add_joint("base", "R", ("frame", near), at=A0)
    b.add_joint("slide", "P", ("barrel", "rod"), at=(A0 + B0) / 2, axis=-u if flip_axis else u)
    b.add_joint("end", "R", (far, "boom"), at=B0)
    b.add_driver("slide")
    b.add_point("tip", "boom", (4.0, 2.5))
    return b.build()


def _stroke(n=401):
    """The whole stroke: from |boom − |AC|| to boom + |AC| (minus 1e-6 of the length)."""
    a, lb, L0 = np.hypot(*(A0 - C0)), np.hypot(*(B0 - C0)), np.hypot(*(B0 - A0))
    lo, hi = abs(lb - a) + 1e-6, lb + a - 1e-6
    return np.linspace(lo - L0, hi - L0, n), a, lb, L0


def _cross(p, q):
    return p[..., 0] * q[..., 1] - p[..., 1] * q[..., 0]


def _area(a, b, c):
    """Triangle area by Kahan's stable Heron formula (sides sorted x ≥ y ≥ z)."""
    x, y, z = np.sort(np.broadcast_arrays(a, b, c), axis=0)[::-1]
    return 0.25 * np.sqrt(np.maximum((x + (y + z)) * (z - (x - y)) * (z + (x - y)) * (x + (y - z)), 0.0))


@pytest.mark.parametrize("flip_axis, rod_on_base", [(False, False), (True, False), (False, True)])
def test_single_cylinder_boom_law_of_cosines(flip_axis, rod_on_base):
    m = boom(flip_axis, rod_on_base)
    ext, a, lb, L0 = _stroke()
    # the input slides the rod along the axis: it extends the cylinder unless the axis
    # points from the rod's pin to the barrel's
    sign = (-1.0 if flip_axis else 1.0) * (-1.0 if rod_on_base else 1.0)
    L, s = L0 + ext, sign * ext
    st = solve(m, s, assemble=True)
    assert st.ok.all()
    # angle γ at the foot between C→A and C→B: cos γ by the law of cosines, sin γ from the
    # area by Kahan's (1986) stable Heron formula (arccos loses digits near the stroke ends);
    # B is on the reference's side of C→A
    cos_g = (a * a + lb * lb - L * L) / (2 * a * lb)
    sin_g = 2 * _area(a, lb, L) / (a * lb)
    e = (A0 - C0) / a
    side = np.sign(_cross(A0 - C0, B0 - C0))
    expect = C0 + lb * (cos_g[:, None] * e + side * sin_g[:, None] * np.array([-e[1], e[0]]))
    B = st.positions[:, st.joint_index("end")]
    # 1e-12, except within ~1e-4 of the stroke ends where the triangle itself is
    # ill-conditioned: the rounding of L (eps·L) moves B by |dB/dL| = L / (a sin γ) times it
    cond = L / (a * sin_g)
    tol = np.maximum(1e-12, 4 * np.finfo(float).eps * L * cond)
    assert np.all(np.abs(B - expect).max(axis=1) < tol)
    assert np.mean(tol == 1e-12) > 0.95
    A = st.positions[:, st.joint_index("base")]
    assert np.max(np.abs(np.hypot(*(B - A).T) - L)) < 1e-12
    # barrel and rod lie along the actuator line A–B, the slide point on it
    P = st.positions[:, st.joint_index("slide")]
    assert np.max(np.abs(_cross(B - A, P - A))) / L.max() < 1e-12
    phi = np.arctan2((B - A)[:, 1], (B - A)[:, 0]) - np.arctan2(*(B0 - A0)[::-1])
    for link in ("barrel", "rod"):
        d = st.angles[:, st.link_index(link)] - phi
        assert np.max(np.abs(np.angle(np.exp(1j * d)))) < 1e-12


def test_single_cylinder_rates_against_differentiated_cosine_law():
    m = boom()
    s, a, lb, L0 = _stroke(41)
    s = s[1:-1]
    st = solve(m, s, derivatives=True, assemble=True)
    L = L0 + s
    gamma = np.arccos((a * a + lb * lb - L * L) / (2 * a * lb))
    side = np.sign(_cross(A0 - C0, B0 - C0))
    w = side * L / (a * lb * np.sin(gamma))           # dθ/ds = dγ/dL · dL/ds
    k = st.link_index("boom")
    assert np.max(np.abs(st.omegas[:, k] - w)) < 1e-9 * np.max(np.abs(w))


def test_single_cylinder_out_of_stroke_reach_is_reported():
    m = boom()
    s, *_ = _stroke(3)
    st = solve(m, [s[0] - 0.05, 0.0, s[-1] + 0.05], assemble=True)
    assert st.ok.tolist() == [False, True, False]
    assert "actuated: slide" in st.message and "out of reach" in st.message


def test_decompose_names_the_actuated_groups():
    text = decompose(load_named("excavator")).to_text()
    for slide in ("boom_cyl_slide", "stick_cyl_slide", "bucket_cyl_slide"):
        assert f"kind RRR (actuated: {slide})" in text
    g = decompose(boom()).groups[0]
    assert g.kind is GroupKind.ACTUATED and g.kind_name == "RRR (actuated: slide)"
    assert (g.layout.near, g.layout.far, g.layout.link2) == ("barrel", "rod", "boom")


def test_a_rocker_turned_by_a_cylinder_is_a_triangle_too():
    """A cylinder from the frame to a rocker is recognised whichever half is pinned where,
    and agrees with Newton."""
    b = MechanismBuilder()
    b.add_link("frame", frame=True)
    for x in ("rocker", "barrel", "rod"):
        b.add_link(x)
    b.add_joint("O", "R", ("frame", "rocker"), at=(0, 0))
    b.add_joint("A", "R", ("rocker", "rod"), at=(1, 0))
    b.add_joint("S", "P", ("barrel", "rod"), at=(1.5, 0.5), axis=(1, 1))
    b.add_joint("B", "R", ("barrel", "frame"), at=(2, 1))
    b.add_driver("S")
    m = b.build()
    g = decompose(m).groups[0]
    assert g.kind is GroupKind.ACTUATED and (g.layout.near, g.layout.far) == ("barrel", "rod")
    x = np.linspace(-0.4, 0.17, 9)          # |OB| − 1 = L₀ − s reached at s = 0.1781
    a, n = solve(m, x, derivatives=True), solve(m, x, derivatives=True, method="newton")
    assert a.ok.all() and n.ok.all() and not solve(m, [0.18], assemble=True).ok.any()
    assert np.max(np.abs(a.positions - n.positions)) < 1e-12
    assert np.max(np.abs(a.velocities - n.velocities)) < 1e-10


CYLINDER_MACHINES = ["excavator", "excavator_bucket", "wheel_loader_zbar", "knuckle_boom_crane"]


def _strokes(m, n=25):
    """All cylinders moving at once, out of phase, inside the machine's working range."""
    t = np.linspace(0.0, 1.0, n)[:, None]
    pattern = np.array([0.5, -0.35, 0.25, -0.2][:len(m.drivers)])
    X = t * pattern[None, :] + 0.05 * np.sin(7 * t) * np.ones(len(m.drivers))
    for k, d in enumerate(m.drivers):        # inside a cylinder's stated range (95 % of it)
        if d.range is not None:
            X[:, k] = np.clip(X[:, k], 0.95 * d.range[0], 0.95 * d.range[1])
    return X


@pytest.mark.parametrize("name", CYLINDER_MACHINES)
def test_plan_uses_the_actuator_step(name):
    m = load_named(name)
    sp = plan_of(m)
    cyl = [st for st in sp.steps if getattr(st.step, "kind", None) is GroupKind.ACTUATED]
    assert len(cyl) == sum(1 for j in m.joints if j.kind.value == "P")
    assert all(isinstance(st.closed, ActuatorStep) for st in cyl)


@pytest.mark.parametrize("name", CYLINDER_MACHINES)
def test_closed_form_against_newton(name):
    m = load_named(name)
    X = _strokes(m)
    a = solve(m, X, derivatives=True)
    b = solve(m, X, derivatives=True, method="newton")
    assert a.ok.all() and b.ok.all()
    for f in ("positions", "angles", "point_positions", "velocities", "omegas", "point_velocities",
              "accelerations", "epsilons"):
        scale = max(1.0, float(np.max(np.abs(getattr(b, f)))))
        assert np.max(np.abs(getattr(a, f) - getattr(b, f))) < 1e-10 * scale, f


@pytest.mark.parametrize("name", CYLINDER_MACHINES)
def test_velocities_against_finite_differences(name):
    m = load_named(name)
    nd = len(m.drivers)
    x0 = _strokes(m, 9)[4]
    rates = np.array([1.0, -0.6, 0.4, 0.3][:nd])
    h = 1e-6
    st = solve(m, x0[None, :], derivatives=True, input_rates=rates)
    pm = solve(m, np.stack([x0 - h * rates, x0 + h * rates]))
    fd = (pm.positions[1] - pm.positions[0]) / (2 * h)
    assert np.max(np.abs(st.velocities[0] - fd)) < 1e-6
    fd_w = np.angle(np.exp(1j * (pm.angles[1] - pm.angles[0]))) / (2 * h)
    assert np.max(np.abs(st.omegas[0] - fd_w)) < 1e-6


def test_oblique_guide_against_newton():
    """A guide not along the pins (a jack with an offset rod eye): the side is
    |d₀ + s u₀|, exact; positions and rates agree with Newton."""
    b = MechanismBuilder()
    b.add_link("frame", frame=True)
    for x in ("boom", "barrel", "rod"):
        b.add_link(x)
    b.add_joint("foot", "R", ("frame", "boom"), at=C0)
    b.add_joint("base", "R", ("frame", "rod"), at=A0)
    b.add_joint("slide", "P", ("barrel", "rod"), at=(1.9, 0.3), axis=(0.2, 1.0))
    b.add_joint("end", "R", ("barrel", "boom"), at=B0)
    b.add_driver("slide")
    m = b.build()
    x = np.linspace(-0.3, 0.3, 13)
    a, n = solve(m, x, derivatives=True), solve(m, x, derivatives=True, method="newton")
    assert a.ok.all() and n.ok.all()
    for f in ("positions", "angles", "velocities", "omegas", "accelerations", "epsilons"):
        assert np.max(np.abs(getattr(a, f) - getattr(n, f))) < 1e-10, f
    d = B0 - A0 - x[:, None] * np.array([0.2, 1.0]) / np.hypot(0.2, 1.0)    # rod on the base: σ = −1
    Aj, Bj = a.positions[:, a.joint_index("base")], a.positions[:, a.joint_index("end")]
    assert np.max(np.abs(np.hypot(*(Bj - Aj).T) - np.hypot(*d.T))) < 1e-12
