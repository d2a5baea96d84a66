"""Design sensitivities: the derivatives of a batch's poses with respect to its design
variables and its inputs, exactly, by the velocity analogue of each step.

Every step of a plan (a driver, a dyad, a triad, a class IV group, any Assur group)
places its unknown links ``u`` so that its pair constraints ``Φ(Z_u, Z_k, x) = 0`` hold
(:mod:`multiloop.topo.constraints`: pins, sliders, drivers; ``Z_k`` the poses of the
links it attaches to, ``x`` the design variables and the inputs).  Differentiating the
constraints (the implicit function theorem) gives, step by step in the plan's order,

    J_u ∂Z_u/∂x = −∂Φ/∂x − J_k ∂Z_k/∂x,

the same linear system as the step's velocities ``J_u u̇ = −J_k k̇ − Φ_φ φ̇`` (Nikravesh
1988, §3.6 and §4.2; Haug 1989, §6.2 on design sensitivity) with one right-hand side per
variable instead of one per driver: no design is solved again, and no step is
differenced.  The explicit term ``∂Φ/∂x`` is that of the design's reference geometry:
a pin's reference position ``r_j`` and the links' reference points ``c`` (their first
joints', :func:`multiloop.topo.constraints.link_origins`) enter through the offsets
``ρ = r_j − c``, a guide through its angle, an input through its driving constraint.
A material point's derivative follows from its link's:
``W = X + R(θ)(r − c)`` gives ``∂W = ∂X + perp(W − X) ∂θ + R(θ)(∂r − ∂c)``.

The derivative with respect to an input is the velocity analogue itself (the pose's
rate per unit driver rate), so the same call gives both.  Positions where a design did
not assemble are NaN; at a singular position the system is singular and the
derivatives are unbounded, as the velocities are.

References
----------
.. [1] Nikravesh P.E. Computer-Aided Analysis of Mechanical Systems. Prentice Hall
   (1988), ch. 3-4.
.. [2] Haug E.J. Computer Aided Kinematics and Dynamics of Mechanical Systems, vol. 1.
   Allyn and Bacon (1989), ch. 6.
"""
from __future__ import annotations

import functools

from dataclasses import dataclass

import numpy as np

from multiloop.topo.model import JointKind

from .design import DesignPoses
from .geometry import joint_rows, origin_joint
from .memo import cached
from .rigid import perp

__all__ = ["PoseSensitivity", "TangentView", "pose_sensitivity", "material_derivative", "offset_columns",
           "sensitivity_plan"]


@dataclass(frozen=True, eq=False)
class _Block:
    """One constraint of a step, compiled: its kind, links, rows and constant selections
    of the design columns (``Ea``, ``Eb``: ``∂ρ/∂x`` on links a and b, (2, q); ``alpha``:
    the guide angle's column; ``drive``: the input's column; -1 for none)."""

    kind: str
    joint: str
    a: int
    b: int
    row: int
    Ea: np.ndarray
    Eb: np.ndarray
    alpha: int
    drive: int
    origin_a: str | None = None             # the joints at links a's and b's reference points
    origin_b: str | None = None


@dataclass(frozen=True, eq=False)
class _StepBlocks:
    unknown: tuple[int, ...]
    blocks: tuple[_Block, ...]
    n_eq: int


@dataclass(frozen=True, eq=False)
class _Compiled:
    """The steps' blocks, and the same as flat arrays for the compiled route
    (:func:`kin._sensitivity_nb.sensitivities`)."""

    names: tuple[str, ...]
    steps: tuple[_StepBlocks, ...]
    flat: dict
    origins: tuple                          # each link's reference joint (None: the origin)


_KINDS = {"R": 0, "P": 1, "drive_R": 2, "drive_P": 3}


