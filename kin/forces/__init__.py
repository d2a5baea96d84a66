"""Kinetostatics of a decomposable planar mechanism (method: docs/forces.md).

For every position of a :class:`~kin.state.KinematicState` (time derivatives at the
drivers' actual speeds), :func:`forces` applies d'Alembert's principle: each moving
link is in equilibrium under its applied loads, its weight, its inertia force
``−m a_G`` at the centre of mass G and inertia moment ``−J_G ε``, the reactions of the
kinematic pairs on it, and the balancing (driving) moment or force of the drivers.

Unknowns
--------
* **R pair** (one per pair): the force ``R = (Rx, Ry)`` exerted by link ``a`` on link
  ``b`` at the pin; ``b`` receives ``+R``, ``a`` receives ``−R``.  A pin joining ``k``
  links (a multiple joint) carries ``k − 1`` pairs: one link of the pin is the *host*
  (the frame if it is on the pin, else the link solved first, i.e. the one through
  which the pin's position is known) and every other link of the pin is paired with
  it (docs/forces.md).  The force balance of the pin is then implied.
* **P pair** (guide ``a``, slider ``b``): a normal force ``N`` along the guide normal
  ``n = rot90(axis)`` (axis turned with the guide) at the joint point (the slider's
  point that sat at the joint's ``at``), plus a couple ``M``; the line of action of
  the normal force is offset by ``M / N`` along the axis (:meth:`ForceResult.line_of_action`).
* **Driver**: the balancing moment ``T`` (R driver) applied to the driver's
  ``links[1]`` by ``links[0]`` (counter-clockwise positive), or the balancing force
  (P driver) along the axis on the slider.

Each moving link gives three equations (ΣFx, ΣFy, ΣM about its centre of mass), so a
mechanism with as many drivers as degrees of freedom gives a square system.

Solving order
-------------
``method="groups"`` (default): group by group, from the last Assur group of the plan
(:func:`topo.assur.decompose`) back to the drivers; a pair (or driver) is solved with the
group of its later link; the solved reactions become known loads on the earlier links.
``method="global"``: one linear system for all moving links (the cross-check route;
also used when no plan is available).  Both are vectorised over positions: each block is
one sparse batched elimination (:func:`~.linsolve.solve_sparse`, threshold pivoting
with a LAPACK fallback), never a Python loop over positions.

Checks
------
Virtual power: ideal pair reactions do no work in total, so
``Σ T·(driver rate) + Σ_links (F·v_G + M·ω) = 0`` where the second sum runs over the
applied, gravity and inertia loads.  The residual is exposed per position
(:attr:`ForceResult.virtual_power_residual`, W) with its scale; a position whose
relative residual exceeds ``VP_TOL`` = 1e-6 is not ``ok``.

Singular positions (a block whose column-scaled determinant is below ``1e-10``, or a
kinematic status other than ``"ok"``) get NaN and a reason in ``status``; nothing raises
(a :class:`~topo.errors.SingularityWarning` says how many positions were singular).

Defaults
--------
Driver speed: ``Driver.speed`` from the file, else 1 rad/s (1 m/s); driver
acceleration: ``Driver.acceleration``, else 0.  A link's centre of mass defaults to the
centroid of its joints' reference points, its inertia to 0; a link without ``mass``
carries no weight and no inertia force, but a moment of inertia ``J_G`` it is given
still loads it with the couple ``−J_G ε``.  A ``[[force]]`` without ``at`` acts at the centre
of mass.  A ``[[force]]`` table is interpolated linearly against the first driver's
input (deg), periodic over 360 deg, or over 720 deg when a row lies beyond 360 deg.

References
----------
.. [1] Vasilenko V.N., Sidorenko A.S., Veretennikov A.N., Yarygin A.V. Program realization
   of the kinematic and power calculation of a four-stroke engine. *Vestnik VGUIT* 80(4)
   (2018) 69–74 (Vasilenko et al. 2018): reactions in every joint and the balancing moment.
.. [2] Pozhbelko V., Kuts E. (2020): a multiple joint of k links counts as
   k − 1 pairs.

Modules
-------
``plan`` (pairs, unknowns, blocks), ``loads`` (applied, weight, inertia), ``linsolve``
(batched small solves), ``solver`` (:func:`forces`, in phases), ``result``
(:class:`ForceResult` and its ``as_dict``).
"""
from __future__ import annotations

from .linsolve import solve_batched, solve_sparse
from .loads import (LinkLoads, PointLoad, check_mass_data, driver_speeds, has_loads, kinetic_energy, link_loads,
                    potential_energy, table_period)
from .plan import METHODS, Block, Column, ForcePlan, Pair, compile_forces
from .result import VP_TOL, ForceResult
from .solver import MAX_ANGLE_DEG, MAX_SLIDE_SIZES, forces, reduce_inputs

__all__ = ["Pair", "PointLoad", "ForceResult", "forces", "link_loads", "solve_batched", "solve_sparse",
           "driver_speeds", "kinetic_energy", "potential_energy", "LinkLoads", "ForcePlan", "Block", "Column",
           "compile_forces", "check_mass_data", "table_period", "VP_TOL", "reduce_inputs",
           "MAX_ANGLE_DEG", "MAX_SLIDE_SIZES", "has_loads", "METHODS"]
