"""The mechanism atlas: inversions up to symmetry with their Assur structure, counted by
two routes (orbit representatives vs Burnside's lemma vs explicit canonical forms),
stored in SQLite and resumed after a kill."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections import Counter

import pytest

from multiloop.catalogue.atlas import Atlas
from multiloop.catalogue.inversions import (
    build_mechanisms, burnside_counts, classify, explicit_inversions, inversion, iter_mechanisms,
    mechanism_counts,
)
from multiloop.catalogue.synthesis import SynthesisOptions, mechanism_choices, nauty_available
from multiloop.cli import main
from multiloop.topo.isomorphism import canonical_form

pytestmark = pytest.mark.skipif(not nauty_available(),
                                reason="nauty's geng/genbg not installed (apt-get install nauty)")


def _masks(r):
    return [sum(1 << x for x in j) for j in r.joints]


def _built(opts):
    atlas = Atlas(":memory:")
    atlas.build(opts, progress=False, loops=False)
    return atlas, build_mechanisms(atlas, opts)


def _explicit_classes(atlas, opts) -> tuple[int, Counter]:
    """Second route: every inversion's mechanism canonical form, one decomposition per form."""
    total, classes = 0, Counter()
    for rec in atlas.chains(opts):
        forms = explicit_inversions(rec)
        total += len(forms)
        for f, a, x in forms.values():
            classes[classify(inversion(rec.joints, f, a, x))[1]] += 1
    return total, classes


def _canonical_form_route(atlas, opts) -> int:
    """Fourth route: distinct ``topo.isomorphism.canonical_form(…, "mechanism")`` over
    every (frame, driver joint, driven link) of every chain."""
    return sum(len({canonical_form(inversion(rec.joints, f, a, x), "mechanism")
                    for a, j in enumerate(rec.joints) for f in j for x in j if x != f})
               for rec in atlas.chains(opts))


def test_four_bar_inversion():
    m = inversion([(0, 1), (1, 2), (2, 3), (3, 0)], 0, 0, 1)
    assert classify(m) == ("I(0,1) → II1(2,3)", 2, True, ("RRR",))


# Published oracle (frame choices of 1-DOF simple-jointed chains, Tsai 2001, ch. 4;
# Mruthyunjaya 2003): 1, 5, 71, 1834 mechanisms for 4, 6, 8, 10 links.
@pytest.mark.parametrize("n, sj, frames", [
    (4, True, 1), (6, True, 5), (8, True, 71), (6, False, None),
    pytest.param(8, False, None, marks=pytest.mark.benchmark),
    pytest.param(10, True, 1834, marks=pytest.mark.benchmark)])
def test_counts_by_three_routes(n, sj, frames):
    """Orbit representatives vs Burnside vs explicit certificates (with the class counts)
    vs the mechanism-mode canonical form of topo/isomorphism."""
    opts = SynthesisOptions(n, 1, simple_joints=sj)
    atlas, counts = _built(opts)
    with atlas:
        if frames is not None:
            assert counts.frames == frames
        burn = [burnside_counts(r.n, _masks(r)) for r in atlas.chains(opts)]
        assert counts.frames == sum(b[0] for b in burn)
        assert counts.drivers == sum(b[1] for b in burn)
        total, classes = _explicit_classes(atlas, opts)
        assert counts.drivers == total == _canonical_form_route(atlas, opts)
        assert dict(counts.by_class) == dict(classes)
        stored = list(iter_mechanisms(atlas, opts))
        assert len(stored) == counts.drivers
        assert sum(r.closed_form for r in stored) == counts.closed_form


def test_watt_and_stephenson_driver_counts_per_chain():
    opts = SynthesisOptions(6, 1, simple_joints=True)
    atlas, counts = _built(opts)
    with atlas:
        per = sorted(burnside_counts(r.n, _masks(r)) for r in atlas.chains(opts))
        assert per == sorted((mechanism_choices(r.n, _masks(r)).n_frames,
                              mechanism_choices(r.n, _masks(r)).n_drivers) for r in atlas.chains(opts))
        # a triad appears: a Stephenson chain driven so that the other four links form one group
        assert any(r.cls == 3 and r.kinds == ("triad",) for r in iter_mechanisms(atlas, opts))


def test_only_one_dof():
    from multiloop.topo.errors import InputError

    with Atlas(":memory:") as atlas:
        with pytest.raises(InputError, match="^mechanisms: expected .dof. 1"):
            build_mechanisms(atlas, SynthesisOptions(7, 2))


def test_resume_after_partial_mechanism_build():
    opts = SynthesisOptions(8, 1, simple_joints=True)
    with Atlas(":memory:") as atlas:
        atlas.build(opts, progress=False, loops=False)
        part = build_mechanisms(atlas, opts, max_chains=5)
        assert part.chains_run == 5 and part.chains == 5
        rest = build_mechanisms(atlas, opts)
        assert rest.chains_run == 11 and (rest.frames, rest.drivers) == (71, 153)
        assert build_mechanisms(atlas, opts).chains_run == 0


def test_mechanism_build_resumes_after_kill(tmp_path):
    """SIGKILL `multiloop atlas --mechanisms` once the first chain's inversions are stored."""
    db = tmp_path / "m.sqlite"
    cmd = [sys.executable, "-m", "multiloop", "atlas", "--links", "8", "--dof", "1", "--db", str(db),
           "--workers", "1", "--no-loops", "--no-progress", "--mechanisms"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline, done = time.time() + 60, 0
    while time.time() < deadline and proc.poll() is None and done < 1:
        time.sleep(0.05)
        try:
            with Atlas(db) as a:
                done = a.con.execute("SELECT count(*) FROM mechanism_chains").fetchone()[0]
        except Exception:  # noqa: BLE001 - the file or table may be mid-creation
            done = 0
    if proc.poll() is None:
        os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    assert main(["atlas", "--links", "8", "--dof", "1", "--db", str(db), "--no-loops",
                 "--no-progress", "--workers", "1", "--mechanisms"]) == 0
    opts = SynthesisOptions(8, 1)
    with Atlas(db) as atlas:
        c = mechanism_counts(atlas, opts)
        assert (c.chains, c.frames, c.drivers) == (60, 330, 850)
        dup = atlas.con.execute("SELECT count(*) - count(DISTINCT chain || frame || ',' || joint || ',' || driven)"
                                " FROM mechanisms").fetchone()[0]
        assert dup == 0


def test_cli_prints_counts_by_class(tmp_path, capsys):
    db = tmp_path / "c.sqlite"
    assert main(["atlas", "--links", "6", "--dof", "1", "--db", str(db), "--simple-joints",
                 "--mechanisms", "--no-progress", "--json"]) == 0
    import json

    doc = json.loads(capsys.readouterr().out)
    assert doc["mechanisms"]["frames"] == 5 and doc["mechanisms"]["drivers"] == 9
    assert doc["mechanisms"]["by_class"] == {"II": 6, "III": 2, "IV": 1}
