"""The default curve atlas of synthesis without a start: built once, on first use, into
the user's cache folder, and reused by every later run.

Its parts are those the documentation recommends for a first atlas
(:data:`DEFAULT_PARTS`): every 1-DOF four-bar inversion with 64 realisations, every
six-link mechanism (multiple joints too) with 24, the simple-joint eight-link ones with 4
and the eight-link ones with multiple joints with 2, each realisation with its coupler
curves (:mod:`.curve_atlas`).  It is built into a
``.partial`` file (resumable: a run interrupted half-way goes on where it stopped) and
renamed when complete, so an atlas under the final name is always whole.  Two runs
that start at once build it once: the second waits for the first (a file lock).
The file's name carries a digest of the parts: a release that changes them builds anew.
"""
from __future__ import annotations

import hashlib
import os
from pathlib import Path

from .synthesis import SynthesisOptions

__all__ = ["DEFAULT_PARTS", "default_atlas_path", "ensure_default_atlas", "BUILD_NOTE"]

#: (chains, realisations per mechanism) of the default atlas
DEFAULT_PARTS: tuple[tuple[SynthesisOptions, int], ...] = (
    (SynthesisOptions(4, 1), 64),
    (SynthesisOptions(6, 1), 24),
    (SynthesisOptions(8, 1, simple_joints=True), 4),
    (SynthesisOptions(8, 1), 2),          # the eight-links with multiple joints (the simple-joint ones are done)
)

#: what a first build says before it starts (the cost measured on 2 cores, see docs/synthesis.md)
BUILD_NOTE = ("building the default curve atlas once, into {path} (4, 6 and 8 links, multiple joints included; "
              "3 to 5 minutes on 2 cores; later runs reuse it; --db chooses another atlas)")


def _digest(parts) -> str:
    text = ";".join(f"{o.key()}:{k}" for o, k in parts)
    return hashlib.sha256(text.encode()).hexdigest()[:10]


def default_atlas_path(parts=None) -> Path:
    """Where the default atlas lives: ``curve-atlas-<digest of its parts>.sqlite`` in
    ``$MULTILOOP_CACHE``, else the user cache folder of multiloop (platformdirs)."""
    from .synthesis.counter_build import cache_dir
    return cache_dir() / f"curve-atlas-{_digest(DEFAULT_PARTS if parts is None else parts)}.sqlite"


def ensure_default_atlas(progress: bool = False, say=None, workers: int | None = None) -> Path:
    """The default atlas's path, built first when it is not there yet.

    Parameters
    ----------
    progress : bool
        Progress bars while it is built.
    say : callable(str), optional
        Told :data:`BUILD_NOTE` (with the path) before a build starts.
    workers : int, optional
        Local processes drawing the curves (default: the available cores).

    Returns
    -------
    Path
        The complete atlas.
    """
    import fcntl

    from .atlas import Atlas
    from .atlas_build import build_atlas
    parts = DEFAULT_PARTS
    final = default_atlas_path(parts)
    if final.is_file():
        return final
    final.parent.mkdir(parents=True, exist_ok=True)
    partial = final.with_name(final.stem + ".partial.sqlite")
    with open(final.with_name(final.stem + ".lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)             # a second run waits for the first
        if final.is_file():
            return final
        if say is not None:
            say(BUILD_NOTE.format(path=final))
        with Atlas(partial) as atlas:
            for opts, k in parts:
                build_atlas(atlas, opts, loops=False, mechanisms=True, curves=k, workers=workers, progress=progress)
        os.replace(partial, final)
    return final
