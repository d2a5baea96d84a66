"""The final choice's ranking of candidates (``synthesise._Ranking``): the first places
of the full order (reaching the targets, meeting the constraints, accepted by
``kin.solve``, RMS error; ties in the candidates' order), with the plan compiled only
for the candidates that decide them."""
from __future__ import annotations

import importlib

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

S = importlib.import_module("multiloop.catalogue.dimensional.synthesise")      # (the module, not the function)


@settings(max_examples=200, deadline=None)
@given(rows=st.lists(st.tuples(st.booleans(), st.booleans(), st.booleans(), st.sampled_from([0.0, 1e-3, 0.5, 2.0])),
                     min_size=0, max_size=12),
       n=st.integers(1, 6))
def test_the_first_places_are_the_full_orders_and_few_plans_are_compiled(rows, n):
    mp = pytest.MonkeyPatch()
    try:
        cands = [((np.array([e]), None, ok), np.array([float(i)]), None, 0) for i, (ok, _, _, e) in enumerate(rows)]
        violates = {i: v for i, (_, v, _, _) in enumerate(rows)}
        solvable = {i: s for i, (_, _, s, _) in enumerate(rows)}
        compiled = []
        mp.setattr(S, "_violation", lambda problem, z: 1.0 if violates[int(z[0])] else 0.0)

        def _solvable(problem, z):
            compiled.append(int(z[0]))
            return solvable[int(z[0])]
        mp.setattr(S, "_solvable", _solvable)
        full = sorted(cands, key=lambda c: (not c[0][2], violates[int(c[1][0])] > 0, not solvable[int(c[1][0])],
                                            float(c[0][0][0])))
        ranking = S._Ranking(None)
        got = ranking.first(cands, n)
        assert [int(c[1][0]) for c in got] == [int(c[1][0]) for c in full[:n]]
        assert len(compiled) == len(set(compiled))                      # each design's plan once
        # no plan compiled past the class that fills the n places
        if got:
            last = (not got[-1][0][2], violates[int(got[-1][1][0])])
            assert all((not cands[i][0][2], violates[i]) <= last for i in compiled)
        assert ranking.first(cands, n) == got and len(compiled) == len(set(compiled))   # kept for the next ranking
        fresh = S._Ranking(None)
        compiled.clear()
        assert list(fresh.ordered(cands)) == full                       # the lazy order is the full order
        lazy = S._Ranking(None).ordered(cands)
        compiled.clear()
        head = next(lazy, None)                                         # the first place alone:
        assert head is (full[0] if full else None)
        if head is not None:                                            # no plan past its class
            assert all((not cands[i][0][2], violates[i]) <= (not head[0][2], violates[int(head[1][0])])
                       for i in compiled)
    finally:
        mp.undo()
