"""topo: the structural model of planar linkages (graph and structure, no solving).

Modules: ``errors`` (exception tree), ``model`` (frozen Link/Joint/Mechanism + builder),
``io`` (TOML/JSON and the typed readers), ``graphs`` (incidence graph, pin pairs),
``constraints`` (pair constraints and their Jacobian), ``mobility`` (actual mobility),
``numbers`` (Pozhbelko & Kuts 2020 structural numbers), ``loops`` (planar embedding,
loop assortment), ``isomorphism`` (canonical form, VF2, invariants), ``degeneracy``
(rigid sub-chains, fractionation), ``assur`` (decomposition into Assur groups).
"""
from .errors import *  # noqa: F401,F403
from .model import *  # noqa: F401,F403
