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
also used when no plan is available).  Both are vectorised over positions with a
batched Gaussian elimination (partial pivoting, NumPy over the batch axis).

Checks
------
Virtual power: ideal pair reactions do no work in total, so
``Σ T·(driver rate) + Σ_links (F·v_G + M·ω) = 0`` where the second sum runs over the
applied, gravity and inertia loads.  The residual is exposed per position
(:attr:`ForceResult.virtual_power_residual`, W) with its scale.

Singular positions (a block whose column-scaled determinant is below ``1e-10``, or a
kinematic status other than ``"ok"``) get NaN and a reason in ``status``; nothing raises
(a :class:`~topo.errors.SingularityWarning` says how many positions were singular).

Defaults
--------
Driver speed: ``Driver.speed`` from the file, else 1 rad/s (1 m/s); driver
acceleration: ``Driver.acceleration``, else 0.  A link's centre of mass defaults to the
centroid of its joints' reference points, its inertia to 0; a link without ``mass``
carries no weight and no inertia.  A ``[[force]]`` without ``at`` acts at the centre
of mass.  A ``[[force]]`` table is interpolated linearly against the first driver's
input (deg), periodic over 360 deg, or over 720 deg when a row lies beyond 360 deg.

References
----------
.. [1] Vasilenko V.N., Sidorenko A.S., Veretennikov A.N., Yarygin A.V. Program realization
   of the kinematic and power calculation of a four-stroke engine. *Vestnik VGUIT* 80(4)
   (2018) 69–74 (Vasilenko et al. 2018): reactions in every joint and the balancing moment.
.. [2] Pozhbelko V., Kuts E. (2020): a multiple joint of k links counts as
   k − 1 pairs.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from multiloop.topo.errors import InputError, MobilityError, SingularityWarning, explain
from multiloop.topo.model import JointKind, Mechanism

from .result import BatchStatus
from .state import KinematicState

__all__ = ["Pair", "PointLoad", "ForceResult", "forces", "link_loads", "solve_batched",
           "driver_speeds", "kinetic_energy", "potential_energy"]

_SING_TOL = 1e-10


@dataclass(frozen=True, slots=True)
class Pair:
    """One kinematic pair carrying a reaction: ``a`` acts on ``b`` at ``joint``."""

    joint: str
    kind: str
    a: str
    b: str

    @property
    def name(self) -> str:
        return f"{self.joint}:{self.a}->{self.b}"


@dataclass(frozen=True)
class PointLoad:
    """An extra load given as arrays (used by the engine for gas forces).

    ``force`` is ``(2,)`` or ``(N, 2)`` in the frame, applied at the material point of
    ``link`` that sat at ``at`` in the reference configuration (``None``: the centre of
    mass); ``moment`` is a couple (N m, CCW), scalar or ``(N,)``.
    """

    link: str
    force: np.ndarray | tuple = (0.0, 0.0)
    at: tuple[float, float] | None = None
    moment: np.ndarray | float = 0.0
    name: str | None = None


@dataclass(frozen=True)
class ForceResult(BatchStatus):
    """Result of :func:`forces` (frozen).  Leading axis: positions.

    Attributes
    ----------
    pairs : tuple of Pair
    reactions : ndarray (N, n_pairs, 2)
        Force of ``pair.a`` on ``pair.b`` (N), frame axes.
    pair_moments : ndarray (N, n_pairs)
        Couple of ``a`` on ``b`` (N m); non-zero only for P pairs.
    balancing : ndarray (N, n_drivers)
        Balancing moment (R driver, N m, on ``links[1]`` by ``links[0]``, CCW +) or force
        (P driver, N, along the axis).
    driver_rates : ndarray (N, n_drivers)
        Relative speed of each driver (rad/s or m/s) taken from the state.
    load_power : ndarray (N,)
        Power of applied, gravity and inertia loads (W).
    virtual_power_residual : ndarray (N,)
        ``Σ balancing·rate + load_power`` (W); zero to round-off.
    power_scale : ndarray (N,)
        Sum of the magnitudes of all power terms (W), for a relative residual.
    status : ndarray (N,) of str
        ``"ok"`` or the reason (kinematic failure, singular block).
    method : str
        ``"groups"`` or ``"global"`` (the route actually used).
    blocks : tuple of tuple of str
        Link sets solved together, in the order solved.
    normal_forces : ndarray (N, n_pairs)
        Signed normal force ``N`` of each P pair along ``rot90(axis)`` (0 for R pairs).
    """

    mechanism: Mechanism
    state: KinematicState
    pairs: tuple[Pair, ...]
    reactions: np.ndarray
    pair_moments: np.ndarray
    balancing: np.ndarray
    driver_rates: np.ndarray
    inertia_forces: np.ndarray
    inertia_moments: np.ndarray
    load_power: np.ndarray
    virtual_power_residual: np.ndarray
    power_scale: np.ndarray
    status: np.ndarray
    method: str
    blocks: tuple = ()
    notes: tuple = ()
    normal_forces: np.ndarray | None = None

    @property
    def n_positions(self) -> int:
        return self.reactions.shape[0]

    @property
    def relative_residual(self) -> np.ndarray:
        """``|residual| / max(scale, 1e-12 · max scale over the batch)`` (a position
        where every load vanishes, e.g. a dead centre without gravity, has scale 0)."""
        ref = np.nanmax(self.power_scale) if np.any(self.power_scale > 0) else 1.0
        s = np.maximum(self.power_scale, 1e-12 * ref)
        return np.abs(self.virtual_power_residual) / s

    def pair_index(self, name: str) -> int:
        for i, p in enumerate(self.pairs):
            if p.name == name:
                return i
        raise KeyError(name)

    def reaction(self, joint: str, a: str | None = None, b: str | None = None) -> np.ndarray:
        """Reaction ``(N, 2)`` of the pair on ``joint`` (between ``a`` and ``b``, either
        order; the sign follows the requested order ``a`` on ``b``)."""
        for i, p in enumerate(self.pairs):
            if p.joint != joint:
                continue
            if a is None and b is None:
                return self.reactions[:, i]
            if (p.a, p.b) == (a, b) or (b is None and p.a == a) or (a is None and p.b == b):
                return self.reactions[:, i]
            if (p.b, p.a) == (a, b):
                return -self.reactions[:, i]
        raise KeyError(f"no pair on joint {joint!r} between {a!r} and {b!r}")

    def line_of_action(self, name: str) -> np.ndarray:
        """Offset (m) along the guide axis of a P pair's normal force from the joint
        point, ``M / N`` (NaN where ``N`` is 0)."""
        i = self.pair_index(name)
        n = self.normal_forces[:, i]
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(n != 0, self.pair_moments[:, i] / n, np.nan)


# --------------------------------------------------------------------------- helpers
def _cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def solve_batched(A: np.ndarray, b: np.ndarray, check: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Solve ``A x = b`` for a batch: ``A (N, m, m)``, ``b (N, m)``.

    Columns are scaled to unit norm; ``absdet`` is the absolute determinant of the
    scaled matrix (between 0 and 1 by Hadamard's inequality), a scale-free singularity
    measure.  Rows with ``absdet <= 1e-10`` (or non-finite entries) are not solved and
    come back as NaN; the others go through one batched LAPACK ``gesv`` call
    (``numpy.linalg.solve``), no Python loop per position.  (A hand-written batched
    elimination with partial pivoting over the batch axis was 2-3x slower for m = 6.)

    With ``check=False`` the determinant is skipped (``absdet`` is all NaN) unless the
    batch contains an exactly singular matrix, when the checked path is taken: faster,
    but near-singular positions are not marked.

    Returns
    -------
    x : ndarray (N, m)
    absdet : ndarray (N,)
    """
    A = np.asarray(A, float)
    N, m, _ = A.shape
    if m == 0:
        return np.zeros((N, 0)), np.ones(N)
    norms = np.sqrt(np.einsum("nij,nij->nj", A, A))
    norms = np.where(norms > 0, norms, 1.0)
    As = A / norms[:, None, :]
    if not check:
        try:
            x = np.linalg.solve(As, b[..., None])[..., 0] / norms
            return x, np.full(N, np.nan)
        except np.linalg.LinAlgError:
            pass
    with np.errstate(invalid="ignore"):
        det = np.abs(np.linalg.det(As))                   # NaN for non-finite rows
    good = (det > _SING_TOL) & np.isfinite(b).all(axis=1)
    det = np.where(np.isfinite(det), det, 0.0)
    if not good.all():
        As[~good] = np.eye(m)
    bb = np.where(good[:, None], b, 0.0)
    x = np.linalg.solve(As, bb[..., None])[..., 0] / norms
    x[~good] = np.nan
    return x, det


def driver_speeds(m: Mechanism, speeds=None, accelerations=None) -> tuple[np.ndarray, np.ndarray]:
    """Driver speeds and accelerations: the arguments, else the file's ``[[driver]]``
    ``speed``/``acceleration``, else 1 and 0."""
    nd = len(m.drivers)
    w = np.array([d.speed if d.speed is not None else 1.0 for d in m.drivers], float)
    e = np.array([d.acceleration if d.acceleration is not None else 0.0 for d in m.drivers], float)
    if speeds is not None:
        w = np.broadcast_to(np.asarray(speeds, float), (nd,)).copy()
    if accelerations is not None:
        e = np.broadcast_to(np.asarray(accelerations, float), (nd,)).copy()
    return w, e


def _cg_ref(m: Mechanism, link: str) -> tuple[float, float]:
    lk = m.link(link)
    if lk.cg is not None:
        return lk.cg
    pts = [j.at for j in m.joints_of(link) if j.at is not None]
    if not pts:
        raise InputError(explain(f"link '{link}'", expected="a centre of mass 'cg' or joint positions",
                                 got="neither"))
    return (float(np.mean([p[0] for p in pts])), float(np.mean([p[1] for p in pts])))


def _material_velocity(state: KinematicState, link: str, P: np.ndarray) -> np.ndarray:
    """Velocity of the material point of ``link`` currently at ``P`` (N, 2)."""
    m = state.mechanism
    if m.link(link).is_frame:
        return np.zeros_like(P)
    i = state._anchor(link)
    k = state.link_index(link)
    r = P - state.positions[:, i]
    w = state.omegas[:, k][:, None]
    return state.velocities[:, i] + w * np.stack([-r[:, 1], r[:, 0]], axis=-1)


def _axis_now(state: KinematicState, joint) -> np.ndarray:
    ax = np.asarray(joint.axis, float)
    ax = ax / np.hypot(*ax)
    th = state.angles[:, state.link_index(joint.links[0])]
    c, s = np.cos(th), np.sin(th)
    return np.stack([c * ax[0] - s * ax[1], s * ax[0] + c * ax[1]], axis=-1)


def _table_force(load, input_deg: np.ndarray) -> np.ndarray:
    rows = np.asarray(load.table, float)
    period = 720.0 if rows[:, 0].max() > 360.0 else 360.0
    x = np.mod(input_deg, period)
    order = np.argsort(rows[:, 0])
    rows = rows[order]
    fx = np.interp(x, rows[:, 0], rows[:, 1], period=period)
    fy = np.interp(x, rows[:, 0], rows[:, 2], period=period)
    return np.stack([fx, fy], axis=-1)


def link_loads(state: KinematicState, extra_loads: Sequence[PointLoad] = (),
               include_file_loads: bool = True, gravity=None):
    """Known loads on every moving link, reduced to the centre of mass.

    Returns
    -------
    F : ndarray (N, n_links, 2)
        Resultant of applied + gravity + inertia forces.
    M : ndarray (N, n_links)
        Resultant moment about the centre of mass.
    power : ndarray (N, n_links)
        Power of these loads (W).
    absp : ndarray (N, n_links)
        Sum of the magnitudes of the individual power terms.
    Fi, Mi : inertia force and moment (N, n_links, 2), (N, n_links)
    G, vG : centre of mass position and velocity (N, n_links, 2)
    """
    m = state.mechanism
    N = state.n_positions
    nl = m.n_links
    F = np.zeros((N, nl, 2))
    M = np.zeros((N, nl))
    P = np.zeros((N, nl))
    AP = np.zeros((N, nl))
    Fi = np.zeros((N, nl, 2))
    Mi = np.zeros((N, nl))
    G = np.zeros((N, nl, 2))
    vG = np.zeros((N, nl, 2))
    g = np.asarray(gravity if gravity is not None else (m.gravity or (0.0, 0.0)), float)
    for k, lk in enumerate(m.links):
        if lk.is_frame:
            continue
        gpos, gvel, gacc = state.point_on_link(lk.name, _cg_ref(m, lk.name))
        G[:, k], vG[:, k] = gpos, gvel
        if lk.mass:
            Fi[:, k] = -lk.mass * gacc
            Mi[:, k] = -(lk.inertia or 0.0) * state.epsilons[:, k]
            wgt = lk.mass * g
            F[:, k] += Fi[:, k] + wgt
            M[:, k] += Mi[:, k]
            p1 = np.einsum("ni,ni->n", Fi[:, k], gvel)
            p2 = Mi[:, k] * state.omegas[:, k]
            p3 = gvel @ wgt
            P[:, k] += p1 + p2 + p3
            AP[:, k] += np.abs(p1) + np.abs(p2) + np.abs(p3)
    loads = list(m.loads) if include_file_loads else []
    input_deg = np.degrees(state.inputs[:, 0]) if state.inputs.size else np.zeros(N)
    for ld in loads + list(extra_loads):
        k = m.link_names.index(ld.link)
        if m.links[k].is_frame:
            continue
        if isinstance(ld, PointLoad):
            f = np.broadcast_to(np.asarray(ld.force, float), (N, 2))
            mom = np.broadcast_to(np.asarray(ld.moment, float), (N,))
        else:
            f = _table_force(ld, input_deg) if ld.table is not None else \
                np.broadcast_to(np.asarray(ld.value, float), (N, 2))
            mom = np.full(N, ld.moment)
        at = ld.at if ld.at is not None else _cg_ref(m, ld.link)
        ppos, pvel, _ = state.point_on_link(ld.link, at)
        F[:, k] += f
        M[:, k] += mom + _cross(ppos - G[:, k], f)
        p1 = np.einsum("ni,ni->n", f, pvel)
        p2 = mom * state.omegas[:, k]
        P[:, k] += p1 + p2
        AP[:, k] += np.abs(p1) + np.abs(p2)
    return F, M, P, AP, Fi, Mi, G, vG


def kinetic_energy(state: KinematicState) -> np.ndarray:
    """``T = Σ ½ m |v_G|² + ½ J_G ω²`` (J) per position."""
    m = state.mechanism
    T = np.zeros(state.n_positions)
    for k, lk in enumerate(m.links):
        if lk.is_frame or not lk.mass:
            continue
        _, v, _ = state.point_on_link(lk.name, _cg_ref(m, lk.name))
        T += 0.5 * lk.mass * np.einsum("ni,ni->n", v, v) + 0.5 * (lk.inertia or 0.0) * state.omegas[:, k] ** 2
    return T


def potential_energy(state: KinematicState, gravity=None) -> np.ndarray:
    """``U = −Σ m g·G`` (J) per position."""
    m = state.mechanism
    g = np.asarray(gravity if gravity is not None else (m.gravity or (0.0, 0.0)), float)
    U = np.zeros(state.n_positions)
    for lk in m.links:
        if lk.is_frame or not lk.mass:
            continue
        pos, _, _ = state.point_on_link(lk.name, _cg_ref(m, lk.name))
        U -= lk.mass * (pos @ g)
    return U


def _plan_order(m: Mechanism, plan=None) -> list[list[str]] | None:
    """Link sets in solving order from the Assur plan (driver links, then groups), or
    None when no plan can be made."""
    if plan is None:
        try:
            from multiloop.topo.assur import decompose  # noqa: PLC0415
        except ImportError:  # pragma: no cover
            return None
        try:
            plan = decompose(m)
        except Exception:  # noqa: BLE001 - no plan: the global route is used
            return None
    steps = getattr(plan, "steps", None)
    if steps is None:
        steps = getattr(plan, "groups", ())
    groups = []
    for s in steps:
        links = getattr(s, "links", None)
        if links is None:
            links = (getattr(s, "link", None),)
        links = [x for x in links if x in m.link_names and not m.link(x).is_frame]
        if links:
            groups.append(links)
    return groups or None


def _unknowns(m: Mechanism, rank: dict[str, float]):
    """Pairs and driver unknowns.  Returns (pairs, columns) where each column is
    (kind, index, a, b, joint) and kind in {'Rx','Ry','PN','PM','DR','DP'}."""
    pairs: list[Pair] = []
    cols = []
    for j in m.joints:
        if j.kind is JointKind.P:
            pairs.append(Pair(j.name, "P", j.links[0], j.links[1]))
        else:
            order = sorted(range(len(j.links)), key=lambda i: (rank[j.links[i]], i))
            host = j.links[order[0]]
            for i in order[1:]:
                pairs.append(Pair(j.name, "R", host, j.links[i]))
    for i, p in enumerate(pairs):
        if p.kind == "R":
            cols += [("Rx", i, p.a, p.b, p.joint), ("Ry", i, p.a, p.b, p.joint)]
        else:
            cols += [("PN", i, p.a, p.b, p.joint), ("PM", i, p.a, p.b, p.joint)]
    for i, d in enumerate(m.drivers):
        kind = "DP" if m.joint(d.joint).kind is JointKind.P else "DR"
        cols.append((kind, i, d.links[0], d.links[1], d.joint))
    return pairs, cols


def forces(mechanism: Mechanism, state_or_inputs, *, speeds=None, accelerations=None,
           method: str = "groups", plan=None, extra_loads: Sequence[PointLoad] = (),
           include_file_loads: bool = True, gravity=None, check: bool = True) -> ForceResult:
    """Reactions in every pair and the balancing moment/force of every driver.

    Parameters
    ----------
    mechanism : Mechanism
        With geometry; masses, gravity, loads as given in the file.
    state_or_inputs : KinematicState or array_like
        A state whose velocities/accelerations are time derivatives at the actual
        driver speeds, or driver inputs ``(N,)``/``(N, n_drivers)`` (rad or m from the
        reference configuration), which are solved with :func:`kin.solve.solve` at
        ``speeds`` and ``accelerations``.
    speeds, accelerations : array_like, optional
        Driver speeds (rad/s or m/s) and accelerations; defaults from the file's
        ``[[driver]]`` ``speed``/``acceleration``, else 1 and 0.  Used only with inputs.
    method : {"groups", "global"}
        Group by group along the Assur plan (falls back to global when no plan is
        available), or one global system.
    plan : AssurPlan, optional
        A precomputed plan (else :func:`topo.assur.decompose` is called).
    extra_loads : sequence of PointLoad
        Array-valued loads added to the file's (e.g. gas forces).
    include_file_loads : bool
        Use the mechanism's ``[[force]]`` loads.
    gravity : (gx, gy), optional
        Overrides the mechanism's gravity.
    check : bool
        Mark singular positions by the scaled determinant of every block (default).
        ``False`` skips the determinants (about 20 % faster; for inner loops on states
        already known to be regular): near-singular positions then give large values
        instead of NaN.

    Returns
    -------
    ForceResult

    Raises
    ------
    MobilityError
        The equations are not square (drivers do not match the mobility).
    InputError
        Unknown method, missing geometry.

    Notes
    -----
    Cost: one batched LAPACK solve and determinant per block, O(N m³) with
    m = 3 × links in the block.

    Examples
    --------
    >>> from multiloop.kin.engine import Cylinder, EngineSpec, engine_mechanism, engine_state
    >>> spec = EngineSpec(0.05, 0.2, 0.08, (Cylinder("1", 0.0),), rod_mass=1.0, rod_cg=0.3,
    ...                   rod_inertia=0.01, piston_mass=0.5)
    >>> m = engine_mechanism(spec)
    >>> fr = forces(m, engine_state(spec, np.radians([30.0, 90.0]), mechanism=m))
    >>> fr.success, [p.name for p in fr.pairs][:2]
    (True, ['O:frame->crank', 'A:crank->rod1'])
    >>> bool(fr.relative_residual.max() < 1e-12)
    True
    """
    m = mechanism
    if method not in ("groups", "global"):
        raise InputError(explain("method", expected="'groups' or 'global'", got=repr(method)))
    if not m.has_geometry:
        raise InputError(explain("mechanism", expected="joint positions 'at' (and P-joint 'axis')",
                                 got="no geometry", hint="kinetostatics needs the reference configuration"))
    if isinstance(state_or_inputs, KinematicState):
        state = state_or_inputs
    else:
        state = _solve_state(m, state_or_inputs, speeds, accelerations)
    if state.velocities is None or state.accelerations is None or state.omegas is None \
            or state.epsilons is None:
        raise InputError(explain("state", expected="velocities and accelerations", got="positions only",
                                 hint="solve with derivatives=True"))
    N = state.n_positions
    moving = [lk.name for lk in m.links if not lk.is_frame]
    notes: list[str] = []
    groups = _plan_order(m, plan) if method == "groups" else None
    used = "groups"
    if groups is None:
        used = "global"
        if method == "groups":
            notes.append("no Assur plan available: global solve")
        groups = [moving]
    covered = {x for g in groups for x in g}
    missing = [x for x in moving if x not in covered]
    if missing:
        groups = [missing] + groups
    rank: dict[str, float] = {x: float(i) for i, g in enumerate(groups) for x in g}
    for lk in m.links:
        if lk.is_frame:
            rank[lk.name] = -1.0
    pairs, cols = _unknowns(m, rank)
    n_eq, n_unk = 3 * len(moving), len(cols)
    if n_eq != n_unk:
        raise MobilityError(explain(
            "kinetostatics", expected=f"as many unknowns as equations ({n_eq} = 3 x {len(moving)} moving links)",
            got=f"{n_unk} (2 per R pair, 2 per P pair, 1 per driver; {len(m.drivers)} drivers)",
            hint="the number of drivers must equal the mobility"))
    # blocks: a column belongs to the group of its later link
    col_block = [max(rank[c[2]], rank[c[3]]) for c in cols]
    blocks = [(g, [ci for ci, r in enumerate(col_block) if r == float(i)]) for i, g in enumerate(groups)]
    if any(3 * len(g) != len(cs) for g, cs in blocks):
        used = "global"
        notes.append("plan blocks not square: global solve")
        blocks = [(moving, list(range(n_unk)))]

    F, Mc, P, AP, Fi, Mi, G, vG = link_loads(state, extra_loads, include_file_loads, gravity)
    li = {x: k for k, x in enumerate(m.link_names)}
    jpos = {j.name: state.positions[:, k] for k, j in enumerate(m.joints)}
    axes = {j.name: _axis_now(state, j) for j in m.joints if j.kind is JointKind.P}
    arms: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]] = {}

    def effect(c, link):
        """Force (fx, fy) and moment about G of ``link`` per unit unknown, on ``link``
        (scalars or (N,) arrays)."""
        kind, _, a, b, jn = c
        sgn = 1.0 if link == b else -1.0
        if kind in ("PM", "DR"):
            return 0.0, 0.0, sgn
        if kind == "Rx":
            dx, dy = 1.0, 0.0
        elif kind == "Ry":
            dx, dy = 0.0, 1.0
        elif kind == "PN":
            t = axes[jn]
            dx, dy = -t[:, 1], t[:, 0]
        else:  # DP
            t = axes[jn]
            dx, dy = t[:, 0], t[:, 1]
        key = (jn, link)
        if key not in arms:
            r = jpos[jn] - G[:, li[link]]
            arms[key] = (r[:, 0], r[:, 1])
        rx, ry = arms[key]
        return sgn * dx, sgn * dy, sgn * (rx * dy - ry * dx)

    known = np.concatenate([F, Mc[..., None]], axis=-1)  # (N, n_links, 3)
    x_all = np.full((N, n_unk), np.nan)
    bad_kin = np.asarray(state.status != "ok", bool)
    any_bad = bool(bad_kin.any())
    singular: list[tuple[np.ndarray, str]] = []
    solved_blocks = []
    for links, cs in reversed(blocks):
        if not cs:
            continue
        rows = {x: r for r, x in enumerate(links)}
        At = np.zeros((3 * len(links), len(cs), N))      # batch last: contiguous column writes
        outside = []
        for q, ci in enumerate(cs):
            c = cols[ci]
            for lk in (c[2], c[3]):
                if m.link(lk).is_frame:
                    continue
                e = effect(c, lk)
                if lk in rows:
                    r0 = 3 * rows[lk]
                    At[r0, q] += e[0]
                    At[r0 + 1, q] += e[1]
                    At[r0 + 2, q] += e[2]
                else:
                    outside.append((q, lk, e))
        A = np.moveaxis(At, 2, 0)
        rhs = -np.concatenate([known[:, li[x]] for x in links], axis=-1)
        if any_bad:
            A = A.copy()
            A[bad_kin] = np.eye(A.shape[1])
            rhs[bad_kin] = 0.0
        rhs = np.nan_to_num(rhs)
        x, det = solve_batched(A, rhs, check)
        sing = ~(det > _SING_TOL) & ~bad_kin if check or not np.isnan(det).all() else np.zeros(N, bool)
        if sing.any():
            singular.append((sing, f"singular: block {{{', '.join(links)}}} (scaled det < {_SING_TOL:g})"))
        if any_bad:
            x[bad_kin] = np.nan
        x_all[:, cs] = x
        for q, lk, e in outside:
            xv = x[:, q]
            k = li[lk]
            known[:, k, 0] += e[0] * xv
            known[:, k, 1] += e[1] * xv
            known[:, k, 2] += e[2] * xv
        solved_blocks.append(tuple(links))
    status = state.status
    if singular:
        status = np.array(status, dtype=object).copy()
        for mask, why in singular:
            status[mask & (status == "ok")] = why
        n_sing = int(np.sum(np.any([mk for mk, _ in singular], axis=0)))
        warnings.warn(f"kinetostatics: {n_sing} singular position(s) marked in status (NaN)",
                      SingularityWarning, stacklevel=2)

    npairs = len(pairs)
    reactions = np.zeros((N, npairs, 2))
    pm = np.zeros((N, npairs))
    normal = np.zeros((N, npairs))
    bal = np.zeros((N, len(m.drivers)))
    for ci, c in enumerate(cols):
        kind, i = c[0], c[1]
        if kind == "Rx":
            reactions[:, i, 0] = x_all[:, ci]
        elif kind == "Ry":
            reactions[:, i, 1] = x_all[:, ci]
        elif kind == "PN":
            t = axes[c[4]]
            reactions[:, i] = x_all[:, ci, None] * np.stack([-t[:, 1], t[:, 0]], axis=-1)
            normal[:, i] = x_all[:, ci]
        elif kind == "PM":
            pm[:, i] = x_all[:, ci]
        else:
            bal[:, i] = x_all[:, ci]
    rates = _driver_rates(state)
    bal_power = np.sum(bal * rates, axis=1)
    load_power = P.sum(axis=1)
    resid = bal_power + load_power
    scale = np.abs(bal * rates).sum(axis=1) + AP.sum(axis=1)
    if singular or any_bad:
        fail = status != "ok"
        for arr in (reactions, pm, bal, normal):
            arr[fail] = np.nan
        resid = np.where(fail, np.nan, resid)
    return ForceResult(m, state, tuple(pairs), reactions, pm, bal, rates, Fi, Mi, load_power,
                       resid, scale, status, used, tuple(solved_blocks), tuple(notes), normal)


def _driver_rates(state: KinematicState) -> np.ndarray:
    m = state.mechanism
    out = np.zeros((state.n_positions, len(m.drivers)))
    for i, d in enumerate(m.drivers):
        j = m.joint(d.joint)
        a, b = d.links
        if j.kind is JointKind.P:
            Pj = state.positions[:, state.joint_index(j.name)]
            va = _material_velocity(state, a, Pj)
            vb = _material_velocity(state, b, Pj)
            t = _axis_now(state, j)
            if a != j.links[0]:
                t = -t
            out[:, i] = np.einsum("ni,ni->n", vb - va, t)
        else:
            out[:, i] = state.omegas[:, state.link_index(b)] - state.omegas[:, state.link_index(a)]
    return out


def _solve_state(m: Mechanism, inputs, speeds, accelerations) -> KinematicState:
    """Kinematics at the drivers' speeds and accelerations through :mod:`kin.solve`.

    Accelerations: ``q̈ = Σ q_ij ω_i ω_j + Σ q_i ε_i``: the state solved at input rates
    ``ω`` (zero input acceleration) plus the first-order analogues times ``ε``.
    """
    try:
        from multiloop.kin.solve import solve  # noqa: PLC0415
    except ImportError as exc:  # pragma: no cover - until kin.solve exists
        raise InputError(explain("forces", expected="a KinematicState (kin.solve is not available)",
                                 got="driver inputs")) from exc
    w, e = driver_speeds(m, speeds, accelerations)
    q = np.asarray(inputs, float)
    if q.ndim == 1:
        q = q[:, None] if len(m.drivers) == 1 else q[None, :]
    st = solve(m, q, derivatives=True, input_rates=w)
    if not np.any(e):
        return st
    acc = st.accelerations.copy()
    eps = st.epsilons.copy()
    for k in range(len(m.drivers)):
        if e[k] == 0.0:
            continue
        unit = np.zeros(len(m.drivers))
        unit[k] = 1.0
        s1 = solve(m, q, derivatives=True, input_rates=unit)
        acc += s1.velocities * e[k]
        eps += s1.omegas * e[k]
    return KinematicState(st.mechanism, st.inputs, st.positions, st.angles, st.status,
                          st.velocities, acc, st.omegas, eps, st.input_rates, st.branches)
