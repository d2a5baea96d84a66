"""Assur decomposition (topo.assur): plans, formulas, errors.

The mechanism builders here are shared with test_solve.py / test_mobility.py.
Every reference configuration satisfies closure by construction (one ``at`` per
joint), so any joint positions make a valid mechanism.
"""
from __future__ import annotations

import math

import pytest

from multiloop.topo.assur import AssurGroup, AssurPlan, GroupKind, decompose
from multiloop.topo.errors import DecompositionError, MobilityError
from multiloop.topo.model import MechanismBuilder


# ---------------------------------------------------------------- builders
def circle_point(A, C, l1, l2, sign=1):
    """The point at distances l1 from A and l2 from C, left (+1) or right of A→C."""
    (ax, ay), (cx, cy) = A, C
    dx, dy = cx - ax, cy - ay
    d = math.hypot(dx, dy)
    a = (l1 * l1 - l2 * l2 + d * d) / (2 * d)
    h = math.sqrt(l1 * l1 - a * a)
    ux, uy = dx / d, dy / d
    return (ax + a * ux - sign * h * uy, ay + a * uy + sign * h * ux)


def four_bar(r=1.0, l=4.0, c=3.5, g=4.0, sign=-1, start=90.0, name="four-bar"):
    """Crank r about O=(0,0), coupler l, rocker c about C=(g,0); tracer M on the coupler."""
    O, C = (0.0, 0.0), (g, 0.0)
    A = (r * math.cos(math.radians(start)), r * math.sin(math.radians(start)))
    B = circle_point(A, C, l, c, sign)
    b = MechanismBuilder(name=name)
    b.add_link("ground", frame=True)
    for n, lk, at in [("O", ("ground", "crank"), O), ("A", ("crank", "coupler"), A),
                      ("B", ("coupler", "rocker"), B), ("C", ("rocker", "ground"), C)]:
        b.add_joint(n, "R", lk, at=at)
    b.add_driver("O")
    b.add_point("M", "coupler", (A[0] + 1.0, A[1] + 1.5))
    return b.build()


def crank_slider(r=0.05, l=0.2, e=0.01):
    b = MechanismBuilder(name="crank-slider")
    b.add_link("frame", frame=True)
    b.add_joint("O", "R", ("frame", "crank"), at=(0, 0))
    b.add_joint("A", "R", ("crank", "rod"), at=(r, 0))
    x = r + math.sqrt(l * l - e * e)
    b.add_joint("B", "R", ("rod", "piston"), at=(x, e))
    b.add_joint("S", "P", ("frame", "piston"), at=(x, e), axis=(1, 0))
    b.add_driver("O")
    b.add_point("G", "rod", (r + 0.3 * (x - r), 0.3 * e))
    return b.build()


def vtwin(r=0.05, l=0.2, gamma=90.0):
    """V-twin: crank + two rods on ONE crank pin A (a 3-link multiple joint)."""
    g = math.radians(gamma)
    b = MechanismBuilder(name="v-twin")
    b.add_link("frame", frame=True)
    b.add_joint("O", "R", ("frame", "crank"), at=(0, 0))
    b.add_joint("A", "R", ("crank", "rod1", "rod2"), at=(r, 0))
    b.add_joint("B1", "R", ("rod1", "p1"), at=(r + l, 0.0))
    b.add_joint("S1", "P", ("frame", "p1"), at=(r + l, 0.0), axis=(1, 0))
    u = (math.cos(g), math.sin(g))
    bq, cq = -2 * r * u[0], r * r - l * l
    t = (-bq + math.sqrt(bq * bq - 4 * cq)) / 2
    b.add_joint("B2", "R", ("rod2", "p2"), at=(t * u[0], t * u[1]))
    b.add_joint("S2", "P", ("frame", "p2"), at=(t * u[0], t * u[1]), axis=u)
    b.add_driver("O")
    return b.build()


