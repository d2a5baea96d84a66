"""Read and write mechanism files (TOML for people, JSON accepted too).

The format is the file format (README), extended with mass data, loads, gravity and driver speeds.
Every malformed input raises :class:`~topo.errors.InputError` naming the table and
key at fault; nothing is half-read.

Top-level keys
--------------
``name``, ``description``, ``source`` (strings); ``joints`` (bare-chain short form:
a list of link-name lists, all pins); ``gravity = [gx, gy]`` (m/s^2);
``[[link]]`` (``name``, ``frame``, ``mass``, ``cg``, ``inertia``, ``color``);
``[[joint]]`` (``name``, ``kind`` R/P, ``links``, ``at``, ``axis``);
``[[driver]]`` (``joint``, optional ``links`` = the two links whose relative motion is
the input, ``speed``, ``acceleration``); ``[[point]]`` (``name``, ``link``, ``at``);
``[[force]]`` (``link``, ``at``, ``value`` = [Fx, Fy], ``table`` = [[deg, Fx, Fy], ...],
``moment``, ``name``).
"""
from __future__ import annotations

import json
import math
import os
import stat
import sys
from pathlib import Path
from typing import Any, Iterable

import numpy as np

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

from .errors import InputError, explain
from .model import Driver, Joint, JointKind, Link, Load, Mechanism, MechanismBuilder, TracerPoint

__all__ = ["load", "loads", "mechanism_from_dict", "mechanism_to_dict", "dumps_toml",
           "dumps_json", "read_document", "read_number", "read_vector", "read_string", "read_bool",
           "read_names", "read_table", "read_tables", "table_label", "read_input_bytes", "MAX_DEPTH",
           "MAX_INPUT_BYTES"]

_TOP_KEYS = {"name", "description", "source", "joints", "link", "joint", "driver", "point",
             "force", "gravity", "reconstruction", "notes"}
_TABLE_KEYS = {
    "link": {"name", "frame", "mass", "cg", "inertia", "color"},
    "joint": {"name", "kind", "links", "at", "axis", "range"},
    "driver": {"joint", "links", "speed", "acceleration", "range"},
    "point": {"name", "link", "at"},
    "force": {"link", "at", "value", "table", "moment", "name"},
}
_REQUIRED = {"link": ("name",), "joint": ("name", "links"), "driver": ("joint",),
             "point": ("name", "link", "at"), "force": ("link",)}


#: deepest nesting of tables and arrays a document may have (a mechanism needs 4)
MAX_DEPTH = 64

#: largest input file read (bytes); the biggest bundled mechanism file is under 5 kB
MAX_INPUT_BYTES = 8 << 20


