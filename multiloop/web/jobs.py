"""Background jobs of one page: a worker thread, its progress, its result, a real cancel.

The page never waits for a job: a periodic callback of the session reads
:attr:`Job.state` and updates the widgets, and a job's ``wake`` (the session's
``add_next_tick_callback``, the one thread-safe way into a Bokeh document) has it read at
once when the job has a result.  :meth:`Job.cancel` sets an event that the
job's progress callback (:meth:`Job.report`) or cancel hook (:meth:`Job.poll`, given to
``check(..., cancel=)``) checks; it then raises ``_Cancelled`` inside the worker, which
unwinds the optimiser or the check and ends the thread (the work stops, it is not
merely hidden).
"""
from __future__ import annotations

import logging
import threading
import time
import warnings

__all__ = ["Job"]

#: each job's start and end, one line each (``multiloop serve`` shows them on stderr)
LOG = logging.getLogger("multiloop.web.jobs")


def log_to(stream, prefix: str = "multiloop serve: ") -> None:
    """The jobs (a check, a synthesis) log their start and end on ``stream``, one
    line each after ``prefix`` (``multiloop serve`` gives stderr)."""
    handler = logging.StreamHandler(stream)
    handler.setFormatter(logging.Formatter(prefix + "%(message)s"))
    LOG.addHandler(handler)
    LOG.setLevel(logging.INFO)
    LOG.propagate = False


class _Cancelled(Exception):
    """Raised inside a job's worker when the job was cancelled."""


class Job:
    """Run ``fn(job)`` in a daemon thread; ``fn`` reports through :meth:`report`.

    Attributes
    ----------
    state : str
        ``"running"``, ``"done"``, ``"failed"`` or ``"cancelled"``.
    fraction, best : float
        The last progress report.
    result, error : the return value, or the error message (one line).
    """

    def __init__(self, fn, name: str = "job", wake=None):
        """``wake()``: called from the worker at :meth:`notify` and when the job ends (the
        page then reads the job at once, not at its next periodic callback)."""
        self.fn, self.name, self.wake = fn, name, wake
        self.state, self.fraction, self.best, self.note = "running", 0.0, float("nan"), ""
        self.result, self.error = None, ""
        self._stop = threading.Event()
        self.started = time.perf_counter()
        self.thread = threading.Thread(target=self._run, name=f"multiloop-web-{name}", daemon=True)
        LOG.info("job %s: started", name)
        self.thread.start()

    def _run(self) -> None:
        from multiloop.topo.errors import LinkageError
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                self.result = self.fn(self)
            self.state = "cancelled" if self._stop.is_set() else "done"
        except _Cancelled:
            self.state = "cancelled"
        except LinkageError as exc:
            self.error, self.state = str(exc), "failed"
        except Exception as exc:  # noqa: BLE001 - shown on the page, the server keeps serving
            self.error, self.state = f"internal error: {type(exc).__name__}: {exc}", "failed"
        finally:
            LOG.info("job %s: %s after %.1f s (its thread ends)", self.name, self.state,
                     time.perf_counter() - self.started)
            self.notify()

    def notify(self) -> None:
        """Wake the page (``wake``): the job has something new to show."""
        if self.wake is not None:
            try:
                self.wake()
            except Exception:  # noqa: BLE001 - a session gone: its periodic callback is gone too
                pass

    def report(self, fraction: float, best: float = float("nan"), note: str = "") -> None:
        """Progress from the worker; raises ``_Cancelled`` once :meth:`cancel` was called."""
        self.fraction, self.best = float(fraction), float(best)
        if note:
            self.note = note
        self.poll()

    def poll(self) -> None:
        """Raise ``_Cancelled`` once :meth:`cancel` was called: the ``cancel`` hook of a
        library call (``check(..., cancel=job.poll)``) that has no progress of its own."""
        if self._stop.is_set():
            raise _Cancelled(self.name)

    def cancel(self) -> None:
        self._stop.set()

    @property
    def cancelled(self) -> bool:
        return self._stop.is_set()

    @property
    def running(self) -> bool:
        return self.state == "running"
