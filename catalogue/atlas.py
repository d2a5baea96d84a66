"""SQLite atlas of chains: resumable builds and safe queries.

Schema (``PRAGMA user_version = 1``)
------------------------------------
``builds``
    one row per set of :class:`~catalogue.synthesis.SynthesisOptions`
    (``options`` is :meth:`SynthesisOptions.key`, UNIQUE), with ``n``, ``F``,
    ``status`` (``running``/``done``), ``count`` (when done) and ``seconds``.
``tasks``
    the independent tasks of each build (``build_id``, ``key`` UNIQUE together),
    ``status`` (``pending``/``done``), ``n_chains``, ``seconds``.
``tallies``
    the rows of a count (:meth:`Atlas.count_table`: the chains of each task tallied by
    ``LA`` and ``MJA``, JSON lists, without storing the chains); its build's options
    key starts with ``count;``.
``chains``
    one row per chain, ``canonical`` UNIQUE (nauty canonical form of the coloured
    incidence graph, the string of :func:`topo.isomorphism.canonical_form`); ``n``,
    ``F``, ``p``, ``K``, ``V``, ``n_joints``, ``j_max``, ``i_max``, ``LA``, ``MJA``
    (JSON lists), ``code``, ``code_star``, ``planar``, ``fractionated``, ``loops``
    (the loop assortment [La], JSON list or NULL; query name ``La``), ``L0``, ``joints`` (JSON list of link-index lists).

Resumability: the chains of a task and the task's ``done`` mark are written in one
transaction, and chains are inserted with ``INSERT OR IGNORE``; a build killed at
any moment loses at most the tasks in flight, and rerunning it runs only the
pending tasks.  The count of a build is a query over ``chains`` with the build's
filters, so it never counts a row twice.

Queries: :func:`parse_query` accepts only ``column op value`` comparisons over the
known columns, joined by ``AND``/``OR``/``NOT`` and parentheses, and turns them into
SQL with bound parameters (no user text reaches SQL unquoted).
"""
from __future__ import annotations

import contextlib
import json
import os
import re
import sqlite3
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator, Sequence

from multiloop.topo.errors import InputError, OutputError, ParameterError, explain

from . import stored_rows as sr
from .synthesis import ChainRecord, SynthesisOptions, plan_tasks
from .synthesis.counting import count_signature, count_tasks

__all__ = ["Atlas", "BuildResult", "QUERY_COLUMNS", "parse_query", "build_atlas"]

_SCHEMA = """
CREATE TABLE IF NOT EXISTS builds (
    id INTEGER PRIMARY KEY,
    options TEXT NOT NULL UNIQUE,
    n INTEGER NOT NULL, F INTEGER NOT NULL,
    status TEXT NOT NULL DEFAULT 'running',
    count INTEGER, seconds REAL DEFAULT 0, loops INTEGER NOT NULL DEFAULT 1
);
CREATE TABLE IF NOT EXISTS tasks (
    build_id INTEGER NOT NULL REFERENCES builds(id),
    key TEXT NOT NULL, m INTEGER NOT NULL, res INTEGER NOT NULL, mod INTEGER NOT NULL,
    status TEXT NOT NULL DEFAULT 'pending', n_chains INTEGER, seconds REAL,
    PRIMARY KEY (build_id, key)
);
CREATE TABLE IF NOT EXISTS chains (
    id INTEGER PRIMARY KEY,
    canonical TEXT NOT NULL UNIQUE,
    n INTEGER NOT NULL, F INTEGER NOT NULL, p INTEGER NOT NULL, K INTEGER NOT NULL,
    V INTEGER NOT NULL, n_joints INTEGER NOT NULL, j_max INTEGER NOT NULL,
    i_max INTEGER NOT NULL,
    LA TEXT NOT NULL, MJA TEXT NOT NULL, code TEXT NOT NULL, code_star TEXT NOT NULL,
    planar INTEGER, fractionated INTEGER NOT NULL, loops TEXT, L0 INTEGER,
    joints TEXT NOT NULL
);
CREATE INDEX IF NOT EXISTS chains_nF ON chains (n, F);
CREATE TABLE IF NOT EXISTS tallies (
    build_id INTEGER NOT NULL REFERENCES builds(id),
    task TEXT NOT NULL, LA TEXT NOT NULL, MJA TEXT NOT NULL, chains INTEGER NOT NULL,
    PRIMARY KEY (build_id, task, LA, MJA)
);
"""
#: the options key of a count (rows tallied, chains not stored) starts with this
_COUNT = "count;"