def knitting_needle():
    """Pozhbelko & Kuts 2020 example 1 shape: crank + four RRR dyads, three 3-link pins
    (A: crank, 2, 4; C: frame, 3, 5; H: 6, 7, 8); n2 = 8, n3 = 1, n4 = 1."""
    b = MechanismBuilder(name="knitting-needle-like")
    b.add_link("frame", frame=True)
    J = [("O", ("frame", "crank"), (0.0, 0.0)),
         ("A", ("crank", "l2", "l4"), (0.1, 0.0)),
         ("B", ("l2", "l3"), (0.7, 0.3)),
         ("C", ("l3", "frame", "l5"), (0.5, -0.6)),
         ("D", ("l4", "l5"), (-0.2, -0.5)),
         ("F", ("l5", "l6"), (0.2, -0.9)),
         ("H", ("l6", "l7", "l8"), (0.6, -1.2)),
         ("E", ("l7", "frame"), (1.0, -0.8)),
         ("K", ("l8", "l9"), (0.3, -1.7)),
         ("G", ("l9", "frame"), (0.9, -1.6))]
    for n, lk, at in J:
        b.add_joint(n, "R", lk, at=at)
    b.add_driver("O")
    b.add_point("needle", "l9", (0.5, -1.9))
    return b.build()


def stephenson3_triad():
    """Crank driving a class III triad: ternary link T (P1, P2, P3), binaries
    b1 (A1 = crank tip → P1), b2 (frame → P2), b3 (frame → P3)."""
    b = MechanismBuilder(name="stephenson-III-triad")
    b.add_link("frame", frame=True)
    J = [("O", ("frame", "crank"), (0.0, 0.0)),
         ("A1", ("crank", "b1"), (0.1, 0.0)),
         ("P1", ("b1", "T"), (0.6, 0.5)),
         ("P2", ("T", "b2"), (1.154, 0.77)),
         ("P3", ("T", "b3"), (0.649, 0.232)),
         ("A2", ("b2", "frame"), (0.679, 1.428)),
         ("A3", ("b3", "frame"), (0.672, -0.306))]
    for n, lk, at in J:
        b.add_joint(n, "R", lk, at=at)
    b.add_driver("O")
    b.add_point("T0", "T", (0.9, 0.5))
    return b.build()


def six_bar_slider():
    """Watt-type six-bar ending in a slider: crank, RRR dyad (coupler, rocker),
    then an RRP dyad (rod, slider on a frame guide)."""
    b = MechanismBuilder(name="six-bar-slider")
    b.add_link("frame", frame=True)
    J = [("O", "R", ("frame", "crank"), (0.0, 0.0), None),
         ("A", "R", ("crank", "coupler"), (0.0, 0.25), None),
         ("B", "R", ("coupler", "rocker"), (0.8, 0.7), None),
         ("C", "R", ("rocker", "frame"), (1.0, 0.0), None),
         ("D", "R", ("rocker", "rod"), (1.05, 0.45), None),
         ("E", "R", ("rod", "slider"), (1.8, 0.3), None),
         ("S", "P", ("frame", "slider"), (1.8, 0.3), (1.0, 0.0))]
    for n, k, lk, at, ax in J:
        b.add_joint(n, k, lk, at=at, axis=ax)
    b.add_driver("O")
    return b.build()


def dyad_mechanism(kind: str):
    """A crank (and, for PRP/RPP, a second guide) driving one dyad of each kind."""
    b = MechanismBuilder(name=f"dyad-{kind}")
    b.add_link("frame", frame=True)
    b.add_joint("O", "R", ("frame", "crank"), at=(0.0, 0.0))
    if kind == "RRR":
        b.add_joint("A", "R", ("crank", "l2"), at=(0.3, 0.0))
        b.add_joint("B", "R", ("l2", "l3"), at=(0.9, 0.6))
        b.add_joint("C", "R", ("l3", "frame"), at=(1.2, 0.0))
    elif kind == "RRP":
        b.add_joint("A", "R", ("crank", "l2"), at=(0.3, 0.0))
        b.add_joint("B", "R", ("l2", "l3"), at=(1.1, 0.2))
        b.add_joint("S", "P", ("frame", "l3"), at=(1.1, 0.2), axis=(1.0, 0.1))
    elif kind == "RPR":   # coulisse: block l2 pinned to the crank at A, slides on l3 pivoted at C
        b.add_joint("A", "R", ("crank", "l2"), at=(0.3, 0.0))
        b.add_joint("S", "P", ("l3", "l2"), at=(0.3, 0.0), axis=(0.3 + 0.2, 0.0 - 0.8))
        b.add_joint("C", "R", ("l3", "frame"), at=(0.2, 0.8 + 0.15))
    elif kind == "PRP":   # l2 slides on the crank, l3 on the frame, joined by a pin B
        b.add_joint("S1", "P", ("crank", "l2"), at=(0.5, 0.2), axis=(1.0, 0.1))
        b.add_joint("B", "R", ("l2", "l3"), at=(0.5, 0.2))
        b.add_joint("S2", "P", ("frame", "l3"), at=(0.5, 0.2), axis=(0.2, 1.0))
    elif kind == "RPP":   # l2 pinned to the crank at A, slides on l3; l3 slides on a frame guide
        b.add_joint("A", "R", ("crank", "l2"), at=(0.3, 0.1))
        b.add_joint("S1", "P", ("l3", "l2"), at=(0.3, 0.1), axis=(0.3, 1.0))
        b.add_joint("S2", "P", ("frame", "l3"), at=(0.6, -0.2), axis=(1.0, 0.0))
    b.add_driver("O")
    return b.build()


