"""Engine files (TOML/JSON; format in docs/forces.md): :func:`load_engine` and
:func:`engine_from_dict`.

The reader is strict: every unknown key or malformed value raises
:class:`~topo.errors.InputError` naming the table and key.  Values are read with the
shared typed readers of :mod:`topo.io`; the phases are the top level, the
``[engine]`` table, the ``[[cylinder]]`` tables and the ``[gas]`` table.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

from multiloop.topo.errors import InputError, explain
from multiloop.topo.io import read_document, read_number, read_string, read_table, read_tables, read_vector

from .gas import IndicatorDiagram, PressureTable
from .model import Cylinder, EngineSpec

__all__ = ["engine_from_dict", "load_engine"]

_TOP_KEYS = {"name", "description", "source", "engine", "cylinder", "gas", "notes"}
_ENGINE_KEYS = {"crank_radius", "stroke", "rod_length", "bore", "offset", "rpm", "crank_acceleration",
                "rod_mass", "rod_cg", "rod_inertia", "rod_radius_of_gyration", "piston_mass",
                "crank_mass", "crank_inertia", "gravity"}
_GAS_KEYS = {"model", "compression_ratio", "peak_pressure", "n_compression", "n_expansion",
             "intake_pressure", "exhaust_pressure", "crankcase_pressure", "table"}
_CYL_KEYS = {"name", "bank", "firing"}


def _top_level(doc: Any) -> None:
    if not isinstance(doc, dict):
        raise InputError(explain("engine file", expected="a table", got=type(doc).__name__))
    if "engine" not in doc and ({"joint", "joints", "link"} & set(doc)):
        raise InputError(explain("top level", expected="an [engine] table (an engine file)",
                                 got="a mechanism file",
                                 hint="use 'multiloop forces FILE' for the kinetostatics of a mechanism"))
    read_table(doc, "top level", _TOP_KEYS)
    if "engine" not in doc:
        raise InputError(explain("[engine]", expected="an [engine] table (bore, crank_radius, rod_length, ...)",
                                 got="nothing", hint="a mechanism file goes to 'multiloop forces'"))
    for key in ("name", "description", "source"):
        if key in doc:
            read_string(doc[key], f"top-level key '{key}'", allow_empty=True)


def _engine_table(eng: Any) -> dict[str, Any]:
    """Keyword arguments of :class:`EngineSpec` from the ``[engine]`` table."""
    eng = read_table(eng, "[engine]", _ENGINE_KEYS, required=("rod_length", "bore"))
    if ("crank_radius" in eng) == ("stroke" in eng):
        raise InputError(explain("[engine] crank_radius", expected="exactly one of 'crank_radius' and 'stroke'",
                                 got="both" if "crank_radius" in eng else "neither"))
    if "rod_inertia" in eng and "rod_radius_of_gyration" in eng:
        raise InputError(explain("[engine] rod_inertia", expected="either rod_inertia or rod_radius_of_gyration",
                                 got="both"))
    kw: dict[str, Any] = {key: read_number(eng[key], f"[engine] {key}")
                          for key in ("rod_length", "bore", "offset", "rpm", "crank_acceleration", "rod_mass",
                                      "rod_cg", "piston_mass", "crank_mass", "crank_inertia", "rod_inertia")
                          if key in eng}
    kw["crank_radius"] = read_number(eng["crank_radius"], "[engine] crank_radius") if "crank_radius" in eng \
        else read_number(eng["stroke"], "[engine] stroke") / 2.0
    if "rod_radius_of_gyration" in eng:
        rho = read_number(eng["rod_radius_of_gyration"], "[engine] rod_radius_of_gyration")
        kw["rod_inertia"] = kw.get("rod_mass", 0.0) * rho * rho
    if "gravity" in eng:
        kw["gravity"] = read_vector(eng["gravity"], "[engine] gravity")
    return kw


def _cylinders(doc: dict) -> tuple[Cylinder, ...]:
    raw = doc.get("cylinder", [{"name": "1", "bank": 90.0}])
    if isinstance(raw, list) and not raw:
        raise InputError(explain("[[cylinder]]", expected="an array of tables", got="[]"))
    cyls = []
    for i, c in enumerate(read_tables({"cylinder": raw}, "cylinder"), 1):
        where = f"[[cylinder]] #{i}"
        read_table(c, where, _CYL_KEYS, required=("bank",))
        name = read_string(c.get("name", str(i)), f"{where} name")
        firing = read_number(c["firing"], f"{where} firing") if "firing" in c else (0.0 if i % 2 else 360.0)
        cyls.append(Cylinder(name, read_number(c["bank"], f"{where} bank"), firing))
    if len({c.name for c in cyls}) != len(cyls):
        raise InputError(explain("[[cylinder]] name", expected="unique names", got=repr([c.name for c in cyls])))
    return tuple(cyls)


def _pressure_table(gd: dict) -> PressureTable:
    rows = gd.get("table")
    if not isinstance(rows, list):
        raise InputError(explain("[gas] table", expected="rows [psi_deg, p_Pa] for model = 'table'",
                                 got=repr(rows)[:40]))
    out = []
    for k, row in enumerate(rows):
        if not isinstance(row, list) or len(row) != 2:
            raise InputError(explain(f"[gas] table row {k}", expected="[psi_deg, p_Pa]", got=repr(row)))
        out.append(tuple(read_vector(row, f"[gas] table row {k}")))
    psi = [r[0] for r in out]
    dup = sorted({a for a in psi if psi.count(a) > 1})
    if dup:
        raise InputError(explain("[gas] table", expected="distinct cycle angles",
                                 got=f"{', '.join(f'{a:g}' for a in dup)} deg more than once"))
    return PressureTable(tuple(out), read_number(gd.get("crankcase_pressure", 0.1e6), "[gas] crankcase_pressure"))


def _gas(doc: dict) -> IndicatorDiagram | PressureTable | None:
    if "gas" not in doc:
        return None
    gd = read_table(doc["gas"], "[gas]", _GAS_KEYS)
    model = gd.get("model", "indicator")
    if model == "indicator":
        for req in ("compression_ratio", "peak_pressure"):
            if req not in gd:
                raise InputError(explain("[gas]", expected=f"key '{req}' for model = 'indicator'", got="nothing"))
        return IndicatorDiagram(**{k: read_number(gd[k], f"[gas] {k}") for k in _GAS_KEYS - {"model", "table"}
                                   if k in gd})
    if model == "table":
        return _pressure_table(gd)
    if model != "none":
        raise InputError(explain("[gas] model", expected="'indicator', 'table' or 'none'", got=repr(model)))
    return None


def engine_from_dict(doc: dict) -> EngineSpec:
    """Parse an engine document (see ``docs/forces.md``); strict about keys.

    Raises
    ------
    InputError
        Unknown key, malformed or physically meaningless value (named): e.g. a
        negative mass or inertia, ``rpm <= 0``, repeated pressure-table angles.
    """
    _top_level(doc)
    kw = _engine_table(doc["engine"])
    spec = EngineSpec(cylinders=_cylinders(doc), gas=_gas(doc), name=doc.get("name", "engine"),
                      description=doc.get("description"), source=doc.get("source"), **kw)
    spec.validate()
    return spec


def load_engine(path: str | Path) -> EngineSpec:
    """Read an engine TOML/JSON file (see ``docs/forces.md``)."""
    doc = read_document(path)
    try:
        return engine_from_dict(doc)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None
