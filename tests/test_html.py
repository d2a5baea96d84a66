"""HTML gallery and drawings: structure, planar drawings without crossings, and a real
render in headless Chromium (screenshot kept in the test's tmp dir)."""
from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest

from multiloop.catalogue.atlas import Atlas
from multiloop.kin.figures.chains import _graph, chain_layout, chain_svg, has_crossings
from multiloop.catalogue.html import write_gallery
from multiloop.catalogue.synthesis import SynthesisOptions, iter_chains, nauty_available

needs_nauty = pytest.mark.skipif(not nauty_available(),
                                 reason="nauty's geng/genbg not installed (apt-get install nauty)")


def _chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome", "headless_shell"):
        path = shutil.which(name)
        if path:
            return path
    return None


@needs_nauty
def test_planar_chains_are_drawn_without_crossings():
    for opts in (SynthesisOptions(8, 1), SynthesisOptions(7, 2), SynthesisOptions(8, 1, simple_joints=True)):
        for r in iter_chains(opts, loops=False):
            lay = chain_layout(r.n, r.joints)
            if r.planar:
                pos = dict(enumerate(lay.links))
                pos.update({r.n + a: p for a, p in enumerate(lay.joints)})
                assert not has_crossings(_graph(r.n, r.joints), pos), r.joints
                assert lay.method in ("tutte", "planar")


def test_svg_marks_multiple_joints():
    joints = [(0, 1), (2, 3), (0, 2, 4), (1, 3, 5), (4, 5)]      # two ternary pins
    svg = chain_svg(6, joints)
    assert svg.count('fill="#e15759"') == 2          # one red dot per multiple joint
    assert svg.count('fill="white" stroke="black"') == 3
    assert svg.count("<line") == 6                   # six binary links as bars


@pytest.fixture(scope="module")
def gallery(tmp_path_factory):
    if not nauty_available():
        pytest.skip("nauty's geng/genbg not installed (apt-get install nauty)")
    d = tmp_path_factory.mktemp("gallery")
    with Atlas(d / "g.sqlite") as atlas:
        atlas.build(SynthesisOptions(7, 2), progress=False)
        paths = write_gallery(atlas, d / "html")
    return d, paths


@needs_nauty
def test_gallery_pages(gallery):
    d, paths = gallery
    page = (d / "html" / "atlas_n7_F2.html").read_text()
    assert page.count("<svg") == 9 and page.count('class="card"') == 9
    assert "oninput=\"filt()\"" in page and "[70]/[2]" in page
    assert (d / "html" / "index.html").exists()
    # every card's search text carries its code
    assert len(re.findall(r'data-search="[^"]*\[61\]/1', page)) == 3


@needs_nauty
@pytest.mark.browser
def test_gallery_renders_in_headless_chromium(gallery):
    browser = _chromium()
    if browser is None:
        pytest.skip("chromium not installed (apt-get install -y chromium)")
    from PIL import Image

    d, _ = gallery
    shot = d / "gallery.png"
    page = (d / "html" / "atlas_n7_F2.html").resolve()
    subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                    "--window-size=1000,800", f"--screenshot={shot}", page.as_uri()],
                   capture_output=True, timeout=120, check=False)
    assert shot.exists(), "chromium wrote no screenshot"
    img = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    non_white = (img.sum(axis=2) < 720).mean()
    red = ((img[:, :, 0] > 200) & (img[:, :, 1] < 120) & (img[:, :, 2] < 120)).sum()
    blue = ((img[:, :, 2] > 140) & (img[:, :, 0] < 110)).sum()
    assert non_white > 0.05, f"page looks blank ({non_white:.1%} non-white pixels)"
    assert red > 50, "no multiple joint (red) rendered"
    assert blue > 200, "no link (coloured bar) rendered"
