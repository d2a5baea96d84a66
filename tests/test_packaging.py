"""The installed layout: one ``multiloop`` namespace, every sub-package listed."""
from __future__ import annotations

import re
import sys
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
MAPPED = {"multiloop": "multiloop", "topo": "multiloop.topo", "kin": "multiloop.kin",
          "catalogue": "multiloop.catalogue"}


def test_every_package_folder_is_installed_under_multiloop():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    listed = set(config["packages"])
    found = set()
    for folder, dotted in MAPPED.items():
        for init in (ROOT / folder).rglob("__init__.py"):
            rel = init.parent.relative_to(ROOT / folder).parts
            found.add(".".join((dotted,) + rel))
    assert found == listed, f"pyproject packages differ: missing {found - listed}, extra {listed - found}"
    assert config["package-dir"] == {v: k for k, v in MAPPED.items()}


def test_no_source_imports_a_top_level_topo_kin_or_catalogue():
    bad = re.compile(r"^\s*(from|import)\s+(topo|kin|catalogue)\b", re.M)
    offenders = [str(p.relative_to(ROOT)) for folder in [*MAPPED, "tests", "benchmarks", "docs"]
                 for p in (ROOT / folder).rglob("*.py") if bad.search(p.read_text())]
    assert not offenders, f"top-level imports left in {offenders}; use multiloop.topo / .kin / .catalogue"
