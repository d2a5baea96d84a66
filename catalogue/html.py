"""Static HTML gallery of an atlas: one page per (n, F) plus an index.

Every chain is a card with its inline SVG drawing (:func:`catalogue.drawing.chain_svg`)
and its numbers (Code, Code*, [LA], [MJA], V, K, [La], planarity, fractionation, the
number of distinct frames and of (frame, driver) choices).  A small inline script
filters the cards by a search text (code, code*, [LA], [La] …), so the pages work
from the file system without a server.
"""
from __future__ import annotations

import html as _html
from pathlib import Path

from .atlas import Atlas
from multiloop.kin.figures.chains import chain_svg
from .synthesis import mechanism_choices

__all__ = ["write_gallery", "gallery_files", "gallery_page", "chain_card", "CSS"]

CSS = """
body{font-family:system-ui,sans-serif;margin:1.2em;background:#fafafa;color:#222}
h1{font-size:1.4em} .meta{color:#555}
#q{font-size:1em;padding:.3em .5em;width:22em}
.grid{display:flex;flex-wrap:wrap;gap:10px;margin-top:1em}
.card{background:white;border:1px solid #ddd;border-radius:6px;padding:6px;width:190px;font-size:11px}
.card svg{display:block;margin:auto}
.card .code{font-weight:bold;font-size:12px}
.legend span{margin-right:1.2em}
"""

_JS = """
function filt(){
  // a word with a capital letter matches case-sensitively ([LA] is not [La]), others not
  var q=document.getElementById('q').value.replace(/,\\s+/g,',').split(/\\s+/).filter(Boolean);
  var n=0;
  document.querySelectorAll('.card').forEach(function(c){
    var t=c.getAttribute('data-search'), tl=t.toLowerCase();
    var ok=q.every(function(w){return w===w.toLowerCase()? tl.indexOf(w)>=0 : t.indexOf(w)>=0;});
    c.style.display=ok?'':'none'; if(ok)n++;
  });
  document.getElementById('shown').textContent=n;
}
"""


def chain_card(i: int, rec) -> str:
    """The gallery card of chain ``rec`` (a :class:`~.synthesis.ChainRecord`) numbered
    ``i``: its drawing, codes and assortments, with a ``data-search`` text for filtering."""
    masks = [sum(1 << x for x in j) for j in rec.joints]
    choices = mechanism_choices(rec.n, masks)
    la = "-".join(map(str, rec.La)) if rec.La else ("non-planar" if rec.planar is False else "—")
    LA, MJA = ",".join(map(str, rec.LA)), ",".join(map(str, rec.MJA))
    search = " ".join([rec.code, rec.code_star, f"V={rec.V}", f"K={rec.K}", f"[LA]=[{LA}]", f"LA=[{LA}]",
                       f"[MJA]=[{MJA}]", f"MJA=[{MJA}]", f"[La]={la}", f"La={la}",
                       "planar" if rec.planar else "nonplanar",
                       "fractionated" if rec.fractionated else "unfractionated"])
    rows = [f'<div class="code">#{i} {_html.escape(rec.code_star)}</div>',
            f"<div>Code {_html.escape(rec.code)} · V={rec.V} K={rec.K}</div>",
            f"<div>[LA]={list(rec.LA)} [MJA]={list(rec.MJA)}</div>",
            f"<div>[La]={_html.escape(la)}{'' if rec.L0 is None else f' (L0={rec.L0})'}</div>",
            f"<div>{'planar' if rec.planar else 'non-planar'}"
            f"{' · fractionated' if rec.fractionated else ''} · frames {choices.n_frames}"
            f" · drivers {choices.n_drivers}</div>"]
    svg = chain_svg(rec.n, rec.joints, title=f"#{i} {rec.code_star}")
    return (f'<div class="card" data-search="{_html.escape(search)}">{svg}{"".join(rows)}</div>')


def gallery_page(atlas: Atlas, n: int, F: int, query: str | None = None, limit: int | None = 2000) -> str:
    """The HTML text of the page of (n, F) (at most ``limit`` chains)."""
    from .synthesis import SynthesisOptions

    opts = SynthesisOptions(n, F)
    total = atlas.count(opts, query)
    cards = [chain_card(i, r) for i, r in enumerate(atlas.chains(opts, query, limit=limit), 1)]
    note = "" if len(cards) == total else f" (first {len(cards)} shown; raise --html-limit for more)"
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>Atlas n={n} F={F}</title>
<style>{CSS}</style><script>{_JS}</script></head>
<body><h1>Atlas of planar chains: n = {n} links, F = {F}</h1>
<p class="meta">{total} non-isomorphic non-degenerate chains{_html.escape(note)}{'' if not query else ' matching ' + _html.escape(query)}.
Links: bars (2 joints) and shaded polygons (3+ joints); open circles: simple joints;
<span style="color:#e15759">red ringed dots</span>: multiple joints (number = multiplicity j).</p>
<p><input id="q" placeholder="filter: [LA]=[6,2], [La]=4-4-6, V=2, planar …" oninput="filt()">
shown: <span id="shown">{len(cards)}</span></p>
<div class="grid">
{chr(10).join(cards)}
</div></body></html>
"""


def gallery_files(atlas: Atlas, pairs=None, query: str | None = None,
                  limit: int | None = 2000) -> dict[str, str]:
    """The gallery as ``{file name: HTML text}``: ``atlas_n{n}_F{F}.html`` for every
    (n, F) in the atlas (or ``pairs``), then ``index.html``."""
    from .synthesis import SynthesisOptions

    if pairs is None:
        pairs = atlas.sizes()
    files: dict[str, str] = {}
    items = []
    for n, F in pairs:
        name = f"atlas_n{n}_F{F}.html"
        files[name] = gallery_page(atlas, n, F, query, limit)
        items.append(f'<li><a href="{name}">n = {n}, F = {F}</a>: '
                     f'{atlas.count(SynthesisOptions(n, F), query)} chains</li>')
    files["index.html"] = ("<!DOCTYPE html><html><head><meta charset='utf-8'><title>multiloop atlas</title>"
                           f"<style>{CSS}</style></head><body><h1>multiloop atlas</h1><ul>"
                           + "".join(items) + "</ul></body></html>")
    return files


def write_gallery(atlas: Atlas, directory: str | Path, pairs=None, query: str | None = None,
                  limit: int | None = 2000) -> list[Path]:
    """Write :func:`gallery_files` into ``directory`` (created if needed); returns the paths."""
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    written = []
    for name, text in gallery_files(atlas, pairs, query, limit).items():
        (d / name).write_text(text, encoding="utf-8")
        written.append(d / name)
    return written
