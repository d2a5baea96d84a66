"""Exchange formats: read and write what other linkage tools use.

* :mod:`multiloop.exchange.pyslvs` — Pyslvs projects (``.pyslvs``, YAML) and bare
  Pyslvs expressions (``M[J[R, color[Green], P[x, y], L[ground, L1]], ...]``).
"""
