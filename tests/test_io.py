"""File formats (the file format (README)) and every kind of malformed input: a message naming the
table/key at fault, exit code 2, no traceback."""
from __future__ import annotations

import json

import pytest

from multiloop.cli import main
from multiloop.topo.errors import InputError, TopologyError
from multiloop.topo.io import dumps_json, dumps_toml, load, loads, mechanism_from_dict
from tests.common import BARE

CRANK_SLIDER = '''
name = "crank-slider"
[[link]]
name = "frame"
frame = true
[[link]]
name = "crank"
[[link]]
name = "rod"
[[link]]
name = "piston"
[[joint]]
name = "O"
kind = "R"                  # R (may list 2 or more links) or P (exactly 2: guide, slider)
links = ["frame", "crank"]
at = [0.0, 0.0]             # reference position (metres)
[[joint]]
name = "A"
kind = "R"
links = ["crank", "rod"]
at = [0.05, 0.0]
[[joint]]
name = "B"
kind = "R"
links = ["rod", "piston"]
at = [0.25, 0.0]
[[joint]]
name = "S"
kind = "P"
links = ["frame", "piston"]
at = [0.25, 0.0]            # a point of the slider on the guide line
axis = [1.0, 0.0]           # guide direction
[[driver]]
joint = "O"                 # R: angle of links[1] relative to links[0]; P: slide
[[point]]
name = "G"                  # tracer point fixed on a link
link = "rod"
at = [0.1, 0.0]
'''


def test_spec_examples_accepted_exactly_as_written():
    m = loads(CRANK_SLIDER)
    assert m.frame == "frame" and m.n_links == 4 and m.joint("S").kind.value == "P"
    assert m.drivers[0].links == ("frame", "crank") and m.points[0].link == "rod"
    c = loads(BARE)
    assert c.frame is None and c.joint("J2").links == ("b", "c", "d")


def test_round_trip_toml_and_json(tmp_path):
    m = loads(CRANK_SLIDER)
    assert loads(dumps_toml(m)) == m
    assert loads(dumps_json(m), fmt="json") == m
    p = tmp_path / "m.json"
    p.write_text(dumps_json(m))
    assert load(p) == m


def test_model_is_frozen_and_hashable():
    m = loads(CRANK_SLIDER)
    with pytest.raises(Exception):
        m.name = "x"  # type: ignore[misc]
    assert hash(m) == hash(loads(CRANK_SLIDER))


BAD = [
    ("syntax", "joints = [[\"a\", \"b\"\n", "TOML syntax error"),
    ("unknown top key", BARE + "colour = 1\n", "unknown key 'colour'"),
    ("unknown joint key", CRANK_SLIDER + '[[joint]]\nname = "X"\nlinks = ["rod", "crank"]\nangle = 3\n', "unknown key 'angle'"),
    ("unknown kind", CRANK_SLIDER.replace('kind = "P"', 'kind = "Q"'), "'R' or 'P'"),
    ("one link", CRANK_SLIDER + '[[joint]]\nname = "X"\nlinks = ["rod"]\nat = [0.0, 0.0]\n', "joint 'X': expected at least 2 links"),
    ("P with 3 links", CRANK_SLIDER.replace('links = ["frame", "piston"]', 'links = ["frame", "piston", "rod"]'), "exactly 2 links for a P joint"),
    ("duplicate joint", CRANK_SLIDER.replace('name = "B"', 'name = "A"'), "joint 'A': expected a unique name"),
    ("duplicate link", CRANK_SLIDER.replace('name = "rod"\n[[link]]', 'name = "crank"\n[[link]]', 1), "link 'crank': expected a unique name"),
    ("unknown driver joint", CRANK_SLIDER.replace('joint = "O"', 'joint = "Z"'), "[[driver]] joint 'Z'"),
    ("driver link not on joint", CRANK_SLIDER.replace('joint = "O"  ', 'joint = "O"\nlinks = ["frame", "rod"]  '), "two distinct links of that joint"),
    ("non-numeric coordinate", CRANK_SLIDER.replace("at = [0.05, 0.0]", 'at = [0.05, "x"]'), "[[joint]] #2 ('A') at: expected a number"),
    ("coordinate length", CRANK_SLIDER.replace("at = [0.05, 0.0]", "at = [0.05]"), "a pair of numbers"),
    ("two frames", CRANK_SLIDER.replace('name = "crank"\n', 'name = "crank"\nframe = true\n'), "exactly one link with frame = true"),
    ("P without axis", CRANK_SLIDER.replace("axis = [1.0, 0.0]", ""), "axis: expected a guide direction"),
    ("unknown point link", CRANK_SLIDER.replace('link = "rod"', 'link = "beam"'), "[[point]] 'G' link"),
    ("partial geometry", CRANK_SLIDER.replace("at = [0.25, 0.0]            # a point", "# a point"), "'at' on every joint or on none"),
    ("bare + tables", BARE + '[[joint]]\nname = "X"\nlinks = ["a", "b"]\n', "either 'joints' (bare chain) or [[joint]] tables"),
]


