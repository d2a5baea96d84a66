"""Number and type synthesis: literature counts and two independent routes.

Literature counts of 1-DOF planar simple-jointed chains (4, 6, 8, 10 links: 1, 2, 16,
230): T. S. Mruthyunjaya, "Kinematic structure of mechanisms revisited", Mechanism
and Machine Theory 38 (2003) 279–320, table 1; L.-W. Tsai, *Mechanism Design:
Enumeration of Kinematic Structures According to Function*, CRC Press (2001),
ch. 4.  2-DOF (5, 7, 9 links: 1, 4, 40, fractionated chains included;
11 links: 839 in the benchmark): the same tables.
"""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, strategies as st

from multiloop.catalogue.synthesis import (
    LITERATURE_SJ_F1, SynthesisOptions, brute_force_chains, canonical_string, count_task,
    iter_chains, joint_masks_degenerate, mechanism_choices, nauty_available, number_synthesis,
    plan_tasks, run_task, universal_table, _degenerate_by_definition, _decode_bipartite,
    _generator_command,
)
from multiloop.topo.degeneracy import fractionation, is_degenerate
from multiloop.topo.errors import InputError
from multiloop.topo.isomorphism import canonical_form
from multiloop.topo.model import chain_from_joint_lists

needs_nauty = pytest.mark.skipif(not nauty_available(),
                                 reason="nauty's geng/genbg not installed (apt-get install nauty)")


def _count(opts: SynthesisOptions) -> int:
    return sum(count_task(t, opts) for t in plan_tasks(opts))


@needs_nauty
@pytest.mark.parametrize("n", [4, 6, 8, 10])
def test_literature_simple_joint_counts_f1(n):
    assert _count(SynthesisOptions(n, 1, simple_joints=True)) == LITERATURE_SJ_F1[n]


@needs_nauty
@pytest.mark.parametrize("n, expected", [(5, 1), (7, 4), (9, 40)])
def test_literature_simple_joint_counts_f2(n, expected):
    assert _count(SynthesisOptions(n, 2, simple_joints=True)) == expected


def _both_routes(opts):
    fast = sorted(r.canonical for r in iter_chains(opts, loops=False))
    slow = sorted(canonical_string(opts.n, j) for j in brute_force_chains(opts))
    return fast, slow


@needs_nauty
@pytest.mark.parametrize("opts", [
    SynthesisOptions(4, 1), SynthesisOptions(5, 2), SynthesisOptions(6, 1), SynthesisOptions(6, 3),
    SynthesisOptions(7, 2), SynthesisOptions(8, 1, simple_joints=True), SynthesisOptions(8, 1),
    SynthesisOptions(8, 3, no_fractionated=True), SynthesisOptions(7, 2, max_link_degree=3),
    SynthesisOptions(7, 2, max_multiplicity=1),
], ids=lambda o: o.key())
def test_generator_equals_brute_force(opts):
    fast, slow = _both_routes(opts)
    assert fast == slow
    assert len(set(fast)) == len(fast)


@needs_nauty
def test_known_multiple_joint_counts_small():
    # exact counts of this library (two routes above); pinned as regression values
    assert [_count(SynthesisOptions(n, F)) for n, F in [(4, 1), (6, 1), (8, 1), (7, 2), (9, 2)]] == \
        [1, 4, 60, 9, 219]


@needs_nauty
def test_partition_does_not_change_the_result():
    opts = SynthesisOptions(9, 2)
    one = sorted(r.canonical for t in plan_tasks(opts, split=1) for r in run_task(t, opts, loops=False))
    three = sorted(r.canonical for t in plan_tasks(opts, split=3) for r in run_task(t, opts, loops=False))
    assert one == three and len(one) == 219


@needs_nauty
def test_filter_agrees_with_definition_and_lead_on_raw_candidates():
    """Every genbg candidate of n = 8, F = 1: the NumPy filter = the definition = topo."""
    import subprocess

    opts = SynthesisOptions(8, 1)
    for task in plan_tasks(opts)[1:3]:
        lines = subprocess.run(_generator_command(task, opts), capture_output=True).stdout.split()
        masks = _decode_bipartite(lines, 8, task.m)
        fast = joint_masks_degenerate(masks, 8)
        for row, flag in zip(masks.tolist()[:300], fast[:300]):
            assert flag == _degenerate_by_definition(row, 8)
            m = chain_from_joint_lists([[str(x) for x in range(8) if j >> x & 1] for j in row])
            assert flag == is_degenerate(m)


@given(st.integers(4, 9).flatmap(lambda n: st.tuples(
    st.just(n), st.lists(st.integers(1, (1 << n) - 1).filter(lambda x: bin(x).count("1") >= 2),
                         min_size=2, max_size=9, unique=True))))
def test_numpy_degeneracy_equals_definition(case):
    n, joints = case
    assert joint_masks_degenerate(np.array([joints]), n)[0] == _degenerate_by_definition(joints, n)


@needs_nauty
def test_records_match_topo():
    """Canonical string, fractionation shortcut and non-degeneracy agree with topo."""
    for opts in (SynthesisOptions(8, 1), SynthesisOptions(8, 3)):
        for r in iter_chains(opts, loops=False):
            m = r.as_mechanism()
            assert r.canonical == canonical_form(m)
            assert not is_degenerate(m)
            assert r.fractionated == fractionation(m).is_fractionated


