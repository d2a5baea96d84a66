"""Coupler curves of the mechanism atlas, stored in the atlas file, and their
nearest-neighbour index.

``build_curves`` draws ``K`` certified realisations of every stored mechanism whose
groups all have closed forms (:mod:`.realisations`; the Newton-solved groups of
classes V and VI take minutes per design under the check, so they are left out and
counted), traces a few points per moving link and stores, per curve, its Fourier
descriptor (:func:`.curves.descriptor`, float32), its normalised shape
(``CURVE_POINTS`` complex samples) and the centre and radius that normalised it.
The realisations of a mechanism and its ``curve_mechanisms`` row are written in one
transaction (a killed build resumes).

:class:`CurveIndex` answers nearest-descriptor queries in both traversal directions
with usearch's HNSW graph (Malkov & Yashunin 2020) when the ``usearch`` package is
installed (extra ``[curves]``), else by an exact NumPy scan; ``exact=True`` forces the
scan (the reference of the recall measurement).  The build stores one graph per number
of links in the atlas (table ``curve_indexes``) with the SHA-256 of its bytes, so a query
loads it instead of building it.  The checksum is verified before usearch reads the bytes
(a damaged graph crashed it); a graph that fails it, or one stored without a checksum by
an older release, is rebuilt from the curves in memory (the next build stores it again).
Every stored value read back is checked (:mod:`.stored_rows`).
"""
from __future__ import annotations

import hashlib
import json
import sqlite3
import time
import warnings
from dataclasses import dataclass
from functools import cache, cached_property
from typing import Sequence

import numpy as np

from . import stored_rows as sr
from .atlas import Atlas, each_with_progress
from .curves import CURVE_POINTS, DESCRIPTOR_HARMONICS, descriptors_closed, normalise_closed, reversed_descriptor
from .distributed import map_calls
from .inversions import InversionRecord, iter_mechanisms
from .realisations import coupler_curves, realise
from .synthesis import SynthesisOptions

__all__ = ["build_curves", "realise_mechanism", "CurveBuild", "CurveIndex", "CurveHit", "curve_records", "stored_curve",
           "POINTS_PER_LINK", "save_index"]

_SCHEMA = """
CREATE TABLE IF NOT EXISTS realisations (
    id INTEGER PRIMARY KEY, mechanism INTEGER NOT NULL, seed INTEGER NOT NULL,
    tries INTEGER NOT NULL, min_angle REAL NOT NULL, joints TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS curves (
    id INTEGER PRIMARY KEY, realisation INTEGER NOT NULL, link TEXT NOT NULL,
    x REAL NOT NULL, y REAL NOT NULL, descriptor BLOB NOT NULL, shape BLOB NOT NULL,
    cx REAL NOT NULL, cy REAL NOT NULL, radius REAL NOT NULL
);
CREATE TABLE IF NOT EXISTS curve_mechanisms (
    mechanism INTEGER PRIMARY KEY, wanted INTEGER NOT NULL, kept INTEGER NOT NULL, seconds REAL
);
CREATE TABLE IF NOT EXISTS curve_indexes (
    n INTEGER PRIMARY KEY, curves INTEGER NOT NULL, data BLOB NOT NULL, sha256 TEXT
);
"""


@dataclass(frozen=True, slots=True)
class CurveBuild:
    """Outcome of :func:`build_curves`."""

    mechanisms: int
    skipped_newton: int
    realisations: int
    curves: int
    mechanisms_run: int
    seconds: float

    def to_text(self) -> str:
        return (f"  curves: {self.curves} coupler curves of {self.realisations} certified realisations of "
                f"{self.mechanisms} mechanisms ({self.skipped_newton} with Newton-solved groups left out)")


