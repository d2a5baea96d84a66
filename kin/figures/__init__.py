"""Every figure of multiloop, in one place (matplotlib with the Agg backend, and SVG text).

API index:

* ``mechanism`` — a solved mechanism with its tracer paths, the analogue diagrams, and
  the animation (:func:`plot_mechanism`, :func:`plot_analogues`, :func:`animate`).
* ``engine`` — the engine diagrams and force plots (:func:`engine_plots`, :func:`plot_forces`).
* ``platform`` — a six-strut platform in 3-D (:func:`plot_platform`).
* ``chains`` — atlas drawings of bare chains (SVG and matplotlib), the existence-domain
  and invariant-merge charts.

Sub-modules are imported on demand, so importing this package does not load matplotlib.
"""