#: columns a query may name (and their SQL type class)
QUERY_COLUMNS = {
    "n": "int", "F": "int", "p": "int", "K": "int", "V": "int", "n_joints": "int",
    "j_max": "int", "i_max": "int", "planar": "int", "fractionated": "int", "L0": "int",
    "LA": "text", "MJA": "text", "code": "text", "code_star": "text", "La": "text",
    "loops": "text",
    "canonical": "text", "id": "int",
}
#: query names that differ from the SQL column (SQLite names are case-insensitive)
_SQL_NAME = {"La": "loops"}


def _column(word: str) -> str | None:
    if word in QUERY_COLUMNS:
        return _SQL_NAME.get(word, word)
    low = [k for k in QUERY_COLUMNS if k.lower() == word.lower()]
    return _SQL_NAME.get(low[0], low[0]) if len(low) == 1 else None

_TOKEN = re.compile(r"""\s*(?:
    (?P<num>-?\d+)
  | (?P<str>'[^']*')
  | (?P<op><=|>=|!=|<>|==|=|<|>)
  | (?P<lp>\()
  | (?P<rp>\))
  | (?P<word>[A-Za-z_][A-Za-z_0-9]*)
)""", re.VERBOSE)


def _tokens(text: str) -> list[tuple[str, str]]:
    out, pos = [], 0
    text = text.strip()
    while pos < len(text):
        mt = _TOKEN.match(text, pos)
        if not mt or mt.end() == pos:
            raise ParameterError(explain("query", expected="column op value terms joined by AND/OR/NOT",
                                         got=f"unexpected text at {text[pos:pos + 12]!r}"), "query")
        kind = mt.lastgroup
        out.append((kind, mt.group(kind)))
        pos = mt.end()
        while pos < len(text) and text[pos].isspace():
            pos += 1
    return out


#: columns stored as JSON lists; a query may give them as printed (``La = '4-4-5-5-5'``)
_LIST_COLUMNS = {"LA", "MJA", "loops"}
_DASHED = re.compile(r"\d+(-\d+)*")

#: limits of a query: nested parentheses, comparisons, integer magnitude (SQLite INTEGER)
MAX_QUERY_DEPTH = 50
MAX_QUERY_TERMS = 200
_MAX_INT = 2 ** 63 - 1


def _check_size(toks: list[tuple[str, str]]) -> None:
    """Refuse queries too deep or too long before parsing them (recursive descent and
    SQLite's expression depth are both bounded)."""
    depth = deepest = 0
    for kind, _ in toks:
        depth += (kind == "lp") - (kind == "rp")
        deepest = max(deepest, depth)
    terms = sum(1 for kind, _ in toks if kind == "op")
    if deepest > MAX_QUERY_DEPTH or terms > MAX_QUERY_TERMS:
        raise ParameterError(explain("query", expected=f"at most {MAX_QUERY_DEPTH} nested parentheses and "
                                     f"{MAX_QUERY_TERMS} comparisons",
                                     got=f"{deepest} nested, {terms} comparisons"), "query")


