"""The curve index stored in the atlas: loaded when current, rebuilt in memory when
stale or missing, the same answers either way, and an exact scan as the reference."""
from __future__ import annotations

import sqlite3

import numpy as np
import pytest

from multiloop.catalogue.atlas import Atlas
from multiloop.catalogue.curve_atlas import CurveIndex, save_index
from multiloop.catalogue.synthesis import nauty_available
from tests.common import four_bar_curve_atlas

pytest.importorskip("usearch")
pytestmark = pytest.mark.skipif(not nauty_available(), reason="nauty's geng/genbg not installed")


@pytest.fixture(scope="module")
def four_bar_atlas(tmp_path_factory):
    return four_bar_curve_atlas(tmp_path_factory.mktemp("index") / "atlas.sqlite")


def _answers(index: CurveIndex, queries) -> list[list[int]]:
    return [[h.curve for h in index.query(q, 5)] for q in queries]


def _nearest(index: CurveIndex, queries) -> list[float]:
    return [index.query(q, 1)[0].distance for q in queries]


def test_the_build_stores_the_index_and_a_query_loads_it(four_bar_atlas):
    with Atlas(four_bar_atlas, readonly=True) as atlas:
        stored = CurveIndex(atlas)
        exact = CurveIndex(atlas, exact=True)
        assert stored.kind == "usearch-hnsw (stored)" and exact.kind == "exact"
        assert len(stored) == len(exact) == len(exact.ids) > 0
        queries = exact.vectors[::3]
        got, want = _answers(stored, queries), _answers(exact, queries)
        assert np.allclose(_nearest(stored, queries), 0.0, atol=1e-6)    # a curve's own descriptor
    assert np.mean([len(set(a) & set(b)) / 5 for a, b in zip(got, want)]) >= 0.9


def test_a_stale_or_missing_index_is_rebuilt_in_memory(four_bar_atlas, tmp_path):
    db = tmp_path / "stale.sqlite"
    db.write_bytes(four_bar_atlas.read_bytes())
    con = sqlite3.connect(db)
    gone = con.execute("SELECT max(id) FROM curves").fetchone()[0]
    con.execute("DELETE FROM curves WHERE id = ?", (gone,))
    con.commit()
    con.close()
    with Atlas(db, readonly=True) as atlas:
        index = CurveIndex(atlas)
        assert index.kind == "usearch-hnsw"                     # the stored graph misses a row: not used
        hits = [h.curve for q in index.vectors for h in index.query(q, 3)]
    assert gone not in hits
    with Atlas(db) as atlas:
        assert save_index(atlas, 4) == len(CurveIndex(atlas, exact=True))
        atlas.con.execute("DROP TABLE curve_indexes")
    with Atlas(db, readonly=True) as atlas:                     # an atlas from before the table
        assert CurveIndex(atlas).kind == "usearch-hnsw"
