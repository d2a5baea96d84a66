"""The kinetostatic solve, in named phases (method: docs/forces.md).

:func:`forces` = state → compiled plan (:func:`.plan.compile_forces`) → known loads
(:func:`.loads.link_loads`) → pose of the unknowns (:class:`_Geometry`) → blocks
solved in order, each solved block's reactions becoming known loads on earlier links
(:func:`_solve_blocks`) → unknowns unpacked into pairs and drivers (:class:`_Unpacked`)
→ virtual-power check (:func:`_power_check`) → :class:`ForceResult`.
"""
from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from multiloop.topo.errors import InputError, SingularityWarning, explain
from multiloop.topo.model import MAX_ANGLE_DEG, MAX_SLIDE_SIZES, JointKind, Mechanism

from ..motion import DriverMotion
from ..solve import check_finite_inputs
from ..state import KinematicState
from .linsolve import SING_TOL, solve_sparse
from .loads import (LoadColumns, PointLoad, StateColumns, check_mass_data, driver_speeds, load_columns, table_period,
                    transpose_batch)
from .plan import Column, ForcePlan, compile_forces
from .result import VP_TOL, ForceResult

__all__ = ["forces", "reduce_inputs", "MAX_ANGLE_DEG", "MAX_SLIDE_SIZES"]


@dataclass(frozen=True)
class _Geometry:
    """Where the unknowns act at every position: joint points, P-joint axes (turned
    with the guide), and the link index of each name."""

    joints: dict
    axes: dict
    link_index: dict


@dataclass(frozen=True)
class _Solved:
    """All unknowns (one (N,) array per column) and the singular-position masks with
    reasons."""

    x: list
    singular: tuple


@dataclass(frozen=True)
class _Unpacked:
    reactions: np.ndarray
    pair_moments: np.ndarray
    normal: np.ndarray
    balancing: np.ndarray


def _geometry(state: KinematicState, cols: StateColumns) -> _Geometry:
    """Joint points and P-joint axes (turned with the guide, ``links[0]``) as (x, y)
    pairs of contiguous (N,) vectors."""
    m = state.mechanism
    joints = {j.name: (cols.get("positions", k, 0), cols.get("positions", k, 1)) for k, j in enumerate(m.joints)}
    axes = {}
    for j in m.joints:
        if j.kind is not JointKind.P:
            continue
        ax = np.asarray(j.axis, float) / np.hypot(*j.axis)
        if m.link(j.links[0]).is_frame:                  # a fixed guide: a constant axis
            axes[j.name] = (float(ax[0]), float(ax[1]))
            continue
        th = cols.get("angles", m.link_names.index(j.links[0]))
        c, s = np.cos(th), np.sin(th)
        axes[j.name] = (c * ax[0] - s * ax[1], s * ax[0] + c * ax[1])
    return _Geometry(joints, axes, {x: k for k, x in enumerate(m.link_names)})


def _effect(c: Column, link: str, geo: _Geometry, G: dict, arms: dict):
    """Force (fx, fy) and moment about G of ``link`` per unit unknown ``c`` acting on
    ``link``: each ``None`` (zero), a float or an (N,) array.  ``arms`` caches the
    lever arms ``joint − G``."""
    sgn = 1.0 if link == c.b else -1.0
    if c.kind in ("PM", "DR"):
        return None, None, sgn
    if (c.joint, link) not in arms:
        jx, jy = geo.joints[c.joint]
        gx, gy = G[geo.link_index[link]]
        arms[c.joint, link] = (jx - gx, jy - gy)
    rx, ry = arms[c.joint, link]
    if c.kind == "Rx":
        return sgn, None, -ry if sgn > 0 else ry
    if c.kind == "Ry":
        return None, sgn, rx if sgn > 0 else -rx
    tx, ty = geo.axes[c.joint]
    dx, dy = (-ty, tx) if c.kind == "PN" else (tx, ty)
    if sgn < 0:
        dx, dy = -dx, -dy
    return dx, dy, rx * dy - ry * dx


def _add(a, b):
    return b if a is None else a + b


