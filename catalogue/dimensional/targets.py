"""Synthesis targets (path, function, motion) and their CSV readers.

A target table is plain CSV: numbers separated by commas, one row per target, an
optional header line.  Every reader validates what it reads (finite numbers, the
right number of columns, enough rows) and raises :class:`InputError` naming the
file, the row and what was expected.
"""
from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from multiloop.topo.errors import InputError, explain
from multiloop.topo.io import read_input_bytes

__all__ = ["PathTarget", "FunctionTarget", "MotionTarget", "read_table", "parse_table", "MIN_ROWS", "MAX_ROWS",
           "MAX_VALUE", "MIN_SIZE", "resample", "TIMINGS"]

#: fewest rows each task needs: a path needs 3 points (a circle passes through any
#: 3 points, so fewer say nothing), function and motion need 3 precision positions
#: (Freudenstein's and Burmester's exact three-position syntheses)
MIN_ROWS = {"path": 3, "function": 3, "motion": 3}

#: most targets used: a longer table is resampled to this many rows, evenly by row
#: number, first and last kept (the work and memory of the search grow with the
#: number of targets × the driver grid × the population; 10 000 rows took 3.2 GB)
MAX_ROWS = 200

#: largest magnitude of a table value (as ``forces`` and ``check`` cap their inputs)
MAX_VALUE = 1e9

#: smallest target size (m): the spread of a path's points or a motion's pose origins
#: (a picometre; below it the relative errors and the search's tolerances lose meaning,
#: and the squares of the distances underflow)
MIN_SIZE = 1e-12

#: meanings of a path table's third column: the driver value from the reference,
#: the driver's absolute value (crank angle from the x-axis, slider position along
#: its guide), or steps between consecutive targets from a free start
TIMINGS = ("reference", "absolute", "step")


def _size(a: np.ndarray) -> float:
    return float(np.max(np.ptp(a, axis=0))) if len(a) > 1 else 0.0


@dataclass(frozen=True)
class PathTarget:
    """Points ``(N, 2)`` the tracer ``point`` meets in this order.

    ``timing`` (N,) gives the driver value (rad, or m for a slider input) at each
    point, or ``None`` for free timing; ``timing_mode`` (:data:`TIMINGS`) says what
    it is measured from: the reference configuration, the driver's absolute zero
    (the x-axis, the guide's pivot), or nothing (``"step"``: only its differences
    count, the start is free).  ``shape_only`` lets the target be scaled, rotated
    and translated (a similarity transform).
    """

    points: np.ndarray
    point: str
    timing: np.ndarray | None = None
    shape_only: bool = False
    source: str = "the given points"
    timing_mode: str = "reference"

    @property
    def size(self) -> float:
        """The target's size: the larger side of its bounding box."""
        return _size(self.points)

    def target_points(self) -> np.ndarray:
        """The rows whose spread is the target's size: the points ``(N, 2)``."""
        return self.points


@dataclass(frozen=True)
class FunctionTarget:
    """Pairs (driver value, output value): the first row is the reference
    configuration; values in rad (R joints) or m (P joints)."""

    inputs: np.ndarray
    outputs: np.ndarray
    joint: str
    source: str = "the given table"

    @property
    def size(self) -> float:
        return float(np.ptp(self.outputs))

    def target_points(self) -> np.ndarray:
        """The rows whose spread is the target's size: the outputs ``(N, 1)``."""
        return self.outputs[:, None]


@dataclass(frozen=True)
class MotionTarget:
    """Poses ``(N, 3)`` = (x, y, angle in rad) of a frame attached to ``link``, met
    in this order with free timing."""

    poses: np.ndarray
    link: str
    source: str = "the given poses"

    @property
    def size(self) -> float:
        return _size(self.poses[:, :2])

    def target_points(self) -> np.ndarray:
        """The rows whose spread is the target's size: the pose origins ``(N, 2)``."""
        return self.poses[:, :2]


def read_table(path: str | Path, columns: tuple[int, ...], what: str) -> np.ndarray:
    """Rows of numbers from a CSV file; a first line that is not numeric is a header.

    Parameters
    ----------
    columns : tuple of int
        Allowed numbers of columns, e.g. ``(2, 3)``.
    what : str
        ``"path"``, ``"function"`` or ``"motion"`` (for :data:`MIN_ROWS` and messages).

    Raises
    ------
    InputError
        No such file, not a regular file, over :data:`~multiloop.topo.io.MAX_INPUT_BYTES`,
        not UTF-8, or a table :func:`parse_table` refuses.
    """
    p = Path(path)
    if not p.exists():
        raise InputError(explain(f"{what} table {str(p)!r}", expected="an existing CSV file", got="no such file"))
    raw = read_input_bytes(p)           # a regular file within the input cap of every reader
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise InputError(explain(f"{what} table {p.name!r}", expected="UTF-8 text",
                                 got=f"byte 0x{raw[e.start]:02x} at offset {e.start}",
                                 hint="save the file as UTF-8")) from None
    return parse_table(text, columns, what, p.name)


