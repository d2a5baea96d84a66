"""The compiled kernels' mode: which route a solve takes in this thread.

``MULTILOOP_KERNEL`` sets the process's mode: ``off`` (the default: every result is the
NumPy path's, whatever the process loaded before), ``on`` (the compiled kernels
whenever numba is installed) or ``auto`` (them once the plan kernel is loaded in the
process, and for a batch of at least :data:`LAZY_MIN` positions).  :func:`using` sets
the mode for a block, in its own thread.  This module imports nothing of the solvers,
so a group's adapter asks it which route to take (:func:`chooses`) without importing
the kernel that imports the adapters (:mod:`kin.kernel` loads the plan kernel and
re-exports these names).
"""
from __future__ import annotations

import os
import sys
import threading

__all__ = ["MODES", "LAZY_MIN", "mode", "using", "is_loaded", "chooses"]

#: the kernel's modes (environment variable ``MULTILOOP_KERNEL``)
MODES = ("auto", "on", "off")
#: in mode "auto", a batch of at least this many positions loads numba itself
LAZY_MIN = 2_000_000
#: the process's mode (``MULTILOOP_KERNEL``) and whether it is the default one (unset);
#: a :func:`using` block overrides both for its own thread only (:data:`_THREAD`)
_MODE = [os.environ.get("MULTILOOP_KERNEL", "off")]
_DEFAULT = ["MULTILOOP_KERNEL" not in os.environ]
_THREAD = threading.local()
#: the plan kernel's module (loaded by :func:`kin.kernel.load`)
PLAN_KERNEL = "multiloop.kin._kernel_nb"


def mode() -> str:
    """The kernel's mode in this thread: ``"auto"``, ``"on"`` or ``"off"``."""
    return _THREAD.__dict__.get("mode", _MODE[0])     # (getattr with a default costs an exception)


def is_default() -> bool:
    """Whether this thread runs in the process's default mode (``MULTILOOP_KERNEL`` unset,
    no :func:`using` block)."""
    return _THREAD.__dict__.get("default", _DEFAULT[0])


def turn_off() -> None:
    """The process's mode set to ``off`` (the compiled kernels cannot load)."""
    _MODE[0] = "off"


class using:  # noqa: N801 - used as a function: ``with using("on"):``
    """Run a block with the kernel's mode ``m`` (one of :data:`MODES`), in this thread
    only: another thread's block (a web page's check beside a synthesis, a Dask
    worker's tasks) neither sees it nor can leave it set.  A plain context manager, not
    a generator: entering and leaving it costs under a microsecond (a benchmark's timed
    call wraps each solve in one)."""

    __slots__ = ("_mode", "_saved")

    def __init__(self, m: str) -> None:
        if m not in MODES:
            raise ValueError(f"kernel mode: expected one of {MODES}, got {m!r}")
        self._mode = m

    def __enter__(self) -> None:
        d = _THREAD.__dict__
        self._saved = d.copy()
        d["mode"], d["default"] = self._mode, False

    def __exit__(self, *exc) -> None:
        d = _THREAD.__dict__
        d.clear()
        d.update(self._saved)


def is_loaded() -> bool:
    """Whether the compiled plan kernel is loaded in this process."""
    return PLAN_KERNEL in sys.modules


def chooses(n_positions: int) -> bool:
    """Whether the current mode asks for the compiled route for a batch of
    ``n_positions`` (whether numba is installed is the caller's to find out)."""
    m = mode()
    return m == "on" or (m == "auto" and (is_loaded() or n_positions >= LAZY_MIN))