def _block_system(fp: ForcePlan, links, cols, geo: _Geometry, G, frame: set):
    """The sparse entry table of one block and the effects of its unknowns on links
    outside it (solved later)."""
    rows = {x: r for r, x in enumerate(links)}
    arms: dict = {}
    table = [[None] * len(cols) for _ in range(3 * len(links))]
    outside = []
    for q, ci in enumerate(cols):
        c = fp.columns[ci]
        for lk in (c.a, c.b):
            if lk in frame:
                continue
            e = _effect(c, lk, geo, G, arms)
            if lk not in rows:
                outside.append((q, lk, e))
                continue
            for d in range(3):
                if e[d] is not None:
                    table[3 * rows[lk] + d][q] = _add(table[3 * rows[lk] + d][q], e[d])
    return table, outside


def _solve_blocks(fp: ForcePlan, state: KinematicState, loads: LoadColumns, geo: _Geometry,
                  check: bool) -> _Solved:
    """Solve the blocks in order; each block's unknowns load the earlier links."""
    m = state.mechanism
    N = state.n_positions
    frame = {lk.name for lk in m.links if lk.is_frame}
    known = {k: [loads.fx[k], loads.fy[k], loads.mz[k]] for k in loads.G}
    x_all: list = [None] * len(fp.columns)
    bad_kin = np.asarray(state.status != "ok", bool)
    any_bad = bool(bad_kin.any())
    singular = []
    for block in fp.blocks:
        table, outside = _block_system(fp, block.links, block.columns, geo, loads.G, frame)
        rhs = [-np.broadcast_to(known[geo.link_index[x]][d], (N,)) for x in block.links for d in range(3)]
        x, det = solve_sparse(table, rhs, N, check, transposed=True)
        sing = ~(det > SING_TOL) if check else ~np.isfinite(x).all(axis=0)
        if any_bad:
            sing &= ~bad_kin
            x[:, bad_kin] = np.nan
        if sing.any():
            singular.append((sing, f"singular: block {{{', '.join(block.links)}}} (scaled det < {SING_TOL:g})"))
        for q, ci in enumerate(block.columns):
            x_all[ci] = x[q]
        for q, lk, e in outside:
            kk = known[geo.link_index[lk]]
            for d in range(3):
                if e[d] is not None:
                    kk[d] = kk[d] + e[d] * x[q]
    return _Solved(x_all, tuple(singular))


def _unpack(fp: ForcePlan, sol: _Solved, geo: _Geometry, N: int, n_drivers: int) -> _Unpacked:
    npairs = len(fp.pairs)
    zero = np.zeros(N)
    rx, ry, pm, nn = [zero] * npairs, [zero] * npairs, [zero] * npairs, [zero] * npairs
    bal = [zero] * n_drivers
    x = sol.x
    for ci, c in enumerate(fp.columns):
        v = x[ci]
        if c.kind == "Rx":
            rx[c.index] = v
        elif c.kind == "Ry":
            ry[c.index] = v
        elif c.kind == "PN":
            tx, ty = geo.axes[c.joint]
            rx[c.index], ry[c.index], nn[c.index] = -v * ty, v * tx, v
        elif c.kind == "PM":
            pm[c.index] = v
        else:
            bal[c.index] = v
    xy = [v for pair in zip(rx, ry) for v in pair]
    return _Unpacked(_rows_to_batch(xy, N).reshape(N, npairs, 2), _rows_to_batch(pm, N),
                     _rows_to_batch(nn, N), _rows_to_batch(bal, N))


def _rows_to_batch(rows: list, N: int) -> np.ndarray:
    """(N,) rows as the columns of a fresh ``(N, len(rows))`` array."""
    if not rows:
        return np.zeros((N, 0))
    return transpose_batch(np.stack(rows))


def _driver_rates(state: KinematicState, geo: _Geometry) -> np.ndarray:
    """Relative speed of every driver: ω_b − ω_a (R) or the slide rate along the axis (P)."""
    m = state.mechanism
    out = np.zeros((state.n_positions, len(m.drivers)))
    for i, d in enumerate(m.drivers):
        j = m.joint(d.joint)
        a, b = d.links
        if j.kind is JointKind.R:
            out[:, i] = state.omegas[:, state.link_index(b)] - state.omegas[:, state.link_index(a)]
            continue
        vel = {}
        for lk in (a, b):
            vel[lk] = state.point_on_link(lk, j.at)[1]
        sg = 1.0 if a == j.links[0] else -1.0
        tx, ty = geo.axes[j.name]
        dv = vel[b] - vel[a]
        out[:, i] = sg * (dv[:, 0] * tx + dv[:, 1] * ty)
    return out


