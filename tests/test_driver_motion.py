"""The motion of one driver (kin.motion.DriverMotion): one frozen home that the check,
the figures, the sweeps, the forces and the page ask for a driver moved alone.

Oracles: a Grashof crank-rocker's crank turns fully (period 2π); a non-Grashof four-bar
(frame 4, crank 1, coupler 1.5, rocker 3) stops at the two crank angles where coupler and
rocker fold, each named by the group at its limit.
"""
from __future__ import annotations

import dataclasses
import pathlib
import re
from types import MappingProxyType

import numpy as np
import pytest

from multiloop.catalogue.named import load_named
from multiloop.kin.check.core import _motion
from multiloop.kin.motion import DriverMotion
from multiloop.kin.solve import compile_plan, motion_events
from multiloop.topo.assur import decompose
from multiloop.topo.model import MechanismBuilder


def _four_bar(crank, coupler, rocker, frame=4.0):
    b = MechanismBuilder()
    b.add_link("ground", frame=True)
    a = np.array([crank, 0.0])
    d = np.array([frame, 0.0])
    # B: at coupler from A and rocker from D, above the frame line
    L = np.linalg.norm(d - a)
    x = (coupler ** 2 - rocker ** 2 + L ** 2) / (2 * L)
    B = a + (d - a) / L * x + np.array([0.0, np.sqrt(coupler ** 2 - x ** 2)])
    for n, lk, at in [("O", ("ground", "crank"), (0.0, 0.0)), ("A", ("crank", "rod"), tuple(a)),
                      ("B", ("rod", "rocker"), tuple(B)), ("C", ("rocker", "ground"), tuple(d))]:
        b.add_joint(n, "R", lk, at=at)
    b.add_driver("O")
    return b.build()


def test_a_crank_that_turns_fully():
    dm = motion_events(load_named("four_bar"))
    assert dm.certified and dm.turns_fully and dm.period == pytest.approx(2 * np.pi)
    assert dm.rotary and dm.joint == "O2" and dm.k == 0
    assert dm.lo == -np.inf and dm.hi == np.inf and dict(dm.limits) == {}


def test_a_crank_that_stops_names_the_groups_at_its_limits():
    m = _four_bar(1.0, 1.5, 3.0)
    dm = motion_events(m)
    assert dm.certified and not dm.turns_fully
    assert np.isfinite(dm.lo) and np.isfinite(dm.hi) and dm.lo < 0.0 < dm.hi
    assert set(dm.limits) == {"lo", "hi"} and all("RRR" in v for v in dm.limits.values())


def test_inputs_move_one_driver_and_hold_the_others():
    m = load_named("excavator")            # three cylinders
    n = len(m.drivers)
    dm = DriverMotion.held(m, 1)
    assert not dm.certified and not dm.turns_fully and dm.change_points == ()
    X = dm.inputs([0.0, 0.01, 0.02])
    assert X.shape == (3, n) and np.all(X[:, 1] == [0.0, 0.01, 0.02])
    assert np.all(np.delete(X, 1, axis=1) == 0.0)
    at = np.arange(n, dtype=float)
    assert np.all(np.delete(dm.inputs([0.5], at), 1, axis=1) == np.delete(at, 1))
    assert dm.rates().tolist() == [1.0 if i == 1 else 0.0 for i in range(n)]
    assert motion_events(m) is None        # no certified walk of several drivers


def test_the_motion_is_frozen():
    dm = motion_events(load_named("four_bar"))
    with pytest.raises(dataclasses.FrozenInstanceError):
        dm.lo = 0.0
    assert isinstance(dm.limits, MappingProxyType)
    assert isinstance(DriverMotion.held(load_named("four_bar")).limits, MappingProxyType)


def test_the_check_samples_the_certified_motion_it_was_given():
    m = _four_bar(1.0, 1.5, 3.0)
    ap = decompose(m)
    _, _, mo = _motion(m, ap, compile_plan(m, ap), 0)
    assert mo.driver.certified and mo.events is mo.driver
    assert all(seg.side.motion is mo.driver for seg in mo.segments)
    assert sorted(mo.limits) == pytest.approx(sorted([mo.driver.lo, mo.driver.hi]), abs=1e-10)