@needs_nauty
def test_existence_domain_and_universal_table():
    for opts in (SynthesisOptions(8, 1), SynthesisOptions(9, 2), SynthesisOptions(10, 1)):
        recs = list(iter_chains(opts, loops=False))
        for r in recs:
            assert r.j_max <= r.K and r.V <= 2 * (r.K - 1)
        rows = universal_table(opts, recs)
        assert all(r.in_domain for r in rows)
        assert sum(r.chains for r in rows) == len(recs)
        assert any(r.chains == 0 for r in rows)     # the equations admit unrealisable rows


@needs_nauty
def test_existence_domain_fails_for_fractionated_f3():
    """F = 3, n = 10: a cut joint of multiplicity 4 > K = 3 (outside Pozhbelko & Kuts 2020 fig. 10)."""
    opts = SynthesisOptions(10, 3)
    recs = list(iter_chains(opts, loops=False))
    out = [r for r in recs if r.j_max > r.K]
    assert out and all(r.fractionated for r in out)
    rows = universal_table(opts, recs)
    assert sum(r.chains for r in rows) == len(recs)
    assert any(not r.in_domain for r in rows)


def test_number_synthesis_equations():
    opts = SynthesisOptions(10, 1)
    p, n = opts.p, opts.n
    rows = number_synthesis(opts)
    assert rows
    for r in rows:
        LA = list(r.LA)
        assert sum(LA) == n
        assert sum(i * c for i, c in zip(range(2, 2 + len(LA)), LA)) == 2 * p - r.V
        assert r.V == sum((j - 1) * c for j, c in zip(range(2, 2 + len(r.MJA)), r.MJA))
        assert r.V <= 2 * (r.K - 1) and len(r.MJA) + 1 <= r.K


def test_options_are_checked():
    with pytest.raises(InputError):
        SynthesisOptions(7, 1)
    with pytest.raises(InputError):
        SynthesisOptions(8, 0)


def test_mechanism_choices_watt_stephenson_and_by_brute_force():
    watt = [(0, 1), (0, 2), (2, 3), (3, 1), (0, 4), (4, 5), (5, 1)]
    steph = [(0, 3), (0, 4), (1, 4), (2, 4), (1, 5), (2, 5), (3, 5)]
    for joints, frames in ((watt, 2), (steph, 3)):
        masks = [sum(1 << x for x in j) for j in joints]
        c = mechanism_choices(6, masks)
        assert c.n_frames == frames
        # brute force: distinct mechanism canonical forms over every frame / driver
        base = chain_from_joint_lists([[str(x) for x in j] for j in joints])
        forms = {canonical_form(base.with_frame(str(f)), "mechanism") for f in range(6)}
        assert len(forms) == frames
        drivers = set()
        for f in range(6):
            for a, j in enumerate(joints):
                if f in j:
                    m = base.with_frame(str(f))
                    m = m.with_drivers([(f"J{a + 1}", (str(f), str([x for x in j if x != f][0])), None, None)])
                    drivers.add(canonical_form(m, "mechanism"))
        assert len(drivers) == c.n_drivers


@needs_nauty
def test_fast_planarity_equals_networkx():
    """The reduced-graph shortcuts (K <= 4: only a K3,3 can be non-planar) vs networkx."""
    import networkx as nx

    for opts in (SynthesisOptions(10, 1), SynthesisOptions(9, 2)):
        recs = list(iter_chains(opts, loops=False))
        assert any(not r.planar for r in recs) == (opts.K >= 4)   # K <= 3: always planar
        for r in recs[::3]:
            g = nx.Graph()
            g.add_edges_from((x, r.n + a) for a, j in enumerate(r.joints) for x in j)
            assert nx.check_planarity(g)[0] == r.planar


@needs_nauty
@pytest.mark.parametrize("n, expected", [(4, 1), (6, 5), (8, 71), (10, 1834)])
def test_literature_mechanism_counts(n, expected):
    """Distinct 1-DOF simple-jointed mechanisms (frame choices): 1, 5, 71, 1834 for
    4…10 links (Tsai 2001, ch. 4; Mruthyunjaya 2003)."""
    opts = SynthesisOptions(n, 1, simple_joints=True)
    total = sum(mechanism_choices(n, [sum(1 << x for x in j) for j in r.joints]).n_frames
                for r in iter_chains(opts, loops=False))
    assert total == expected


@given(st.integers(3, 9), st.lists(st.integers(1, 2 ** 9 - 1), min_size=2, max_size=12))
def test_fractionation_two_routes(n, raw):
    # articulation points of the incidence graph (rustworkx) vs removing each link / joint
    from multiloop.catalogue.synthesis.records import _connected, _fractionation, _fractionation_by_removal

    full = (1 << n) - 1
    joints = sorted({jm & full for jm in raw if bin(jm & full).count("1") >= 2})
    covered = 0
    for jm in joints:
        covered |= jm
    if covered != full or not _connected(n, joints):
        return   # every link on a joint, one connected chain
    assert _fractionation(n, joints) == _fractionation_by_removal(n, joints)