def read_document(path: str | Path) -> dict[str, Any]:
    """Parse a ``.toml`` or ``.json`` file into a dict (no interpretation).

    UTF-8 with or without a byte-order mark.  A JSON object may not repeat a key,
    and no document may nest tables and arrays deeper than :data:`MAX_DEPTH`.

    Raises
    ------
    InputError
        Missing or unreadable file (permission, directory), undecodable bytes,
        unknown suffix, syntax error, repeated JSON key, nesting too deep.
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in (".json", ".toml"):
        if p.is_dir():
            raise InputError(explain(f"file '{p}'", expected="a file", got="a directory"))
        raise InputError(explain(f"file '{p}'", expected="a .toml or .json file",
                                 got=f"suffix '{suffix or '(none)'}'"))
    text = _read_text(p)
    return _parse_json(text, str(p)) if suffix == ".json" else _parse_toml(text, str(p))


def read_input_bytes(path: str | Path, limit: int = MAX_INPUT_BYTES) -> bytes:
    """The bytes of a regular input file of at most ``limit`` bytes.

    A FIFO, a device (``/dev/zero``), a socket or a directory is refused before anything
    is read, so a bad path can neither hang the reader nor exhaust the memory.

    Raises
    ------
    InputError
        Missing, unreadable or non-regular file; a file larger than ``limit``.
    """
    p = Path(path)
    try:
        fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except FileNotFoundError:
        raise InputError(explain(f"file '{p}'", expected="an existing file", got="nothing there")) from None
    except IsADirectoryError:
        raise InputError(explain(f"file '{p}'", expected="a file", got="a directory")) from None
    except PermissionError:
        raise InputError(explain(f"file '{p}'", expected="a readable file", got="permission denied",
                                 hint="check the file's permissions")) from None
    except OSError as exc:
        raise InputError(explain(f"file '{p}'", expected="a readable file",
                                 got=exc.strerror or type(exc).__name__)) from None
    with os.fdopen(fd, "rb") as f:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            kind = ("a directory" if stat.S_ISDIR(mode) else "a FIFO (named pipe)" if stat.S_ISFIFO(mode)
                    else "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else "not a regular file")
            raise InputError(explain(f"file '{p}'", expected="a regular file", got=kind,
                                     hint="save the input to a file first"))
        try:
            data = f.read(limit + 1)
        except OSError as exc:
            raise InputError(explain(f"file '{p}'", expected="a readable file",
                                     got=exc.strerror or type(exc).__name__)) from None
    if len(data) > limit:
        raise InputError(explain(f"file '{p}'", expected=f"at most {limit >> 20} MiB",
                                 got="a larger file", hint="an input file describes one mechanism or one target"))
    return data


def _read_text(p: Path) -> str:
    """The file's text as UTF-8 (a leading byte-order mark is dropped)."""
    data = read_input_bytes(p)
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(explain(f"file '{p}'", expected="UTF-8 text",
                                 got=f"undecodable bytes ({exc.reason})")) from None


def _too_deep(where: str) -> InputError:
    return InputError(explain(where, expected=f"tables and arrays nested at most {MAX_DEPTH} deep",
                              got="deeper nesting"))


def _check_depth(doc: Any, where: str) -> None:
    """Raise when ``doc`` nests dicts/lists deeper than :data:`MAX_DEPTH` (iterative)."""
    stack = [(doc, 1)]
    while stack:
        value, depth = stack.pop()
        if depth > MAX_DEPTH:
            raise _too_deep(where)
        children = value.values() if isinstance(value, dict) else value
        stack.extend((c, depth + 1) for c in children if isinstance(c, (dict, list)))


def _parse_toml(text: str, where: str) -> dict[str, Any]:
    try:
        doc = tomllib.loads(text.removeprefix("\ufeff"))
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{where}: TOML syntax error: {exc}") from None
    except ValueError as exc:   # an integer of more than 4300 digits
        raise InputError(explain(where, expected="numbers of a sensible size", got=str(exc)[:120])) from None
    except RecursionError:
        raise _too_deep(where) from None
    _check_depth(doc, where)
    return doc


