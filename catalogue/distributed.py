"""Run the independent tasks of a type synthesis locally or on a Dask cluster.

* ``workers=1``: in this process, task after task;
* ``workers=k`` (default: all local cores): a :class:`concurrent.futures.ProcessPoolExecutor`;
* ``scheduler="tcp://host:8786"`` (or a :class:`distributed.Client`): one Dask task per
  synthesis task (:func:`map_calls` does the same for any module-level function: the
  curve atlas runs one task per mechanism).  Start a cluster with::

      dask scheduler                       # prints tcp://HOST:8786
      dask worker tcp://HOST:8786 --nthreads 1 --nworkers 4    # on every machine

  Every worker needs multiloop and nauty (``geng``/``genbg``) installed.

Results come back as ``(task, records)`` in completion order; the atlas stores each
task in its own transaction, so the partition and the order do not change the result.

Local pool workers die with their parent: each asks the kernel for a signal when its
parent dies (Linux ``PR_SET_PDEATHSIG``) and also watches its parent id, so killing
``multiloop atlas`` (SIGKILL or SIGTERM) leaves no orphan; the killed tasks stay
pending and a rerun resumes them.  An unreachable scheduler is an
:class:`~topo.errors.InputError` after a short connect timeout.
"""
from __future__ import annotations

import os
import signal
import threading
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Iterator, Sequence

from multiloop.topo.errors import ParameterError, explain

from .synthesis import ChainRecord, SynthesisOptions, Task, iter_chains, plan_tasks, run_task

__all__ = ["map_calls", "map_tasks", "map_count_tasks", "default_workers", "type_synthesis", "die_with_parent", "connect_scheduler", "require_dask",
           "SCHEDULER_TIMEOUT"]

#: seconds to wait for a Dask scheduler before giving up
SCHEDULER_TIMEOUT = 5.0


