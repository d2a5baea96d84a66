"""The synthesis figure: the target against what the synthesised mechanism does."""
from __future__ import annotations

import numpy as np

__all__ = ["plot_synthesis"]


def plot_synthesis(res):
    """Mechanism at its reference with the achieved curve, the targets and the hits.

    Function generation adds a second panel: output against input, target and achieved.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import warnings

    import matplotlib.pyplot as plt

    from multiloop.kin.figures.mechanism import plot_mechanism
    from multiloop.kin.solve import solve

    m = res.mechanism
    phi = np.asarray(res.inputs, float)
    lo, hi = min(0.0, phi.min()), max(0.0, phi.max())
    if m.is_rotary(0) and hi - lo < 2 * np.pi:
        pad = 0.05 * (hi - lo)
        lo, hi = lo - pad, hi + pad
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = solve(m, np.concatenate([[0.0], np.linspace(lo, hi, 181)]))
    ncol = 2 if res.task == "function" else 1
    fig, axes = plt.subplots(1, ncol, figsize=(7 * ncol, 6), dpi=110, squeeze=False)
    ax = axes[0, 0]
    plot_mechanism(st, 0, ax=ax, title=f"{m.name or 'mechanism'}: {res.task} generation, "
                                        f"error max {res.error_max:.2g}, RMS {res.error_rms:.2g}")
    a = np.asarray(res.achieved)
    tgt = res.target
    if res.task in ("path", "motion"):
        if tgt is not None:
            t = np.asarray(tgt)
            ax.plot(t[:, 0], t[:, 1], "o", mfc="none", mec="k", ms=9, label="target")
        ax.plot(a[:, 0], a[:, 1], ".", color="crimson", ms=7, label="achieved")
        ax.legend(loc="best", fontsize=8)
    else:
        b = axes[0, 1]
        x = np.degrees(phi)
        if tgt is not None:
            b.plot(x, np.asarray(tgt), "o", mfc="none", mec="k", ms=9, label="target")
        b.plot(x, a, ".", color="crimson", ms=7, label="achieved")
        b.set_xlabel("driver value from the reference")
        b.set_ylabel("output")
        b.grid(True, lw=0.3)
        b.legend(loc="best", fontsize=8)
    fig.tight_layout()
    return fig
