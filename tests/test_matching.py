"""The decomposition's maximum bipartite matching (``topo.assur.maximum_matching``,
augmenting paths) against SciPy's Hopcroft–Karp on random incidences: the same size,
and a valid matching (each row its own allowed column)."""
from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import maximum_bipartite_matching

from multiloop.topo.assur import maximum_matching


@st.composite
def incidences(draw):
    n_cols = draw(st.integers(1, 16))
    rows = draw(st.lists(st.lists(st.integers(0, n_cols - 1), max_size=6, unique=True), min_size=1, max_size=16))
    return [tuple(r) for r in rows], n_cols


@settings(max_examples=300, deadline=None)
@given(incidences())
def test_matching_is_maximum_like_hopcroft_karp(case):
    rows, n_cols = case
    match = maximum_matching(rows, n_cols)
    taken = [int(c) for c in match if c >= 0]
    assert all(c in rows[r] for r, c in enumerate(match) if c >= 0)
    assert len(set(taken)) == len(taken)
    data = [(r, c) for r, cs in enumerate(rows) for c in cs]
    S = csr_matrix((np.ones(len(data)), ([d[0] for d in data], [d[1] for d in data])), shape=(len(rows), n_cols))
    assert len(taken) == int((np.asarray(maximum_bipartite_matching(S, perm_type="column")) >= 0).sum())
