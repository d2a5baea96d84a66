"""The façade ``import multiloop as ml`` and the one input resolver of every command."""
from __future__ import annotations

import doctest
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import multiloop as ml
from multiloop.cli import main
from multiloop.inputs import load_mechanism, resolve
from multiloop.topo.errors import InputError

ROOT = Path(__file__).resolve().parents[1]


def test_api_page_examples_run():
    res = doctest.testfile(str(ROOT / "docs" / "api.md"), module_relative=False,
                           optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert res.attempted >= 15 and res.failed == 0


def test_import_is_lazy_and_fast():
    code = "import sys, multiloop; print(sorted(m for m in sys.modules if m.startswith('multiloop')))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "['multiloop']"
    assert "scipy" not in subprocess.run([sys.executable, "-c", "import sys, multiloop; print(list(sys.modules))"],
                                         capture_output=True, text=True, check=True).stdout


def test_names_files_and_mechanisms_are_the_same_input(tmp_path):
    by_name = ml.load("four_bar")
    by_path = ml.load(resolve("four_bar"))
    assert by_name == by_path
    assert ml.analyse("four_bar").as_dict() == ml.analyse(by_name).as_dict()
    s1 = ml.solve("four_bar", np.radians([10.0, 20.0]))
    s2 = ml.solve(by_name, np.radians([10.0, 20.0]))
    np.testing.assert_array_equal(s1.positions, s2.positions)


def test_unknown_name_lists_the_catalogue():
    with pytest.raises(InputError, match="four_bar"):
        load_mechanism("no_such_mechanism")


@pytest.mark.parametrize("command", ["analyse", "decompose", "solve", "check"])
def test_every_command_accepts_a_catalogue_name(command, capsys):
    assert main([command, "four_bar", "--json"]) == 0
    json.loads(capsys.readouterr().out)


@pytest.mark.parametrize("command", ["analyse", "decompose", "solve"])
def test_unknown_name_exits_2(command, capsys):
    assert main([command, "no_such_mechanism"]) == 2
    assert "catalogue names" in capsys.readouterr().err
