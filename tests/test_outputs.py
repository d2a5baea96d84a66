"""The safe output writer (multiloop.outputs) and its use by every command.

One regression test per rule: symlinks written through, FIFOs and devices never
replaced, a directory target refused, a missing parent refused in every command,
unknown/empty figure names refused, a failing run writes nothing, and no temporary
file survives.
"""
from __future__ import annotations

import os
import stat
import threading
from pathlib import Path

import pytest

from multiloop.cli import main
from multiloop.outputs import OutputError, Outputs, check_target

ROOT = Path(__file__).resolve().parents[1]
FOUR_BAR = str(ROOT / "catalogue" / "mechanisms" / "four_bar.toml")
LOADED = str(ROOT / "catalogue" / "mechanisms" / "crank_slider_loaded.toml")
PNG = b"\x89PNG\r\n\x1a\n"


def _solve(*extra) -> int:
    return main(["solve", FOUR_BAR, "--steps", "6", *map(str, extra)])


def _leftovers(d: Path) -> list[str]:
    return sorted(p.name for p in d.iterdir() if p.name.endswith(".tmp") or p.name.startswith("tmp"))


# ------------------------------------------------------------------ the writer itself
def test_commit_writes_nothing_before(tmp_path):
    out = Outputs("t")
    out.add(tmp_path / "a.txt", "x")
    out.add(tmp_path / "b.bin", b"\x00\x01")
    assert list(tmp_path.iterdir()) == []
    assert [p.name for p in out.commit()] == ["a.txt", "b.bin"]
    assert (tmp_path / "b.bin").read_bytes() == b"\x00\x01"


def test_existing_file_keeps_its_mode(tmp_path):
    p = tmp_path / "a.txt"
    p.write_text("old")
    p.chmod(0o640)
    out = Outputs("t")
    out.add(p, "new")
    out.commit()
    assert p.read_text() == "new"
    assert stat.S_IMODE(p.stat().st_mode) == 0o640


def test_new_directory_created_and_removed_on_failure(tmp_path):
    fifo = tmp_path / "f"
    os.mkfifo(fifo)
    out = Outputs("t")
    d = out.directory(tmp_path / "new")
    out.add(d / "a.txt", "x")
    out.add(fifo, "y")                      # no reader: the commit fails
    with pytest.raises(OutputError, match="no reader"):
        out.commit()
    assert not (tmp_path / "new").exists()
    assert stat.S_ISFIFO(fifo.lstat().st_mode)
    assert _leftovers(tmp_path) == []


@pytest.mark.parametrize("bad, match", [("", "empty name"), ("   ", "empty name")])
def test_empty_names(bad, match):
    with pytest.raises(OutputError, match=match):
        check_target(bad, "--plot")


def test_directory_where_a_directory_is_expected_must_not_be_a_file(tmp_path):
    f = tmp_path / "file"
    f.write_text("x")
    with pytest.raises(OutputError, match="an existing file"):
        Outputs("t").directory(f, "--plot")


# ------------------------------------------------------------------ the commands
def test_symlink_is_written_through(tmp_path):
    target = tmp_path / "real.png"
    target.write_bytes(b"old")
    link = tmp_path / "link.png"
    link.symlink_to(target)
    assert _solve("--plot", link) == 0
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert target.read_bytes().startswith(PNG)
    assert _leftovers(tmp_path) == []


def test_dangling_symlink_gets_its_target(tmp_path):
    link = tmp_path / "link.png"
    link.symlink_to(tmp_path / "made.png")
    assert _solve("--plot", link) == 0
    assert link.is_symlink()
    assert (tmp_path / "made.png").read_bytes().startswith(PNG)


def test_fifo_without_reader_is_refused_and_kept(tmp_path, capsys):
    fifo = tmp_path / "out.png"
    os.mkfifo(fifo)
    assert _solve("--plot", fifo) == 2
    assert "no reader" in capsys.readouterr().err
    assert stat.S_ISFIFO(fifo.lstat().st_mode)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.png"]   # no analogues either


def test_fifo_with_reader_is_written_in_place(tmp_path):
    fifo = tmp_path / "anim.gif"
    os.mkfifo(fifo)
    got = []
    reader = threading.Thread(target=lambda: got.append(open(fifo, "rb").read()))
    reader.start()
    try:
        assert _solve("--animate", fifo) == 0
    finally:
        if reader.is_alive():           # unblock the reader if the command never opened the FIFO
            with open(fifo, "wb"):
                pass
        reader.join(10)
    assert got and got[0].startswith(b"GIF8")
    assert stat.S_ISFIFO(fifo.lstat().st_mode)


def _full_device(tmp_path) -> Path:
    """A character device like /dev/full (made with mknod as root), else skip."""
    if os.geteuid() != 0:
        pytest.skip("making a device node needs root")
    dev = tmp_path / "full"
    try:
        os.mknod(dev, 0o666 | stat.S_IFCHR, os.makedev(1, 7))
        with open(dev, "wb") as f:
            f.write(b"x")
    except PermissionError:
        pytest.skip("mknod not permitted here")
    except OSError:
        pass                            # ENOSPC: it is /dev/full
    return dev


def test_full_device_is_refused_and_kept(tmp_path, capsys):
    dev = _full_device(tmp_path)
    assert _solve("--plot", dev) == 2
    assert "No space" in capsys.readouterr().err
    assert stat.S_ISCHR(dev.lstat().st_mode)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["full"]