# ---------------------------------------------------------------- tests
def test_four_bar_plan():
    p = decompose(four_bar())
    assert isinstance(p, AssurPlan)
    assert p.formula == "I(0,1) → II1(2,3)"
    (g,) = p.groups
    assert (g.cls, g.order, g.kind) == (2, 2, "RRR")
    assert set(g.links) == {"coupler", "rocker"}
    assert set(g.outer_joints) == {"A", "C"} and g.inner_joints == ("B",)
    assert set(g.known_links) == {"crank", "ground"}


def test_plan_is_frozen_and_hashable_parts():
    p = decompose(four_bar())
    with pytest.raises(Exception):
        p.steps = ()
    g = p.groups[0]
    assert hash(g) == hash(g)
    with pytest.raises(Exception):
        g.kind = "x"


def test_knitting_needle_is_crank_plus_four_rrr_dyads():
    m = knitting_needle()
    p = decompose(m)
    assert p.formula == "I(0,1) → II1(2,3) → II1(4,5) → II1(6,7) → II1(8,9)"
    assert [g.kind for g in p.groups] == ["RRR"] * 4
    assert all((g.cls, g.order) == (2, 2) for g in p.groups)
    # the multiple joints are never broken: each real link keeps its full joint set
    full = {lk: js for g in p.groups for lk, js in g.joints}
    assert full["l5"] == ("C", "D", "F")
    # the 3-link pin A feeds two dyads, C is shared by two groups, H by two groups
    feeding = [g for g in p.groups if "A" in g.outer_joints]
    assert len(feeding) == 2


def test_vtwin_one_pin_feeds_two_rrp_dyads():
    p = decompose(vtwin())
    assert p.formula == "I(0,1) → II2(2,3) → II2(4,5)"
    assert [g.kind for g in p.groups] == ["RRP", "RRP"]
    for g in p.groups:
        assert "A" in g.outer_joints and "crank" in g.known_links


def test_triad_is_class_three_order_three():
    p = decompose(stephenson3_triad())
    (g,) = p.groups
    assert (g.cls, g.order, g.kind) == (3, 3, "triad")
    assert p.formula == "I(0,1) → III(2,3,4,5)"
    tern, bins, outs, inns = g.layout
    assert tern == "T" and set(outs) == {"A1", "A2", "A3"}


@pytest.mark.parametrize("kind", ["RRR", "RRP", "RPR", "PRP", "RPP"])
def test_each_dyad_kind_is_recognised(kind):
    p = decompose(dyad_mechanism(kind))
    (g,) = p.groups
    assert g.kind == kind and g.cls == 2 and g.order == 2
    assert g.label.startswith(f"II{['RRR', 'RRP', 'RPR', 'PRP', 'RPP'].index(kind) + 1}(")


def test_six_bar_slider_order():
    p = decompose(six_bar_slider())
    assert p.formula == "I(0,1) → II1(2,3) → II2(4,5)"


def test_json_layout():
    d = decompose(knitting_needle()).as_dict()
    assert set(d) >= {"groups", "formula", "drivers"}
    g = d["groups"][0]
    assert set(g) >= {"class", "order", "kind", "links", "joints"}
    assert d["drivers"][0]["joint"] == "O"


def test_no_driver_is_a_mobility_error_naming_the_free_links():
    m = four_bar().with_drivers([])
    with pytest.raises(MobilityError, match=r"expected 1 driver.*got 0 driver.*F = 3\(n−1\) − 2p.*links"):
        decompose(m)


def test_too_many_drivers_is_a_mobility_error():
    m = four_bar()
    b = MechanismBuilder.from_mechanism(m)
    b.add_driver("C")
    with pytest.raises(MobilityError, match="over-constrained part"):
        decompose(b.build())


