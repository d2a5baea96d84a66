"""The second core of the web workbench (multiloop.web.second_core): a child process moves
half the drivers of a design while the page's job moves the others, and the report is
``check``'s, bit for bit; a cancelled job stops the child's task; the child ends with
the server."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import numpy as np
import pytest

from multiloop.catalogue.named import load_named
from multiloop.kin.check import check
from multiloop.web.editing import moved
from multiloop.web.second_core import SecondCore, theirs


class _Job:
    """The part of :class:`multiloop.web.jobs.Job` a check job's worker uses."""

    name = "check"
    sweeps = None

    def __init__(self):
        self.polls = 0

    def poll(self):
        self.polls += 1

    def report(self, *a, **k):
        self.poll()

    def notify(self):
        pass


@pytest.fixture(scope="module")
def core(monkeypatch_module):
    c = SecondCore()
    c.start()
    assert c.proc is not None, "the machine has one core or MULTILOOP_SECOND_CORE=0"
    assert c.ready.wait(120)                # (a hang guard: the child's imports and warm-up)
    monkeypatch_module.setattr("multiloop.web.second_core.SECOND_CORE", c)
    yield c
    c.proc.stdin.close()
    c.proc.wait(timeout=60)


@pytest.fixture(scope="module")
def monkeypatch_module():
    mp = pytest.MonkeyPatch()
    yield mp
    mp.undo()


def test_the_second_half_of_the_drivers_goes_to_the_child():
    assert theirs(1) == () and theirs(2) == (1,) and theirs(3) == (1, 2) and theirs(4) == (2, 3)


@pytest.mark.parametrize("name", ["excavator", "excavator_bucket", "knuckle_boom_crane", "stephenson_3_triad",
                                  "four_bar"])
def test_a_job_on_two_cores_gives_check_s_report_and_the_sweeps_bit_for_bit(core, name):
    """An edited design's job with the child doing its share (half the drivers; the
    angles' extremes of a design with one driver): the document is
    ``check(...).as_dict()`` and every sweep equals the one moved in this process."""
    from multiloop.web import app
    from multiloop.web.scene import sweep_driver
    m = load_named(name)
    j = m.joints[1]
    m2 = moved(m, j.name, (j.at[0] + 0.004 * m.size, j.at[1]))
    job = _Job()
    doc = app._motion_and_check(job, m2, 40.0, None)
    assert core.task is None                 # the child's share was taken (and answered)
    assert json.dumps(doc, sort_keys=True) == json.dumps(check(m2).as_dict(), sort_keys=True)
    for k, sw in enumerate(job.sweeps):
        alone = sweep_driver(m2, k)
        assert sw.joint == alone.joint
        np.testing.assert_array_equal(sw.nodes, alone.nodes)
        np.testing.assert_array_equal(sw.x, alone.x)


def test_a_cancelled_job_stops_the_child_s_task_and_the_child_takes_the_next(core):
    """linkage_24's driver takes the child about a second: stopped at once, its task
    ends without a result, and the next task is answered."""
    task = core.submit(load_named("linkage_24"), (0,))
    assert task is not None
    assert core.submit(load_named("excavator_bucket"), (1,)) is None       # busy: the job moves them itself
    core.stop(task)
    assert task.result(lambda: None) is None
    nxt = core.submit(load_named("excavator_bucket"), (1,))
    sweep, dc = nxt.result(lambda: None)[0]
    assert dc.joint == "thumb_cyl_slide" and sweep.joint == "thumb_cyl_slide"


def test_a_failed_child_leaves_the_drivers_to_the_job(monkeypatch):
    """No child (one core, or it could not start): the job moves every driver itself."""
    from multiloop.web import app
    c = SecondCore()
    monkeypatch.setattr("multiloop.web.second_core.SECOND_CORE", c)
    m = load_named("excavator_bucket")
    assert c.drivers(m, _Job())[1] is None and c.angles(load_named("four_bar"), _Job()) is None
    doc = app._motion_and_check(_Job(), m, 40.0, None)
    assert doc == check(m).as_dict()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_the_child_ends_with_the_server():
    """A process that started the child and ended: the child reads the end of its input
    and ends too (no orphan keeps a core)."""
    code = ("from multiloop.web.second_core import SECOND_CORE as c; c.start(); "
            "print(c.proc.pid, flush=True)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120)
    pid = int(out.stdout.split()[0])

    def alive() -> bool:
        try:
            with open(f"/proc/{pid}/stat") as f:
                return f.read().split(")")[-1].split()[0] != "Z"
        except OSError:
            return False
    for _ in range(600):                 # a hang guard only: it ends as soon as its imports do
        if not alive():
            break
        time.sleep(0.1)
    assert not alive()


def test_a_design_shown_from_the_cache_has_the_child_decompose_it_alone(core):
    """``prepare``: the child compiles the design's plan and computes nothing else (its
    answer holds no result); the next task is taken."""
    task = core.prepare(load_named("excavator"))
    assert task is not None
    assert task.result(lambda: None) is None and task.ok
    nxt = core.submit(load_named("excavator"), (2,))
    sweep, dc = nxt.result(lambda: None)[0]
    assert dc.joint == sweep.joint == "bucket_cyl_slide"