@cache
def _columns() -> dict[str, tuple[str, ...]]:
    """The columns of each curve table, read from :data:`_SCHEMA` itself."""
    con = sqlite3.connect(":memory:")
    con.executescript(_SCHEMA)
    tables = [r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")]
    return {t: tuple(r[1] for r in con.execute(f"PRAGMA table_info({t})")) for t in tables}


def _check_tables(atlas: Atlas) -> None:
    """Each curve table the atlas has holds the columns of :data:`_SCHEMA` (a stored graph
    without its checksum column is from before it: its graph is rebuilt from the curves)."""
    for table, want in _columns().items():
        have = [r[1] for r in atlas.con.execute(f"PRAGMA table_info({table})")]
        missing = [c for c in want if c not in have and (table, c) != ("curve_indexes", "sha256")]
        if have and missing:
            raise sr.corrupt(atlas.path, table, None, f"the columns {', '.join(want)}",
                             f"the columns {', '.join(have)[:200]} (no {', '.join(missing)})")


def _ensure(atlas: Atlas) -> None:
    """The curve tables, created or checked; an atlas from before the stored graphs'
    checksums gets the column (its graphs are stored again by the next build)."""
    atlas.con.executescript(_SCHEMA)
    _check_tables(atlas)
    if "sha256" not in [r[1] for r in atlas.con.execute("PRAGMA table_info(curve_indexes)")]:
        atlas.con.execute("ALTER TABLE curve_indexes ADD COLUMN sha256 TEXT")


def _mechanism_ids(atlas: Atlas, opts: SynthesisOptions) -> list[tuple[int, InversionRecord]]:
    ids = {(ch, f, a, x): i for i, ch, f, a, x in
           atlas.con.execute("SELECT id, chain, frame, joint, driven FROM mechanisms")}
    return [(ids[(r.chain, r.frame, r.joint, r.driven)], r) for r in iter_mechanisms(atlas, opts)]


def curve_records(curves: np.ndarray) -> list[tuple[bytes, bytes, complex, float]]:
    """Descriptor and normalised shape (as stored BLOBs), centre and radius of each closed
    curve of a batch ``(K, n, 2)`` (the curves of one realisation, traced at the same inputs)."""
    if not len(curves):
        return []
    z, c, r = normalise_closed(curves, CURVE_POINTS)
    d = descriptors_closed(curves)
    return [(d[i].tobytes(), z[i].astype(np.complex64).tobytes(), complex(c[i]), float(r[i]))
            for i in range(len(curves))]


def realise_mechanism(mid: int, inv: InversionRecord, k: int, per_link: int) -> list[tuple]:
    """The ``k`` realisations of one mechanism with their curves (``per_link`` tracer
    points on each moving link other than the driven one), ready to store (seeds from the
    mechanism's row id, so any process gives the same rows)."""
    rows = []
    for s in range(k):
        seed = 1_000_003 * mid + 7919 * s
        r = realise(inv, seed)
        if r is None:
            continue
        m = r.mechanism
        curves = coupler_curves(m, (m.frame, m.drivers[0].links[1]), per_link, np.random.default_rng(seed))
        joints = {j.name: list(j.at) for j in m.joints}
        records = curve_records(np.array([cv.points for cv in curves]))
        rows.append((r.seed, r.tries, r.min_angle, joints,
                     [(cv.link, cv.at, *rec) for cv, rec in zip(curves, records)]))
    return rows


def _write_mechanism(atlas: Atlas, k: int, mid: int, rows: list[tuple], seconds: float) -> None:
    """One mechanism's realisations, curves and done mark in one transaction."""
    with atlas._tx() as con:
        for seed, tries, low, joints, curves in rows:
            rid = con.execute("INSERT INTO realisations (mechanism, seed, tries, min_angle, joints) VALUES "
                              "(?, ?, ?, ?, ?)", (mid, seed, tries, low, json.dumps(joints))).lastrowid
            con.executemany("INSERT INTO curves (realisation, link, x, y, descriptor, shape, cx, cy, radius) "
                            "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                            [(rid, link, at[0], at[1], d, shape, c.real, c.imag, rad)
                             for link, at, d, shape, c, rad in curves])
        con.execute("INSERT OR REPLACE INTO curve_mechanisms (mechanism, wanted, kept, seconds) VALUES (?, ?, ?, ?)",
                    (mid, k, len(rows), seconds))


def _timed(mid: int, inv: InversionRecord, k: int, per_link: int) -> tuple[int, list[tuple], float]:
    t = time.perf_counter()
    rows = realise_mechanism(mid, inv, k, per_link)
    return mid, rows, time.perf_counter() - t


#: tracer points per moving link of a realisation (``multiloop atlas --points-per-link``)
POINTS_PER_LINK = 2


