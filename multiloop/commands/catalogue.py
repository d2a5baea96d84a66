"""``multiloop catalogue [--json]``: the bundled mechanisms with their basic numbers.

Lists every ``catalogue/mechanisms/*.toml`` with name, n (links), F (mobility),
K (independent loops), structural code ([LA]/V of Pozhbelko & Kuts 2020) and source.  The full
report of one entry is ``multiloop analyse $(python -c "from multiloop.catalogue.named import
path; print(path('excavator'))")``, or in Python ``structural_report(load_named(name))``.
"""
from __future__ import annotations

from multiloop.catalogue.named import listing
from multiloop.outputs import emit


def add_arguments(p) -> None:
    p.add_argument("--json", action="store_true",
                   help="print a JSON list of {name, n, F, K, code, drivers, description, source}")


def run(args) -> int:
    emit(listing(), args.json)
    return 0
