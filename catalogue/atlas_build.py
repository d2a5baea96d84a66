"""The request of ``multiloop atlas`` checked, and its build sequence: chains, then the
mechanisms (inversions) and their coupler curves.

:func:`atlas_request` checks every option before the atlas file is opened (a rejected
run creates no file) and returns the :class:`~.synthesis.SynthesisOptions` of the
chains to build; :func:`build_atlas` runs the builds the options ask for.
"""
from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from multiloop.topo.errors import ParameterError, explain

from .atlas import Atlas, BuildResult, parse_query
from .synthesis import SynthesisOptions

__all__ = ["INT_RANGES", "STORED_UP_TO", "atlas_request", "build_atlas", "counts_only", "parse_assortment"]

#: with ``table``, chains of more links are counted by row, not stored (14 links:
#: tens of millions of chains)
STORED_UP_TO = 12

#: the integer options by their names in the request, and their ranges (SQLite and C
#: ints stop at 2**63 and 2**31)
INT_RANGES = {"dof": (1, 2 ** 31 - 1), "max_multiplicity": (1, 2 ** 31 - 1), "max_link_degree": (2, 2 ** 31 - 1),
              "workers": (1, 1024), "limit": (0, 2 ** 63 - 1), "curves": (1, 10 ** 6),
              "points_per_link": (1, 256), "html_limit": (1, 2 ** 63 - 1)}


def _check_options(req: Mapping) -> None:
    """Every integer option within its range, the query well formed."""
    for key, (lo, hi) in INT_RANGES.items():
        value = req.get(key)
        if value is not None and not lo <= value <= hi:
            got = str(value) if abs(value) < 10 ** 30 else f"a {len(str(abs(value)))}-digit number"
            raise ParameterError(explain(key, expected=f"an integer from {lo} to {hi}", got=got), key)
    if req["query"] is not None:
        parse_query(req["query"])
    if req["table"] and req["links"] is None:
        raise ParameterError(explain("table", expected="'links' N and 'dof' F", got="no 'links'"),
                             "table", "links", "dof")
    if req["curves"] is not None and not (req["mechanisms"] and req["links"] is not None and req["dof"] == 1):
        raise ParameterError(explain("curves", expected="'links' N, 'dof' 1 and 'mechanisms'",
                                     got="'curves' without them", hint="the curves belong to the stored mechanisms"),
                             "curves", "links", "dof", "mechanisms")
    if req.get("points_per_link") is not None and req["curves"] is None:
        raise ParameterError(explain("points_per_link", expected="'curves' K too", got="'points_per_link' alone",
                                     hint="it is the number of traced points per moving link of each realisation"),
                             "points_per_link", "curves")


def parse_assortment(text: str | None, name: str) -> tuple[int, ...] | None:
    """``"8-1-1"`` (or ``"8,1,1"``, ``"[8, 1, 1]"``) as counts; None for None; ``name``
    is the parameter it was given as (``la``, ``mja``)."""
    if text is None:
        return None
    body = text.strip().strip("[]").replace(",", "-").replace(" ", "")
    words = body.split("-") if body else []
    if len(text) > 200 or not all(w.isdigit() and len(w) <= 3 for w in words):
        raise ParameterError(explain(name, expected="counts joined by '-' (e.g. 8-1-1; 0 for none)",
                                     got=repr(text[:40])), name)
    return tuple(int(w) for w in words)


def counts_only(opts: SynthesisOptions | None, table: bool) -> bool:
    """True when the request is counted by row without storing chains: ``table`` beyond
    :data:`STORED_UP_TO` links."""
    return opts is not None and table and opts.n > STORED_UP_TO


def atlas_request(req: Mapping) -> SynthesisOptions | None:
    """Check the options of ``multiloop atlas`` (``req``: its values by name, ``links``,
    ``dof``, ``db``, ``query``, ``scheduler``, …) before any file is created; returns the
    chains to build (None without ``links``: a query of an existing atlas).

    Raises
    ------
    InputError
        An option out of range, a malformed query, ``table`` or ``curves`` without
        what they need, a missing atlas, no Dask or an unreachable scheduler.
    """
    _check_options(req)
    db, scheduler = req["db"], req["scheduler"]
    if req["links"] is None and not Path(db).exists():
        raise ParameterError(explain("db", expected="an existing atlas file (or 'links' N to build one)",
                                     got=repr(db)), "db", "links")
    if scheduler is not None:
        from .distributed import require_dask
        require_dask()
    if req["links"] is None:
        return None
    opts = SynthesisOptions(req["links"], req["dof"], simple_joints=req["simple_joints"],
                            max_multiplicity=req["max_multiplicity"],
                            max_link_degree=req["max_link_degree"], planar=req["planar"],
                            no_fractionated=req["no_fractionated"],
                            la=parse_assortment(req.get("la"), "la"), mja=parse_assortment(req.get("mja"), "mja"))
    if counts_only(opts, req["table"]) and (opts.planar or opts.no_fractionated):
        raise ParameterError(explain("table", expected=f"no 'planar' or 'no_fractionated' beyond {STORED_UP_TO} links",
                                     got=f"{opts.n} links with a per-chain filter",
                                     hint="the rows are counted inside the generator, chain records are not built"),
                             "table", "planar", "no_fractionated")
    if scheduler is not None and not Path(db).exists():
        from .distributed import connect_scheduler   # fail before a file is created
        connect_scheduler(scheduler).close()
    return opts


def build_atlas(atlas: Atlas, opts: SynthesisOptions | None, *, loops: bool | None = None,
                workers: int | None = None, scheduler=None, progress: bool = True,
                mechanisms: bool = False, curves: int | None = None, table: bool = False,
                points_per_link: int | None = None):
    """Build the chains of ``opts`` (``loops``: None for [La] up to 10 links; with
    ``table`` beyond :data:`STORED_UP_TO` links count them by row instead), with
    ``mechanisms`` the inversions of a 1-DOF atlas and with ``curves`` that many
    realisations of each closed-form mechanism, each traced at ``points_per_link`` points
    of every moving link other than the driven one (default
    :data:`~.curve_atlas.POINTS_PER_LINK`); returns ``(built, inversions, curves)``,
    None for each build not asked for (:class:`BuildResult`,
    :class:`~.inversions.MechanismCounts`, :class:`~.curve_atlas.CurveBuild`)."""
    built: BuildResult | None = None
    inv = made = None
    if counts_only(opts, table):
        return atlas.count_table(opts, workers=workers, scheduler=scheduler, progress=progress), None, None
    if opts is not None:
        built = atlas.build(opts, loops=loops if loops is not None else opts.n <= 10, workers=workers,
                            scheduler=scheduler, progress=progress)
    if mechanisms and opts is not None and opts.F == 1:
        from .inversions import build_mechanisms
        inv = build_mechanisms(atlas, opts, progress=progress)
        if curves is not None:
            from .curve_atlas import POINTS_PER_LINK, build_curves
            from .distributed import default_workers
            made = build_curves(atlas, opts, curves, points_per_link or POINTS_PER_LINK, progress=progress,
                                workers=workers or default_workers(), scheduler=scheduler)
    return built, inv, made
