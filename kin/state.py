"""The result of a kinematic analysis: :class:`KinematicState` (frozen).

Shapes follow one rule: a leading batch axis over positions, the last axis is the
coordinate.  ``positions`` is ``(N, n_joints, 2)``, ``angles`` is ``(N, n_links)``.

Conventions
-----------
* ``inputs[:, k]`` is the value of driver ``k``: rotation (rad) of the driver's
  ``links[1]`` relative to ``links[0]`` measured from the reference configuration,
  or the slide (m) from the reference for a P joint.
* ``positions[:, i]`` is joint ``i``'s point; for a P joint, the point of the
  *slider* that sat at the joint's ``at`` in the reference configuration.
* ``angles[:, k]`` is link ``k``'s rotation from the reference configuration (rad,
  counter-clockwise); the frame's is 0.
* Derivatives are with respect to time for the input rates ``input_rates``
  (default 1 rad/s or 1 m/s for every driver, zero input acceleration), so for one
  driver they are the paper's analogues d/dφ and d²/dφ² (Vasechkin et al. 2017).
* ``status[n]`` is ``"ok"`` or the reason position ``n`` failed (which group, why);
  ``codes[n]`` is its :class:`~kin.result.Status` (test the codes, not the text);
  failed rows are NaN.
* The arrays are read-only (the result is frozen).
"""
from __future__ import annotations

import csv
import io
from dataclasses import MISSING, dataclass, fields

import numpy as np

from multiloop.topo.model import Mechanism

from .result import BatchStatus, inputs_json, json_ready
from .rigid import move_point

__all__ = ["KinematicState", "doc_csv", "doc_text", "failure_text"]


def _read_only(d: dict, fields) -> None:
    """Each still-writable array among ``fields`` of the instance dict ``d`` replaced by
    its read-only view, in place (a frozen dataclass's own ``__setattr__`` refuses)."""
    for f in fields:                       # (keys replaced, none added: safe while iterating d)
        v = d[f]
        if type(v) is np.ndarray and v.flags.writeable:
            v = v.view()
            v.flags.writeable = False
            d[f] = v


