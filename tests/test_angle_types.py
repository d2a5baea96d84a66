"""The types of monitored angle and their registry (issue 36).

Every quantity a group kind declares is a registered type; a type registered from a
test (with a group kind that declares it) flows through the angles, the check's
extremes, its JSON, its text and its verdict with no other file edited; and the three
library types give the values of their textbook formulas, computed here another way
(arccos of a dot product, a 2×2 solve for the triad's intersection).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from multiloop.catalogue.named import load_named
from multiloop.kin.check import check
from multiloop.kin.check.angle_types import ANGLE_TYPES, AngleType, angle_type, unsigned_angle
from multiloop.kin.check.transmission import angle_specs, angle_values
from multiloop.kin.groups.registry import KINDS, angle_defs, registered
from multiloop.kin.groups.rrr import RRRStep
from multiloop.kin.groups.step import AngleDef, GroupStep
from multiloop.kin.solve import solve
from multiloop.topo.assur import GroupKind, decompose

CATALOGUE = sorted(p.stem for p in (Path(__file__).resolve().parents[1] / "catalogue" / "mechanisms").glob("*.toml"))


def test_every_declared_quantity_is_a_registered_type():
    seen = {}                                   # adapter -> quantities it declared
    for name in CATALOGUE:
        m = load_named(name)
        for g in decompose(m).groups:
            if g.kind in KINDS:
                seen.setdefault(KINDS[g.kind], set()).update(d.quantity for d in angle_defs(m, g))
    declaring = {a for a in KINDS.values() if a.monitored_angles.__func__ is not GroupStep.monitored_angles.__func__}
    assert declaring and declaring <= set(seen), "an adapter that declares angles has no catalogue mechanism"
    for adapter, quantities in seen.items():
        assert adapter in declaring or not quantities
        for q in quantities:
            assert angle_type(q).name == q, (adapter.__name__, q)
    assert set().union(*seen.values()) == {"transmission", "pressure", "triad"}


def test_an_unknown_quantity_is_named():
    with pytest.raises(KeyError, match="no monitored angle type 'nope'"):
        angle_type("nope")


def test_the_library_types_facts():
    t, p, r = (ANGLE_TYPES[n] for n in ("transmission", "pressure", "triad"))
    assert (t.span, t.ideal, t.degenerate) == ((0.0, 180.0), 90.0, (0.0, 180.0))
    assert (p.span, p.ideal, p.degenerate) == ((0.0, 90.0), 0.0, (90.0,))
    assert (r.span, r.ideal, r.degenerate) == ((0.0, 90.0), 90.0, (0.0,))
    # which extreme is flagged: both for a transmission angle, the maximum of a pressure
    # angle, only the minimum of a triad's
    assert t.flagged(30.0, 100.0, 40.0) and t.flagged(60.0, 150.0, 40.0) and not t.flagged(60.0, 100.0, 40.0)
    assert p.flagged(0.0, 55.0, 40.0) and not p.flagged(0.0, 45.0, 40.0)
    assert r.flagged(30.0, 90.0, 40.0) and not r.flagged(60.0, 90.0, 40.0)
    assert (t.margin(30.0, 170.0), p.margin(0.0, 55.0), r.margin(30.0, 90.0)) == (10.0, 35.0, 30.0)
    assert t.reach_limit and p.reach_limit and not r.reach_limit
    assert AngleType().margin(30.0, 90.0) == np.inf and not AngleType().flagged(0.0, 180.0, 40.0)


# -- a type of the test's own, and a group kind that declares it ----------------------

@dataclass(frozen=True)
class Deviation(AngleType):
    """The deviation |90° − μ| of a triangle's angle μ at B from the right angle: 0° is
    ideal, 90° the toggle, so only its maximum is flagged."""

    name: str = "deviation"
    label: str = "deviation angle"
    span: tuple[float, float] = (0.0, 90.0)
    ideal: float = 0.0
    degenerate: tuple[float, ...] = (90.0,)
    rises: str = "reaches"
    summary: str = "deviation_angles"
    reach_limit: bool = True

    def value(self, view, spec):
        A, B, C = (view.point(n) for n in spec.points)
        return np.abs(90.0 - unsigned_angle(A - B, C - B))

    def signed_det(self, view, spec):
        A, B, C = (view.point(n) for n in spec.points)
        u, v = A - B, C - B
        return (u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]) / (
            np.hypot(u[..., 0], u[..., 1]) * np.hypot(v[..., 0], v[..., 1]))


class DeviationStep(RRRStep):
    """An RRR dyad whose monitored angle is the deviation at its inner pin."""

    kind = "RRR_deviation"

    @classmethod
    def relabel(cls, m, group):
        return (cls.kind, group.layout) if group.kind is GroupKind.RRR else None

    @classmethod
    def monitored_angles(cls, m, group):
        lay = group.layout
        return (AngleDef(lay.inner, "deviation", (lay.outer1, lay.inner, lay.outer2)),)


@pytest.fixture
def deviated(monkeypatch):
    """The four-bar read with the type and the kind registered, and its check before."""
    ref = check(load_named("four_bar"))
    monkeypatch.setitem(ANGLE_TYPES, "deviation", Deviation())
    with registered(DeviationStep):
        yield load_named("four_bar"), ref


def test_a_registered_type_flows_through_the_angles(deviated):
    m, _ = deviated
    (sp,) = angle_specs(decompose(m))
    assert (sp.quantity, sp.joint, sp.kind, sp.ideal) == ("deviation", "B", "RRR_deviation", 0.0)
    x = np.radians(np.arange(0.0, 360.0, 15.0))
    st = solve(m, x)
    A, B, C = (st.positions[:, st.joint_index(n)] for n in sp.points)
    u, v = A - B, C - B
    mu = np.degrees(np.arccos(np.sum(u * v, axis=1) / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1))))
    np.testing.assert_allclose(angle_values(st, [sp])[:, 0], np.abs(90.0 - mu), atol=1e-9)


def test_a_registered_type_flows_through_the_check(deviated):
    m, ref = deviated
    rep = check(m)
    (a,), (t,) = rep.drivers[0].angles, ref.drivers[0].angles
    assert (a.quantity, a.joint, t.quantity) == ("deviation", "B", "transmission")
    # the extremes are the transmission angle's, mirrored about 90°
    assert abs(a.extreme.max - (90.0 - t.extreme.min)) < 1e-6 and abs(a.extreme.min - (90.0 - t.extreme.max)) < 1e-6
    assert abs(a.extreme.at_max - t.extreme.at_min) < 1e-5 and rep.drivers[0].full_rotation
    d = rep.as_dict()
    assert d["drivers"]["O2"]["angles"]["B"]["quantity"] == "deviation"
    assert d["deviation_angles"]["B"]["max"] == a.extreme.max and d["deviation_angles"]["B"]["driver"] == "O2"
    assert d["transmission"] == {} and list(d).index("deviation_angles") == list(d).index("dead_centres") - 1
    assert a.flagged(40.0) and not a.flagged(20.0)          # 63.6° > 90° − 40°, < 90° − 20°
    (line,) = rep.verdict
    assert line.startswith(f"deviation angle at B reaches {a.extreme.max:.3f}° at O2 = ") and "(above 50°)" in line
    assert f"deviation angle at B: min {a.extreme.min:.3f}°" in rep.to_text()


# -- the library's types against their formulas, computed another way ---------------------

def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _guide(st, m, guide):
    pj, link = guide
    ax = np.asarray(m.joint(pj).axis, float)
    th = st.angles[:, st.link_index(link)] + np.arctan2(ax[1], ax[0])
    return np.stack([np.cos(th), np.sin(th)], axis=-1)


def _by_hand(st, m, sp):
    P = {n: st.positions[:, st.joint_index(n)] for n in sp.points}
    if sp.quantity == "transmission":
        A, B, C = (P[n] for n in sp.points)
        return np.degrees(np.arccos(np.clip(np.sum(_unit(A - B) * _unit(C - B), axis=1), -1, 1)))
    if sp.quantity == "pressure":
        X, Y = (P[n] for n in sp.points)
        return np.degrees(np.arccos(np.clip(np.abs(np.sum(_unit(Y - X) * _guide(st, m, sp.guide), axis=1)), 0, 1)))
    Ai, Pi, Aj, Pj, Ak, Pk = (P[n] for n in sp.points)
    out = np.full(len(Ai), np.nan)
    for r in range(len(Ai)):              # I = Aj + s (Pj − Aj) = Ak + t (Pk − Ak)
        M = np.column_stack([Pj[r] - Aj[r], Ak[r] - Pk[r]])
        if abs(np.linalg.det(M)) < 1e-6 * np.linalg.norm(M) ** 2:
            continue
        s, _ = np.linalg.solve(M, Ak[r] - Aj[r])
        to_i = Aj[r] + s * (Pj[r] - Aj[r]) - Pi[r]
        out[r] = np.degrees(np.arccos(min(1.0, abs(_unit(Ai[r] - Pi[r]) @ _unit(to_i)))))
    return out


@pytest.mark.parametrize("name", ["four_bar", "dyad_rrr", "dyad_rrp", "dyad_rpr", "six_bar_slider",
                                  "stephenson_3_triad", "excavator_bucket"])
def test_the_values_are_the_formulas(name):
    m = load_named(name)
    specs = angle_specs(decompose(m))
    x = np.linspace(-0.3, 0.3, 13) if m.is_rotary(0) else np.linspace(-0.01, 0.01, 13)
    X = np.column_stack([x] + [np.zeros_like(x)] * (len(m.drivers) - 1)) if len(m.drivers) > 1 else x
    st = solve(m, X)
    assert st.ok.sum() >= 5
    got = angle_values(st, specs)
    for c, sp in enumerate(specs):
        want = _by_hand(st, m, sp)
        keep = st.ok & np.isfinite(want)
        assert keep.sum() >= 5
        np.testing.assert_allclose(got[keep, c], want[keep], atol=1e-6, err_msg=f"{name} {sp.quantity} {sp.joint}")
        lo, hi = angle_type(sp.quantity).span
        assert np.all((got[keep, c] >= lo) & (got[keep, c] <= hi))
