"""CLI: ``multiloop decompose`` and ``multiloop solve`` (JSON/CSV layout, errors, files)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from multiloop.cli import main
from test_assur import crank_slider, four_bar, knitting_needle, stephenson3_triad
from multiloop.topo.io import dumps_toml


@pytest.fixture
def files(tmp_path):
    out = {}
    for name, make in [("fb", four_bar), ("kn", knitting_needle), ("tri", stephenson3_triad),
                       ("cs", crank_slider)]:
        p = tmp_path / f"{name}.toml"
        p.write_text(dumps_toml(make()))
        out[name] = p
    return out


def test_decompose_json(files, capsys):
    assert main(["decompose", str(files["kn"]), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["formula"] == "I(0,1) → II1(2,3) → II1(4,5) → II1(6,7) → II1(8,9)"
    assert [g["kind"] for g in d["groups"]] == ["RRR"] * 4
    assert all({"class", "order", "kind", "links", "joints"} <= set(g) for g in d["groups"])
    assert d["drivers"][0]["joint"] == "O"


def test_decompose_text_and_triad(files, capsys):
    assert main(["decompose", str(files["tri"])]) == 0
    out = capsys.readouterr().out
    assert "III(2,3,4,5)" in out and "class 3, order 3, kind triad" in out


def test_solve_json_layout_steps_alone_is_one_turn_from_the_reference(files, capsys):
    assert main(["solve", str(files["fb"]), "--steps", "8", "--derivatives", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["input"] == pytest.approx([45.0 * k for k in range(8)])
    assert d["status"] == ["ok"] * 8
    assert set(d["joints"]["B"]) == {"x", "y", "vx", "vy", "ax", "ay"}
    assert set(d["links"]["coupler"]) == {"angle", "omega", "epsilon"}
    assert set(d["points"]["M"]) == {"x", "y", "vx", "vy", "ax", "ay"}
    m = four_bar()
    B = dict(zip(m.joint_names, m.joints))["B"].at
    assert d["joints"]["B"]["x"][0] == pytest.approx(B[0], abs=1e-14)
    assert d["links"]["crank"]["omega"] == pytest.approx([1.0] * 8)


def test_solve_from_to_and_failures_are_null(files, capsys, tmp_path):
    # non-Grashof four-bar: positions beyond the reach limit are null with a status
    p = tmp_path / "ng.toml"
    p.write_text(dumps_toml(four_bar(1.5, 2.0, 2.0, 3.0)))
    assert main(["solve", str(p), "--from", "0", "--to", "90", "--steps", "10", "--json"]) == 0
    cap = capsys.readouterr()
    d = json.loads(cap.out)
    bad = [i for i, s in enumerate(d["status"]) if s != "ok"]
    assert bad and all(d["joints"]["B"]["x"][i] is None for i in bad)
    assert "unreachable: limit at" in d["status"][bad[0]]
    assert "first at input" in cap.err


def test_solve_csv(files, capsys):
    assert main(["solve", str(files["cs"]), "--steps", "4", "--csv"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[0].startswith("input,status,O.x,O.y")
    assert len(lines) == 5 and lines[1].split(",")[1] == "ok"


def test_solve_plot_and_animation(files, capsys, tmp_path):
    png, gif = tmp_path / "m.png", tmp_path / "m.gif"
    assert main(["solve", str(files["tri"]), "--steps", "24", "--plot", str(png), "--animate", str(gif)]) == 0
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert (tmp_path / "m_analogues.png").exists()
    assert gif.read_bytes()[:3] == b"GIF"


def test_nothing_written_on_error(files, capsys, tmp_path):
    png = tmp_path / "x.png"
    assert main(["solve", str(files["fb"]), "--from", "0", "--plot", str(png)]) == 2
    assert "--from/--to" in capsys.readouterr().err and not png.exists()


def test_bad_file_exit_2(tmp_path, capsys):
    p = tmp_path / "nodrv.toml"
    p.write_text(dumps_toml(four_bar().with_drivers([])))
    assert main(["decompose", str(p)]) == 2
    err = capsys.readouterr().err
    assert "expected 1 driver" in err and "Traceback" not in err
    assert main(["solve", str(p)]) == 2


def test_degrees_on_the_cli_radians_in_the_api(files, capsys):
    from multiloop.kin.solve import solve
    assert main(["solve", str(files["fb"]), "--from", "30", "--to", "30", "--steps", "1", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    st = solve(four_bar(), math.radians(30))
    assert np.allclose([d["joints"]["B"]["x"][0], d["joints"]["B"]["y"][0]], st.positions[0, 2], atol=1e-14)


def test_the_commands_offer_the_library_s_methods():
    """Every --method (and --modes) list is the library's own tuple, its first the default:
    the command line types none of them again (the page's synthesis menu imports it too)."""
    import argparse

    from multiloop.catalogue.dimensional import optimise
    from multiloop.cli import build_parser
    from multiloop.kin import forces, solve as solve_mod
    from multiloop.kin.spatial import platform
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    for command, flag, names in [("solve", "--method", solve_mod.METHODS), ("forces", "--method", forces.METHODS),
                                 ("synthesise", "--method", optimise.METHODS),
                                 ("platform", "--modes", platform.NORMALISATIONS)]:
        action = next(a for a in sub.choices[command]._actions if flag in a.option_strings)
        assert action.choices is names and action.default == names[0], command
