"""Type synthesis, task by task: nauty's generators piped through the exact NumPy
degeneracy filter (:func:`run_task`), and the independent brute-force route
(:func:`brute_force_chains`)."""
from __future__ import annotations

import itertools
import subprocess
from typing import Iterator, Sequence

import numpy as np

from multiloop.topo.errors import InputError, explain

from .assortments import in_row
from .degenerate import _degenerate_by_definition, joint_masks_degenerate
from .nauty import _decode_bipartite, _decode_simple, _generator_command, nauty_available
from .options import SynthesisOptions, Task, plan_tasks
from .records import ChainRecord, _certificate, _connected, _fractionation, chain_record

__all__ = ["run_task", "count_task", "iter_chains", "brute_force_chains"]


def _raw_task(task: Task, opts: SynthesisOptions, batch: int = 20000) -> Iterator[np.ndarray]:
    """Joint masks of the non-degenerate chains of one task, in batches."""
    if not nauty_available():
        raise InputError(explain("type synthesis", expected="nauty's geng/genbg (PATH or the passagemath-nauty wheel)",
                                 got="neither geng nor nauty-geng found",
                                 hint="pip install passagemath-nauty (or apt-get install nauty), "
                                      "or use method='brute-force' for small n"))
    cmd = _generator_command(task, opts)
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    p = opts.p
    try:
        buf: list[bytes] = []
        assert proc.stdout is not None
        for line in proc.stdout:
            buf.append(line.rstrip(b"\n"))
            if len(buf) >= batch:
                yield _filter_batch(buf, task, opts, p)
                buf = []
        if buf:
            yield _filter_batch(buf, task, opts, p)
    finally:
        proc.stdout.close()  # type: ignore[union-attr]
        proc.wait()


def _filter_batch(lines: list[bytes], task: Task, opts: SynthesisOptions, p: int) -> np.ndarray:
    if task.m == p:
        masks = _decode_simple(lines, opts.n, p)
    else:
        masks = _decode_bipartite(lines, opts.n, task.m)
    keep = ~joint_masks_degenerate(masks, opts.n)
    masks = masks[keep]
    return masks[in_row(masks, opts)]


def run_task(task: Task, opts: SynthesisOptions, loops: bool = True) -> list[ChainRecord]:
    """All chains of one task with their numbers (after the option filters)."""
    out = []
    for masks in _raw_task(task, opts):
        for row in masks.tolist():
            rec = _record_if_kept(row, opts, loops)
            if rec is not None:
                out.append(rec)
    return out


def count_task(task: Task, opts: SynthesisOptions) -> int:
    """Number of chains of one task (fast path when no per-chain filter is set)."""
    if opts.planar or opts.no_fractionated:
        return len(run_task(task, opts, loops=False))
    return sum(len(masks) for masks in _raw_task(task, opts))


def _record_if_kept(joints: Sequence[int], opts: SynthesisOptions, loops: bool) -> ChainRecord | None:
    rec = chain_record(opts.n, opts.F, joints, loops=loops)
    if opts.planar and not rec.planar:
        return None
    if opts.no_fractionated and rec.fractionated:
        return None
    return rec


def iter_chains(opts: SynthesisOptions, loops: bool = True) -> Iterator[ChainRecord]:
    """Every chain of the options, task after task (serial)."""
    for task in plan_tasks(opts):
        yield from run_task(task, opts, loops)


# ------------------------------------------------------------------ brute force
def brute_force_chains(opts: SynthesisOptions) -> list[tuple[int, ...]]:
    """Independent route: add joints to ``n`` labelled links one at a time, drop
    degenerate partial chains (by the definition), dedupe by pynauty certificates.

    Returns sorted joint-mask tuples of the surviving chains (connected, every link on
    two or more joints, the options' filters applied except planarity).
    Exponential: meant for ``n <= 8``.
    """
    n, p = opts.n, opts.p
    cands = [sum(1 << x for x in c) for size in range(2, opts.j_cap + 2)
             for c in itertools.combinations(range(n), size) if size - 1 <= p]
    level = {_certificate(n, ()): ()}
    results: dict[bytes, tuple[int, ...]] = {}
    for _ in range(p):
        nxt: dict[bytes, tuple[int, ...]] = {}
        for joints in level.values():
            used = sum(bin(j).count("1") - 1 for j in joints)
            for c in cands:
                if c in joints or used + bin(c).count("1") - 1 > p:
                    continue
                new = tuple(sorted(joints + (c,)))
                if any(bin(c & j).count("1") >= 2 for j in joints):
                    continue   # two links on two common joints: over-constrained
                deg = [sum(1 for j in new if j >> x & 1) for x in range(n)]
                if max(deg) > opts.i_cap:
                    continue
                cert = _certificate(n, new)
                if cert in nxt or cert in results:
                    continue
                if _degenerate_by_definition(new, n):
                    continue
                if used + bin(c).count("1") - 1 == p:
                    if min(deg) >= 2 and _connected(n, new):
                        results[cert] = new
                else:
                    nxt[cert] = new
        level = nxt
        if not level:
            break
    out = []
    for joints in results.values():
        if opts.no_fractionated:
            cl, cj = _fractionation(n, joints)
            if cl or cj:
                continue
        out.append(joints)
    return sorted(out)