def parse_query(text: str) -> tuple[str, list]:
    """Turn a user expression into a parameterised SQL ``WHERE`` clause.

    Grammar: ``expr := term (OR term)*``, ``term := factor (AND factor)*``,
    ``factor := NOT factor | '(' expr ')' | column op value``; ``op`` is one of
    ``= == != <> < <= > >=``, ``value`` an integer, a quoted string or
    ``true``/``false``.  A list column (``LA``, ``MJA``, ``La``) matches its stored
    text (``'[4, 4, 5, 5, 5]'``) or the form the listing prints (``'4-4-5-5-5'``).

    Raises
    ------
    InputError
        Unknown column, bad syntax (the message lists the columns).

    Examples
    --------
    >>> parse_query("V=2 AND K=4")
    ('("V" = ?) AND ("K" = ?)', [2, 4])
    >>> parse_query("code_star = '[8110]/[3-0-0]' or not planar = true")
    ('("code_star" = ?) OR (NOT ("planar" = ?))', ['[8110]/[3-0-0]', 1])
    >>> parse_query("La = '4-4-5-5-5'")[1]
    ['[4, 4, 5, 5, 5]']
    """
    try:
        text.encode("utf-8")
    except UnicodeEncodeError as exc:          # a byte of the command line that is not UTF-8
        raise ParameterError(explain("query", expected="UTF-8 text", got=f"an undecodable byte at {exc.start}",
                                     hint="write the query in UTF-8"), "query") from None
    toks = _tokens(text)
    _check_size(toks)
    if not toks:
        return "1", []
    parser = _QueryParser(toks)
    sql = parser.expr()
    if parser.pos != len(toks):
        parser.bad("AND, OR or the end of the query")
    return sql, parser.params


class _QueryParser:
    """Recursive descent over the tokens of :func:`parse_query` (depth bounded by
    :func:`_check_size`); ``params`` collects the bound values in order."""

    def __init__(self, toks: list[tuple[str, str]]):
        self.toks, self.pos, self.params = toks, 0, []

    def peek(self) -> tuple[str | None, str | None]:
        return self.toks[self.pos] if self.pos < len(self.toks) else (None, None)

    def bad(self, what: str):
        kind, val = self.peek()
        raise ParameterError(explain("query", expected=what, got=repr(val) if kind else "end of text",
                                     hint="columns: " + ", ".join(QUERY_COLUMNS)), "query")

    def _joined(self, word: str, part) -> str:
        parts = [part()]
        while self.peek()[0] == "word" and self.peek()[1].upper() == word:
            self.pos += 1
            parts.append(part())
        return f" {word} ".join(parts)

    def expr(self) -> str:
        return self._joined("OR", self.term)

    def term(self) -> str:
        return self._joined("AND", self.factor)

    def factor(self) -> str:
        kind, val = self.peek()
        if kind == "word" and val.upper() == "NOT":
            self.pos += 1
            return f"(NOT {self.factor()})"
        if kind == "lp":
            self.pos += 1
            inner = self.expr()
            if self.peek()[0] != "rp":
                self.bad("')'")
            self.pos += 1
            return f"({inner})"
        return self.comparison()

    def comparison(self) -> str:
        kind, val = self.peek()
        col = _column(val) if kind == "word" else None
        if col is None:
            self.bad("a column name (LA and La are case-sensitive)")
        self.pos += 1
        kind, op = self.peek()
        if kind != "op":
            self.bad("a comparison operator")
        self.pos += 1
        op = {"==": "=", "<>": "!="}.get(op, op)
        value = self.value()
        if col in _LIST_COLUMNS and isinstance(value, str) and _DASHED.fullmatch(value.strip()):
            value = json.dumps([int(v) for v in value.strip().split("-")])   # 4-4-5 as printed
        self.params.append(value)
        self.pos += 1
        return f'("{col}" {op} ?)'

    def value(self):
        kind, v = self.peek()
        if kind == "num":
            if abs(int(v)) > _MAX_INT:
                self.bad(f"an integer within ±{_MAX_INT}")
            return int(v)
        if kind == "str":
            return v[1:-1]
        if kind == "word" and v.lower() in ("true", "false"):
            return int(v.lower() == "true")
        self.bad("a number, 'string', true or false")


