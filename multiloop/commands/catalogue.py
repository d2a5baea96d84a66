"""``multiloop catalogue [--json]``: the bundled mechanisms with their basic numbers.

Lists every ``catalogue/mechanisms/*.toml`` with name, n (links), F (mobility),
K (independent loops), structural code ([LA]/V of Pozhbelko & Kuts 2020) and source.  The full
report of one entry is ``multiloop analyse $(python -c "from multiloop.catalogue.named import
path; print(path('excavator'))")``, or in Python ``structural_report(load_named(name))``.
"""
from __future__ import annotations


from multiloop.catalogue.named import entry, names
from multiloop.outputs import dumps_json


def add_arguments(p) -> None:
    p.add_argument("--json", action="store_true",
                   help="print a JSON list of {name, n, F, K, code, drivers, description, source}")


def run(args) -> int:
    rows = [entry(name).as_dict() for name in names()]
    if args.json:
        print(dumps_json(rows))
        return 0
    head = ("name", "n", "F", "K", "code", "source")
    table = [(r["name"], str(r["n"]), str(r["F"]), str(r["K"]), r["code"],
              _short(r["source"] or "")) for r in rows]
    widths = [max(len(h), *(len(t[i]) for t in table)) for i, h in enumerate(head[:-1])]
    fmt = "  ".join(f"{{:<{w}}}" for w in widths) + "  {}"
    print(fmt.format(*head))
    for t in table:
        print(fmt.format(*t))
    return 0


def _short(text: str, width: int = 70) -> str:
    text = " ".join(text.split()).split("; ")[0]
    return text if len(text) <= width else text[: width - 3] + "..."
