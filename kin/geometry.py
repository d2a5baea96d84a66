"""The reference dimensions that the compiled steps of a plan are built from.

A plan's topology (its Assur steps and constraint systems) is compiled once; the
numbers of each step — pin positions, guide directions, lengths, branch signs — are
read from a :class:`Geometry`: the mechanism's own reference configuration, or a batch
of D designs of the same topology given as a design matrix ``(D, p)`` whose columns are
named by :func:`design_names`.  A single design gives ``(2,)`` points (Python-float
fast paths); a batch gives ``(D, 1, 2)`` points and ``(D, 1)`` numbers that broadcast
over the inputs, so that every kernel runs once for all designs and positions.  The
same code computes a step's numbers in both cases, so a design solves to the same bits
alone and in a batch.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from multiloop.topo.errors import InputError, explain
from multiloop.topo.model import JointKind, Mechanism

from .memo import cached
from .poses import unit

__all__ = ["Geometry", "design_names", "design_matrix", "origin_joint", "joint_rows", "joint_tables"]


def design_names(m: Mechanism, points=()) -> tuple[str, ...]:
    """The design variables of ``m``: ``"J.x"``, ``"J.y"`` of every R joint (frame pivots
    included), ``"J.angle"`` (rad) of every P joint's guide, and ``"T.x"``, ``"T.y"`` of
    the tracer points named in ``points``.  A P joint's point is not a variable: the
    slider's track runs through the slider's own joints parallel to the guide, so moving
    the joint's reference point along the guide's normal changes no motion."""
    names = []
    for j in m.joints:
        names += [f"{j.name}.angle"] if j.kind is JointKind.P else [f"{j.name}.x", f"{j.name}.y"]
    chosen = set(points)
    for p in m.points:
        if p.name in chosen:
            names += [f"{p.name}.x", f"{p.name}.y"]
    return tuple(names)


def design_matrix(names, positions) -> np.ndarray:
    """The design matrix ``(D, len(names))`` of designs given as point positions by name
    (``{"J1": (x, y), ...}``, one dict per design), for names ``"J.x"`` / ``"J.y"`` only
    (pin-jointed designs; a guide angle has no position)."""
    return np.array([[at[n[:-2]][0 if n.endswith(".x") else 1] for n in names] for at in positions], float)


def origin_joint(m: Mechanism, link: str) -> str | None:
    """The joint whose reference position is link ``link``'s reference point (its first
    joint), or None where that point is the origin (the frame, a link without joints)."""
    lk = next(x for x in m.links if x.name == link)
    js = m.joints_of(link)
    return None if lk.is_frame or not js or js[0].at is None else js[0].name


class _Tables(NamedTuple):
    """A mechanism's joints as table rows (:meth:`Geometry.gather`): the reference points
    ``at`` and unit guides ``axes`` (n_joints + 1, 2), each link's row ``first``, the rows
    and columns of the design's positions (``rows``, ``cx``, ``cy``) and guide angles
    (``angles``: (row, column) pairs)."""

    at: np.ndarray
    axes: np.ndarray
    first: np.ndarray
    rows: np.ndarray
    cx: np.ndarray
    cy: np.ndarray
    angles: tuple


def joint_rows(m: Mechanism) -> dict[str, int]:
    """Each joint's row in a batch's joint table (:meth:`Geometry.gather`): its index in
    ``m.joints`` (the row after the last is the origin's)."""
    return {j.name: i for i, j in enumerate(m.joints)}


def joint_tables(owner, m: Mechanism, names: tuple) -> _Tables:
    """The template of a batch's joint table (:meth:`Geometry.gather`) for the design
    columns ``names``: the mechanism's reference points and unit guides, the rows the
    columns set, and each link's reference joint's row; kept on ``owner`` (the plan)."""
    def make(owner, names):
        nj = len(m.joints)
        row = joint_rows(m)
        at, axes = np.zeros((nj + 1, 2)), np.zeros((nj + 1, 2))
        for i, j in enumerate(m.joints):
            at[i] = j.at if j.at is not None else np.nan
            if j.axis is not None:
                axes[i] = unit(np.asarray(j.axis, float))
        first = np.array([row.get(origin_joint(m, x), nj) for x in m.link_names], np.int64)
        col = {n: i for i, n in enumerate(names)}
        pos = np.array([(i, col[f"{j.name}.x"], col[f"{j.name}.y"]) for i, j in enumerate(m.joints)
                        if f"{j.name}.x" in col], np.int64).reshape(-1, 3).T
        ang = tuple((i, col[f"{j.name}.angle"]) for i, j in enumerate(m.joints) if f"{j.name}.angle" in col)
        return _Tables(at, axes, first, pos[0], pos[1], pos[2], ang)
    return cached(owner, ("joint tables", names), make, names)


class Geometry:
    """Reference points, guide directions and link origins of one design or of D designs.

    Parameters
    ----------
    mechanism : Mechanism
        The topology, and the values of whatever the design matrix does not name.
    names : sequence of str, optional
        Column names of ``designs`` (see :func:`design_names`).
    designs : ndarray, shape (D, p), optional
        The design matrix; without it the geometry is the mechanism's own.
    """

    def __init__(self, mechanism: Mechanism, names=None, designs=None):
        self.mechanism = mechanism
        self.batch = designs is not None
        self._pts = {p.name: p for p in mechanism.points}
        self._cache: dict = {}
        #: ``(P, U, O)`` of a batch once :meth:`gather` has gathered them, else None
        self.joint_table: tuple | None = None
        if self.batch:
            X = np.asarray(designs, float)
            if X.ndim != 2 or X.shape[1] != len(names):
                raise InputError(explain("designs", expected=f"shape (D, {len(names)}) for the variables "
                                         + ", ".join(names), got=f"shape {X.shape}"))
            self.X, self.D = X, X.shape[0]
            self.names = tuple(names)
            self.cols = {n: i for i, n in enumerate(names)}

    def _fixed(self, name: str):
        if name in self._pts:
            return self._pts[name].at
        return self.mechanism.joint(name).at

    def at(self, name: str) -> np.ndarray:
        """Reference position of joint or tracer point ``name``: ``(2,)`` or ``(D, 1, 2)``."""
        hit = self._cache.get(("at", name))
        if hit is None:
            if not self.batch:
                hit = np.asarray(self._fixed(name), float)
            elif f"{name}.x" in self.cols:
                hit = self.X[:, [self.cols[f"{name}.x"], self.cols[f"{name}.y"]]][:, None, :]
            else:
                hit = np.broadcast_to(np.asarray(self._fixed(name), float), (self.D, 1, 2))
            self._cache["at", name] = hit
        return hit

    def axis(self, joint: str) -> np.ndarray:
        """Unit guide direction of P joint ``joint`` in the reference: ``(2,)`` or ``(D, 1, 2)``."""
        hit = self._cache.get(("axis", joint))
        if hit is None:
            if self.batch and f"{joint}.angle" in self.cols:
                a = self.X[:, self.cols[f"{joint}.angle"]]
                hit = unit(np.stack([np.cos(a), np.sin(a)], axis=-1))[:, None, :]
            else:
                hit = unit(self.mechanism.joint(joint).axis)
                if self.batch:
                    hit = np.broadcast_to(hit, (self.D, 1, 2))
            self._cache["axis", joint] = hit
        return hit

    def origin(self, link: str) -> np.ndarray:
        """A link's reference point: its first joint's position (the origin for the frame
        or a link without joints), as :func:`topo.constraints.link_origins`."""
        j = origin_joint(self.mechanism, link)
        if j is None:
            return np.zeros((self.D, 1, 2)) if self.batch else np.zeros(2)
        return self.at(j)

    def origins(self) -> np.ndarray:
        """Every link's reference point in one array: ``(n_links, D, 1, 2)`` for designs,
        ``(n_links, 2)`` for one (computed once per geometry)."""
        hit = self._cache.get("origins")
        if hit is None:
            hit = self._cache["origins"] = np.stack([self.origin(x) for x in self.mechanism.link_names])
        return hit

    def gather(self, owner) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A batch's joints in three arrays, gathered once: every joint's reference point
        and unit guide ``(D, n_joints + 1, 2)`` (mechanism order, a zero row last; an R
        joint's guide zero) and every link's reference point ``(D, n_links, 2)``, the
        same floats as :meth:`at`, :meth:`axis` and :meth:`origins` (which then reads
        them).  The design columns' rows are kept on ``owner`` (the mechanism's plan).
        The guides of designs with a guide angle are NumPy's cos and sin, as
        :meth:`axis` computes them."""
        if self.joint_table is None:
            tab = joint_tables(owner, self.mechanism, self.names)
            X, D = self.X, self.D
            P = np.empty((D,) + tab.at.shape)
            P[:] = tab.at
            P[:, tab.rows, 0], P[:, tab.rows, 1] = X[:, tab.cx], X[:, tab.cy]
            U = np.empty((D,) + tab.axes.shape)
            U[:] = tab.axes
            for i, c in tab.angles:
                a = X[:, c]
                U[:, i] = unit(np.stack([np.cos(a), np.sin(a)], axis=-1))
            O = P[:, tab.first]
            self._cache.setdefault("origins", np.ascontiguousarray(O.transpose(1, 0, 2))[:, :, None, :])
            self.joint_table = (P, U, O)
        return self.joint_table

    def origins_xy(self) -> tuple:
        """Every link's reference point as ``(x, y)`` arrays ``(D, 1)`` (batch only): views
        of :meth:`origins`."""
        return tuple((o[..., 0], o[..., 1]) for o in self.origins())