@dataclass(frozen=True)
class KinematicState(BatchStatus):
    mechanism: Mechanism
    inputs: np.ndarray                      # (N, n_drivers)
    positions: np.ndarray                   # (N, n_joints, 2)
    angles: np.ndarray                      # (N, n_links)
    status: np.ndarray                      # (N,) object array of str
    velocities: np.ndarray | None = None    # (N, n_joints, 2)
    accelerations: np.ndarray | None = None
    omegas: np.ndarray | None = None        # (N, n_links)
    epsilons: np.ndarray | None = None
    input_rates: np.ndarray | None = None   # (n_drivers,)
    # -- added by kin.solve (fields at the end; defaults keep older callers valid)
    point_names: tuple = ()                 # tracer point names, in file order
    point_positions: np.ndarray | None = None      # (N, n_points, 2)
    point_velocities: np.ndarray | None = None
    point_accelerations: np.ndarray | None = None
    notes: tuple = ()                       # branch events, lead-in failures (plain text)
    poses: np.ndarray | None = None         # (N, n_links, 3): (X, Y, θ) of each link's reference point
    pose_rates: np.ndarray | None = None
    pose_accelerations: np.ndarray | None = None
    codes: np.ndarray | None = None         # (N,) int8 kin.result.Status per position

    def __post_init__(self) -> None:
        _read_only(self.__dict__, self.__dict__)

    @classmethod
    def frozen_from(cls, **values) -> "KinematicState":
        """The state of ``values`` (every required field; the others default) whose
        arrays the caller made read-only already (fresh arrays it owns, frozen in
        place, and views of them), ``inputs`` excepted: the caller's own array, it gets
        its read-only view here.  Built without the frozen dataclass's per-field
        ``__setattr__`` nor a check of every array's flags: the solver's compiled route,
        where building the state cost a third of a 360-position call."""
        obj = object.__new__(cls)
        d = obj.__dict__
        d.update(_DEFAULTS)
        d.update(values)
        if len(d) != len(_DEFAULTS) + len(_REQUIRED) or not _REQUIRED <= values.keys():
            raise TypeError(f"KinematicState.frozen_from: expected the fields {sorted(_REQUIRED)} and known ones, "
                            f"got {sorted(values)}")
        _read_only(d, ("inputs",))
        return obj

    def as_dict(self, formula: str | None = None, inputs_cli=None, derivatives: bool | None = None) -> dict:
        """The stable JSON document (layout: docs/kinematics.md, section 3); NaN is
        ``None``.  ``inputs_cli`` (N,): the inputs as the user gave them (deg / m),
        printed as given; default: this state's inputs in deg (R) or m (P).
        ``derivatives``: False leaves the rates out even when they were computed (for a
        figure); default: included when computed."""
        return _state_dict(self, formula, inputs_cli, derivatives)

    def point_index(self, name: str) -> int:
        return self.point_names.index(name)

    def _repr_html_(self) -> str:
        """Notebook view: a table, link angles against the input and a drawing."""
        from multiloop.kin.notebook import state_html  # noqa: PLC0415 - only when a notebook asks
        return state_html(self)

    @property
    def n_positions(self) -> int:
        return self.positions.shape[0]

    def joint_index(self, name: str) -> int:
        return self.mechanism.joint_names.index(name)

    def link_index(self, name: str) -> int:
        return self.mechanism.link_names.index(name)

    def _anchor(self, link: str) -> int:
        """Index of a joint on ``link`` whose point moves with the link."""
        m = self.mechanism
        for i, j in enumerate(m.joints):
            if link in j.links and (j.kind.value == "R" or j.links[1] == link):
                return i
        raise ValueError(f"link '{link}' has no joint point that moves with it")

    def point_on_link(self, link: str, at_ref) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """Position, velocity, acceleration of the material point of ``link`` that was at
        ``at_ref`` in the reference configuration.  Shapes ``(N, 2)``.

        Rigid-body transport from an anchor joint X of the link:
        ``P = X + R(θ) r``, ``v = v_X + ω × r'``, ``a = a_X + ε × r' − ω² r'``
        with ``r' = R(θ) r`` and ``r = at_ref − X_ref``.
        """
        m = self.mechanism
        k = self.link_index(link)
        if m.link(link).is_frame:
            p = np.broadcast_to(np.asarray(at_ref, float), (self.n_positions, 2)).copy()
            z = np.zeros_like(p)
            return p, (z if self.velocities is not None else None), (z if self.accelerations is not None else None)
        i = self._anchor(link)
        r = np.asarray(at_ref, float) - np.asarray(m.joints[i].at, float)
        w = self.omegas[:, k] if self.omegas is not None else None
        e = self.epsilons[:, k] if self.epsilons is not None else None
        return move_point(self.positions[:, i], self.angles[:, k], r, self.velocities[:, i]
                          if self.velocities is not None else None, w,
                          self.accelerations[:, i] if self.accelerations is not None else None, e)


def _list(a) -> list:
    return json_ready(np.asarray(a, float).ravel())


