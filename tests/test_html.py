"""HTML gallery and drawings: structure, planar drawings without crossings, and a real
render in headless Chromium (screenshot kept in the test's tmp dir)."""
from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest

from multiloop.catalogue.atlas import Atlas
from multiloop.cli import main
from multiloop.kin.figures.chains import chain_svg
from multiloop.kin.figures.layout import chain_layout, crossing_pairs, spread
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
def test_planar_chains_are_drawn_without_crossings_and_spread_out():
    """Every n = 8, F = 1 chain (all 60 are planar) and the n = 7, F = 2 ones: no two
    drawn link sides cross or touch, joints stay apart (no corner collapse), and
    polygon links are not slivers (4π·area/perimeter² of an equilateral triangle is 0.60)."""
    seen = 0
    for opts in (SynthesisOptions(8, 1), SynthesisOptions(7, 2)):
        for r in iter_chains(opts, loops=False):
            lay = chain_layout(r.n, r.joints)
            if not r.planar:
                continue
            seen += 1
            assert crossing_pairs(lay) == [], r.joints
            s = spread(lay)
            assert s["joint_gap"] > 0.05 and s["edge_gap"] > 0.012 and s["roundness"] > 0.08, (r.joints, s)
            assert lay.method in ("tutte", "planar")
    assert seen == 60 + 9


def test_reported_cases_no_longer_cross_or_collapse():
    """n = 8 chains #1, #3 (crossed) and #15, #16, #60 (collapsed) of the gallery."""
    cases = [((0, 4), (1, 4), (0, 5), (2, 5), (2, 6), (3, 6), (4, 6), (1, 7), (3, 7), (5, 7)),
             ((0, 3), (1, 4), (0, 5), (2, 5), (1, 6), (2, 6), (3, 6), (2, 7), (3, 7), (4, 7)),
             ((0, 4), (1, 5), (0, 6), (1, 6), (2, 6), (3, 6), (2, 7), (3, 7), (4, 7), (5, 7)),
             ((0, 3), (1, 4), (2, 5), (0, 6), (1, 6), (2, 6), (3, 7), (4, 7), (5, 7), (6, 7)),
             ((0, 1), (2, 3), (4, 5), (0, 2, 4, 6), (1, 3, 5, 7), (6, 7))]
    for joints in cases:
        lay = chain_layout(8, joints)
        assert crossing_pairs(lay) == []
        assert spread(lay)["joint_gap"] > 0.05
        P = np.array(lay.joints)
        assert np.ptp(P, axis=0).min() > 0.5          # fills the square, not a corner


@pytest.mark.parametrize("flag", ["--html-limit", "--workers"])
@pytest.mark.parametrize("value", ["0", "-3"])
def test_non_positive_limits_rejected(tmp_path, capsys, flag, value):
    argv = ["atlas", "--links", "4", "--db", str(tmp_path / "a.sqlite"), flag, value]
    assert main(argv) == 2
    assert flag in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


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
        atlas.build(SynthesisOptions(8, 1), progress=False)
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
    # [LA] and [La] are distinct words of the search text
    assert re.search(r'data-search="[^"]*\[LA\]=\[[0-9,]+\][^"]*\[La\]=', page)


