"""catalogue: named mechanisms, synthesis and atlases.

API index:

* ``catalogue.named`` — the bundled mechanisms (``mechanisms/*.toml``, each citing its
  source): ``names()``, ``path(name)``, ``load_named(name)``.
* ``catalogue.engines`` — builders of engine mechanisms with masses (single cylinder,
  V-twin on one crank pin, radial N-cylinder on one multiple pin); engine files in
  ``engines/*.toml``; platforms in ``platforms/*.toml``.
* ``catalogue.synthesis`` — number synthesis (the universal structural table) and type
  synthesis (every non-isomorphic, non-degenerate chain for n links and F DOF, with or
  without multiple joints), mechanisms from a chain up to symmetry.
* ``catalogue.atlas`` — the SQLite atlas store (resumable builds, safe queries).
* ``catalogue.distributed`` — local processes or a Dask cluster.
* ``catalogue.drawing`` / ``catalogue.html`` — chain drawings (SVG) and the HTML gallery.
"""
