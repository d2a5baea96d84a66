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
scan (the reference of the recall measurement).
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .atlas import Atlas, each_with_progress
from .curves import CURVE_POINTS, DESCRIPTOR_HARMONICS, descriptor, normalise, reversed_descriptor
from .distributed import map_calls
from .inversions import InversionRecord, iter_mechanisms
from .realisations import coupler_curves, realise
from .synthesis import SynthesisOptions

__all__ = ["build_curves", "realise_mechanism", "CurveBuild", "CurveIndex", "CurveHit", "curve_record", "stored_curve"]

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


def _ensure(atlas: Atlas) -> None:
    atlas.con.executescript(_SCHEMA)


def _mechanism_ids(atlas: Atlas, opts: SynthesisOptions) -> list[tuple[int, InversionRecord]]:
    ids = {(ch, f, a, x): i for i, ch, f, a, x in
           atlas.con.execute("SELECT id, chain, frame, joint, driven FROM mechanisms")}
    return [(ids[(r.chain, r.frame, r.joint, r.driven)], r) for r in iter_mechanisms(atlas, opts)]


def curve_record(points: np.ndarray) -> tuple[bytes, bytes, complex, float]:
    """Descriptor and normalised shape (as stored BLOBs), centre and radius of a closed curve."""
    z, c, r = normalise(points, CURVE_POINTS, True)
    d = descriptor(points, closed=True)
    return d.tobytes(), z.astype(np.complex64).tobytes(), c, r


def realise_mechanism(mid: int, inv: InversionRecord, k: int, per_link: int) -> list[tuple]:
    """The ``k`` realisations of one mechanism with their curves, ready to store
    (seeds from the mechanism's row id, so any process gives the same rows)."""
    rows = []
    for s in range(k):
        seed = 1_000_003 * mid + 7919 * s
        r = realise(inv, seed)
        if r is None:
            continue
        m = r.mechanism
        curves = coupler_curves(m, (m.frame, m.drivers[0].links[1]), per_link, np.random.default_rng(seed))
        joints = {j.name: list(j.at) for j in m.joints}
        rows.append((r.seed, r.tries, r.min_angle, joints,
                     [(cv.link, cv.at, *curve_record(cv.points)) for cv in curves]))
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


def build_curves(atlas: Atlas, opts: SynthesisOptions, k: int, per_link: int = 2, progress: bool = False,
                 max_mechanisms: int | None = None, workers: int = 1, scheduler=None) -> CurveBuild:
    """Draw ``k`` certified realisations of every closed-form mechanism of ``opts``
    (mechanisms already built with :func:`.inversions.build_mechanisms`) and store
    ``per_link`` coupler curves per moving link other than the driven one; resumes.
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


class CurveIndex:
    """Nearest-descriptor search over the stored curves (optionally of given link counts).

    Parameters
    ----------
    atlas : Atlas
    links : sequence of int, optional
        Only curves of mechanisms with these numbers of links.
    exact : bool
        Exact NumPy scan instead of the HNSW graph.
    """

    def __init__(self, atlas: Atlas, links: Sequence[int] | None = None, exact: bool = False):
        _ensure(atlas)
        where, params = "1", []
        if links:
            where = f"m.n IN ({','.join('?' * len(links))})"
            params = [int(n) for n in links]
        rows = atlas.con.execute(
            "SELECT c.id, c.descriptor FROM curves c JOIN realisations r ON r.id = c.realisation "
            f"JOIN mechanisms m ON m.id = r.mechanism WHERE {where} ORDER BY c.id", params).fetchall()
        self.ids = np.array([r[0] for r in rows], dtype=np.int64)
        width = 2 * DESCRIPTOR_HARMONICS
        self.vectors = (np.frombuffer(b"".join(r[1] for r in rows), dtype=np.float32).reshape(-1, width)
                        if rows else np.zeros((0, width), np.float32))
        Index = None if exact else _usearch()
        self.kind = "exact" if Index is None or not len(rows) else "usearch-hnsw"
        self._index = None
        if self.kind != "exact":
            self._index = Index(ndim=width, metric="l2sq", dtype="f32", connectivity=32,
                                expansion_add=128, expansion_search=256)
            self._index.add(np.arange(len(rows), dtype=np.uint64), self.vectors)

    def __len__(self) -> int:
        return len(self.ids)

    def _search(self, q: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
        k = min(k, len(self.ids))
        if self._index is None:
            d = np.sum((self.vectors - q[None, :]) ** 2, axis=1)
            top = np.argpartition(d, k - 1)[:k]
            top = top[np.argsort(d[top])]
            return top, d[top]
        m = self._index.search(q, k)
        return np.asarray(m.keys, dtype=np.int64), np.asarray(m.distances, dtype=float)

    def query(self, d: np.ndarray, k: int = 50) -> list[CurveHit]:
        """The ``k`` nearest curves to descriptor ``d`` over both directions."""
        if not len(self.ids) or k <= 0:
            return []
        best: dict[int, CurveHit] = {}
        for rev, q in ((False, d), (True, reversed_descriptor(d))):
            keys, dist = self._search(np.asarray(q, np.float32), k)
            for key, dd in zip(keys, dist):
                cid = int(self.ids[key])
                if cid not in best or dd < best[cid].distance:
                    best[cid] = CurveHit(cid, float(np.sqrt(max(dd, 0.0))), rev)
        return sorted(best.values(), key=lambda h: h.distance)[:k]


def stored_curve(atlas: Atlas, curve_id: int) -> dict:
    """A stored curve with its realisation and mechanism: ``shape`` (complex normalised
    samples), ``centre``, ``radius``, ``link``, ``at``, ``joints`` (positions by name),
    ``mechanism`` (row id), ``joints_of_chain`` (link indices per joint), ``chain``, ``frame``, ``joint``, ``driven``, ``n``, ``formula``."""
    row = atlas.con.execute(
        "SELECT c.shape, c.cx, c.cy, c.radius, c.link, c.x, c.y, r.joints, m.id, m.chain, m.frame, m.joint, "
        "m.driven, m.n, m.formula FROM curves c JOIN realisations r ON r.id = c.realisation "
        "JOIN mechanisms m ON m.id = r.mechanism WHERE c.id = ?", (int(curve_id),)).fetchone()
    shape, cx, cy, rad, link, x, y, joints, mid, chain, f, a, xd, n, formula = row
    chain_joints = json.loads(atlas.con.execute("SELECT joints FROM chains WHERE canonical = ?",
                                                (chain,)).fetchone()[0])
    return {"joints_of_chain": tuple(tuple(int(v) for v in j) for j in chain_joints),"shape": np.frombuffer(shape, np.complex64).astype(complex), "centre": complex(cx, cy),
            "radius": rad, "link": link, "at": (x, y), "joints": json.loads(joints), "mechanism": mid,
            "chain": chain, "frame": f, "joint": a, "driven": xd, "n": n, "formula": formula}
