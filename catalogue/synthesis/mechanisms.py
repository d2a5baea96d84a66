"""Distinct inversions of a chain up to its automorphisms: frames and (frame, driver)
choices by iterated stabilisers (pynauty; McKay & Piperno 2014)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Sequence

import pynauty

from .records import _mask_links, _nauty_incidence

__all__ = ["MechanismChoices", "mechanism_choices"]


# ------------------------------------------------------------ mechanisms from chains
@dataclass(frozen=True, slots=True)
class MechanismChoices:
    """Distinct inversions of a chain up to its automorphisms.

    Attributes
    ----------
    frames : tuple of int
        One link index per orbit of links (the distinct frames).
    drivers : tuple of (int, int, int)
        One ``(frame, joint, driven link)`` per orbit: the driver is the rotation
        of the driven link relative to the frame at a joint on the frame.
    group_order : float
        Order of the automorphism group of the chain.
    """

    frames: tuple[int, ...]
    drivers: tuple[tuple[int, int, int], ...]
    group_order: float

    @property
    def n_frames(self) -> int:
        return len(self.frames)

    @property
    def n_drivers(self) -> int:
        return len(self.drivers)


def _orbit_reps(n: int, joints: Sequence[int], fixed: Sequence[int], candidates: Iterable[int]) -> list[int]:
    g = _nauty_incidence(n, joints, [{v} for v in fixed])
    _, order, _, orbits, _ = pynauty.autgrp(g)
    reps: dict[int, int] = {}
    for v in candidates:
        reps.setdefault(orbits[v], v)
    return sorted(reps.values())


def mechanism_choices(n: int, joints: Sequence[int]) -> MechanismChoices:
    """Distinct frames and (frame, driver) choices of a chain up to symmetry.

    Examples
    --------
    >>> four_bar = [0b0011, 0b0110, 0b1100, 0b1001]
    >>> c = mechanism_choices(4, four_bar)
    >>> c.n_frames, c.n_drivers, c.group_order
    (1, 1, 8.0)
    """
    joints = list(joints)
    _, order, _, _, _ = pynauty.autgrp(_nauty_incidence(n, joints))
    frames = _orbit_reps(n, joints, (), range(n))
    drivers = []
    for f in frames:
        on_f = [n + a for a, jm in enumerate(joints) if jm >> f & 1]
        for jv in _orbit_reps(n, joints, (f,), on_f):
            others = [x for x in _mask_links(joints[jv - n]) if x != f]
            for x in _orbit_reps(n, joints, (f, jv), others):
                drivers.append((f, jv - n, x))
    return MechanismChoices(tuple(frames), tuple(drivers), float(order))


def record_choices(record) -> MechanismChoices:
    """:func:`mechanism_choices` of an atlas :class:`~.records.ChainRecord`."""
    return mechanism_choices(record.n, [sum(1 << x for x in j) for j in record.joints])
