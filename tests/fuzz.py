"""Seeded fuzzing of the command line (the stage of tests/test_hostile.py, run in a child
process under a memory cap).

Each case is a file (a mutation of a TOML, JSON or ``.pyslvs`` mechanism, an engine or a
platform file; a huge integer in a numeric field; a non-regular file) plus an argument
set, or an argument set alone (huge or out-of-range numbers), or one of

* a **driver move**: a catalogue mechanism with a driver on another joint, solved and
  checked (the moves are taken in turn, so a run of 5000 cases meets every one with
  both commands; a run of fewer than 1000 cases only solves them);
* a **damaged curve atlas**: one stored value of one table replaced (NULL, text, JSON
  that does not parse, bytes that are not UTF-8, a truncated, empty or bit-flipped
  BLOB, zero, NaN, huge numbers), a table of another schema, a dropped table, or the
  file's own bytes flipped or cut, read by synthesis, a query, a listing, the gallery
  and a resumed build;
* a **hostile option value** (``nan``, ``inf``, negative, ``2**70`` …) for every numeric
  option of every command;
* a **degenerate target** of synthesis (identical points, a circle of radius 1e-300, a
  field over the csv module's limit, a table over the input cap, …).

Every case runs
``multiloop.cli.main`` in an empty working directory that holds a sentinel file and a
sentinel directory, and must

* exit 0 or 2, print no traceback and no "internal error";
* print less than 10 kB on stderr;
* destroy nothing: the input file, the sentinels and nothing else left behind
  (besides the outputs of a run that succeeded; a failed atlas build removes the atlas
  it created);
* when ``convert`` succeeds, write a file multiloop reads back with the same canonical
  form (``.toml``/``.json``: the same document; ``.pyslvs``: the same canonical
  labelling of the chain and of the mechanism; ``.expr``: of the chain).

Usage: ``python tests/fuzz.py CASES SEED [MEMORY_MB]``; prints one JSON summary line
(counts by exit code and by kind, and the failures).
"""
from __future__ import annotations

import contextlib
import io
import json
import os
import random
import resource
import shutil
import signal
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CAT = ROOT / "catalogue"

#: the seed files (path relative to the repository) and the commands run on them
TOML_SEEDS = ["mechanisms/four_bar.toml", "mechanisms/crank_slider_loaded.toml", "mechanisms/dyad_rpr.toml",
              "mechanisms/stephenson_3_triad.toml", "mechanisms/six_bar_slider.toml", "mechanisms/watt_1.toml"]
ENGINE_SEED = "engines/single_cylinder.toml"
PLATFORM_SEED = "platforms/doronin_platform.toml"
MECH_COMMANDS = [["analyse"], ["decompose"], ["solve", "--steps", "6"], ["solve", "--steps", "5", "--json"],
                 ["forces", "--steps", "6"], ["convert", "OUT.toml"], ["convert", "OUT.json"],
                 ["convert", "OUT.pyslvs"], ["convert", "OUT.expr"], ["check", "--json"]]

HOSTILE_NUMBERS = ["nan", "inf", "-inf", "1e308", "-1e308", "1e-320", "0", "-0.0", "1" + "0" * 19,
                   "1" + "0" * 20, "1" + "0" * 309, "-1" + "0" * 400, "1" + "0" * 4400, '"7"', "true",
                   "[]", "{}", "[1, 2, 3]", "1e9", "-1e9"]
HOSTILE_NAMES = ['"$x^{$"', '"cou,pler"', '"a]b"', '"P0"', '"ground"', '"frame"', '""', '"' + "n" * 3000 + '"',
                 '"шатун ☃"', '"\\u0000"', '"A"', '"O2"', '"crank"', '"a\\nb"', "1", "[]"]
INSERTS = [b"\x00", b"\xff\xfe", b"[", b"]", b"=", b'"', b"\n", b"[[link]]\n", b"[[joint]]\nname = 1\n",
           b"{", b"}", b",", b"#", "\u2603".encode(), b"\\", b"[[force]]\nlink = \"crank\"\n"]


def _numbers(text: str) -> list[tuple[int, int]]:
    import re
    return [m.span() for m in re.finditer(r"(?<![A-Za-z_\"])-?\d+(\.\d+)?([eE][+-]?\d+)?", text)]


