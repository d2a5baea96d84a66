"""``multiloop decompose FILE [--json]``: Assur groups in solving order.

JSON (stable): ``formula`` (e.g. ``I(0,1) → II1(2,3)``), ``drivers`` (list of
``{joint, kind, links, numbers}``), ``groups`` in solving order, each with
``class``, ``order``, ``kind`` (``RRR`` … ``RPP``, ``triad``, ``class IV``, or
``"<n>-link group"``), ``links`` (real link names), ``joints`` (every joint of its
links: a multiple joint is never broken), plus ``label``, ``link_joints`` (each
link's full joint set), ``inner_joints``, ``outer_joints``, ``known_links``,
``numbers``; and ``link_numbers`` (0 = frame, then solving order).
"""
from __future__ import annotations


from multiloop.topo.assur import decompose
from multiloop.inputs import load_mechanism as load  # files, .pyslvs or catalogue names
from multiloop.outputs import emit

__all__ = ["add_arguments", "run"]


def add_arguments(p) -> None:
    p.add_argument("file", help="mechanism with a frame and drivers (.toml or .json)")
    p.add_argument("--json", action="store_true", help="print the stable JSON plan")


def run(args) -> int:
    plan = decompose(load(args.file))
    emit(plan, args.json)
    return 0
