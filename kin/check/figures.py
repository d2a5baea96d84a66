"""Figures and the one-page HTML report of a design check (matplotlib, Agg).

* :func:`mechanism_axes` — the mechanism at the reference with the coupler curves
  (tracer-point paths, dashed) and joint paths over the first driver's reachable motion;
* :func:`transmission_axes` — every monitored angle and the mechanical advantage
  against the first driver, with the threshold, the limits (red) and the dead
  centres (grey) marked;
* :func:`instant_centre_axes` — the mechanism at the instant-centre position with
  every finite centre (pins black, the others blue, labelled ``a|b``);
* :func:`report_figures`, :func:`overview_figure`, :func:`html_page`.
"""
from __future__ import annotations

import html
import warnings

import matplotlib
import matplotlib.ticker

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from multiloop.kin.figures.labels import place_labels  # noqa: E402
from multiloop.kin.figures.mechanism import plot_mechanism  # noqa: E402
from multiloop.kin.figures.style import no_mathtext  # noqa: E402
from multiloop.kin.motion import DriverMotion  # noqa: E402
from multiloop.kin.solve import solve  # noqa: E402

from .verdict import fmt_input  # noqa: E402

__all__ = ["mechanism_axes", "transmission_axes", "instant_centre_axes", "workspace_axes", "report_figures",
           "overview_figure", "html_page"]


def _solve(m, x, k=0, at=None, derivatives=False):
    X = DriverMotion.held(m, k).inputs(x, at)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return solve(m, X, derivatives=derivatives)


def _xplot(dc, x):
    return np.degrees(x) if dc.rotary else x


def mechanism_axes(ax, m, rep):
    dc = rep.drivers[0]
    x = dc.ratio_x
    st = _solve(m, x)
    ref = int(np.argmin(np.abs(x)))
    plot_mechanism(st, ref, ax=ax, title=f"{rep.mechanism}: reference and coupler curves")


def transmission_axes(ax, ax2, m, rep):
    dc = rep.drivers[0]
    x = _xplot(dc, dc.ratio_x)
    unit = "deg" if dc.rotary else "m"
    # angles sampled along the motion (the exact extremes are in the report)
    from multiloop.topo.assur import decompose

    from .angle_types import angle_type
    from .transmission import angle_specs, angle_values
    specs = angle_specs(decompose(m))
    st = _solve(m, dc.ratio_x)
    V = angle_values(st, specs)
    for c, sp in enumerate(specs):
        ax.plot(x, V[:, c], lw=1.4, label=f"{sp.quantity} at {sp.joint}")
    thr = rep.min_transmission
    lines = [thr]                  # the threshold, then each type's own lines
    for sp in specs:
        lines += [y for y in angle_type(sp.quantity).plot_lines(thr) if y not in lines]
    for y in lines:
        ax.axhline(y, color="r", lw=0.8, ls=":")
    ax.set_ylabel("angle (deg)")
    ma = np.abs(1.0 / np.where(dc.ratio == 0, np.nan, dc.ratio))
    ax2.semilogy(x, np.clip(ma, 1e-3, 1e4), color="k", lw=1.2,
                 label=f"|MA| {dc.joint}→{dc.output} (1/({dc.output_unit}))")
    ax2.set_ylabel("|mechanical advantage|")
    ax2.yaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}"))
    ax2.yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax2.set_xlabel(f"input {dc.joint} ({unit}, from the reference)")
    for a in (ax, ax2):
        for lim in dc.limits:
            a.axvline(_xplot(dc, lim), color="r", lw=1.2)
        for _, xs in dc.dead_centres:
            for d in xs:
                v = _xplot(dc, d)
                if dc.rotary and dc.full_rotation:
                    v = v % 360.0
                a.axvline(v, color="0.5", lw=0.8, ls="--")
        a.grid(True, lw=0.3)
        a.legend(fontsize=7, loc="best")
    ax.set_title("transmission / pressure angles and MA (red: limits, grey: dead centres)", fontsize=9)


