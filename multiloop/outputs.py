"""The one safe output writer of the command line: every file a command writes goes here.

A command collects its outputs in an :class:`Outputs` set while it computes, then
calls :meth:`Outputs.commit` once at the end.  The rules (each has a regression test
in ``tests/test_outputs.py``):

* **All or nothing.**  Nothing touches the file system before ``commit``; a run that
  fails before it writes none of its outputs, and a commit that fails part-way removes
  every temporary file and every directory it created.
* **Regular files are replaced atomically.**  The bytes go to a temporary file in the
  target's own directory (``.NAME.XXXX.tmp``), which is then renamed over the target
  (``os.replace``).  The temporary file is removed in ``finally`` on every exit,
  SIGTERM included; an existing file keeps its permission bits.
* **Symbolic links are written through.**  The link's final target gets the content;
  the link itself stays a link.
* **Nothing is renamed over a non-regular file.**  A FIFO or a character device
  (``/dev/null``, ``/dev/full``, a terminal) is written in place; a FIFO without a
  reader, a device that refuses the bytes (``/dev/full``: no space), a block device
  or a socket is refused with an :class:`OutputError` (exit 2).
* **Bad targets are exit 2, checked before the work starts:** an empty name, a
  directory where a file is expected (or a file where a directory is expected), a
  missing parent directory, no write permission, an unknown figure format.
* **A read-only file is never replaced**, even by root (whom the permission check
  lets through, and whose atomic rename would replace it): a regular target with no
  write bit is exit 2; make it writable or name another file.

Figures are rendered in memory (:meth:`Outputs.add_figure`); matplotlib's warnings
are collected and reported as one line each on stderr, never raw
(:func:`quiet_warnings`), and text is never parsed as mathtext, so names containing
``$`` draw as they are.

Examples
--------
>>> import tempfile, pathlib
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> out = Outputs("demo")
>>> p = out.add(d / "a.txt", "hello\\n", what="--out")
>>> (d / "a.txt").exists()
False
>>> [q.name for q in out.commit()]
['a.txt']
>>> (d / "a.txt").read_text()
'hello\\n'
"""
from __future__ import annotations

import contextlib
import errno
import io
import json
import os
import signal
import stat
import sys
import tempfile
import threading
import warnings
from pathlib import Path

from multiloop.topo.errors import OutputError, explain

__all__ = ["OutputError", "Outputs", "check_target", "check_directory", "figure_formats",
           "quiet_warnings", "JSON_SETTINGS", "dumps_json", "emit"]

#: matplotlib's warnings that say nothing the user can act on
_BENIGN = ("Glyph", "missing from font", "tight_layout", "Tight layout", "constrained_layout")


#: the JSON of every command, one setting: UTF-8 kept, one-space indent, NaN refused (the
#: results write null for it)
JSON_SETTINGS = {"indent": 1, "ensure_ascii": False, "allow_nan": False}


def dumps_json(doc) -> str:
    """A command's JSON document as text (:data:`JSON_SETTINGS`)."""
    return json.dumps(doc, **JSON_SETTINGS)


def emit(result, as_json: bool, text: str | None = None) -> None:
    """Print a result the one way every command does: its ``as_dict()`` as JSON, or its
    ``to_text()`` (``text`` when the command prints it with options)."""
    print(dumps_json(result.as_dict()) if as_json else (result.to_text() if text is None else text))


def _err(what: str, path, expected: str, got: str, hint: str | None = None) -> OutputError:
    return OutputError(explain(f"{what} '{path}'", expected=expected, got=got, hint=hint))


def figure_formats() -> tuple[str, ...]:
    """The file suffixes matplotlib can write (``png``, ``svg``, ``pdf`` …), sorted."""
    from matplotlib.backend_bases import FigureCanvasBase

    return tuple(sorted(FigureCanvasBase.get_supported_filetypes()))


def _kind(path: Path) -> str:
    """``missing``, ``dangling``, ``regular``, ``directory``, ``fifo``, ``chardev`` or ``other``."""
    try:
        st = os.stat(path)            # follows symbolic links
    except FileNotFoundError:
        return "dangling" if os.path.lexists(path) else "missing"
    except NotADirectoryError:
        return "missing"
    if stat.S_ISREG(st.st_mode):
        return "regular"
    if stat.S_ISDIR(st.st_mode):
        return "directory"
    if stat.S_ISFIFO(st.st_mode):
        return "fifo"
    if stat.S_ISCHR(st.st_mode):
        return "chardev"
    return "other"


def _check_parent(p: Path, parent: Path, what: str) -> Path:
    """The directory that will hold ``p`` must exist and be writable."""
    if not parent.is_dir():
        raise _err(what, p, "a name in an existing directory", f"a missing directory '{parent}'",
                   "create the directory first")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise _err(what, p, "a writable directory", f"permission denied on '{parent}'")
    return p