@pytest.mark.parametrize("label,text,needle", BAD, ids=[b[0] for b in BAD])
def test_bad_input_named(tmp_path, capsys, label, text, needle):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(InputError) as exc:
        load(f)
    assert needle in str(exc.value)
    assert main(["analyse", str(f)]) == 2
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err


def test_disconnected_chain(tmp_path, capsys):
    f = tmp_path / "two.toml"
    f.write_text('joints = [["a", "b"], ["b", "c"], ["c", "a"], ["x", "y"], ["y", "z"], ["z", "x"]]\n')
    with pytest.raises(TopologyError, match=r"2 separate parts: \{a, b, c\} \| \{x, y, z\}"):
        load(f)
    assert main(["analyse", str(f)]) == 2


def test_wrong_suffix_and_missing_file(tmp_path, capsys):
    f = tmp_path / "m.yaml"
    f.write_text("a: 1\n")
    assert main(["analyse", str(f)]) == 2
    assert "expected a .toml or .json file" in capsys.readouterr().err
    assert main(["analyse", str(tmp_path / "none.toml")]) == 2
    assert "expected an existing file" in capsys.readouterr().err


def test_json_top_level_must_be_object(tmp_path, capsys):
    f = tmp_path / "m.json"
    f.write_text("[1, 2]")
    assert main(["analyse", str(f)]) == 2
    assert "a JSON object at top level" in capsys.readouterr().err


def test_all_problems_reported_at_once():
    with pytest.raises(InputError) as exc:
        mechanism_from_dict({"joint": [{"name": "A", "links": ["a"]}, {"name": "A", "links": ["a", "b"]}]})
    msg = str(exc.value)
    assert "2 problems" in msg and "at least 2 links" in msg and "unique name" in msg