def _strings(text: str) -> list[tuple[int, int]]:
    import re
    return [m.span() for m in re.finditer(r'"[^"\n]*"', text)]


def mutate_mild(rng: random.Random, text: str) -> bytes:
    """A plausible edit (a number moved by up to 5 %): the file usually still loads, so the
    commands and the ``convert`` round trips run on it."""
    nums = _numbers(text)
    for _ in range(rng.randint(0, 3)):
        if nums:
            a, b = rng.choice(nums)
            try:
                v = float(text[a:b]) * (1 + rng.uniform(-0.05, 0.05)) + rng.uniform(-1e-3, 1e-3)
            except ValueError:
                continue
            new = repr(round(v, 6))
            text = text[:a] + new + text[b:]
            nums = _numbers(text)
    return text.encode("utf-8")


def mutate_text(rng: random.Random, text: str) -> bytes:
    """One to three mutations of a TOML or YAML text: a number or a string replaced by a
    hostile one, a line deleted, duplicated or swapped, bytes inserted or deleted; a
    third of the cases get a plausible edit only (:func:`mutate_mild`)."""
    if rng.random() < 0.33:
        return mutate_mild(rng, text)
    for _ in range(rng.randint(1, 3)):
        op = rng.random()
        nums, strs = _numbers(text), _strings(text)
        if op < 0.35 and nums:
            a, b = rng.choice(nums)
            text = text[:a] + rng.choice(HOSTILE_NUMBERS) + text[b:]
        elif op < 0.55 and strs:
            a, b = rng.choice(strs)
            text = text[:a] + rng.choice(HOSTILE_NAMES) + text[b:]
        elif op < 0.75:
            lines = text.split("\n")
            i, j = rng.randrange(len(lines)), rng.randrange(len(lines))
            kind = rng.choice(("delete", "duplicate", "swap"))
            if kind == "delete":
                del lines[i]
            elif kind == "duplicate":
                lines.insert(j, lines[i])
            else:
                lines[i], lines[j] = lines[j], lines[i]
            text = "\n".join(lines)
        else:
            data = text.encode("utf-8", "surrogatepass")
            p = rng.randrange(len(data) + 1)
            if rng.random() < 0.5:
                data = data[:p] + rng.choice(INSERTS) + data[p:]
            else:
                data = data[:p] + data[p + rng.randint(1, 12):]
            text = data.decode("utf-8", "surrogateescape")
    return text.encode("utf-8", "surrogateescape")


def _leaves(doc, path=()):
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield from _leaves(v, path + (k,))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            yield from _leaves(v, path + (i,))
    yield path


HOSTILE_JSON = [float("nan"), float("inf"), 10 ** 400, -(10 ** 30), 2 ** 63, -1, 0, "", "x", "\ud800", None, True,
                [], {}, [[[[[]]]]], "$x$", "a,b", "P0", [1e308, 1e308], "n" * 5000, 1e-320]


def mutate_json(rng: random.Random, doc) -> bytes:
    """A leaf or a whole sub-tree of the document replaced by a hostile JSON value."""
    doc = json.loads(json.dumps(doc))
    for _ in range(rng.randint(1, 3)):
        paths = [p for p in _leaves(doc) if p]
        if not paths:
            break
        path = rng.choice(paths)
        node = doc
        for k in path[:-1]:
            node = node[k]
        if rng.random() < 0.15 and isinstance(node, dict):
            del node[path[-1]]
        else:
            node[path[-1]] = rng.choice(HOSTILE_JSON)
    return json.dumps(doc, ensure_ascii=rng.random() < 0.5).encode("utf-8", "surrogatepass")


def _seed_texts() -> dict[str, str]:
    from multiloop.topo.pyslvs import dumps_pyslvs
    from multiloop.inputs import load_mechanism

    texts = {s: (CAT / s).read_text() for s in TOML_SEEDS + [ENGINE_SEED, PLATFORM_SEED]}
    for name in ("four_bar", "crank_slider", "dyad_rpr", "six_bar_slider"):
        texts[f"{name}.pyslvs"] = dumps_pyslvs(load_mechanism(name))
    data = json.loads((ROOT / "tests/data/pyslvs_solutions.json").read_text())["examples"]
    for name in sorted(data)[:6]:
        ex = data[name]
        texts[f"{name}.pyslvs"] = json.dumps({"mechanism": ex["expression"], "input": ex["input"]})
    return texts


