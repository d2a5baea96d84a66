"""The structure tab: the numbers of ``multiloop analyse`` (:func:`topo.numbers.structural_report`),
the structure formula and the Assur groups of :func:`topo.assur.decompose`, as HTML tables."""
from __future__ import annotations

import html

__all__ = ["structure_html"]


def structure_html(m) -> str:
    """The structural report and the Assur plan of ``m`` as HTML tables."""
    from multiloop.topo.assur import decompose
    from multiloop.topo.errors import LinkageError
    from multiloop.topo.numbers import structural_report

    rep = structural_report(m).as_dict()
    keep = ("n", "p", "LA", "MJA", "V", "K", "L", "AVC", "F", "N", "rc", "SL", "La", "L0", "code", "code_star",
            "planar", "degenerate", "fractionated", "actual_F", "redundant", "canonical")
    rows = "".join(f"<tr><td>{k}</td><td>{html.escape(str(rep.get(k)))}</td></tr>" for k in keep if k in rep)
    out = f'<h3>Structural report</h3><table id="ml-structure">{rows}</table>'
    if not m.drivers:
        return out
    try:
        plan = decompose(m).as_dict()
    except LinkageError as exc:
        return out + f"<p>{html.escape(str(exc))}</p>"
    grows = "".join(f"<tr><td>{html.escape(g['label'])}</td><td>{html.escape(str(g['kind']))}</td>"
                    f"<td>{html.escape(', '.join(g['links']))}</td><td>{html.escape(', '.join(g['joints']))}</td></tr>"
                    for g in plan["groups"])
    return out + (f'<h3>Structure formula</h3><p id="ml-formula">{html.escape(plan["formula"])}</p>'
                  f'<table id="ml-groups"><tr><th>group</th><th>kind</th><th>links</th><th>joints</th></tr>'
                  f"{grows}</table>")
