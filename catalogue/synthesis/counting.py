"""Number synthesis by counting: the chains of a task tallied by their row ([LA],
[MJA]) without storing them — the route of the large tables (14 links: tens of millions
of chains).

Three routes give the same rows:

* **compiled** (:func:`~.counter_build.find_counter`): nauty's genbg with our pruning
  procedure (``c/chaincount.c``): a degenerate partial chain, or one that can no longer
  reach the restricted row, is cut with its whole subtree, and every output chain is
  tallied inside the generator;
* **Python**: the generator's output through the exact NumPy degeneracy filter
  (:func:`~.degenerate.joint_masks_degenerate`) and :func:`~.assortments.tally_rows`;
* **swapped**: the second route of the cross-checks: genbg with the two classes swapped
  (the joints first, the links added one at a time), so that its search tree, its
  isomorph rejection and its residues are another's, through the NumPy filter; it
  shares neither the pruning nor the tally with the compiled route.

Tasks (:func:`count_tasks`) are those of type synthesis split finer, at a level nearer
the root of genbg's search (``-X``), so that a 14-link count runs as some hundreds of
resumable pieces of seconds to minutes.
"""
from __future__ import annotations

import hashlib
import json
import os
import subprocess
from collections import Counter

from multiloop.topo.errors import InputError, explain

from .assortments import in_row, tally_rows
from .counter_build import find_counter
from .degenerate import joint_masks_degenerate
from .enumeration import _raw_task
from .nauty import _decode_joints_first, _tool, genbg_bounds, genbg_swapped
from .options import SynthesisOptions, Task, joint_counts

__all__ = ["count_tasks", "count_rows", "count_signature", "RowCounts"]

#: a task's tally: (LA, MJA) -> chains, both assortments without trailing zeros
RowCounts = Counter


def _count_split(opts: SynthesisOptions, m: int) -> tuple[int, int | None]:
    """Residues and split level of the count tasks with ``m`` joints."""
    if opts.n <= 10 or m < 6:
        return 1, None
    return (8 if opts.n <= 12 else 64), m // 2 + 1


def count_tasks(opts: SynthesisOptions) -> list[Task]:
    """The tasks of a count: one per joint count ``m`` and residue."""
    out = []
    for m in joint_counts(opts):
        mod, level = _count_split(opts, m)
        out += [Task(opts.n, opts.F, m, r, mod, level if mod > 1 else None) for r in range(mod)]
    return out


def _arguments(task: Task, opts: SynthesisOptions) -> list[str]:
    """The generator's arguments of a count task (its residue included)."""
    return genbg_bounds(task, opts) + ([f"{task.res}/{task.mod}"] if task.mod > 1 else [])


def count_signature(opts: SynthesisOptions) -> str:
    """A digest of the generator arguments of every count task: a residue's chains depend
    on every bound of genbg's search, so a count resumes only tasks of the same
    signature (a changed generator starts a fresh count)."""
    text = json.dumps([_arguments(t, opts) for t in count_tasks(opts)])
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def count_rows(task: Task, opts: SynthesisOptions, route: str = "auto") -> RowCounts:
    """The chains of ``task`` counted by row.

    Parameters
    ----------
    route : {"auto", "compiled", "python", "swapped"}
        ``auto``: the compiled counter when it is built, else Python.
    """
    if route == "swapped":
        return _swapped(task, opts)
    if opts.planar or opts.no_fractionated:
        raise InputError(explain("count", expected="no per-chain filter (planar, no_fractionated)",
                                 got="a filter that needs each chain's record",
                                 hint="build the chains (multiloop atlas without --table) to filter them"))
    exe = find_counter() if route != "python" else None
    if route == "compiled" and exe is None:
        raise InputError(explain("route", expected="the compiled counter",
                                 got="it is not built",
                                 hint="python3 -m multiloop.catalogue.synthesis.counter_build"))
    if exe is None:
        counts: RowCounts = Counter()
        for masks in _raw_task(task, opts):
            counts += tally_rows(masks, opts.n)
        return counts
    return _compiled(str(exe), task, opts)


def _swapped(task: Task, opts: SynthesisOptions) -> RowCounts:
    cmd = [_tool("genbg"), "-q", *genbg_swapped(task, opts)] + ([f"{task.res}/{task.mod}"] if task.mod > 1 else [])
    counts: RowCounts = Counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, preexec_fn=_die_with_parent)
    assert proc.stdout is not None
    with proc:
        for lines in _batches(proc.stdout):
            masks = _decode_joints_first(lines, opts.n, task.m)
            masks = masks[~joint_masks_degenerate(masks, opts.n)]
            counts += tally_rows(masks[in_row(masks, opts)], opts.n)
    return counts


def _batches(stream, size: int = 20000):
    """graph6 lines of a stream in lists of ``size``."""
    buf: list[bytes] = []
    for line in stream:
        buf.append(line.rstrip(b"\n"))
        if len(buf) >= size:
            yield buf
            buf = []
    if buf:
        yield buf


def _compiled(exe: str, task: Task, opts: SynthesisOptions) -> RowCounts:
    cmd = [exe, "-q", *_arguments(task, opts)]
    env = dict(os.environ, MULTILOOP_LA=_listed(opts.la), MULTILOOP_MJA=_listed(opts.mja))
    done = subprocess.run(cmd, capture_output=True, text=True, env=env, check=True, preexec_fn=_die_with_parent)
    return _parse(done.stdout, opts)


def _die_with_parent() -> None:
    """In the counter's process: die when the caller dies (Linux ``PR_SET_PDEATHSIG``), so
    that a killed count leaves no generator running."""
    try:
        import ctypes
        ctypes.CDLL(None).prctl(1, 9, 0, 0, 0)     # PR_SET_PDEATHSIG = 1, SIGKILL = 9
    except (OSError, AttributeError):  # pragma: no cover - not Linux
        pass


def _listed(counts: tuple[int, ...] | None) -> str:
    """An assortment for the counter's environment (``*``: not restricted)."""
    return "*" if counts is None else ",".join(map(str, counts))


def _parse(text: str, opts: SynthesisOptions) -> RowCounts:
    counts: RowCounts = Counter()
    total = None
    for line in text.splitlines():
        word = line.split()
        if word[0] == "LA":
            la = () if word[1] == "-" else tuple(map(int, word[1].split(",")))
            mja = () if word[3] == "-" else tuple(map(int, word[3].split(",")))
            counts[(la, mja)] += int(word[4])
        elif word[0] == "total":
            total = int(word[1])
    if total is None or total != sum(counts.values()):   # pragma: no cover - a broken counter
        raise RuntimeError(f"the compiled counter's output is incomplete: {text[-200:]!r}")
    return counts
