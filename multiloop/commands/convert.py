"""``multiloop convert IN OUT``: convert a mechanism between ``.toml``, ``.json`` and ``.pyslvs``.

IN may be any input the other commands take (a ``.toml``/``.json``/``.pyslvs``/``.expr``
file or a catalogue name); the format of OUT follows its suffix: ``.toml``, ``.json``,
``.pyslvs`` (Pyslvs project YAML: ``mechanism`` expression and ``input`` pairs) or
``.expr`` (a bare Pyslvs expression): the writers of :data:`topo.formats.FORMATS`.  The
mapping to and from Pyslvs is documented in :mod:`multiloop.topo.pyslvs`; what a Pyslvs file cannot keep (masses, loads, gravity,
joint names, ...) is named on stderr.  Nothing is written when the conversion fails.
"""
from __future__ import annotations

import sys

from multiloop.inputs import load_mechanism
from multiloop.outputs import Outputs
from multiloop.topo.errors import InputError
from multiloop.topo.formats import dumps_mechanism, format_of

__all__ = ["add_arguments", "run"]


def add_arguments(p) -> None:
    p.add_argument("input", help="mechanism file (.toml/.json/.pyslvs/.expr) or catalogue name")
    p.add_argument("output", help="output file; its suffix picks the format (.toml/.json/.pyslvs/.expr)")


def run(args) -> int:
    suffix = format_of(args.output, f"output '{args.output}'").suffix
    m = load_mechanism(args.input)
    try:
        text = dumps_mechanism(m, args.output)
    except InputError as exc:
        raise InputError(f"{args.input}: {exc}") from None
    outs = Outputs("multiloop convert")
    outs.add(args.output, text, "OUT")
    outs.commit()
    if suffix in (".pyslvs", ".expr"):
        from multiloop.topo.pyslvs import pyslvs_losses  # noqa: PLC0415
        lost = pyslvs_losses(m) + (["the inputs (a bare expression has none)"] if suffix == ".expr" and m.drivers
                                   else [])
        if lost:
            print(f"multiloop convert: note: {args.output} does not keep " + "; ".join(lost), file=sys.stderr)
    return 0
