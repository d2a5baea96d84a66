"""`multiloop bench`: listing, unknown names, and the summary of goal lines."""
from __future__ import annotations

from multiloop.cli import main


def test_list_and_unknown_name(capsys):
    assert main(["bench", "--list"]) == 0
    names = capsys.readouterr().out.split()
    assert {"analyse", "atlas", "solve", "forces"} <= set(names)
    assert main(["bench", "no_such_bench"]) == 2


def test_goal_lines_are_collected(tmp_path, monkeypatch, capsys):
    from multiloop.commands import bench

    (tmp_path / "bench_demo.py").write_text(
        "import sys\nprint('timing 1 s')\nprint('goal demo: 0.9x (goal <= 1.0x) -> met', sys.argv[1:])\n")
    monkeypatch.setattr(bench, "BENCH_DIR", tmp_path)
    assert main(["bench", "demo"]) == 0
    out = capsys.readouterr().out
    summary = out.split("=== goals")[1]
    assert "[demo] goal demo: 0.9x (goal <= 1.0x) -> met []" in summary
    assert "timing 1 s" not in summary


def test_goal_table_rows(monkeypatch):
    import importlib.util
    import sys
    from multiloop.commands import bench

    spec = importlib.util.spec_from_file_location("goals", bench.BENCH_DIR / "goals.py")
    goals = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, "goals", goals)          # dataclasses look their module up
    spec.loader.exec_module(goals)
    rows = goals.table([goals.Goal("fast", "s", 1.0, lambda: 0.5, 24), goals.Goal("slow", "s", 1.0, lambda: 2.0)])
    assert rows[0] == "goal fast: 0.5 s (goal <= 1 s) -> MET [issue 24]"
    assert rows[1] == "goal slow: 2 s (goal <= 1 s) -> NOT MET"
    assert rows[2].startswith("(load average")
    assert "goals" in bench.GOAL_SCRIPTS and {g.issue for g in goals.GOALS} >= {24}
