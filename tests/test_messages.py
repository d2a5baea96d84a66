"""Error messages across commands: exit code 2, the thing at fault named, no traceback."""
from __future__ import annotations

import pytest

from multiloop.cli import main
from tests.common import BARE, PARALLELOGRAM



def _run(capsys, *argv):
    code = main(list(argv))
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return code, err


def test_parallelogram_solve_says_it_moves_and_names_the_redundant_pair(tmp_path, capsys):
    f = tmp_path / "par.toml"
    f.write_text(PARALLELOGRAM)
    code, err = _run(capsys, "solve", str(f))
    assert code == 2
    assert "F = 3(n−1) − 2p = 3·4 − 2·6 = 0" in err
    assert "does move with 1 DOF" in err and "c3" in err


@pytest.mark.parametrize("command,needle", [
    ("solve", "expected geometry"),
    ("decompose", "expected a frame link"),
    ("forces", "expected at least one driver"),
    ("engine", "expected an [engine] table"),
    ("platform", "unknown key 'joints'"),
])
def test_bare_chain_rejected_by_every_command_that_needs_more(tmp_path, capsys, command, needle):
    f = tmp_path / "chain.toml"
    f.write_text(BARE)
    code, err = _run(capsys, command, str(f))
    assert code == 2 and needle in err


def test_engine_given_a_mechanism_points_to_forces(capsys):
    code, err = _run(capsys, "engine", "catalogue/mechanisms/four_bar.toml")
    assert code == 2 and "multiloop forces" in err


def test_one_exception_tree_in_topo_errors():
    """Every public exception class of the package is defined in topo/errors.py and
    derives from LinkageError (warnings from UserWarning)."""
    import ast
    from pathlib import Path

    import multiloop.topo.errors as errors
    root = Path(__file__).resolve().parents[1]
    outside = []
    for path in [*root.glob("topo/**/*.py"), *root.glob("kin/**/*.py"),
                 *root.glob("catalogue/**/*.py"), *root.glob("multiloop/**/*.py")]:
        if path.name == "errors.py" and path.parent.name == "topo":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ClassDef) and not node.name.startswith("_") and any(
                    getattr(b, "id", getattr(b, "attr", "")).endswith(("Error", "Exception", "Warning"))
                    for b in node.bases):
                outside.append(f"{path.relative_to(root)}:{node.name}")
    assert outside == []
    for name in errors.__all__:
        obj = getattr(errors, name)
        if isinstance(obj, type):
            assert issubclass(obj, (errors.LinkageError, UserWarning)), name