def make_case(rng: random.Random, seeds: dict) -> tuple[str, str | None, bytes | None, list[str]]:
    """(kind, file name, file bytes, argv with FILE / OUT.* / TARGET / ATLAS placeholders)."""
    from multiloop.topo.io import mechanism_to_dict
    from multiloop.inputs import load_mechanism

    r = rng.random()
    if r < 0.22:
        seed = rng.choice(TOML_SEEDS)
        return "toml", "m.toml", mutate_text(rng, seeds[seed]), ["FILE"]
    if r < 0.40:
        seed = rng.choice(TOML_SEEDS)
        doc = mechanism_to_dict(load_mechanism(CAT / seed))
        data = mutate_json(rng, doc) if rng.random() < 0.7 else mutate_mild(rng, json.dumps(doc))
        return "json", "m.json", data, ["FILE"]
    if r < 0.54:
        seed = rng.choice([k for k in seeds if k.endswith(".pyslvs")])
        return "pyslvs", "m.pyslvs", mutate_text(rng, seeds[seed]), ["FILE"]
    if r < 0.59:
        return "engine", "e.toml", mutate_text(rng, seeds[ENGINE_SEED]), ["engine", "FILE", "--steps", "16",
                                                                         "--no-check"]
    if r < 0.62:
        return "platform", "p.toml", mutate_text(rng, seeds[PLATFORM_SEED]), ["platform", "FILE"]
    if r < 0.70:
        return "numbers", None, None, _number_argv(rng)
    if r < 0.74:
        return "special", *_special_file(rng)
    if r < 0.84:
        return _move_case(seeds[MOVES], seeds[CHECKS])
    if r < 0.90 and seeds[ATLAS] is not None:
        return "atlas", "a.sqlite", damaged_atlas(rng, seeds[ATLAS]), rng.choice(ATLAS_COMMANDS)
    if r < 0.96:
        return "option", None, None, _option_argv(rng)
    return "target", "t.csv", degenerate_target(rng), rng.choice(TARGET_COMMANDS)


# --- driver moves ---------------------------------------------------------------------------
#: keys of the seeds: the driver moves, the pristine curve atlas (None without nauty or
#: usearch) and a path target (the catalogue four-bar's coupler curve)
MOVES, ATLAS, TARGET, CHECKS = "__moves__", "__atlas__", "__target__", "__checks__"
#: runs of at least this many cases check the driver moves too (a check of a hydraulic
#: machine with a moved driver, three Newton groups, takes a minute; the suite's run solves)
CHECK_MOVES_FROM = 1000


def driver_moves() -> list[tuple[str, int, str, str]]:
    """Every catalogue mechanism with one of its drivers moved to another joint: (file stem,
    driver index, its joint, the new joint); the joints of the other drivers are skipped."""
    from multiloop.inputs import load_mechanism

    out = []
    for f in sorted((CAT / "mechanisms").glob("*.toml")):
        m = load_mechanism(f)
        taken = {d.joint for d in m.drivers}
        out += [(f.stem, k, d.joint, j) for k, d in enumerate(m.drivers) for j in m.joint_names if j not in taken]
    return out


def moved_driver(stem: str, k: int, old: str, new: str) -> bytes:
    """The catalogue file ``stem`` with its ``k``-th ``[[driver]]`` on joint ``new``."""
    head, *tables = (CAT / "mechanisms" / f"{stem}.toml").read_text().split("[[driver]]")
    tables[k] = tables[k].replace(f'joint = "{old}"', f'joint = "{new}"', 1)
    return "[[driver]]".join([head, *tables]).encode()


#: driver-move cases made so far (the first one's move depends on the seed), and the moves
#: met by each command
_MOVES_MADE = [0]
MOVES_MET: dict[str, set] = {"solve": set(), "check": set()}


