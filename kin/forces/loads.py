"""Known loads of the kinetostatics: applied forces, weight and d'Alembert inertia.

Every moving link carries its applied loads (the file's ``[[force]]`` tables and
:class:`PointLoad` arrays), its weight ``m g`` and its inertia force ``−m a_G`` with
inertia moment ``−J_G ε`` (d'Alembert's principle; Vasilenko et al. 2018), all
reduced to the centre of mass G.  The power of these loads feeds the virtual-power
check of :func:`~kin.forces.forces`.

Defaults: a link's centre of mass is the centroid of its joints' reference points, its
inertia 0; a link without ``mass`` carries no weight and no inertia force, but its
moment of inertia still gives the couple ``−J_G ε``; a ``[[force]]``
without ``at`` acts at G; a force table is interpolated linearly against the first
driver's input (deg), periodic over 360 deg, or over 720 deg when a row lies beyond
360 deg.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple, Sequence

import numpy as np

from multiloop.topo.errors import InputError, explain
from multiloop.topo.model import Mechanism

from ..state import KinematicState

__all__ = ["PointLoad", "LinkLoads", "LoadColumns", "StateColumns", "link_loads", "load_columns", "kinetic_energy", "potential_energy",
           "driver_speeds", "cg_ref", "check_mass_data", "table_period", "has_loads",
           "transpose_batch"]


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


class LinkLoads(NamedTuple):
    """Known loads per position and link (leading axis positions, then links)."""

    force: np.ndarray          # (N, n_links, 2) applied + weight + inertia, at G
    moment: np.ndarray         # (N, n_links) about G
    power: np.ndarray          # (N, n_links) power of these loads (W)
    abs_power: np.ndarray      # (N, n_links) sum of the magnitudes of the power terms
    inertia_force: np.ndarray  # (N, n_links, 2)
    inertia_moment: np.ndarray  # (N, n_links)
    G: np.ndarray              # (N, n_links, 2) centre of mass
    vG: np.ndarray             # (N, n_links, 2) its velocity


def cg_ref(m: Mechanism, link: str) -> tuple[float, float]:
    """Centre of mass of ``link`` in the reference configuration (default: the centroid
    of its joints' reference points)."""
    lk = m.link(link)
    if lk.cg is not None:
        return lk.cg
    pts = [j.at for j in m.joints_of(link) if j.at is not None]
    if not pts:
        raise InputError(explain(f"link '{link}'", expected="a centre of mass 'cg' or joint positions",
                                 got="neither"))
    return (float(np.mean([p[0] for p in pts])), float(np.mean([p[1] for p in pts])))


def check_mass_data(m: Mechanism) -> None:
    """Reject physically meaningless mass data and loads, naming the fault.

    Raises
    ------
    InputError
        A negative mass or moment of inertia; a force table with repeated angles.
    """
    for lk in m.links:
        for key in ("mass", "inertia"):
            v = getattr(lk, key)
            if v is not None and not v >= 0:
                raise InputError(explain(f"link '{lk.name}' {key}", expected="a value >= 0", got=repr(v),
                                         hint="a mass or a moment of inertia cannot be negative"))
    for i, ld in enumerate(m.loads, 1):
        if ld.table is None:
            continue
        angles = [r[0] for r in ld.table]
        dup = sorted({a for a in angles if angles.count(a) > 1})
        if dup:
            raise InputError(explain(f"[[force]] #{i} on '{ld.link}' table", expected="distinct input angles",
                                     got=f"{', '.join(f'{a:g}' for a in dup)} deg more than once",
                                     hint="a table gives one force per angle"))


def has_loads(m: Mechanism) -> bool:
    """True when the mechanism carries any load: a link mass or a ``[[force]]``
    (without them every reaction and balancing moment is zero)."""
    return bool(m.loads) or any(lk.mass or lk.inertia for lk in m.links if not lk.is_frame)


def table_period(m: Mechanism) -> float:
    """360 deg, or 720 deg when a force table has a row beyond 360 deg."""
    rows = [r[0] for ld in m.loads if ld.table is not None for r in ld.table]
    return 720.0 if rows and max(rows) > 360.0 else 360.0


def _table_force(load, input_deg: np.ndarray) -> np.ndarray:
    rows = np.asarray(load.table, float)
    period = 720.0 if rows[:, 0].max() > 360.0 else 360.0
    rows = rows[np.argsort(rows[:, 0])]
    x = np.mod(input_deg, period)
    fx = np.interp(x, rows[:, 0], rows[:, 1], period=period)
    fy = np.interp(x, rows[:, 0], rows[:, 2], period=period)
    return np.stack([fx, fy], axis=-1)


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


def _gravity(m: Mechanism, gravity) -> np.ndarray:
    return np.asarray(gravity if gravity is not None else (m.gravity or (0.0, 0.0)), float)


class StateColumns:
    """Contiguous per-index columns of a state's arrays.  The state stores positions as
    (N, n, 2); batched arithmetic is fastest on contiguous (N,) vectors, so each array
    is transposed once (one pass) and its columns are views."""

    def __init__(self, state: KinematicState):
        self.state = state
        self._cache: dict = {}

    def get(self, name: str, k: int, c: int | None = None) -> np.ndarray:
        if name not in self._cache:
            self._cache[name] = transpose_batch(np.asarray(getattr(self.state, name), float))
        t = self._cache[name]
        return t[k] if c is None else t[k, c]


def transpose_batch(a: np.ndarray, block: int = 4096) -> np.ndarray:
    """``a (N, ...)`` as a contiguous ``(..., N)`` array, copied in cache-sized blocks
    (about 5x faster than one strided copy for N = 10⁵); on ``(K, N)`` it gives the
    contiguous ``(N, K)``."""
    N = a.shape[0]
    flat = a.reshape(N, -1)
    out = np.empty((flat.shape[1], N))
    for i in range(0, N, block):
        out[:, i:i + block] = flat[i:i + block].T
    return out.reshape(a.shape[1:] + (N,))


def _point_motion(cols: StateColumns, m: Mechanism, k: int, anchor: int, at, acceleration: bool = True) -> tuple:
    """Rigid transport of the material point of link ``k`` that sat at ``at``:
    ``P = X + R(θ) r``, ``v = v_X + ω × r'``, ``a = a_X + ε × r' − ω² r'``, ``r' = R(θ) r``
    (Vasechkin et al. 2017, eqs. (4)–(8)).  Returns ((x, y), (vx, vy), (ax, ay) or None)."""
    P = (cols.get("positions", anchor, 0), cols.get("positions", anchor, 1))
    V = (cols.get("velocities", anchor, 0), cols.get("velocities", anchor, 1))
    A = (cols.get("accelerations", anchor, 0), cols.get("accelerations", anchor, 1)) if acceleration else None
    rx, ry = np.subtract(at, m.joints[anchor].at)
    if rx == 0.0 and ry == 0.0:
        return P, V, A
    th, w = cols.get("angles", k), cols.get("omegas", k)
    c, s = np.cos(th), np.sin(th)
    px, py = c * rx - s * ry, s * rx + c * ry
    vel = (V[0] - w * py, V[1] + w * px)
    if not acceleration:
        return (P[0] + px, P[1] + py), vel, None
    e, w2 = cols.get("epsilons", k), w * w
    acc = (A[0] - e * py - w2 * px, A[1] + e * px - w2 * py)
    return (P[0] + px, P[1] + py), vel, acc


@dataclass
class LoadColumns:
    """Known loads per moving link as contiguous (N,) vectors (internal layout of
    :func:`link_loads`); dictionaries keyed by link index."""

    fx: dict
    fy: dict
    mz: dict
    power: dict
    abs_power: dict
    G: dict
    inertia: dict
    columns: "StateColumns"

    def total_power(self) -> tuple:
        """Power of all known loads and the sum of the magnitudes of its terms (W)."""
        return sum(self.power.values(), 0.0), sum(self.abs_power.values(), 0.0)


def _inertia_columns(state: KinematicState, cols: StateColumns, g: np.ndarray) -> LoadColumns:
    m = state.mechanism
    out = LoadColumns({}, {}, {}, {}, {}, {}, {}, cols)
    for k, lk in enumerate(m.links):
        if lk.is_frame:
            continue
        G, vG, aG = _point_motion(cols, m, k, state._anchor(lk.name), cg_ref(m, lk.name))
        out.G[k] = G
        out.power[k], out.abs_power[k] = 0.0, 0.0
        mass, inertia = lk.mass or 0.0, lk.inertia or 0.0
        if not mass and not inertia:
            out.fx[k], out.fy[k], out.mz[k] = 0.0, 0.0, 0.0
            continue
        fix, fiy = -mass * aG[0], -mass * aG[1]
        mi = -inertia * cols.get("epsilons", k)
        out.inertia[k] = (fix, fiy, mi)
        out.fx[k], out.fy[k], out.mz[k] = fix + mass * g[0], fiy + mass * g[1], mi
        p1 = fix * vG[0] + fiy * vG[1]
        p2 = mi * cols.get("omegas", k)
        p3 = mass * (g[0] * vG[0] + g[1] * vG[1])
        out.power[k] = p1 + p2 + p3
        out.abs_power[k] = np.abs(p1) + np.abs(p2) + np.abs(p3)
    return out


def _applied_terms(state: KinematicState, cols: StateColumns, loads: Sequence, out: LoadColumns) -> None:
    """Applied forces and couples into ``out`` (in place)."""
    m = state.mechanism
    N = state.n_positions
    input_deg = np.degrees(state.inputs[:, 0]) if state.inputs.size else np.zeros(N)
    for ld in loads:
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
        fx, fy = np.ascontiguousarray(f[:, 0]), np.ascontiguousarray(f[:, 1])
        at = ld.at if ld.at is not None else cg_ref(m, ld.link)
        (px, py), (vx, vy), _ = _point_motion(cols, m, k, state._anchor(ld.link), at, acceleration=False)
        rx, ry = px - out.G[k][0], py - out.G[k][1]
        out.fx[k] = out.fx[k] + fx
        out.fy[k] = out.fy[k] + fy
        out.mz[k] = out.mz[k] + mom + rx * fy - ry * fx
        p1 = fx * vx + fy * vy
        p2 = mom * cols.get("omegas", k)
        out.power[k] = out.power[k] + p1 + p2
        out.abs_power[k] = out.abs_power[k] + np.abs(p1) + np.abs(p2)


def load_columns(state: KinematicState, extra_loads: Sequence[PointLoad] = (),
                 include_file_loads: bool = True, gravity=None) -> LoadColumns:
    """Known loads on every moving link reduced to its centre of mass, as columns."""
    m = state.mechanism
    cols = StateColumns(state)
    out = _inertia_columns(state, cols, _gravity(m, gravity))
    loads = (list(m.loads) if include_file_loads else []) + list(extra_loads)
    _applied_terms(state, cols, loads, out)
    return out


def link_loads(state: KinematicState, extra_loads: Sequence[PointLoad] = (),
               include_file_loads: bool = True, gravity=None) -> LinkLoads:
    """Known loads on every moving link, reduced to the centre of mass.

    Returns
    -------
    LinkLoads
        ``force`` (N, n_links, 2) and ``moment`` (N, n_links) resultants of the applied,
        gravity and inertia loads about G; their ``power`` and ``abs_power`` (sum of
        magnitudes of the power terms, W; per link); ``inertia_force``,
        ``inertia_moment``; the centre of mass ``G`` and its velocity ``vG``.
    """
    m = state.mechanism
    N, nl = state.n_positions, m.n_links
    lc = load_columns(state, extra_loads, include_file_loads, gravity)
    out = LinkLoads(np.zeros((N, nl, 2)), np.zeros((N, nl)), np.zeros((N, nl)), np.zeros((N, nl)),
                    np.zeros((N, nl, 2)), np.zeros((N, nl)), np.zeros((N, nl, 2)), np.zeros((N, nl, 2)))
    for k in lc.G:
        out.force[:, k, 0], out.force[:, k, 1], out.moment[:, k] = lc.fx[k], lc.fy[k], lc.mz[k]
        out.G[:, k, 0], out.G[:, k, 1] = lc.G[k]
        out.power[:, k], out.abs_power[:, k] = lc.power[k], lc.abs_power[k]
        out.vG[:, k] = state.point_on_link(m.links[k].name, cg_ref(m, m.links[k].name))[1]
        if k in lc.inertia:
            out.inertia_force[:, k, 0], out.inertia_force[:, k, 1], out.inertia_moment[:, k] = lc.inertia[k]
    return out


def kinetic_energy(state: KinematicState) -> np.ndarray:
    """``T = Σ ½ m |v_G|² + ½ J_G ω²`` (J) per position."""
    m = state.mechanism
    T = np.zeros(state.n_positions)
    for k, lk in enumerate(m.links):
        if lk.is_frame or not (lk.mass or lk.inertia):
            continue
        _, v, _ = state.point_on_link(lk.name, cg_ref(m, lk.name))
        T += 0.5 * (lk.mass or 0.0) * np.einsum("ni,ni->n", v, v) + 0.5 * (lk.inertia or 0.0) * state.omegas[:, k] ** 2
    return T


def potential_energy(state: KinematicState, gravity=None) -> np.ndarray:
    """``U = −Σ m g·G`` (J) per position."""
    m = state.mechanism
    g = _gravity(m, gravity)
    U = np.zeros(state.n_positions)
    for lk in m.links:
        if lk.is_frame or not lk.mass:
            continue
        pos, _, _ = state.point_on_link(lk.name, cg_ref(m, lk.name))
        U -= lk.mass * (pos @ g)
    return U
