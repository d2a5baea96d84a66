"""numba's disk cache kept fresh: numba keys a module's cached machine code on that
module's own file timestamp, so code it inlines from other files (the registry's scalar
steps, another kernel) would stay stale after an edit there.  :func:`as_new_as` makes the
module's file as new as the newest of those sources before its decorators read the
timestamp, so its cache is rebuilt once."""
from __future__ import annotations

import os

__all__ = ["as_new_as"]


def as_new_as(path: str, sources) -> None:
    """Touch ``path`` when one of the files ``sources`` is newer; a read-only install is
    left alone."""
    newest = max(os.path.getmtime(f) for f in sources if f)
    if newest > os.path.getmtime(path):
        try:
            os.utime(path, (newest, newest))
        except OSError:
            pass
