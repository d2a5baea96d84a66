"""Driver ranges (``[[driver]] range = [low, high]``): reading, solving, checking.

Oracle for the usable range: the single-cylinder boom's reach limits from the law of
cosines (the cylinder side ``L₀ + s`` of the triangle base–end–foot lies between
``| |AC| − l |`` and ``|AC| + l``), against which the check's "which end binds" is read.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from multiloop.cli import main
from multiloop.kin.check import check
from multiloop.kin.result import Status
from multiloop.kin.solve import solve
from multiloop.kin.sweep import cycle_inputs, input_range, si_inputs
from multiloop.topo.errors import InputError
from multiloop.topo.io import dumps_json, dumps_toml, load, loads
from multiloop.topo.model import MechanismBuilder

BOOM = """\
name = "boom"
[[link]]
name = "frame"
frame = true
[[link]]
name = "boom"
[[link]]
name = "barrel"
[[link]]
name = "rod"
[[joint]]
name = "foot"
links = ["frame", "boom"]
at = [0, 0]
[[joint]]
name = "base"
links = ["frame", "barrel"]
at = [1, 0]
[[joint]]
name = "slide"
kind = "P"
links = ["barrel", "rod"]
at = [1, 0.5]
axis = [0, 1]
[[joint]]
name = "end"
links = ["rod", "boom"]
at = [1, 1]
[[driver]]
joint = "slide"
RANGE
"""
# |AC| = 1 (base to foot), lever l = √2 (foot to end), L0 = 1: the cylinder reaches
# L ∈ [√2 − 1, √2 + 1], i.e. s ∈ [√2 − 2, √2]
S_LO, S_HI = math.sqrt(2.0) - 2.0, math.sqrt(2.0)


def boom_file(tmp_path, rng="range = [-0.3, 0.4]", name="boom.toml"):
    f = tmp_path / name
    f.write_text(BOOM.replace("RANGE", rng))
    return f


def test_range_read_in_file_units_and_written_back(tmp_path):
    m = load(boom_file(tmp_path))
    assert m.drivers[0].range == (-0.3, 0.4)
    again = loads(dumps_toml(m), "toml")
    assert again.drivers[0].range == (-0.3, 0.4)


def test_rotary_range_in_degrees():
    b = MechanismBuilder()
    b.add_link("ground", frame=True)
    for n, lk, at in [("O", ("ground", "crank"), (0, 0)), ("A", ("crank", "rod"), (1, 0)),
                      ("B", ("rod", "rocker"), (3, 2)), ("C", ("rocker", "ground"), (4, 0))]:
        b.add_joint(n, "R", lk, at=at)
    b.add_driver("O", range=(math.radians(-30), math.radians(60)))
    m = b.build()
    text = dumps_toml(m)
    assert "range = [-30.0" in text or "range = [-29.99999" in text
    assert np.allclose(loads(text, "toml").drivers[0].range, (math.radians(-30), math.radians(60)))
    x = input_range(m, 4)
    assert np.allclose(x, [-30, 0, 30, 60])      # the default sweep is the range, in degrees
    assert np.allclose(cycle_inputs(m, steps=4)[:, 0], np.radians([-30, 0, 30, 60]))   # forces too
    assert np.allclose(loads(dumps_json(m), "json").drivers[0].range, m.drivers[0].range)
    st = solve(m, np.radians([-30.0, 60.0, 61.0]))
    assert st.ok.tolist() == [True, True, False]
    assert st.status[2] == "out of range: angular range of O is [-30, 60] deg"


@pytest.mark.parametrize("x, ok", [(-0.3, True), (0.4, True), (0.1, True), (0.0, True),
                                   (-0.3 - 1e-9, False), (0.4 + 1e-9, False), (0.7, False)])
def test_solve_marks_inputs_outside_the_range(tmp_path, x, ok):
    m = load(boom_file(tmp_path))
    st = solve(m, np.array([0.0, x]))
    assert bool(st.ok[1]) is ok
    if not ok:
        assert st.status[1] == "out of range: stroke of slide is [-0.3, 0.4] m"
        assert st.codes[1] == Status.OUT_OF_RANGE
        assert np.isnan(st.positions[1, m.joint_names.index("end")]).all()   # the frame pins stay


def test_batch_is_marked_not_aborted(tmp_path):
    m = load(boom_file(tmp_path))
    st = solve(m, np.linspace(-0.5, 0.6, 12))
    inside = (np.linspace(-0.5, 0.6, 12) >= -0.3 - 1e-12) & (np.linspace(-0.5, 0.6, 12) <= 0.4 + 1e-12)
    assert st.ok.tolist() == inside.tolist()


def test_default_sweep_is_the_range(tmp_path):
    m = load(boom_file(tmp_path))
    x = input_range(m, 8)
    assert x[0] == -0.3 and x[-1] == 0.4 and x.size == 8
    assert solve(m, si_inputs(m, x)).ok.all()


@pytest.mark.parametrize("rng, binds, usable", [
    ("range = [-0.3, 0.4]", ("range", "range"), (-0.3, 0.4)),
    ("range = [-0.9, 0.4]", ("assembly", "range"), (S_LO, 0.4)),
    ("range = [-0.3, 1.5]", ("range", "assembly"), (-0.3, S_HI)),
    ("range = [0, 0.5]", ("range", "range"), (0.0, 0.5)),
])
def test_check_usable_range_and_what_binds(tmp_path, rng, binds, usable):
    dc = check(load(boom_file(tmp_path, rng))).drivers[0]
    assert (dc.bound_at("low"), dc.bound_at("high")) == binds
    assert np.allclose(dc.usable, usable, atol=1e-9)
    d = dc.as_dict()
    assert d["binds"] == {"low": binds[0], "high": binds[1]}
    assert np.allclose(d["usable_range"], usable, atol=1e-9)


def test_check_flags_an_assembly_limit_inside_the_range(tmp_path):
    rep = check(load(boom_file(tmp_path, "range = [-0.3, 1.5]")))
    assert any("assembly limits cut its range [-0.3, 1.5] m at the high end" in v for v in rep.verdict)
    rep = check(load(boom_file(tmp_path, "range = [-0.3, 0.4]")))
    assert not any("range" in v or "stroke" in v for v in rep.verdict)


@pytest.mark.parametrize("rng, words", [
    ("range = [0.4, -0.3]", "expected low < high"),
    ("range = [nan, 0.3]", "expected a finite number"),
    ("range = [0.1, 0.3]", "contains the reference"),
    ("range = [-0.4, -0.1]", "contains the reference"),
    ("range = [-0.3]", "expected [low, high]"),
    ("range = 'long'", "expected [low, high]"),
])
def test_malformed_range_exit_2(tmp_path, capsys, rng, words):
    f = boom_file(tmp_path, rng)
    assert main(["solve", str(f)]) == 2
    err = capsys.readouterr().err
    assert words in err and "range" in err and "Traceback" not in err


def test_range_on_a_joint_that_is_not_a_driver_exit_2(tmp_path, capsys):
    f = tmp_path / "j.toml"
    f.write_text(BOOM.replace("RANGE", "").replace('at = [1, 1]\n', 'at = [1, 1]\nrange = [0, 1]\n'))
    assert main(["check", str(f)]) == 2
    err = capsys.readouterr().err
    assert "[[joint]] #4 ('end') range" in err and "not a driver" in err and "hint" in err


def test_builder_rejects_bad_range():
    b = MechanismBuilder()
    b.add_link("ground", frame=True)
    b.add_joint("O", "R", ("ground", "crank"), at=(0, 0))
    b.add_joint("A", "R", ("crank", "rod"), at=(1, 0))
    b.add_joint("B", "R", ("rod", "rocker"), at=(3, 2))
    b.add_joint("C", "R", ("rocker", "ground"), at=(4, 0))
    b.add_driver("O", range=(0.5, 1.0))
    with pytest.raises(InputError, match=r"contains the reference.*got \[28.6479, 57.2958\]"):
        b.build()


def _lifted_boom(factor: float, rng):
    """A boom pinned at the origin, lifted by one cylinder from (1.5, -0.5) to (2, 1),
    every length times ``factor``."""
    b = MechanismBuilder()
    b.add_link("frame", frame=True)
    for x in ("boom", "barrel", "rod"):
        b.add_link(x)
    A, B = np.array([1.5, -0.5]) * factor, np.array([2.0, 1.0]) * factor
    b.add_joint("foot", "R", ("frame", "boom"), at=(0.0, 0.0))
    b.add_joint("base", "R", ("frame", "barrel"), at=tuple(A))
    b.add_joint("slide", "P", ("barrel", "rod"), at=tuple((A + B) / 2), axis=tuple((B - A) / np.hypot(*(B - A))))
    b.add_joint("end", "R", ("rod", "boom"), at=tuple(B))
    b.add_driver("slide", range=rng)
    return b.build()


@pytest.mark.parametrize("factor", [0.7, 1.0, 1.7, 3.0, 5.0, 11.0])
@pytest.mark.parametrize("rng", [(-0.25, 0.45), (-0.3, 0.4), (-0.1, 0.7)])
def test_every_position_at_a_closed_stroke_range_end_solves(factor, rng):
    """A cylinder's range ends are part of its motion: both solve (alone, together, and
    as the default sweep's first and last rows), whatever the mechanism's size (the walk
    from the reference runs in units of the size; ``x / size * size`` may fall an ulp
    short of ``x``, which made the end an "other circuit")."""
    m = _lifted_boom(factor, rng)
    lo, hi = rng
    for X in ([hi], [lo], [lo, hi], [hi, lo]):
        st = solve(m, np.array(X))
        assert st.ok.all(), (X, list(st.status))
    x = input_range(m, 36)
    assert x[0] == lo and x[-1] == hi
    assert solve(m, si_inputs(m, x)).ok.all()
    assert check(m).drivers[0].usable == (lo, hi)


def test_whether_a_driver_turns_is_asked_of_the_mechanism():
    """``Mechanism.is_rotary`` is the one test of an R (turning) or P (sliding) driver, by
    index or by driver, and ``JointKind.is_rotary`` the one test of a kind; no library
    module reads a driver's joint kind itself."""
    import pathlib
    import re

    from multiloop.topo.model import JointKind
    m = loads(BOOM.replace("RANGE", ""), "toml")
    assert [m.is_rotary(k) for k in range(len(m.drivers))] == [m.is_rotary(d) for d in m.drivers] == [False]
    b = MechanismBuilder()
    b.add_link("ground", frame=True)
    for n, lk, at in [("O", ("ground", "crank"), (0, 0)), ("A", ("crank", "rod"), (1, 0)),
                      ("B", ("rod", "rocker"), (3, 2)), ("C", ("rocker", "ground"), (4, 0))]:
        b.add_joint(n, "R", lk, at=at)
    b.add_driver("O")
    assert b.build().is_rotary(0)
    assert JointKind.R.is_rotary and not JointKind.P.is_rotary and JointKind("R").is_rotary
    root = pathlib.Path(__file__).resolve().parents[1]
    hand = re.compile(r"joint\(([\w.]*drivers\[[^\]]+\]|d|drv|driver)\.joint\)\.kind (is|==)|_driver_is_rotary"
                      r"|is JointKind\.R\)?$|JointKind\(kind\) is")
    found = [f"{p.relative_to(root)}:{i}" for pkg in ("topo", "kin", "catalogue", "multiloop")
             for p in sorted((root / pkg).rglob("*.py"))
             for i, line in enumerate(p.read_text().splitlines(), 1) if hand.search(line)]
    assert [f.split(":")[0] for f in found] == ["topo/model.py"]      # JointKind.is_rotary itself
