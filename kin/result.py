"""Batch statuses: integer codes with one message table, and the shared behaviour of
batch results (``ok`` / ``success`` / ``message``), and :func:`json_ready`, the
conversion every result's ``as_dict`` ends with.

A batch result carries ``status`` (one readable message per position: ``"ok"`` or the
reason, naming the group) and, from :mod:`kin.solve`, ``codes`` (one :class:`Status`
per position).  Callers test the codes, never the text: ``state.codes == Status.SINGULAR``.
"""
from __future__ import annotations

import math
from enum import IntEnum

import numpy as np

__all__ = ["Status", "MESSAGES", "BatchStatus", "status_text", "json_ready", "inputs_json"]


def inputs_json(q) -> list:
    """Driver inputs ``(N, n_drivers)`` as every JSON document prints them: a flat list
    for one driver, a list of rows for several (NaN as null)."""
    q = np.asarray(q, float)
    return json_ready(q[:, 0] if q.ndim == 2 and q.shape[1] == 1 else q)


def json_ready(o):
    """``o`` with NumPy arrays as lists, NumPy scalars as Python numbers and every
    non-finite float as ``None`` (JSON null), through dicts, lists and tuples."""
    if isinstance(o, dict):
        return {k: json_ready(v) for k, v in o.items()}
    if isinstance(o, np.ndarray):
        return json_ready(o.tolist())
    if isinstance(o, (list, tuple)):
        return [json_ready(v) for v in o]
    if isinstance(o, (float, np.floating)):
        return float(o) if math.isfinite(o) else None
    if isinstance(o, np.bool_):
        return bool(o)
    if isinstance(o, np.integer):
        return int(o)
    return o


class Status(IntEnum):
    """Why a position of a batch is not ``ok`` (0 means it is)."""

    OK = 0
    OUT_OF_REACH = 1        #: a group cannot be assembled at this input
    SINGULAR = 2            #: a group is singular here (branches meet, dead centre)
    LIMIT = 3               #: the motion from the reference stops at a limit before this input
    OTHER_CIRCUIT = 4       #: assembles here, but on a circuit no motion from the reference reaches
    UPSTREAM = 5            #: an earlier group failed
    MODE_LOST = 6           #: a tracked mode (triad, class IV, Newton) was lost earlier in the path
    NOT_CONVERGED = 7       #: Newton did not converge
    NOT_SOLVED = 8          #: not asked for (``only=``)
    OUT_OF_RANGE = 9        #: an input lies outside its driver's ``range`` (stroke or angular limits)


#: the short text of each code; position messages start with the group's label
MESSAGES = {
    Status.OK: "ok",
    Status.OUT_OF_REACH: "no assembly (out of reach)",
    Status.SINGULAR: "singular position",
    Status.LIMIT: "unreachable: past a limit of the motion from the reference",
    Status.OTHER_CIRCUIT: "other circuit: not reachable from the reference without disassembly",
    Status.UPSTREAM: "failed upstream",
    Status.MODE_LOST: "assembly mode lost earlier in the path",
    Status.NOT_CONVERGED: "no assembly (Newton did not converge)",
    Status.NOT_SOLVED: "not solved (not asked for)",
    Status.OUT_OF_RANGE: "out of range: an input is outside its driver's range",
}


def status_text(code: int) -> str:
    """The message of a status code."""
    return MESSAGES[Status(int(code))]


class BatchStatus:
    """Mixin for frozen batch results that carry ``status`` (and possibly ``inputs``,
    ``codes``).

    ``ok`` is the mask of positions that succeeded, ``success`` says all did, and
    ``message`` names how many failed and the first failing input with its reason.
    """

    __slots__ = ()

    @property
    def ok(self) -> np.ndarray:
        """Boolean mask of the positions that succeeded (``status == "ok"``; the codes
        say the same, and callers that rewrite ``status`` keep it authoritative)."""
        return np.asarray(self.status) == "ok"

    @property
    def success(self) -> bool:
        return bool(np.all(self.ok))

    @property
    def message(self) -> str:
        """``"ok"``, or the count of failures and the first failing input and reason."""
        ok = self.ok
        bad = np.flatnonzero(~ok)
        if bad.size == 0:
            return "ok"
        n = int(bad[0])
        inputs = getattr(self, "inputs", None)
        where = f"input {np.asarray(inputs)[n].tolist()}" if inputs is not None else f"position #{n}"
        return f"{bad.size} of {ok.size} positions failed; first at {where}: {self.status[n]}"
