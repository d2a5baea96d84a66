"""Crank–slider engines: single cylinder (with offset), V-twin and radial on one crank pin.

Everything here follows ``docs/forces.md`` and Vasilenko et al. 2018 (Vasilenko et al.
2018).  Conventions:

* crank centre O at the origin; the crank turns counter-clockwise, crank angle φ
  measured from cylinder 1's axis, crank pin ``A = r e(γ_1 + φ)``;
* cylinder j has the axis ``u_j = e(γ_j)`` (towards the head; ``γ_j`` is its ``bank``
  angle) and the normal ``n_j = e(γ_j + 90°)``; its local crank angle is
  ``θ_j = φ + γ_1 − γ_j`` (0 at its top dead centre when the offset is 0);
* the wrist pin B_j is offset by ``e`` (``offset``) along ``n_j``: ``B_j = x u_j + e n_j``;
* the rod's centre of mass ``G = A + k (B − A)``, ``k = |AG| / l`` from the crank pin
  (the seed program's "o"); rod inertia ``J_G`` about G (``m ρ²`` with the paper's radius
  of inertia ρ);
* all rods of a V-twin or a radial engine share the crank pin A: one multiple joint
  (crank + N rods, N pairs; Pozhbelko & Kuts 2020 example 2 for N = 5);
* four-stroke cycle angle of cylinder j: ``ψ_j = (φ − δ_j − Δ_j) mod 720`` with the
  lag ``δ_j = (γ_j − γ_1) mod 360`` (the crank reaches cylinder j δ_j after cylinder 1)
  and ``Δ_j ∈ {0, 360}`` (``firing``); firing TDC at ψ = 360.

Kinematics are exact (offset formulas); the λ-approximation is computed only
to show its error.  Forces: the closed form for every cylinder's RRP dyad
(rod + piston), then the crank: ``M_b = A × Σ_j R12_j + J_1 ε``.  The general
kinetostatics (:func:`kin.forces.forces`) on :func:`engine_mechanism` is the second
route; virtual power and the energy rate are the checks, and over a cycle at constant
speed ``∮ M_b dφ = −W_ind``.

Engine file (TOML)
------------------
See ``docs/forces.md``; :func:`load_engine` reads it, :func:`engine_from_dict` parses a
document.  Every bad key or value raises :class:`~topo.errors.InputError` naming it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from multiloop.topo.errors import InputError, explain
from multiloop.topo.model import Driver, Mechanism, MechanismBuilder

from ..forces import PointLoad, forces
from ..forces.result import json_list
from ..result import json_ready
from .files import engine_from_dict, load_engine
from .gas import STROKES, IndicatorDiagram
from .model import Cylinder, EngineSpec
from ..state import KinematicState

__all__ = ["Cylinder", "EngineSpec", "EngineResult", "load_engine", "engine_from_dict",
           "engine_mechanism", "piston_kinematics", "lambda_approximation", "engine_state",
           "engine_reactions", "analyse_engine", "seed004_rod_com", "cyclogram", "MAX_STEPS"]


# --------------------------------------------------------------------------- kinematics
def piston_kinematics(theta, r: float, l: float, e: float = 0.0) -> dict[str, np.ndarray]:
    """Exact wrist-pin and rod motion of one cylinder against its local crank angle.

    ``q = r sinθ − e``, ``R_e = sqrt(l² − q²)`` (docs/forces.md, offset cylinder):
    ``x = r cosθ + R_e``; ``x' = −r sinθ − r cosθ q / R_e``;
    ``x'' = −r cosθ − (r² cos²θ − r sinθ q)/R_e − q² r² cos²θ / R_e³``.
    The rod direction relative to the axis is ``α = atan2(−q, R_e)`` (``= −β``),
    ``α' = −r cosθ / R_e``, ``α'' = r sinθ / R_e − r² cos²θ q / R_e³``.
    Derivatives are with respect to θ (analogues).  Any array shape.
    """
    th = np.asarray(theta, float)
    S, C = np.sin(th), np.cos(th)
    q = r * S - e
    Re = np.sqrt(l * l - q * q)
    x = r * C + Re
    x1 = -r * S - r * C * q / Re
    x2 = -r * C - (r * r * C * C - r * S * q) / Re - q * q * r * r * C * C / Re ** 3
    alpha = np.arctan2(-q, Re)
    a1 = -r * C / Re
    a2 = r * S / Re - r * r * C * C * q / Re ** 3
    return {"x": x, "x1": x1, "x2": x2, "alpha": alpha, "alpha1": a1, "alpha2": a2, "q": q, "Re": Re}


def lambda_approximation(theta, r: float, l: float) -> dict[str, np.ndarray]:
    """The usual second-order approximations (in-line cylinder), per unit ω:
    ``s ≈ r[(1 − cosθ) + (λ/2) sin²θ]``, ``s' ≈ r(sinθ + (λ/2) sin2θ)``,
    ``s'' ≈ r(cosθ + λ cos2θ)`` (travel from TDC, positive towards the crank)."""
    th = np.asarray(theta, float)
    lam = r / l
    return {"s": r * ((1 - np.cos(th)) + 0.5 * lam * np.sin(th) ** 2),
            "s1": r * (np.sin(th) + 0.5 * lam * np.sin(2 * th)),
            "s2": r * (np.cos(th) + lam * np.cos(2 * th))}


def seed004_rod_com(f_deg, r: float, l: float, o: float, n_rpm: float) -> dict[str, np.ndarray]:
    """The seed program's rod centre-of-mass formulas (Vasilenko et al. 2018, Pascal listing; cleaned in
    docs/forces.md), in-line cylinder, x along the axis:

    ``Vx = −S ω − o r² ω sin2f / (2 sqrt(l² − S²))``, ``Vy = (1 − o) C ω``,
    ``Wx = −C ω² − o r² ω² [cos2f / sqrt(l² − S²) + r² sin²2f / (4 (l² − S²)^{3/2})]``,
    ``Wy = −(1 − o) S ω²``, ``Rcp = Vc² / Wn`` with ``C = r cos f``, ``S = r sin f``,
    ``ω = π n / 30``.  Metres (the seed prints Rcp in mm).
    """
    f = np.radians(np.asarray(f_deg, float))
    w = math.pi * n_rpm / 30.0
    C, S = r * np.cos(f), r * np.sin(f)
    root = np.sqrt(l * l - S * S)
    Vx = -S * w - o * (r * r * w * np.sin(2 * f) / (2 * root))
    Vy = (1 - o) * C * w
    Wx = -C * w * w - o * r * r * w * w * (np.cos(2 * f) / root + r * r * np.sin(2 * f) ** 2 / (4 * root ** 3))
    Wy = -(1 - o) * S * w * w
    Vc = np.hypot(Vx, Vy)
    Wc = np.hypot(Wx, Wy)
    Wt = (Wx * Vx + Wy * Vy) / Vc
    Wn = np.sqrt(np.maximum(Wc * Wc - Wt * Wt, 0.0))
    return {"Vx": Vx, "Vy": Vy, "Wx": Wx, "Wy": Wy, "Vc": Vc, "Wc": Wc, "Wt": Wt, "Wn": Wn, "Rcp": Vc * Vc / Wn}


# --------------------------------------------------------------------------- mechanism
def _names(spec: EngineSpec):
    n = spec.n_cylinders
    return ([f"rod{j + 1}" for j in range(n)], [f"piston{j + 1}" for j in range(n)],
            [f"B{j + 1}" for j in range(n)], [f"S{j + 1}" for j in range(n)])


def engine_mechanism(spec: EngineSpec, gas_loads: bool = False, table_step: float = 1.0) -> Mechanism:
    """The engine as a :class:`~topo.model.Mechanism` with masses, in the reference
    configuration φ = 0.

    Links ``frame, crank, rod1, piston1, rod2, …``; joints ``O`` (frame–crank), ``A``
    (crank + every rod: a multiple joint when there are two or more cylinders), ``Bj``
    (rod–piston), ``Sj`` (P: frame guide, piston slider, axis ``u_j``).  The crank's
    centre of mass is at O (balanced crank).  Driver: ``O`` at ``ω = π rpm/30`` and the
    crank acceleration.  Gas forces are not part of the mechanism (they are passed to
    :func:`kin.forces.forces` as arrays by :func:`analyse_engine`) unless ``gas_loads``:
    then each piston gets a ``[[force]]`` table at B_j against the crank angle, sampled
    every ``table_step`` degrees over 720° (linear interpolation between the rows).
    """
    r, l, e, k = spec.crank_radius, spec.rod_length, spec.offset, spec.rod_cg
    g = spec.banks()
    rods, pistons, bs, ss = _names(spec)
    b = MechanismBuilder(name=spec.name, description=spec.description, source=spec.source)
    b.gravity = tuple(spec.gravity) if any(spec.gravity) else None
    b.add_link("frame", frame=True)
    b.add_link("crank", mass=spec.crank_mass, cg=(0.0, 0.0), inertia=spec.crank_inertia)
    A = r * np.array([math.cos(g[0]), math.sin(g[0])])
    B_list = []
    for j in range(spec.n_cylinders):
        u = np.array([math.cos(g[j]), math.sin(g[j])])
        n = np.array([-u[1], u[0]])
        kin = piston_kinematics(g[0] - g[j], r, l, e)
        B = float(kin["x"]) * u + e * n
        B_list.append((B, u))
        G = A + k * (B - A)
        b.add_link(rods[j], mass=spec.rod_mass, cg=tuple(G), inertia=spec.rod_inertia)
        b.add_link(pistons[j], mass=spec.piston_mass, cg=tuple(B), inertia=0.0)
    b.add_joint("O", "R", ("frame", "crank"), at=(0.0, 0.0))
    b.add_joint("A", "R", ("crank", *rods), at=tuple(A))
    for j, (B, u) in enumerate(B_list):
        b.add_joint(bs[j], "R", (rods[j], pistons[j]), at=tuple(B))
        b.add_joint(ss[j], "P", ("frame", pistons[j]), at=tuple(B), axis=tuple(u))
    b.drivers.append(Driver("O", ("frame", "crank"), spec.omega, spec.crank_acceleration))
    if gas_loads and spec.gas is not None:
        deg = np.arange(0.0, 720.0, table_step)
        fg = engine_reactions(spec, np.radians(deg))["Fg"]
        for j, (B, _) in enumerate(B_list):
            rows = tuple((float(d), float(f[0]), float(f[1])) for d, f in zip(deg, fg[:, j]))
            b.add_load(pistons[j], at=tuple(B), table=rows, name=f"gas {spec.cylinders[j].name}")
    return b.build()


@dataclass(frozen=True)
class _Motion:
    """Exact engine motion on a grid (arrays (N,) or (N, n_cyl) or (..., 2))."""

    phi: np.ndarray
    omega: np.ndarray
    eps: np.ndarray
    theta: np.ndarray
    A: np.ndarray
    vA: np.ndarray
    aA: np.ndarray
    B: np.ndarray
    vB: np.ndarray
    aB: np.ndarray
    G: np.ndarray
    vG: np.ndarray
    aG: np.ndarray
    x: np.ndarray
    xd: np.ndarray
    xdd: np.ndarray
    rod_angle: np.ndarray
    rod_omega: np.ndarray
    rod_eps: np.ndarray
    u: np.ndarray
    n: np.ndarray
    x1: np.ndarray


def _motion(spec: EngineSpec, phi, omega=None, eps=None) -> _Motion:
    phi = np.atleast_1d(np.asarray(phi, float))
    N = phi.shape[0]
    w = np.broadcast_to(np.asarray(spec.omega if omega is None else omega, float), (N,))
    ep = np.broadcast_to(np.asarray(spec.crank_acceleration if eps is None else eps, float), (N,))
    r, l, e, k = spec.crank_radius, spec.rod_length, spec.offset, spec.rod_cg
    g = spec.banks()
    u = np.stack([np.cos(g), np.sin(g)], axis=-1)          # (nc, 2)
    n = np.stack([-u[:, 1], u[:, 0]], axis=-1)
    theta = phi[:, None] + g[0] - g[None, :]                # (N, nc)
    kin = piston_kinematics(theta, r, l, e)
    ca = np.stack([np.cos(g[0] + phi), np.sin(g[0] + phi)], axis=-1)
    cp = np.stack([-ca[:, 1], ca[:, 0]], axis=-1)
    A = r * ca
    vA = r * w[:, None] * cp
    aA = r * ep[:, None] * cp - r * (w * w)[:, None] * ca
    xd = kin["x1"] * w[:, None]
    xdd = kin["x2"] * (w * w)[:, None] + kin["x1"] * ep[:, None]
    B = kin["x"][..., None] * u + e * n
    vB = xd[..., None] * u
    aB = xdd[..., None] * u
    G = (1 - k) * A[:, None] + k * B
    vG = (1 - k) * vA[:, None] + k * vB
    aG = (1 - k) * aA[:, None] + k * aB
    rod_angle = g[None, :] + kin["alpha"]
    rod_omega = kin["alpha1"] * w[:, None]
    rod_eps = kin["alpha2"] * (w * w)[:, None] + kin["alpha1"] * ep[:, None]
    return _Motion(phi, w, ep, theta, A, vA, aA, B, vB, aB, G, vG, aG, kin["x"], xd, xdd,
                   rod_angle, rod_omega, rod_eps, u, n, kin["x1"])


def engine_state(spec: EngineSpec, phi, omega=None, eps=None, mechanism: Mechanism | None = None) -> KinematicState:
    """The exact closed-form :class:`~kin.state.KinematicState` of
    :func:`engine_mechanism` at crank angles ``phi`` (rad, from the reference φ = 0),
    with time derivatives at crank speed ``omega`` (default ``spec.omega``, may be an
    array) and acceleration ``eps`` (default ``spec.crank_acceleration``)."""
    m = mechanism or engine_mechanism(spec)
    mo = _motion(spec, phi, omega, eps)
    N, nc = mo.theta.shape
    nj = 2 + 2 * nc
    P = np.zeros((N, nj, 2))
    V = np.zeros_like(P)
    Acc = np.zeros_like(P)
    P[:, 1], V[:, 1], Acc[:, 1] = mo.A, mo.vA, mo.aA
    for j in range(nc):
        for c in (2 + 2 * j, 3 + 2 * j):
            P[:, c], V[:, c], Acc[:, c] = mo.B[:, j], mo.vB[:, j], mo.aB[:, j]
    nl = 2 + 2 * nc
    ang = np.zeros((N, nl))
    om = np.zeros((N, nl))
    ep = np.zeros((N, nl))
    ang[:, 1], om[:, 1], ep[:, 1] = mo.phi, mo.omega, mo.eps
    ref = _motion(spec, np.zeros(1)).rod_angle[0]
    for j in range(nc):
        ang[:, 2 + 2 * j] = mo.rod_angle[:, j] - ref[j]
        om[:, 2 + 2 * j] = mo.rod_omega[:, j]
        ep[:, 2 + 2 * j] = mo.rod_eps[:, j]
    status = np.full(N, "ok", dtype=object)
    rates = np.array([float(mo.omega[0])]) if np.all(mo.omega == mo.omega[0]) else None
    return KinematicState(m, mo.phi[:, None], P, ang, status, V, Acc, om, ep, rates)


# --------------------------------------------------------------------------- forces
def _cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _lags(spec: EngineSpec) -> np.ndarray:
    """``δ_j = (γ_j − γ_1) mod 360`` (deg): the crank reaches cylinder j's axis δ_j after
    cylinder 1's; ``ψ_j = (φ − δ_j − Δ_j) mod 720``."""
    return np.mod(np.array([c.bank for c in spec.cylinders]) - spec.cylinders[0].bank, 360.0)