def _unique_keys(where: str):
    def hook(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for key, value in pairs:
            if key in out:
                raise InputError(explain(f"{where}: JSON object", expected="each key once",
                                         got=f"key {key!r} twice", hint="remove or rename one of them"))
            out[key] = value
        return out
    return hook


def _parse_json(text: str, where: str) -> dict[str, Any]:
    try:
        doc = json.loads(text.removeprefix("\ufeff"), object_pairs_hook=_unique_keys(where))
    except json.JSONDecodeError as exc:
        raise InputError(f"{where}: JSON syntax error: {exc.msg} at line {exc.lineno} column {exc.colno}") from None
    except InputError:
        raise
    except ValueError as exc:   # an integer of more than 4300 digits
        raise InputError(explain(where, expected="numbers of a sensible size", got=str(exc)[:120])) from None
    except RecursionError:
        raise _too_deep(where) from None
    if not isinstance(doc, dict):
        raise InputError(explain(f"{where}", expected="a JSON object at top level",
                                 got=type(doc).__name__))
    _check_depth(doc, where)
    return doc


def load(path: str | Path) -> Mechanism:
    """Read a mechanism or bare chain from a TOML or JSON file.

    Raises
    ------
    InputError
        Unknown suffix, syntax error, unknown key, wrong type (the table/key is named).
    TopologyError
        Disconnected chain and other graph-level faults.
    """
    doc = read_document(path)
    try:
        return mechanism_from_dict(doc)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None


def loads(text: str, fmt: str = "toml", where: str = "<string>") -> Mechanism:
    """Parse a mechanism from a TOML (default) or JSON string; ``where`` names it in
    messages (e.g. the name of an uploaded file)."""
    doc = _parse_json(text, where) if fmt == "json" else _parse_toml(text, where)
    try:
        return mechanism_from_dict(doc)
    except InputError as exc:
        if where == "<string>":
            raise
        raise InputError(f"{where}: {exc}") from None


# ---------------------------------------------------------------------------------
# typed readers: every parser of a TOML/JSON document (mechanisms, engines,
# platforms) reads its values through these, so every message has the same form.
def read_number(value: Any, where: str, *, positive: bool = False, non_negative: bool = False,
                unit: str | None = None) -> float:
    """A finite number (``bool`` is not a number), optionally ``> 0`` or ``>= 0``.

    Raises
    ------
    InputError
        Naming ``where``, e.g. ``"[[link]] #2 ('crank') mass: expected a number >= 0, got -1"``.

    Examples
    --------
    >>> read_number(2, "mass")
    2.0
    >>> read_number(-1, "mass", non_negative=True, unit="kg")
    Traceback (most recent call last):
    ...
    multiloop.topo.errors.InputError: mass: expected a number >= 0 (kg), got -1
    """
    noun = "a positive number" if positive else ("a number >= 0" if non_negative else "a number")
    noun += f" ({unit})" if unit else ""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InputError(explain(where, expected=noun, got=repr(value)[:60]))
    try:
        f = float(value)
    except OverflowError:   # an integer beyond the float range
        raise InputError(explain(where, expected=noun.replace("a ", "a finite ", 1),
                                 got=f"an integer of {int(value).bit_length()} bits, beyond the float range")) from None
    if not math.isfinite(f):
        raise InputError(explain(where, expected=noun.replace("a ", "a finite ", 1), got=repr(value)[:60]))
    if (positive and f <= 0) or (non_negative and f < 0):
        raise InputError(explain(where, expected=noun, got=repr(value)[:60]))
    return f


_VECTOR_NOUNS = {2: "a pair of numbers [x, y]", 3: "3 numbers [x, y, z]"}


def read_vector(value: Any, where: str, n: int = 2) -> tuple[float, ...]:
    """``n`` finite numbers given as a list (default a pair ``[x, y]``).

    Examples
    --------
    >>> read_vector([1, 2.5], "at")
    (1.0, 2.5)
    """
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise InputError(explain(where, expected=_VECTOR_NOUNS.get(n, f"{n} numbers"),
                                 got=repr(value)[:60]))
    return tuple(read_number(v, where) for v in value)


def read_string(value: Any, where: str, *, allow_empty: bool = False) -> str:
    """A string (non-empty unless ``allow_empty``)."""
    if not isinstance(value, str) or not (value or allow_empty):
        raise InputError(explain(where, expected="a string" if allow_empty else "a non-empty string",
                                 got=repr(value)[:60]))
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:   # a lone surrogate (JSON "\ud800") cannot be written back
        raise InputError(explain(where, expected="a string of Unicode characters",
                                 got=f"a lone surrogate in {ascii(value)[:60]}")) from None
    return value


def read_bool(value: Any, where: str) -> bool:
    """``true`` or ``false`` (not 0/1)."""
    if not isinstance(value, bool):
        raise InputError(explain(where, expected="true or false", got=repr(value)[:60]))
    return value


def read_names(value: Any, where: str) -> tuple[str, ...]:
    """A list of non-empty names."""
    if not isinstance(value, (list, tuple)):
        raise InputError(explain(where, expected="a list of link names", got=repr(value)[:60]))
    return tuple(read_string(v, where) for v in value)


def read_table(value: Any, label: str, keys: Iterable[str] | None = None,
               required: Iterable[str] = (), hint: str | None = None) -> dict:
    """A table whose keys are all among ``keys`` (when given) and include ``required``."""
    if not isinstance(value, dict):
        raise InputError(explain(label, expected="a table", got=repr(value)[:60]))
    if keys is not None:
        allowed = set(keys)
        unknown = sorted(set(value) - allowed)
        if unknown:
            raise InputError(explain(label, expected=f"keys among {', '.join(sorted(allowed))}",
                                     got=f"unknown key {', '.join(repr(u) for u in unknown)}", hint=hint))
    for key in required:
        if key not in value:
            raise InputError(explain(label, expected=f"key '{key}'", got="nothing"))
    return value


def read_tables(doc: dict, key: str) -> list[dict]:
    """The array of tables ``[[key]]`` of a document (a single table is accepted)."""
    raw = doc.get(key, [])
    if isinstance(raw, dict):
        raw = [raw]
    if not isinstance(raw, list) or not all(isinstance(t, dict) for t in raw):
        raise InputError(explain(f"[[{key}]]", expected="an array of tables", got=repr(raw)[:60]))
    return raw


def table_label(key: str, i: int, t: dict) -> str:
    """``[[key]] #i ('name')``: how messages name the i-th (1-based) table."""
    name = t.get("name")
    return f"[[{key}]] #{i}" + (f" ('{name}')" if isinstance(name, str) and name else "")


def _tables(doc: dict, key: str) -> list[tuple[str, dict]]:
    out = []
    for i, t in enumerate(read_tables(doc, key), 1):
        label = table_label(key, i, t)
        read_table(t, label, _TABLE_KEYS[key], _REQUIRED[key])
        out.append((label, t))
    return out


def mechanism_from_dict(doc: dict[str, Any]) -> Mechanism:
    """Build a :class:`Mechanism` from a parsed document (strict, see module doc).

    The document is read table by table into a :class:`MechanismBuilder`, whose
    ``build`` then validates the mechanism as a whole.
    """
    if not isinstance(doc, dict):
        raise InputError(explain("document", expected="a table", got=type(doc).__name__))
    unknown = sorted(set(doc) - _TOP_KEYS)
    if unknown:
        raise InputError(explain("top level", expected=f"keys among {', '.join(sorted(_TOP_KEYS))}",
                                 got=f"unknown key {', '.join(repr(u) for u in unknown)}",
                                 hint="tables are written [[link]], [[joint]], [[driver]], [[point]], [[force]]"))
    b = MechanismBuilder()
    _read_header(doc, b)
    b.links += [_read_link(label, t) for label, t in _tables(doc, "link")]
    b.joints += [_read_joint(label, t) for label, t in _tables(doc, "joint")]
    for label, t in _tables(doc, "driver"):
        jn = read_string(t["joint"], f"{label} joint")
        b.add_driver(jn, read_names(t["links"], f"{label} links") if "links" in t else None,
                     read_number(t["speed"], f"{label} speed") if "speed" in t else None,
                     read_number(t["acceleration"], f"{label} acceleration") if "acceleration" in t else None,
                     _read_range(label, t["range"], b.joints, jn) if "range" in t else None)
    b.points += [TracerPoint(read_string(t["name"], f"{label} name"), read_string(t["link"], f"{label} link"),
                             read_vector(t["at"], f"{label} at")) for label, t in _tables(doc, "point")]
    b.loads += [_read_force(label, t) for label, t in _tables(doc, "force")]
    return b.build()


def _read_header(doc: dict, b: MechanismBuilder) -> None:
    """Name, description, source, gravity and the bare-chain short form ``joints``."""
    for key in ("name", "description", "source"):
        if key in doc:
            setattr(b, key, read_string(doc[key], f"top-level key '{key}'"))
    if "gravity" in doc:
        b.gravity = read_vector(doc["gravity"], "top-level key 'gravity'")
    if "joints" in doc:
        if "joint" in doc:
            raise InputError(explain("top level", expected="either 'joints' (bare chain) or [[joint]] tables",
                                     got="both"))
        jl = doc["joints"]
        if not isinstance(jl, list) or not jl:
            raise InputError(explain("key 'joints'", expected="a non-empty list of link-name lists", got=repr(jl)[:60]))
        for i, lks in enumerate(jl, 1):
            b.add_joint(f"J{i}", "R", read_names(lks, f"joints[{i - 1}]"))


def _read_link(label: str, t: dict) -> Link:
    return Link(read_string(t["name"], f"{label} name"), read_bool(t.get("frame", False), f"{label} frame"),
                read_number(t["mass"], f"{label} mass") if "mass" in t else None,
                read_vector(t["cg"], f"{label} cg") if "cg" in t else None,
                read_number(t["inertia"], f"{label} inertia") if "inertia" in t else None,
                read_string(t["color"], f"{label} color") if "color" in t else None)


def _read_range(label: str, value: Any, joints, jn: str) -> tuple[float, float]:
    """A driver's ``range = [low, high]`` in the file's units (degrees for an R joint, m
    for a P joint), returned in rad or m; the builder checks low < high and that it
    contains the reference."""
    kind = next((j.kind for j in joints if j.name == jn), None)
    rotary = kind is not None and JointKind(kind).is_rotary
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise InputError(explain(f"{label} range", expected="[low, high] (" + ("deg" if rotary else "m")
                                 + ", from the reference)", got=repr(value)[:60]))
    lo, hi = (read_number(v, f"{label} range", unit="deg" if rotary else "m") for v in value)
    return (math.radians(lo), math.radians(hi)) if rotary else (lo, hi)


def _read_joint(label: str, t: dict) -> Joint:
    if "range" in t:
        name = t.get("name")
        raise InputError(explain(f"{label} range", expected="a range only in a [[driver]] table",
                                 got=f"a range on [[joint]] {name!r} (a joint, not a driver)",
                                 hint=f"write it as [[driver]] joint = {name!r} range = [low, high]"))
    kind = t.get("kind", "R")
    if kind not in ("R", "P"):
        raise InputError(explain(f"{label} kind", expected="'R' or 'P'", got=repr(kind)))
    return Joint(read_string(t["name"], f"{label} name"), JointKind(kind), read_names(t["links"], f"{label} links"),
                 read_vector(t["at"], f"{label} at") if "at" in t else None,
                 read_vector(t["axis"], f"{label} axis") if "axis" in t else None)


def _read_force(label: str, t: dict) -> Load:
    if "table" in t and "value" in t:
        raise InputError(explain(label, expected="either 'value' (a constant force) or 'table' (force against "
                                 "the input)", got="both", hint="a table already gives the force at every input"))
    return Load(read_string(t["link"], f"{label} link"),
                read_vector(t["at"], f"{label} at") if "at" in t else None,
                read_vector(t["value"], f"{label} value") if "value" in t else (0.0, 0.0),
                _read_force_table(label, t["table"]) if "table" in t else None,
                read_number(t["moment"], f"{label} moment") if "moment" in t else 0.0,
                read_string(t["name"], f"{label} name") if "name" in t else None)


def _read_force_table(label: str, rows: Any) -> tuple[tuple[float, float, float], ...]:
    """Rows ``[input_deg, Fx, Fy]`` with distinct input angles."""
    if not isinstance(rows, list) or not rows:
        raise InputError(explain(f"{label} table", expected="rows [input_deg, Fx, Fy]", got=repr(rows)[:60]))
    table = []
    for r, row in enumerate(rows):
        if not isinstance(row, list) or len(row) != 3:
            raise InputError(explain(f"{label} table row {r}", expected="[input_deg, Fx, Fy]", got=repr(row)[:60]))
        table.append(tuple(read_number(x, f"{label} table row {r}") for x in row))
    seen: set[float] = set()
    dup = sorted({row[0] for row in table if row[0] in seen or seen.add(row[0])})
    if dup:
        raise InputError(explain(f"{label} table", expected="distinct input angles",
                                 got=f"{', '.join(f'{a:g}' for a in dup)} deg more than once"))
    return tuple(table)


def mechanism_to_dict(m: Mechanism) -> dict[str, Any]:
    """The document form of a mechanism (round-trips through :func:`mechanism_from_dict`)."""
    doc: dict[str, Any] = {}
    for key in ("name", "description", "source"):
        if getattr(m, key):
            doc[key] = getattr(m, key)
    if m.gravity is not None:
        doc["gravity"] = list(m.gravity)
    links = []
    for lk in m.links:
        t: dict[str, Any] = {"name": lk.name}
        if lk.is_frame:
            t["frame"] = True
        for key in ("mass", "inertia", "color"):
            if getattr(lk, key) is not None:
                t[key] = getattr(lk, key)
        if lk.cg is not None:
            t["cg"] = list(lk.cg)
        links.append(t)
    doc["link"] = links
    joints = []
    for j in m.joints:
        t = {"name": j.name, "kind": j.kind.value, "links": list(j.links)}
        if j.at is not None:
            t["at"] = list(j.at)
        if j.axis is not None:
            t["axis"] = list(j.axis)
        joints.append(t)
    doc["joint"] = joints
    if m.drivers:
        doc["driver"] = []
        for d in m.drivers:
            t = {"joint": d.joint, "links": list(d.links)}
            if d.speed is not None:
                t["speed"] = d.speed
            if d.acceleration is not None:
                t["acceleration"] = d.acceleration
            if d.range is not None:
                rotary = m.is_rotary(d)
                t["range"] = [math.degrees(v) if rotary else v for v in d.range]
            doc["driver"].append(t)
    if m.points:
        doc["point"] = [{"name": p.name, "link": p.link, "at": list(p.at)} for p in m.points]
    if m.loads:
        doc["force"] = []
        for ld in m.loads:
            t = {"link": ld.link}
            if ld.table is None:
                t["value"] = list(ld.value)
            if ld.at is not None:
                t["at"] = list(ld.at)
            if ld.table is not None:
                t["table"] = [list(r) for r in ld.table]
            if ld.moment:
                t["moment"] = ld.moment
            if ld.name:
                t["name"] = ld.name
            doc["force"].append(t)
    return doc


def _toml_value(v: Any) -> str:
    """One TOML value on one line: a string, bool, number or (nested) array."""
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False).replace("\x7f", "\\u007f")  # TOML escapes DEL too
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    return "[" + ", ".join(_toml_value(x) for x in v) + "]"


