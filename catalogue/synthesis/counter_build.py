"""The compiled counter of number synthesis: nauty's ``genbg`` (McKay & Piperno 2014)
built with ``c/chaincount.c`` as its pruning and output procedures.

nauty's sources come from the ``pynauty`` source distribution on PyPI (it bundles nauty
2.8.8, Apache License 2.0); the binary is built once per machine into the user cache,
named after a digest of ``chaincount.c`` so that a changed source is built afresh.
``install.sh`` runs ``python3 -m multiloop.catalogue.synthesis.counter_build``; without
a C compiler the counts run on the Python route (the same rows, slower).
"""
from __future__ import annotations

import hashlib
import os
import platform
import shutil
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

from multiloop.topo.errors import InputError, explain

__all__ = ["SOURCE", "NAUTY_SDIST", "cache_dir", "counter_path", "find_counter", "build_counter"]

#: our pruning and tallying procedures, compiled into genbg
SOURCE = Path(__file__).with_name("c") / "chaincount.c"
#: the PyPI source distribution that carries nauty's sources
NAUTY_SDIST = "pynauty==2.8.8.1"
#: nauty's objects genbg links with, built for 64-bit set words (up to 64 vertices)
_OBJECTS = ["gtoolsL.o", "schreierL.o", "nautyL1.o", "nautilL1.o", "naugraphL1.o", "naurng.o"]
_FLAGS = ["-O3", "-march=native"]
_DEFINES = ["-DMAXN=WORDSIZE", "-DWORDSIZE=64", "-DPRUNE1=chain_prune", "-DOUTPROC=chain_out",
            "-DSUMMARY=chain_summary"]


def cache_dir() -> Path:
    """``$MULTILOOP_CACHE``, else the user cache folder of multiloop (platformdirs)."""
    env = os.environ.get("MULTILOOP_CACHE")
    if env:
        return Path(env)
    import platformdirs
    return Path(platformdirs.user_cache_dir("multiloop"))


def counter_path() -> Path:
    """Where the counter of the current ``chaincount.c``, compiler flags and processor
    lives (built or not): it is built for the processor it runs on (``-march=native``)."""
    text = SOURCE.read_bytes() + " ".join(_FLAGS).encode() + _processor().encode()
    digest = hashlib.sha256(text).hexdigest()[:12]
    return cache_dir() / "bin" / f"genbg-chaincount-{digest}"


def _processor() -> str:
    """The machine and its processor model (a binary for one need not run on another)."""
    model = ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith(("model name", "Model", "CPU part")):
                model = line
                break
    except OSError:
        pass
    return f"{platform.machine()} {model}"


def find_counter() -> Path | None:
    """The built counter (``$MULTILOOP_COUNTER`` names another one; ``none`` turns it
    off), or None."""
    env = os.environ.get("MULTILOOP_COUNTER")
    if env:
        return None if env == "none" else Path(env)
    path = counter_path()
    return path if path.is_file() and os.access(path, os.X_OK) else None


def _nauty_sources(work: Path) -> Path:
    """nauty's source folder, unpacked from the pynauty source distribution."""
    subprocess.run([sys.executable, "-m", "pip", "download", "-q", "--no-deps", "--no-binary", ":all:",
                    "-d", str(work), NAUTY_SDIST], check=True)
    archive = next(work.glob("pynauty-*.tar.gz"))
    with tarfile.open(archive) as tar:
        tar.extractall(work, filter="data")
    return next(work.glob("pynauty-*/src/nauty*"))


def build_counter(nauty_dir: Path | None = None, verbose: bool = False) -> Path:
    """Build the counter into :func:`counter_path` and return its path.

    Parameters
    ----------
    nauty_dir : Path, optional
        An unpacked nauty source folder (default: downloaded from PyPI).
    """
    cc = shutil.which(os.environ.get("CC", "cc"))
    if cc is None:
        raise InputError(explain("counter", expected="a C compiler (cc)", got="none on the PATH",
                                 hint="the atlas counts on the Python route without it"))
    out = os.dup(1) if verbose else subprocess.DEVNULL
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        src = shutil.copytree(nauty_dir, work / "nauty") if nauty_dir else _nauty_sources(work)
        quiet = {"stdout": out, "stderr": out, "check": True, "cwd": src}
        subprocess.run(["./configure", "--quiet"], **quiet)
        subprocess.run(["make", "-s", *_OBJECTS], **quiet)
        target = counter_path()
        target.parent.mkdir(parents=True, exist_ok=True)
        part = target.with_suffix(".part")
        subprocess.run([cc, *_FLAGS, "-I.", *_DEFINES, "-o", str(part), "genbg.c", str(SOURCE), *_OBJECTS],
                       **quiet)
        part.replace(target)
    return target


if __name__ == "__main__":
    nauty = Path(sys.argv[1]) if len(sys.argv) > 1 else None
    print(f"compiled counter: {build_counter(nauty)}")
