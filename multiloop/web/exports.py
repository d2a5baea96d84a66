"""The page's exports of the open design: the files the command line writes, made by
the same library writers, in memory, named after the design.

=========  ============================================================================
format     what (the command line that writes the same file)
=========  ============================================================================
toml       the mechanism file (``multiloop convert X --out NAME.toml``)
pyslvs     Pyslvs's expression file (``multiloop convert X --out NAME.pyslvs``)
csv        the motion, one row per position (``multiloop solve X --csv``)
svg, dxf   the drawing at the reference position (``multiloop solve X --svg/--dxf``)
gif        the animation of the motion (``multiloop solve X --animate``)
json       the design check (``multiloop check X --json``, at the page's threshold)
=========  ============================================================================

Nothing is kept on the server: each export is made when its button is clicked and sent
to the browser, which saves it.
"""
from __future__ import annotations

import re
import tempfile
from pathlib import Path

__all__ = ["EXPORTS", "export", "file_stem"]

#: the page's export formats, in the order of its menu, with their labels
EXPORTS = {"toml": "mechanism (.toml)", "pyslvs": "Pyslvs (.pyslvs)", "csv": "motion (.csv)",
           "svg": "drawing (.svg)", "dxf": "drawing (.dxf)", "gif": "animation (.gif)",
           "json": "check report (.json)"}


def file_stem(m, fallback: str = "design") -> str:
    """A file name for ``m``: its name with every character but letters, digits, ``-``,
    ``_`` and ``.`` replaced by ``_`` (never a path), at most 80 characters."""
    stem = re.sub(r"[^\w.-]+", "_", str(m.name or ""), flags=re.ASCII).strip("._")[:80]
    return stem or fallback


def _motion(m, derivatives: bool = False):
    """The motion ``multiloop solve`` computes without options: (state, its document)."""
    import warnings

    from multiloop.kin.solve import compile_plan, solve
    from multiloop.kin.sweep import input_range, si_inputs
    plan = compile_plan(m)
    x = input_range(m, None, None, None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        state = solve(m, si_inputs(m, x), derivatives=derivatives, plan=plan)
    return state, state.as_dict(plan.assur.formula, x)


def _gif(state) -> bytes:
    from multiloop.kin.figures.mechanism import animate
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "motion.gif"
        animate(state, path)
        return path.read_bytes()


def export(m, fmt: str, check_doc: dict | None = None, threshold: float = 40.0) -> tuple[str, str | bytes]:
    """The file ``fmt`` (a key of :data:`EXPORTS`) of the design ``m``: (file name, text or
    bytes).  ``check_doc``: the check's document when the page has it (else computed).

    Raises
    ------
    InputError
        ``fmt`` is not an export format.
    LinkageError
        The design cannot be written or solved in that format (its message).
    """
    from multiloop.topo.errors import InputError

    from .menus import refusal
    if fmt not in EXPORTS:
        raise InputError(refusal("export menu", fmt))
    name = f"{file_stem(m)}.{fmt}"
    if fmt == "toml":
        from multiloop.topo.io import dumps_toml
        return name, dumps_toml(m)
    if fmt == "pyslvs":
        from multiloop.topo.pyslvs import dumps_pyslvs, with_pyslvs_names
        return name, dumps_pyslvs(with_pyslvs_names(m))
    if fmt == "json":
        from multiloop.outputs import dumps_json
        if check_doc is None:
            from multiloop.kin.check import check
            check_doc = check(m, min_transmission=threshold).as_dict()
        return name, dumps_json(check_doc)
    state, doc = _motion(m)
    if fmt == "csv":
        from multiloop.kin.state import doc_csv
        return name, doc_csv(doc)
    if fmt == "gif":
        return name, _gif(state)
    from multiloop.kin.figures.cad import mechanism_dxf, mechanism_svg
    return name, (mechanism_svg(state) if fmt == "svg" else mechanism_dxf(state))


class ExportBar:
    """The page's export widgets: a menu of :data:`EXPORTS` and a Download button that
    sends the chosen file of the design ``design()`` returns: (mechanism or None, the
    check's document or None, threshold).  A failure is the page's one-line message."""

    def __init__(self, design, say):
        from .glue import Download
        from .menus import Menu
        self.design, self.say = design, say
        self.menu = Menu("export menu", say, list(EXPORTS), "toml", labels=EXPORTS, title="export", width=170,
                         css_classes=["ml-export"])
        self.download = Download("Download", self.make, width=100, css="ml-download")

    def make(self):
        from multiloop.topo.errors import InputError, LinkageError, explain
        m, doc, threshold = self.design()
        try:
            if m is None:
                raise InputError(explain("export", expected="an open design", got="none"))
            return export(m, self.menu.value, doc, threshold)
        except LinkageError as exc:
            self.say(str(exc))
            return None