def test_driver_in_the_wrong_place_names_both_parts():
    """F = 1 overall, but the driver sits on a rigid triangle while a four-bar is free."""
    b = MechanismBuilder(name="misplaced")
    b.add_link("g", frame=True)
    for n, lk, at in [("O", ("g", "crank"), (0, 0)), ("A", ("crank", "cp"), (0, 1)),
                      ("B", ("cp", "rk"), (3, 2)), ("C", ("rk", "g"), (3, 0)),
                      ("D", ("g", "t1"), (5, 0)), ("E", ("t1", "t2"), (6, 1)), ("F", ("t2", "g"), (7, 0))]:
        b.add_joint(n, "R", lk, at=at)
    b.add_driver("D")
    with pytest.raises(DecompositionError) as e:
        decompose(b.build())
    msg = str(e.value)
    assert "under-constrained" in msg and "over-constrained" in msg
    assert "crank" in msg or "cp" in msg
    assert "D" in msg and "E" in msg


def test_rigid_triangle_tied_to_one_pin_passes_matching_but_is_not_rigid():
    b = MechanismBuilder(name="triangle-on-a-pin")
    b.add_link("g", frame=True)
    for n, lk, at in [("A", ("g", "b1", "b2", "b3"), (0, 0)), ("P", ("b1", "T"), (1, 0)),
                      ("Q", ("b2", "T"), (0, 1)), ("R", ("b3", "T"), (1, 1))]:
        b.add_joint(n, "R", lk, at=at)
    with pytest.raises(DecompositionError, match="not rigid"):
        decompose(b.build())


def test_bare_chain_is_rejected():
    from multiloop.topo.model import chain_from_joint_lists
    with pytest.raises(DecompositionError, match="frame"):
        decompose(chain_from_joint_lists([["a", "b"], ["b", "c"], ["c", "d"], ["d", "a"]]))


def test_decomposition_is_relabelling_invariant():
    m = knitting_needle()
    link_map = {x: f"z{x}" for x in m.link_names}
    p1, p2 = decompose(m), decompose(m.relabelled(link_map))
    assert [g.kind for g in p1.groups] == [g.kind for g in p2.groups]
    assert [tuple(link_map[x] for x in g.links) for g in p1.groups] == [g.links for g in p2.groups]


def test_driver_between_moving_links_gives_an_actuated_triangle():
    """A hydraulic cylinder (P driver between two moving links) lifting a boom: a block
    with the driver inside, recognised as a triangle of driven side length."""
    b = MechanismBuilder(name="boom")
    b.add_link("frame", frame=True)
    b.add_joint("O", "R", ("frame", "boom"), at=(0, 0))
    b.add_joint("A", "R", ("frame", "barrel"), at=(0.5, -0.5))
    b.add_joint("S", "P", ("barrel", "rod"), at=(1.0, 0.0), axis=(0.5, 0.5))
    b.add_joint("B", "R", ("rod", "boom"), at=(1.0, 0.0))
    b.add_driver("S")
    p = decompose(b.build())
    (g,) = p.groups
    assert g.kind is GroupKind.ACTUATED and set(g.links) == {"boom", "barrel", "rod"}
    assert g.kind_name == "RRR (actuated: S)" and g.drivers == (0,) and g.label.startswith("G3(")
    assert isinstance(g, AssurGroup)


def class4_mechanism():
    """Crank driving a class IV order 2 group: ternaries T2 (A, Q1, Q2) and T1 (K, P1, P2)
    closed by binaries b1 (Q1–P1) and b2 (Q2–P2) into a quadrilateral (dimensions of
    catalogue/mechanisms/stephenson_3.toml)."""
    b = MechanismBuilder(name="class-IV")
    b.add_link("frame", frame=True)
    J = [("O", ("frame", "crank"), (0.1851, 0.0143)), ("A", ("crank", "T2"), (0.1987, -0.0037)),
         ("Q1", ("T2", "b1"), (0.0391, 0.1598)), ("Q2", ("T2", "b2"), (0.1079, 0.1893)),
         ("P1", ("b1", "T1"), (-0.0379, 0.0678)), ("P2", ("b2", "T1"), (0.0426, 0.0227)),
         ("K", ("T1", "frame"), (0.0, 0.0))]
    for n, lk, at in J:
        b.add_joint(n, "R", lk, at=at)
    b.add_driver("O")
    return b.build()


def test_class_four_group():
    p = decompose(class4_mechanism())
    (g,) = p.groups
    assert (g.cls, g.order, g.kind) == (4, 2, "class IV")
    assert p.formula == "I(0,1) → IV(2,3,4,5)"
    t1, t2, b0, b1, o1, o2, *js = g.layout
    assert {t1, t2} == {"T1", "T2"} and {o1, o2} == {"A", "K"} and {b0, b1} == {"b1", "b2"}


