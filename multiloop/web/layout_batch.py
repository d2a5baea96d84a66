"""One layout of the page per message from the server, not one per changed text.

BokehJS lays out the whole page again each time a Div's text (or any of its properties)
or a button's state changes: the widget's view renders itself and asks the root view to
compute the layout of every plot and widget (``MarkupView.rerender`` →
``root.compute_layout``).  A re-check changes five or six of them in one message (the
readout, the status line, the verdict, the table of events, the check's JSON, the
address), and the page spent 50-80 ms laying itself out five or six times in a row
before it could draw the new design (measured with ``benchmarks/bench_web.py
--edit-latency`` and a per-call timer in the browser).

:data:`LAYOUT_BATCH_JS`, run once when the page is ready, defers the layouts asked for
while a message's changes are applied and computes it once when they are all applied,
before the browser draws a frame: the page is laid out as before, once.  It relies on
two methods of BokehJS's document and root views (``apply_json_patch``,
``compute_layout``); where either is missing it does nothing, and every layout happens
as Bokeh asks for it.
"""
from __future__ import annotations

__all__ = ["LAYOUT_BATCH_JS"]

#: the page's glue (a CustomJS on DocumentReady, one install a page): see the module docstring
LAYOUT_BATCH_JS = """
if (window.__mlLayoutBatch) { return; }
const doc = Bokeh.documents[0];
// the root views that lay the page out (a root that is no layout has no compute_layout)
const roots = ((Bokeh.index && Bokeh.index.roots) ? [...Bokeh.index.roots] : [])
  .filter(v => typeof v.compute_layout === 'function');
if (!doc || typeof doc.apply_json_patch !== 'function' || roots.length === 0) { return; }
// layouts put off while a message was applied, and layouts then computed (read by the tests)
const counts = window.__mlLayoutBatch = {deferred: 0, laid: 0};
let applying = 0;
const asked = new Map();                 // root view -> its own compute_layout, asked for
for (const view of roots) {
  const own = view.compute_layout;
  view.compute_layout = function (...args) {
    if (applying > 0) { asked.set(view, own); counts.deferred += 1; return; }
    return own.apply(view, args);
  };
}
const apply = doc.apply_json_patch;
doc.apply_json_patch = function (...args) {
  applying += 1;
  try { return apply.apply(doc, args); }
  finally {
    applying -= 1;
    if (applying === 0 && asked.size > 0) {
      const layouts = [...asked];
      asked.clear();
      for (const [view, own] of layouts) { counts.laid += 1; own.call(view); }
    }
  }
};
"""
