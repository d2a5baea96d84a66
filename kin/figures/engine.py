"""Figures of the engine analysis (Vasilenko et al. 2018 diagrams) and of kinetostatics (PNG, Agg).

:func:`engine_plots` writes, into a directory:

* ``kinematics.png`` — piston displacement, velocity, acceleration over 720° (exact,
  with the λ-approximation of the acceleration dashed);
* ``pressure.png`` — cylinder pressure against the crank angle, the p–V diagram, the
  gas force on each piston;
* ``balancing.png`` — balancing moment M_b and its mean (= −W_ind / 4π);
* ``cyclogram.png`` — the four-stroke cyclogram of every cylinder;
* ``rod_com.png`` — con-rod centre-of-mass path and the radius of curvature;
* ``reactions.png`` — crank-pin, main-bearing and wall reactions.

:func:`plot_forces` draws the balancing force/moment and the reaction magnitudes of a
:class:`~kin.forces.ForceResult` against the input.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .style import escape_math, no_mathtext

__all__ = ["engine_figures", "engine_plots", "plot_forces"]

_STROKE_COLOURS = {"intake": "#9ecae1", "compression": "#fdd0a2", "power": "#fc9272", "exhaust": "#bdbdbd"}


def _plt():
    import matplotlib  # noqa: PLC0415
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415
    return plt


def _cyl(j: int) -> str:
    """The colour of cylinder ``j`` (and of its rod and piston) in every panel."""
    return f"C{j % 10}"


def _xaxis(ax):
    ax.set_xlim(0, 720)
    ax.set_xticks(np.arange(0, 721, 90))
    ax.grid(True, alpha=0.3)


def _save(fig, name):
    """Lay out a figure; returns ``(name, fig)``."""
    no_mathtext(fig)
    fig.tight_layout()
    return name, fig


def engine_plots(res, outdir) -> list[Path]:
    """Write the six PNG diagrams of an :class:`~kin.engine.EngineResult` (110 dpi); returns the paths."""
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, fig in engine_figures(res).items():
        fig.savefig(out / name, dpi=110)
        _plt().close(fig)
        paths.append(out / name)
    return paths


def engine_figures(res) -> dict:
    """The six diagrams of an :class:`~kin.engine.EngineResult`, ``{file name: Figure}``."""
    return dict(f(res) for f in (_kinematics, _pressure, _balancing, _cyclogram, _rod_com, _reactions))


def _kinematics(res):
    """``kinematics.png``."""
    plt, spec, phi = _plt(), res.spec, res.phi_deg
    names = [c.name for c in spec.cylinders]
    fig, axs = plt.subplots(3, 1, figsize=(9, 9), sharex=True)
    for j, nm in enumerate(names):
        axs[0].plot(phi, res.displacement[:, j] * 1e3, color=_cyl(j), label=f"cyl {nm}")
        axs[1].plot(phi, res.velocity[:, j], color=_cyl(j), label=f"cyl {nm}")
        axs[2].plot(phi, res.acceleration[:, j], color=_cyl(j), label=f"cyl {nm} exact")
        if spec.offset == 0.0:
            axs[2].plot(phi, res.approx["a"][:, j], "--", lw=0.8, color=_cyl(j), label=f"cyl {nm} λ-approx.")
    axs[0].set_ylabel("s from TDC (mm)")
    axs[1].set_ylabel("v (m/s)")
    axs[2].set_ylabel("a (m/s²)")
    axs[2].set_xlabel("crank angle φ (deg)")
    err = res.approx_error["a"]
    axs[0].set_title(f"{spec.name}: piston motion at {spec.rpm:g} rpm (λ-approx. error of a: "
                     f"{err['max_abs']:.3g} m/s², {100 * err['max_rel']:.2f} %)", fontsize=9)
    for ax in axs:
        _xaxis(ax)
        ax.legend(fontsize=7, loc="upper right")
    return _save(fig, "kinematics.png")


def _pressure(res):
    """``pressure.png``."""
    plt, spec, phi = _plt(), res.spec, res.phi_deg
    names = [c.name for c in spec.cylinders]
    fig, axs = plt.subplots(1, 3, figsize=(14, 4.2))
    for j, nm in enumerate(names):
        axs[0].plot(phi, res.pressure[:, j] / 1e6, color=_cyl(j), label=f"cyl {nm}")
        order = np.argsort(res.psi_deg[:, j])
        axs[1].plot(res.volume[order, j] * 1e6, res.pressure[order, j] / 1e6, color=_cyl(j), label=f"cyl {nm}")
        axs[2].plot(phi, res.gas_force[:, j] / 1e3, color=_cyl(j), label=f"cyl {nm}")
    axs[0].set_xlabel("crank angle φ (deg)")
    axs[0].set_ylabel("cylinder pressure (MPa, absolute)")
    _xaxis(axs[0])
    axs[1].set_xlabel("volume (cm³)")
    axs[1].set_ylabel("pressure (MPa)")
    axs[1].set_title(f"W_ind = {res.indicated_work.sum():.4g} J per cycle", fontsize=9)
    axs[1].grid(True, alpha=0.3)
    axs[2].set_xlabel("crank angle φ (deg)")
    axs[2].set_ylabel("gas force along the axis (kN)")
    _xaxis(axs[2])
    for ax in axs:
        ax.legend(fontsize=7)
    return _save(fig, "pressure.png")


def _balancing(res):
    """``balancing.png``."""
    plt, phi = _plt(), res.phi_deg
    fig, ax = plt.subplots(figsize=(9, 4))
    ax.plot(phi, res.balancing, label="M_b (on the crank, CCW +)")
    mean = res.cycle_integral / (4 * np.pi)
    ax.axhline(mean, color="k", lw=0.8, ls="--", label=f"mean {mean:.4g} N m = −W_ind/4π")
    ax.set_xlabel("crank angle φ (deg)")
    ax.set_ylabel("balancing moment (N m)")
    ax.set_title(f"∮M_b dφ = {res.cycle_integral:.6g} J, −W_ind = {-res.indicated_work.sum():.6g} J", fontsize=9)
    _xaxis(ax)
    ax.legend(fontsize=8)
    return _save(fig, "balancing.png")


def _cyclogram(res):
    """``cyclogram.png``."""
    plt, spec = _plt(), res.spec
    names = [c.name for c in spec.cylinders]
    fig, ax = plt.subplots(figsize=(9, 1.0 + 0.5 * len(names)))
    cyc = res.cyclogram
    for j, row in enumerate(cyc["cylinders"]):
        y = len(names) - 1 - j
        for name, a, b in row["strokes"]:
            segs = [(a, b - a)] if b > a else [(a, 720.0 - a), (0.0, b)]
            ax.broken_barh(segs, (y - 0.35, 0.7), facecolors=_STROKE_COLOURS[name], edgecolor="k", lw=0.5)
            mid = (a + ((b - a) % 720.0) / 2.0) % 720.0
            ax.text(mid, y, name, ha="center", va="center", fontsize=7)
        ax.plot([row["firing"]], [y], marker="*", color="red", ms=10)
    ax.set_yticks(range(len(names)))
    ax.set_yticklabels([escape_math(f"cyl {n}") for n in reversed(names)])
    for j, tick in enumerate(reversed(ax.get_yticklabels())):
        tick.set_color(_cyl(j))
    ax.set_xlabel("crank angle φ (deg); * firing")
    ax.set_title("four-stroke cyclogram; firing intervals " + "/".join(f"{x:g}" for x in cyc["firing_intervals"])
                 + " deg, order " + "-".join(cyc["firing_order"]), fontsize=9)
    _xaxis(ax)
    return _save(fig, "cyclogram.png")


def _rod_com(res):
    """``rod_com.png``."""
    plt, spec, phi = _plt(), res.spec, res.phi_deg
    names = [c.name for c in spec.cylinders]
    fig, axs = plt.subplots(1, 2, figsize=(12, 4.5))
    for j, nm in enumerate(names):
        axs[0].plot(res.rod_com[:, j, 0] * 1e3, res.rod_com[:, j, 1] * 1e3, color=_cyl(j), label=f"rod {nm}")
        axs[1].plot(phi, np.minimum(res.rod_com_radius[:, j], 10.0) * 1e3, color=_cyl(j), label=f"rod {nm}")
    axs[0].set_aspect("equal")
    axs[0].set_xlabel("x (mm)")
    axs[0].set_ylabel("y (mm)")
    axs[0].set_title("con-rod centre-of-mass paths", fontsize=9)
    axs[0].grid(True, alpha=0.3)
    axs[1].set_yscale("log")
    axs[1].set_xlabel("crank angle φ (deg)")
    axs[1].set_ylabel("radius of curvature (mm, clipped at 10 m)")
    _xaxis(axs[1])
    for ax in axs:
        ax.legend(fontsize=7)
    return _save(fig, "rod_com.png")


def _reactions(res):
    """``reactions.png``."""
    plt, spec, phi = _plt(), res.spec, res.phi_deg
    names = [c.name for c in spec.cylinders]
    fig, ax = plt.subplots(figsize=(9, 4.5))
    rx = res.reactions
    ax.plot(phi, np.linalg.norm(rx["R01"], axis=-1) / 1e3, color="k", label="|R01| main bearing")
    for j, nm in enumerate(names):
        ax.plot(phi, np.linalg.norm(rx["R12"][:, j], axis=-1) / 1e3, color=_cyl(j), label=f"|R12| crank pin, rod {nm}")
        ax.plot(phi, rx["N"][:, j] / 1e3, ":", color=_cyl(j), label=f"N wall, cyl {nm}")
    ax.set_xlabel("crank angle φ (deg)")
    ax.set_ylabel("kN")
    ax.set_title("reactions (crank pin A is a multiple joint: one reaction per rod)", fontsize=9)
    _xaxis(ax)
    ax.legend(fontsize=7, ncol=2)
    return _save(fig, "reactions.png")




def plot_forces(fr, x, out=None):
    """Balancing moment/force of each driver and |reaction| of each pair against ``x``.

    Writes ``out`` (PNG, 110 dpi) and returns its path; without ``out`` returns the figure.
    """
    plt = _plt()
    m = fr.mechanism
    fig, axs = plt.subplots(2, 1, figsize=(9, 7), sharex=True)
    rot = [m.is_rotary(d) for d in m.drivers]
    for i, d in enumerate(m.drivers):
        what = "moment M_b (N m)" if rot[i] else "force F_b (N)"
        axs[0].plot(x, fr.balancing[:, i], marker=".", label=f"driver {d.joint}: {what}")
    axs[0].set_ylabel("balancing moment (N m)" if all(rot) else "balancing force (N)" if not any(rot)
                      else "balancing: N m (R drivers), N (P drivers)")
    axs[0].grid(True, alpha=0.3)
    axs[0].legend(fontsize=8)
    for i, p in enumerate(fr.pairs):
        axs[1].plot(x, np.linalg.norm(fr.reactions[:, i], axis=-1), label=p.name)
    axs[1].set_ylabel("|reaction| (N)")
    d0 = m.drivers[0].joint if m.drivers else "?"
    axs[1].set_xlabel(f"input {d0} ({'deg' if rot and rot[0] else 'm'})")
    axs[1].grid(True, alpha=0.3)
    axs[1].legend(fontsize=7, ncol=2)
    axs[0].set_title(f"{m.name or 'mechanism'}: kinetostatics ({fr.method}); "
                     f"max relative virtual-power residual {np.nanmax(fr.relative_residual):.2g}", fontsize=9)
    no_mathtext(fig)
    fig.tight_layout()
    if out is None:
        return fig
    p = Path(out)
    p.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(p, dpi=110)
    plt.close(fig)
    return p
