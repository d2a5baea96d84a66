"""Figures: CAD drawings (SVG/DXF layers), closed full-turn paths, readable plots."""
from __future__ import annotations

import collections
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from multiloop.cli import main
from multiloop.kin.figures.cad import LAYERS, mechanism_dxf, mechanism_svg
from multiloop.kin.figures.geometry import is_full_turn, path_pieces
from multiloop.kin.solve import solve
from multiloop.topo.io import load
from multiloop.topo.model import JointKind
from test_assur import crank_slider

ROOT = Path(__file__).resolve().parents[1]
FOUR_BAR = ROOT / "catalogue" / "mechanisms" / "four_bar.toml"
SVG = "{http://www.w3.org/2000/svg}"


def _turn(m, n=36):
    return solve(m, 2 * np.pi * np.arange(n) / n)


def _expected(m):
    """Entity counts per layer read from the mechanism's own structure."""
    moving = [lk for lk in m.link_names if lk != m.frame]
    r_joints = [j for j in m.joints if j.kind is JointKind.R]
    p_joints = [j for j in m.joints if j.kind is JointKind.P]
    pivots = [j for j in r_joints if m.frame in j.links]
    return {"LINKS": len(moving), "PINS": len(r_joints) + len(p_joints),
            "FRAME": len(pivots) + len(p_joints), "PATHS": len(m.points),
            "LABELS": len(m.joints) + len(m.points)}


@pytest.mark.parametrize("make", [lambda: load(FOUR_BAR), crank_slider])
def test_dxf_reopens_with_layers_and_counts(tmp_path, make):
    ezdxf = pytest.importorskip("ezdxf")
    m = make()
    state = _turn(m)
    path = tmp_path / "m.dxf"
    path.write_bytes(mechanism_dxf(state))
    doc = ezdxf.readfile(path)
    assert set(LAYERS) <= {layer.dxf.name for layer in doc.layers}
    counts = collections.Counter(e.dxf.layer for e in doc.modelspace())
    assert dict(counts) == {k: v for k, v in _expected(m).items() if v}
    assert doc.header["$INSUNITS"] == 4          # millimetres
    paths = [e for e in doc.modelspace() if e.dxf.layer == "PATHS"]
    assert all(e.dxftype() == "LWPOLYLINE" and e.closed and len(e) == 36 for e in paths)
    circles = [e for e in doc.modelspace() if e.dxftype() == "CIRCLE"]
    for c in circles:               # centres are the joint positions at the first input, in mm
        j = next(k for k, jt in enumerate(m.joints) if np.allclose(
            1000 * state.positions[0, k], (c.dxf.center.x, c.dxf.center.y)))
        assert m.joints[j].kind is JointKind.R


def test_svg_parses_with_one_group_per_layer():
    m = load(FOUR_BAR)
    root = ET.fromstring(mechanism_svg(_turn(m)))
    groups = {g.get("id"): g for g in root.findall(f"{SVG}g")}
    assert list(groups) == list(LAYERS)
    exp = _expected(m)
    for layer, g in groups.items():
        assert len(list(g)) == exp[layer], layer
    names = {e.get("data-name") for e in groups["LINKS"]}
    assert names == {"crank", "coupler", "rocker"}
    assert [t.text for t in groups["LABELS"]] == ["O2", "A", "B", "O4", "P"]


def test_svg_escapes_names(tmp_path):
    text = FOUR_BAR.read_text().replace('name = "four_bar"', 'name = "a<b & $c$"', 1)
    src = tmp_path / "m.toml"
    src.write_text(text)
    root = ET.fromstring(mechanism_svg(_turn(load(src))))
    assert root.find(f"{SVG}title").text == "a<b & $c$"


def test_cli_svg_and_dxf(tmp_path):
    svg, dxf = tmp_path / "m.svg", tmp_path / "m.dxf"
    assert main(["solve", str(FOUR_BAR), "--steps", "12", "--svg", str(svg), "--dxf", str(dxf)]) == 0
    ET.parse(svg)
    assert dxf.read_bytes().lstrip().startswith(b"0")
    assert main(["solve", str(FOUR_BAR), "--svg", str(tmp_path / "m.png")]) == 2


