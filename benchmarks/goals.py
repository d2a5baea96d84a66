"""The performance goals as a table: one row per goal (measured value, goal, met or not).

``GOALS`` is the registry: each :class:`Goal` names what is measured, its unit, the
limit and a function that measures it (on this machine, now).  ``multiloop bench
--goals`` prints the table (``benchmarks/bench_goals.py``).  A new goal is one more
entry in ``GOALS``.

CPU times are ``time.process_time`` (in-process) or the child's user + system time
(``resource.getrusage``) for a command run as a subprocess, so the load of other
processes on a shared machine changes them less than wall times; the load average is
printed with the table.
"""
from __future__ import annotations

import os
import resource
import subprocess
import sys
import time
import warnings
from dataclasses import dataclass
from typing import Callable

import numpy as np


@dataclass(frozen=True)
class Goal:
    """One goal row: ``measure()`` returns the value, met when ``value <= limit``."""

    name: str
    unit: str
    limit: float
    measure: Callable[[], float]
    issue: int | None = None


def _command_cpu(*argv: str) -> float:
    """User + system CPU seconds of ``python -m multiloop ARGV`` (a fresh process:
    imports included, as a user runs it)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([sys.executable, "-m", "multiloop", *argv], check=True, stdout=subprocess.DEVNULL)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def check_excavator_cpu() -> float:
    """``multiloop check excavator`` (three cylinders, modes enumerated): CPU seconds."""
    return _command_cpu("check", "excavator")


def excavator_grid_solve_cpu() -> float:
    """One ``solve`` of the excavator on a 20 × 20 × 20 grid of its three cylinders over
    their usable ranges (each range cut by the assembly limits, from ``check``; a batch is
    a path from the reference, so a grid reaching past a limit fails from there on)
    ((8000, 3) inputs, plan compiled first): CPU seconds, best of 3."""
    from multiloop.catalogue.named import load_named
    from multiloop.kin.check import check
    from multiloop.kin.solve import plan_of, solve

    m = load_named("excavator")
    # 0.1 % inside the ends: a grid whose bucket values reach the toggle exactly touches
    # the limit on every row (400 crossings of the walk, each resolved and marked singular:
    # it solves, in ~5 s CPU; tests/test_singular.py), which is not the interior grid timed here
    axes = [np.linspace(lo + 1e-3 * (hi - lo), hi - 1e-3 * (hi - lo), 20)
            for lo, hi in (dc.usable for dc in check(m).drivers)]
    X = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    plan_of(m)
    best = np.inf
    for _ in range(3):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t0 = time.process_time()
            solve(m, X)
            best = min(best, time.process_time() - t0)
    return best


#: the goals, one row each
GOALS: list[Goal] = [
    Goal("check excavator (modes enumerated)", "s CPU", 10.0, check_excavator_cpu, 24),
    Goal("solve excavator, 20x20x20 grid, one call", "s CPU", 1.0, excavator_grid_solve_cpu, 24),
]


def table(goals=None) -> list[str]:
    """Measure every goal and return the table's lines (each says ``goal``)."""
    rows = []
    for g in GOALS if goals is None else goals:
        v = float(g.measure())
        rows.append(f"goal {g.name}: {v:.3g} {g.unit} (goal <= {g.limit:g} {g.unit}) -> "
                    f"{'MET' if v <= g.limit else 'NOT MET'}" + (f" [issue {g.issue}]" if g.issue else ""))
    load = os.getloadavg()
    rows.append(f"(load average {load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f} on {os.cpu_count()} cores)")
    return rows
