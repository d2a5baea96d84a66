"""A second process that moves some drivers of a design while the page's job moves the others.

A design check moves each driver in turn, the others held: the drivers are
independent (:func:`multiloop.kin.check.driver_check`), and Python runs one of them at a
time.  On a machine with a second core, a child process (``python -m
multiloop.web.second_core PARENT_PID``, started once per server) takes half the
drivers of a design with several: their motion frames (:func:`~.scene.sweep_driver`) and
their checks, the same functions on the same design, so the report the page shows is
the one ``multiloop check --json`` prints, bit for bit.

A design with one driver gives the child the extremes of its angles
(:func:`~multiloop.kin.check.driver_angles`), which the job's check takes once its
branch points, dead centres and velocity ratio are done
(:func:`~multiloop.kin.check.driver_check`'s ``angles``).

Tasks and results are pickled over the child's stdin and stdout, one task at a time,
once the child has said it is ready (its signal handler set, its warm-up done; until
then every job does all of its work itself): ``(serial, mechanism, what, drivers)``
in, ``(serial, ok, value)`` out (``value``: the ``(Sweep, DriverCheck)`` of each
driver, or the angles' extremes, or the error's text).  The server writes and reads
them itself: nothing a page sends is unpickled.  A task whose job was cancelled (a
newer edit) is stopped at its next solve by ``SIGUSR1`` where the system has it; a job
never waits for a busy or failed child: it does that work itself.  The child stops at
its next solve once the server is gone, and at the end of its input when the server
exits.
"""
from __future__ import annotations

import gc
import os
import pickle
import signal
import subprocess
import sys
import threading

__all__ = ["SecondCore", "SECOND_CORE", "theirs", "cores", "main"]

#: the wait for the child's result between two polls of the job (s)
POLL_S = 0.005


