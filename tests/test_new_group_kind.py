"""A group kind registered from a test, with no other file edited (issue 36).

The kind "RRR_mirror" is an RRR dyad read the other way round (outer2-inner-outer1)
under its own name: its adapter is the RRR one with its kind and its decomposition rule
changed, so every answer must be the RRR dyad's (its branch sign, read from the
reference, is the opposite one).  Registered, it is solved, checked (with its monitored
angle), solved in a design batch and used by the dimensional synthesis, all through the
registry (:mod:`multiloop.kin.groups.registry`).
"""
from __future__ import annotations

import numpy as np
import pytest

from multiloop.catalogue.dimensional import Evaluator, design_space, synthesise
from multiloop.catalogue.named import load_named
from multiloop.kin.check import check
from multiloop.kin.check.transmission import angle_specs
from multiloop.kin.design import branch_signs, solve_designs
from multiloop.kin.groups.registry import KINDS, mode_count, register, registered, unregister
from multiloop.kin.groups.rrr import RRRStep
from multiloop.kin.solve import plan_of, solve
from multiloop.topo.assur import DyadLayout, GroupKind, decompose

MIRROR = "RRR_mirror"


class MirrorStep(RRRStep):
    """An RRR dyad read outer2-inner-outer1, as a kind of its own."""

    kind = MIRROR

    @classmethod
    def relabel(cls, m, group):
        if group.kind is not GroupKind.RRR:
            return None
        o1, inner, o2, l1, l2 = group.layout
        return cls.kind, DyadLayout(o2, inner, o1, l2, l1)


X_SOLVE = np.radians(np.arange(0.0, 360.0, 7.5))
X_BATCH = np.radians(np.arange(0.0, 360.0, 15.0))


def _designs(m):
    sp = design_space(m)
    return sp.names, sp.x0 + 0.002 * np.random.default_rng(36).standard_normal((5, sp.size))


def _answers(m) -> dict:
    """What the library answers for ``m`` (solve, check, a design batch)."""
    names, X = _designs(m)
    batch = solve_designs(m, names, X, X_BATCH)
    return {"state": solve(m, X_SOLVE, derivatives=True), "check": check(m), "batch": batch,
            "P": batch.point("P"), "signs": branch_signs(m, names, X)}


@pytest.fixture
def mirrored():
    """The four-bar read while the kind is registered, and the answers for the same file
    before it (an RRR dyad)."""
    ref = _answers(load_named("four_bar"))
    with registered(MirrorStep):
        yield load_named("four_bar"), ref
    assert MIRROR not in KINDS


def test_the_decomposition_gives_the_registered_kind(mirrored):
    m, _ = mirrored
    (g,) = decompose(m).groups
    assert g.kind == MIRROR and g.kind_name == MIRROR and g.label == "II(2,3)"
    assert g.layout.outer1 == "O4" and mode_count(m, g) == 2


def test_the_kind_is_gone_after_the_block():
    with registered(MirrorStep):
        pass
    (g,) = decompose(load_named("four_bar")).groups
    assert g.kind is GroupKind.RRR


def test_a_kind_name_is_registered_once(mirrored):
    with pytest.raises(ValueError, match="new kind name"):
        register(MirrorStep)
    for name in ("RRR", "triad", "group"):
        with pytest.raises(ValueError, match="new kind name"):
            register(type("Taken", (RRRStep,), {"kind": name}))
    with pytest.raises(ValueError, match="registered kind"):
        unregister(GroupKind.RRR)


def test_solve_uses_its_adapter(mirrored):
    m, ref = mirrored
    st = plan_of(m).steps[1]
    assert type(st.closed) is MirrorStep and st.solver == "dyad"
    a, b = solve(m, X_SOLVE, derivatives=True), ref["state"]
    assert a.ok.all() and b.ok.all()
    assert np.allclose(a.positions, b.positions, rtol=0, atol=1e-12)
    assert np.allclose(a.velocities, b.velocities, rtol=0, atol=1e-10)
    assert np.allclose(a.accelerations, b.accelerations, rtol=0, atol=1e-8)


def test_check_reports_its_monitored_angle(mirrored):
    m, ref = mirrored
    (spec,) = angle_specs(decompose(m))
    assert spec.quantity == "transmission" and spec.points == ("O4", "B", "A") and spec.kind == MIRROR
    a, b = check(m), ref["check"]
    assert a.circuits[0].kind == MIRROR and a.circuits[0].modes == 2
    assert b.circuits[0].kind == "RRR"
    (ang,) = a.drivers[0].angles
    (ref_ang,) = b.drivers[0].angles
    assert ang.joint == "B" and ang.quantity == "transmission"
    assert abs(ang.extreme.min - ref_ang.extreme.min) < 1e-7 and abs(ang.extreme.max - ref_ang.extreme.max) < 1e-7
    assert a.drivers[0].full_rotation and b.drivers[0].full_rotation
    # the same verdict, naming the group by its kind
    assert len(a.verdict) == len(b.verdict) == 1 and "(RRR_mirror; links coupler, rocker)" in a.verdict[0]


def test_a_design_batch(mirrored):
    m, ref = mirrored
    names, X = _designs(m)
    a = solve_designs(m, names, X, X_BATCH)
    assert type(a.plan.steps[1].closed) is MirrorStep
    assert type(ref["batch"].plan.steps[1].closed) is RRRStep
    assert np.array_equal(a.ok, ref["batch"].ok) and a.ok.any()
    assert np.allclose(a.point("P")[a.ok], ref["P"][a.ok], rtol=0, atol=1e-12)
    # the mirrored dyad reads the other branch sign from the same reference
    assert np.array_equal(branch_signs(m, names, X), -ref["signs"])


def test_a_dimensional_synthesis(mirrored):
    m, _ = mirrored
    st = solve(m, np.radians(np.arange(0.0, 360.0, 45.0)))
    target = st.point_positions[:, st.point_index("P")] + 0.001
    assert not Evaluator(m, design_space(m, ["P"])).slow
    res = synthesise(m, path=target, point="P", evaluations=200, seed=0, tol=0.0, min_transmission=20.0)
    assert res.evaluations <= 200 and res.stopped == "evaluations" and np.isfinite(res.error_max)
    (g,) = decompose(res.mechanism).groups
    assert g.kind == MIRROR


def test_the_compiled_kernel_runs_its_lowered_step(mirrored):
    pytest.importorskip("numba")
    from multiloop.kin import kernel
    m, ref = mirrored
    kp = kernel.kernel_plan(plan_of(m))
    assert kp.complete                      # its lowered step has a compiled function (the RRR one)
    with kernel.using("on"):
        a = solve(m, X_SOLVE)
    assert a.ok.all() and np.allclose(a.positions, ref["state"].positions, rtol=0, atol=1e-12)
