"""Run the independent tasks of a type synthesis locally or on a Dask cluster.

* ``workers=1``: in this process, task after task;
* ``workers=k`` (default: all local cores): a :class:`concurrent.futures.ProcessPoolExecutor`;
* ``scheduler="tcp://host:8786"`` (or a :class:`distributed.Client`): one Dask task per
  synthesis task.  Start a cluster with::

      dask scheduler                       # prints tcp://HOST:8786
      dask worker tcp://HOST:8786 --nthreads 1 --nworkers 4    # on every machine

  Every worker needs multiloop and nauty (``geng``/``genbg``) installed.

Results come back as ``(task, records)`` in completion order; the atlas stores each
task in its own transaction, so the partition and the order do not change the result.
"""
from __future__ import annotations

import os
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Iterator, Sequence

from .synthesis import ChainRecord, SynthesisOptions, Task, run_task

__all__ = ["map_tasks", "default_workers"]


def default_workers() -> int:
    """All local cores (``os.sched_getaffinity`` where available)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - macOS, Windows
        return max(1, os.cpu_count() or 1)


def _run(task: Task, opts: SynthesisOptions, loops: bool) -> tuple[Task, list[ChainRecord]]:
    return task, run_task(task, opts, loops)


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
    if not tasks:
        return
    if scheduler is not None:
        yield from _dask(tasks, opts, loops, scheduler)
        return
    workers = default_workers() if workers is None else max(1, int(workers))
    if workers == 1 or len(tasks) == 1:
        for t in tasks:
            yield _run(t, opts, loops)
        return
    # largest tasks first (fewest joints are the big genbg runs at n >= 12)
    order = sorted(tasks, key=lambda t: (abs(t.m - (opts.p * 3) // 4), t.res))
    with ProcessPoolExecutor(max_workers=workers) as pool:
        futures = [pool.submit(_run, t, opts, loops) for t in order]
        try:
            for fut in as_completed(futures):
                yield fut.result()
        except BaseException:
            for fut in futures:
                fut.cancel()
            raise


def _dask(tasks, opts, loops, scheduler):
    from distributed import Client, as_completed as dask_completed

    own = not isinstance(scheduler, Client)
    client = Client(scheduler) if own else scheduler
    try:
        futures = [client.submit(_run, t, opts, loops, pure=False) for t in tasks]
        for fut in dask_completed(futures):
            yield fut.result()
    finally:
        if own:
            client.close()
