"""The values of an atlas's stored rows, read back with every one checked.

An atlas is a file like any input: a disk error, a bit flip, a truncated BLOB, text that
is not UTF-8 (read as lone surrogates, :func:`decoded_text`), JSON that does not parse or
a table of another schema must end in an :class:`~multiloop.topo.errors.InputError`
naming the atlas, the table and the row (:func:`corrupt`), never in a crash deeper down.
Each reader here takes the atlas's path, the table, the row's id, the column and the
stored value, and returns the value in the type its user needs.

Examples
--------
>>> real("a.sqlite", "curves", 7, "radius", 0.25, positive=True)
0.25
>>> real("a.sqlite", "curves", 7, "radius", 0.0, positive=True)
Traceback (most recent call last):
...
multiloop.topo.errors.InputError: atlas 'a.sqlite': table curves row 7: expected radius: a finite number > 0, got 0.0; hint: rebuild the atlas into a new file (multiloop atlas … --db NEW.sqlite)
"""
from __future__ import annotations

import json
import math

from multiloop.topo.errors import InputError, explain

__all__ = ["corrupt", "decoded_text", "blob", "real", "text", "integer", "int_list", "int_lists", "text_list",
           "positions", "REBUILD"]

#: what to do with a damaged atlas
REBUILD = "rebuild the atlas into a new file (multiloop atlas … --db NEW.sqlite)"


def corrupt(path: str, table: str, row, expected: str, got: str) -> InputError:
    """The error of a damaged stored value: ``atlas 'PATH': table T row R: expected …``
    (``row`` None: the table itself, e.g. its columns)."""
    where = f"atlas {str(path)!r}: table {table}" + ("" if row is None else f" row {row}")
    return InputError(explain(where, expected=expected, got=got, hint=REBUILD))


def decoded_text(data: bytes) -> str:
    """SQLite TEXT as a str (the atlas connection's ``text_factory``); bytes that are not
    UTF-8 come back as lone surrogates, which :func:`text` refuses with their row."""
    return data.decode("utf-8", "surrogateescape")


def _shown(value) -> str:
    """A short description of a stored value for a message."""
    if isinstance(value, bytes):
        return f"a BLOB of {len(value)} bytes"
    if isinstance(value, str):
        return f"the text {value[:40]!r}" + ("…" if len(value) > 40 else "")
    return "NULL" if value is None else repr(value)


def blob(path, table, row, column, value, nbytes: int) -> bytes:
    """A BLOB of exactly ``nbytes`` bytes."""
    if not isinstance(value, bytes) or len(value) != nbytes:
        raise corrupt(path, table, row, f"{column}: a BLOB of {nbytes} bytes", _shown(value))
    return value


def real(path, table, row, column, value, positive: bool = False) -> float:
    """A finite number (> 0 when ``positive``)."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if not ok or (positive and not value > 0):
        raise corrupt(path, table, row, f"{column}: a finite number{' > 0' if positive else ''}", _shown(value))
    return float(value)


def integer(path, table, row, column, value, lo: int = 0, hi: int = 2 ** 63 - 1) -> int:
    """An integer in ``[lo, hi]``."""
    if not isinstance(value, int) or isinstance(value, bool) or not lo <= value <= hi:
        raise corrupt(path, table, row, f"{column}: an integer from {lo} to {hi}", _shown(value))
    return value


def text(path, table, row, column, value) -> str:
    """UTF-8 text."""
    if not isinstance(value, str):
        raise corrupt(path, table, row, f"{column}: text", _shown(value))
    try:
        value.encode("utf-8")
    except UnicodeEncodeError as exc:
        raise corrupt(path, table, row, f"{column}: UTF-8 text",
                      f"an undecodable byte at offset {exc.start}") from None
    return value


def _json(path, table, row, column, value, what: str, check):
    value = text(path, table, row, column, value)
    try:
        doc = json.loads(value)
    except ValueError:
        doc = check = None
    if check is None or not check(doc):
        raise corrupt(path, table, row, f"{column}: {what}", _shown(value))
    return doc


def _ints(v) -> bool:
    return isinstance(v, list) and all(isinstance(x, int) and not isinstance(x, bool) and x >= 0 for x in v)


def int_list(path, table, row, column, value) -> list[int]:
    """JSON: a list of integers >= 0 (an assortment)."""
    return _json(path, table, row, column, value, "a JSON list of integers >= 0", _ints)


def int_lists(path, table, row, column, value, below: int | None = None) -> list[list[int]]:
    """JSON: a list of lists of integers >= 0 (each below ``below``), e.g. a chain's joints."""
    def ok(doc):
        return isinstance(doc, list) and all(_ints(j) and (below is None or all(x < below for x in j)) for j in doc)
    return _json(path, table, row, column, value, "a JSON list of lists of link indices"
                 + (f" below {below}" if below is not None else ""), ok)


def text_list(path, table, row, column, value) -> list[str]:
    """JSON: a list of strings (e.g. the kinds of a mechanism's groups)."""
    return _json(path, table, row, column, value, "a JSON list of strings",
                 lambda doc: isinstance(doc, list) and all(isinstance(x, str) for x in doc))


def positions(path, table, row, column, value, names) -> dict[str, list[float]]:
    """JSON: ``{name: [x, y]}`` with finite numbers, for exactly the given names."""
    def ok(doc):
        return (isinstance(doc, dict) and set(doc) == set(names) and all(
            isinstance(p, list) and len(p) == 2 and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                        and math.isfinite(x) for x in p) for p in doc.values()))
    return _json(path, table, row, column, value, f"a JSON object of {len(names)} positions [x, y] "
                 f"({', '.join(sorted(names)[:4])}{', …' if len(names) > 4 else ''})", ok)
