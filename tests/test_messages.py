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


def test_library_messages_name_parameters_and_the_command_line_names_flags(capsys):
    """A library error names the parameter (``steps``, ``'start'``); the command line puts
    the option's flag in its place, in one function (``multiloop.cli.flagged``).  The
    library's messages name no flag but in a recipe that names its command."""
    import ast
    import pathlib
    import re

    from multiloop.catalogue.named import load_named
    from multiloop.kin.sweep import cycle_inputs, input_range
    from multiloop.topo.errors import ParameterError
    m = load_named("four_bar")
    with pytest.raises(ParameterError, match=r"^start/stop: expected both or neither") as e:
        input_range(m, 4, start=1.0)
    assert e.value.parameters == ("start", "stop")
    with pytest.raises(ParameterError, match=r"^at: expected 1 value"):
        cycle_inputs(m, at="1,2")
    code, err = _run(capsys, "solve", "four_bar", "--from", "1")
    assert code == 2 and "error: --from/--to: expected both or neither" in err
    code, err = _run(capsys, "forces", "four_bar", "--at", "1,2")
    assert code == 2 and "error: --at: expected 1 value" in err
    code, err = _run(capsys, "atlas", "--table", "--db", "none.sqlite")
    assert code == 2 and "error: --table: expected --links N and --dof F, got no --links" in err
    flag = re.compile(r"(?<![\w-])--[a-z]")
    root = pathlib.Path(__file__).resolve().parents[1]
    named = []
    for pkg in ("topo", "kin", "catalogue"):
        for p in sorted((root / pkg).rglob("*.py")):
            for node in ast.walk(ast.parse(p.read_text())):
                f = getattr(node, "func", None)
                name = getattr(f, "id", None) or getattr(f, "attr", "")
                if isinstance(node, ast.Call) and (name == "explain" or name.endswith("Error")):
                    texts = [c.value for c in ast.walk(node) if isinstance(c, ast.Constant) and isinstance(c.value, str)]
                    if any(flag.search(t) and "multiloop atlas" not in t for t in texts):
                        named.append(f"{p.relative_to(root)}:{node.lineno}")
    assert named == []