# Runs in the page: every drawn link side in screen pixels (getScreenCTM), every pair
# of sides of different links that cross away from a shared joint, and the search box
# driven with a case-sensitive [La] word.
_PROBE = """<script>
window.addEventListener('load', function(){
  function pt(svg, x, y){ var p=svg.createSVGPoint(); p.x=x; p.y=y; return p.matrixTransform(svg.getScreenCTM()); }
  function orient(a,b,c){ return (b.x-a.x)*(c.y-a.y)-(b.y-a.y)*(c.x-a.x); }
  function same(a,b){ return Math.abs(a.x-b.x)<0.5 && Math.abs(a.y-b.y)<0.5; }
  var out={drawings:0, segments:0, crossings:[]};
  document.querySelectorAll('svg.chain').forEach(function(svg, k){
    var segs=[];
    svg.querySelectorAll('.link').forEach(function(el){
      var id=el.getAttribute('data-link');
      if(el.tagName==='line'){
        segs.push([id, pt(svg, el.x1.baseVal.value, el.y1.baseVal.value), pt(svg, el.x2.baseVal.value, el.y2.baseVal.value)]);
      } else {
        var P=el.points, m=P.numberOfItems;
        for(var i=0;i<m;i++){ var a=P.getItem(i), b=P.getItem((i+1)%m);
          segs.push([id, pt(svg,a.x,a.y), pt(svg,b.x,b.y)]); }
      }
    });
    out.drawings++; out.segments+=segs.length;
    for(var i=0;i<segs.length;i++) for(var j=i+1;j<segs.length;j++){
      var s=segs[i], t=segs[j];
      if(s[0]===t[0] || same(s[1],t[1])||same(s[1],t[2])||same(s[2],t[1])||same(s[2],t[2])) continue;
      var d1=orient(t[1],t[2],s[1]), d2=orient(t[1],t[2],s[2]), d3=orient(s[1],s[2],t[1]), d4=orient(s[1],s[2],t[2]);
      if(d1*d2<0 && d3*d4<0) out.crossings.push([k, s[0], t[0]]);
    }
  });
  var q=document.getElementById('q'); q.value=QUERY; filt();
  out.shown=parseInt(document.getElementById('shown').textContent);
  var pre=document.createElement('pre'); pre.id='probe'; pre.textContent=JSON.stringify(out);
  document.body.appendChild(pre);
});
</script>"""


@needs_nauty
@pytest.mark.browser
def test_gallery_in_headless_chromium_has_no_crossing_links(gallery):
    """The n = 8, F = 1 page as Chromium renders it: a screenshot with drawn links, and
    in-page geometry of every drawing's link sides with no crossings; the search
    box tells [La] from [LA]."""
    browser = _chromium()
    if browser is None:
        pytest.skip("chromium not installed (install.sh installs it; apt-get install -y chromium)")
    import json

    from PIL import Image

    d, _ = gallery
    page = (d / "html" / "atlas_n8_F1.html").read_text()
    searches = re.findall(r'data-search="([^"]*)"', page)
    la = re.search(r"\[La\]=(\S+)", searches[0]).group(1)
    word = f"[La]={la}"
    expected = sum(word in t for t in searches)          # the page's rule: substring, case kept
    probe = d / "html" / "probe.html"
    control = ('<svg xmlns="http://www.w3.org/2000/svg" class="chain" width="50" height="50">'
               '<line class="link" data-link="0" x1="0" y1="0" x2="50" y2="50"/>'
               '<line class="link" data-link="1" x1="0" y1="50" x2="50" y2="0"/></svg>')
    probe.write_text(page.replace("</body>", control + _PROBE.replace("QUERY", json.dumps(word)) + "</body>"))
    run = [browser, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
           "--window-size=1200,900"]
    dom = subprocess.run(run + ["--virtual-time-budget=10000", "--dump-dom", probe.as_uri()],
                         capture_output=True, text=True, timeout=180, check=False).stdout
    found = re.search(r'<pre id="probe">(.*?)</pre>', dom)
    assert found, "the in-page probe did not run"
    out = json.loads(_html_unescape(found.group(1)))
    assert out["drawings"] == 61 and out["segments"] > 60 * 8
    assert out["crossings"] == [[60, "0", "1"]]      # only the crossed control drawing
    assert out["shown"] == expected < 60
    shot = d / "gallery.png"
    subprocess.run(run + [f"--screenshot={shot}", (d / "html" / "atlas_n8_F1.html").as_uri()],
                   capture_output=True, timeout=180, check=False)
    assert shot.exists(), "chromium wrote no screenshot"
    img = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    non_white = (img.sum(axis=2) < 720).mean()
    red = ((img[:, :, 0] > 200) & (img[:, :, 1] < 120) & (img[:, :, 2] < 120)).sum()
    blue = ((img[:, :, 2] > 140) & (img[:, :, 0] < 110)).sum()
    assert non_white > 0.05, f"page looks blank ({non_white:.1%} non-white pixels)"
    assert red > 50, "no multiple joint (red) rendered"
    assert blue > 200, "no link (coloured bar) rendered"


def _html_unescape(text: str) -> str:
    import html

    return html.unescape(text)
