"""The port of LInK's chamfer metric in ``benchmarks/bench_link_abc.py``: the strided
shift sums equal the index-array form of LInK's ``batch_ordered_distance``, the
resampling is LInK's, the dyadic solver keeps its link lengths, and the metric scores
a curve against itself near zero in both branches (the data, LInK's letters, are not
shipped: these tests use curves of their own)."""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest


@pytest.fixture(scope="module")
def B():
    f = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_link_abc.py"
    spec = importlib.util.spec_from_file_location("bench_link_abc", f)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


def _ordered_reference(c1, c2):
    """LInK's ``batch_ordered_distance`` with its index arrays (``row_inds``,
    ``col_inds``, ``col_inds[:, ::-1]``), in NumPy."""
    n = c2.shape[1]
    r = np.arange(n)
    row_inds = r[r[:, None] - np.zeros_like(r)].T
    col_inds = r[r[:, None] - r].T
    col_ccw = col_inds[:, ::-1]
    out = []
    for a, b in zip(c1, c2):
        C = np.linalg.norm(b[:, None] - a[None], axis=-1)
        ds = []
        for cols in (col_inds, col_ccw):
            k = int(np.argmin(C[row_inds, cols].sum(1)))
            ds.append(np.mean(np.linalg.norm(b - a[cols[k]], axis=-1) ** 2))
        out.append(min(ds))
    return np.array(out)


def test_ordered_distance_equals_the_index_form(B):
    rng = np.random.default_rng(3)
    for n in (5, 40, 161):
        c1 = rng.normal(size=(4, n, 2))
        c2 = rng.normal(size=(4, n, 2))
        c2[0] = np.roll(c1[0], 7, axis=0) + 0.01                # a shifted copy
        c2[1] = np.roll(c1[1][::-1], 3, axis=0) - 0.02          # shifted and reversed
        assert np.allclose(B.batch_ordered_distance(c1, c2), _ordered_reference(c1, c2), rtol=1e-5, atol=1e-7)
    assert B.batch_ordered_distance(c1[:1], c1[:1])[0] < 1e-10


def test_uniformize_is_arc_length_resampling(B):
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]], float)
    u = B.uniformize(square[None], 9)[0]
    assert np.allclose(u[0], [0, 0])
    steps = np.linalg.norm(np.diff(u, axis=0), axis=1)
    assert np.allclose(steps[1:-1], 0.5, atol=1e-5)          # 4 / 8 per step (LInK's 1e-6 offset aside)


def test_link_solver_keeps_link_lengths(B):
    # LInK's format: joint 0 frame (motor pivot), 1 crank, 2 frame, 3 coupler joint, 4 tracer
    A = np.zeros((5, 5))
    for i, j in ((0, 1), (1, 3), (2, 3), (1, 4), (3, 4)):
        A[i, j] = A[j, i] = 1
    x = np.array([[0, 0], [0.3, 0.0], [1.2, 0.0], [0.9, 0.8], [0.5, 1.1]])
    nt = np.array([1, 0, 1, 0, 0])
    P = B.link_solve(A, x, nt, np.linspace(0, 2 * np.pi, 50))
    for i, j in ((1, 3), (2, 3), (1, 4), (3, 4)):
        d = np.linalg.norm(P[i] - P[j], axis=-1)
        assert np.allclose(d, np.linalg.norm(x[i] - x[j]))
    # the crank is at the absolute angle: at theta = 0 joint 1 is on the +x axis
    assert np.allclose(P[1][0], [0.3, 0.0])


def test_metric_of_a_curve_against_itself(B):
    t = np.linspace(0, 2 * np.pi, 200)
    egg = np.stack([np.cos(t) + 0.2 * np.cos(2 * t), 0.6 * np.sin(t)], 1)
    assert B.is_link_closed(egg)
    assert B.link_cd(egg, egg, True) < 0.01
    stroke = egg[:120]
    assert not B.is_link_closed(stroke)
    assert B.link_cd(stroke, stroke, False) < 0.01
    # a stroke half the length scores far worse
    assert B.link_cd(stroke, stroke[:60], False) > 0.1


def test_report_writes_both_charts_and_the_merged_rows(B, tmp_path):
    """--report merges the rows of two runs (letters sorted), writes --json, the per-letter
    chart and the chart of error against links and time beside it (both PNG)."""
    import json

    def row(ch, cd, s):
        return {"letter": ch, "mode": "closed", "seconds": s, "cpu_seconds": s, "link_cd": 0.02, "link_joints": 19,
                "cd": cd, "links": 8, "structure": "x",
                "designs": [{"links": 8, "cd": cd}, {"links": 6, "cd": 2 * cd}]}
    for name, rows in (("a", [row("B", 0.03, 40.0)]), ("b", [row("A", 0.01, 20.0)])):
        (tmp_path / f"{name}.json").write_text(json.dumps({"evaluations": 1, "seed": 0, "rows": rows}))
    out = tmp_path / "m.json"
    assert B.main(["--report", str(tmp_path / "b.json"), str(tmp_path / "a.json"), "--json", str(out),
                   "--chart", str(tmp_path / "c.png")]) == 0
    assert [r["letter"] for r in json.loads(out.read_text())["rows"]] == ["A", "B"]
    for f in ("c.png", "c_links_time.png"):
        assert (tmp_path / f).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
