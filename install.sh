#!/usr/bin/env bash
# Install multiloop and everything its tests use, on a fresh Debian/Ubuntu machine or
# any machine with Python >= 3.10 and a C compiler (pynauty builds nauty from source).
# System packages are installed with apt-get when it is available and we are root:
# nauty (geng/genbg, the generators behind `multiloop atlas`) and headless Chromium
# (the HTML-atlas browser test).  Set MULTILOOP_NO_APT=1 to skip them: `atlas` then
# says it needs nauty (exit 2) and the tests that need them are skipped with a reason.
set -euo pipefail
cd "$(dirname "$0")"
python3 -m pip install --disable-pip-version-check -q -e ".[test]"
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