def _state_dict(state, formula=None, inputs_cli=None, derivatives=None) -> dict:
    """The JSON document of a :class:`~kin.state.KinematicState` (layout: module doc).
    ``inputs_cli`` (N,) or (N, n_drivers): the inputs as given on the command line
    (deg / m), printed as given (no round trip through radians)."""
    m = state.mechanism
    drivers = []
    inp = []
    for k, d in enumerate(m.drivers):
        is_r = m.is_rotary(d)
        drivers.append({"joint": d.joint, "kind": "R" if is_r else "P", "unit": "deg" if is_r else "m"})
        if inputs_cli is not None:
            x = np.asarray(inputs_cli, float)
            inp.append(x[:, k] if x.ndim == 2 else x)
        else:
            inp.append(np.degrees(state.inputs[:, k]) if is_r else state.inputs[:, k])
    doc = {"mechanism": m.name, "formula": formula,
           "drivers": drivers,
           "input": inputs_json(np.stack(inp, 1)),
           "status": [str(s) for s in state.status]}
    der = state.velocities is not None and derivatives is not False
    joints = {}
    for i, j in enumerate(m.joints):
        e = {"x": _list(state.positions[:, i, 0]), "y": _list(state.positions[:, i, 1])}
        if der:
            e.update(vx=_list(state.velocities[:, i, 0]), vy=_list(state.velocities[:, i, 1]),
                     ax=_list(state.accelerations[:, i, 0]), ay=_list(state.accelerations[:, i, 1]))
        joints[j.name] = e
    links = {}
    for k, lk in enumerate(m.link_names):
        e = {"angle": _list(np.degrees(state.angles[:, k]))}
        if der:
            e.update(omega=_list(state.omegas[:, k]), epsilon=_list(state.epsilons[:, k]))
        links[lk] = e
    points = {}
    for k, name in enumerate(state.point_names):
        e = {"x": _list(state.point_positions[:, k, 0]), "y": _list(state.point_positions[:, k, 1])}
        if der:
            e.update(vx=_list(state.point_velocities[:, k, 0]), vy=_list(state.point_velocities[:, k, 1]),
                     ax=_list(state.point_accelerations[:, k, 0]), ay=_list(state.point_accelerations[:, k, 1]))
        points[name] = e
    doc.update(joints=joints, links=links, points=points, notes=list(state.notes))
    return doc


def doc_csv(doc: dict) -> str:
    """CSV of a state document (:meth:`KinematicState.as_dict`): one row per position,
    columns ``input[_joint]``, ``status``, ``<joint>.x`` … in the document's order."""
    cols: list[tuple[str, list]] = []
    inp = doc["input"]
    if doc["drivers"] and len(doc["drivers"]) > 1:
        for k, d in enumerate(doc["drivers"]):
            cols.append((f"input_{d['joint']}", [r[k] for r in inp]))
    else:
        cols.append(("input", inp))
    cols.append(("status", doc["status"]))
    for table in ("joints", "links", "points"):
        for name, e in doc[table].items():
            for key, vals in e.items():
                cols.append((f"{name}.{key}", vals))
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow([c for c, _ in cols])
    for row in zip(*[v for _, v in cols]):
        w.writerow(["" if v is None else (repr(v) if isinstance(v, float) else v) for v in row])
    return buf.getvalue()


def doc_text(doc: dict) -> str:
    """Readable table of a state document: joint coordinates per position, failed rows
    with their reason, then the notes."""
    names = list(doc["joints"])
    units = sorted({d["unit"] for d in doc["drivers"]})
    unit = "/".join(units) + (" each driver" if len(doc["drivers"]) > 1 else "")
    head = [f"input ({unit})"] + [f"{n}.{c}" for n in names for c in "xy"]
    lines = [f"{doc['mechanism'] or 'mechanism'}: {doc['formula']}", "  ".join(f"{h:>12}" for h in head)]
    for i, s in enumerate(doc["status"]):
        x = doc["input"][i]
        x = x[0] if isinstance(x, list) else x
        if s != "ok":
            lines.append(f"{x:>12.6g}  {s}")
            continue
        vals = [doc["joints"][n][c][i] for n in names for c in "xy"]
        lines.append(f"{x:>12.6g}  " + "  ".join(f"{v:>12.6g}" for v in vals))
    for n in doc["notes"]:
        lines.append(f"note: {n}")
    return "\n".join(lines)


def failure_text(state: KinematicState, doc: dict) -> str:
    """One line on the failed positions of ``state`` (at least one), whose document is
    ``doc``: how many, and the first with its input (user units) and reason."""
    bad = np.flatnonzero(~state.ok)
    x0 = doc["input"][int(bad[0])]
    unit = "/".join(sorted({d["unit"] for d in doc["drivers"]}))
    shown = f"{x0}" if isinstance(x0, list) else f"{x0:g}"
    return f"{bad.size} of {state.n_positions} positions failed; first at input {shown} {unit}: {state.status[bad[0]]}"


_DEFAULTS = {f.name: f.default for f in fields(KinematicState) if f.default is not MISSING}
_REQUIRED = frozenset(f.name for f in fields(KinematicState) if f.default is MISSING)
