"""Notebook helpers (the optional ``[notebook]`` extra): scrub a solved motion with a slider.

>>> import multiloop as ml, numpy as np                       # doctest: +SKIP
>>> from multiloop.notebook import scrub                      # doctest: +SKIP
>>> scrub(ml.solve("four_bar", np.linspace(0, 2 * np.pi, 73)))  # doctest: +SKIP

Mechanisms, structural reports, kinematic states and check reports also display
themselves in a notebook (``_repr_svg_`` / ``_repr_html_``) without this extra.
"""
from __future__ import annotations

from multiloop.topo.errors import InputError, explain

__all__ = ["scrub"]


def scrub(state, width: int = 420, height: int = 320):
    """An ipywidgets box: a slider over the positions of ``state`` and the drawing there.

    Returns
    -------
    ipywidgets.VBox
        ``children[0]`` is the ``IntSlider``, ``children[1]`` the ``HTML`` drawing.
    """
    try:
        import ipywidgets as w  # noqa: PLC0415
    except ImportError:
        raise InputError(explain("scrub", expected="ipywidgets", got="it is not installed",
                                 hint="pip install 'multiloop[notebook]'")) from None
    from multiloop.kin.notebook import state_svg  # noqa: PLC0415

    slider = w.IntSlider(value=0, min=0, max=max(state.n_positions - 1, 0), description="position")
    view = w.HTML(state_svg(state, 0, width=width, height=height))

    def show(change) -> None:
        view.value = state_svg(state, int(change["new"]), width=width, height=height)

    slider.observe(show, names="value")
    return w.VBox([slider, view])
