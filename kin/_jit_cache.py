"""numba's disk cache kept fresh across the files a compiled module's code inlines.

numba keys a module's cached machine code on that module's own source file alone (its
content's hash from numba 0.59 on, its time stamp and size before), but the kernels'
code inlines code from other files: the registry's scalar steps and lowerings
(``kin/groups/*.py``), the triad's tracker, another kernel.  After an edit there (or an
upgrade that changes them and not the kernel's file) the cache would hand back the old
code.  :func:`depends_on` names those sources before the module's decorators read its
stamp:

* the stamp of a registered module becomes its own stamp plus the hash of every source's
  content, transitively (a source that is itself a registered module brings its own),
  through a cache locator placed first in numba's list (:class:`_InTree`, or
  :class:`_UserDir` under ``NUMBA_CACHE_DIR``); numba then rebuilds the cache once;
* for a numba that keys on time stamps, the module's file is also made as new as the
  newest source (a read-only install is left alone).
"""
from __future__ import annotations

import functools
import hashlib
import os

from numba.core import caching

__all__ = ["depends_on", "source_stamp"]

#: a registered module's file -> the source files its compiled code inlines
_SOURCES: dict[str, tuple[str, ...]] = {}


@functools.lru_cache(maxsize=None)
def _key(path: str) -> str:
    return os.path.normcase(os.path.realpath(path))


def depends_on(path: str, sources) -> None:
    """Record that the compiled code of module file ``path`` inlines code from the files
    ``sources``: its cached machine code is valid only for their present contents.  Call
    before the module's ``numba.njit(cache=True)`` decorators run."""
    srcs = tuple(sorted({_key(f) for f in sources if f} - {_key(path)}))
    _SOURCES[_key(path)] = srcs
    _install()
    newest = max((os.path.getmtime(f) for f in srcs), default=0.0)
    if newest > os.path.getmtime(path):
        try:
            os.utime(path, (newest, newest))
        except OSError:
            pass


def source_stamp(path: str, _seen=None) -> str:
    """The hash of the contents of every source registered for ``path`` (transitively)."""
    seen = set() if _seen is None else _seen
    h = hashlib.sha256()
    for f in _SOURCES.get(_key(path), ()):
        if f in seen:
            continue
        seen.add(f)
        st = os.stat(f)
        h.update(f.encode() + b"\0" + _digest(f, st.st_mtime_ns, st.st_size))
        h.update(source_stamp(f, seen).encode())
    return h.hexdigest()


@functools.lru_cache(maxsize=None)
def _digest(path: str, mtime_ns: int, size: int) -> bytes:
    """The hash of a file's content, read once per version of it in a process (every
    compiled function of a module asks for its stamp)."""
    with open(path, "rb") as fh:
        return hashlib.sha256(fh.read()).digest()


class _WithSources:
    """A cache locator for a registered module: numba's own, its stamp extended by the
    registered sources' (:func:`source_stamp`)."""

    @classmethod
    def from_function(cls, py_func, py_file):
        if _key(py_file) not in _SOURCES:
            return None
        return super().from_function(py_func, py_file)

    def get_source_stamp(self):
        return super().get_source_stamp(), source_stamp(self._py_file)


_IMPL = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl")


class _UserDir(_WithSources, getattr(caching, "UserProvidedCacheLocator", None)
               or getattr(caching, "_UserProvidedCacheLocator")):
    """numba's ``NUMBA_CACHE_DIR`` locator, its stamp extended."""


class _InTree(_WithSources, getattr(caching, "InTreeCacheLocator", None) or getattr(caching, "_InTreeCacheLocator")):
    """numba's ``__pycache__`` locator, its stamp extended."""


def _install() -> None:
    """Put the locators first in numba's list, once."""
    if _IMPL._locator_classes[:2] != [_UserDir, _InTree]:
        _IMPL._locator_classes[:0] = [_UserDir, _InTree]
