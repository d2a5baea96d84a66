"""Design check of a planar mechanism over its whole motion (``multiloop check``).

:func:`check` returns a frozen :class:`CheckReport`; ``report.as_dict()`` is the
stable JSON of ``multiloop check --json`` and :func:`format_report` its text form.
"""
from __future__ import annotations

from .core import check, driver_angles, driver_check
from .report import CheckReport
from .text import format_report

__all__ = ["check", "driver_check", "driver_angles", "CheckReport", "format_report"]
