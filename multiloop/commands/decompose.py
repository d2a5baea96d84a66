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

import json

from multiloop.topo.assur import decompose
from multiloop.inputs import load_mechanism as load  # files, .pyslvs or catalogue names

__all__ = ["add_arguments", "run", "format_plan"]


def add_arguments(p) -> None:
    p.add_argument("file", help="mechanism with a frame and drivers (.toml or .json)")
    p.add_argument("--json", action="store_true", help="print the stable JSON plan")


def format_plan(plan) -> str:
    """Readable plan: formula, drivers, then one block per group."""
    d = plan.as_dict()
    lines = [f"structure formula: {d['formula']}",
             "link numbers: " + ", ".join(f"{n}={k}" for k, n in d["link_numbers"].items())]
    for dr in d["drivers"]:
        lines.append(f"I{tuple(dr['numbers'])}: driver {dr['joint']} ({dr['kind']}) moves "
                     f"{dr['links'][1]} relative to {dr['links'][0]}")
    for i, g in enumerate(d["groups"], 1):
        lines.append(f"group {i}: {g['label']}  class {g['class']}, order {g['order']}, kind {g['kind']}")
        for lk, js in g["link_joints"].items():
            lines.append(f"    link {lk}: joints {', '.join(js)}")
        lines.append(f"    outer joints {', '.join(g['outer_joints'])} → known links "
                     f"{', '.join(g['known_links'])}; inner joints {', '.join(g['inner_joints'])}")
    return "\n".join(lines)


def run(args) -> int:
    plan = decompose(load(args.file))
    if args.json:
        print(json.dumps(plan.as_dict(), indent=2, ensure_ascii=False))
    else:
        print(format_plan(plan))
    return 0
