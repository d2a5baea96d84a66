"""Class III triad and class IV group: all modes by the degree-6 polynomial,
an independent Newton search, rates vs central differences, mode tracking."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.optimize import root

from multiloop.kin.groups import (class4_modes, class4_rates, class4_track, triad_modes,
                        triad_rates, triad_track)
from multiloop.kin.groups.class4 import class4_points

# docs/groups.md
A63 = np.array([[0.250191, 0.794428], [0.551371, -0.549586], [-0.399667, 0.747107]])
B63 = np.array([[0.0, 0.0], [-0.989469, 0.642457], [0.594139, -0.06413]])
L63 = np.array([0.593942, 0.561953, 0.53133])
MODES63 = np.array([(0.327896, 0.205590, 115.3802), (-0.338230, 0.713630, 139.9507),
                    (0.590567, 0.307692, 146.8548), (-0.337942, 0.711559, 176.4640),
                    (-0.231143, 0.446455, -172.5995), (-0.022263, 0.266662, -173.5404)])


def rot(th):
    c, s = np.cos(th), np.sin(th)
    return np.array([[c, -s], [s, c]])


def triad_residual(A, b, l, x):
    """Closure equations in pose coordinates (x, y, θ) — written independently."""
    P = x[:2] + (b - b[0]) @ rot(x[2]).T
    return np.linalg.norm(P - A, axis=1) - l


def newton_modes(A, b, l, rng, n_starts):
    """An independent route: scipy `root` (hybr) from random starts."""
    found = []
    span = np.max(np.abs(A)) + np.max(l) + np.max(np.abs(b))
    for _ in range(n_starts):
        x0 = np.r_[rng.uniform(-span, span, 2), rng.uniform(-np.pi, np.pi)]
        sol = root(lambda x: triad_residual(A, b, l, x), x0, tol=1e-14)
        if np.max(np.abs(triad_residual(A, b, l, sol.x))) < 1e-10 * np.max(l):
            found.append(sol.x)
    return found


def test_six_mode_instance():
    m = triad_modes(A63, B63, L63)
    assert m.n_modes == 6
    assert np.all(m.residual <= 1e-10)
    for x, y, th in MODES63:
        d = np.hypot(m.P[:, 0, 0] - x, m.P[:, 0, 1] - y) + np.abs(np.degrees(m.theta) - th) * 1e-3
        assert d.min() < 1e-5
    for k in range(6):       # independent residual
        x = np.r_[m.P[k, 0], m.theta[k]]
        assert np.max(np.abs(triad_residual(A63, B63, L63, x))) <= 1e-10
    # det signs of §2.3 (+,-,-,+,-,+) in the order listed there
    order = [np.argmin(np.abs(np.degrees(m.theta) - th)) for th in MODES63[:, 2]]
    assert np.sign(m.det[order]).tolist() == [1, -1, -1, 1, -1, 1]


def random_triad(rng):
    A = rng.uniform(-1, 1, (3, 2))
    b = rng.uniform(-1, 1, (3, 2))
    th = rng.uniform(-np.pi, np.pi)
    p = rng.uniform(-0.5, 0.5, 2)
    P = p + (b - b[0]) @ rot(th).T
    return A, b, np.linalg.norm(P - A, axis=1), (p, th)


def test_random_triads_roots_are_assemblies_and_newton_finds_nothing_else():
    rng = np.random.default_rng(7)
    tri = [random_triad(rng) for _ in range(12)]
    m = triad_modes(np.stack([t[0] for t in tri]), tri[0][1], tri[0][2])  # batch shape
    assert m.P.shape == (12, 6, 3, 2)
    for A, b, l, (p, th) in tri:
        m = triad_modes(A, b, l)
        n = int(m.n_modes)
        assert n >= 1 and n % 2 == 0 or n >= 1   # at least the constructed one
        for k in range(n):
            x = np.r_[m.P[k, 0], m.theta[k]]
            assert np.max(np.abs(triad_residual(A, b, l, x))) <= 1e-10 * np.max(l)
            assert np.allclose(np.linalg.norm(m.P[k] - A, axis=1), l, rtol=0, atol=1e-10)
        # the constructed pose is one of the modes
        d = np.hypot(*(m.P[:n, 0] - p).T) + np.abs(np.angle(np.exp(1j * (m.theta[:n] - th))))
        assert d.min() < 1e-8
        # no Newton solution outside the set
        for x in newton_modes(A, b, l, rng, 25):
            d = np.hypot(*(m.P[:n, 0] - x[:2]).T) + np.abs(np.angle(np.exp(1j * (m.theta[:n] - x[2]))))
            assert d.min() < 1e-7, (x, m.theta[:n])


def path(t):
    """Anchors of the §2.3 triad moving on small circles (pos, vel, acc)."""
    t = np.asarray(t, dtype=float)[..., None, None]
    w = np.array([1.0, -0.7, 1.3])[:, None]
    ph = np.array([0.0, 1.0, 2.0])[:, None]
    r = 0.02
    e = np.concatenate([np.cos(w * t + ph), np.sin(w * t + ph)], -1)
    n = np.concatenate([-np.sin(w * t + ph), np.cos(w * t + ph)], -1)
    return A63 + r * e, r * w * n, -r * w * w * e


def test_triad_rates_vs_central_differences():
    T = np.linspace(0, 0.5, 6)
    A, vA, aA = path(T)
    tr = triad_track(A, B63, L63, MODES63_points(0))
    assert tr.ok.all()
    r = triad_rates(A, tr.P, vA, aA)
    h = 1e-4
    Pp = triad_track(path(T + h)[0], B63, L63, MODES63_points(0)).P
    Pm = triad_track(path(T - h)[0], B63, L63, MODES63_points(0)).P
    # positions at t±h of the same mode: nearest mode to tr.P
    close_p = lambda Q: Q  # noqa: E731
    vfd = (close_p(Pp) - close_p(Pm)) / (2 * h)
    afd = (Pp - 2 * tr.P + Pm) / h ** 2
    assert np.allclose(r.vP, vfd, atol=1e-7)
    assert np.allclose(r.aP, afd, atol=1e-5)
    th = lambda Q: np.arctan2(*(Q[:, 1] - Q[:, 0]).T[::-1])  # noqa: E731
    assert np.allclose(r.omega, np.angle(np.exp(1j * (th(Pp) - th(Pm)))) / (2 * h), atol=1e-7)
    assert not r.singular.any()


def MODES63_points(k):
    x, y, th = MODES63[k]
    return np.array([x, y]) + (B63 - B63[0]) @ rot(np.radians(th)).T


def test_tracker_matches_all_modes_and_newton_continuation():
    T = np.linspace(0, 2.0, 400)
    A = path(T)[0]
    m = triad_modes(A, B63, L63)
    for k in range(6):
        tr = triad_track(A, B63, L63, MODES63_points(k))
        good = tr.ok
        assert good[0]
        # every tracked pose is one of the all-modes results
        d = np.max(np.linalg.norm(m.P[good] - tr.P[good][:, None], axis=-1), axis=-1)
        assert np.all(np.nanmin(d, axis=1) < 1e-12)
        # independent route: Newton continuation with small steps agrees
        x = np.r_[tr.P[0, 0], tr.theta[0]]
        for i in np.flatnonzero(good)[1:]:
            x = root(lambda z: triad_residual(A[i], B63, L63, z), x, tol=1e-14).x
            assert np.allclose(x[:2], tr.P[i, 0], atol=1e-9)
        if not good.all():     # a loss is final and marked
            i = np.argmin(good)
            assert tr.status[i] == 2 and not good[i:].any()
            assert np.all(tr.status[i + 1:] == 3) and np.isnan(tr.P[~good]).all()


def test_tracker_marks_mode_loss():
    """Moving A3 away: modes collide and vanish; the tracker stops, never jumps."""
    s = np.linspace(0, 3.0, 1500)
    A = np.repeat(A63[None], len(s), 0)
    A[:, 2] += s[:, None] * np.array([-1.0, 0.5])
    m = triad_modes(A, B63, L63)
    assert m.n_modes[0] == 6 and m.n_modes[-1] == 0
    for k in range(6):
        tr = triad_track(A, B63, L63, MODES63_points(k))
        assert not tr.ok[-1]
        i = np.argmin(tr.ok)
        assert tr.status[i] == 2
        steps = np.max(np.linalg.norm(np.diff(tr.P[:i], axis=0), axis=-1), axis=-1)
        assert steps.max() < 0.05      # continuous up to the loss


def test_triad_singular_concurrent_lines():
    P = MODES63_points(0)
    O = np.array([0.1, -0.2])
    A = P + np.array([0.5, 0.7, 0.9])[:, None] * (P - O)
    l = np.linalg.norm(P - A, axis=1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = triad_rates(A, P, np.ones((3, 2)))
        assert r.singular and abs(r.det) < 1e-12
    m = triad_modes(A, B63, l)
    assert m.n_modes >= 1


def test_no_assembly():
    A = A63 * 10.0
    m = triad_modes(A, B63, L63)
    assert m.n_modes == 0 and np.isnan(m.P).all()
    tr = triad_track(A[None].repeat(3, 0), B63, L63, MODES63_points(0))
    assert not tr.ok.any() and np.all(tr.status == 1)


# ----------------------------------------------------------------- class IV
O4 = np.array([[0.0, 0.0], [2.0, 0.1]])
R4 = np.array([[0.6, 0.5], [0.7, -0.4], [-0.5, 0.6], [-0.6, -0.3]])
J4ref = class4_points(O4, R4, np.zeros(2))
M4 = np.array([np.linalg.norm(J4ref[2] - J4ref[0]), np.linalg.norm(J4ref[3] - J4ref[1])])


def class4_res(O, th):
    J = class4_points(O, R4, th)
    return np.linalg.norm(J[2:] - J[:2], axis=1) - M4


def test_class4_modes_and_newton():
    m = class4_modes(O4, R4, M4)
    n = int(m.n_modes)
    assert n >= 2 and np.all(m.residual[:n] <= 1e-10)
    assert np.min(np.max(np.abs(np.angle(np.exp(1j * m.theta[:n]))), axis=1)) < 1e-9  # reference
    rng = np.random.default_rng(3)
    for _ in range(30):
        sol = root(lambda z: class4_res(O4, z), rng.uniform(-np.pi, np.pi, 2), tol=1e-14)
        if np.max(np.abs(class4_res(O4, sol.x))) < 1e-10:
            d = np.max(np.abs(np.angle(np.exp(1j * (m.theta[:n] - sol.x)))), axis=1)
            assert d.min() < 1e-7


def test_class4_rates_and_track():
    T = np.linspace(0, 1.0, 200)
    w = 0.8

    def O(t):
        t = np.asarray(t)[..., None]
        o2 = O4[1] + 0.05 * np.concatenate([np.cos(w * t) - 1, np.sin(w * t)], -1)
        return np.stack([np.broadcast_to(O4[0], o2.shape), o2], -2)

    def dO(t):
        t = np.asarray(t)[..., None]
        v = 0.05 * w * np.concatenate([-np.sin(w * t), np.cos(w * t)], -1)
        a = -0.05 * w * w * np.concatenate([np.cos(w * t), np.sin(w * t)], -1)
        z = np.zeros_like(v)
        return np.stack([z, v], -2), np.stack([z, a], -2)
    tr = class4_track(O(T), R4, M4, np.zeros(2))
    assert tr.ok.all()
    for i in range(0, len(T), 20):
        assert np.max(np.abs(class4_res(O(T[i]), tr.theta[i]))) < 1e-10
    vO, aO = dO(T)
    r = class4_rates(O(T), tr.J, vO, aO)
    h = 1e-4
    tp = class4_track(O(T + h), R4, M4, np.zeros(2)).theta
    tm = class4_track(O(T - h), R4, M4, np.zeros(2)).theta
    dth = np.angle(np.exp(1j * (tp - tm))) / (2 * h)
    ddth = np.angle(np.exp(1j * (tp - tr.theta))) + np.angle(np.exp(1j * (tm - tr.theta)))
    assert np.allclose(r.omega, dth, atol=1e-7)
    assert np.allclose(r.eps, ddth / h ** 2, atol=1e-4)
    Jp = class4_track(O(T + h), R4, M4, np.zeros(2)).J
    Jm = class4_track(O(T - h), R4, M4, np.zeros(2)).J
    assert np.allclose(r.vJ, (Jp - Jm) / (2 * h), atol=1e-7)
    assert np.allclose(r.aJ, (Jp - 2 * tr.J + Jm) / h ** 2, atol=1e-4)


@pytest.mark.parametrize("k", [0, 1])
def test_class4_track_other_mode(k):
    m = class4_modes(O4, R4, M4)
    O = np.repeat(O4[None], 50, 0)
    O[:, 1, 0] += np.linspace(0, 0.2, 50)
    tr = class4_track(O, R4, M4, m.theta[k])
    assert tr.ok[0]
    assert np.allclose(tr.theta[0], m.theta[k])


@pytest.mark.parametrize("stride", [8, 32])
def test_strided_tracker_equals_full_resolution(stride):
    """Coarse all-modes + Newton fill-in gives the same track and the same loss
    position as all modes at every position."""
    s = np.linspace(0, 3.0, 1500)
    A = np.repeat(A63[None], len(s), 0)
    A[:, 2] += s[:, None] * np.array([-1.0, 0.5])
    A[:, 0] += 0.02 * np.stack([np.cos(7 * s), np.sin(5 * s)], -1)
    for k in range(6):
        t1 = triad_track(A, B63, L63, MODES63_points(k), stride=stride)
        t2 = triad_track(A, B63, L63, MODES63_points(k), stride=1)
        assert np.array_equal(t1.status, t2.status)
        assert np.nanmax(np.abs(t1.P - t2.P)) < 1e-12


def test_class4_mode_loss_marked_and_strided_equals_full():
    O = np.repeat(O4[None], 400, 0)
    O[:, 1, 0] += np.linspace(0, 0.1, 400)          # beyond ~0.03 the group cannot assemble
    t1 = class4_track(O, R4, M4, np.zeros(2))
    t2 = class4_track(O, R4, M4, np.zeros(2), stride=1)
    assert np.array_equal(t1.status, t2.status)
    assert np.nanmax(np.abs(t1.J - t2.J)) < 1e-12
    i = np.argmin(t1.ok)
    assert 0 < i < 400 and t1.status[i] == 2 and not t1.ok[i:].any()
    steps = np.max(np.linalg.norm(np.diff(t1.J[:i], axis=0), axis=-1), axis=-1)
    assert steps.max() < 0.05
    for k in range(0, i, 37):
        assert np.max(np.abs(class4_res(O[k], t1.theta[k]))) < 1e-10


def test_every_unit_circle_root_of_the_polynomial_is_an_assembly():
    """Second root finder (numpy.roots on the degree-6 coefficients): each root on
    the unit circle, before any polish, gives a pose with a small residual, and
    their number equals the number of modes returned."""
    from multiloop.kin.groups.triad import _poly_coefficients, _position_from_angle
    rng = np.random.default_rng(11)
    cases = [(A63, B63, L63)] + [random_triad(rng)[:3] for _ in range(15)]
    for A, b, l in cases:
        bb = b - b[0]
        coef, bc, a = _poly_coefficients(A[None], bb, l[None])
        roots = np.roots(coef[0])
        on = roots[np.abs(np.abs(roots) - 1) < 1e-6]
        th = np.angle(on)
        for t in th:
            p = _position_from_angle(A, bc, a[0], l, np.array(t))
            assert np.max(np.abs(triad_residual(A, b, l, np.r_[p, t]))) < 1e-8 * np.max(l)
        m = triad_modes(A, b, l)
        assert len(np.unique(np.round(th, 8))) == m.n_modes