def _toml_pair(key: str, v: Any) -> str:
    """``key = value``; an array of arrays (a force table) gets one row per line."""
    if isinstance(v, list) and v and all(isinstance(x, list) for x in v):
        return f"{key} = [\n" + "".join(f"    {_toml_value(x)},\n" for x in v) + "]"
    return f"{key} = {_toml_value(v)}"


def dumps_toml(m: Mechanism) -> str:
    """TOML text of a mechanism in the layout of the catalogue files: the header keys,
    then one ``[[link]]``, ``[[joint]]``, … table per item, every pair and vector on
    one line (round-trips through :func:`loads`).

    Examples
    --------
    >>> print(dumps_toml(loads('joints = [["a", "b"], ["b", "c"], ["c", "a"]]')).splitlines()[12])
    links = ["a", "b"]
    """
    doc = mechanism_to_dict(m)
    lines = [_toml_pair(k, v) for k, v in doc.items() if not isinstance(v, list) or k == "gravity"]
    for key, tables in doc.items():
        if key == "gravity" or not isinstance(tables, list):
            continue
        for t in tables:
            lines += ["", f"[[{key}]]"] + [_toml_pair(k, v) for k, v in t.items()]
    return "\n".join(lines).lstrip("\n") + "\n"


def dumps_json(m: Mechanism) -> str:
    """JSON text of a mechanism."""
    return json.dumps(mechanism_to_dict(m), indent=2)


# keep Driver imported for type references in docs
_ = Driver
