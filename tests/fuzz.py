"""Seeded fuzzing of the command line (the stage of tests/test_hostile.py, run in a child
process under a memory cap).

Each case is a file (a mutation of a TOML, JSON or ``.pyslvs`` mechanism, an engine or a
platform file; a huge integer in a numeric field; a non-regular file) plus an argument
set, or an argument set alone (huge or out-of-range numbers).  Every case runs
``multiloop.cli.main`` in an empty working directory that holds a sentinel file and a
sentinel directory, and must

* exit 0 or 2, print no traceback and no "internal error";
* print less than 10 kB on stderr;
* destroy nothing: the input file, the sentinels and nothing else left behind
  (besides the outputs of a run that succeeded);
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


def make_case(rng: random.Random, seeds: dict[str, str]) -> tuple[str, str | None, bytes | None, list[str]]:
    """(kind, file name, file bytes, argv with FILE / OUT.* placeholders)."""
    from multiloop.topo.io import mechanism_to_dict
    from multiloop.inputs import load_mechanism

    r = rng.random()
    if r < 0.30:
        seed = rng.choice(TOML_SEEDS)
        return "toml", "m.toml", mutate_text(rng, seeds[seed]), ["FILE"]
    if r < 0.50:
        seed = rng.choice(TOML_SEEDS)
        doc = mechanism_to_dict(load_mechanism(CAT / seed))
        data = mutate_json(rng, doc) if rng.random() < 0.7 else mutate_mild(rng, json.dumps(doc))
        return "json", "m.json", data, ["FILE"]
    if r < 0.68:
        seed = rng.choice([k for k in seeds if k.endswith(".pyslvs")])
        return "pyslvs", "m.pyslvs", mutate_text(rng, seeds[seed]), ["FILE"]
    if r < 0.74:
        return "engine", "e.toml", mutate_text(rng, seeds[ENGINE_SEED]), ["engine", "FILE", "--steps", "16",
                                                                         "--no-check"]
    if r < 0.78:
        return "platform", "p.toml", mutate_text(rng, seeds[PLATFORM_SEED]), ["platform", "FILE"]
    if r < 0.90:
        return "numbers", None, None, _number_argv(rng)
    return "special", *_special_file(rng)


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


def run_case(rng: random.Random, seeds, index: int, top: Path) -> dict:
    from multiloop.cli import main

    kind, name, content, argv = make_case(rng, seeds)
    case = top / f"c{index}"
    work = case / "work"
    work.mkdir(parents=True)
    (work / "keep.txt").write_text("sentinel\n")
    (work / "keepdir").mkdir()
    path = _place(work, name, content)
    argv = _argv(rng, kind, argv, path)
    before = path.read_bytes() if path is not None and path.is_file() and not path.is_symlink() else None
    out, err = io.StringIO(), io.StringIO()
    cwd = os.getcwd()
    os.chdir(work)
    t0 = time.perf_counter()
    signal.signal(signal.SIGALRM, lambda *a: (_ for _ in ()).throw(_Timeout()))
    signal.alarm(60)
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
        signal.alarm(0)
        os.chdir(cwd)
    seconds = time.perf_counter() - t0
    msg = err.getvalue()
    problems = []
    if code not in (0, 2):
        problems.append(f"exit {code}")
    if "Traceback" in msg or "internal error" in msg:
        problems.append("traceback or internal error")
    if len(msg.encode("utf-8", "replace")) >= 10_000:
        problems.append(f"message of {len(msg)} characters")
    if (work / "keep.txt").read_text() != "sentinel\n" or not (work / "keepdir").is_dir():
        problems.append("a sentinel was destroyed")
    if before is not None and path.read_bytes() != before:
        problems.append("the input file changed")
    left = {p.name for p in work.iterdir()} - {"keep.txt", "keepdir"}
    if code != 0 and left - {"OUT.sqlite"}:
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
            "problems": problems, "stderr": msg[-400:] if problems else ""}


def main(n: int, seed: int, memory_mb: int | None = None) -> dict:
    if memory_mb:
        limit = memory_mb << 20
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    import matplotlib
    matplotlib.use("Agg")
    rng = random.Random(seed)
    seeds = _seed_texts()
    counts: dict[str, int] = {}
    kinds: dict[str, int] = {}
    failures = []
    slowest = (0.0, None)
    with tempfile.TemporaryDirectory() as top:
        for i in range(n):
            r = run_case(random.Random(rng.getrandbits(64)), seeds, i, Path(top))
            counts[str(r["code"])] = counts.get(str(r["code"]), 0) + 1
            kinds[r["kind"]] = kinds.get(r["kind"], 0) + 1
            if r["problems"]:
                failures.append(r)
            if r["seconds"] > slowest[0]:
                slowest = (r["seconds"], r["argv"])
    return {"cases": n, "seed": seed, "memory_mb": memory_mb, "by_exit_code": counts, "by_kind": kinds,
            "failures": failures, "slowest": slowest}


if __name__ == "__main__":
    n, seed = int(sys.argv[1]), int(sys.argv[2])
    mem = int(sys.argv[3]) if len(sys.argv) > 3 else None
    print(json.dumps(main(n, seed, mem), ensure_ascii=True))
