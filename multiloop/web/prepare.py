"""The first page's content, computed by a second process while the server starts.

``multiloop serve`` spends about a second importing Bokeh before it listens;
the first mechanism's drawing, structure, motion and check need about as long again,
mostly to import the solvers (networkx, SciPy).  Done one after the other in the server's
process they are the larger part of the page's load time.  A child process
(``python -m multiloop.web.prepare PARENT_PID``) does the second part on another core
meanwhile: it reads the mechanism and the check's threshold pickled from its stdin and
writes its results pickled to its stdout, as they come:

* ``("scene", (Scene, structure HTML))``: the drawing and the structure tab;
* ``("sweeps", (Sweep, ...))``: the motion of every driver;
* ``("check", (dict, CheckReport))``: ``check(...).as_dict()``, the document of
  ``multiloop check --json``, and the report itself (its verdict in the page's units).

The child writes nothing else, runs at a lower priority (the server's own start comes
first when the cores are busy) and stops at its next solve once the server is gone.
"""
from __future__ import annotations

import os
import pickle
import subprocess
import sys

__all__ = ["start", "results", "main"]


def start(m, threshold: float):
    """Start the child for mechanism ``m``; None when it cannot be started (the server
    then computes the first page itself)."""
    # one BLAS thread: the problems are small, and idle BLAS threads that spin would take
    # the core the server needs
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    try:
        proc = subprocess.Popen([sys.executable, "-m", "multiloop.web.prepare", str(os.getpid())],
                                stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env)
    except OSError:
        return None
    try:
        with proc.stdin:
            pickle.dump((m, float(threshold)), proc.stdin)
    except (OSError, pickle.PicklingError):
        proc.kill()
        proc.wait()
        return None
    return proc


def results(proc):
    """The child's messages ``(kind, value)`` in order; they end early if it failed."""
    with proc.stdout:
        while True:
            try:
                yield pickle.load(proc.stdout)
            except (EOFError, OSError, pickle.UnpicklingError):
                break
    proc.wait()


def main(argv: list[str]) -> int:
    parent = int(argv[0])
    if hasattr(os, "nice"):
        os.nice(10)                     # the server's own start comes first when cores are busy

    def cancel():                       # the server is gone: stop at the next solve
        if os.getppid() != parent:
            raise SystemExit(0)

    m, threshold = pickle.load(sys.stdin.buffer)
    out = sys.stdout.buffer

    def send(kind, value):
        pickle.dump((kind, value), out)
        out.flush()

    from .scene import scene_of, sweep_driver
    from .structure_view import structure_html
    send("scene", (scene_of(m), structure_html(m)))
    if m.drivers and m.has_geometry:
        send("sweeps", tuple(sweep_driver(m, k, cancel=cancel) for k in range(len(m.drivers))))
        from multiloop.kin.check import check      # after the first page's needs
        rep = check(m, min_transmission=threshold, cancel=cancel)
        send("check", (rep.as_dict(), rep))
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except Exception:  # noqa: BLE001 - the server computes what is missing itself
        sys.exit(1)
