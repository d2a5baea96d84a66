"""What ``multiloop atlas`` reports about an atlas: the JSON document of a query and its
readable listing.

:func:`atlas_listing` gathers the count, the chains (:meth:`ChainRecord.as_dict`, with
the distinct frames and drivers of each when asked), the universal structural table
and the build statistics; :func:`listing_text` prints the same document.
"""
from __future__ import annotations

from .atlas import Atlas, BuildResult
from .synthesis import SynthesisOptions, record_choices, table_rows, universal_table

__all__ = ["atlas_listing", "listing_text"]

#: queries with at most this many chains list every chain in the text listing
LIST_ALL = 50


def atlas_listing(atlas: Atlas, opts: SynthesisOptions | None, query: str | None = None,
                  limit: int | None = None, table: bool = False, mechanisms: bool = False,
                  built: BuildResult | None = None, inversions=None, counted: bool = False) -> dict:
    """The JSON document of a query: ``count``, ``chains``, and with the options
    ``table`` (rows of :func:`universal_table`), ``mechanisms`` (frames and drivers per
    chain and their totals; with ``inversions``, a stored
    :class:`~.inversions.MechanismCounts`, also the counts by highest Assur class and
    of the mechanisms solved in closed form) and ``build`` (tasks and seconds of the build).
    ``counted``: the table and the count come from :meth:`Atlas.count_table` (no chains
    are stored; ``complete`` says whether every task has run)."""
    out: dict = {}
    if counted:
        counts = atlas.table_counts(opts)
        out["table"] = [r.as_dict() for r in table_rows(opts, counts)]
        out["count"] = sum(counts.values())
        out["complete"] = atlas.is_counted(opts)
    elif table:
        out["table"] = [r.as_dict() for r in universal_table(opts, atlas.chains(opts))]
    if not counted:
        out["count"] = atlas.count(opts, query)
    chains = [] if counted else list(atlas.chains(opts, query, limit=limit))
    items = [r.as_dict() for r in chains]
    if mechanisms:
        for d, c in zip(items, map(record_choices, chains)):
            d["frames"], d["drivers"] = c.n_frames, c.n_drivers
        out["mechanisms"] = {"frames": sum(d["frames"] for d in items),
                             "drivers": sum(d["drivers"] for d in items)}
        if inversions is not None:
            out["mechanisms"] = inversions.as_dict()
    out["chains"] = items
    if built is not None:
        out["build"] = {"tasks_run": built.tasks_run, "tasks_total": built.tasks_total,
                        "seconds": round(built.seconds, 3)}
    return out


def listing_text(doc: dict, opts: SynthesisOptions | None, query: str | None = None,
                 limit: int | None = None) -> str:
    """The readable listing of :func:`atlas_listing`'s document: the count, the build,
    then the table, or the chains (all of them for a query, a limit or a small count)."""
    head = f"n = {opts.n}, F = {opts.F}: " if opts is not None else ""
    lines = [f"{head}{doc['count']} chains" + (f" matching {query}" if query else "")]
    if "build" in doc:
        b = doc["build"]
        lines.append(f"  tasks run {b['tasks_run']}/{b['tasks_total']} in {b['seconds']:.2f} s")
    if "table" in doc:
        table = doc["table"]
        lines.append(f"{'Code*':<28}{'[LA]':<22}{'[MJA]':<14}{'V':>3}{'K':>3}{'chains':>8}")
        lines += [f"{r['code_star']:<28}{str(r['LA']):<22}{str(r['MJA']):<14}{r['V']:>3}{r['K']:>3}"
                  f"{r['chains']:>8}" for r in table]
        lines.append(f"{sum(1 for r in table if r['realisable'])} of {len(table)} assortments are realisable")
        return "\n".join(lines)
    if "mechanisms" in doc:
        mech = doc["mechanisms"]
        lines.append(f"  mechanisms: {mech['frames']} distinct frames, "
                     f"{mech['drivers']} distinct (frame, driver) choices")
        if "by_class" in mech:
            lines.append("  by highest Assur class: " + ", ".join(f"{c}: {k}" for c, k in mech["by_class"].items())
                         + f"; every group in closed form: {mech['closed_form']}")
    if limit is not None or query or doc["count"] <= LIST_ALL:
        for i, r in enumerate(doc["chains"], 1):
            extra = f"  frames {r['frames']} drivers {r['drivers']}" if "frames" in r else ""
            la = "-".join(map(str, r["La"])) if r["La"] else ("non-planar" if r["planar"] is False else "")
            lines.append(f"{i:>5} {r['code_star']:<26} V={r['V']} K={r['K']} La={la:<16}{extra} "
                         f"joints={r['joints']}")
    return "\n".join(lines)
