"""The structure tab: the numbers of ``multiloop analyse`` under its names
(:meth:`topo.numbers.StructuralReport.labelled`),
the structure formula and the Assur groups of :func:`topo.assur.decompose`, as HTML tables."""
from __future__ import annotations

from .markup import Html, html, join

__all__ = ["structure_html"]


def structure_html(m) -> Html:
    """The structural report and the Assur plan of ``m`` as HTML tables."""
    from multiloop.topo.assur import decompose
    from multiloop.topo.errors import LinkageError
    from multiloop.topo.numbers import structural_report

    rows = join(html("<tr><td>{k}</td><td>{v}</td></tr>", k=k, v=v) for k, v in structural_report(m).labelled())
    out = html('<h3>Structural report</h3><table id="ml-structure">{rows}</table>', rows=rows)
    if not m.drivers:
        return out
    try:
        plan = decompose(m).as_dict()
    except LinkageError as exc:
        return html("{out}<p>{text}</p>", out=out, text=str(exc))
    grows = join(html("<tr><td>{label}</td><td>{kind}</td><td>{links}</td><td>{joints}</td></tr>",
                      label=g["label"], kind=g["kind"], links=", ".join(g["links"]), joints=", ".join(g["joints"]))
                 for g in plan["groups"])
    return html('{out}<h3>Structure formula</h3><p id="ml-formula">{formula}</p><table id="ml-groups"><tr>'
                "<th>group</th><th>kind</th><th>links</th><th>joints</th></tr>{grows}</table>",
                out=out, formula=plan["formula"], grows=grows)