#: a regular file with none of these permission bits is read-only: never replaced (root
#: passes ``os.access``, and the atomic rename would replace it silently)
_WRITE_BITS = stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH


def check_target(path, what: str = "output", formats=None, pending=()) -> Path:
    """Validate a file target before any work; returns it as a :class:`~pathlib.Path`.

    Parameters
    ----------
    path : str or path-like
        The file to write.
    what : str
        The option that named it (``--plot``), for the message.
    formats : iterable of str, optional
        Accepted suffixes without the dot (lower case); a name without a suffix is
        accepted when ``""`` is among them.
    pending : iterable of Path
        Directories this run will create (their files are accepted).

    Raises
    ------
    OutputError
        Empty name, unknown suffix, a directory, a block device or socket, a missing
        parent directory, or no write permission.
    """
    if path is None or str(path).strip() == "":
        raise OutputError(explain(what, expected="a file name", got="an empty name"))
    p = Path(path)
    if formats is not None:
        fmts = tuple(formats)
        suffix = p.suffix.lower().lstrip(".")
        if suffix not in fmts:
            shown = ", ".join("." + f for f in fmts if f)
            raise _err(what, p, f"one of the suffixes {shown}",
                       f"'{p.suffix}'" if p.suffix else "no suffix")
    kind = _kind(p)
    if kind == "directory":
        raise _err(what, p, "a file", "a directory", "name a file inside it")
    if kind == "other":
        raise _err(what, p, "a regular file, a FIFO or a character device",
                   "a block device or a socket", "multiloop never writes over those")
    if kind == "regular" and not (os.access(p, os.W_OK) and os.stat(p).st_mode & _WRITE_BITS):
        raise _err(what, p, "a writable file", f"a read-only file ({stat.filemode(os.stat(p).st_mode)}: "
                   "permission denied)", "multiloop never replaces a read-only file, even as root: make it "
                   "writable (chmod u+w) or name another file")
    if kind in ("regular", "fifo", "chardev"):
        return p
    real = Path(os.path.realpath(p))
    parent = real.parent
    if any(parent == Path(os.path.realpath(d)) for d in pending):
        return p
    return _check_parent(p, parent, what)


def check_directory(path, what: str = "output directory") -> Path:
    """Validate a directory target: an existing directory, or a new one whose parent exists."""
    if path is None or str(path).strip() == "":
        raise OutputError(explain(what, expected="a directory name", got="an empty name"))
    p = Path(path)
    kind = _kind(p)
    if kind == "directory":
        if not os.access(p, os.W_OK | os.X_OK):
            raise _err(what, p, "a writable directory", "permission denied")
        return p
    if kind != "missing":
        raise _err(what, p, "a directory", "an existing file" if kind == "regular" else f"a {kind}")
    return _check_parent(p, Path(os.path.realpath(p)).parent, what)