def default_workers() -> int:
    """All local cores (``os.sched_getaffinity`` where available)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - macOS, Windows
        return max(1, os.cpu_count() or 1)


def die_with_parent(parent: int | None = None, poll: float = 0.5) -> None:
    """Make this process exit when its parent dies (pool-worker initializer).

    Linux delivers SIGKILL on the parent's death (``prctl(PR_SET_PDEATHSIG)``); a
    daemon thread that polls ``os.getppid()`` covers the other platforms and the
    window before the ``prctl`` call.
    """
    parent = os.getppid() if parent is None else parent
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL, 0, 0, 0)     # PR_SET_PDEATHSIG = 1
    except (OSError, AttributeError):  # pragma: no cover - not Linux
        pass

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(poll)
        os._exit(1)

    if os.getppid() != parent:
        os._exit(1)
    threading.Thread(target=watch, daemon=True, name="die-with-parent").start()


def _run(task: Task, opts: SynthesisOptions, loops: bool) -> tuple[Task, list[ChainRecord]]:
    return task, run_task(task, opts, loops)


def map_calls(fn, calls: Sequence[tuple], workers: int = 1, scheduler=None) -> Iterator:
    """``fn(*args)`` for every ``args`` of ``calls``, yielded as each finishes: in this
    process one after the other (``workers`` 1), in a pool of ``workers`` local processes
    that die with their parent, or as one Dask task each on ``scheduler`` (an address or
    a :class:`distributed.Client`; it overrides ``workers``).  ``fn`` must be importable
    by the workers (a module-level function)."""
    calls = list(calls)
    if scheduler is not None:       # (connects even when nothing is pending: a bad address is reported)
        yield from _dask(fn, calls, scheduler)
        return
    if workers <= 1 or len(calls) <= 1:
        for c in calls:
            yield fn(*c)
        return
    with ProcessPoolExecutor(max_workers=workers, initializer=die_with_parent,
                             initargs=(os.getpid(),)) as pool:
        futures = [pool.submit(fn, *c) for c in calls]
        try:
            for fut in as_completed(futures):
                yield fut.result()
        except BaseException:
            for fut in futures:
                fut.cancel()
            raise


def map_tasks(tasks: Sequence[Task], opts: SynthesisOptions, loops: bool = True,
              workers: int | None = None, scheduler=None) -> Iterator[tuple[Task, list[ChainRecord]]]:
    """Run ``tasks`` and yield ``(task, records)`` as each finishes.

    Parameters
    ----------
    tasks : sequence of Task
    opts : SynthesisOptions
    loops : bool
        Compute planarity and the loop assortment of every chain.
    workers : int, optional
        Local processes (default all cores; 1 runs in this process).
    scheduler : str or distributed.Client, optional
        Address of a Dask scheduler (or a client); overrides ``workers``.
    """
    tasks = list(tasks)
    workers = default_workers() if workers is None else max(1, int(workers))
    if scheduler is None and workers > 1:
        # largest tasks first (fewest joints are the big genbg runs at n >= 12)
        tasks = sorted(tasks, key=lambda t: (abs(t.m - (opts.p * 3) // 4), t.res))
    yield from map_calls(_run, [(t, opts, loops) for t in tasks], workers, scheduler)


def _count(task: Task, opts: SynthesisOptions):
    from .synthesis.counting import count_rows
    return task, count_rows(task, opts)


def map_count_tasks(tasks: Sequence[Task], opts: SynthesisOptions, workers: int | None = None,
                    scheduler=None) -> Iterator[tuple[Task, dict]]:
    """Count the chains of ``tasks`` by row (:func:`~.synthesis.counting.count_rows`) and
    yield ``(task, counts)`` as each finishes; ``workers`` and ``scheduler`` as
    :func:`map_tasks`."""
    workers = default_workers() if workers is None else max(1, int(workers))
    # residue by residue across the joint counts: the tasks done so far are a fair sample
    # of the whole, so the progress bar's estimate of the time left holds from the start
    tasks = sorted(tasks, key=lambda t: (t.res, t.m))
    yield from map_calls(_count, [(t, opts) for t in tasks], workers, scheduler)


def require_dask() -> None:
    """Raise :class:`InputError` naming the ``[dask]`` extra when Dask is not installed."""
    import importlib.util

    if importlib.util.find_spec("distributed") is None:
        raise ParameterError(explain("scheduler", expected="Dask's distributed package",
                                     got="it is not installed",
                                     hint="pip install 'multiloop[dask]' (the [dask] extra), "
                                          "or drop 'scheduler' to use local processes"), "scheduler")


def _dask(fn, calls, scheduler):
    require_dask()
    from distributed import Client, as_completed as dask_completed

    own = not isinstance(scheduler, Client)
    client = connect_scheduler(scheduler) if own else scheduler
    try:
        futures = [client.submit(fn, *c, pure=False) for c in calls]
        for fut in dask_completed(futures):
            yield fut.result()
    finally:
        if own:
            client.close()


def connect_scheduler(address: str):
    """A Dask client, or InputError when the scheduler cannot be reached in time."""
    from distributed import Client

    try:
        return Client(address, timeout=SCHEDULER_TIMEOUT)
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        raise ParameterError(explain("scheduler", expected="a reachable Dask scheduler (tcp://host:8786)",
                                     got=f"{address!r}: {type(exc).__name__}: {exc}"[:200],
                                     hint=f"start one with `dask scheduler`; connect timeout "
                                          f"{SCHEDULER_TIMEOUT:g} s"), "scheduler") from None


def type_synthesis(opts: SynthesisOptions, loops: bool = True, workers: int | None = 1,
                   scheduler: str | None = None) -> list[ChainRecord]:
    """All non-isomorphic chains, sorted by canonical form.

    ``workers`` > 1 uses local processes, ``scheduler`` a Dask cluster.
    """
    if (workers or 1) == 1 and scheduler is None:
        recs = list(iter_chains(opts, loops))
    else:
        recs = [r for part in map_tasks(plan_tasks(opts), opts, loops, workers=workers,
                                        scheduler=scheduler) for r in part[1]]
    return sorted(recs, key=lambda r: r.canonical)