def build_curves(atlas: Atlas, opts: SynthesisOptions, k: int, per_link: int = POINTS_PER_LINK, progress: bool = False,
                 max_mechanisms: int | None = None, workers: int = 1, scheduler=None) -> CurveBuild:
    """Draw ``k`` certified realisations of every closed-form mechanism of ``opts``
    (mechanisms already built with :func:`.inversions.build_mechanisms`) and store
    ``per_link`` coupler curves per moving link other than the driven one (the motion is
    solved once per realisation, so more points per link cost little: Hrones & Nelson
    1951 drew their four-bar atlas the same way, many coupler points per linkage); resumes
    (a mechanism already done keeps the points it was built with).
    ``workers`` local processes, or one Dask task per mechanism on ``scheduler`` (an
    address or a ``distributed.Client``), draw them (:func:`.distributed.map_calls`);
    this process writes each mechanism in one transaction, so the rows are the same for
    any count or cluster."""
    _ensure(atlas)
    done = {r[0] for r in atlas.con.execute("SELECT mechanism FROM curve_mechanisms")}
    mechs = _mechanism_ids(atlas, opts)
    closed = [(i, r) for i, r in mechs if r.closed_form]
    todo = [(i, r) for i, r in closed if i not in done]
    if max_mechanisms is not None:
        todo = todo[:max_mechanisms]
    t0 = time.perf_counter()
    results = map_calls(_timed, [(mid, inv, k, per_link) for mid, inv in todo], workers, scheduler)
    each_with_progress(todo, f"curves n={opts.n}", progress,
                       lambda _: _write_mechanism(atlas, k, *next(results)))   # in completion order
    ids = [i for i, _ in closed]
    save_index(atlas, opts.n)
    n_real, n_curves = _totals(atlas, ids)
    return CurveBuild(len(closed), len(mechs) - len(closed), n_real, n_curves, len(todo),
                      time.perf_counter() - t0)


def _totals(atlas: Atlas, mechanism_ids: Sequence[int]) -> tuple[int, int]:
    if not mechanism_ids:
        return 0, 0
    q = ",".join("?" * len(mechanism_ids))
    n_real = atlas.con.execute(f"SELECT count(*) FROM realisations WHERE mechanism IN ({q})",
                               list(mechanism_ids)).fetchone()[0]
    n_curves = atlas.con.execute(f"SELECT count(*) FROM curves JOIN realisations ON realisations.id = "
                                 f"curves.realisation WHERE mechanism IN ({q})", list(mechanism_ids)).fetchone()[0]
    return n_real, n_curves


# ------------------------------------------------------------------ the index
@dataclass(frozen=True, slots=True)
class CurveHit:
    """One retrieved curve: its row id, its descriptor distance and the direction."""

    curve: int
    distance: float
    reversed: bool


def _usearch():
    try:
        from usearch.index import Index
    except ImportError:
        return None
    return Index


def _hnsw(Index, ids: np.ndarray, vectors: np.ndarray):
    """The HNSW graph of ``vectors`` keyed by the curve row ``ids``."""
    ix = Index(ndim=2 * DESCRIPTOR_HARMONICS, metric="l2sq", dtype="f32", connectivity=32,
               expansion_add=128, expansion_search=256)
    ix.add(ids.astype(np.uint64), vectors)
    return ix


#: the curves of the mechanisms with ``n`` links (the query's parameter)
_OF_N = ("FROM curves c JOIN realisations r ON r.id = c.realisation "
         "JOIN mechanisms m ON m.id = r.mechanism WHERE m.n = ?")