def parse_table(text: str, columns: tuple[int, ...], what: str, name: str) -> np.ndarray:
    """Rows of numbers from the text of a CSV table named ``name`` (see :func:`read_table`).

    Messages name the *line* of the file (blank lines and the header counted), the same
    numbering for every fault; a table whose first line is separated by ``;`` and has
    no comma is read with ``;`` (a spreadsheet's export), never taken as a header."""
    lines = text.splitlines()
    first = next((ln for ln in lines if ln.strip()), "")
    sep = ";" if ";" in first and "," not in first else ","
    rows = _csv_rows(lines, sep, name)
    if not rows:
        raise InputError(explain(f"{what} table {name!r}", expected="rows of numbers", got="an empty file"))
    out, where = [], []
    for i, (line, r) in enumerate(rows):
        try:
            vals = [float(c) for c in r]
        except ValueError:
            if i == 0:
                continue        # header
            raise InputError(explain(f"{name} line {line}", expected="numbers", got=sep.join(r)[:80])) from None
        if len(vals) not in columns:
            raise InputError(explain(f"{name} line {line}", expected=" or ".join(map(str, columns)) + " columns",
                                     got=f"{len(vals)}"))
        out.append(vals)
        where.append(line)
    if not out:
        raise InputError(explain(f"{what} table {name!r}", expected="rows of numbers", got="a header line only"))
    if len({len(v) for v in out}) > 1:
        raise InputError(explain(name, expected="the same number of columns on every row", got="a ragged table"))
    return check_rows(np.array(out, float).reshape(len(out), -1), what, name, where)


def _csv_rows(lines: list[str], sep: str, name: str) -> list[tuple[int, list[str]]]:
    """The non-blank rows of a CSV text with their line numbers; a row the csv module
    refuses (a field over its limit of 131 072 characters, a stray quote) names its line."""
    reader = csv.reader(lines, delimiter=sep, strict=False)
    rows = []
    while True:
        try:
            r = next(reader)
        except StopIteration:
            return rows
        except csv.Error as exc:
            raise InputError(explain(f"{name} line {reader.line_num}", expected="numbers separated by "
                                     f"{sep!r}", got=f"a row the CSV reader refuses ({exc})")) from None
        if r and any(c.strip() for c in r):
            rows.append((reader.line_num, r))


def resample(a: np.ndarray, n: int = MAX_ROWS) -> np.ndarray:
    """At most ``n`` rows of ``a``, evenly by row number (the first and the last kept)."""
    if len(a) <= n:
        return a
    return a[np.unique(np.round(np.linspace(0, len(a) - 1, n)).astype(int))]


def check_rows(a: np.ndarray, what: str, where: str, lines=None) -> np.ndarray:
    """Validate a target array: enough rows, finite values of a bounded magnitude, and the
    points of a path or a motion spread (:func:`_check_spread`); ``lines`` are the rows'
    line numbers in their file (messages then say ``line``, else ``row``)."""
    def at(i):
        return f"{where} line {lines[i]}" if lines is not None else f"{where} row {i + 1}"

    need = MIN_ROWS[what]
    if a.shape[0] < need:
        raise InputError(explain(where, expected=f"at least {need} {what} targets", got=f"{a.shape[0]}",
                                 hint="fewer targets do not determine the dimensions"))
    bad = ~np.all(np.isfinite(a), axis=1)
    if bad.any():
        raise InputError(explain(at(int(np.flatnonzero(bad)[0])), expected="finite numbers",
                                 got="NaN or infinity"))
    big = np.abs(a) > MAX_VALUE
    if big.any():
        i, j = np.argwhere(big)[0]
        raise InputError(explain(at(int(i)), expected=f"numbers of magnitude at most {MAX_VALUE:g}",
                                 got=f"{a[i, j]:g} in column {int(j) + 1}"))
    if what in ("path", "motion"):
        span = (lines[0], lines[-1]) if lines is not None else (1, len(a))
        _check_spread(a[:, :2], what, f"{where} {'lines' if lines is not None else 'rows'} {span[0]}–{span[1]}")
    return a


def _check_spread(xy: np.ndarray, what: str, where: str) -> None:
    """The points ``xy`` of a path or motion target spread over at least :data:`MIN_SIZE`
    and over 1e-12 of their distance from the origin (else they are one point)."""
    size, far = _size(xy), float(np.max(np.abs(xy)))
    if size >= MIN_SIZE and size > 1e-12 * far:
        return
    got = (f"every point at ({xy[0, 0]:.6g}, {xy[0, 1]:.6g})" if size == 0.0 else
           f"a target of size {size:.3g} m" + (f" {far:.3g} m from the origin" if size >= MIN_SIZE else ""))
    raise InputError(explain(where, expected=f"{what} points that are not all the same: a spread of at least "
                             f"{MIN_SIZE:g} m and of 1e-12 of their distance from the origin", got=got,
                             hint="the error is relative to the target's size"))
