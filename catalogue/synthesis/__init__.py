"""Number and type synthesis of planar chains with simple and multiple joints.

A **chain** here is a connected hypergraph on ``n`` links whose hyperedges are the
joints (a pin on ``n'`` links has multiplicity ``j = n' − 1`` and counts ``n' − 1``
pairs); every link lies on two or more joints, the mobility is
``F = 3(n − 1) − 2p`` and the chain is **non-degenerate**: no link subset ``S``,
``2 <= |S| < n``, has ``3(|S| − 1) − 2c(S) <= 0`` (the structural definitions (README), Pozhbelko & Kuts 2020).

Number synthesis (:func:`number_synthesis`)
    Every link assortment [LA] = (n2, n3, …) and multiple-joint assortment
    [MJA] = (V2, V3, …) that satisfies the structural equations
    ``Σ n_i = n``, ``Σ i n_i = 2p − V`` (the link corners ``SL``), ``m = p − V`` joints,
    and the existence domain of Pozhbelko & Kuts 2020 fig. 10 (``j <= K``, ``V <= 2(K − 1)``),
    flagged by the number of non-degenerate chains that realise it (the
    "universal structural table").

Type synthesis (:func:`iter_chains`; in parallel :func:`catalogue.distributed.type_synthesis`)
    The enumeration is split into independent :class:`Task` objects, one per
    number of joints ``m = p − V`` (i.e. per MJ factor ``V``) and per residue class
    ``res/mod`` of nauty's generators, so that any partition gives the same chains.

    * ``V = 0`` (simple joints): ``geng -c -d2 -t n p:p`` lists the connected
      triangle-free graphs of minimum degree 2 (a triangle is a rigid sub-chain);
    * ``V > 0``: ``genbg -c -d2:2 -Z1 n m e:e`` lists the connected bicoloured
      graphs (links × joints, ``e = 2p − V`` incidences); ``-Z1`` (two joints share at
      most one link) is implied by non-degeneracy (two links on two common joints
      are over-constrained).

    Both generators are isomorph-free (colour classes fixed), so the surviving
    graphs are the non-isomorphic chains.  Degeneracy is tested exactly for all
    ``2^n`` link subsets at once, in NumPy batches: with ``D(S)`` the sum of the link
    degrees in ``S`` and ``t(S)`` the number of joints touching ``S``,
    ``c(S) = D(S) − t(S)``, and ``t(S) = m − #{J ⊆ complement(S)}`` is a subset-sum
    (zeta) transform.

    An independent route, :func:`brute_force_chains`, adds joints one at a time to
    ``n`` labelled links (every subset of size 2…j+1 as a candidate), drops
    degenerate partial chains (degeneracy is monotone: adding a joint only raises
    ``c(S)``) and removes isomorphs by pynauty certificates after every step; it
    does not use nauty's generators and checks degeneracy by the definition.

Mechanisms from a chain (:func:`mechanism_choices`)
    The distinct frames (link orbits of the automorphism group) and the distinct
    (frame, driver joint, driven link) choices, by iterated stabilisers (pynauty).

References
----------
.. [1] T. S. Mruthyunjaya, "Kinematic structure of mechanisms revisited", Mechanism
   and Machine Theory 38 (2003) 279–320 (counts of 1-DOF simple-jointed chains:
   1, 2, 16, 230, 6856 for 4…12 links).
.. [2] L.-W. Tsai, *Mechanism Design: Enumeration of Kinematic Structures According
   to Function*, CRC Press, 2001, table 4.x (same counts).
.. [3] B. D. McKay, A. Piperno, "Practical graph isomorphism, II", J. Symbolic
   Computation 60 (2014) 94–112 (geng, genbg).
.. [4] V. A. Pozhbelko, E. N. Kuts (2020): existence domain (fig. 10) and
   the universal structural table.

Modules: :mod:`.options` (what to enumerate, the tasks), :mod:`.nauty` (generators
and graph6 decoding), :mod:`.degenerate` (the batch degeneracy filter),
:mod:`.records` (a chain's numbers), :mod:`.enumeration` (tasks, both routes),
:mod:`.tables` (number synthesis), :mod:`.mechanisms` (inversions), :mod:`.assortments`
([LA], [MJA] of a batch), :mod:`.counting` (number synthesis by counting, for tables
too large to store), :mod:`.counter_build` (the compiled counter).
"""
from __future__ import annotations

from .degenerate import _degenerate_by_definition, joint_masks_degenerate  # noqa: F401 (tests)
from .enumeration import brute_force_chains, count_task, iter_chains, run_task
from .mechanisms import MechanismChoices, mechanism_choices, record_choices
from .nauty import (  # noqa: F401 (private helpers used by the tests and benchmarks)
    _decode_bipartite, _decode_simple, _generator_command, _tool, nauty_available,
)
from .options import LITERATURE_SJ_F1, SynthesisOptions, Task, n_pairs, plan_tasks
from .records import ChainRecord, canonical_string, chain_record
from .tables import AssortmentRow, number_synthesis, table_rows, universal_table

__all__ = [
    "SynthesisOptions", "Task", "ChainRecord", "AssortmentRow", "MechanismChoices", "n_pairs",
    "nauty_available", "plan_tasks", "run_task", "count_task", "LITERATURE_SJ_F1", "iter_chains",
    "brute_force_chains", "number_synthesis", "universal_table", "table_rows", "chain_record",
    "canonical_string", "mechanism_choices", "record_choices", "joint_masks_degenerate",
]
