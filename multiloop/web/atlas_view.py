"""The atlas browser: the chains of a stored atlas (SQLite, opened read-only) as the
gallery's cards (:func:`multiloop.catalogue.html.chain_card`), filtered by the query
language of ``multiloop atlas --query``."""
from __future__ import annotations

import html

import panel as pn

from multiloop.catalogue.atlas import Atlas
from multiloop.catalogue.html import CSS, chain_card
from multiloop.catalogue.synthesis import SynthesisOptions
from multiloop.topo.errors import LinkageError

__all__ = ["AtlasView"]


class AtlasView:
    """Browse the atlases given to ``multiloop serve --atlas`` (one connection per session)."""

    def __init__(self, paths: list[str], say):
        self.say = say
        self.atlases = {p: Atlas(p, readonly=True) for p in paths}
        self.file = pn.widgets.Select(name="atlas", options=list(self.atlases), width=260)
        self.pair = pn.widgets.Select(name="n, F", options=[], width=120)
        self.query = pn.widgets.TextInput(name="query (as atlas --query)", placeholder="V>=1 and planar",
                                          width=280)
        self.limit = pn.widgets.IntInput(name="at most", value=60, start=1, end=2000, width=90)
        self.button = pn.widgets.Button(name="Show", button_type="primary", width=80)
        self.cards = pn.pane.HTML("", sizing_mode="stretch_width")
        self.file.param.watch(lambda e: self._pairs(), "value")
        self.button.on_click(lambda e: self.show())
        self.pair.param.watch(lambda e: self.show(), "value")
        self.query.param.watch(lambda e: self.show(), "value")
        self.panel = pn.Column(pn.Row(self.file, self.pair, self.query, self.limit, self.button), self.cards)
        self._pairs()

    def _pairs(self) -> None:
        a = self.atlases.get(self.file.value)
        if a is None:
            return
        pairs = sorted({(r[0], r[1]) for r in a.con.execute("SELECT DISTINCT n, F FROM chains")})
        self.pair.options = [f"{n}, {F}" for n, F in pairs]
        if self.pair.options and self.pair.value not in self.pair.options:
            self.pair.value = self.pair.options[0]
        self.show()

    def show(self) -> None:
        a = self.atlases.get(self.file.value)
        if a is None or not self.pair.value:
            self.cards.object = "<p>no chains stored</p>"
            return
        n, F = (int(v) for v in self.pair.value.split(","))
        q = self.query.value.strip() or None
        try:
            opts = SynthesisOptions(n, F)
            total = a.count(opts, q)
            cards = [chain_card(i, r) for i, r in enumerate(a.chains(opts, q, limit=self.limit.value), 1)]
        except LinkageError as exc:
            self.say(str(exc))
            return
        self.cards.object = (f"<style>{CSS}</style><p id='ml-atlas-count'>{total} chains with n = {n}, F = {F}"
                             f"{'' if q is None else ' matching ' + html.escape(q)}; {len(cards)} shown</p>"
                             f"<div class='grid'>{''.join(cards)}</div>")

    def close(self) -> None:
        for a in self.atlases.values():
            a.close()
