"""What a type synthesis enumerates (:class:`SynthesisOptions`) and its independent
tasks (:class:`Task`, :func:`plan_tasks`): one per number of joints ``m = p − V`` and
residue class of nauty's generators (McKay & Piperno 2014)."""
from __future__ import annotations

from dataclasses import dataclass

from multiloop.topo.errors import InputError, explain

__all__ = ["SynthesisOptions", "Task", "n_pairs", "plan_tasks", "joint_counts", "LITERATURE_SJ_F1"]

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
    la : tuple of int, optional
        One link assortment [LA] = (n2, n3, …): the enumeration itself is restricted to
        it (the generator's degree bounds and the compiled counter's pruning), so one
        row of the number-synthesis table can be recounted alone.
    mja : tuple of int, optional
        One multiple-joint assortment [MJA] = (V2, V3, …) (``()`` for simple joints
        only); it fixes the joint count ``m = p − V``.
    """

    n: int
    F: int = 1
    simple_joints: bool = False
    max_multiplicity: int | None = None
    max_link_degree: int | None = None
    planar: bool = False
    no_fractionated: bool = False
    la: tuple[int, ...] | None = None
    mja: tuple[int, ...] | None = None

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
        if not problems:
            problems += self._row_problems()
        if problems:
            raise InputError("; ".join(problems))

    def _row_problems(self) -> list[str]:
        """The restriction to one row checked against the structural equations
        (``Σ n_i = n``, ``Σ i n_i = 2p − V``, ``m = p − V`` joints of which ``Σ V_j`` multiple)."""
        out = []
        for name, counts in (("la", self.la), ("mja", self.mja)):
            if counts is not None and not (isinstance(counts, tuple)
                                           and all(isinstance(c, int) and c >= 0 for c in counts)):
                out.append(explain(name, expected="a tuple of counts >= 0", got=repr(counts)))
        if out:
            return out
        p = self.p
        if self.mja is not None:
            V = self.row_V
            if self.simple_joints and V:
                out.append(explain("mja", expected="() with simple_joints", got=repr(self.mja)))
            if V > p or sum(self.mja) > p - V:
                out.append(explain("mja", expected=f"at most m = p − V joints (p = {p})",
                                   got=f"{self.mja}: V = {V}, {sum(self.mja)} multiple joints"))
        if self.la is not None:
            if sum(self.la) != self.n:
                out.append(explain("la", expected=f"{self.n} links (Σ n_i = n)", got=f"{self.la}: {sum(self.la)}"))
            elif self.mja is not None and not out:
                corners = sum(i * c for i, c in enumerate(self.la, 2))
                if corners != 2 * p - self.row_V:
                    out.append(explain("la", expected=f"Σ i n_i = 2p − V = {2 * p - self.row_V}",
                                       got=f"{self.la}: {corners}",
                                       hint="a row of the number-synthesis table (multiloop atlas --table)"))
        return out

    @property
    def row_V(self) -> int:
        """The MJ factor ``V = Σ (j − 1) V_j`` of the restricted [MJA] (0 without one)."""
        return sum((j - 1) * c for j, c in enumerate(self.mja or (), 2))

    def link_degrees(self) -> tuple[int, int]:
        """The smallest and largest number of joints a link may carry.

        At most ``i_cap``, and for ``F = 1`` at most ``K + 1``: a one-freedom chain has
        no cut link (the two parts of a cut link ``L`` give ``F = F_A + F_B`` with
        ``F_A, F_B >= 1`` in a non-degenerate chain), so the chain without ``L`` stays
        connected and the ``i`` joints of ``L`` close ``i − 1`` independent loops
        through it: ``i <= K + 1``.
        """
        top = self.i_cap if self.F > 1 else min(self.i_cap, self.K + 1)
        if self.la and any(self.la):
            used = [i for i, c in enumerate(self.la, 2) if c]
            return used[0], min(used[-1], top)
        return 2, top

    def joint_sizes(self, m: int) -> tuple[int, int]:
        """The fewest and most links on one of ``m`` joints.

        At most ``j_cap + 1`` links, and for ``F <= 2`` at most ``K + 1``: a chain of one or
        two freedoms has no cut joint (the two parts of a cut joint ``J`` give
        ``F = F_A + F_B + 1`` with ``F_A, F_B >= 1`` in a non-degenerate chain), so the
        ``j + 1`` links on ``J`` stay connected without it and close ``j`` independent
        loops through it: ``j <= K``.
        """
        top = (self.j_cap if self.F > 2 else min(self.j_cap, self.K)) + 1
        if self.mja is None:
            return 2, top
        used = [j + 1 for j, c in enumerate(self.mja, 2) if c]
        simple = m - sum(self.mja)
        return (2 if simple else min(used, default=2)), min(max(used, default=2), top)

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
        key = (f"n={self.n};F={self.F};sj={int(self.simple_joints)};j={self.max_multiplicity};"
               f"i={self.max_link_degree};planar={int(self.planar)};nofrac={int(self.no_fractionated)}")
        if self.la is not None or self.mja is not None:
            key += f";la={_dashed(self.la)};mja={_dashed(self.mja)}"
        return key


def _dashed(counts: tuple[int, ...] | None) -> str:
    return "*" if counts is None else "-".join(map(str, counts))


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
    """One independent piece of a type synthesis: ``m`` joints, residue ``res`` of ``mod``
    of the generator's nodes at its split ``level`` (joints placed; None: nauty's default,
    two levels above the output)."""

    n: int
    F: int
    m: int
    res: int = 0
    mod: int = 1
    level: int | None = None

    @property
    def V(self) -> int:
        return n_pairs(self.n, self.F) - self.m

    @property
    def key(self) -> str:
        tail = "" if self.level is None else f"L{self.level}"
        return f"n{self.n}F{self.F}m{self.m}r{self.res}of{self.mod}{tail}"


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
    return [Task(opts.n, opts.F, m, r, mod) for m in joint_counts(opts)
            for mod in [split if split is not None else _split(m, opts.p, opts.n)] for r in range(mod)]


def joint_counts(opts: SynthesisOptions) -> list[int]:
    """The joint counts ``m`` of the options, from ``p`` (simple joints) down."""
    p = opts.p
    out = []
    for m in range(p, 0, -1):
        V = p - m
        if opts.mja is not None and V != opts.row_V:
            continue
        if p + m < 2 * opts.n:            # not enough corners for degree >= 2
            break
        if V > 0 and opts.j_cap < 2:
            continue
        # a joint of multiplicity j takes j pairs: m joints carry p pairs only if
        # the largest joint reaches ceil(p / m) − 1 … at most j_cap
        if -(-p // m) > opts.j_cap:
            continue
        out.append(m)
    return out