def _rows_of(blocks, m) -> np.ndarray:
    """(3, n_blocks): each block's joint and its links' reference joints, as rows of a
    geometry's joint table (:attr:`~kin.geometry.Geometry.joint_table`; a zero row for
    the origin).  A slider's guide is read at its joint's row, an R joint's is zero."""
    row, nj = joint_rows(m), len(m.joints)
    return np.array([[row[b.joint] for b in blocks], [row.get(b.origin_a, nj) for b in blocks],
                     [row.get(b.origin_b, nj) for b in blocks]], np.int64).reshape(3, -1)


def _flatten(steps: tuple[_StepBlocks, ...], m) -> dict:
    n_links = m.n_links
    blocks = [b for st in steps for b in st.blocks]
    bounds = np.cumsum([0] + [len(st.blocks) for st in steps])
    col_of = np.full((len(steps), n_links), -1, np.int64)
    unknown = np.full((len(steps), max(len(st.unknown) for st in steps)), -1, np.int64)
    for s, st in enumerate(steps):
        for i, k in enumerate(st.unknown):
            col_of[s, k], unknown[s, i] = 3 * i, k
    ints = lambda f: np.array([f(b) for b in blocks], np.int64)      # noqa: E731
    return dict(rows=_rows_of(blocks, m),
                kind=ints(lambda b: _KINDS[b.kind]), la=ints(lambda b: b.a), lb=ints(lambda b: b.b),
                row=ints(lambda b: b.row), alpha=ints(lambda b: b.alpha), drive=ints(lambda b: b.drive),
                Ea=np.stack([b.Ea for b in blocks]), Eb=np.stack([b.Eb for b in blocks]),
                step_lo=bounds[:-1].astype(np.int64), step_hi=bounds[1:].astype(np.int64),
                neq=np.array([st.n_eq for st in steps], np.int64), col_of=col_of, unknown=unknown)


def _selection(cols: dict, name: str, q: int) -> np.ndarray:
    """``∂(reference position of name)/∂x`` (2, q): ones at its ``.x``/``.y`` columns."""
    E = np.zeros((2, q))
    for i, axis in enumerate(("x", "y")):
        c = cols.get(f"{name}.{axis}")
        if c is not None:
            E[i, c] = 1.0
    return E


def offset_columns(cols: dict, name: str, origin: str | None, q: int) -> np.ndarray:
    """``∂(r_name − r_origin)/∂x`` (2, q): the design columns ``cols`` that move the
    reference position of joint or tracer point ``name`` from that of joint ``origin``
    (a link's reference point; None: the origin)."""
    return _selection(cols, name, q) - (_selection(cols, origin, q) if origin is not None else 0.0)


def sensitivity_plan(sp, names: tuple[str, ...]) -> _Compiled:
    """The blocks of plan ``sp`` for the design columns ``names``, compiled once and kept
    on the plan."""
    return cached(sp, ("sensitivity", tuple(names)), _compile, tuple(names))


def _compile(sp, names: tuple[str, ...]) -> _Compiled:
    m = sp.mechanism
    p = len(names)
    q = p + len(m.drivers)
    cols = {n: i for i, n in enumerate(names)}
    idx = {x: i for i, x in enumerate(m.link_names)}
    origin = {x: origin_joint(m, x) for x in m.link_names}
    zero = np.zeros((2, q))

    def rho(joint: str, link: str) -> np.ndarray:
        if m.joint(joint).kind is JointKind.R:
            return offset_columns(cols, joint, origin[link], q)
        return zero - (_selection(cols, origin[link], q) if origin[link] is not None else zero)

    steps = []
    for st in sp.steps:
        blocks, row = [], 0
        for c in st.step.constraints:
            alpha = cols.get(f"{c.joint}.angle", -1) if c.kind in ("P", "drive_P") else -1
            drive = p + c.driver if c.kind.startswith("drive") else -1
            blocks.append(_Block(c.kind, c.joint, idx[c.a], idx[c.b], row, rho(c.joint, c.a), rho(c.joint, c.b),
                                 alpha, drive, origin[c.a], origin[c.b]))
            row += c.n_equations
        steps.append(_StepBlocks(tuple(st.unknown), tuple(blocks), row))
    return _Compiled(tuple(names), tuple(steps), _flatten(tuple(steps), m),
                     tuple(origin[x] for x in m.link_names))


