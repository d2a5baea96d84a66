"""Loop assortment [La]: special cases of the canonical rule (Pozhbelko & Kuts 2020)."""
from __future__ import annotations

from multiloop.topo.loops import loop_assortment
from multiloop.topo.model import chain_from_joint_lists
from multiloop.topo.numbers import structural_report


def test_loopless_chains_have_no_loop():
    # two links on one joint: K = 0, no loop (it used to report [La] = 2 with L0 = 2)
    la = loop_assortment(chain_from_joint_lists([["a", "b"]]))
    assert la.planar and la.sizes == () and la.outer is None
    r = structural_report(chain_from_joint_lists([["a", "b"], ["b", "c"]]))
    assert r.K == 0 and r.La == () and r.L0 is None


def test_single_loop_and_dangling_link():
    # a four-bar loop: inner and outer face of four links each
    assert loop_assortment(chain_from_joint_lists([["a", "b"], ["b", "c"], ["c", "d"], ["d", "a"]])).sizes == (4, 4)
    # a triangle with a dangling link: its joint adds two link corners (c again, d) to the outer loop
    la = loop_assortment(chain_from_joint_lists([["a", "b"], ["b", "c"], ["c", "a"], ["c", "d"]]))
    assert la.sizes == (3, 5) and la.outer == 5
