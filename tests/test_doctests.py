"""Every docstring example of the installed ``multiloop`` package runs as a test.

The modules are imported by their installed names (``multiloop.topo.model``, …), not by
file path, so a doctest sees exactly the objects a user imports.
"""
from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

import multiloop


def _module_names() -> list[str]:
    names = ["multiloop"]
    for info in pkgutil.walk_packages(multiloop.__path__, "multiloop."):
        names.append(info.name)
    # sub-packages mapped from other folders (multiloop.topo -> topo/, …)
    for sub in ("topo", "kin", "catalogue"):
        pkg = importlib.import_module(f"multiloop.{sub}")
        names.append(pkg.__name__)
        names += [i.name for i in pkgutil.walk_packages(pkg.__path__, pkg.__name__ + ".")]
    return sorted(set(names) - {"multiloop.__main__"})  # __main__ runs the CLI on import


@pytest.mark.parametrize("name", _module_names())
def test_doctests(name: str) -> None:
    module = importlib.import_module(name)
    finder = doctest.DocTestFinder(exclude_empty=True)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    for test in finder.find(module, name):
        runner.run(test)
    failed, attempted = runner.summarize(verbose=False)
    assert failed == 0, f"{failed} of {attempted} doctest examples failed in {name}"