def instant_centre_axes(ax, m, rep):
    at = np.array(rep.instant_centres_at)
    st = _solve(m, [at[0]], at=at)
    plot_mechanism(st, 0, ax=ax, title=f"instant centres at {[round(float(v), 4) for v in at]}")
    pins = {frozenset(j.links[i:i + 2]) for j in m.joints if j.kind.value == "R" for i in range(len(j.links) - 1)}
    pins |= {frozenset(p) for j in m.joints if j.kind.value == "R"
             for p in [(a, b) for a in j.links for b in j.links if a != b]}
    P = st.positions[0]
    if st.point_positions is not None:
        P = np.concatenate([P, st.point_positions[0]])
    size = float(np.ptp(P, axis=0).max())
    c0 = P.mean(axis=0)
    labelled = []
    for c in rep.instant_centres:
        if c.point is None or np.max(np.abs(np.array(c.point) - c0)) > 2.5 * size:
            continue
        primary = frozenset((c.a, c.b)) in pins
        ax.plot(*c.point, "o" if primary else "D", ms=4, color="k" if primary else "tab:blue")
        if not primary:
            labelled.append(c)
    pts = np.array([c.point for c in rep.instant_centres if c.point is not None
                    and np.max(np.abs(np.array(c.point) - c0)) <= 2.5 * size] + list(P))
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = 0.08 * float(max(hi - lo)) + 1e-9
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    if labelled:                          # placed apart (centres at one pivot overlap otherwise)
        texts = [f"{c.a}|{c.b}" for c in labelled]
        offsets = place_labels(ax, np.array([c.point for c in labelled], float), texts,
                               [3.0] * len(texts), fontsize=6)
        for c, t, off in zip(labelled, texts, offsets):
            ax.annotate(t, c.point, fontsize=6, color="tab:blue", textcoords="offset points",
                        xytext=off, ha="center", va="center")


def workspace_axes(ax, m, rep):
    """The workspace envelope (boundary polygon), its extremes and the mechanism at the
    reference."""
    ws = rep.workspace
    plot_mechanism(_solve(m, [0.0]), 0, ax=ax, title=f"{rep.mechanism}: workspace of {ws.point}")
    b = np.asarray(ws.boundary)
    if len(b):
        ax.fill(b[:, 0], b[:, 1], color="tab:green", alpha=0.15, lw=0)
        ax.plot(b[:, 0], b[:, 1], color="tab:green", lw=1.2, label=f"envelope ({ws.area:.4g} m²)")
    ax.axvline(ws.x[0], color="grey", lw=0.6, ls=":")
    ax.axvline(ws.x[1], color="grey", lw=0.6, ls=":")
    ax.axhline(ws.y[0], color="grey", lw=0.6, ls=":")
    ax.axhline(ws.y[1], color="grey", lw=0.6, ls=":")
    ax.legend(loc="best", fontsize=7)
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    x0, x1 = min(x0, ws.x[0]), max(x1, ws.x[1])
    y0, y1 = min(y0, ws.y[0]), max(y1, ws.y[1])
    pad = 0.05 * max(x1 - x0, y1 - y0)
    ax.set_xlim(x0 - pad, x1 + pad)
    ax.set_ylim(y0 - pad, y1 + pad)


def report_figures(m, rep) -> dict:
    """``{file name: figure}`` of the HTML report."""
    f1, a1 = plt.subplots(figsize=(7, 6), dpi=100)
    mechanism_axes(a1, m, rep)
    f2, (a2, a3) = plt.subplots(2, 1, figsize=(8, 6.5), dpi=100, sharex=True)
    transmission_axes(a2, a3, m, rep)
    f3, a4 = plt.subplots(figsize=(7, 6), dpi=100)
    instant_centre_axes(a4, m, rep)
    for f in (f1, f2, f3):
        f.tight_layout()
        no_mathtext(f)
    out = {"mechanism.png": f1, "transmission.png": f2, "instant_centres.png": f3}
    if rep.workspace is not None:
        f4, a5 = plt.subplots(figsize=(7, 6), dpi=100)
        workspace_axes(a5, m, rep)
        f4.tight_layout()
        out["workspace.png"] = no_mathtext(f4)
    return out