@dataclass(frozen=True, slots=True)
class BuildResult:
    """Outcome of :meth:`Atlas.build`."""

    options: SynthesisOptions
    count: int
    tasks_run: int
    tasks_total: int
    seconds: float


class Atlas:
    """An atlas file (SQLite).  Use as a context manager or call :meth:`close`.

    Examples
    --------
    >>> from multiloop.catalogue.synthesis import SynthesisOptions, nauty_available
    >>> with Atlas(":memory:") as atlas:                  # doctest: +SKIP
    ...     atlas.build(SynthesisOptions(8, 1, simple_joints=True), progress=False).count
    16
    """

    def __init__(self, path: str | Path = "atlas.sqlite", readonly: bool = False):
        self.path = str(path)
        if self.path != ":memory:" and Path(self.path).is_dir():
            raise InputError(explain(f"atlas {self.path!r}", expected="an atlas file (SQLite)", got="a directory"))
        self.created = False             # this Atlas made the file: a run that fails removes it
        if readonly:
            self._open_readonly()
            return
        self.created = self.path != ":memory:" and not os.path.lexists(self.path)
        try:
            self.con = sqlite3.connect(self.path, timeout=60, isolation_level=None)
            self.con.text_factory = sr.decoded_text
            self.con.execute("PRAGMA journal_mode=WAL" if self.path != ":memory:" else "PRAGMA journal_mode=MEMORY")
            self.con.execute("PRAGMA synchronous=NORMAL")
            self.con.executescript(_SCHEMA)
            self.con.execute("PRAGMA user_version = 1")
            self.con.commit()
        except sqlite3.DatabaseError as exc:   # not a database, unreadable, read-only place, a full disk
            self._remove_created()
            raise InputError(explain(f"atlas {self.path!r}", expected="an atlas file (SQLite) or a new file name",
                                     got=str(exc), hint="give another file name")) from None

    def _open_readonly(self) -> None:
        """Open an existing atlas for reading only: no journal, no lock file, nothing
        written (SQLite's ``immutable`` URI; the file must not change while open)."""
        p = Path(self.path)
        if not p.is_file():
            raise InputError(explain("atlas", expected="an existing atlas file (SQLite)", got=f"{self.path!r}: no such file"))
        try:
            self.con = sqlite3.connect(f"{p.resolve().as_uri()}?mode=ro&immutable=1", uri=True,
                                       check_same_thread=False)
            self.con.text_factory = sr.decoded_text
            self.con.execute("SELECT count(*) FROM chains").fetchone()
        except sqlite3.DatabaseError as exc:
            raise InputError(explain("atlas", expected="an atlas file (SQLite) with a chains table",
                                     got=f"{self.path!r}: {exc}")) from None

    def close(self) -> None:
        self.con.close()

    def _remove_created(self) -> None:
        """Remove the file this Atlas created, with SQLite's journal files (a failed run
        leaves nothing behind; a file that was there before is kept)."""
        if getattr(self, "con", None) is not None:
            self.con.close()
        if self.created:
            for suffix in ("", "-wal", "-shm", "-journal"):
                with contextlib.suppress(FileNotFoundError):
                    os.remove(self.path + suffix)

    def __enter__(self) -> "Atlas":
        return self

    def __exit__(self, kind, exc, tb) -> None:
        """Close; when a run fails (but for an interrupt) the file it created is removed.  A
        read or write that failed on the file's contents (SQLite's ``DatabaseError``: a
        malformed page, a table of another schema, rows that collide because a table is
        missing; JSON that does not parse; text that is not UTF-8) names the atlas (the readers of :mod:`.stored_rows` name the table and
        the row as well)."""
        self.close()
        if exc is not None and not isinstance(exc, KeyboardInterrupt):     # (an interrupted build resumes)
            self._remove_created()
        if isinstance(exc, (sqlite3.DatabaseError, json.JSONDecodeError, UnicodeError)):
            raise InputError(explain(f"atlas {self.path!r}", expected="an intact atlas",
                                     got=f"{type(exc).__name__}: {exc}", hint=sr.REBUILD)) from None

    @contextlib.contextmanager
    def _tx(self):
        """One write transaction; a full disk is an :class:`OutputError` naming the file
        (the rollback that follows it must not hide it)."""
        try:
            self.con.execute("BEGIN IMMEDIATE")
            yield self.con
            self.con.execute("COMMIT")
        except sqlite3.OperationalError as exc:
            self._rollback()
            if "full" in str(exc):     # SQLITE_FULL: "database or disk is full"
                raise OutputError(explain(f"atlas {self.path!r}", expected="room to store the atlas",
                                          got="disk full", hint="free some space and run again: the "
                                          "build resumes from the tasks already stored")) from None
            raise
        except BaseException:
            self._rollback()
            raise

    def _rollback(self) -> None:
        try:
            self.con.execute("ROLLBACK")
        except sqlite3.Error:   # SQLite already rolled back (a full disk does)
            pass

    # ------------------------------------------------------------------ build
    def _build_id(self, opts: SynthesisOptions, loops: bool, count: bool = False) -> int:
        key = _count_key(opts) if count else opts.key()
        cur = self.con.execute("SELECT id FROM builds WHERE options = ?", (key,))
        row = cur.fetchone()
        if row:
            return row[0]
        tasks = count_tasks(opts) if count else plan_tasks(opts)
        with self._tx() as con:
            bid = con.execute("INSERT INTO builds (options, n, F, loops) VALUES (?, ?, ?, ?)",
                              (key, opts.n, opts.F, int(loops))).lastrowid
            con.executemany("INSERT INTO tasks (build_id, key, m, res, mod) VALUES (?, ?, ?, ?, ?)",
                            [(bid, t.key, t.m, t.res, t.mod) for t in tasks])
        return bid

    def pending_tasks(self, opts: SynthesisOptions, loops: bool = True, count: bool = False):
        """The build's id and its tasks not yet stored (of a count with ``count``)."""
        bid = self._build_id(opts, loops, count)
        keys = {r[0] for r in self.con.execute(
            "SELECT key FROM tasks WHERE build_id = ? AND status = 'pending'", (bid,))}
        return bid, [t for t in (count_tasks(opts) if count else plan_tasks(opts)) if t.key in keys]

    def _task_done(self, con, bid: int, task, found: int, seconds: float) -> None:
        con.execute("UPDATE tasks SET status = 'done', n_chains = ?, seconds = ? "
                    "WHERE build_id = ? AND key = ?", (found, seconds, bid, task.key))
        con.execute("UPDATE builds SET seconds = seconds + ? WHERE id = ?", (seconds, bid))

    def store_task(self, bid: int, task, records: Sequence[ChainRecord], seconds: float = 0.0) -> None:
        """Insert one task's chains and mark it done, in one transaction."""
        rows = [_row(r) for r in records]
        with self._tx() as con:
            con.executemany(
                "INSERT OR IGNORE INTO chains (canonical, n, F, p, K, V, n_joints, j_max, i_max, LA,"
                " MJA, code, code_star, planar, fractionated, loops, L0, joints)"
                " VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)", rows)
            self._task_done(con, bid, task, len(records), seconds)

    def store_tally(self, bid: int, task, counts, seconds: float = 0.0) -> None:
        """Insert one task's row counts (``{(LA, MJA): chains}``) and mark it done, in one
        transaction."""
        rows = [(bid, task.key, json.dumps(list(la)), json.dumps(list(mja)), c)
                for (la, mja), c in sorted(counts.items())]
        with self._tx() as con:
            con.executemany("INSERT OR REPLACE INTO tallies (build_id, task, LA, MJA, chains)"
                            " VALUES (?, ?, ?, ?, ?)", rows)
            self._task_done(con, bid, task, sum(counts.values()), seconds)

    def build(self, opts: SynthesisOptions, loops: bool = True, workers: int | None = 1,
              scheduler=None, progress: bool = True, max_tasks: int | None = None) -> BuildResult:
        """Build (or resume) the atlas of ``opts``; returns the exact count.

        Parameters
        ----------
        opts : SynthesisOptions
        loops : bool
            Compute planarity and loop assortments (``--no-loops`` skips them unless
            ``opts.planar``).
        workers : int or None
            Local processes (None: all cores).
        scheduler : str or distributed.Client, optional
            Dask scheduler address.
        progress : bool
            A rich progress bar on stderr.
        max_tasks : int, optional
            Stop after this many tasks (used to test resuming).
        """
        from .distributed import map_tasks

        def run(pending):
            return map_tasks(pending, opts, loops, workers=workers, scheduler=scheduler)
        return self._run_build(opts, loops, False, run, self.store_task, progress, max_tasks)

    def count_table(self, opts: SynthesisOptions, workers: int | None = 1, scheduler=None,
                    progress: bool = True, max_tasks: int | None = None) -> BuildResult:
        """Count (or resume counting) the chains of ``opts`` by row of the number-synthesis
        table without storing them (:mod:`.synthesis.counting`); the parameters as
        :meth:`build`.  The result's ``count`` is the total so far."""
        from .distributed import map_count_tasks

        def run(pending):
            return map_count_tasks(pending, opts, workers=workers, scheduler=scheduler)
        return self._run_build(opts, False, True, run, self.store_tally, progress, max_tasks)

    def _run_build(self, opts, loops, count, run, store, progress, max_tasks) -> BuildResult:
        t0 = time.perf_counter()
        bid, pending = self.pending_tasks(opts, loops, count)
        total = self.con.execute("SELECT count(*) FROM tasks WHERE build_id = ?", (bid,)).fetchone()[0]
        done = total - len(pending)
        if max_tasks is not None:
            pending = pending[:max_tasks]
        bar = _progress(progress)
        with bar:
            tid = bar.add_task(f"n={opts.n} F={opts.F}", total=total, completed=done)
            started = time.perf_counter()
            for task, found in run(pending):
                now = time.perf_counter()
                store(bid, task, found, now - started)
                started = now
                bar.advance(tid)
        left = self.con.execute("SELECT count(*) FROM tasks WHERE build_id = ? AND status = 'pending'",
                                (bid,)).fetchone()[0]
        found = sum(self.table_counts(opts).values()) if count else self.count(opts)
        if left == 0:
            with self._tx() as con:
                con.execute("UPDATE builds SET status = 'done', count = ? WHERE id = ?", (found, bid))
        return BuildResult(opts, found, total - done - left, total, time.perf_counter() - t0)

    def table_counts(self, opts: SynthesisOptions):
        """The chains counted so far by :meth:`count_table`, by row: ``{(LA, MJA): chains}``."""
        from collections import Counter

        out: Counter = Counter()
        cur = self.con.execute("SELECT t.LA, t.MJA, sum(t.chains) FROM tallies t JOIN builds b"
                               " ON b.id = t.build_id WHERE b.options = ? GROUP BY t.LA, t.MJA",
                               (_count_key(opts),))
        for la, mja, c in cur:
            out[(tuple(json.loads(la)), tuple(json.loads(mja)))] = c
        return out

    def is_counted(self, opts: SynthesisOptions) -> bool:
        """True when :meth:`count_table` of ``opts`` has run every task."""
        row = self.con.execute("SELECT status FROM builds WHERE options = ?", (_count_key(opts),)).fetchone()
        return bool(row) and row[0] == "done"

    def is_complete(self, opts: SynthesisOptions) -> bool:
        row = self.con.execute("SELECT status FROM builds WHERE options = ?", (opts.key(),)).fetchone()
        return bool(row) and row[0] == "done"

    # ------------------------------------------------------------------ queries
    def _where(self, opts: SynthesisOptions | None, query: str | None) -> tuple[str, list]:
        clauses, params = [], []
        if opts is not None:
            clauses += ["n = ?", "F = ?"]
            params += [opts.n, opts.F]
            if opts.simple_joints:
                clauses.append("V = 0")
            if opts.max_multiplicity is not None:
                clauses.append("j_max <= ?")
                params.append(opts.max_multiplicity)
            if opts.max_link_degree is not None:
                clauses.append("i_max <= ?")
                params.append(opts.max_link_degree)
            if opts.planar:
                clauses.append("planar = 1")
            if opts.no_fractionated:
                clauses.append("fractionated = 0")
            for column, counts in (("LA", opts.la), ("MJA", opts.mja)):
                if counts is not None:
                    clauses.append(f"{column} = ?")
                    params.append(json.dumps(list(_stripped(counts))))
        if query:
            sql, qp = parse_query(query)
            clauses.append(f"({sql})")
            params += qp
        return (" AND ".join(clauses) or "1"), params

    def count(self, opts: SynthesisOptions | None = None, query: str | None = None) -> int:
        where, params = self._where(opts, query)
        return self.con.execute(f"SELECT count(*) FROM chains WHERE {where}", params).fetchone()[0]

    def chains(self, opts: SynthesisOptions | None = None, query: str | None = None,
               limit: int | None = None) -> Iterator[ChainRecord]:
        """Stored chains (ordered by n, F, V, LA, canonical)."""
        where, params = self._where(opts, query)
        sql = (f"SELECT id, n, F, K, V, j_max, LA, MJA, code, code_star, planar, fractionated, loops, L0,"
               f" joints, canonical FROM chains WHERE {where} ORDER BY n, F, V, LA, canonical")
        if limit is not None:
            sql += " LIMIT ?"
            params = params + [int(limit)]
        for row in self.con.execute(sql, params):
            yield self._chain(row)

    def _chain(self, row) -> ChainRecord:
        """A stored chain row (``id`` first) as a record, every value checked (:mod:`.stored_rows`)."""
        rid, n, F, K, V, jmax, LA, MJA, code, code_star, planar, frac, La, L0, joints, canon = row
        at = (self.path, "chains", rid)
        n = sr.integer(*at, "n", n, 1, 10_000)
        return ChainRecord(n=n, F=sr.integer(*at, "F", F, -10_000, 10_000),
                           joints=tuple(tuple(j) for j in sr.int_lists(*at, "joints", joints, below=n)),
                           canonical=sr.text(*at, "canonical", canon), LA=tuple(sr.int_list(*at, "LA", LA)),
                           MJA=tuple(sr.int_list(*at, "MJA", MJA)), V=sr.integer(*at, "V", V),
                           K=sr.integer(*at, "K", K), j_max=sr.integer(*at, "j_max", jmax),
                           code=sr.text(*at, "code", code), code_star=sr.text(*at, "code_star", code_star),
                           fractionated=bool(frac), planar=None if planar is None else bool(planar),
                           La=None if La is None else tuple(sr.int_list(*at, "loops", La)), L0=L0)

    def sizes(self) -> list[tuple[int, int]]:
        """The (n, F) pairs the atlas holds chains of, sorted."""
        return sorted((int(r[0]), int(r[1])) for r in self.con.execute("SELECT DISTINCT n, F FROM chains"))

    def domain_cells(self, pairs=None) -> dict[int, set[tuple[int, int]]]:
        """The occupied cells of the existence domain: ``{K: {(V, j_max), …}}`` over the
        chains of every (n, F) in ``pairs`` (default: all)."""
        sql, params = "SELECT DISTINCT K, V, j_max FROM chains", []
        if pairs:
            sql += " WHERE " + " OR ".join("(n = ? AND F = ?)" for _ in pairs)
            params = [int(x) for pr in pairs for x in pr]
        cells: dict[int, set] = {}
        for K, V, j in self.con.execute(sql, params):
            cells.setdefault(int(K), set()).add((int(V), int(j)))
        return cells

    def signatures(self, n: int, F: int) -> list[tuple[str, str, str | None, list]]:
        """(LA, MJA, La as stored JSON text, joints) of every chain of (n, F): the paper's
        invariants, compared as text."""
        rows = self.con.execute("SELECT id, LA, MJA, loops, joints FROM chains WHERE n = ? AND F = ?", (n, F))
        return [(LA, MJA, La, sr.int_lists(self.path, "chains", rid, "joints", joints, below=n))
                for rid, LA, MJA, La, joints in rows]

    def sizes_with_loops(self, at_least: int = 4) -> list[tuple[int, int]]:
        """The (n, F) pairs with at least ``at_least`` chains whose loops are known (stored,
        or non-planar chains, which have none)."""
        return sorted((int(r[0]), int(r[1])) for r in self.con.execute(
            "SELECT n, F FROM chains WHERE loops IS NOT NULL OR planar = 0 GROUP BY n, F HAVING count(*) >= ?",
            (at_least,)))

    def builds(self) -> list[dict]:
        cur = self.con.execute("SELECT options, n, F, status, count, seconds FROM builds ORDER BY n, F")
        return [dict(zip(("options", "n", "F", "status", "count", "seconds"), r)) for r in cur]

    def duplicates(self) -> int:
        """Rows sharing a canonical form (0 by the UNIQUE constraint; a test hook)."""
        return self.con.execute("SELECT count(*) - count(DISTINCT canonical) FROM chains").fetchone()[0]


