"""Synthesis without a start and without ``--db``: the default curve atlas is built on
first use into the user cache (``$MULTILOOP_CACHE`` here, a fresh folder), and the
second run builds nothing.  The default's parts are replaced by a small one (the four-bar
inversions, 6 realisations each) so that the test builds in seconds; the real parts are
checked to be those the documentation recommends."""
from __future__ import annotations

import json

import numpy as np
import pytest

import multiloop.catalogue.atlas_build as atlas_build
import multiloop.catalogue.default_atlas as default_atlas
from multiloop.catalogue.synthesis import SynthesisOptions, nauty_available
from multiloop.cli import main

pytestmark = pytest.mark.skipif(not nauty_available(), reason="nauty's geng/genbg not installed")


@pytest.fixture
def small_default(tmp_path, monkeypatch):
    monkeypatch.setenv("MULTILOOP_CACHE", str(tmp_path / "fresh-cache"))
    monkeypatch.setattr(default_atlas, "DEFAULT_PARTS", ((SynthesisOptions(4, 1, simple_joints=True), 6),))
    return tmp_path


def _ellipse(n: int = 24) -> np.ndarray:
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.column_stack([0.05 + 0.03 * np.cos(t), 0.08 + 0.012 * np.sin(t)])


def test_first_use_builds_the_default_atlas_and_the_second_run_builds_nothing(small_default, capsys, monkeypatch):
    target = small_default / "t.csv"
    np.savetxt(target, _ellipse(), delimiter=",")
    args = ["synthesise", "--path", str(target), "--links", "4", "--top", "1", "--evaluations", "2000", "--json"]
    assert main(args + ["--out", str(small_default / "a.toml")]) == 0
    out, err = capsys.readouterr()
    assert "building the default curve atlas once" in err and (small_default / "a.toml").is_file()
    path = default_atlas.default_atlas_path()
    assert path.is_file() and path.parent == small_default / "fresh-cache"
    assert not list(path.parent.glob("*.partial.sqlite*"))           # renamed once whole
    first = json.loads(out)

    def no_build(*a, **k):
        raise AssertionError("the second run built the atlas again")
    monkeypatch.setattr(atlas_build, "build_atlas", no_build)
    assert main(args + ["--out", str(small_default / "b.toml")]) == 0
    out, err = capsys.readouterr()
    assert "building" not in err
    assert (small_default / "a.toml").read_text().replace("a.toml", "") == \
        (small_default / "b.toml").read_text().replace("b.toml", "")          # same seed, same design
    assert json.loads(out)[0]["error_rms"] == first[0]["error_rms"]


def test_bad_options_are_refused_before_a_build(small_default, capsys, monkeypatch):
    def no_build(*a, **k):
        raise AssertionError("built before checking the options")
    monkeypatch.setattr(atlas_build, "build_atlas", no_build)
    target = small_default / "t.csv"
    np.savetxt(target, _ellipse(), delimiter=",")
    for bad in (["--tol", "nan"], ["--top", "0"], ["--links", "5"]):
        assert main(["synthesise", "--path", str(target), "--out", str(small_default / "x.toml"), *bad]) == 2
    assert main(["synthesise", "--path", str(small_default / "missing.csv"), "--out", str(small_default / "x.toml")]) == 2
    assert not default_atlas.default_atlas_path().exists()


def test_the_default_parts_are_the_documented_first_atlas():
    """docs/synthesis.md recommends 4 links with 64 realisations, 6 links (multiple joints
    too) with 24, 8 simple-joint links with 4 and the other 8-link ones (multiple joints)
    with 2."""
    assert [(o.n, o.F, o.simple_joints, k) for o, k in default_atlas.DEFAULT_PARTS] == \
        [(4, 1, False, 64), (6, 1, False, 24), (8, 1, True, 4), (8, 1, False, 2)]