def _power_check(u: _Unpacked, rates: np.ndarray, load_power, load_abs):
    """Virtual power: ``Σ T·rate + Σ load power`` is zero for ideal pairs.  Returns
    (residual, scale, relative residual)."""
    resid = np.sum(u.balancing * rates, axis=1) + load_power
    scale = np.abs(u.balancing * rates).sum(axis=1) + load_abs
    ok = np.isfinite(scale)
    ref = np.max(scale[ok]) if ok.any() and np.any(scale[ok] > 0) else 1.0
    with np.errstate(invalid="ignore"):
        rel = np.abs(resid) / np.maximum(scale, 1e-12 * ref)
    return resid, scale, rel


def _status(state: KinematicState, sol: _Solved, rel: np.ndarray) -> np.ndarray:
    """Kinematic status, then singular blocks, then a virtual-power residual above
    ``VP_TOL``: the first reason wins."""
    status = np.array(state.status, dtype=object)
    ok = status == "ok"
    for mask, why in sol.singular:
        status[mask & ok] = why
        ok &= ~mask
    with np.errstate(invalid="ignore"):
        vp_bad = ok & ~(rel <= VP_TOL)
    for n in np.flatnonzero(vp_bad):
        status[n] = f"virtual power: relative residual {rel[n]:.2g} > {VP_TOL:g}"
    if sol.singular:
        n_sing = int(np.sum(np.any([mk for mk, _ in sol.singular], axis=0)))
        warnings.warn(f"kinetostatics: {n_sing} singular position(s) marked in status (NaN)",
                      SingularityWarning, stacklevel=3)
    return status


def _state_of(m: Mechanism, state_or_inputs, speeds, accelerations) -> KinematicState:
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
    return state


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
        reference configuration), solved with :func:`kin.solve.solve` at ``speeds``
        and ``accelerations``.
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
        ``False`` marks only positions that cannot be solved at all.

    Returns
    -------
    ForceResult
        A position is ``ok`` when its kinematics are, no block is singular, and the
        relative virtual-power residual is at most ``VP_TOL`` (1e-6).

    Raises
    ------
    MobilityError
        The equations are not square (drivers do not match the mobility).
    InputError
        Unknown method, missing geometry, negative mass or inertia, a force table
        with repeated angles.

    Notes
    -----
    Per block one sparse batched elimination (:func:`.linsolve.solve_sparse`).

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
    fp = compile_forces(m, method, plan)
    check_mass_data(m)
    state = _state_of(m, state_or_inputs, speeds, accelerations)
    loads = load_columns(state, extra_loads, include_file_loads, gravity)
    geo = _geometry(state, loads.columns)
    sol = _solve_blocks(fp, state, loads, geo, check)
    u = _unpack(fp, sol, geo, state.n_positions, len(m.drivers))
    rates = _driver_rates(state, geo)
    load_power, load_abs = loads.total_power()
    resid, scale, rel = _power_check(u, rates, load_power, load_abs)
    status = _status(state, sol, rel)
    resid = _blank_failures(u, status, state, sol, resid)
    fi, mi = _inertia_arrays(loads, state.n_positions, m.n_links)
    return ForceResult(m, state, fp.pairs, u.reactions, u.pair_moments, u.balancing, rates,
                       fi, mi, np.broadcast_to(load_power, resid.shape).copy(), resid, scale,
                       status, fp.method, tuple(b.links for b in fp.blocks), fp.notes, u.normal)


def _blank_failures(u: _Unpacked, status, state: KinematicState, sol: _Solved, resid):
    """NaN for every unknown of a failed position; the residual stays visible where
    only the virtual-power check failed."""
    fail = status != "ok"
    if not fail.any():
        return resid
    for arr in (u.reactions, u.pair_moments, u.balancing, u.normal):
        arr[fail] = np.nan
    return np.where(fail & (np.asarray(state.status) != "ok") | _sing_mask(sol, len(status)), np.nan, resid)


