"""One compiled step of a mechanism's plan, behind one small protocol.

Every step of a plan (a driver, a dyad, a triad, a class IV group, any other group)
is compiled once into an object with

* ``positions(G, X, factor=1.0, probe=False) -> Outcome``: place the step's links in
  the pose store ``G`` (:class:`~kin.poses.Poses`) at the inputs ``X`` (N, n_drivers),
  on the branch ``reference sign × factor``; ``Outcome.why[n] = (Status, text)`` for
  each failed position, ``Outcome.probe`` a :class:`~kin.continuation.Probe` when asked;
* ``rates(R, input_rates)``: velocities and accelerations of its links into
  ``R`` (:class:`~kin.poses.PoseRates`);
* ``lower(origins) -> Lowered | None``: the step as flat numbers for the compiled
  kernel (:mod:`kin.kernel`), or None for a kind without a compiled step.  A kind with
  one keeps, next to its kernel, a scalar function ``*_place(ip, fp, X, n, W, factor,
  T, C, S, PP) -> status`` (plain arithmetic that numba compiles: position ``n`` of
  the inputs ``X`` in the pose store ``T``, ``C``, ``S``, see :mod:`kin.kernel`) and
  names it in :data:`kin.groups.registry.COMPILED`.

The closed-form kinds keep their adapter next to their kernel (``rrr.RRRStep`` …,
``triad.TriadStep``, ``class4.Class4Step``, ``driver.DriverStepSolver``).  An adapter
also declares every fact of its kind that the rest of the library asks the registry
(:mod:`kin.groups.registry`) for, so that no caller switches on the kind:

* ``kind``: its key in the registry (a ``topo.assur.GroupKind``, or the name of a kind
  registered at run time), and ``compiled``: its scalar function, if any;
* ``assembly_modes(m, group)``: the group's assembly modes at the reference (None: not
  enumerated);
* ``monitored_angles(m, group)``: the angles the design check and the synthesis's
  transmission constraint watch (:class:`AngleDef`);
* ``reference_margin(m, group, at, axis)``: the relative determinant of a population
  of designs' reference configurations (the synthesis's penalty near a singular one);
* ``singular_hint``: the advice when a group of the kind is singular at the reference;
* ``relabel(m, group)``: the decomposition's hook for a kind registered at run time:
  ``(kind, layout)`` for a group the decomposition gave another kind, or None.
:class:`~kin.groups.newton.NewtonStep` solves any group by continuation, and its rates
(the group's Jacobian, one linear system per position, exact for any group) serve the
triad and class IV steps too.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..continuation import Probe
from ..geometry import Geometry
from ..result import Status

__all__ = ["Outcome", "GroupStep", "Lowered", "Deferred", "AngleDef", "dyad_outcome", "SINGULAR", "PARALLEL_GUIDES",
           "GUIDES_HINT", "trig_row"]

#: relative determinant below which a position is singular
SINGULAR = 1e-9
#: PRP/RPP: |det| = |sin(angle between the unit guides)| below which the guides count as
#: parallel; nearer than this the slider positions exceed 1e6 × the offsets (change point)
PARALLEL_GUIDES = 1e-6
#: the advice for a singular reference of a linear dyad (PRP, RPP: their guides)
GUIDES_HINT = "parallel guides of a PRP dyad or α = 0 of an RPP dyad are structurally singular"


class Deferred(NamedTuple):
    """A compiled step kept in a module that imports numba itself (a tracker whose
    compiled parts live there), named by ``module`` (absolute) and ``name`` and imported
    only when the kernel loads (:mod:`kin._kernel_nb`): the adapter's module stays free
    of numba, so that the command line's cold start does not grow."""

    module: str
    name: str

    def resolve(self):
        """The compiled function (a numba dispatcher)."""
        import importlib
        return getattr(importlib.import_module(self.module), self.name)


class Lowered(NamedTuple):
    """A compiled step as flat numbers (:meth:`GroupStep.lower`): ``key`` names its
    scalar function in :data:`kin.groups.registry.COMPILED`; ``ints`` are link (and
    driver) indices, ``floats`` its numbers; the layout is the scalar function's own.
    Points of a link are given relative to the link's reference point (the pose
    store's convention, :class:`~kin.poses.Poses`).  ``trig`` lists the (driver, sign)
    whose cos and sin of ``sign × input`` the step reads from the kernel's table ``W``
    (rows ``trig_row(driver, sign)``), computed by NumPy before the loop as the NumPy
    path computes them."""

    key: object
    ints: tuple
    floats: tuple
    trig: tuple = ()


def trig_row(driver: int, sign: float) -> int:
    """The row of ``cos(sign × input[driver])`` in the kernel's table ``W`` (its sin is
    the next row)."""
    return 4 * driver + (2 if sign < 0 else 0)


class AngleDef(NamedTuple):
    """One monitored angle of a group (:meth:`GroupStep.monitored_angles`): reported at
    ``joint``; ``quantity`` is the name of its type, a key of
    :data:`kin.check.angle_types.ANGLE_TYPES` (``"transmission"``, ``"pressure"``,
    ``"triad"``, or one registered there), whose object owns its formula, range, ideal
    and flagged values; ``points`` the joint names its formula reads; ``guide`` =
    (P joint, guide link) for a pressure angle."""

    joint: str
    quantity: str
    points: tuple[str, ...]
    guide: tuple[str, str] | None = None


class Outcome(NamedTuple):
    """What :meth:`GroupStep.positions` found: ``ok`` (N,), ``why`` {n: (Status, text)}
    for the failed positions, ``probe`` (or None)."""

    ok: np.ndarray
    why: dict
    probe: Probe | None


class GroupStep:
    """Base of the compiled steps, built once per plan from the ``mechanism``, the step's
    :class:`~kin.solve.StepPlan` ``st`` (its Assur step, constraint system and unknown
    links) and the mechanism's ``size`` (m, for tolerances); its numbers come from
    ``geo`` (:class:`~kin.geometry.Geometry`: the mechanism's reference by default, or a
    batch of designs, when every number is an array over the designs)."""

    #: whether the step solves a batch of designs (:mod:`kin.design`) in one pass
    batched = True
    #: the plan's name for the solver (``StepPlan.solver``): "dyad" (closed form with two
    #: branches or none, charted by the continuation walk), "triad", "class4", "newton"
    solver = "dyad"
    #: the group kind this adapter solves: its key in :data:`kin.groups.registry.KINDS`
    kind = None
    #: its scalar function for the compiled kernel (:data:`kin.groups.registry.COMPILED`)
    compiled = None
    #: its lowering of a batch of designs for the compiled kernel, ``f(q, P, U, O, size,
    #: out)`` (:data:`kin.groups.registry.LOWERING`, :func:`kin.kernel.lower_designs`):
    #: every design's :meth:`lower` floats into ``out`` (D, width), from the joints'
    #: reference points ``P`` and guides ``U`` (D, n_joints + 1, 2), the links' reference
    #: points ``O`` (D, n_links, 2), the plan's ``size`` and the step's rows and links
    #: ``q`` (:meth:`lower_indices`); None: :meth:`lower` binds the batch in NumPy
    compiled_lower = None
    #: whether the step's solution at an input depends on the inputs before it (a
    #: followed assembly mode): its compiled step serves batches of designs along each
    #: design's own path (:func:`kin.kernel.run_designs`), not ``solve``'s kernel routes,
    #: which solve a failed row again on its own
    tracked = False
    #: whether a batch of designs takes the step's own compiled route, where it has one
    #: (set by :func:`kin.design.solve_designs` from :func:`kin.kernel.wanted`)
    jit = False
    #: the advice when a group of this kind is singular in the reference configuration
    singular_hint = None

    @classmethod
    def assembly_modes(cls, m, group) -> int | None:
        """The assembly modes of ``group`` at the reference (None: not enumerated)."""
        return None

    @classmethod
    def monitored_angles(cls, m, group) -> tuple[AngleDef, ...]:
        """The monitored angles of ``group`` (none by default)."""
        return ()

    @classmethod
    def reference_margin(cls, m, group, at, axis) -> np.ndarray | None:
        """The relative determinant ``(P,)`` of designs' reference configurations (zero:
        singular), from ``at(joint)`` and ``axis(joint)`` ``(P, 2)``; None: no margin."""
        return None

    @classmethod
    def relabel(cls, m, group):
        """The decomposition's hook for a kind registered at run time: ``(kind, layout)``
        when ``group`` is one of this kind, else None."""
        return None

    def __init__(self, mechanism, st, size: float, geo=None):
        self.mechanism, self.st, self.size = mechanism, st, size
        self.geo = geo if geo is not None else Geometry(mechanism)
        self.strict = not self.geo.batch          # a singular reference raises (one design)
        self.group = st.step
        self.label = st.label

    def at(self, joint: str) -> np.ndarray:
        """A joint's reference position ((2,), or (D, 1, 2) for designs)."""
        return self.geo.at(joint)

    def axis(self, joint: str) -> np.ndarray:
        """A P joint's unit guide direction in the reference."""
        return self.geo.axis(joint)

    def positions(self, G, X: np.ndarray, factor: float = 1.0, probe: bool = False) -> Outcome:
        raise NotImplementedError

    def rates(self, R, input_rates: np.ndarray) -> None:
        raise NotImplementedError

    def lower(self, origins) -> Lowered | None:
        """The step as flat numbers for the compiled kernel (None: no compiled step;
        a plan holding it is solved by the NumPy path).  ``origins`` (n_links, 2)
        are the links' reference points."""
        return None

    def lower_indices(self, row) -> tuple[int, ...]:
        """The step's structural numbers that :attr:`compiled_lower` reads (joints by
        ``row(joint)``, their rows in its arrays; links by index)."""
        raise NotImplementedError

    def link_index(self, name: str) -> int:
        """A link's index in the mechanism."""
        return self.mechanism.link_names.index(name)

    @staticmethod
    def rel(origins, k: int, r) -> tuple[float, float]:
        """Reference point ``r`` relative to link k's reference point (as the pose store
        computes it: the same floats); for a batch of designs (``origins`` (n_links, D,
        1, 2)) arrays ``(D, 1)``."""
        o = np.asarray(origins, float)[k]
        if o.ndim == 1:
            o = o.tolist()
            return float(r[0]) - o[0], float(r[1]) - o[1]
        r = np.asarray(r, float)          # a batch: origins (n_links, D, 1, 2), r (D, 1, 2)
        return r[..., 0] - o[..., 0], r[..., 1] - o[..., 1]

    @staticmethod
    def off(origins, k: int, r) -> tuple[float, float]:
        """Link k's reference point relative to its material point at ``r``."""
        x, y = GroupStep.rel(origins, k, r)
        return -x, -y


def dyad_outcome(ok, why: dict, det, rdet: float, parallel: bool, probe_obj, probe: bool,
                 reasons: bool = True) -> Outcome:
    """The common end of a dyad's ``positions``: a generic reason for every failure not
    explained yet (unless ``reasons`` is False: designs in a batch), and singular
    positions (``|det| <= tol · rdet``) marked and removed."""
    if reasons and not ok.all():
        for n in np.flatnonzero(~ok):
            why.setdefault(int(n), (Status.OUT_OF_REACH, "no assembly (out of reach)"))
    tol = PARALLEL_GUIDES if parallel else SINGULAR
    sing = ok & ~(np.abs(det) > tol * rdet)
    if probe_obj is None and probe:       # PRP, RPP: one assembly; parallel guides are a pole, not a limit
        probe_obj = Probe(ok.copy())
    if not sing.any():
        return Outcome(ok, why, probe_obj)
    for n in (np.flatnonzero(sing) if reasons else ()):
        why[int(n)] = (Status.SINGULAR, f"singular position (dyad determinant {det[n]:.2e}: links or guides aligned)")
    return Outcome(ok & ~sing, why, probe_obj)