def _count_key(opts: SynthesisOptions) -> str:
    """The options key of a count: ``count;<generator signature>;<options>``."""
    return f"{_COUNT}{count_signature(opts)};{opts.key()}"


def _stripped(counts: tuple[int, ...]) -> tuple[int, ...]:
    """An assortment as stored: without trailing zeros."""
    end = len(counts)
    while end and not counts[end - 1]:
        end -= 1
    return counts[:end]


def _row(r: ChainRecord) -> tuple:
    p = sum(len(j) - 1 for j in r.joints)
    i_max = len(r.LA) + 1        # [LA] runs n2 … n_imax (every atlas link is on >= 2 joints)
    return (r.canonical, r.n, r.F, p, r.K, r.V, len(r.joints), r.j_max, i_max,
            json.dumps(list(r.LA)), json.dumps(list(r.MJA)), r.code, r.code_star,
            None if r.planar is None else int(r.planar), int(r.fractionated),
            None if r.La is None else json.dumps(list(r.La)), r.L0,
            json.dumps([list(j) for j in r.joints]))


class _NoBar:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def add_task(self, *a, **k):
        return 0

    def advance(self, *a, **k):
        pass


def _progress(enabled: bool):
    if not enabled:
        return _NoBar()
    from rich.console import Console
    from rich.progress import (
        BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn,
    )

    return Progress(TextColumn("[bold]atlas {task.description}"), BarColumn(), MofNCompleteColumn(),
                    TextColumn("tasks"), TimeElapsedColumn(), TextColumn("left"), TimeRemainingColumn(),
                    console=Console(stderr=True), transient=not sys.stderr.isatty())


def each_with_progress(items: Sequence, label: str, progress: bool, work) -> None:
    """Call ``work(item)`` for each item with a progress bar on stderr (when ``progress``)."""
    bar = _progress(progress)
    with bar:
        tid = bar.add_task(label, total=len(items))
        for item in items:
            work(item)
            bar.advance(tid)


def build_atlas(opts: SynthesisOptions, db: str | Path = "atlas.sqlite", **kwargs) -> BuildResult:
    """Open ``db``, build (or resume) the atlas of ``opts``, close it."""
    with Atlas(db) as atlas:
        return atlas.build(opts, **kwargs)