def test_analyse_json_keys(tmp_path, capsys):
    f = tmp_path / "c.toml"
    f.write_text(BARE)
    assert main(["analyse", str(f), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    for key in ("n", "p", "LA", "MJA", "V", "K", "L", "AVC", "F", "N", "rc", "SL", "La", "L0",
                "code", "code_star", "planar", "degenerate", "fractionated", "canonical"):
        assert key in d
    assert d["LA"] == [4, 1] and d["MJA"] == [1] and d["La"] == sorted(d["La"])


# ---- the shared typed readers (used by every document parser) ---------------------
def test_typed_readers_accept_and_name_the_fault():
    from multiloop.topo.io import (read_bool, read_names, read_number, read_string, read_table,
                                   read_tables, read_vector, table_label)
    assert read_number(3, "x") == 3.0 and isinstance(read_number(3, "x"), float)
    assert read_vector([1, 2], "at") == (1.0, 2.0)
    assert read_vector([1, 2, 3], "p", 3) == (1.0, 2.0, 3.0)
    assert read_string("a", "s") == "a" and read_string("", "s", allow_empty=True) == ""
    assert read_bool(False, "f") is False
    assert read_names(["a", "b"], "links") == ("a", "b")
    assert read_tables({"link": {"name": "a"}}, "link") == [{"name": "a"}]
    assert table_label("link", 2, {"name": "crank"}) == "[[link]] #2 ('crank')"
    bad = [
        (lambda: read_number(True, "mass"), "mass: expected a number, got True"),
        (lambda: read_number(float("nan"), "mass"), "mass: expected a finite number"),
        (lambda: read_number(0, "rpm", positive=True, unit="1/min"), "rpm: expected a positive number (1/min), got 0"),
        (lambda: read_number(-1e-3, "inertia", non_negative=True), "inertia: expected a number >= 0"),
        (lambda: read_vector([1], "at"), "at: expected a pair of numbers [x, y]"),
        (lambda: read_vector([1, 2], "p", 3), "p: expected 3 numbers [x, y, z]"),
        (lambda: read_string("", "name"), "name: expected a non-empty string"),
        (lambda: read_bool(1, "frame"), "frame: expected true or false, got 1"),
        (lambda: read_table([], "[engine]"), "[engine]: expected a table"),
        (lambda: read_table({"a": 1, "zz": 2}, "[t]", {"a"}), "[t]: expected keys among a, got unknown key 'zz'"),
        (lambda: read_table({"a": 1}, "[t]", {"a", "b"}, required=("b",)), "[t]: expected key 'b', got nothing"),
        (lambda: read_tables({"link": 3}, "link"), "[[link]]: expected an array of tables"),
    ]
    for call, needle in bad:
        with pytest.raises(InputError) as exc:
            call()
        assert needle in str(exc.value)


# ---- physically meaningless or hostile input (issue 10) ---------------------------
FOUR_BAR = '''
[[link]]
name = "g"
frame = true
[[joint]]
name = "O"
links = ["g", "crank"]
at = [0, 0]
[[joint]]
name = "A"
links = ["crank", "coupler"]
at = [1, 1]
[[joint]]
name = "B"
links = ["coupler", "rocker"]
at = [3, 3]
[[joint]]
name = "C"
links = ["rocker", "g"]
at = [4, 0]
[[driver]]
joint = "O"
'''

MEANINGLESS = [
    ("zero-length link", FOUR_BAR.replace("at = [3, 3]", "at = [1, 1]"),
     "link 'coupler': expected a length > 0 between its pins, got a zero-length link: its pins 'A' and 'B' are both at (1, 1)"),
    ("coincident pins", FOUR_BAR.replace("at = [1, 1]", "at = [4, 0]"),
     "joints 'A' and 'C': expected pins at distinct points, got coincident pins, both at (4, 0)"),
    ("coincident within 1e-9 of the size", FOUR_BAR.replace("at = [3, 3]", "at = [1.000000000001, 1]"),
     "zero-length link"),
    ("negative inertia", FOUR_BAR + '[[link]]\nname = "crank"\ninertia = -0.5\n',
     "link 'crank' inertia: expected a moment of inertia >= 0"),
]


@pytest.mark.parametrize("label,text,needle", MEANINGLESS, ids=[b[0] for b in MEANINGLESS])
def test_physically_meaningless_input_is_named(tmp_path, capsys, label, text, needle):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    for command in ("analyse", "decompose", "solve", "forces"):
        assert main([command, str(f)]) == 2
        err = capsys.readouterr().err
        assert needle in err and "Traceback" not in err and "toggle" not in err


def test_a_slider_point_may_sit_on_its_pin(tmp_path):
    # the crank-slider's P joint reference point is the piston pin: not a coincidence of pins
    m = loads(CRANK_SLIDER)
    assert m.joint("B").at == m.joint("S").at


def test_duplicate_json_key_is_named(tmp_path, capsys):
    f = tmp_path / "dup.json"
    f.write_text('{"joints": [["a", "b"], ["b", "c"], ["c", "a"]], "name": "x", "name": "y"}')
    assert main(["analyse", str(f)]) == 2
    assert "expected each key once, got key 'name' twice" in capsys.readouterr().err
    with pytest.raises(InputError, match="key 'a' twice"):
        loads('{"joints": [["a", "b"], ["b", "c"], ["c", "a"]], "link": [{"name": "a", "a": 1, "a": 2}]}', "json")


@pytest.mark.parametrize("suffix,text", [
    ("json", '{"joints": ' + "[" * 100_000 + "]" * 100_000 + "}"),
    ("json", '{"joints": ' + "[" * 900 + "]" * 900 + "}"),
    ("toml", "joints = " + "[" * 100_000 + "]" * 100_000 + "\n"),
])
def test_deeply_nested_document_is_exit_2(tmp_path, capsys, suffix, text):
    f = tmp_path / f"deep.{suffix}"
    f.write_text(text)
    assert main(["analyse", str(f)]) == 2
    err = capsys.readouterr().err
    assert "nested at most 64 deep" in err and "Traceback" not in err and "internal" not in err


@pytest.mark.parametrize("suffix,text", [
    ("json", '{"joints": [["a", "b"], ["b", "c"], ["c", "a"]]}'),
    ("toml", 'joints = [["a", "b"], ["b", "c"], ["c", "a"]]\n'),
])
def test_byte_order_mark_is_accepted(tmp_path, capsys, suffix, text):
    f = tmp_path / f"bom.{suffix}"
    f.write_bytes(b"\xef\xbb\xbf" + text.encode())
    assert load(f).n_links == 3
    assert loads("\ufeff" + text, suffix).n_links == 3
    assert main(["analyse", str(f)]) == 0


def test_unreadable_input_is_exit_2_naming_the_path(tmp_path, capsys, monkeypatch):
    from pathlib import Path
    f = tmp_path / "locked.toml"
    f.write_text(BARE)

    import os
    real_open = os.open

    def denied(path, *args, **kwargs):   # the tests run as root, where chmod 000 still reads
        if Path(path) == f:
            raise PermissionError(13, "Permission denied", str(path))
        return real_open(path, *args, **kwargs)
    monkeypatch.setattr(os, "open", denied)
    for command in ("analyse", "decompose", "solve"):
        assert main([command, str(f)]) == 2
        err = capsys.readouterr().err
        assert f"file '{f}': expected a readable file, got permission denied" in err


def test_any_os_error_is_exit_2_naming_the_file(capsys, monkeypatch):
    import multiloop.commands.analyse as analyse

    def fails(args):
        raise IsADirectoryError(21, "Is a directory", "some/dir")
    monkeypatch.setattr(analyse, "run", fails)
    assert main(["analyse", "x.toml"]) == 2
    err = capsys.readouterr().err
    assert "multiloop analyse: error: 'some/dir': Is a directory" in err and "internal" not in err


def test_help_describes_the_tool(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    out = capsys.readouterr().out
    assert "planar multi-loop linkages" in out and "console command" not in out