def cores() -> int:
    """The cores this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def theirs(n_drivers: int) -> tuple[int, ...]:
    """The drivers the child moves: the second half (the larger, of an odd number: the
    job also assembles the report)."""
    return tuple(range(n_drivers // 2, n_drivers)) if n_drivers > 1 else ()


class _Task:
    """One task given to the child: its result, once :attr:`done` is set."""

    def __init__(self, serial: int):
        self.serial, self.done, self.ok, self.value = serial, threading.Event(), False, None

    def result(self, poll):
        """The child's ``(Sweep, DriverCheck)`` pairs, or None when it failed or was
        stopped; ``poll()`` is called between waits (it raises when the job is cancelled)."""
        while not self.done.wait(POLL_S):
            poll()
        return self.value if self.ok else None


class SecondCore:
    """The child process and the one task it runs (:func:`main` is the child's side)."""

    def __init__(self):
        self.proc, self.task, self.serial = None, None, 0
        self.lock = threading.Lock()
        self.ready = threading.Event()          # the child has started and warmed up

    def start(self) -> None:
        """Start the child (once; not on a machine with one core, or with
        ``MULTILOOP_SECOND_CORE=0``)."""
        if self.proc is not None or cores() < 2 or os.environ.get("MULTILOOP_SECOND_CORE") == "0":
            return
        # one BLAS thread: the problems are small, and spinning BLAS threads take cores
        env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
        try:
            proc = subprocess.Popen([sys.executable, "-m", "multiloop.web.second_core", str(os.getpid())],
                                    stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                                    env=env)
        except OSError:
            return
        self.proc = proc
        threading.Thread(target=self._read, args=(proc,), name="multiloop-web-second-core", daemon=True).start()

    def submit(self, m, drivers: tuple[int, ...], what: str = "drivers") -> _Task | None:
        """Give the child ``drivers`` of ``m`` (``what``: "drivers", their sweeps and
        checks; "angles", their angles' extremes; "plan", the check's plan of ``m``
        alone); None when it is not running or busy."""
        with self.lock:
            if not self.ready.is_set() or self.proc.poll() is not None or self.task is not None:
                return None
            self.serial += 1
            task = _Task(self.serial)
            try:
                pickle.dump((task.serial, m, what, tuple(drivers)), self.proc.stdin)
                self.proc.stdin.flush()
            except (OSError, pickle.PicklingError):
                return None
            self.task = task
            return task

    def prepare(self, m) -> _Task | None:
        """Have the child decompose ``m`` (and compile its check's plan), nothing more: a
        design the page shows from its cache (a catalogue machine) then finds its
        structure's plan kept in the child (``decompose`` keeps plans by structure) when
        its first edit is checked.  The task, or None (the child busy or not ready)."""
        return self.submit(m, (), "plan")

    def stop(self, task: _Task) -> None:
        """Stop ``task`` at the child's next solve (its job was cancelled)."""
        with self.lock:
            if self.task is task and hasattr(signal, "SIGUSR1"):
                try:
                    os.kill(self.proc.pid, signal.SIGUSR1)
                except OSError:
                    pass

    def _read(self, proc) -> None:
        """The child's results, each to its task (the reader thread), after its word
        that it is ready (its signal handler set, its warm-up done)."""
        try:
            pickle.load(proc.stdout)
        except Exception:  # noqa: BLE001 - the child is gone before its start: never used
            return
        self.ready.set()
        from .jobs import LOG
        LOG.info("second core: ready (pid %d)", proc.pid)
        while True:
            try:
                serial, ok, value = pickle.load(proc.stdout)
            except Exception:  # noqa: BLE001 - the child is gone: no task is ever answered again
                serial, ok, value = None, False, None
            with self.lock:
                task = self.task
                if task is not None and (serial is None or task.serial == serial):
                    self.task = None
                    task.ok, task.value = ok, value
                    task.done.set()
            if serial is None:
                return

    def drivers(self, m, job):
        """Start the child on its share of ``m``'s drivers (:func:`theirs`): ``(drivers,
        wait)``, ``wait()`` giving their ``(Sweep, DriverCheck)`` pairs or None (the job
        then moves them itself); ``wait`` is None when the child is not used (one driver,
        or the child busy, not ready or gone).  A cancelled job stops the child's task too."""
        ks = theirs(len(m.drivers))
        return ks, self._waiter(self.submit(m, ks) if ks else None, job)

    def angles(self, m, job):
        """Start the child on the angles' extremes of ``m``'s only driver: ``wait()``
        giving them (``driver_angles(m, 0).angles``) or None (the job then computes them
        itself); None when the child is not used."""
        return self._waiter(self.submit(m, (0,), "angles") if len(m.drivers) == 1 else None, job)

    def _waiter(self, task, job):
        if task is None:
            return None

        def wait():
            try:
                return task.result(job.poll)
            except BaseException:
                self.stop(task)
                raise
        return wait


#: the server's child (started by :func:`multiloop.web.app.warm_up` after the first page)
SECOND_CORE = SecondCore()


class _Stop(Exception):
    """The task was stopped (its job cancelled)."""


def _warm_up(sweep_driver, driver_check, cancel) -> None:
    """The first task's one-time costs (the solvers' lazy imports and first calls) paid
    at the start, on a catalogue machine with two cylinders."""
    try:
        from multiloop.catalogue.named import load_named
        m = load_named("excavator_bucket")
        for k in range(len(m.drivers)):
            sweep_driver(m, k, cancel=cancel)
            driver_check(m, k, cancel=cancel)
    except Exception:  # noqa: BLE001 - a warm-up only
        pass


def main(argv: list[str]) -> int:
    parent = int(argv[0])
    stop = threading.Event()
    if hasattr(signal, "SIGUSR1"):
        signal.signal(signal.SIGUSR1, lambda *_: stop.set())

    def cancel():
        if os.getppid() != parent:          # the server is gone
            raise SystemExit(0)
        if stop.is_set():
            raise _Stop

    from multiloop.kin.check import driver_angles, driver_check
    from multiloop.kin.check.core import check_plan

    from .scene import sweep_driver
    _warm_up(sweep_driver, driver_check, cancel)
    gc.freeze()                             # (as the server's: no full collection scans the imports)
    inp, out = sys.stdin.buffer, sys.stdout.buffer
    pickle.dump("ready", out)
    out.flush()
    while True:
        try:
            serial, m, what, ks = pickle.load(inp)
        except EOFError:
            return 0
        try:
            if what == "plan":
                check_plan(m)
                value = None
            elif what == "angles":
                value = driver_angles(m, ks[0], cancel=cancel).angles
            else:
                value = [(sweep_driver(m, k, cancel=cancel), driver_check(m, k, cancel=cancel)) for k in ks]
            reply = (serial, True, value)
        except Exception as exc:  # noqa: BLE001 - the job moves these drivers itself (its error is shown)
            reply = (serial, False, str(exc))
        stop.clear()                        # (a stop asked before the reply is this task's)
        pickle.dump(reply, out)
        out.flush()


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except Exception:  # noqa: BLE001 - the server's jobs move every driver themselves
        sys.exit(1)
