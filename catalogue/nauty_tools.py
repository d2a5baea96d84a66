"""Locate nauty's graph generators ``geng`` and ``genbg`` (McKay & Piperno 2014).

The atlas enumerates chains with nauty's generators.  They are found, in order:

1. on the ``PATH`` under their own names (``geng``, ``genbg``), then under Debian's
   names (``nauty-geng``, ``nauty-genbg``);
2. in the ``sage_wheels/bin/`` folder of the ``passagemath-nauty`` wheel, which a plain
   ``pip install multiloop`` installs and which is not on the ``PATH``.

So a pip-only install has working generators, and a system nauty (``apt-get install
nauty``) is used when it is there.  The environment variable ``MULTILOOP_NAUTY_BIN``
names a folder to look in first.

References
----------
B. D. McKay and A. Piperno, "Practical graph isomorphism, II", Journal of Symbolic
Computation 60 (2014) 94–112.

Examples
--------
>>> tool("no-such-generator") is None
True
"""
from __future__ import annotations

import os
import shutil
import sys
import sysconfig
from functools import lru_cache
from pathlib import Path

__all__ = ["tool", "available", "wheel_bin_dirs"]


def wheel_bin_dirs() -> list[Path]:
    """The ``sage_wheels/bin`` folders of every site-packages this Python sees."""
    roots: list[str] = []
    for key in ("purelib", "platlib"):
        p = sysconfig.get_paths().get(key)
        if p:
            roots.append(p)
    roots += [p for p in sys.path if p.endswith("-packages")]
    seen: list[Path] = []
    for r in roots:
        d = Path(r) / "sage_wheels" / "bin"
        if d not in seen and d.is_dir():
            seen.append(d)
    return seen


def _executable(path: Path) -> bool:
    return path.is_file() and os.access(path, os.X_OK)


@lru_cache(maxsize=None)
def tool(name: str) -> str | None:
    """The path of nauty's generator ``name`` (``"geng"`` or ``"genbg"``), or None.

    Parameters
    ----------
    name : str
        The generator's own name.

    Returns
    -------
    str or None
        An executable path, or None when no copy was found.
    """
    extra = os.environ.get("MULTILOOP_NAUTY_BIN")
    if extra and _executable(Path(extra) / name):
        return str(Path(extra) / name)
    for cand in (name, f"nauty-{name}"):
        found = shutil.which(cand)
        if found:
            return found
    for d in wheel_bin_dirs():
        if _executable(d / name):
            return str(d / name)
    return None


def available() -> bool:
    """True when both ``geng`` and ``genbg`` were found."""
    return tool("geng") is not None and tool("genbg") is not None
