#!/usr/bin/env bash
# Install multiloop and everything its tests use, on a fresh Debian/Ubuntu machine or
# any machine with Python >= 3.10 and a C compiler (pynauty builds nauty from source).
# Optional system packages (headless Chromium for the HTML-atlas browser test) are
# installed with apt-get when it is available and we are root; set MULTILOOP_NO_APT=1
# to skip them (the browser test is then skipped with a reason).
set -euo pipefail
cd "$(dirname "$0")"
python3 -m pip install --disable-pip-version-check -q -e ".[test]"
if [ -z "${MULTILOOP_NO_APT:-}" ] && command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
  if ! command -v chromium >/dev/null 2>&1; then
    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null) \
      || echo "install.sh: chromium not installed (the browser test will be skipped)" >&2
  fi
fi
echo "multiloop installed: $(command -v multiloop)"