def _rows(v, D: int, N: int) -> np.ndarray:
    """A pose-store row (``(D, N)``, or a value that broadcasts to it) flattened to
    ``(D·N,)`` (a view where it already has the shape)."""
    return v.reshape(-1) if np.shape(v) == (D, N) else np.broadcast_to(v, (D, N)).reshape(-1)


def _per_design(a: np.ndarray, D: int) -> np.ndarray:
    """A geometry value ``(2,)`` (one design's, shared) or ``(D, 1, 2)`` as ``(D, 2)``."""
    return a[:, 0] if a.ndim == 3 else np.broadcast_to(a, (D, 2))


def _rotate(c, s, v):
    """``R(θ) v`` for rotations given by their cos and sin (B,) (kept by the pose store,
    :func:`kin.rigid.rotate` takes θ) and vectors (B, 2) or (2,) → (B, 2)."""
    out = np.empty(c.shape + (2,))
    out[..., 0] = c * v[..., 0] - s * v[..., 1]
    out[..., 1] = s * v[..., 0] + c * v[..., 1]
    return out


def _rotate_cols(c, s, E):
    """``R(θ) E`` for rotations (B,) and a constant (2, q) → (B, 2, q)."""
    return np.stack([c[:, None] * E[0] - s[:, None] * E[1], s[:, None] * E[0] + c[:, None] * E[1]], axis=1)


@dataclass(frozen=True, eq=False)
class PoseSensitivity:
    """The derivatives of D designs' poses at N inputs.

    ``dZ`` ``(n_links, D·N, 3, q)``: ``∂(X, Y, θ)/∂(x, inputs)`` of every link, the
    columns ``names`` (the design variables, then ``"input:<joint>"`` per driver).
    """

    poses: DesignPoses
    names: tuple[str, ...]
    dZ: np.ndarray
    origins: tuple                          # each link's reference joint (None: the origin)

    @property
    def shape(self) -> tuple[int, int]:
        return self.poses.store.shape

    def point(self, name: str) -> np.ndarray:
        """``∂W/∂(x, inputs)`` of joint or tracer point ``name``: ``(D, N, 2, q)``."""
        return self.world(self.poses.host(name), name)

    def angle(self, link: str) -> np.ndarray:
        """``∂θ/∂(x, inputs)`` of link ``link``: ``(D, N, q)``."""
        D, N = self.shape
        k = self.poses.plan.mechanism.link_names.index(link)
        return self.dZ[k][:, 2, :].reshape(D, N, -1)

    def axis(self, joint: str) -> np.ndarray:
        """``∂u/∂(x, inputs)`` of P joint ``joint``'s reference guide ``u``: ``(D, 2, q)``
        (nonzero in its angle's column only)."""
        D = self.shape[0]
        out = np.zeros((D, 2, len(self.names)))
        if f"{joint}.angle" in self.names:
            out[:, :, self.names.index(f"{joint}.angle")] = perp(_per_design(self.poses.geometry.axis(joint), D))
        return out

    def tangent(self, eps) -> "TangentView":
        """The poses moved to first order by ``±eps`` (a number, or one per column) along
        each column (:class:`TangentView`)."""
        return TangentView(self, eps)

    @functools.cached_property
    def _cols(self) -> dict:
        return {n: i for i, n in enumerate(self.names)}

    def world(self, k: int, name: str) -> np.ndarray:
        """``∂W/∂(x, inputs)`` of the material point of link ``k`` at the reference
        position of joint or tracer point ``name``: ``(D, N, 2, q)``."""
        geo = self.poses.geometry
        return self.material(k, _per_design(geo.at(name), self.shape[0]), _selection(self._cols, name, len(self.names)))

    def material(self, k: int, r: np.ndarray, E: np.ndarray | None = None) -> np.ndarray:
        """``∂W/∂(x, inputs)`` of the material point of link ``k`` at reference position
        ``r`` (D, 2), which moves with the design by ``E`` (2, q) (None: it does not):
        ``(D, N, 2, q)``."""
        st = self.poses
        G, geo = st.store, st.geometry
        D, N = self.shape
        q = len(self.names)
        o = self.origins[k]
        E = (np.zeros((2, q)) if E is None else E) - (_selection(self._cols, o, q) if o is not None else 0.0)
        r = np.asarray(r, float) - (_per_design(geo.at(o), D) if o is not None else 0.0)
        return material_derivative(self.dZ[k], _rows(G.c[k], D, N), _rows(G.s[k], D, N), r, E).reshape(D, N, 2, q)


