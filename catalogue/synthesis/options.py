"""What a type synthesis enumerates (:class:`SynthesisOptions`) and its independent
tasks (:class:`Task`, :func:`plan_tasks`): one per number of joints ``m = p − V`` and
residue class of nauty's generators (McKay & Piperno 2014)."""
from __future__ import annotations

from dataclasses import dataclass

from multiloop.topo.errors import InputError, explain

__all__ = ["SynthesisOptions", "Task", "n_pairs", "plan_tasks", "LITERATURE_SJ_F1"]

#: literature counts of 1-DOF simple-jointed planar chains (Mruthyunjaya 2003; Tsai 2001)
LITERATURE_SJ_F1 = {4: 1, 6: 2, 8: 16, 10: 230, 12: 6856, 14: 318162}


_MAX_LINKS = 16


# ----------------------------------------------------------------------------- options
@dataclass(frozen=True, slots=True)
class SynthesisOptions:
    """What to enumerate.

    Attributes
    ----------
    n : int
        Number of links.
    F : int
        Degrees of freedom (``3(n − 1) − 2p``).
    simple_joints : bool
        Only simple joints (``j = 1``).
    max_multiplicity : int or None
        Largest joint multiplicity ``j`` allowed.
    max_link_degree : int or None
        Largest number of joints on one link.
    planar : bool
        Keep planar chains only (incidence graph planar).
    no_fractionated : bool
        Drop fractionated chains (with a cut link or cut joint).
    """

    n: int
    F: int = 1
    simple_joints: bool = False
    max_multiplicity: int | None = None
    max_link_degree: int | None = None
    planar: bool = False
    no_fractionated: bool = False

    def __post_init__(self):
        problems = []
        if not isinstance(self.n, int) or not 2 <= self.n <= _MAX_LINKS:
            problems.append(explain("links", expected=f"an integer 2…{_MAX_LINKS}", got=repr(self.n)))
        if not isinstance(self.F, int) or self.F < 1:
            problems.append(explain("dof", expected="an integer >= 1", got=repr(self.F)))
        if self.max_multiplicity is not None and self.max_multiplicity < 1:
            problems.append(explain("max multiplicity", expected=">= 1", got=repr(self.max_multiplicity)))
        if self.max_link_degree is not None and self.max_link_degree < 2:
            problems.append(explain("max link degree", expected=">= 2", got=repr(self.max_link_degree)))
        if not problems and (3 * (self.n - 1) - self.F) % 2:
            problems.append(explain(f"n = {self.n}, F = {self.F}",
                                    expected="3(n − 1) − F even (p = (3(n − 1) − F)/2 pairs)",
                                    got=f"3(n − 1) − F = {3 * (self.n - 1) - self.F}",
                                    hint="an odd F (1, 3, 5, …) needs an even n, an even F (2, 4, …) an odd n"))
        if problems:
            raise InputError("; ".join(problems))

    @property
    def p(self) -> int:
        return n_pairs(self.n, self.F)

    @property
    def K(self) -> int:
        return self.p - self.n + 1

    @property
    def j_cap(self) -> int:
        """Largest multiplicity searched (user cap, the chain size)."""
        j = 1 if self.simple_joints else self.n - 1
        if self.max_multiplicity is not None:
            j = min(j, self.max_multiplicity)
        return j

    @property
    def i_cap(self) -> int:
        i = self.n - 1
        if self.max_link_degree is not None:
            i = min(i, self.max_link_degree)
        return i

    def key(self) -> str:
        """A stable string naming the options (used in the atlas store)."""
        return (f"n={self.n};F={self.F};sj={int(self.simple_joints)};j={self.max_multiplicity};"
                f"i={self.max_link_degree};planar={int(self.planar)};nofrac={int(self.no_fractionated)}")


def n_pairs(n: int, F: int) -> int:
    """``p = (3(n − 1) − F) / 2`` (Chebyshev–Grübler).

    Examples
    --------
    >>> n_pairs(10, 1), n_pairs(9, 2)
    (13, 11)
    """
    twice = 3 * (n - 1) - F
    if twice < 0 or twice % 2:
        raise InputError(explain(f"n = {n}, F = {F}", expected="3(n − 1) − F even and >= 0",
                                 got=str(twice)))
    return twice // 2


# ----------------------------------------------------------------------------- tasks
@dataclass(frozen=True, slots=True, order=True)
class Task:
    """One independent piece of a type synthesis: ``m`` joints, residue ``res`` of ``mod``."""

    n: int
    F: int
    m: int
    res: int = 0
    mod: int = 1

    @property
    def V(self) -> int:
        return n_pairs(self.n, self.F) - self.m

    @property
    def key(self) -> str:
        return f"n{self.n}F{self.F}m{self.m}r{self.res}of{self.mod}"


def _split(m: int, p: int, n: int) -> int:
    """Default number of residue classes for a task (balances the big tasks)."""
    if n <= 10:
        return 1
    if m == p:
        return 1
    return 8 if n <= 12 else 64


def plan_tasks(opts: SynthesisOptions, split: int | None = None) -> list[Task]:
    """The independent tasks of a type synthesis, one per joint count and residue.

    ``m`` runs over the joint counts allowed by the options: ``m = p`` (simple joints
    only) down to the fewest joints that give every link two joints
    (``2p − V = p + m >= 2n``) and respect the multiplicity cap.
    """
    p = opts.p
    tasks = []
    for m in range(p, 0, -1):
        V = p - m
        if p + m < 2 * opts.n:            # not enough corners for degree >= 2
            break
        if V > 0 and opts.j_cap < 2:
            continue
        # a joint of multiplicity j takes j pairs: m joints carry p pairs only if
        # the largest joint reaches ceil(p / m) − 1 … at most j_cap
        if -(-p // m) > opts.j_cap:
            continue
        mod = split if split is not None else _split(m, p, opts.n)
        for r in range(mod):
            tasks.append(Task(opts.n, opts.F, m, r, mod))
    return tasks