def _inertia_arrays(loads: LoadColumns, N: int, nl: int):
    zero = np.zeros(N)
    rows = [loads.inertia.get(k, (zero, zero, zero)) for k in range(nl)]
    fi = _rows_to_batch([v for r in rows for v in r[:2]], N).reshape(N, nl, 2)
    return fi, _rows_to_batch([r[2] for r in rows], N)


def _sing_mask(sol: _Solved, n: int) -> np.ndarray:
    return np.any([mk for mk, _ in sol.singular], axis=0) if sol.singular else np.zeros(n, bool)




def reduce_inputs(m: Mechanism, inputs, degrees: bool = False) -> np.ndarray:
    """Driver inputs ``(N, n_drivers)``; an R input beyond one load period ``p``
    (360 deg, or 720 deg when a force table spans two turns) is reduced modulo ``p``
    into ``[0, p)``.  ``degrees``: R inputs are given in degrees (reduced exactly
    before the conversion); the result is in radians and metres.

    Positions, velocities and loads are periodic in an R input, so the reduction
    changes nothing but the solver's lead-in from the reference (which would otherwise
    walk 2 deg steps all the way: 5·10⁸ of them for 1e9 deg).

    Raises
    ------
    InputError
        A non-finite input, an R input beyond ``MAX_ANGLE_DEG``, or a P input beyond
        ``MAX_SLIDE_SIZES`` × the mechanism's size (the limits are stated).
    """
    q = np.array(inputs, float)
    if q.ndim == 1:
        q = q[:, None] if len(m.drivers) == 1 else q[None, :]
    check_finite_inputs(m, q, "driver inputs")
    period = table_period(m) if degrees else np.radians(table_period(m))
    limit = MAX_ANGLE_DEG if degrees else np.radians(MAX_ANGLE_DEG)
    size = m.size
    for k, d in enumerate(m.drivers):
        col = q[:, k]
        if m.is_rotary(d):
            if np.any(np.abs(col) > limit):
                big = np.max(np.abs(col)) * (1.0 if degrees else 180.0 / np.pi)
                raise InputError(explain(f"input of driver {d.joint!r}", expected=f"at most {MAX_ANGLE_DEG:g} deg in magnitude",
                                         got=f"{big:.6g} deg"))
            q[:, k] = np.where(np.abs(col) > period, np.mod(col, period), col)
            if degrees:
                q[:, k] = np.radians(q[:, k])
        elif np.any(np.abs(col) > MAX_SLIDE_SIZES * size):
            raise InputError(explain(f"input of driver {d.joint!r}",
                                     expected=f"at most {MAX_SLIDE_SIZES:g} x the mechanism's size = {MAX_SLIDE_SIZES * size:.6g} m",
                                     got=f"{np.max(np.abs(col)):.6g} m",
                                     hint="the solver walks from the reference in steps of 1 % of the size"))
    return q


def _solve_state(m: Mechanism, inputs, speeds, accelerations) -> KinematicState:
    """Kinematics at the drivers' speeds and accelerations through :mod:`kin.solve`,
    at the inputs reduced by :func:`reduce_inputs`.

    Accelerations: ``q̈ = Σ q_ij ω_i ω_j + Σ q_i ε_i``: the state solved at input rates
    ``ω`` (zero input acceleration) plus the first-order analogues times ``ε``.
    """
    from multiloop.kin.solve import solve  # noqa: PLC0415 - kin.solve imports the groups lazily
    w, e = driver_speeds(m, speeds, accelerations)
    q = reduce_inputs(m, inputs)
    st = solve(m, q, derivatives=True, input_rates=w)
    if not np.any(e):
        return st
    acc = st.accelerations.copy()
    eps = st.epsilons.copy()
    for k in range(len(m.drivers)):
        if e[k] == 0.0:
            continue
        s1 = solve(m, q, derivatives=True, input_rates=DriverMotion.held(m, k).rates())
        acc += s1.velocities * e[k]
        eps += s1.omegas * e[k]
    return dataclasses.replace(st, accelerations=acc, epsilons=eps)   # every other field kept