def material_derivative(dZk: np.ndarray, c: np.ndarray, s: np.ndarray, r: np.ndarray, E: np.ndarray) -> np.ndarray:
    """``∂W/∂(x, inputs)`` ``(B, 2, q)`` of a material point ``W = X + R(θ) r`` of a link
    whose derivatives are ``dZk`` ``(B, 3, q)`` and rotations ``c``, ``s`` (B,) (B = D·N
    positions, design by design), ``r`` ``(D, 2)`` the point's offset from the link's
    reference point, which moves with the design by ``E`` ``(2, q)``:
    ``∂X + perp(R(θ) r) ∂θ + R(θ) E`` (module docstring)."""
    arm = _rotate(c, s, np.repeat(r, len(c) // len(r), axis=0))                   # R(θ)(r − c)
    return dZk[:, :2, :] + perp(arm)[:, :, None] * dZk[:, 2:3, :] + _rotate_cols(c, s, E)


class TangentView:
    """The poses of a :class:`PoseSensitivity` moved to first order along each of its q
    columns by ``+eps`` and by ``−eps`` (a number or one per column; ``2q`` copies on a new axis after the inputs'),
    in the interface of a check's view (``point(joint)`` ``(D, N, 2q, 2)``,
    ``angle(link)`` ``(D, N, 2q)``, ``axis(joint)`` ``(D, 1, 2q, 2)``): an explicit
    function ``f`` of the poses (a monitored angle's formula) evaluated on it gives its
    derivative along the exact tangents by :meth:`derivative`, ``(f₊ − f₋)/(2 eps)``,
    with no design solved again (the error is that of the formula's own second
    derivative, ``O(eps²)``)."""

    def __init__(self, sens: PoseSensitivity, eps):
        self.sens = sens
        self.eps = np.broadcast_to(np.asarray(eps, float), (len(sens.names),))
        self.signs = np.concatenate([self.eps, -self.eps])

    def _moved(self, value, d):
        """``value`` (…, c) moved by ``±eps d`` (…, c, q) → (…, 2q, c)."""
        step = np.concatenate([d, d], axis=-1) * self.signs
        return value[..., None, :] + np.swapaxes(step, -1, -2)

    @property
    def ok(self) -> np.ndarray:
        """Where the poses assembled ``(D, N, 2q)``."""
        return np.repeat(self.sens.poses.ok[..., None], len(self.signs), axis=-1)

    def point(self, name: str) -> np.ndarray:
        return self._moved(self.sens.poses.point(name), self.sens.point(name))

    def angle(self, link: str) -> np.ndarray:
        th = self.sens.poses.angle(link)
        return th[..., None] + np.concatenate([self.sens.angle(link)] * 2, axis=-1) * self.signs

    def axis(self, joint: str) -> np.ndarray:
        u = _per_design(self.sens.poses.geometry.axis(joint), self.sens.shape[0])
        return self._moved(u, self.sens.axis(joint))[:, None]

    def derivative(self, values: np.ndarray) -> np.ndarray:
        """``(…, 2q)`` values of a function over this view → its derivatives ``(…, q)``."""
        q = values.shape[-1] // 2
        return (values[..., :q] - values[..., q:]) / (2.0 * self.eps)


def pose_sensitivity(st: DesignPoses) -> PoseSensitivity:
    """The exact derivatives of poses ``st`` (from :func:`kin.design.solve_designs`)
    with respect to their design variables and inputs (module docstring).

    Examples
    --------
    A crank of length 1 turned by φ = 90° from its reference: its tip is at
    ``O + R(φ)(T − O)``, so the columns (O.x, O.y, T.x, T.y, the input) are
    ``I − R(φ)``, ``R(φ)`` and the tip's velocity ``(−sin φ, cos φ)``.

    >>> from multiloop.topo.model import MechanismBuilder
    >>> from multiloop.kin.design import solve_designs
    >>> b = MechanismBuilder()
    >>> b.add_link("g", frame=True)
    >>> b.add_joint("O", "R", ("g", "crank"), at=(0, 0))
    >>> b.add_point("T", "crank", at=(1, 0))
    >>> b.add_driver("O", ("g", "crank"))
    >>> m = b.build()
    >>> names = ("O.x", "O.y", "T.x", "T.y")
    >>> st = solve_designs(m, names, [[0.0, 0.0, 1.0, 0.0]], [np.pi / 2])
    >>> np.round(pose_sensitivity(st).point("T")[0, 0], 12).tolist()
    [[1.0, 1.0, 0.0, -1.0, -1.0], [-1.0, 1.0, 1.0, 0.0, 0.0]]
    """
    sp, geo = st.plan, st.geometry
    m = sp.mechanism
    names = tuple(geo.cols) if geo.batch else ()
    comp = sensitivity_plan(sp, names)
    D, N = st.store.shape
    B = D * N
    q = len(names) + len(m.drivers)
    dZ = np.full((m.n_links, B, 3, q), np.nan)
    dZ[sp.mechanism.link_names.index(m.frame)] = 0.0
    view = _Flat(st, geo, D, N)
    nb = _compiled_route(B)
    if nb is not None:
        _run_compiled(nb, comp, view, st.ok.reshape(-1), dZ)
    else:
        for step in comp.steps:
            _step_sensitivity(step, view, dZ, q)
    bad = ~st.ok.reshape(-1)
    if bad.any():
        dZ[:, bad] = np.nan
    return PoseSensitivity(st, names + tuple(f"input:{d.joint}" for d in m.drivers), dZ, comp.origins)


def _compiled_route(n_positions: int):
    """The compiled route (:mod:`kin._sensitivity_nb`) when the kernel's mode asks for it
    and numba loads, else None (the NumPy route)."""
    from . import kernel
    if not kernel.wanted(n_positions):
        return None
    if not _NB:
        try:
            from . import _sensitivity_nb
        except (ImportError, RuntimeError):        # no numba, or no writable cache directory
            return None
        _NB.append(_sensitivity_nb)
    return _NB[0]


_NB: list = []


def _run_compiled(nb, comp: _Compiled, v: "_Flat", ok: np.ndarray, dZ: np.ndarray) -> None:
    """Every step's velocity analogue by the compiled kernel, into ``dZ`` in place (the
    blocks' per-design offsets ρ on links a and b and reference guides gathered here, the
    rest compiled once)."""
    table = v.geo.joint_table if v.geo.batch else None
    rows = v.st.store.stacked_rows()
    C, S = (np.ascontiguousarray(x.reshape(x.shape[0], -1)) for x in rows) if rows is not None else \
        (np.ascontiguousarray(np.stack(x)) for x in (v.c, v.s))
    f = comp.flat
    if table is not None:                      # (the batch's gathered joints: the same floats)
        P, U, _ = table
        jr, oa, ob = f["rows"]
        rho = np.stack([P[:, jr] - P[:, oa], P[:, jr] - P[:, ob], U[:, jr]]).swapaxes(1, 2)
    else:
        blocks = [b for st in comp.steps for b in st.blocks]
        rho = np.empty((3, len(blocks), v.D, 2))
        for i, b in enumerate(blocks):
            rho[0, i], rho[1, i] = v.offset(b.joint, b.origin_a), v.offset(b.joint, b.origin_b)
            rho[2, i] = v.reference_axis(b.joint) if b.kind in ("P", "drive_P") else 0.0
    rho_a, rho_b, u0 = (np.ascontiguousarray(a) for a in rho)
    nb.sensitivities(np.ascontiguousarray(v.X), np.ascontiguousarray(v.Y), C, S, v.N, f["kind"], f["la"], f["lb"],
                     f["row"], f["alpha"], f["drive"], f["Ea"], f["Eb"], rho_a, rho_b, u0, f["step_lo"],
                     f["step_hi"], f["neq"], f["col_of"], f["unknown"], np.ascontiguousarray(ok), dZ)


class _Flat:
    """The poses of a batch flattened to B = D·N rows, with the per-design offsets ρ."""

    def __init__(self, st: DesignPoses, geo, D: int, N: int):
        G = st.store
        st.th                                   # (the angle rows of pending links)
        self.st, self.geo, self.D, self.N = st, geo, D, N
        self.X = G.T[:, 0].reshape(G.T.shape[0], -1)
        self.Y = G.T[:, 1].reshape(G.T.shape[0], -1)
        self._rho: dict = {}
        self._offsets: dict = {}

    @functools.cached_property
    def c(self) -> list:
        """Each link's cos row over the batch (B,)."""
        return [_rows(v, self.D, self.N) for v in self.st.store.c]

    @functools.cached_property
    def s(self) -> list:
        """Each link's sin row over the batch (B,)."""
        return [_rows(v, self.D, self.N) for v in self.st.store.s]

    def offset(self, joint: str, origin: str | None) -> np.ndarray:
        """``ρ = r_joint − c`` per design (D, 2), ``c`` the reference position of joint
        ``origin`` (a link's reference point; None: the origin)."""
        key = (joint, origin)
        hit = self._offsets.get(key)
        if hit is None:
            r = _per_design(self.geo.at(joint), self.D)
            hit = self._offsets[key] = r - _per_design(self.geo.at(origin), self.D) if origin is not None else np.array(r)
        return hit

    def reference_axis(self, joint: str) -> np.ndarray:
        """A P joint's reference guide per design (D, 2)."""
        return _per_design(self.geo.axis(joint), self.D)

    def arm(self, joint: str, k: int, origin: str | None) -> np.ndarray:
        """``R(θ_k) ρ`` over the batch (B, 2), ``origin`` link k's reference joint."""
        key = (joint, k)
        hit = self._rho.get(key)
        if hit is None:
            r = np.repeat(self.offset(joint, origin), self.N, axis=0)
            hit = self._rho[key] = _rotate(self.c[k], self.s[k], r)
        return hit

    def axis(self, joint: str) -> np.ndarray:
        return np.repeat(self.reference_axis(joint), self.N, axis=0)

    def position(self, k: int) -> np.ndarray:
        return np.stack([self.X[k], self.Y[k]], axis=-1)


def _partials(b: _Block, v: _Flat, q: int):
    """The block's ``∂Φ/∂Z_a``, ``∂Φ/∂Z_b`` (B, rows, 3) and ``∂Φ/∂x`` (B, rows, q) (module docstring)."""
    Bn = v.D * v.N
    if b.kind == "R":
        ra, rb = v.arm(b.joint, b.a, b.origin_a), v.arm(b.joint, b.b, b.origin_b)
        da = np.zeros((Bn, 2, 3))
        da[:, 0, 0] = da[:, 1, 1] = 1.0
        da[:, :, 2] = perp(ra)
        db = np.zeros((Bn, 2, 3))
        db[:, 0, 0] = db[:, 1, 1] = -1.0
        db[:, :, 2] = -perp(rb)
        dx = _rotate_cols(v.c[b.a], v.s[b.a], b.Ea) - _rotate_cols(v.c[b.b], v.s[b.b], b.Eb)
        return da, db, dx
    if b.kind == "drive_R":
        da = np.zeros((Bn, 1, 3))
        da[:, 0, 2] = -1.0
        db = -da
        dx = np.zeros((Bn, 1, q))
        dx[:, 0, b.drive] = -1.0
        return da, db, dx
    # a guide's line (P) or slide (drive_P): w · d with w = R(θ_a) n₀ (the line) or R(θ_a) u
    ra, rb = v.arm(b.joint, b.a, b.origin_a), v.arm(b.joint, b.b, b.origin_b)
    u0 = v.axis(b.joint)
    u = _rotate(v.c[b.a], v.s[b.a], u0)
    n = perp(u)
    w, dw = (n, -u) if b.kind == "P" else (u, n)          # ∂w/∂α
    d = v.position(b.b) + rb - v.position(b.a) - ra
    line_a = np.concatenate([-w, (np.sum(perp(w) * d, -1) - np.sum(w * perp(ra), -1))[:, None]], axis=1)
    line_b = np.concatenate([w, np.sum(w * perp(rb), -1)[:, None]], axis=1)
    line_x = (np.einsum("bi,bij->bj", w, _rotate_cols(v.c[b.b], v.s[b.b], b.Eb))
              - np.einsum("bi,bij->bj", w, _rotate_cols(v.c[b.a], v.s[b.a], b.Ea)))
    if b.alpha >= 0:
        line_x[:, b.alpha] += np.sum(dw * d, -1)
    if b.kind == "drive_P":
        line_x[:, b.drive] -= 1.0
        return line_a[:, None], line_b[:, None], line_x[:, None]
    da = np.zeros((Bn, 2, 3))
    db = np.zeros((Bn, 2, 3))
    da[:, 0, 2], db[:, 0, 2] = -1.0, 1.0                 # θ_b − θ_a = 0
    da[:, 1], db[:, 1] = line_a, line_b
    dx = np.zeros((Bn, 2, q))
    dx[:, 1] = line_x
    return da, db, dx


def _step_sensitivity(step: _StepBlocks, v: _Flat, dZ: np.ndarray, q: int) -> None:
    """Solve one step's velocity analogue for ``∂Z_u/∂x`` (module docstring), in place."""
    Bn = v.D * v.N
    col = {k: 3 * i for i, k in enumerate(step.unknown)}
    J = np.zeros((Bn, step.n_eq, step.n_eq))
    rhs = np.zeros((Bn, step.n_eq, q))
    for b in step.blocks:
        da, db, dx = _partials(b, v, q)
        r = slice(b.row, b.row + dx.shape[1])
        rhs[:, r] -= dx
        for k, part in ((b.a, da), (b.b, db)):
            if k in col:
                J[:, r, col[k]:col[k] + 3] += part
            else:
                rhs[:, r] -= part @ dZ[k]
    good = np.all(np.isfinite(J), axis=(1, 2)) & np.all(np.isfinite(rhs), axis=(1, 2))
    J[~good] = np.eye(step.n_eq)
    rhs[~good] = 0.0
    with np.errstate(all="ignore"):
        try:
            sol = np.linalg.solve(J, rhs)
        except np.linalg.LinAlgError:          # an exactly singular position: left out
            good &= np.linalg.det(J) != 0.0
            J[~good] = np.eye(step.n_eq)
            sol = np.linalg.solve(J, rhs)
    sol[~good] = np.nan
    for k, c0 in col.items():
        dZ[k] = sol[:, c0:c0 + 3]

