"""A pip-only install does everything: a fresh venv, ``pip install .``, no nauty on PATH.

The venv has no system site packages; the PyPI distribution ``catalogue`` (a dependency
of spaCy) is installed beside multiloop and both must import.  The atlas then finds
nauty's generators in the ``passagemath-nauty`` wheel and ``multiloop atlas --links 8
--dof 1`` gives the 60 chains of Pozhbelko & Kuts (2020) for n = 8, F = 1.

The dependencies' wheels are kept in a wheelhouse (``~/.cache/multiloop-wheelhouse``, or
``$MULTILOOP_WHEELHOUSE``) filled once with ``pip wheel`` from the package index; later
runs install offline from it (``pip install --no-index --find-links``).  The project
itself is always built from a copy of its tracked sources.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import tempfile
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# Measured on the shared 2-core machine: about 8.5 min wall (53 s of CPU) with the
# wheelhouse warm, most of it unpacking and byte-compiling numpy/scipy/matplotlib/
# passagemath.  So it runs in CI (CI=true) and on request, not in every local run.
pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(not (os.environ.get("CI") or os.environ.get("MULTILOOP_INSTALL_TEST")),
                                 reason="fresh-venv install takes minutes: set MULTILOOP_INSTALL_TEST=1 "
                                        "(always run in CI)")]


def _source_copy(dest: Path) -> Path:
    """The tracked files of the repository (so the build never writes into the tree)."""
    files = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True)
    names = [n for n in files.stdout.decode().split("\0") if n]
    for n in names:
        src = ROOT / n
        if src.is_file():
            (dest / n).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / n)
    return dest


def _run(cmd, **kw) -> subprocess.CompletedProcess:
    return subprocess.run(cmd, capture_output=True, text=True, timeout=900, **kw)


@pytest.fixture(scope="module")
def fresh_venv():
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("needs the git checkout to copy the sources")
    # a private folder: pytest's shared basetemp may be pruned by other pytest runs
    base = Path(tempfile.mkdtemp(prefix="multiloop-install-"))
    try:
        yield _install(base)
    finally:
        shutil.rmtree(base, ignore_errors=True)


def _install(base: Path) -> Path:
    src = _source_copy(base / "src")
    env_dir = base / "venv"
    venv.EnvBuilder(with_pip=True, system_site_packages=False).create(env_dir)
    py = env_dir / "bin" / "python"
    wheels = Path(os.environ.get("MULTILOOP_WHEELHOUSE",
                                 Path.home() / ".cache" / "multiloop-wheelhouse"))
    wheels.mkdir(parents=True, exist_ok=True)
    pip = [str(py), "-m", "pip", "--disable-pip-version-check", "-q"]
    # offline from the wheelhouse when it holds everything, else fill it from the index
    r = _run(pip + ["install", "--no-index", "--find-links", str(wheels), str(src), "catalogue"])
    if r.returncode != 0:
        d = _run(pip + ["wheel", "-w", str(wheels), str(src), "catalogue", "setuptools>=64", "wheel"])
        if d.returncode != 0:
            if "Could not find a version" in d.stderr or "Network is unreachable" in d.stderr:
                pytest.skip(f"package index unreachable: {d.stderr[-300:]}")
            pytest.fail(f"pip wheel failed:\n{d.stderr[-3000:]}")
        for w in wheels.glob("multiloop-*.whl"):
            w.unlink()  # the project itself is always built from the sources
        r = _run(pip + ["install", "--no-index", "--find-links", str(wheels), str(src), "catalogue"])
    if r.returncode != 0:
        pytest.fail(f"pip install failed:\n{r.stdout[-2000:]}\n{r.stderr[-3000:]}")
    return env_dir


def _clean_env(env_dir: Path) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "MULTILOOP_NAUTY_BIN")}
    env["PATH"] = str(env_dir / "bin")  # no /usr/bin: no system nauty
    return env


def test_pip_only_install_imports_beside_spacys_catalogue(fresh_venv):
    env = _clean_env(fresh_venv)
    code = ("import catalogue, multiloop, multiloop.catalogue as mc;"
            "assert hasattr(catalogue, 'create'), catalogue.__file__;"
            "from multiloop.catalogue import nauty_tools as t;"
            "print(t.tool('geng'))")
    r = _run([str(fresh_venv / "bin" / "python"), "-c", code], env=env, cwd=fresh_venv)
    assert r.returncode == 0, r.stderr
    assert "sage_wheels" in r.stdout, f"geng not taken from the wheel: {r.stdout}"


def test_pip_only_atlas_gives_60_chains_for_8_links(fresh_venv, tmp_path):
    env = _clean_env(fresh_venv)
    r = _run([str(fresh_venv / "bin" / "multiloop"), "atlas", "--links", "8", "--dof", "1",
              "--db", str(tmp_path / "a.sqlite"), "--json", "--no-progress"], env=env, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["count"] == 60  # Pozhbelko & Kuts (2020): 60 chains, n = 8, F = 1


def test_scheduler_without_dask_names_the_extra(fresh_venv, tmp_path):
    env = _clean_env(fresh_venv)
    r = _run([str(fresh_venv / "bin" / "multiloop"), "atlas", "--links", "6", "--dof", "1",
              "--db", str(tmp_path / "d.sqlite"), "--scheduler", "tcp://127.0.0.1:1"], env=env, cwd=tmp_path)
    assert r.returncode == 2, r.stderr
    assert "multiloop[dask]" in r.stderr and "Traceback" not in r.stderr
    assert not (tmp_path / "d.sqlite").exists()