def test_no_other_module_moves_a_driver_alone():
    """"Driver k at x, the others at the reference" is written once, in kin/motion.py."""
    root = pathlib.Path(__file__).resolve().parents[1]
    alone = re.compile(r"\[:, (self\.)?k\] = (x|col)\b|\[(self\.)?k\] = 1\.0|unit\[k\] = 1")
    found = [f"{p.relative_to(root)}:{i}" for pkg in ("kin", "catalogue", "multiloop")
             for p in sorted((root / pkg).rglob("*.py"))
             for i, line in enumerate(p.read_text().splitlines(), 1) if alone.search(line)]
    assert [f.split(":")[0] for f in found] == ["kin/motion.py", "kin/motion.py"]


@pytest.mark.parametrize("dims", [(1.0, 3.5, 3.0), (1.0, 1.5, 3.0), (2.2, 2.0, 3.0)])
def test_reaches_agrees_with_solve_and_with_the_check(dims):
    """Two routes to "the motion reaches this input": DriverMotion.reaches (the certified
    ends, R inputs modulo 360°) against solve's own answer (ok, or a limit / another
    circuit) and against the check's unreachable positions, on a crank-rocker and two
    non-Grashof four-bars, over inputs from −720° to 720°."""
    from multiloop.kin.check import check
    from multiloop.kin.solve import solve
    m = _four_bar(*dims)
    mo = motion_events(m)
    x = np.radians(np.linspace(-720.0, 720.0, 97)) + 1e-3
    got = mo.reaches(x)
    st = solve(m, x)
    assert np.array_equal(got, np.asarray(st.ok, bool))
    dc = check(m, positions={"O": list(x)}).drivers[0]
    assert {float(v) for v in dc.unreachable} == {float(v) for v in x[~got]}
    assert mo.holds_span(x) == mo.turns_fully
    if not mo.turns_fully:
        assert mo.holds_span([mo.lo, mo.hi]) and not mo.holds_span([mo.lo, mo.hi + 1e-6])


def test_reaches_needs_a_certified_motion():
    with pytest.raises(ValueError, match="certified"):
        DriverMotion.held(_four_bar(1.0, 3.5, 3.0)).reaches([0.0])


def test_turns_fully_agrees_with_the_checks_full_rotation():
    """The dimensional synthesis asks the certified motion whether a design turns fully
    (catalogue.dimensional.report.turns_fully), where it ran the whole check: both
    routes agree on four-bars around the Grashof boundary (crank + frame = coupler +
    rocker ± 1e-3) and on every one-crank catalogue mechanism."""
    from multiloop.kin.check import check
    from multiloop.inputs import load_mechanism
    ms = [_four_bar(1.0, c, 3.0) for c in (2.0 - 1e-3, 2.0 + 1e-3, 2.5, 1.2)]
    ms += [load_mechanism(n) for n in ("four_bar", "watt_1", "watt_2", "stephenson_1", "stephenson_3_triad",
                                      "crank_slider")]
    seen = set()
    for m in ms:
        full = check(m).drivers[0].full_rotation
        assert motion_events(m).turns_fully == full, m.name
        seen.add(full)
    assert seen == {True, False}


@pytest.mark.parametrize("name", ["four_bar", "radial_engine_5cyl", "excavator", "stephenson_3_triad"])
def test_a_side_solves_its_inputs_alone_only_where_the_path_changes_none_of_their_values(name):
    """A side of the check's motion (kin.check.sweep.Side) solves the inputs it is asked
    for alone when the plan solves each on its own branch (drivers and closed-form dyads:
    ``solved_alone``), and along the grid's path from the reference otherwise (a triad):
    the values are the path's bit for bit, with velocities."""
    from unittest import mock

    from multiloop.kin.check import sweep
    m = load_named(name)
    _, _, mo = _motion(m, decompose(m), compile_plan(m, decompose(m)), 0)
    side = mo.segments[0].side
    assert sweep.solved_alone(side.plan) == (name != "stephenson_3_triad")
    x = np.linspace(0.0, 0.9, 7) * (mo.segments[0].x[-1] if mo.segments[0].n else 1.0)
    alone, rows = side.at(x[::-1], derivatives=True)
    with mock.patch.object(sweep, "solved_alone", return_value=False):
        path, path_rows = side.at(x[::-1], derivatives=True)
    for f in ("positions", "velocities", "omegas"):
        assert np.array_equal(getattr(alone, f)[rows], getattr(path, f)[path_rows], equal_nan=True)
    assert alone.accelerations is None and path.accelerations is None      # (the check reads velocities only)
    assert list(alone.status[rows]) == list(path.status[path_rows])
