"""Closed-form dyad kernels (kinds 1-5 of Vasechkin et al. 2017): closure, branches, rates vs
central differences, a second route (Newton) for positions, failures, and the
seed's kind-1 acceleration misprint."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, strategies as st

from multiloop.kin.groups import (prp_position, prp_rates, rpp_position, rpp_rates, rpr_branch,
                        rpr_position, rpr_rates, rrp_branch, rrp_position, rrp_rates,
                        rrr_branch, rrr_position, rrr_rates)
from multiloop.topo.errors import SingularityError
from multiloop.kin.groups.rrr import rrr_xy

H = 1e-4


# ----------------------------------------------------------------- smooth knowns
def circ(t, c, r, w, p0, drift=(0.0, 0.0)):
    """Point on a circle plus a drift: position, velocity, acceleration at t."""
    t = np.asarray(t, dtype=float)[..., None]
    ang = w * t + p0
    e = np.concatenate([np.cos(ang), np.sin(ang)], axis=-1)
    n = np.concatenate([-np.sin(ang), np.cos(ang)], axis=-1)
    d = np.asarray(drift)
    return np.asarray(c) + r * e + d * t, r * w * n + d, -r * w * w * e + 0 * d


def guide(t, phi0, k, j):
    """Guide angle φ = φ0 + k t + j t²: direction u, ω, ε."""
    t = np.asarray(t, dtype=float)
    phi = phi0 + k * t + j * t * t
    return np.stack([np.cos(phi), np.sin(phi)], axis=-1), k + 2 * j * t, 2 * j + 0 * t


def perp(v):
    return np.stack([-v[..., 1], v[..., 0]], axis=-1)


def cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def fd(f, t):
    """Central first and second differences of f at t."""
    fp, f0, fm = f(t + H), f(t), f(t - H)
    return (fp - fm) / (2 * H), (fp - 2 * f0 + fm) / H ** 2


def close(a, b, rtol, scale=1.0):
    a, b = np.asarray(a), np.asarray(b)
    err = np.max(np.abs(a - b))
    assert err <= rtol * max(scale, np.max(np.abs(b))), (err, rtol)


T = np.linspace(0.0, 1.0, 7)


# ----------------------------------------------------------------- RRR (kind 1)
def rrr_knowns(t):
    A = circ(t, (0.0, 0.0), 0.3, 1.3, 0.2)
    C = circ(t, (1.5, 0.4), 0.2, -0.7, 1.0, drift=(0.1, -0.05))
    return A, C


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_rrr_closure_and_branch(sign):
    (A, _, _), (C, _, _) = rrr_knowns(T)
    l2, l3 = 1.1, 0.9
    B, ok, det = rrr_position(A, C, l2, l3, sign)
    assert ok.all()
    close(np.linalg.norm(B - A, axis=-1), l2, 1e-12)
    close(np.linalg.norm(B - C, axis=-1), l3, 1e-12)
    assert np.all(rrr_branch(A, C, B) == sign)
    assert np.all(np.sign(det) == -sign)          # assembly No. 1 <=> det < 0
    close(det, cross(B - C, B - A), 1e-13)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_rrr_rates_vs_central_differences(sign):
    l2, l3 = 1.1, 0.9
    (A, vA, aA), (C, vC, aC) = rrr_knowns(T)
    B = rrr_position(A, C, l2, l3, sign).B
    r = rrr_rates(A, C, B, vA, vC, aA, aC)
    posB = lambda t: rrr_position(*(k[0] for k in rrr_knowns(t)), l2, l3, sign).B  # noqa: E731
    ang2 = lambda t: np.unwrap(np.arctan2(*(posB(t) - rrr_knowns(t)[0][0]).T[::-1]))  # noqa: E731
    vB, aB = fd(posB, T)
    close(r.vB, vB, 1e-7)
    close(r.aB, aB, 1e-5)
    w2, e2 = fd(ang2, T)
    close(r.w2, w2, 1e-7)
    close(r.e2, e2, 1e-5)
    assert not r.singular.any()


def test_rrr_seed_acceleration_misprint():
    """Vasechkin et al. 2017 prints b2 = a_Cy - a_Ay + a11 ω2² + a12 ω3²: finite differences
    reject it, our  - a11 ω2² - a12 ω3²  agrees."""
    l2, l3 = 1.1, 0.9
    (A, vA, aA), (C, vC, aC) = rrr_knowns(T)
    B = rrr_position(A, C, l2, l3, 1.0).B
    r = rrr_rates(A, C, B, vA, vC, aA, aC)
    phi2 = np.arctan2(*(B - A).T[::-1])
    phi3 = np.arctan2(*(B - C).T[::-1])
    a11, a12 = -l2 * np.sin(phi2), l3 * np.sin(phi3)
    a21, a22 = l2 * np.cos(phi2), -l3 * np.cos(phi3)
    b1 = aC[:, 0] - aA[:, 0] + a21 * r.w2 ** 2 + a22 * r.w3 ** 2
    det = a11 * a22 - a12 * a21
    e2 = {}
    for name, s in (("printed", +1.0), ("correct", -1.0)):
        b2 = aC[:, 1] - aA[:, 1] + s * (a11 * r.w2 ** 2 + a12 * r.w3 ** 2)
        e2[name] = (b1 * a22 - a12 * b2) / det
    posB = lambda t: rrr_position(*(k[0] for k in rrr_knowns(t)), l2, l3, 1.0).B  # noqa: E731
    ang2 = lambda t: np.unwrap(np.arctan2(*(posB(t) - rrr_knowns(t)[0][0]).T[::-1]))  # noqa: E731
    _, e2_fd = fd(ang2, T)
    close(e2["correct"], e2_fd, 1e-5)
    close(r.e2, e2_fd, 1e-5)
    assert np.max(np.abs(e2["printed"] - e2_fd)) > 1e-2 * np.max(np.abs(e2_fd))
    close(r.det, det, 1e-13)          # our det is the paper's det


def test_rrr_second_route_newton():
    """Closed form = Newton on |B-A|² = l2², |B-C|² = l3² from a nearby guess."""
    rng = np.random.default_rng(1)
    (A, _, _), (C, _, _) = rrr_knowns(T)
    B = rrr_position(A, C, 1.1, 0.9, -1.0).B
    X = B + 0.05 * rng.standard_normal(B.shape)
    for _ in range(30):
        f = np.stack([0.5 * (np.sum((X - A) ** 2, -1) - 1.1 ** 2),
                      0.5 * (np.sum((X - C) ** 2, -1) - 0.9 ** 2)], -1)
        J = np.stack([X - A, X - C], axis=-2)
        X = X - np.linalg.solve(J, f[..., None])[..., 0]
    close(X, B, 1e-12)


def test_rrr_out_of_reach_and_singular():
    A = np.zeros((4, 2))
    C = np.array([[3.0, 0.0], [2.0, 0.0], [0.05, 0.0], [1.0, 1.0]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        B, ok, det = rrr_position(A, C, 1.0, 1.0, 1.0)
        assert ok.tolist() == [False, True, True, True]
        assert np.isnan(B[0]).all() and np.isfinite(B[1:]).all()
        # full extension (d = l2 + l3): det = 0, flagged singular, no crash
        r = rrr_rates(A[1:2], C[1:2], B[1:2], np.zeros((1, 2)), np.array([[0.0, 1.0]]),
                      np.zeros((1, 2)), np.zeros((1, 2)))
        assert r.singular.all() and abs(r.det[0]) < 1e-12
        assert not np.isfinite(r.w2).all()
        # d = 0 (coincident pins) and d < |l2 - l3|
        B0, ok0, _ = rrr_position([0.0, 0.0], [0.0, 0.0], 1.0, 1.0)
        assert not ok0 and np.isnan(B0).all()
        assert not rrr_position([0.0, 0.0], [0.1, 0.0], 1.0, 0.5).ok
    with pytest.raises(SingularityError):
        rrr_branch([0.0, 0.0], [2.0, 0.0], [1.0, 0.0])


def test_rrr_components_flags():
    """rrr_xy: a NaN pin or coincident pins fail; ``exact`` is False only where a
    position was clamped to the tangent, and True means |B-A| = l2, |B-C| = l3."""
    bx, by, ok, det, exact = rrr_xy(np.array([0.0, np.nan, 0.0]), 0.0, np.array([1.5, 1.5, 0.0]), 0.0, 1.0, 1.0)
    assert ok.tolist() == [True, False, False] and exact
    close(np.hypot(bx[0], by[0]), 1.0, 1e-15)
    assert np.isnan(bx[1:]).all() and np.isnan(det[1:]).all()
    *_, ok_t, _, exact_t = rrr_xy(0.0, 0.0, 2.0 * (1 + 2e-15), 0.0, 1.0, 1.0)
    assert ok_t and not exact_t                    # beyond reach by 2e-15 (rounding): clamped


def test_rrr_scalar_and_array_sign():
    (A, _, _), (C, _, _) = rrr_knowns(T)
    sign = np.where(np.arange(len(T)) % 2, 1.0, -1.0)
    B = rrr_position(A, C, 1.1, 0.9, sign).B
    assert np.all(rrr_branch(A, C, B) == sign)
    b = rrr_position(A[0], C[0], 1.1, 0.9)
    assert b.B.shape == (2,) and b.ok.shape == ()


@given(st.lists(st.floats(-2, 2), min_size=4, max_size=4),
       st.floats(0.2, 2.0), st.floats(0.2, 2.0), st.sampled_from([1.0, -1.0]),
       st.floats(-3, 3), st.floats(-3, 3))
def test_rrr_random_geometry(pts, l2, l3, sign, vy, ay):
    A = np.array(pts[:2])
    C = np.array(pts[2:])
    d = np.linalg.norm(C - A)
    B, ok, det = rrr_position(A, C, l2, l3, sign)
    reach = abs(l2 - l3) < d < l2 + l3
    margin = min(l2 + l3 - d, d - abs(l2 - l3)) if d > 0 else -1
    if margin > 1e-6:
        assert ok
        s = max(l2, l3, 1.0)
        assert abs(np.linalg.norm(B - A) - l2) <= 1e-12 * s
        assert abs(np.linalg.norm(B - C) - l3) <= 1e-12 * s
        if margin > 1e-3:
            assert rrr_branch(A, C, B) == sign
            # velocity vs central difference along C(t) = C + t v, A fixed
            v = np.array([0.3, vy])
            r = rrr_rates(A, C, B, np.zeros(2), v, np.zeros(2), np.array([0.0, ay]))
            f = lambda t: rrr_position(A, C + t * v + 0.5 * t * t * np.array([0, ay]),  # noqa: E731
                                       l2, l3, sign).B
            h = 1e-6 * max(1.0, np.linalg.norm(v))
            vfd = (f(h) - f(-h)) / (2 * h)
            assert np.allclose(r.vB, vfd, rtol=1e-4, atol=1e-4 * (1 + np.abs(r.vB).max()))
    elif not reach and margin < -1e-9:
        assert not ok and np.isnan(B).all()


# ----------------------------------------------------------------- RRP (kind 2)
def rrp_knowns(t):
    A = circ(t, (0.0, 0.0), 0.4, 1.1, 0.3)
    P = circ(t, (1.2, -0.2), 0.1, 0.9, 0.0, drift=(0.05, 0.02))
    u, w, e = guide(t, 0.3, 0.4, -0.2)
    return A, P, (u, w, e)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_rrp_closure_rates(sign):
    l2, h = 1.3, 0.15
    (A, vA, aA), (P, vP, aP), (u, w, e) = rrp_knowns(T)
    B, s, ok, det = rrp_position(A, P, u, l2, h, sign)
    assert ok.all()
    close(np.linalg.norm(B - A, axis=-1), l2, 1e-12)
    close(np.sum((B - P) * perp(u), -1), h, 1e-12, scale=l2)
    close(np.sum((B - P) * u, -1), s, 1e-12, scale=l2)
    assert np.all(rrp_branch(A, B, u) == sign) and np.all(np.sign(det) == sign)
    r = rrp_rates(A, B, P, u, vA, vP, w, aA, aP, e)
    close(r.det, det, 1e-13)

    def pos(t):
        (A_, _, _), (P_, _, _), (u_, _, _) = rrp_knowns(t)
        return rrp_position(A_, P_, u_, l2, h, sign)
    vB, aB = fd(lambda t: pos(t).B, T)
    sd, sdd = fd(lambda t: pos(t).s, T)
    close(r.vB, vB, 1e-7)
    close(r.aB, aB, 1e-5)
    close(r.sd, sd, 1e-7)
    close(r.sdd, sdd, 1e-5)


def test_rrp_failures():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        A = np.zeros((2, 2))
        P = np.array([[0.0, 2.0], [0.0, 1.0]])
        u = np.array([[1.0, 0.0], [1.0, 0.0]])
        B, s, ok, det = rrp_position(A, P, u, 1.0, 0.0, 1.0)
        assert ok.tolist() == [False, True] and np.isnan(B[0]).all()
        # link perpendicular to the guide: det = 0, rates flagged singular
        r = rrp_rates(A[1], B[1], P[1], u[1], [0.0, 0.0], [1.0, 0.0], 0.0)
        assert r.singular and abs(det[1]) < 1e-12
    with pytest.raises(SingularityError):
        rrp_branch([0.0, 0.0], [0.0, 1.0], [1.0, 0.0])


# ----------------------------------------------------------------- RPR (kind 3)
def rpr_knowns(t):
    A = circ(t, (0.0, 0.0), 0.35, 1.7, 0.5)
    C = circ(t, (1.1, 0.3), 0.05, -0.6, 0.0, drift=(0.02, 0.03))
    return A, C


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_rpr_closure_rates(sign):
    h = 0.2
    (A, vA, aA), (C, vC, aC) = rpr_knowns(T)
    u, s, ok, det = rpr_position(A, C, h, sign)
    assert ok.all()
    close(np.linalg.norm(u, axis=-1), 1.0, 1e-14)
    close(C + s[:, None] * u + h * perp(u), A, 1e-12)
    assert np.all(rpr_branch(A, C, u) == sign)
    r = rpr_rates(A, C, u, vA, vC, aA, aC)
    close(r.det, s, 1e-13)

    def pos(t):
        (A_, _, _), (C_, _, _) = rpr_knowns(t)
        return rpr_position(A_, C_, h, sign)
    sd, sdd = fd(lambda t: pos(t).s, T)
    ang = lambda t: np.unwrap(np.arctan2(*pos(t).u.T[::-1]))  # noqa: E731
    w3, e3 = fd(ang, T)
    close(r.sd, sd, 1e-7)
    close(r.sdd, sdd, 1e-5)
    close(r.w3, w3, 1e-7)
    close(r.e3, e3, 1e-5)


def test_rpr_failures():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        u, s, ok, det = rpr_position([[0.1, 0.0], [0.0, 0.5]], [[0.0, 0.0], [0.0, 0.0]], 0.5)
        assert ok.tolist() == [False, True] and np.isnan(u[0]).all()
        # s = 0: A at the foot of the perpendicular, det = 0
        r = rpr_rates([0.0, 0.5], [0.0, 0.0], u[1], [1.0, 0.0], [0.0, 0.0])
        assert r.singular and abs(r.det) < 1e-12
    with pytest.raises(SingularityError):
        rpr_branch([0.0, 0.5], [0.0, 0.0], [1.0, 0.0])


# ----------------------------------------------------------------- PRP (kind 4)
def prp_knowns(t):
    P1 = circ(t, (0.0, 0.0), 0.3, 1.2, 0.0)
    P2 = circ(t, (1.0, 0.5), 0.2, -0.8, 0.4, drift=(0.03, 0.0))
    g1 = guide(t, 0.2, 0.5, 0.1)
    g2 = guide(t, 1.6, -0.3, 0.2)
    return P1, P2, g1, g2


def test_prp_closure_rates():
    h1, h2 = 0.1, -0.25
    (P1, v1, a1), (P2, v2, a2), (u1, w1, e1), (u2, w2, e2) = prp_knowns(T)
    B, s1, s2, ok, det = prp_position(P1, u1, h1, P2, u2, h2)
    assert ok.all()
    close(P1 + s1[:, None] * u1 + h1 * perp(u1), B, 1e-12)
    close(P2 + s2[:, None] * u2 + h2 * perp(u2), B, 1e-12)
    r = prp_rates(B, P1, u1, P2, u2, v1, w1, v2, w2, a1, e1, a2, e2)

    def pos(t):
        (P1_, _, _), (P2_, _, _), (u1_, _, _), (u2_, _, _) = prp_knowns(t)
        return prp_position(P1_, u1_, h1, P2_, u2_, h2)
    vB, aB = fd(lambda t: pos(t).B, T)
    s1d, s1dd = fd(lambda t: pos(t).s1, T)
    s2d, s2dd = fd(lambda t: pos(t).s2, T)
    close(r.vB, vB, 1e-7)
    close(r.aB, aB, 1e-5)
    close(r.s1d, s1d, 1e-7)
    close(r.s2dd, s2dd, 1e-5)
    close(r.s1dd, s1dd, 1e-5)
    close(r.s2d, s2d, 1e-7)
    close(det, cross(u2, u1), 1e-14)


def test_prp_parallel_guides():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        B, s1, s2, ok, det = prp_position([0, 0], [1.0, 0.0], 0.0, [0, 1], [-1.0, 0.0], 0.0)
        assert not ok and np.isnan(B).all()


# ----------------------------------------------------------------- RPP (kind 5)
def test_rpp_closure_rates():
    alpha, h = 1.1, 0.12

    def kn(t):
        A = circ(t, (0.2, 0.1), 0.4, 1.4, 0.1)
        P = circ(t, (-0.5, 0.3), 0.1, 0.7, 0.0, drift=(0.0, 0.04))
        return A, P, guide(t, -0.4, 0.6, 0.15)
    (A, vA, aA), (P, vP, aP), (u, w, e) = kn(T)
    Q, s1, s2, ok, det = rpp_position(A, P, u, alpha, h)
    assert ok.all()
    wv = np.stack([np.cos(alpha) * u[:, 0] - np.sin(alpha) * u[:, 1],
                   np.sin(alpha) * u[:, 0] + np.cos(alpha) * u[:, 1]], -1)
    close(P + s1[:, None] * u, Q, 1e-12)
    close(Q + s2[:, None] * wv + h * perp(wv), A, 1e-12)
    close(det, np.sin(alpha), 1e-14)
    r = rpp_rates(A, Q, P, u, alpha, vA, vP, w, aA, aP, e)

    def pos(t):
        (A_, _, _), (P_, _, _), (u_, _, _) = kn(t)
        return rpp_position(A_, P_, u_, alpha, h)
    vQ, aQ = fd(lambda t: pos(t).Q, T)
    s2d, s2dd = fd(lambda t: pos(t).s2, T)
    close(r.vQ, vQ, 1e-7)
    close(r.aQ, aQ, 1e-5)
    close(r.s2d, s2d, 1e-7)
    close(r.s2dd, s2dd, 1e-5)


def test_rpp_structurally_singular():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = rpp_position([1.0, 1.0], [0.0, 0.0], [1.0, 0.0], 0.0, 0.0)
        assert not res.ok and np.isnan(res.Q).all()
        r = rpp_rates([1.0, 1.0], [0.0, 0.0], [0.0, 0.0], [1.0, 0.0], 0.0,
                      [0.0, 0.0], [0.0, 0.0], 0.0)
        assert r.singular


# ----------------------------------------------------------------- batch behaviour
def test_batch_never_raises_and_no_python_loop_shapes():
    rng = np.random.default_rng(0)
    n = 1000
    A = rng.uniform(-1, 1, (n, 2))
    C = rng.uniform(-1, 1, (n, 2))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        B, ok, det = rrr_position(A, C, 0.6, 0.5, 1.0)
        assert B.shape == (n, 2) and ok.shape == (n,)
        assert 0 < ok.sum() < n
        assert np.isnan(B[~ok]).all() and np.isfinite(B[ok]).all()
        r = rrr_rates(A, C, B, np.zeros((n, 2)), np.ones((n, 2)))
        assert r.w2.shape == (n,)


# ----------------------------------------------------------------- hypothesis, sliders
coord = st.floats(-2, 2)
angle = st.floats(-np.pi, np.pi)


@given(coord, coord, coord, coord, angle, st.floats(0.2, 2.0), st.floats(-0.5, 0.5),
       st.sampled_from([1.0, -1.0]), st.floats(-2, 2), st.floats(-2, 2))
def test_rrp_random_geometry(ax, ay, px, py, phi, l2, h, sign, om, vy):
    A, P = np.array([ax, ay]), np.array([px, py])
    u = np.array([np.cos(phi), np.sin(phi)])
    B, s, ok, det = rrp_position(A, P, u, l2, h, sign)
    dist = abs(h - np.dot(A - P, perp(u)))
    if dist < l2 * (1 - 1e-6):
        assert ok
        assert abs(np.linalg.norm(B - A) - l2) <= 1e-12 * max(l2, 1.0) * 4
        assert abs(np.dot(B - P, perp(u)) - h) <= 1e-12 * 8
        if dist < l2 * 0.999:
            assert rrp_branch(A, B, u) == sign
            # velocity vs central difference: the guide turns about P, A moves
            vA = np.array([0.2, vy])
            r = rrp_rates(A, B, P, u, vA, np.zeros(2), om)

            def pos(t):
                ut = np.array([np.cos(phi + om * t), np.sin(phi + om * t)])
                return rrp_position(A + t * vA, P, ut, l2, h, sign).B
            hh = 1e-6
            vfd = (pos(hh) - pos(-hh)) / (2 * hh)
            assert np.allclose(r.vB, vfd, rtol=1e-4, atol=1e-4 * (1 + np.abs(r.vB).max()))
    elif dist > l2 * (1 + 1e-9):
        assert not ok and np.isnan(B).all()


@given(coord, coord, coord, coord, st.floats(-1, 1), st.sampled_from([1.0, -1.0]),
       st.floats(-2, 2), st.floats(-2, 2))
def test_rpr_random_geometry(ax, ay, cx, cy, h, sign, vx, vy):
    A, C = np.array([ax, ay]), np.array([cx, cy])
    d = np.linalg.norm(A - C)
    u, s, ok, det = rpr_position(A, C, h, sign)
    if d > abs(h) * (1 + 1e-6) and d > 1e-6:
        assert ok
        assert np.allclose(C + s * u + h * perp(u), A, atol=1e-12 * max(d, 1.0) * 4)
        if d > abs(h) * 1.001 + 1e-3:
            assert rpr_branch(A, C, u) == sign
            vA = np.array([vx, vy])
            r = rpr_rates(A, C, u, vA, np.zeros(2))
            hh = 1e-6
            sp = rpr_position(A + hh * vA, C, h, sign).s
            sm = rpr_position(A - hh * vA, C, h, sign).s
            assert np.isclose(r.sd, (sp - sm) / (2 * hh), rtol=1e-4, atol=1e-4 * (1 + abs(r.sd)))
    elif d < abs(h) * (1 - 1e-9):
        assert not ok and np.isnan(u).all()


@given(coord, coord, coord, coord, angle, angle, st.floats(-1, 1), st.floats(-1, 1))
def test_prp_random_geometry(x1, y1, x2, y2, p1, p2, h1, h2):
    u1 = np.array([np.cos(p1), np.sin(p1)])
    u2 = np.array([np.cos(p2), np.sin(p2)])
    P1, P2 = np.array([x1, y1]), np.array([x2, y2])
    B, s1, s2, ok, det = prp_position(P1, u1, h1, P2, u2, h2)
    if abs(np.sin(p2 - p1)) > 1e-3:
        assert ok
        tol = 1e-12 * (1 + np.abs(B).max() + abs(s1) + abs(s2)) * 8
        assert np.allclose(P1 + s1 * u1 + h1 * perp(u1), B, atol=tol)
        assert np.allclose(P2 + s2 * u2 + h2 * perp(u2), B, atol=tol)
    elif abs(np.sin(p2 - p1)) < 1e-12:
        assert not ok
