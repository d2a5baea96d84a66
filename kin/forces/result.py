"""The result of the kinetostatics, :class:`ForceResult`, and its JSON form."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from multiloop.topo.model import Mechanism

from ..result import BatchStatus, inputs_json, json_ready
from ..state import KinematicState
from .plan import Pair

__all__ = ["ForceResult", "VP_TOL", "json_list"]

#: relative virtual-power residual above which a position is not ``ok``
VP_TOL = 1e-6


def json_list(a) -> list:
    """A nested list of floats with every non-finite value as ``None`` (JSON null)."""
    return json_ready(np.asarray(a, float))


@dataclass(frozen=True)
class ForceResult(BatchStatus):
    """Result of :func:`~kin.forces.forces` (frozen; the arrays are read-only).

    Leading axis: positions.

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
        ``"ok"`` or the reason (kinematic failure, singular block, virtual-power
        residual above ``VP_TOL``).
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

    def __post_init__(self) -> None:
        for name in ("reactions", "pair_moments", "balancing", "driver_rates", "inertia_forces",
                     "inertia_moments", "load_power", "virtual_power_residual", "power_scale", "status",
                     "normal_forces"):
            a = getattr(self, name)
            if isinstance(a, np.ndarray):
                a.flags.writeable = False

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

    @property
    def inputs_user(self) -> np.ndarray:
        """Driver inputs per position in the user's units: deg (R) or m (P)."""
        m = self.mechanism
        q = np.array(self.state.inputs, float)
        for k, d in enumerate(m.drivers):
            if m.is_rotary(d):
                q[:, k] = np.degrees(q[:, k])
        return q

    def _drivers_dict(self) -> list[dict]:
        m = self.mechanism
        out = []
        for d in m.drivers:
            rotary = m.is_rotary(d)
            out.append({"joint": d.joint, "links": list(d.links), "kind": "R" if rotary else "P",
                        "speed": float(d.speed) if d.speed is not None else 1.0,
                        "acceleration": float(d.acceleration) if d.acceleration is not None else 0.0,
                        "unit": "N m" if rotary else "N"})
        return out

    def _reactions_dict(self) -> dict:
        out = {}
        for i, p in enumerate(self.pairs):
            entry = {"joint": p.joint, "kind": p.kind, "from": p.a, "on": p.b,
                     "Fx": json_list(self.reactions[:, i, 0]), "Fy": json_list(self.reactions[:, i, 1])}
            if p.kind == "P":
                entry["normal"] = json_list(self.normal_forces[:, i])
                entry["moment"] = json_list(self.pair_moments[:, i])
                entry["offset"] = json_list(self.line_of_action(p.name))
            out[p.name] = entry
        return out

    def to_text(self, notes=()) -> str:
        """Readable report (``multiloop forces``): balancing and virtual-power residual per
        position, every pair's reaction for a single position; ``notes`` are printed
        under the title."""
        m, q_user, n_drivers = self.mechanism, self.inputs_user, len(self.mechanism.drivers)
        tag = f" ({'; '.join(self.notes)})" if self.notes else ""
        lines = [f"{m.name or 'mechanism'}: kinetostatics, {self.n_positions} position(s), method {self.method}{tag}"]
        lines += [f"  note: {n}" for n in notes]
        lines.append("  blocks solved: " + " <- ".join("{" + ", ".join(b) + "}" for b in self.blocks))
        heads = ["input"] + [("Mb" if m.is_rotary(d) else "Fb") + f"[{d.joint}]"
                             for d in m.drivers] + ["VP residual", "status"]
        lines.append("  " + "  ".join(f"{h:>14}" for h in heads))
        for n in range(self.n_positions):
            row = [f"{q_user[n, 0]:14.4f}"] + [f"{self.balancing[n, i]:14.6g}" for i in range(n_drivers)] \
                + [f"{self.virtual_power_residual[n]:14.3g}", f"{self.status[n]:>14}"]
            lines.append("  " + "  ".join(row))
        if self.n_positions == 1:
            lines.append("  reactions (force of 'from' on 'on', N):")
            for i, p in enumerate(self.pairs):
                extra = ""
                if p.kind == "P":
                    extra = (f"  normal {self.normal_forces[0, i] + 0.0:.6g} N, "
                             f"couple {self.pair_moments[0, i] + 0.0:.6g} N m")
                lines.append(f"    {p.name:<28} Fx {self.reactions[0, i, 0] + 0.0:14.6g}  "
                             f"Fy {self.reactions[0, i, 1] + 0.0:14.6g}{extra}")
        bad = int(np.sum(~self.ok))
        if bad:
            lines.append(f"  {bad} position(s) failed: {self.message}")
        any_ok = self.ok.any()
        worst = np.nanmax(np.abs(self.virtual_power_residual)) if any_ok else float("nan")
        worst_rel = np.nanmax(self.relative_residual) if any_ok else float("nan")
        lines.append(f"  max |virtual power residual| = {worst:.3g} W (relative {worst_rel:.3g}; ok up to {VP_TOL:g})")
        return "\n".join(lines)

    def as_dict(self) -> dict:
        """The JSON-ready report (keys documented in docs/forces.md)."""
        m = self.mechanism
        bal = {}
        for i, d in enumerate(m.drivers):
            key = d.joint if sum(x.joint == d.joint for x in m.drivers) == 1 else f"{d.joint}:{d.links[0]}->{d.links[1]}"
            bal[key] = json_list(self.balancing[:, i])
        return {"mechanism": m.name, "method": self.method, "blocks": [list(b) for b in self.blocks],
                "notes": list(self.notes), "drivers": self._drivers_dict(), "input": inputs_json(self.inputs_user),
                "status": [str(s) for s in self.status], "balancing": bal, "reactions": self._reactions_dict(),
                "virtual_power_residual": json_list(self.virtual_power_residual),
                "relative_residual": json_list(self.relative_residual),
                "virtual_power_tolerance": VP_TOL}
