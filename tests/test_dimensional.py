"""Dimensional synthesis (multiloop.catalogue.dimensional) and ``multiloop synthesise``."""
from __future__ import annotations

import numpy as np
import pytest

from multiloop.catalogue.dimensional import Evaluator, design_space
from multiloop.catalogue.named import load_named
from multiloop.kin.solve import solve


@pytest.mark.parametrize("name", ["four_bar", "watt_1", "stephenson_1", "crank_slider", "dyad_rpr",
                                  "knitting_needle_drive", "stephenson_3_triad"])
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
from multiloop.topo.model import TracerPoint  # noqa: E402


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
    res = synthesise(start, path=target, point=pt, budget=1.5, seed=0)
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
    rc = main(["synthesise", str(named_path("four_bar")), "--path", str(tgt), "--point", "P",
               "--out", str(out), "--budget", "1", "--json"])
    assert rc == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["error_max"] < 1e-3 and doc["evaluations"] > 0
    m = load(out)
    assert "target.csv" in m.source
    assert main(["analyse", str(out)]) == 0
    assert main(["solve", str(out), "--steps", "8"]) == 0


@pytest.mark.parametrize("case", ["few", "nan", "point", "budget", "unassembled", "output", "link"])
def test_cli_bad_input_exit_2(tmp_path, capsys, case):
    start = str(named_path("four_bar"))
    out = tmp_path / "out.toml"
    tgt = _four_bar_path(tmp_path)
    args = ["synthesise", start, "--path", str(tgt), "--point", "P", "--out", str(out), "--budget", "1"]
    if case == "few":
        args[3] = str(_four_bar_path(tmp_path, rows=[[0.0, 0.0], [0.01, 0.02]]))
    elif case == "nan":
        args[3] = str(_four_bar_path(tmp_path, rows=[[0.0, 0.0], [0.01, float("nan")], [0.02, 0.0]]))
    elif case == "point":
        args[5] = "nowhere"
    elif case == "budget":
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
