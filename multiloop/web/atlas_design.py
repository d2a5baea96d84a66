"""From an atlas card to a design: a chain of the atlas view, one of its mechanisms (a
frame and a driver), and generic dimensions from the library.

The dimensions are those the curve atlas draws (:func:`multiloop.catalogue.realisations.realise`):
the first random realisation, from a fixed seed, whose driver turns fully with every
monitored angle at least 20° from 0° and 180° (certified by the design check's motion).
A tracer point ``P`` is put where the library draws the atlas's coupler curves
(:func:`~multiloop.catalogue.realisations.coupler_curves`, the first curve that moves),
so the design is also a start for the synthesis of a path.  The realisation runs in a
background :class:`~.jobs.Job` (a few tenths of a second for six links, a few seconds
for a triad): the page goes on meanwhile.
"""
from __future__ import annotations

import numpy as np

from multiloop.topo.errors import InputError, explain

from .markup import html

__all__ = ["mechanisms_of", "mechanism_label", "generic_design", "AtlasOpener", "SEED", "CARD_CLICK_JS"]

#: the seed of the realisation (the same design every time a card is opened)
SEED = 0

#: a click on an atlas card chooses its chain in the chain menu (model ``ml-atlas-chain``),
#: whose entries start with the cards' numbers; one listener a page, installed when the
#: page is ready (the atlas tab is built later: the menu is looked up at the click)
CARD_CLICK_JS = """
if (window.__mlCardClick) { return; }
window.__mlCardClick = true;
document.addEventListener('click', (e) => {
  const card = e.composedPath().find(el => el.classList && el.classList.contains('card') && el.dataset
    && el.dataset.search !== undefined);
  const chain = card && Bokeh.documents[0].get_model_by_name('ml-atlas-chain');
  const head = card && card.querySelector('.code');
  const num = head && /^#(\\d+) /.exec(head.textContent);
  if (!chain || !num) { return; }
  const entry = chain.options.find(o => String(o).startsWith('#' + num[1] + ' '));
  if (entry !== undefined && chain.value !== entry) { chain.value = entry; }
});
"""


def mechanisms_of(rec) -> list:
    """The mechanisms of chain ``rec`` (a :class:`~multiloop.catalogue.synthesis.ChainRecord`):
    every frame and driver up to symmetry, :class:`~multiloop.catalogue.inversions.InversionRecord` s."""
    from multiloop.catalogue.inversions import chain_inversions
    return chain_inversions(rec)[0]


def mechanism_label(inv) -> str:
    """A menu label of mechanism ``inv``: frame, driver and structure formula."""
    return f"frame {inv.frame + 1}, driver J{inv.joint + 1} turning {inv.driven + 1}: {inv.formula}"


def generic_design(inv, name: str, seed: int = SEED):
    """Mechanism ``inv`` with generic dimensions (the library's certified realisation)
    and a tracer point ``P``, named ``name``.

    Raises
    ------
    InputError
        No realisation turns fully within the library's tries.
    """
    from multiloop.catalogue.realisations import coupler_curves, realise
    from multiloop.topo.model import MechanismBuilder, TracerPoint
    r = realise(inv, seed)
    if r is None:
        raise InputError(explain(f"atlas mechanism {inv.formula}", expected="generic dimensions that turn fully",
                                 got="none among the library's random realisations",
                                 hint="choose another mechanism of the chain"))
    m = r.mechanism
    b = MechanismBuilder.from_mechanism(m)
    b.name = name
    curves = coupler_curves(m, (m.frame, m.drivers[0].links[1]), 1, np.random.default_rng(seed))
    if curves:
        b.points = [TracerPoint("P", curves[0].link, tuple(float(v) for v in curves[0].at))]
    return b.build()


class AtlasOpener:
    """The atlas view's row that opens a card: a chain menu (the cards shown), a menu of
    its mechanisms, **Open in mechanism view** and **Start a synthesis**.  ``open(m, name)``
    shows a design, ``start(m, name)`` makes it the synthesis's start; ``say`` shows the
    one-line message."""

    def __init__(self, say, open_design, start):
        from bokeh.models import Button, Row

        from .glue import div
        from .menus import Menu
        self.say, self.open_design, self.start = say, open_design, start
        self.records: dict = {}                  # chain menu entry -> ChainRecord
        self.inversions: list = []
        self.chains = Menu("chain menu", say, title="chain (or click a card)", width=200,
                           css_classes=["ml-atlas-chain"], name="ml-atlas-chain")
        self.mechanisms = Menu("atlas mechanism menu", say, title="mechanism (frame, driver)", width=360,
                               css_classes=["ml-atlas-mechanism"])
        self.open_button = Button(label="Open in mechanism view", width=180, css_classes=["ml-atlas-open"])
        self.start_button = Button(label="Start a synthesis", width=140, css_classes=["ml-atlas-start"])
        self.status = div(html('<span id="ml-atlas-design"></span>'))
        self.job = None
        self.chains.on_choice(lambda entry: self._mechanisms())
        self.open_button.on_click(lambda: self.make(self.open_design))
        self.start_button.on_click(lambda: self.make(self.start))
        self.panel = Row(self.chains.select, self.mechanisms.select, self.open_button, self.start_button,
                         self.status)

    def set_chains(self, records) -> None:
        """The cards shown: ``records`` in the order of their numbers (#1, #2, …)."""
        self.records = {f"#{i} {r.code_star}": r for i, r in enumerate(records, 1)}
        self.chains.set(list(self.records), next(iter(self.records), ""))
        self._mechanisms()

    def _mechanisms(self) -> None:
        rec = self.records.get(self.chains.value)
        self.inversions = [] if rec is None else mechanisms_of(rec)
        entries = [f"{k + 1}. {mechanism_label(inv)}" for k, inv in enumerate(self.inversions)]
        self.mechanisms.set(entries, entries[0] if entries else "")

    def make(self, then) -> None:
        """Realise the chosen mechanism in the background; ``then(m, name)`` once done."""
        from .jobs import Job
        if self.job is not None and self.job.running:
            return
        entry = self.mechanisms.value
        if not entry or entry not in self.mechanisms.choices:
            self.say(explain("atlas mechanism", expected="a mechanism of a chain shown", got="none",
                             hint="press Show to list the chains"))
            return
        inv = self.inversions[self.mechanisms.choices.index(entry)]
        name = f"atlas: {self.chains.value.split(' ', 1)[0]} {entry.split(':', 1)[0]}"
        self.job = Job(lambda job: generic_design(inv, name), "atlas-design")
        self.job.then, self.job.design_name = then, name
        self.status.text = html('<span id="ml-atlas-design" data-state="running">generic dimensions: '
                                "computing…</span>")

    def poll(self) -> None:
        """The session's periodic callback: the realised design, once ready."""
        job = self.job
        if job is None or job.running:
            return
        self.job = None
        self.status.text = html('<span id="ml-atlas-design" data-state="{s}">{name}: {s}</span>', s=job.state,
                                name=job.design_name)
        if job.state == "failed":
            self.say(job.error)
        elif job.state == "done":
            job.then(job.result, job.design_name)

    def cancel(self) -> None:
        if self.job is not None:
            self.job.cancel()