def test_full_turn_is_detected_and_closed():
    m = load(FOUR_BAR)
    assert is_full_turn(_turn(m))
    assert not is_full_turn(solve(m, np.radians(np.linspace(0, 90, 10))))
    assert not is_full_turn(solve(m, np.radians(np.linspace(0, 360, 10))))   # 0 and 360 both given
    p = np.array([[0.0, 0], [1, 0], [1, 1]])
    assert np.array_equal(path_pieces(p, True)[0][-1], p[0])
    q = np.array([[0.0, 0], [1, 0], [np.nan, 0], [2, 2], [3, 3], [4, 4]])
    assert [len(x) for x in path_pieces(q, True)] == [2, 3]


# ------------------------------------------------------------------ plot readability
def _label_boxes(fig):
    from matplotlib.text import Text

    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    ax = fig.axes[0]
    return ax, [Text.get_window_extent(t, r) for t in ax.texts]     # the text, not its leader line


@pytest.mark.parametrize("name", ["four_bar", "linkage_24", "excavator", "stephenson_3_triad"])
def test_joint_labels_overlap_neither_each_other_nor_markers(name):
    import matplotlib.pyplot as plt

    from multiloop.kin.figures.mechanism import _markers, plot_mechanism
    m = load(ROOT / "catalogue" / "mechanisms" / f"{name}.toml")
    state = solve(m, np.zeros((12, len(m.drivers))) if len(m.drivers) > 1 else np.radians(np.arange(12) * 30.0))
    fig = plot_mechanism(state)
    ax, boxes = _label_boxes(fig)
    marks = _markers(state, 0)
    assert len(boxes) == len(marks) > 0
    for i, a in enumerate(boxes):
        for b in boxes[i + 1:]:
            assert not a.overlaps(b), (ax.texts[i].get_text(), a, b)
    px = fig.dpi / 72.0
    for (mname, p, _, size, _, _) in marks:
        c = ax.transData.transform(p)
        half = 0.5 * size * px
        for t, box in zip(ax.texts, boxes):
            inside = box.x0 < c[0] + half and c[0] - half < box.x1 and box.y0 < c[1] + half and c[1] - half < box.y1
            assert not inside, (t.get_text(), "covers the marker of", mname)
    plt.close(fig)


def test_full_turn_paths_are_closed_in_the_plot():
    import matplotlib.pyplot as plt

    from multiloop.kin.figures.mechanism import plot_mechanism
    fig = plot_mechanism(_turn(load(FOUR_BAR)))
    paths = [ln for ln in fig.axes[0].lines if ln.get_linestyle() == "--"]
    assert paths
    for ln in paths:
        xy = ln.get_xydata()
        assert len(xy) == 37 and np.array_equal(xy[0], xy[-1])
    plt.close(fig)


def test_one_colour_per_cylinder_in_every_engine_panel():
    import matplotlib.pyplot as plt

    from multiloop.kin.engine import analyse_engine, load_engine
    from multiloop.kin.figures.engine import engine_figures
    spec = load_engine(ROOT / "catalogue" / "engines" / "v_twin.toml")
    figs = engine_figures(analyse_engine(spec, 72, check=False))
    names = [c.name for c in spec.cylinders]
    colours: dict[str, set] = {nm: set() for nm in names}
    for fig in figs.values():
        for ax in fig.axes:
            for ln in ax.lines:
                for nm in names:
                    if ln.get_label().endswith(f" {nm}") or f" {nm} " in ln.get_label():
                        colours[nm].add(ln.get_color())
        plt.close(fig)
    assert all(len(c) == 1 for c in colours.values()), colours
    assert len(set.union(*colours.values())) == len(names)


def test_force_plot_axes_state_units():
    import matplotlib.pyplot as plt

    from multiloop.kin.figures.engine import plot_forces
    from multiloop.kin.forces import forces
    m = load(ROOT / "catalogue" / "mechanisms" / "crank_slider_loaded.toml")
    q = np.radians(np.arange(0, 360, 30.0))
    fig = plot_forces(forces(m, q), np.degrees(q))
    labels = [ax.get_xlabel() for ax in fig.axes] + [ax.get_ylabel() for ax in fig.axes]
    assert "balancing moment (N m)" in labels and any(lb.endswith("(deg)") for lb in labels)
    assert not any(" or " in lb for lb in labels)
    plt.close(fig)


@pytest.mark.parametrize("suffix", [".mp4", ".png", ".webp", ""])
def test_animate_refuses_other_formats(tmp_path, capsys, suffix):
    assert main(["solve", str(FOUR_BAR), "--steps", "6", "--animate", str(tmp_path / f"a{suffix}")]) == 2
    assert ".gif" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []
