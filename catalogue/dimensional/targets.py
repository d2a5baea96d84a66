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

__all__ = ["PathTarget", "FunctionTarget", "MotionTarget", "read_table", "parse_table", "MIN_ROWS"]

#: fewest rows each task needs: a path needs 3 points (a circle passes through any
#: 3 points, so fewer say nothing), function and motion need 3 precision positions
#: (Freudenstein's and Burmester's exact three-position syntheses)
MIN_ROWS = {"path": 3, "function": 3, "motion": 3}


def _size(a: np.ndarray) -> float:
    return float(np.max(np.ptp(a, axis=0))) if len(a) > 1 else 0.0


@dataclass(frozen=True)
class PathTarget:
    """Points ``(N, 2)`` the tracer ``point`` meets in this order.

    ``timing`` (N,) gives the driver value (rad, or m for a slider input) from the
    reference at each point, or ``None`` for free timing; ``shape_only`` lets the
    target be scaled, rotated and translated (a similarity transform).
    """

    points: np.ndarray
    point: str
    timing: np.ndarray | None = None
    shape_only: bool = False
    source: str = "the given points"

    @property
    def size(self) -> float:
        """The target's size: the larger side of its bounding box."""
        return _size(self.points)


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


def read_table(path: str | Path, columns: tuple[int, ...], what: str) -> np.ndarray:
    """Rows of numbers from a CSV file; a first line that is not numeric is a header.

    Parameters
    ----------
    columns : tuple of int
        Allowed numbers of columns, e.g. ``(2, 3)``.
    what : str
        ``"path"``, ``"function"`` or ``"motion"`` (for :data:`MIN_ROWS` and messages).
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(explain(f"{what} table {str(p)!r}", expected="an existing CSV file", got="no such file"))
    return parse_table(p.read_text(encoding="utf-8"), columns, what, p.name)


def parse_table(text: str, columns: tuple[int, ...], what: str, name: str) -> np.ndarray:
    """Rows of numbers from the text of a CSV table named ``name`` (see :func:`read_table`)."""
    rows = [r for r in csv.reader(text.splitlines()) if r and any(c.strip() for c in r)]
    out = []
    for i, r in enumerate(rows):
        try:
            vals = [float(c) for c in r]
        except ValueError:
            if i == 0:
                continue        # header
            raise InputError(explain(f"{name} row {i + 1}", expected="numbers", got=",".join(r))) from None
        if len(vals) not in columns:
            raise InputError(explain(f"{name} row {i + 1}", expected=" or ".join(map(str, columns)) + " columns",
                                     got=f"{len(vals)}"))
        out.append(vals)
    if len({len(v) for v in out}) > 1:
        raise InputError(explain(name, expected="the same number of columns on every row", got="a ragged table"))
    return check_rows(np.array(out, float).reshape(len(out), -1), what, name)


def check_rows(a: np.ndarray, what: str, where: str) -> np.ndarray:
    """Validate a target array: enough rows, finite values."""
    need = MIN_ROWS[what]
    if a.shape[0] < need:
        raise InputError(explain(where, expected=f"at least {need} {what} targets", got=f"{a.shape[0]}",
                                 hint="fewer targets do not determine the dimensions"))
    bad = ~np.all(np.isfinite(a), axis=1)
    if bad.any():
        raise InputError(explain(f"{where} row {int(np.flatnonzero(bad)[0]) + 1}", expected="finite numbers",
                                 got="NaN or infinity"))
    return a
