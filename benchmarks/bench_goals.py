"""The goal table of ``benchmarks/goals.py`` (plain script).

Run:  python benchmarks/bench_goals.py
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from goals import table  # noqa: E402

if __name__ == "__main__":
    for line in table():
        print(line, flush=True)