_CAT = __import__("pathlib").Path(__file__).resolve().parents[1] / "catalogue" / "mechanisms"


@pytest.mark.parametrize("stem, formula", [
    ("knitting_needle_drive", "I(0,1) → II1(2,3) → II1(4,5) → II1(6,7) → II1(8,9)"),   # Pozhbelko & Kuts 2020 ex. 1
    ("radial_engine_5cyl", "I(0,1) → II2(2,3) → II2(4,5) → II2(6,7) → II2(8,9) → II2(10,11)"),
    ("stephenson_3_triad", "I(0,1) → III(2,3,4,5)"),
])
def test_catalogue_structure_formulas(stem, formula):
    from multiloop.topo.io import load
    m = load(_CAT / f"{stem}.toml")
    p = decompose(m)
    assert p.formula == formula
    if stem == "radial_engine_5cyl":   # all five rods hang off ONE 6-link pin, never broken
        pins = {j for g in p.groups for j in g.outer_joints if len(m.joint(j).links) == 6}
        assert len(pins) == 1


def test_documented_outputs_match_the_commands(capsys):
    """Every ``$ multiloop analyse|decompose FILE`` block of the README and docs shows
    what the command prints (up to a ``...`` line that marks an abridged block)."""
    import re
    from pathlib import Path

    from multiloop.cli import main
    root = Path(__file__).resolve().parents[1]
    seen = 0
    for doc in [root / "README.md", *sorted((root / "docs").glob("*.md"))]:
        for cmd, body in re.findall(r"```\n\$ multiloop ((?:analyse|decompose) \S+)\n(.*?)```", doc.read_text(), re.S):
            command, path = cmd.split()
            if not (root / path).is_file():
                continue        # a user's file, not one of the repository
            assert main([command, str(root / path)]) == 0
            printed = capsys.readouterr().out.splitlines()
            shown = body.splitlines()
            cut = [i for i, line in enumerate(shown) if line.strip() == "..."]
            shown = shown[:cut[0]] if cut else shown
            assert shown == printed[:len(shown)], f"{doc.name}: multiloop {cmd}"
            seen += 1
    assert seen >= 3


def test_a_mechanism_is_decomposed_once_and_an_equal_copy_alike(monkeypatch):
    """decompose keeps the plans of the last mechanisms by identity: the same object gives
    the same plan without a second decomposition; an equal copy is decomposed again, to an
    equal formula."""
    import dataclasses

    from multiloop.inputs import load_mechanism
    from multiloop.topo import assur
    m = load_mechanism("stephenson_3")
    calls = []
    real = assur._decompose
    monkeypatch.setattr(assur, "_decompose", lambda *a: calls.append(1) or real(*a))
    first = assur.decompose(m)
    assert assur.decompose(m) is first and len(calls) <= 1
    copy = dataclasses.replace(m)
    assert copy is not m and assur.decompose(copy).formula == first.formula
    assert assur.decompose(copy, check_rigidity=False).formula == first.formula


@pytest.mark.parametrize("name", ["four_bar", "stephenson_3_triad", "excavator_bucket", "knitting_needle_drive"])
def test_a_moved_point_keeps_the_plan_of_its_structure_with_its_own_mechanism(name):
    """``decompose`` keeps plans by structure too: a design with a joint moved (the web
    page's drag) gets the plan its structure had, bound to itself, and it equals a
    decomposition from scratch; another structure (here a joint renamed) is decomposed
    anew."""
    from dataclasses import replace

    from multiloop.catalogue.named import load_named
    from multiloop.topo.assur import _decompose
    m = load_named(name)
    first = decompose(m)
    j = m.joints[-1]
    moved = replace(m, joints=tuple(replace(x, at=(x.at[0] + 1e-3, x.at[1])) if x is j else x for x in m.joints))
    plan = decompose(moved)
    assert plan.mechanism is moved and plan == _decompose(moved, True)
    assert plan.steps is first.steps                  # reused, not decomposed again
    assert j.name not in {d.joint for d in m.drivers}
    renamed = replace(m, joints=tuple(replace(x, name=x.name + "_") if x is j else x for x in m.joints))
    other = decompose(renamed)          # another structure: decomposed anew
    assert other == _decompose(renamed, True) and other.steps != first.steps
