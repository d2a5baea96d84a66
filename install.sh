#!/usr/bin/env bash
# Install multiloop and everything its tests use.  pip alone gives every feature:
# nauty's geng/genbg come from the passagemath-nauty wheel and pynauty from a prebuilt
# wheel (no C compiler on Linux x86_64, Python 3.11); extras: [test] the suite, [dask]
# Dask clusters for `atlas --scheduler`, [curves] usearch's HNSW index of the coupler curves, [notebook] the notebook widgets and the
# executed example notebook, [web] Bokeh for `multiloop serve`,
# [browser-test] Playwright (it drives Debian's chromium; its own browser download is
# not used), [bench] the libraries the benchmarks compare against.
# System packages are installed with apt-get when it is available and we are root:
# Debian's nauty (a fallback for the wheel's generators) and headless Chromium (the
# HTML-atlas and `multiloop serve` browser tests).  Set MULTILOOP_NO_APT=1 to skip them.
set -euo pipefail
cd "$(dirname "$0")"
python3 -m pip install --disable-pip-version-check -q -e ".[test,dask,notebook,web,browser-test,curves]"
# byte-compile the package now, as pip does for a regular install and not for an editable
# one: the first run of each command (and every run where PYTHONDONTWRITEBYTECODE is set)
# then reads bytecode instead of compiling its modules
python3 -m compileall -q multiloop topo kin catalogue >/dev/null
# the atlas's compiled counter: nauty's genbg (sources from the pynauty sdist on PyPI)
# built with catalogue/synthesis/c/chaincount.c into the user cache; without a C compiler
# the counts run on the Python route (the same rows, slower)
python3 -m multiloop.catalogue.synthesis.counter_build \
  || echo "install.sh: could not build the atlas counter (counts run on the Python route)" >&2
# numba's kernels compiled into their disk cache now (tens of seconds of CPU once), not
# by the first synthesis of the install nor by each test worker of a fresh checkout
python3 -m multiloop.warmup
if [ -z "${MULTILOOP_NO_APT:-}" ] && command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
  need=""
  command -v nauty-geng >/dev/null 2>&1 || command -v geng >/dev/null 2>&1 || need="$need nauty"
  command -v chromium >/dev/null 2>&1 || need="$need chromium"
  if [ -n "$need" ]; then
    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $need >/dev/null) \
      || echo "install.sh: could not install$need (the tests that need them will be skipped)" >&2
  fi
fi
echo "multiloop installed: $(command -v multiloop)"