def test_char_device_null_written_in_place(tmp_path):
    if not os.path.exists("/dev/null"):
        pytest.skip("no /dev/null")
    assert _solve("--plot", "/dev/null") == 0
    assert stat.S_ISCHR(os.lstat("/dev/null").st_mode)


def test_directory_target_is_exit_2_without_leftovers(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "somedir.png").mkdir()
    assert _solve("--plot", "somedir.png") == 2
    assert "a directory" in capsys.readouterr().err
    assert _leftovers(tmp_path) == [] and sorted(os.listdir(tmp_path)) == ["somedir.png"]


@pytest.mark.parametrize("argv", [
    ["solve", FOUR_BAR, "--steps", "4", "--plot", "{d}/nope/x.png"],
    ["solve", FOUR_BAR, "--steps", "4", "--animate", "{d}/nope/x.gif"],
    ["forces", LOADED, "--steps", "4", "--plot", "{d}/nope/x.png"],
    ["engine", "single_cylinder", "--steps", "16", "--no-check", "--plot", "{d}/nope/deeper"],
    ["platform", "doronin_platform", "--plot", "{d}/nope/x.png"],
    ["atlas", "--links", "4", "--dof", "1", "--db", "{d}/a.sqlite", "--no-progress", "--html", "{d}/nope/g"],
    ["atlas", "--links", "4", "--dof", "1", "--db", "{d}/a.sqlite", "--no-progress", "--charts", "{d}/nope/c"],
])
def test_missing_parent_is_exit_2_in_every_command(tmp_path, capsys, argv):
    argv = [a.replace("{d}", str(tmp_path)) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "missing directory" in err and "Traceback" not in err
    assert not (tmp_path / "nope").exists()


@pytest.mark.parametrize("argv, match", [
    (["solve", FOUR_BAR, "--plot", "{d}/x.xyz"], "suffixes"),
    (["solve", FOUR_BAR, "--plot", ""], "empty name"),
    (["solve", FOUR_BAR, "--animate", "{d}/x.png"], ".gif"),
    (["forces", LOADED, "--plot", "{d}/x.nope"], "suffixes"),
    (["forces", LOADED, "--plot", ""], "empty name"),
    (["platform", "doronin_platform", "--plot", ""], "empty name"),
    (["engine", "single_cylinder", "--plot", ""], "empty name"),
])
def test_unknown_format_or_empty_name_is_exit_2(tmp_path, capsys, argv, match):
    argv = [a.replace("{d}", str(tmp_path)) for a in argv]
    assert main(argv) == 2
    assert match in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_failing_run_writes_none(tmp_path, monkeypatch):
    import multiloop.kin.figures.mechanism as fm

    def boom(state):
        raise RuntimeError("analogues failed")
    monkeypatch.setattr(fm, "plot_analogues", boom)
    assert _solve("--plot", tmp_path / "a.png", "--animate", tmp_path / "a.gif") == 1
    assert list(tmp_path.iterdir()) == []


def test_failing_commit_writes_none(tmp_path):
    """The plot is fine but the animation target refuses: neither file appears."""
    fifo = tmp_path / "a.gif"
    os.mkfifo(fifo)
    assert _solve("--plot", tmp_path / "a.png", "--animate", fifo) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.gif"]


def test_dollar_names_plot(tmp_path):
    text = Path(FOUR_BAR).read_text().replace('name = "four_bar"', 'name = "cost $5 or $x_{1"', 1)
    src = tmp_path / "m.toml"
    src.write_text(text)
    assert main(["solve", str(src), "--steps", "6", "--plot", str(tmp_path / "d.png"),
                 "--animate", str(tmp_path / "d.gif")]) == 0
    assert (tmp_path / "d.png").read_bytes().startswith(PNG)


def test_engine_and_atlas_write_directories(tmp_path, capsys):
    assert main(["engine", "single_cylinder", "--steps", "16", "--no-check",
                 "--plot", str(tmp_path / "eng")]) == 0
    assert len(list((tmp_path / "eng").glob("*.png"))) == 6
    assert main(["atlas", "--links", "6", "--dof", "1", "--db", str(tmp_path / "a.sqlite"),
                 "--no-progress", "--html", str(tmp_path / "g"), "--charts", str(tmp_path / "c")]) == 0
    assert sorted(p.name for p in (tmp_path / "g").iterdir()) == ["atlas_n6_F1.html", "index.html"]
    assert len(list((tmp_path / "c").glob("*.png"))) == 2
    assert _leftovers(tmp_path) == []
    assert "Warning" not in capsys.readouterr().err


def test_warnings_become_one_line_each(capsys):
    import warnings

    from multiloop.outputs import quiet_warnings
    with quiet_warnings("multiloop t"):
        warnings.warn("Glyph 128512 (\\N{GRINNING FACE}) missing from font(s) DejaVu Sans.")
        warnings.warn("something\n  worth   saying")
        warnings.warn("something worth saying")
    assert capsys.readouterr().err == "multiloop t: warning: something worth saying\n"


def test_no_raw_library_warning_on_stderr(tmp_path, capsys):
    """A name the font cannot draw makes matplotlib warn; nothing raw reaches stderr."""
    text = Path(FOUR_BAR).read_text().replace('name = "four_bar"', 'name = "bar \\u4e2d\\uac00"', 1)
    src = tmp_path / "m.toml"
    src.write_text(text, encoding="utf-8")
    assert main(["solve", str(src), "--steps", "6", "--plot", str(tmp_path / "w.png"),
                 "--animate", str(tmp_path / "w.gif")]) == 0
    err = capsys.readouterr().err
    assert "Warning" not in err and "warnings.warn" not in err