@contextlib.contextmanager
def quiet_warnings(command: str = "multiloop"):
    """Collect warnings raised inside; report each distinct one as one line on stderr.

    matplotlib's benign layout and missing-glyph warnings are dropped.
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        yield
    seen = set()
    for w in caught:
        msg = " ".join(str(w.message).split())
        if any(b in msg for b in _BENIGN) or msg in seen:
            continue
        seen.add(msg)
        print(f"{command}: warning: {msg}", file=sys.stderr)


class _Terminated(BaseException):
    pass


@contextlib.contextmanager
def _sigterm_as_exception():
    """Turn SIGTERM into an exception while temporary files exist (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        raise _Terminated()
    old = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    except _Terminated:
        raise SystemExit(128 + signal.SIGTERM) from None
    finally:
        signal.signal(signal.SIGTERM, old)


def _write_in_place(path: Path, data: bytes, kind: str, what: str) -> None:
    flags = os.O_WRONLY | (os.O_NONBLOCK if kind == "fifo" else 0)
    try:
        fd = os.open(path, flags)
    except OSError as exc:
        if exc.errno == errno.ENXIO:
            raise _err(what, path, "a FIFO with a reader", "no reader") from None
        raise _err(what, path, "a writable target", exc.strerror or str(exc)) from None
    try:
        if kind == "fifo":
            os.set_blocking(fd, True)
        view = memoryview(data)
        while view:
            n = os.write(fd, view)
            view = view[n:]
    except OSError as exc:
        raise _err(what, path, "a target that accepts the bytes", exc.strerror or str(exc)) from None
    finally:
        os.close(fd)


class Outputs:
    """The files of one run, held in memory until :meth:`commit` writes them all.

    Parameters
    ----------
    command : str
        The command's name for messages (``multiloop solve``).
    """

    def __init__(self, command: str = "multiloop") -> None:
        self.command = command
        self._files: list[tuple[Path, bytes, str]] = []
        self._dirs: list[tuple[Path, str]] = []

    # -------------------------------------------------------------- collecting
    def directory(self, path, what: str = "output directory") -> Path:
        """Register a directory target (created at commit when missing); returns it."""
        p = check_directory(path, what)
        self._dirs.append((p, what))
        return p

    def target(self, path, what: str = "output", formats=None) -> Path:
        """Validate a file target now (before the work); returns it."""
        return check_target(path, what, formats, pending=[d for d, _ in self._dirs])

    def figure_target(self, path, what: str = "--plot") -> Path | None:
        """Validate a figure target now, in a format matplotlib writes (no suffix: PNG);
        None when ``path`` is None (no figure asked for)."""
        return None if path is None else self.target(path, what, formats=("",) + figure_formats())

    def add(self, path, data, what: str = "output") -> Path:
        """Stage ``data`` (bytes, or text written as UTF-8) for ``path``."""
        p = self.target(path, what)
        if isinstance(data, str):
            data = data.encode("utf-8")
        self._files.append((p, bytes(data), what))
        return p

    def add_files(self, directory, files, what: str = "output") -> None:
        """Stage every ``name: data`` of ``files`` as ``directory/name``."""
        for name, data in files.items():
            self.add(Path(directory) / name, data, what)

    def add_figure(self, path, fig, what: str = "--plot", close: bool = True, **savefig) -> Path:
        """Render a matplotlib figure in memory in the format of ``path``'s suffix and stage it.

        No suffix means PNG.  Raises :class:`OutputError` for a format matplotlib
        cannot write.
        """
        p = self.target(path, what, formats=("",) + figure_formats())
        fmt = p.suffix.lower().lstrip(".") or "png"
        from multiloop.kin.figures.style import no_mathtext

        no_mathtext(fig)
        buf = io.BytesIO()
        try:
            with quiet_warnings(self.command):
                fig.savefig(buf, format=fmt, **savefig)
        finally:
            if close:
                import matplotlib.pyplot as plt

                plt.close(fig)
        self._files.append((p, buf.getvalue(), what))
        return p

    def add_rendered(self, path, render, what: str = "output", suffix: str | None = None) -> Path:
        """Stage the file that ``render(tmp_path)`` writes into a private temporary directory.

        For writers that need a file name (matplotlib's animation writers).
        """
        p = self.target(path, what)
        with tempfile.TemporaryDirectory(prefix="multiloop-") as d:
            tmp = Path(d) / ("out" + (suffix if suffix is not None else p.suffix))
            with quiet_warnings(self.command):
                render(tmp)
            self._files.append((p, tmp.read_bytes(), what))
        return p

    def discard(self) -> None:
        """Forget everything staged (nothing was written)."""
        self._files.clear()
        self._dirs.clear()

    def __enter__(self) -> "Outputs":
        return self

    def __exit__(self, *exc) -> None:
        self.discard()

    # -------------------------------------------------------------- writing
    def commit(self) -> list[Path]:
        """Write every staged file (all or nothing); returns the paths as given.

        Raises
        ------
        OutputError
            A target became unusable or refused the bytes; nothing was replaced and no
            temporary file or created directory remains.
        """
        made: list[Path] = []
        staged: list[tuple[Path, str]] = []
        done = False
        try:
            with _sigterm_as_exception():
                self._commit(made, staged)
            done = True
        except OSError as exc:
            raise OutputError(f"cannot write the outputs: {exc.strerror or exc}"
                              + (f" ('{exc.filename}')" if exc.filename else "")) from None
        finally:
            for _, tmp in staged:
                with contextlib.suppress(OSError):
                    os.unlink(tmp)
            if not done:
                for d in reversed(made):
                    with contextlib.suppress(OSError):
                        d.rmdir()
        paths = [p for p, _, _ in self._files]
        self.discard()
        return paths

    def _commit(self, made: list, staged: list) -> None:
        for d, what in self._dirs:
            check_directory(d, what)
            if not d.is_dir():
                d.mkdir()
                made.append(d)
        in_place = []
        for p, data, what in self._files:
            check_target(p, what)
            kind = _kind(p)
            if kind in ("fifo", "chardev"):
                in_place.append((p, data, kind, what))
                continue
            real = Path(os.path.realpath(p))
            fd, tmp = tempfile.mkstemp(dir=real.parent, prefix=f".{real.name}.", suffix=".tmp")
            staged.append((real, tmp))
            with os.fdopen(fd, "wb") as f:
                f.write(data)
            if kind == "regular":
                mode = stat.S_IMODE(os.stat(real).st_mode)
            else:
                umask = os.umask(0)
                os.umask(umask)
                mode = 0o666 & ~umask
            os.chmod(tmp, mode)
        for p, data, kind, what in in_place:
            _write_in_place(p, data, kind, what)
        while staged:
            real, tmp = staged[0]
            os.replace(tmp, real)
            staged.pop(0)