def _gas_gauge(spec: EngineSpec, phi, mo: _Motion | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Cycle angle ψ (deg), volume V, absolute and gauge pressure, each (N, n_cyl)."""
    mo = mo or _motion(spec, phi)
    psi = np.mod(np.degrees(mo.phi)[:, None] - _lags(spec) - np.array([c.firing for c in spec.cylinders]), 720.0)
    Ap, Vc = spec.piston_area, spec.clearance_volume
    vol = Vc + Ap * (spec.x_tdc - mo.x)
    if spec.gas is None:
        z = np.zeros_like(vol)
        return psi, vol, z, z
    r, l, e = spec.crank_radius, spec.rod_length, spec.offset
    # volumes at ψ = 180 and 360 (local angles 180 + Δ, 360 + Δ: cos/sin periodic)
    v180 = Vc + Ap * (spec.x_tdc - float(piston_kinematics(math.pi, r, l, e)["x"]))
    v360 = Vc + Ap * (spec.x_tdc - float(piston_kinematics(0.0, r, l, e)["x"]))
    p = spec.gas.pressure(psi, vol, v180, v360)
    return psi, vol, p, p - spec.gas.crankcase_pressure


def engine_reactions(spec: EngineSpec, phi, gauge=None, omega=None, eps=None, mo: _Motion | None = None) -> dict[str, np.ndarray]:
    """Closed-form reactions and balancing moment (docs/forces.md), vectorised.

    Parameters
    ----------
    phi : array (N,)
        Crank angle (rad) from cylinder 1's axis.
    gauge : array (N, n_cyl), optional
        Gauge cylinder pressure ``p − p_cc`` (Pa); default from ``spec.gas``.

    Returns
    -------
    dict with ``R12`` (N, nc, 2) crank on rod j at A; ``R23`` (N, nc, 2) rod on piston;
    ``N`` (N, nc) wall normal force along ``n_j`` (through B); ``R01`` (N, 2) frame on
    crank at O; ``Mb`` (N,) balancing moment on the crank (CCW +); ``Fg`` (N, nc, 2) gas
    force; ``power`` (N,) power of applied + inertia loads; ``scale``; ``residual``
    (N,) virtual-power residual ``M_b ω + power`` (W).

    Notes
    -----
    ``W3 = F_g − m3 a_B + m3 g``, ``W2 = −m2 a_G + m2 g``, ``M_i2 = −J_G ε_rod``;
    ``N = −[(B − A) × W3 + (G − A) × W2 + M_i2] / ((B − A) × n)``, ``R23 = −W3 − N n``,
    ``R12 = R23 − W2``; ``R01 = Σ R12 − m1 g``; ``M_b = A × Σ R12 + J_1 ε``.
    """
    mo = mo or _motion(spec, phi, omega, eps)
    if gauge is None:
        gauge = _gas_gauge(spec, phi, mo)[3]
    g = np.asarray(spec.gravity, float)
    m1, m2, m3, J1, J2 = spec.crank_mass, spec.rod_mass, spec.piston_mass, spec.crank_inertia, spec.rod_inertia
    Fg = -(gauge * spec.piston_area)[..., None] * mo.u
    W3 = Fg - m3 * mo.aB + m3 * g
    W2 = -m2 * mo.aG + m2 * g
    Mi2 = -J2 * mo.rod_eps
    A = mo.A[:, None]
    d = mo.B - A
    Nw = -(_cross(d, W3) + _cross(mo.G - A, W2) + Mi2) / _cross(d, np.broadcast_to(mo.n, d.shape))
    R23 = -W3 - Nw[..., None] * mo.n
    R12 = R23 - W2
    sR12 = R12.sum(axis=1)
    R01 = sR12 - m1 * g
    Mb = _cross(mo.A, sR12) + J1 * mo.eps
    terms = [np.einsum("nci,nci->nc", W3, mo.vB).sum(axis=1), np.einsum("nci,nci->nc", W2, mo.vG).sum(axis=1),
             (Mi2 * mo.rod_omega).sum(axis=1), -J1 * mo.eps * mo.omega]
    power = sum(terms)
    scale = sum(np.abs(t) for t in terms) + np.abs(Mb * mo.omega)
    return {"R12": R12, "R23": R23, "N": Nw, "R01": R01, "Mb": Mb, "Fg": Fg, "power": power,
            "scale": scale, "residual": Mb * mo.omega + power}


def cyclogram(spec: EngineSpec) -> dict[str, Any]:
    """Four-stroke cyclogram: per cylinder the crank-angle intervals (deg, in [0, 720))
    of intake/compression/power/exhaust, its firing crank angle, and the firing
    intervals of the engine in firing order (docs/forces.md).

    Examples
    --------
    >>> spec = EngineSpec(0.05, 0.2, 0.08, (Cylinder("1", 45.0, 0.0), Cylinder("2", 135.0, 360.0)))
    >>> cyclogram(spec)["firing_intervals"]
    [270.0, 450.0]
    """
    rows = []
    for c, lag in zip(spec.cylinders, _lags(spec)):
        start = float((c.firing + lag) % 720.0)        # crank angle where ψ = 0
        strokes = [(name, (start + 180.0 * i) % 720.0, (start + 180.0 * (i + 1)) % 720.0 or 720.0)
                   for i, name in enumerate(STROKES)]
        rows.append({"cylinder": c.name, "start": start, "firing": (start + 360.0) % 720.0, "strokes": strokes})
    fire = sorted((r["firing"], r["cylinder"]) for r in rows)
    angles = [f for f, _ in fire]
    intervals = [((angles[(i + 1) % len(angles)] - angles[i]) % 720.0) or 720.0 for i in range(len(angles))]
    return {"cylinders": rows, "firing_order": [c for _, c in fire], "firing_angles": angles,
            "firing_intervals": intervals}


# --------------------------------------------------------------------------- analysis
@dataclass(frozen=True)
class EngineResult:
    """Everything :func:`analyse_engine` computes over one 720° cycle (frozen).

    Arrays are (N,) over crank angle ``phi_deg`` or (N, n_cyl) per cylinder; SI units.
    """

    spec: EngineSpec
    phi_deg: np.ndarray
    theta_deg: np.ndarray
    displacement: np.ndarray      # piston travel from TDC, s = x_TDC − x (m)
    velocity: np.ndarray          # ds/dt (m/s), positive towards the crank
    acceleration: np.ndarray      # d²s/dt² (m/s²)
    approx: dict                  # λ-approximation arrays s, v, a (in-line formulas)
    approx_error: dict            # max abs/rel errors of the approximation
    psi_deg: np.ndarray
    volume: np.ndarray
    pressure: np.ndarray          # absolute (Pa)
    gas_force: np.ndarray         # along u_j: −(p − p_cc) A_p (N); negative pushes the piston down
    rod_com: np.ndarray           # (N, nc, 2)
    rod_com_velocity: np.ndarray
    rod_com_acceleration: np.ndarray
    rod_com_radius: np.ndarray    # radius of curvature of G's path (m)
    reactions: dict               # R01, R12, R23, N (closed form)
    balancing: np.ndarray         # M_b (N m)
    virtual_power_residual: np.ndarray
    power_scale: np.ndarray
    indicated_work: np.ndarray    # per cylinder ∮ p dV (J)
    cycle_integral: float         # ∮ M_b dφ (J)
    cyclogram: dict
    general_check: dict = field(default_factory=dict)
    status: np.ndarray | None = None

    def __post_init__(self) -> None:
        for name, a in vars(self).items():
            if isinstance(a, np.ndarray):
                a.flags.writeable = False
        for d in (self.approx, self.reactions):
            for a in d.values():
                a.flags.writeable = False

    @property
    def success(self) -> bool:
        return self.status is None or bool(np.all(self.status == "ok"))

    def _cylinder_dicts(self) -> list[dict]:
        out = []
        for j, c in enumerate(self.spec.cylinders):
            out.append({"name": c.name, "bank": c.bank, "firing": c.firing,
                        "displacement": json_list(self.displacement[:, j]), "velocity": json_list(self.velocity[:, j]),
                        "acceleration": json_list(self.acceleration[:, j]),
                        "acceleration_approx": json_list(self.approx["a"][:, j]),
                        "psi": json_list(self.psi_deg[:, j]), "volume": json_list(self.volume[:, j]),
                        "pressure": json_list(self.pressure[:, j]), "gas_force": json_list(self.gas_force[:, j]),
                        "rod_com_x": json_list(self.rod_com[:, j, 0]), "rod_com_y": json_list(self.rod_com[:, j, 1]),
                        "rod_com_radius": json_list(self.rod_com_radius[:, j]),
                        "indicated_work": float(self.indicated_work[j])})
        return out

    def _reaction_dicts(self) -> dict:
        rx = self.reactions
        out = {"O:frame->crank": {"Fx": json_list(rx["R01"][:, 0]), "Fy": json_list(rx["R01"][:, 1])}}
        for j in range(self.spec.n_cylinders):
            out[f"A:crank->rod{j + 1}"] = {"Fx": json_list(rx["R12"][:, j, 0]), "Fy": json_list(rx["R12"][:, j, 1])}
            out[f"B{j + 1}:rod{j + 1}->piston{j + 1}"] = {"Fx": json_list(rx["R23"][:, j, 0]),
                                                         "Fy": json_list(rx["R23"][:, j, 1])}
            out[f"S{j + 1}:frame->piston{j + 1}"] = {"normal": json_list(rx["N"][:, j])}
        return out

    def to_text(self) -> str:
        """The main numbers, one per line (``multiloop engine``)."""
        spec, cyc = self.spec, self.cyclogram
        W = self.indicated_work.sum()
        e = self.approx_error
        rows = [
            ("engine", spec.name),
            ("cylinders", ", ".join(f"{c.name} (bank {c.bank:g} deg, firing TDC +{c.firing:g})" for c in spec.cylinders)),
            ("crank r / rod l / λ / offset", f"{spec.crank_radius * 1e3:g} mm / {spec.rod_length * 1e3:g} mm / "
                                             f"{spec.lam:.6g} / {spec.offset * 1e3:g} mm"),
            ("stroke (exact) / swept volume", f"{spec.stroke * 1e3:.6f} mm / {spec.swept_volume * 1e6:.4f} cm3 per cylinder"),
            ("speed", f"{spec.rpm:g} rpm = {spec.omega:.6g} rad/s"),
            ("firing angles / intervals", "/".join(f"{x:g}" for x in cyc["firing_angles"]) + " deg / "
                                          + "/".join(f"{x:g}" for x in cyc["firing_intervals"]) + " deg, order "
                                          + "-".join(cyc["firing_order"])),
            ("λ-approximation max error", f"s {e['s']['max_abs'] * 1e6:.4g} µm, v {e['v']['max_abs']:.4g} m/s, "
                                          f"a {e['a']['max_abs']:.4g} m/s² ({100 * e['a']['max_rel']:.3f} %)"),
            ("peak acceleration (exact)", f"{np.abs(self.acceleration).max():.6g} m/s²"),
            ("indicated work W_ind", f"{W:.6g} J per cycle ({W * spec.rpm / 120.0 / 1e3:.4g} kW indicated)"),
            ("∮ M_b dφ", f"{self.cycle_integral:.6g} J (−W_ind = {-W:.6g} J)"),
            ("balancing moment min / max / mean", f"{self.balancing.min():.6g} / {self.balancing.max():.6g} / "
                                                  f"{self.cycle_integral / (4 * np.pi):.6g} N m"),
            ("peak |R12| crank pin / |R01| bearing", f"{np.linalg.norm(self.reactions['R12'], axis=-1).max():.6g} N / "
                                                     f"{np.linalg.norm(self.reactions['R01'], axis=-1).max():.6g} N"),
            ("min radius of curvature of rod COM", f"{np.min(self.rod_com_radius) * 1e3:.6g} mm"),
            ("virtual power residual (max)", f"{np.nanmax(np.abs(self.virtual_power_residual)):.3g} W"),
        ]
        if self.general_check:
            g = self.general_check
            rows.append(("general kinetostatics vs closed form", f"|ΔM_b| ≤ {g['max_balancing_difference']:.3g} N m "
                         f"(relative {g['relative_balancing_difference']:.2g}), method {g['method']}"))
        width = max(len(k) for k, _ in rows)
        return "\n".join(f"  {k:<{width}}  {v}" for k, v in rows)

    def as_dict(self) -> dict:
        """The JSON-ready report (keys documented in docs/forces.md); every non-finite
        number, scalar or in an array, is ``None`` (JSON null)."""
        s = self.spec
        return json_ready({"name": s.name, "rpm": s.rpm, "omega": s.omega, "lambda": s.lam, "stroke": s.stroke,
                "swept_volume": s.swept_volume, "compression_ratio": s.compression_ratio,
                "phi": json_list(self.phi_deg), "cylinders": self._cylinder_dicts(),
                "balancing": json_list(self.balancing), "reactions": self._reaction_dicts(),
                "virtual_power_residual": json_list(self.virtual_power_residual),
                "approx_error": self.approx_error, "cyclogram": self.cyclogram,
                "indicated_work": float(self.indicated_work.sum()), "cycle_integral": self.cycle_integral,
                "general_check": self.general_check})


#: most crank positions :func:`analyse_engine` computes
MAX_STEPS = 100_000


def _approximation(spec: EngineSpec, mo: "_Motion", s, v, a) -> tuple[dict, dict]:
    """λ-approximation arrays (s, v, a) and their largest errors against the exact motion."""
    ap = lambda_approximation(mo.theta, spec.crank_radius, spec.rod_length)
    w = mo.omega[:, None]
    approx = {"s": ap["s"], "v": ap["s1"] * w, "a": ap["s2"] * w * w}
    err = {}
    for key, exact in (("s", s), ("v", v), ("a", a)):
        d = np.abs(approx[key] - exact)
        err[key] = {"max_abs": float(d.max()), "max_rel": float(d.max() / max(np.abs(exact).max(), 1e-300))}
    return approx, err


def _indicated_work(spec: EngineSpec, psi, vol, p_abs) -> np.ndarray:
    """∮ p dV per cylinder: closed form for the indicator diagram, else the trapezoid
    rule on the p–V polygon of the table."""
    r, l, e = spec.crank_radius, spec.rod_length, spec.offset
    Vc, Ap = spec.clearance_volume, spec.piston_area
    W = np.zeros(spec.n_cylinders)
    if spec.gas is None:
        return W
    for j in range(spec.n_cylinders):
        if isinstance(spec.gas, IndicatorDiagram):
            vols = [Vc + Ap * (spec.x_tdc - float(piston_kinematics(math.radians(t), r, l, e)["x"]))
                    for t in (0.0, 180.0, 360.0, 540.0)]
            W[j] = spec.gas.indicated_work(*vols)
            continue
        order = np.argsort(psi[:, j])
        pj = np.append(p_abs[order, j], p_abs[order[0], j])
        vj = np.append(vol[order, j], vol[order[0], j])
        W[j] = float(np.sum(0.5 * (pj[1:] + pj[:-1]) * np.diff(vj)))
    return W


def _general_check(spec: EngineSpec, phi, rx: dict) -> tuple[dict, np.ndarray]:
    """The general kinetostatics on :func:`engine_mechanism` against the closed form."""
    m = engine_mechanism(spec)
    st = engine_state(spec, phi, mechanism=m)
    rods, pistons, bs, _ = _names(spec)
    loads = [PointLoad(pistons[j], rx["Fg"][:, j], at=m.joint(bs[j]).at, name=f"gas{j + 1}")
             for j in range(spec.n_cylinders)]
    fr = forces(m, st, extra_loads=loads)
    dMb = np.abs(fr.balancing[:, 0] - rx["Mb"])
    scale = max(np.abs(rx["Mb"]).max(), 1e-300)
    dR = max(float(np.nanmax(np.abs(fr.reaction("A", "crank", rods[j]) - rx["R12"][:, j])))
             for j in range(spec.n_cylinders))
    return ({"method": fr.method, "max_balancing_difference": float(np.nanmax(dMb)),
             "relative_balancing_difference": float(np.nanmax(dMb) / scale),
             "max_rod_reaction_difference": dR,
             "max_relative_virtual_power_residual": float(np.nanmax(fr.relative_residual))}, fr.status)


def analyse_engine(spec: EngineSpec, steps: int = 720, *, check: bool = True) -> EngineResult:
    """Kinematics, gas forces, reactions and balancing moment over a 720° cycle.

    Parameters
    ----------
    spec : EngineSpec
    steps : int
        Crank positions, uniform over [0, 720) deg, from 8 to ``MAX_STEPS``
        (include the dead centres when ``steps`` is a multiple of 4 × the bank spacing
        in degrees).
    check : bool
        Also run the general kinetostatics (:func:`kin.forces.forces`, group by group)
        on :func:`engine_mechanism` and report its largest difference from the closed
        form in ``general_check``.

    Notes
    -----
    ``cycle_integral`` is ``∮ M_b dφ`` by the periodic trapezoid rule; at constant speed
    it equals ``−Σ indicated_work`` (docs/forces.md check 3) up to the quadrature error.
    """
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or not 8 <= steps <= MAX_STEPS:
        raise InputError(explain("steps", expected=f"an integer from 8 to {MAX_STEPS}", got=repr(steps)))
    spec.validate()
    phi_deg = np.arange(steps) * (720.0 / steps)
    phi = np.radians(phi_deg)
    mo = _motion(spec, phi)
    psi, vol, p_abs, gauge = _gas_gauge(spec, phi, mo)
    rx = engine_reactions(spec, phi, gauge, mo=mo)
    s, v, a = spec.x_tdc - mo.x, -mo.xd, -mo.xdd
    approx, err = _approximation(spec, mo, s, v, a)
    cross = np.abs(_cross(mo.vG, mo.aG))
    speed = np.linalg.norm(mo.vG, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = np.where(cross > 0, speed ** 3 / cross, np.inf)
    cyc = float(np.sum(rx["Mb"]) * math.radians(720.0 / steps))
    check_out, status = _general_check(spec, phi, rx) if check else ({}, np.full(steps, "ok", dtype=object))
    return EngineResult(spec, phi_deg, np.degrees(mo.theta), s, v, a, approx, err, psi, vol, p_abs,
                        gauge * spec.piston_area * -1.0, mo.G, mo.vG, mo.aG, rho,
                        {k: rx[k] for k in ("R01", "R12", "R23", "N")}, rx["Mb"], rx["residual"],
                        rx["scale"], _indicated_work(spec, psi, vol, p_abs), cyc, cyclogram(spec), check_out, status)
