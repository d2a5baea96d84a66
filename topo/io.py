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
import sys
from pathlib import Path
from typing import Any

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

from .errors import InputError, explain
from .model import Driver, Joint, JointKind, Link, Load, Mechanism, MechanismBuilder, TracerPoint

__all__ = ["load", "loads", "mechanism_from_dict", "mechanism_to_dict", "dumps_toml",
           "dumps_json", "read_document"]

_TOP_KEYS = {"name", "description", "source", "joints", "link", "joint", "driver", "point",
             "force", "gravity", "reconstruction", "notes"}
_TABLE_KEYS = {
    "link": {"name", "frame", "mass", "cg", "inertia", "color"},
    "joint": {"name", "kind", "links", "at", "axis"},
    "driver": {"joint", "links", "speed", "acceleration"},
    "point": {"name", "link", "at"},
    "force": {"link", "at", "value", "table", "moment", "name"},
}
_REQUIRED = {"link": ("name",), "joint": ("name", "links"), "driver": ("joint",),
             "point": ("name", "link", "at"), "force": ("link",)}


def read_document(path: str | Path) -> dict[str, Any]:
    """Parse a ``.toml`` or ``.json`` file into a dict (no interpretation)."""
    p = Path(path)
    if not p.exists():
        raise InputError(explain(f"file '{p}'", expected="an existing file", got="nothing there"))
    if p.is_dir():
        raise InputError(explain(f"file '{p}'", expected="a file", got="a directory"))
    suffix = p.suffix.lower()
    try:
        text = p.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(explain(f"file '{p}'", expected="UTF-8 text", got=f"undecodable bytes ({exc.reason})")) from None
    if suffix == ".json":
        return _parse_json(text, str(p))
    if suffix == ".toml":
        return _parse_toml(text, str(p))
    raise InputError(explain(f"file '{p}'", expected="a .toml or .json file",
                             got=f"suffix '{suffix or '(none)'}'"))


def _parse_toml(text: str, where: str) -> dict[str, Any]:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{where}: TOML syntax error: {exc}") from None


def _parse_json(text: str, where: str) -> dict[str, Any]:
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"{where}: JSON syntax error: {exc.msg} at line {exc.lineno} column {exc.colno}") from None
    if not isinstance(doc, dict):
        raise InputError(explain(f"{where}", expected="a JSON object at top level",
                                 got=type(doc).__name__))
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


def loads(text: str, fmt: str = "toml") -> Mechanism:
    """Parse a mechanism from a TOML (default) or JSON string."""
    doc = _parse_json(text, "<string>") if fmt == "json" else _parse_toml(text, "<string>")
    return mechanism_from_dict(doc)