def _move_case(moves: list, checks: bool) -> tuple[str, str, bytes, list[str]]:
    """The next driver move in turn, solved then (``checks``) checked: a run of 5000 cases,
    10 % of them moves, meets each move with both commands."""
    i = _MOVES_MADE[0]
    _MOVES_MADE[0] += 1
    move = moves[(i // 2) % len(moves) if checks else i % len(moves)]
    stem, k, old, new = move
    argv = ["solve", "FILE", "--steps", "6"] if i % 2 == 0 or not checks else ["check", "FILE", "--json"]
    MOVES_MET[argv[0]].add(move)
    return "move", f"{stem}-{new}.toml", moved_driver(stem, k, old, new), argv


# --- hostile values of every numeric option -------------------------------------------------
HOSTILE_OPTION_VALUES = ["nan", "inf", "-inf", "-1", "0", "-0.0", str(2 ** 70), str(-(2 ** 70)), "1e308", "1e-320"]
_SYNTH = ["synthesise", "four_bar", "--path", "TARGET", "--out", "OUT.toml", "--budget", "1"]
_TOPO = ["synthesise", "--path", "TARGET", "--out", "OUT.toml", "--db", "ATLAS", "--links", "4", "--budget", "1",
         "--top", "1"]
_ATLAS = ["atlas", "--db", "OUT.sqlite", "--no-progress"]
#: (the command, an option, its number of values)
OPTION_CASES = [
    (["solve", "four_bar", "--to", "90"], "--from", 1), (["solve", "four_bar", "--from", "0"], "--to", 1),
    (["solve", "four_bar"], "--steps", 1), (["forces", "four_bar"], "--steps", 1), (["forces", "four_bar"], "--at", 1),
    (["check", "four_bar", "--json"], "--at", 1), (["check", "four_bar", "--json"], "--min-transmission", 1),
    (["check", "four_bar", "--json"], "--positions", 2), (["engine", "single_cylinder", "--no-check"], "--steps", 1),
    (["analyse", "four_bar"], "--drivers", 1),
    (_ATLAS + ["--dof", "1"], "--links", 1), (_ATLAS + ["--links", "6"], "--dof", 1),
    (_ATLAS + ["--links", "6"], "--limit", 1), (_ATLAS + ["--links", "6"], "--max-multiplicity", 1),
    (_ATLAS + ["--links", "6"], "--max-link-degree", 1), (_ATLAS + ["--links", "6"], "--workers", 1),
    (_ATLAS + ["--links", "6", "--html", "OUTDIR"], "--html-limit", 1),
    (_ATLAS + ["--links", "4", "--simple-joints", "--mechanisms"], "--curves", 1),
    (_SYNTH[:-2], "--budget", 1), (_SYNTH, "--tol", 1), (_SYNTH, "--seed", 1), (_SYNTH, "--min-transmission", 1),
    (_SYNTH, "--max-ratio", 1), (_SYNTH, "--length-bounds", 2),
    (_TOPO[:-4], "--budget", 1), (_TOPO, "--tol", 1), (_TOPO[:-2], "--top", 1), (_TOPO, "--seed", 1),
    (_TOPO[:7] + _TOPO[9:], "--links", 1),
]


def _option_argv(rng: random.Random) -> list[str]:
    """A command with one numeric option given hostile values (``--opt=v``: a negative one
    is a value, not an option)."""
    base, opt, n = rng.choice(OPTION_CASES)
    vals = [rng.choice(HOSTILE_OPTION_VALUES) for _ in range(n)]
    if opt == "--positions":
        return base + [f"--positions={','.join(vals)}"]
    return base + ([f"{opt}={vals[0]}"] if n == 1 else [opt, *vals])


# --- degenerate targets of synthesis ------------------------------------------------------
def _circle(r: float, n: int = 24) -> str:
    import math
    return "".join(f"{r * math.cos(2 * math.pi * k / n)!r},{r * math.sin(2 * math.pi * k / n)!r}\n" for k in range(n))


#: a target table each: bytes or text
DEGENERATE_TARGETS = {
    "same": "1,1\n" * 12, "tiny": _circle(1e-300), "subnormal": _circle(1e-320), "below_min": _circle(1e-13),
    "long_field": "x,y\n" + "1" * 140_000 + ",2\n1,2\n3,4\n5,6\n", "header": "x,y\n", "one_row": "1,2\n",
    "nan": "0,0\n1,nan\n2,1\n3,3\n", "inf": "0,0\n1,inf\n2,1\n", "huge": "0,0\n1e10,1\n2,1\n",
    "semicolon": "0;0\n1;0\n1;1\n0;1\n", "latin1": b"x,y\ncaf\xe9,1\n1,2\n3,4\n", "empty": "",
    "ragged": "0,0\n1,0,5\n1,1\n", "four_columns": "0,0,0,0\n1,1,1,1\n2,2,2,2\n", "quote": '0,0\n"1,0\n1,1\n',
    "bom_crlf": "\ufeff0,0\r\n1,0\r\n1,1\r\n0,1\r\n", "over_cap": b"x,y\n" + b"1,2\n" * (9 << 18),
    "words": "a,b\nc,d\ne,f\n", "big_circle": _circle(1e9), "line": "0,0\n1,0\n2,0\n3,0\n",
}
TARGET_COMMANDS = [
    ["synthesise", "four_bar", "--path", "FILE", "--out", "OUT.toml", "--budget", "1"],
    _TOPO[:2] + ["FILE"] + _TOPO[3:],
    ["synthesise", "four_bar", "--function", "FILE", "--output", "O4", "--out", "OUT.toml", "--budget", "1"],
    ["synthesise", "four_bar", "--motion", "FILE", "--link", "coupler", "--out", "OUT.toml", "--budget", "1"],
]


def degenerate_target(rng: random.Random) -> bytes:
    t = DEGENERATE_TARGETS[rng.choice(sorted(DEGENERATE_TARGETS))]
    return t if isinstance(t, bytes) else t.encode("utf-8")


# --- damaged curve atlases -------------------------------------------------------------------
ATLAS_COMMANDS = [
    ["synthesise", "--path", "TARGET", "--out", "OUT.toml", "--db", "FILE", "--links", "4", "--budget", "1",
     "--top", "1"],
    ["atlas", "--db", "FILE", "--query", "n = 4", "--json"], ["atlas", "--db", "FILE", "--json"],
    ["atlas", "--db", "FILE", "--html", "OUTDIR", "--no-progress"],
    ["atlas", "--links", "4", "--dof", "1", "--simple-joints", "--no-loops", "--mechanisms", "--curves", "6",
     "--db", "FILE", "--no-progress"],
]


def pristine_atlas(top: Path) -> Path | None:
    """A small curve atlas (the tests' four-bar atlas: its mechanisms, 6 realisations),
    or None without nauty or usearch."""
    import importlib.util
    from multiloop.catalogue.synthesis import nauty_available

    if not nauty_available() or importlib.util.find_spec("usearch") is None:
        return None
    sys.path.insert(0, str(ROOT))
    from tests.common import four_bar_curve_atlas
    return four_bar_curve_atlas(top / "pristine.sqlite")


def _hostile_stored(rng: random.Random, value):
    """A value to store in place of ``value``: for a BLOB its bytes cut, emptied, flipped
    or replaced; else NULL, text, JSON that does not parse, bytes that are not UTF-8 (as
    TEXT), zero, NaN (as text), huge or tiny numbers."""
    if isinstance(value, bytes) and value and rng.random() < 0.6:
        flipped = bytearray(value)
        for _ in range(rng.randint(1, 40)):
            flipped[rng.randrange(len(flipped))] ^= 1 << rng.randrange(8)
        return rng.choice([value[: rng.randrange(len(value))], b"", bytes(flipped), rng.randbytes(rng.randint(1, 300)),
                           value + b"\x00"])
    return rng.choice([None, "", "garbage", '{"x": [', "[[0, 99]]", '{"J1": [1]}', "[1, 2]", ("utf8", b"\xc3(\xff"),
                       0, -1, 2 ** 63 - 1, -(2 ** 63), 1e308, -1e308, "NaN", 1e-320, 0.5])


def _damage_table(rng: random.Random, con) -> None:
    import sqlite3
    tables = [r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")]
    t = rng.choice(tables)
    op = rng.random()
    if op < 0.08:
        con.executescript(f"DROP TABLE {t}")
    elif op < 0.18:
        con.executescript(f"DROP TABLE {t}; CREATE TABLE {t} (a TEXT, b BLOB); INSERT INTO {t} VALUES ('x', x'00')")
    elif op < 0.22:
        con.execute(f"DELETE FROM {t}")
    else:
        col = rng.choice([r[1] for r in con.execute(f"PRAGMA table_info({t})")])
        rows = con.execute(f"SELECT rowid, {col} FROM {t}").fetchall()
        if not rows:
            return
        rid, value = rng.choice(rows)
        new = _hostile_stored(rng, value)
        sql = f"UPDATE {t} SET {col} = CAST(? AS TEXT) WHERE rowid = ?" if isinstance(new, tuple) else \
            f"UPDATE {t} SET {col} = ? WHERE rowid = ?"
        for sql, args in ((sql, (new[1] if isinstance(new, tuple) else new, rid)),
                          (f"UPDATE {t} SET {col} = 'garbage' || rowid WHERE rowid = ?", (rid,)),   # NOT NULL, UNIQUE
                          (f"UPDATE {t} SET {col} = {col} + 1000 WHERE rowid = ?", (rid,))):       # a row id
            try:
                con.execute(sql, args)
                return
            except sqlite3.IntegrityError:
                continue


def damaged_atlas(rng: random.Random, pristine: Path) -> bytes:
    """The bytes of ``pristine`` with one stored value, one table or the file damaged."""
    import sqlite3
    data = pristine.read_bytes()
    r = rng.random()
    if r < 0.08:                              # the file's own bytes flipped
        b = bytearray(data)
        for _ in range(rng.randint(1, 20)):
            b[rng.randrange(100, len(b))] ^= 1 << rng.randrange(8)
        return bytes(b)
    if r < 0.12:
        return data[: rng.randrange(len(data))]
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d) / "a.sqlite"
        tmp.write_bytes(data)
        con = sqlite3.connect(tmp)
        _damage_table(rng, con)
        con.commit()
        con.close()
        return tmp.read_bytes()


def _number_argv(rng: random.Random) -> list[str]:
    big = ["1" + "0" * k for k in (19, 20, 40, 309, 400)] + [str(2 ** 63), str(-(2 ** 63) - 1)]
    num = rng.choice(big + ["nan", "inf", "-inf", "1e308", "-1e300", "0", "-1", "1e9", "1e10", "1e-320"])
    mech = rng.choice(["four_bar", "dyad_prp", "stephenson_3_triad", "crank_slider_loaded"])
    return rng.choice([
        ["solve", mech, "--steps", num], ["solve", mech, "--from", num, "--to", num, "--steps", "3"],
        ["solve", mech, "--from", "0", "--to", num, "--steps", "4"], ["forces", mech, "--at", num],
        ["forces", mech, "--steps", num], ["check", mech, "--at", num, "--json"],
        ["check", mech, "--min-transmission", num, "--json"], ["check", mech, f"--positions={num},{num}"],
        ["engine", "single_cylinder", "--steps", num],
        ["atlas", "--links", "6", "--dof", "1", "--db", "OUT.sqlite", "--limit", num, "--no-progress"],
        ["atlas", "--links", "6", "--dof", num, "--db", "OUT.sqlite", "--no-progress"],
        ["atlas", "--links", num, "--dof", "1", "--db", "OUT.sqlite", "--no-progress"],
        ["atlas", "--links", "6", "--dof", "1", "--db", "OUT.sqlite", "--max-multiplicity", num, "--no-progress"],
        ["atlas", "--links", "6", "--dof", "1", "--db", "OUT.sqlite", "--query", f"K = {num}", "--no-progress"],
    ])


def _special_file(rng: random.Random) -> tuple[str, bytes | str, list[str]]:
    kind = rng.choice(["fifo", "dev_zero", "dev_null", "directory", "dangling", "big", "empty", "deep_yaml",
                       "alias_yaml", "deep_json"])
    suffix = rng.choice([".toml", ".json", ".pyslvs"])
    content = {"big": b"# " + b"x" * (9 << 20), "empty": b"",
               "deep_yaml": b"[" * 60_000 + b"]" * 60_000,
               "alias_yaml": b"a: &a [x, x, x, x, x, x, x, x]\nb: &b [*a, *a, *a, *a, *a, *a, *a, *a]\n"
                             b"c: [*b, *b, *b, *b, *b, *b, *b, *b]\nmechanism: x\n",
               "deep_json": b"[" * 60_000 + b"]" * 60_000}.get(kind, kind)
    return f"m{suffix}", content, ["FILE"]


def _place(work: Path, name: str | None, content) -> Path | None:
    if name is None:
        return None
    p = work.parent / name
    if content == "fifo":
        os.mkfifo(p)
    elif content == "dev_zero":
        p.symlink_to("/dev/zero")
    elif content == "dev_null":
        p.symlink_to("/dev/null")
    elif content == "directory":
        p.mkdir()
    elif content == "dangling":
        p.symlink_to(work.parent / "nothing-there")
    else:
        p.write_bytes(content)
    return p


def _argv(rng: random.Random, kind: str, argv: list[str], path: Path | None) -> list[str]:
    if argv == ["FILE"]:
        cmd = rng.choice(MECH_COMMANDS)
        argv = [cmd[0], "FILE", *cmd[1:]] if kind != "special" else [rng.choice(["analyse", "solve", "convert"]), "FILE"]
        if argv[0] == "convert" and len(argv) == 2:
            argv.append("OUT.toml")
        elif argv[0] != "convert":
            argv = [a for a in argv if not a.startswith("OUT")]
        if argv[0] in ("solve", "forces") and rng.random() < 0.1:
            argv += ["--plot", "OUT.png"]
    return [str(path) if a == "FILE" else a for a in argv]


def _materialise(argv: list[str], work: Path, seeds: dict) -> list[str]:
    """The placeholders of the shared inputs: TARGET (a path target) and ATLAS (a copy of
    the pristine curve atlas) beside the working directory, OUTDIR (a directory output)."""
    out = []
    for a in argv:
        if a == "TARGET":
            a = work.parent / "target.csv"
            a.write_bytes(seeds[TARGET])
        elif a == "ATLAS" and seeds[ATLAS] is not None:
            a = work.parent / "atlas.sqlite"
            a.write_bytes(seeds[ATLAS].read_bytes())
        elif a == "OUTDIR":
            a = "OUTDIR"
        out.append(str(a))
    return out


def _read_back_problem(argv: list[str], work: Path) -> str | None:
    """For a ``convert`` that succeeded: the output read back has the input's canonical form."""
    from multiloop.inputs import load_mechanism
    from multiloop.topo.io import mechanism_to_dict
    from multiloop.topo.isomorphism import canonical_form

    src, out = load_mechanism(argv[1]), work / argv[2]
    back = load_mechanism(out)
    suffix = out.suffix
    if suffix in (".toml", ".json"):
        same = json.dumps(mechanism_to_dict(back), sort_keys=True) == json.dumps(mechanism_to_dict(src), sort_keys=True)
    else:
        same = canonical_form(back, "chain") == canonical_form(src, "chain") and (
            suffix == ".expr" or canonical_form(back, "mechanism") == canonical_form(src, "mechanism"))
    return None if same else f"convert to {suffix}: the file read back has another canonical form"


class _Timeout(BaseException):
    pass


#: Newton solves one case may make (the count that bounds its work; the alarms below are
#: only safety nets)
MAX_NEWTON = 200_000
#: CPU seconds of this process before a case is stopped as hung (CPU, not wall time: the
#: verdict does not depend on the machine's load)
ALARM = 300
#: wall seconds before a case is stopped as hung whatever its CPU (a process that waits)
WALL_ALARM = 1800
_NEWTON = [0]


def _count_newton() -> None:
    """Count the Newton solves of :mod:`multiloop.kin.groups.newton` (every tracked group's
    continuation makes them)."""
    import multiloop.kin.groups.newton as nw
    real = nw.newton

    def counted(*a, **k):
        _NEWTON[0] += 1
        return real(*a, **k)
    nw.newton = counted


def run_case(rng: random.Random, seeds, index: int, top: Path) -> dict:
    from multiloop.cli import main

    kind, name, content, argv = make_case(rng, seeds)
    case = top / f"c{index}"
    work = case / "work"
    work.mkdir(parents=True)
    (work / "keep.txt").write_text("sentinel\n")
    (work / "keepdir").mkdir()
    path = _place(work, name, content)
    argv = _materialise(_argv(rng, kind, argv, path), work, seeds)
    changes = kind == "atlas"                 # an atlas is opened for writing (a resumed build)
    before = path.read_bytes() if path is not None and path.is_file() and not path.is_symlink() \
        and not changes else None
    out, err = io.StringIO(), io.StringIO()
    cwd = os.getcwd()
    os.chdir(work)
    t0, c0 = time.perf_counter(), time.process_time()
    for sig in (signal.SIGALRM, signal.SIGPROF):
        signal.signal(sig, lambda *a: (_ for _ in ()).throw(_Timeout()))
    signal.setitimer(signal.ITIMER_PROF, ALARM)
    signal.alarm(WALL_ALARM)
    _NEWTON[0] = 0
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main(argv)
    except _Timeout:
        code = "timeout"
    except SystemExit as exc:        # argparse
        code = exc.code
    except BaseException as exc:     # noqa: BLE001 - recorded as a failure
        code = f"raised {type(exc).__name__}"
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0)
        signal.alarm(0)
        os.chdir(cwd)
    seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
    msg = err.getvalue()
    problems = []
    if code not in (0, 2):
        problems.append(f"exit {code}")
    if _NEWTON[0] > MAX_NEWTON:
        problems.append(f"{_NEWTON[0]} Newton solves (at most {MAX_NEWTON})")
    if "Traceback" in msg or "internal error" in msg:
        problems.append("traceback or internal error")
    if len(msg.encode("utf-8", "replace")) >= 10_000:
        problems.append(f"message of {len(msg)} characters")
    if (work / "keep.txt").read_text() != "sentinel\n" or not (work / "keepdir").is_dir():
        problems.append("a sentinel was destroyed")
    if before is not None and path.read_bytes() != before:
        problems.append("the input file changed")
    left = {p.name for p in work.iterdir()} - {"keep.txt", "keepdir"}
    if code != 0 and left:
        problems.append(f"a failed run left {sorted(left)}")
    if code == 0 and argv[0] == "convert":
        try:
            problem = _read_back_problem(argv, work)
        except Exception as exc:  # noqa: BLE001
            problem = f"convert output not read back: {type(exc).__name__}: {str(exc)[:200]}"
        if problem:
            problems.append(problem)
    shutil.rmtree(case, ignore_errors=True)
    return {"kind": kind, "argv": [a[:80] for a in argv], "code": code, "seconds": round(seconds, 3),
            "cpu": cpu, "newton": _NEWTON[0], "problems": problems, "stderr": msg[-400:] if problems else ""}


def _shared_inputs(top: Path) -> dict:
    """The driver moves, the pristine curve atlas and a path target (the four-bar's curve)."""
    import numpy as np
    from multiloop.inputs import load_mechanism
    from multiloop.kin.solve import solve

    st = solve(load_mechanism("four_bar"), np.radians(np.arange(0.0, 360.0, 15.0)))
    target = "".join(f"{x!r},{y!r}\n" for x, y in st.point_positions[:, 0])
    return {MOVES: driver_moves(), ATLAS: pristine_atlas(top), TARGET: target.encode()}


def main(n: int, seed: int, memory_mb: int | None = None) -> dict:
    if memory_mb:
        limit = memory_mb << 20
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    import matplotlib
    matplotlib.use("Agg")
    _count_newton()
    rng = random.Random(seed)
    seeds = _seed_texts()
    counts: dict[str, int] = {}
    kinds: dict[str, int] = {}
    cpu: dict[str, float] = {}                # CPU seconds by kind
    failures = []
    slowest = (0.0, None)
    most_newton = (0, None)
    with tempfile.TemporaryDirectory() as top:
        seeds.update(_shared_inputs(Path(top)), **{CHECKS: n >= CHECK_MOVES_FROM})
        _MOVES_MADE[0] = 2 * (seed * 7919 % len(seeds[MOVES]))     # another seed, other moves first
        for i in range(n):
            r = run_case(random.Random(rng.getrandbits(64)), seeds, i, Path(top))
            counts[str(r["code"])] = counts.get(str(r["code"]), 0) + 1
            kinds[r["kind"]] = kinds.get(r["kind"], 0) + 1
            cpu[r["kind"]] = round(cpu.get(r["kind"], 0.0) + r["cpu"], 1)
            if r["problems"]:
                failures.append(r)
            if r["seconds"] > slowest[0]:
                slowest = (r["seconds"], r["argv"])
            if r["newton"] > most_newton[0]:
                most_newton = (r["newton"], r["argv"])
    moves = {"moves": len(seeds[MOVES]), "solved": len(MOVES_MET["solve"]), "checked": len(MOVES_MET["check"])}
    return {"cases": n, "seed": seed, "memory_mb": memory_mb, "by_exit_code": counts, "by_kind": kinds,
            "cpu_by_kind": cpu,
            "driver_moves": moves, "failures": failures, "slowest": slowest, "most_newton": most_newton}


if __name__ == "__main__":
    n, seed = int(sys.argv[1]), int(sys.argv[2])
    mem = int(sys.argv[3]) if len(sys.argv) > 3 else None
    print(json.dumps(main(n, seed, mem), ensure_ascii=True))
