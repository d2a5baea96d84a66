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
* ``catalogue.curves`` / ``catalogue.curve_atlas`` — coupler-curve descriptors, the
  aligned and windowed distances, the stored curves and their index;
  ``catalogue.topology_synthesis`` — path synthesis without a start (the atlas chooses
  the topology); ``catalogue.open_targets`` — its open targets (sub-arc retrieval, the
  driver's input interval).
"""