def _num(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(explain(where, expected="a number", got=repr(value)))
    f = float(value)
    if not math.isfinite(f):
        raise InputError(explain(where, expected="a finite number", got=repr(value)))
    return f


def _vec(value: Any, where: str) -> tuple[float, float]:
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise InputError(explain(where, expected="a pair of numbers [x, y]", got=repr(value)))
    return (_num(value[0], where), _num(value[1], where))


def _str(value: Any, where: str) -> str:
    if not isinstance(value, str) or not value:
        raise InputError(explain(where, expected="a non-empty string", got=repr(value)))
    return value


def _names(value: Any, where: str) -> tuple[str, ...]:
    if not isinstance(value, (list, tuple)):
        raise InputError(explain(where, expected="a list of link names", got=repr(value)))
    return tuple(_str(v, where) for v in value)


def _tables(doc: dict, key: str) -> list[dict]:
    raw = doc.get(key, [])
    if isinstance(raw, dict):
        raw = [raw]
    if not isinstance(raw, list) or not all(isinstance(t, dict) for t in raw):
        raise InputError(explain(f"[[{key}]]", expected="an array of tables", got=repr(raw)[:60]))
    out = []
    for i, t in enumerate(raw, 1):
        label = f"[[{key}]] #{i}" + (f" ('{t['name']}')" if isinstance(t.get("name"), str) else "")
        unknown = sorted(set(t) - _TABLE_KEYS[key])
        if unknown:
            raise InputError(explain(f"{label}", expected=f"keys among {', '.join(sorted(_TABLE_KEYS[key]))}",
                                     got=f"unknown key {', '.join(repr(u) for u in unknown)}"))
        for req in _REQUIRED[key]:
            if req not in t:
                raise InputError(explain(f"{label}", expected=f"key '{req}'", got="nothing"))
        out.append((label, t))
    return out


def mechanism_from_dict(doc: dict[str, Any]) -> Mechanism:
    """Build a :class:`Mechanism` from a parsed document (strict, see module doc)."""
    if not isinstance(doc, dict):
        raise InputError(explain("document", expected="a table", got=type(doc).__name__))
    unknown = sorted(set(doc) - _TOP_KEYS)
    if unknown:
        raise InputError(explain("top level", expected=f"keys among {', '.join(sorted(_TOP_KEYS))}",
                                 got=f"unknown key {', '.join(repr(u) for u in unknown)}",
                                 hint="tables are written [[link]], [[joint]], [[driver]], [[point]], [[force]]"))
    b = MechanismBuilder()
    for key in ("name", "description", "source"):
        if key in doc:
            setattr(b, key, _str(doc[key], f"top-level key '{key}'"))
    if "gravity" in doc:
        b.gravity = _vec(doc["gravity"], "top-level key 'gravity'")
    if "joints" in doc:
        if "joint" in doc:
            raise InputError(explain("top level", expected="either 'joints' (bare chain) or [[joint]] tables",
                                     got="both"))
        jl = doc["joints"]
        if not isinstance(jl, list) or not jl:
            raise InputError(explain("key 'joints'", expected="a non-empty list of link-name lists", got=repr(jl)[:60]))
        for i, lks in enumerate(jl, 1):
            b.add_joint(f"J{i}", "R", _names(lks, f"joints[{i - 1}]"))
    for label, t in _tables(doc, "link"):
        frame = t.get("frame", False)
        if not isinstance(frame, bool):
            raise InputError(explain(f"{label} frame", expected="true or false", got=repr(frame)))
        b.links.append(Link(
            _str(t["name"], f"{label} name"), frame,
            _num(t["mass"], f"{label} mass") if "mass" in t else None,
            _vec(t["cg"], f"{label} cg") if "cg" in t else None,
            _num(t["inertia"], f"{label} inertia") if "inertia" in t else None,
            _str(t["color"], f"{label} color") if "color" in t else None))
    for label, t in _tables(doc, "joint"):
        kind = t.get("kind", "R")
        if kind not in ("R", "P"):
            raise InputError(explain(f"{label} kind", expected="'R' or 'P'", got=repr(kind)))
        b.joints.append(Joint(
            _str(t["name"], f"{label} name"), JointKind(kind), _names(t["links"], f"{label} links"),
            _vec(t["at"], f"{label} at") if "at" in t else None,
            _vec(t["axis"], f"{label} axis") if "axis" in t else None))
    for label, t in _tables(doc, "driver"):
        links = _names(t["links"], f"{label} links") if "links" in t else None
        b.add_driver(_str(t["joint"], f"{label} joint"), links,
                     _num(t["speed"], f"{label} speed") if "speed" in t else None,
                     _num(t["acceleration"], f"{label} acceleration") if "acceleration" in t else None)
    for label, t in _tables(doc, "point"):
        b.points.append(TracerPoint(_str(t["name"], f"{label} name"), _str(t["link"], f"{label} link"),
                                    _vec(t["at"], f"{label} at")))
    for label, t in _tables(doc, "force"):
        table = None
        if "table" in t:
            rows = t["table"]
            if not isinstance(rows, list) or not rows:
                raise InputError(explain(f"{label} table", expected="rows [input_deg, Fx, Fy]", got=repr(rows)[:60]))
            table = []
            for r, row in enumerate(rows):
                if not isinstance(row, list) or len(row) != 3:
                    raise InputError(explain(f"{label} table row {r}", expected="[input_deg, Fx, Fy]", got=repr(row)))
                table.append(tuple(_num(x, f"{label} table row {r}") for x in row))
            table = tuple(table)
        b.loads.append(Load(_str(t["link"], f"{label} link"),
                            _vec(t["at"], f"{label} at") if "at" in t else None,
                            _vec(t["value"], f"{label} value") if "value" in t else (0.0, 0.0),
                            table, _num(t["moment"], f"{label} moment") if "moment" in t else 0.0,
                            _str(t["name"], f"{label} name") if "name" in t else None))
    return b.build()


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
            doc["driver"].append(t)
    if m.points:
        doc["point"] = [{"name": p.name, "link": p.link, "at": list(p.at)} for p in m.points]
    if m.loads:
        doc["force"] = []
        for ld in m.loads:
            t = {"link": ld.link, "value": list(ld.value)}
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


def dumps_toml(m: Mechanism) -> str:
    """TOML text of a mechanism."""
    import tomli_w
    return tomli_w.dumps(mechanism_to_dict(m))


def dumps_json(m: Mechanism) -> str:
    """JSON text of a mechanism."""
    return json.dumps(mechanism_to_dict(m), indent=2)


# keep Driver imported for type references in docs
_ = Driver
