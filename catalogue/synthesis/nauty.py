"""nauty's generators (McKay & Piperno 2014): finding ``geng``/``genbg``, the command of
a task, and decoding their graph6 output into joint bit masks with NumPy."""
from __future__ import annotations

from typing import Sequence

import numpy as np

from .. import nauty_tools
from .options import SynthesisOptions, Task

__all__ = ["nauty_available"]


def nauty_available() -> bool:
    """True when nauty's ``geng`` and ``genbg`` were found (:mod:`catalogue.nauty_tools`)."""
    return _tool("geng") is not None and _tool("genbg") is not None


def _tool(name: str) -> str | None:
    return nauty_tools.tool(name)


# ------------------------------------------------------------------ graph6 decoding
def _graph6_bits(lines: Sequence[bytes], N: int) -> np.ndarray:
    """Upper-triangle adjacency bits of same-order graph6 lines, shape (B, N(N−1)/2)."""
    width = len(lines[0])
    arr = np.frombuffer(b"".join(lines), dtype=np.uint8).reshape(len(lines), width)
    data = arr[:, 1:] - 63
    bits = np.unpackbits(data[:, :, None], axis=2)[:, :, 2:].reshape(len(lines), -1)
    return bits[:, : N * (N - 1) // 2]


def _pos(i: int, j: int) -> int:
    """graph6 bit index of the pair (i, j), i < j."""
    return j * (j - 1) // 2 + i


def _decode_bipartite(lines: Sequence[bytes], n: int, m: int) -> np.ndarray:
    """Joint masks (B, m) of genbg output (links 0…n−1, joints n…n+m−1)."""
    bits = _graph6_bits(lines, n + m)
    idx = np.array([[_pos(i, n + a) for i in range(n)] for a in range(m)])
    sel = bits[:, idx].astype(np.int64)                    # (B, m, n)
    return sel @ (np.int64(1) << np.arange(n, dtype=np.int64))


def _decode_joints_first(lines: Sequence[bytes], n: int, m: int) -> np.ndarray:
    """Joint masks (B, m) of genbg output with the classes swapped (joints 0…m−1, links
    m…m+n−1)."""
    bits = _graph6_bits(lines, n + m)
    idx = np.array([[_pos(a, m + i) for i in range(n)] for a in range(m)])
    sel = bits[:, idx].astype(np.int64)                    # (B, m, n)
    return sel @ (np.int64(1) << np.arange(n, dtype=np.int64))


def _decode_simple(lines: Sequence[bytes], n: int, p: int) -> np.ndarray:
    """Joint (edge) masks (B, p) of geng output."""
    bits = _graph6_bits(lines, n)
    pairs = [(i, j) for j in range(1, n) for i in range(j)]
    pm = np.array([(1 << i) | (1 << j) for i, j in pairs], dtype=np.int64)
    rows, cols = np.nonzero(bits)
    if len(rows) != len(lines) * p:  # pragma: no cover - geng was asked for p edges
        raise RuntimeError("geng returned graphs with an unexpected number of edges")
    return pm[cols].reshape(len(lines), p)


# -------------------------------------------------------------------- generation
def _generator_command(task: Task, opts: SynthesisOptions) -> list[str]:
    p = opts.p
    lo, hi = opts.link_degrees()
    if task.m == p:   # simple joints: triangle-free graphs, min degree 2
        cmd = [_tool("geng"), "-cq", f"-d{lo}", "-t", f"-D{hi}", str(opts.n), f"{p}:{p}"]
    else:
        cmd = [_tool("genbg"), "-q", *genbg_bounds(task, opts)]
    if task.mod > 1:
        cmd.append(f"{task.res}/{task.mod}")
    return cmd


def genbg_bounds(task: Task, opts: SynthesisOptions) -> list[str]:
    """genbg's arguments for the links × joints graphs of ``task`` (without the residue):
    the degree bounds of both classes (the options' caps and restricted row), two joints
    on at most one common link (``-Z1``), the two class sizes and the incidence count."""
    lo, hi = opts.link_degrees()
    jlo, jhi = opts.joint_sizes(task.m)
    e = opts.p + task.m
    split = [] if task.level is None else [f"-X{task.level - _default_split_level(task.m)}"]
    return ["-c", f"-d{lo}:{jlo}", f"-D{hi}:{jhi}", "-Z1", *split, str(opts.n), str(task.m), f"{e}:{e}"]


def genbg_swapped(task: Task, opts: SynthesisOptions) -> list[str]:
    """genbg's arguments for the same graphs with the classes swapped: joints first, the
    links added one at a time last (``-Z1`` then says two links share at most one joint,
    which non-degeneracy implies as well: two links on two common joints are rigid)."""
    lo, hi = opts.link_degrees()
    jlo, jhi = opts.joint_sizes(task.m)
    e = opts.p + task.m
    return ["-c", f"-d{jlo}:{lo}", f"-D{jhi}:{hi}", "-Z1", str(task.m), str(opts.n), f"{e}:{e}"]


def _default_split_level(m: int) -> int:
    """The level (joints placed) at which genbg splits ``res/mod`` by default; ``-X``
    moves it by the difference."""
    return m - 2 if m >= 6 else m - 1 if m >= 3 else m