def _rows(atlas: Atlas, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Row ids and descriptors of the curves of ``n``-link mechanisms (each a BLOB of
    finite float32 values, checked)."""
    rows = atlas.con.execute(f"SELECT c.id, c.descriptor {_OF_N} ORDER BY c.id", (int(n),)).fetchall()
    width = 2 * DESCRIPTOR_HARMONICS
    ids = np.array([r[0] for r in rows], dtype=np.int64)
    data = b"".join(sr.blob(atlas.path, "curves", i, "descriptor", d, 4 * width) for i, d in rows)
    vectors = np.frombuffer(data, dtype=np.float32).reshape(-1, width)
    bad = np.flatnonzero(~np.all(np.isfinite(vectors), axis=1))
    if bad.size:
        raise sr.corrupt(atlas.path, "curves", int(ids[bad[0]]), "descriptor: finite numbers", "NaN or infinity")
    return ids, vectors


def _shapes(atlas: Atlas, n: int) -> np.ndarray:
    """Normalised shapes (complex, ``(K, CURVE_POINTS)``) of the curves of ``n``-link
    mechanisms, in row-id order (each a BLOB of finite complex64 values, checked)."""
    rows = atlas.con.execute(f"SELECT c.id, c.shape {_OF_N} ORDER BY c.id", (int(n),)).fetchall()
    data = b"".join(sr.blob(atlas.path, "curves", i, "shape", z, 8 * CURVE_POINTS) for i, z in rows)
    shapes = np.frombuffer(data, dtype=np.complex64).reshape(-1, CURVE_POINTS).astype(complex)
    bad = np.flatnonzero(~np.all(np.isfinite(shapes), axis=1))
    if bad.size:
        raise sr.corrupt(atlas.path, "curves", int(rows[bad[0]][0]), "shape: finite numbers", "NaN or infinity")
    return shapes


def _count(atlas: Atlas, n: int) -> int:
    return atlas.con.execute(f"SELECT count(*) {_OF_N}", (int(n),)).fetchone()[0]


def _stored_index(atlas: Atlas, n: int, count: int):
    """The HNSW graph stored for ``n`` links when it covers all ``count`` curves and its
    bytes pass their SHA-256 checksum (checked before usearch reads them: a damaged graph
    crashed its reader).  None otherwise: the caller builds the graph from the curves.  An
    atlas from before the checksum (or the table) has none: its graph is rebuilt too."""
    Index = _usearch()
    try:
        row = atlas.con.execute("SELECT curves, data, sha256 FROM curve_indexes WHERE n = ?", (int(n),)).fetchone()
    except sqlite3.OperationalError:          # an atlas written before the table or the checksum
        return None
    if Index is None or row is None or row[0] != count or row[2] is None:
        return None
    if not isinstance(row[1], bytes) or hashlib.sha256(row[1]).hexdigest() != row[2]:
        warnings.warn(f"atlas {atlas.path!r}: table curve_indexes row {int(n)}: the stored graph fails its SHA-256 "
                      f"checksum; it is rebuilt from the curves (hint: {sr.REBUILD})", stacklevel=3)
        return None
    return Index.restore(row[1])


def save_index(atlas: Atlas, n: int) -> int:
    """Build the HNSW graph of the curves of ``n``-link mechanisms (keys: curve row ids)
    and store it in the atlas with the SHA-256 of its bytes, so that a query loads it
    instead of building it; the number of curves indexed (0 without usearch)."""
    _ensure(atlas)
    Index = _usearch()
    ids, vectors = _rows(atlas, n)
    if Index is None or not len(ids):
        return 0
    data = bytes(_hnsw(Index, ids, vectors).save())
    with atlas._tx() as con:
        con.execute("INSERT OR REPLACE INTO curve_indexes (n, curves, data, sha256) VALUES (?, ?, ?, ?)",
                    (int(n), len(ids), data, hashlib.sha256(data).hexdigest()))
    return len(ids)


class CurveIndex:
    """Nearest-descriptor search over the stored curves (optionally of given link counts).

    One graph per number of links: the one stored by :func:`save_index` when it is
    current, else one built in memory.

    Parameters
    ----------
    atlas : Atlas
    links : sequence of int, optional
        Only curves of mechanisms with these numbers of links.
    exact : bool
        Exact NumPy scan instead of the HNSW graph.
    """

    def __init__(self, atlas: Atlas, links: Sequence[int] | None = None, exact: bool = False):
        try:
            _ensure(atlas)
        except sqlite3.OperationalError:      # read-only, written before a table existed
            _check_tables(atlas)
        self.atlas = atlas
        ns = sorted({int(r[0]) for r in atlas.con.execute(
            "SELECT DISTINCT m.n FROM curve_mechanisms c JOIN mechanisms m ON m.id = c.mechanism")}
                    if not links else {int(n) for n in links})
        Index = None if exact else _usearch()
        self._parts, kinds, self._size = [], set(), 0
        for n in ns:
            count = _count(atlas, n)
            if not count:
                continue
            self._size += count
            ix = None if Index is None else _stored_index(atlas, n, count)
            if ix is not None:
                self._parts.append((ix, None, None))
                kinds.add("usearch-hnsw (stored)")
                continue
            ids, vectors = _rows(atlas, n)
            if Index is None:
                self._parts.append((None, ids, vectors))
                kinds.add("exact")
            else:
                self._parts.append((_hnsw(Index, ids, vectors), None, None))
                kinds.add("usearch-hnsw")
        self.kind = "+".join(sorted(kinds)) or "exact"
        self._links = ns

    def __len__(self) -> int:
        return self._size

    @cached_property
    def _table(self) -> tuple[np.ndarray, np.ndarray]:
        rows = [_rows(self.atlas, n) for n in self._links]
        return (np.concatenate([r[0] for r in rows] or [np.zeros(0, np.int64)]),
                np.concatenate([r[1] for r in rows] or [np.zeros((0, 2 * DESCRIPTOR_HARMONICS), np.float32)]))

    @property
    def ids(self) -> np.ndarray:
        """Row ids of the indexed curves (read from the atlas once, when first asked for)."""
        return self._table[0]

    @property
    def vectors(self) -> np.ndarray:
        """Descriptors of the indexed curves, in :attr:`ids` order."""
        return self._table[1]

    @cached_property
    def shapes(self) -> np.ndarray:
        """Normalised shapes of the indexed curves (complex, ``(len, CURVE_POINTS)``), in
        :attr:`ids` order: what an open target's windows are matched against
        (:func:`.curves.window_distances`)."""
        parts = [_shapes(self.atlas, n) for n in self._links]
        return np.concatenate(parts) if parts else np.zeros((0, CURVE_POINTS), complex)

    def _search(self, q: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Curve ids and squared distances of the ``k`` nearest in every part."""
        keys, dists = [], []
        for ix, ids, vectors in self._parts:
            if ix is None:
                d = np.sum((vectors - q[None, :]) ** 2, axis=1)
                top = np.argpartition(d, min(k, len(d)) - 1)[:k]
                keys.append(ids[top])
                dists.append(d[top])
            else:
                m = ix.search(q, min(k, len(ix)))
                keys.append(np.asarray(m.keys, dtype=np.int64))
                dists.append(np.asarray(m.distances, dtype=float))
        return np.concatenate(keys), np.concatenate(dists)

    def query(self, d: np.ndarray, k: int = 50) -> list[CurveHit]:
        """The ``k`` nearest curves to descriptor ``d`` over both directions."""
        if not self._size or k <= 0:
            return []
        best: dict[int, CurveHit] = {}
        for rev, q in ((False, d), (True, reversed_descriptor(d))):
            keys, dist = self._search(np.asarray(q, np.float32), k)
            for cid, dd in zip(keys.tolist(), dist):
                if cid not in best or dd < best[cid].distance:
                    best[cid] = CurveHit(cid, float(np.sqrt(max(dd, 0.0))), rev)
        return sorted(best.values(), key=lambda h: h.distance)[:k]


def stored_curve(atlas: Atlas, curve_id: int) -> dict:
    """A stored curve with its realisation and mechanism: ``shape`` (complex normalised
    samples), ``centre``, ``radius``, ``link``, ``at``, ``joints`` (positions by name),
    ``mechanism`` (row id), ``joints_of_chain`` (link indices per joint), ``chain``, ``frame``,
    ``joint``, ``driven``, ``n``, ``formula``; every value checked (:mod:`.stored_rows`)."""
    row = atlas.con.execute(
        "SELECT c.shape, c.cx, c.cy, c.radius, c.link, c.x, c.y, r.id, r.joints, m.id, m.chain, m.frame, m.joint, "
        "m.driven, m.n, m.formula FROM curves c JOIN realisations r ON r.id = c.realisation "
        "JOIN mechanisms m ON m.id = r.mechanism WHERE c.id = ?", (int(curve_id),)).fetchone()
    at = (atlas.path, "curves", int(curve_id))
    if row is None:
        raise sr.corrupt(*at, "a curve whose realisation and mechanism are stored", "a dangling reference")
    shape, cx, cy, rad, link, x, y, rid, joints, mid, chain, f, a, xd, n, formula = row
    m_at = (atlas.path, "mechanisms", mid)
    n = sr.integer(*m_at, "n", n, 2, 10_000)
    found = atlas.con.execute("SELECT id, joints FROM chains WHERE canonical = ?",
                              (sr.text(*m_at, "chain", chain),)).fetchone()
    if found is None:
        raise sr.corrupt(*m_at, "chain: the canonical form of a stored chain", "a dangling reference")
    chain_joints = sr.int_lists(atlas.path, "chains", found[0], "joints", found[1], below=n)
    return {"joints_of_chain": tuple(tuple(j) for j in chain_joints),
            "shape": np.frombuffer(sr.blob(*at, "shape", shape, 8 * CURVE_POINTS), np.complex64).astype(complex),
            "centre": complex(sr.real(*at, "cx", cx), sr.real(*at, "cy", cy)),
            "radius": sr.real(*at, "radius", rad, positive=True), "link": sr.text(*at, "link", link),
            "at": (sr.real(*at, "x", x), sr.real(*at, "y", y)),
            "joints": sr.positions(atlas.path, "realisations", rid, "joints", joints,
                                   [f"J{i + 1}" for i in range(len(chain_joints))]),
            "mechanism": mid, "chain": chain, "frame": sr.integer(*m_at, "frame", f, 0, n - 1),
            "joint": sr.integer(*m_at, "joint", a, 0, len(chain_joints) - 1),
            "driven": sr.integer(*m_at, "driven", xd, 0, n - 1), "n": n, "formula": sr.text(*m_at, "formula", formula)}