def overview_figure(m, rep):
    """The three figures on one canvas (``--plot``), and the workspace as a fourth."""
    ws = rep.workspace is not None
    fig = plt.figure(figsize=(21 if ws else 16, 6.5), dpi=100)
    gs = fig.add_gridspec(2, 4 if ws else 3)
    mechanism_axes(fig.add_subplot(gs[:, 0]), m, rep)
    a2 = fig.add_subplot(gs[0, 1])
    transmission_axes(a2, fig.add_subplot(gs[1, 1], sharex=a2), m, rep)
    instant_centre_axes(fig.add_subplot(gs[:, 2]), m, rep)
    if ws:
        workspace_axes(fig.add_subplot(gs[:, 3]), m, rep)
    fig.tight_layout()
    return no_mathtext(fig)


def html_page(rep, images) -> str:
    """One self-contained page: verdict, per-driver tables, circuits, loops, figures."""
    e = html.escape
    rows = []
    for dc in rep.drivers:
        rng = "full rotation" if dc.full_rotation else (
            "stops at " + ", ".join(fmt_input(dc, x) for x in dc.limits) if dc.limits else "no limit found")
        rows.append(f"<h2>driver {e(dc.joint)}</h2><p>range of motion: {e(rng)}</p><table>"
                    "<tr><th>angle</th><th>min</th><th>where</th><th>max</th><th>where</th></tr>")
        for a in dc.angles:
            if a.extreme is None:
                continue
            x = a.extreme
            flag = ' class="bad"' if a.flagged(rep.min_transmission) else ""
            rows.append(f"<tr{flag}><td>{e(a.quantity)} at {e(a.joint)}</td><td>{x.min:.3f}°</td>"
                        f"<td>{e(fmt_input(dc, x.at_min))}</td><td>{x.max:.3f}°</td>"
                        f"<td>{e(fmt_input(dc, x.at_max))}</td></tr>")
        rows.append("</table><ul>")
        for lk, xs in dc.dead_centres:
            rows.append(f"<li>dead centres of {e(lk)}: {e(', '.join(fmt_input(dc, v) for v in xs) or 'none')}</li>")
        rows.append("</ul>")
    circ = "".join(f"<li>{e(c.group)}: {c.modes} modes, {c.reachable} reachable ({e(c.note)})</li>"
                   for c in rep.circuits)
    loops = "".join(f"<li>{e('-'.join(g.links))}: {e(g.cls)} (fixed {e(g.fixed)})</li>" for g in rep.grashof)
    verdict = "".join(f"<li>{e(v)}</li>" for v in rep.verdict) or "<li>no problem found</li>"
    imgs = "".join(f'<p><img src="{e(i)}" alt="{e(i)}"></p>' for i in images)
    return ("<!DOCTYPE html><html><head><meta charset='utf-8'>"
            f"<title>check: {e(rep.mechanism)}</title><style>body{{font-family:sans-serif;max-width:60em;"
            "margin:auto}}td,th{{padding:2px 8px}}.bad{{color:#b00}}img{{max-width:100%}}</style></head><body>"
            f"<h1>Design check: {e(rep.mechanism)}</h1><p>{e(rep.formula)}</p>"
            f"<h2>verdict</h2><ul>{verdict}</ul>{''.join(rows)}<h2>assembly modes</h2><ul>{circ}</ul>"
            f"<h2>four-bar loops</h2><ul>{loops or '<li>none</li>'}</ul>{imgs}</body></html>\n")
