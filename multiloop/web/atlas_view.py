"""The atlas browser: the chains of a stored atlas (SQLite, opened read-only) as the
gallery's cards (:func:`multiloop.catalogue.html.chain_card`), filtered by the query
language of ``multiloop atlas --query``; a card shown opens as a design with generic
dimensions, or as the start of a synthesis (:mod:`.atlas_design`)."""
from __future__ import annotations

from bokeh.models import Button, Column, NumericInput, Row, TextInput

from multiloop.catalogue.atlas import Atlas
from multiloop.catalogue.html import CSS, chain_card
from multiloop.catalogue.synthesis import SynthesisOptions
from multiloop.topo.errors import LinkageError

from .glue import div
from .markup import Html, html
from .menus import Menu

__all__ = ["AtlasView"]


class AtlasView:
    """Browse the atlases given to ``multiloop serve --atlas`` (one connection per session)."""

    def __init__(self, paths: list[str], say, open_design=None, start=None):
        from .atlas_design import AtlasOpener
        self.say = say
        self.opener = AtlasOpener(say, open_design or (lambda m, name: None), start or (lambda m, name: None))
        self.atlases = {p: Atlas(p, readonly=True) for p in paths}
        paths = list(self.atlases)
        self.files = Menu("atlas menu", say, paths, title="atlas", width=260)
        self.pairs = Menu("n, F menu", say, title="n, F", width=120)
        self.file, self.pair = self.files.select, self.pairs.select
        self.query = TextInput(title="query (as atlas --query)", placeholder="V>=1 and planar", width=280)
        self.limit = NumericInput(title="at most", value=60, low=1, high=2000, mode="int", width=90)
        self.button = Button(label="Show", button_type="primary", width=80, align="end")
        self.cards = div("")
        self.files.on_choice(lambda path: self._pairs())
        self.button.on_click(lambda: self.show())
        self.pairs.on_choice(lambda pair: self.show())
        self.query.on_change("value", lambda attr, old, new: self.show())
        self.panel = Column(Row(self.file, self.pair, self.query, self.limit, self.button), self.opener.panel,
                            self.cards)
        self._pairs()

    def _pairs(self) -> None:
        a = self.atlases.get(self.files.value)
        if a is None:
            return
        pairs = a.sizes()
        self.pairs.set([f"{n}, {F}" for n, F in pairs])
        self.show()

    def show(self) -> None:
        a = self.atlases.get(self.files.value)
        if a is None or not self.pairs.value:
            self.cards.text = html("<p>no chains stored</p>")
            return
        n, F = (int(v) for v in self.pairs.value.split(","))
        q = self.query.value.strip() or None
        try:
            opts = SynthesisOptions(n, F)
            total = a.count(opts, q)
            records = list(a.chains(opts, q, limit=int(self.limit.value or 60)))
            cards = [chain_card(i, r) for i, r in enumerate(records, 1)]
        except LinkageError as exc:
            self.say(str(exc))
            return
        self.opener.set_chains(records)
        # the gallery's style and cards come from catalogue.html, which escapes what it shows
        self.cards.text = html("<style>{css}</style><p id='ml-atlas-count'>{total} chains with n = {n}, F = {F}"
                               "{matching}; {shown} shown</p><div class='grid'>{cards}</div>",
                               css=Html(CSS), total=total, n=n, F=F, matching="" if q is None else f" matching {q}",
                               shown=len(cards), cards=Html("".join(cards)))

    def close(self) -> None:
        self.opener.cancel()
        for a in self.atlases.values():
            a.close()
