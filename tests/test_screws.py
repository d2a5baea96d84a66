"""Screws in Plücker coordinates (kin.screws): conventions, invariants, two-route checks."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from multiloop.kin.spatial.screws import (Screw, ScrewPairingError, Twist, Wrench, axis_points, moved_about, mutual_moment,
                        pitches, plucker_lines, reciprocal, reciprocal_complements, reciprocal_products)
from multiloop.topo.errors import InputError, LinkageError

coord = st.floats(-10, 10, allow_nan=False, allow_infinity=False)
vec3 = st.tuples(coord, coord, coord)
six = st.tuples(coord, coord, coord, coord, coord, coord)
unit_dir = vec3.filter(lambda v: np.linalg.norm(v) > 1e-2)


def _rotation(seed: int) -> np.ndarray:
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


# -- conventions ---------------------------------------------------------------
def test_line_moment_is_r_cross_d():
    # strut 3 of Doronin 2015 (A -> A'): printed e3 = (0 0 -1 | b 0 0), b = 3 m
    s = Screw.from_points((0.0, -3.0, 0.0), (0.0, -3.0, -2.0))
    assert s.as_array().tolist() == [0.0, 0.0, -1.0, 3.0, 0.0, 0.0]
    assert s.pitch == 0.0


def test_twist_is_omega_and_velocity_at_origin():
    t = Twist.from_axis((0.0, -3.0, 0.0), (0.0, 0.0, 1.0))
    # the body point at the origin moves as a point of a body turning about x=0, y=-3
    np.testing.assert_allclose(t.linear, np.cross(t.angular, np.array([0.0, 3.0, 0.0])))
    np.testing.assert_allclose(t.velocity_at((0.0, -3.0, 5.0)), 0.0, atol=1e-15)


@given(vec3, unit_dir, coord)
def test_axis_and_pitch_recovered(point, direction, pitch):
    t = Twist.from_axis(point, direction, pitch=pitch, rate=2.5)
    assert t.pitch == pytest.approx(pitch, abs=1e-9)
    u = np.asarray(direction) / np.linalg.norm(direction)
    np.testing.assert_allclose(t.axis_direction, u, atol=1e-12)
    p = t.axis_point
    assert abs(np.dot(p, u)) < 1e-9 * (1 + np.linalg.norm(point))      # nearest to O
    off = p - np.asarray(point)
    np.testing.assert_allclose(np.cross(off, u), 0.0, atol=1e-9)          # on the given line


def test_pure_translation():
    t = Twist.translation((0.0, 3.0, 4.0))
    assert t.is_infinite_pitch and t.pitch == np.inf
    assert np.all(np.isnan(t.axis_point))
    np.testing.assert_allclose(t.axis_direction, (0, 0.6, 0.8))
    np.testing.assert_allclose(t.normalized().as_array(), (0, 0, 0, 0, 0.6, 0.8))
    with pytest.raises(InputError, match="non-zero"):
        Twist.translation((0, 0, 0)).normalized()


# -- the reciprocal product ----------------------------------------------------
@given(six, six, vec3)
def test_reciprocal_invariant_under_change_of_origin(t, w, P):
    tw, wr = Twist.from_array(t), Wrench.from_array(w)
    a = reciprocal(tw, wr)
    b = reciprocal(tw.about(P), wr.about(P))
    assert b == pytest.approx(a, abs=1e-9 * (1 + abs(a) + 100 * np.linalg.norm(P) ** 2))


@given(six, six, st.integers(0, 10_000), vec3)
def test_reciprocal_invariant_under_rigid_motion(t, w, seed, shift):
    R = _rotation(seed)
    tw, wr = Twist.from_array(t), Wrench.from_array(w)
    a = reciprocal(tw, wr)
    b = reciprocal(tw.transformed(R, shift), wr.transformed(R, shift))
    assert b == pytest.approx(a, abs=1e-8 * (1 + abs(a) + 100 * np.linalg.norm(shift) ** 2))


@given(six, vec3, vec3)
def test_reciprocal_is_power(t, point, force):
    """Two routes: screw product vs F · v(point) of the body point where F acts."""
    tw = Twist.from_array(t)
    w = Wrench.from_force(point, force)
    assert reciprocal(w, tw) == pytest.approx(float(np.dot(force, tw.velocity_at(point))), abs=1e-8)


@given(six, vec3)
def test_wrench_about_point_is_moment_about_point(w0, P):
    wr = Wrench.from_force((1.0, 2.0, 3.0), w0[:3], couple=w0[3:])
    moment_P = np.cross(np.subtract((1.0, 2.0, 3.0), P), w0[:3]) + np.asarray(w0[3:])
    np.testing.assert_allclose(wr.about(P).torque, moment_P, atol=1e-9)


def test_mutual_moment_of_lines():
    h = 1.7
    x_axis = Screw.from_line((0, 0, 0), (1, 0, 0))
    y_line = Screw.from_line((0, 0, h), (0, 1, 0))
    assert mutual_moment(x_axis, y_line) == pytest.approx(-h)          # -dist * sin(90°)
    meeting = Screw.from_line((5, 0, 0), (0, 1, 1))
    parallel = Screw.from_line((0, 4, 4), (2, 0, 0))
    assert mutual_moment(x_axis, meeting) == pytest.approx(0.0, abs=1e-15)
    assert mutual_moment(x_axis, parallel) == pytest.approx(0.0, abs=1e-15)


# -- types -----------------------------------------------------------------------
def test_twists_and_wrenches_pair_only_by_reciprocal():
    t = Twist.from_array([1, 2, 3, 4, 5, 6])
    w = Wrench.from_array([1, 2, 3, 4, 5, 6])
    with pytest.raises(ScrewPairingError, match="one Twist and one Wrench"):
        reciprocal(t, t)
    with pytest.raises(ScrewPairingError):
        reciprocal(w, w)
    with pytest.raises(ScrewPairingError):
        _ = t + w
    with pytest.raises(ScrewPairingError):
        mutual_moment(t, Screw.from_array([1, 0, 0, 0, 0, 0]))
    assert issubclass(ScrewPairingError, LinkageError) and issubclass(ScrewPairingError, TypeError)
    assert t != w and reciprocal(t, w) == reciprocal(w, t) == 2 * (1 * 4 + 2 * 5 + 3 * 6)


def test_frozen_and_hashable():
    t = Twist.from_array([1, 2, 3, 4, 5, 6])
    with pytest.raises(dataclasses.FrozenInstanceError):
        t.direction = (0.0, 0.0, 0.0)
    assert hash(t) == hash(Twist.from_array(np.arange(1.0, 7.0)))
    assert len({t, Twist.from_array([1, 2, 3, 4, 5, 6]), Wrench.from_array([1, 2, 3, 4, 5, 6])}) == 2
    assert (2 * t).as_array().tolist() == [2, 4, 6, 8, 10, 12] and (-t + t).as_array().tolist() == [0] * 6


def test_bad_coordinates_are_input_errors():
    with pytest.raises(InputError, match=r"shape \(6,\)"):
        Twist.from_array([1, 2, 3])
    with pytest.raises(InputError, match="finite"):
        Wrench((0, 0, float("nan")), (0, 0, 0))
    with pytest.raises(InputError, match="non-zero"):
        Screw.from_line((0, 0, 0), (0, 0, 0))


# -- batch helpers agree with the objects ------------------------------------------
def test_batch_helpers_match_objects():
    rng = np.random.default_rng(1)
    pts, dirs = rng.normal(size=(4, 5, 3)), rng.normal(size=(4, 5, 3))
    lines = plucker_lines(pts, dirs)
    assert lines.shape == (4, 5, 6)
    one = Screw.from_line(pts[2, 3], dirs[2, 3]).as_array()
    np.testing.assert_allclose(lines[2, 3], one, atol=1e-14)
    s = rng.normal(size=(7, 6))
    obj = [Screw.from_array(r) for r in s]
    np.testing.assert_allclose(pitches(s), [o.pitch for o in obj])
    np.testing.assert_allclose(axis_points(s), [o.axis_point for o in obj])
    P = rng.normal(size=3)
    np.testing.assert_allclose(moved_about(s, P), [o.about(P).as_array() for o in obj], atol=1e-14)
    np.testing.assert_allclose(reciprocal_products(s[:3], s[3:6]),
                               [mutual_moment(a, b) for a, b in zip(obj[:3], obj[3:6])])


@given(st.integers(0, 10_000))
def test_reciprocal_complement(seed):
    five = np.random.default_rng(seed).normal(size=(5, 6))
    x, ratio = reciprocal_complements(five)
    assert ratio > 1e-6
    np.testing.assert_allclose(reciprocal_products(five, x), 0.0, atol=1e-10)
    assert np.linalg.norm(x[:3]) == pytest.approx(1.0)                 # unit screw


def test_reciprocal_complement_flags_dependent_sets():
    five = np.random.default_rng(3).normal(size=(5, 6))
    five[4] = 2 * five[0] - five[1]
    x, ratio = reciprocal_complements(five)
    assert ratio < 1e-12 and np.all(np.isnan(x))
