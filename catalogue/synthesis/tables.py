"""Number synthesis and the universal structural table (Pozhbelko & Kuts 2020): every
([LA], [MJA]) that satisfies the structural equations and the existence domain."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Iterator, Mapping, Sequence

from .options import SynthesisOptions
from .records import ChainRecord

__all__ = ["AssortmentRow", "number_synthesis", "universal_table", "table_rows"]


# ------------------------------------------------------------- number synthesis
@dataclass(frozen=True, slots=True)
class AssortmentRow:
    """One row of the universal structural table.

    ``chains`` is the number of non-degenerate non-isomorphic chains realising
    ([LA], [MJA]) (``None`` when type synthesis was not run).
    """

    LA: tuple[int, ...]
    MJA: tuple[int, ...]
    V: int
    K: int
    n_joints: int
    chains: int | None = None
    in_domain: bool = True

    @property
    def realisable(self) -> bool | None:
        return None if self.chains is None else self.chains > 0

    @property
    def code_star(self) -> str:
        from multiloop.topo.numbers import structural_codes
        degrees = [i for i, c in enumerate(self.LA, 2) for _ in range(c)]
        mult = [j for j, c in enumerate(self.MJA, 2) for _ in range(c)]
        mult += [1] * (self.n_joints - len(mult))          # the simple joints
        codes = structural_codes(degrees, mult)
        assert codes.K == self.K   # the row satisfies the structural equations
        return codes.code_star

    def as_dict(self) -> dict:
        return {"LA": list(self.LA), "MJA": list(self.MJA), "V": self.V, "K": self.K,
                "n_joints": self.n_joints, "code_star": self.code_star,
                "chains": self.chains, "realisable": self.realisable, "in_domain": self.in_domain}


def _compositions(total_items: int, total_weight: int, weights: Sequence[int]) -> Iterator[tuple[int, ...]]:
    """Non-negative (c_k) with Σ c_k = total_items and Σ c_k w_k = total_weight."""
    if not weights:
        if total_items == 0 and total_weight == 0:
            yield ()
        return
    w, rest = weights[0], weights[1:]
    for c in range(total_items + 1):
        if c * w > total_weight:
            break
        for tail in _compositions(total_items - c, total_weight - c * w, rest):
            yield (c,) + tail


def _strip(t: tuple[int, ...]) -> tuple[int, ...]:
    t = list(t)
    while t and t[-1] == 0:
        t.pop()
    return tuple(t)


def number_synthesis(opts: SynthesisOptions) -> list[AssortmentRow]:
    """All ([LA], [MJA]) satisfying the structural equations and the existence domain.

    Equations: ``m = p − V`` joints with ``Σ_j j V_j <= p`` (simple joints take the
    rest), ``Σ n_i = n`` and ``Σ i n_i = 2p − V``; link degrees ``2 <= i <= m``;
    existence domain ``j <= K`` and ``V <= 2(K − 1)`` (Pozhbelko & Kuts 2020 fig. 10).
    """
    n, p, K = opts.n, opts.p, opts.K
    jtop = min(opts.j_cap, K)
    rows = []
    mjas: list[tuple[int, ...]] = []
    # multiple joints: V_j for j = 2..jtop with V = Σ (j − 1) V_j <= 2(K − 1), Σ j V_j <= p
    def rec(j: int, acc: tuple[int, ...], V: int, pairs: int):
        if j > jtop:
            mjas.append(acc)
            return
        c = 0
        while V + c * (j - 1) <= 2 * (K - 1) and pairs + c * j <= p:
            rec(j + 1, acc + (c,), V + c * (j - 1), pairs + c * j)
            c += 1
    rec(2, (), 0, 0)
    for mja in mjas:
        V = sum((j - 1) * c for j, c in zip(range(2, jtop + 1), mja))
        if V > 2 * max(K - 1, 0):
            continue
        m = p - V
        corners = 2 * p - V
        itop = min(opts.i_cap, m)
        for la in _compositions(n, corners, list(range(2, itop + 1))):
            rows.append(AssortmentRow(_strip(la), _strip(mja), V, K, m))
    return sorted(rows, key=lambda r: (r.V, r.MJA, r.LA))


def universal_table(opts: SynthesisOptions, records: Iterable[ChainRecord]) -> list[AssortmentRow]:
    """:func:`number_synthesis` rows with the number of chains realising each.

    A chain whose assortments lie outside the existence domain gets an extra row with
    ``in_domain = False`` (none for F = 1 and 2 in the atlases computed; for F = 3 a
    fractionated chain with a cut joint of multiplicity ``j = K + 1`` exists, e.g.
    n = 10: four loops hung on one 5-link pin).
    """
    counts: dict[tuple, int] = {}
    for r in records:
        key = (_strip(r.LA), _strip(r.MJA))
        counts[key] = counts.get(key, 0) + 1
    return table_rows(opts, counts)


def table_rows(opts: SynthesisOptions, counts: Mapping[tuple, int]) -> list[AssortmentRow]:
    """:func:`number_synthesis` rows with their chains from ``counts``
    (``{(LA, MJA): chains}``, assortments without trailing zeros); a row the counts have
    outside the existence domain is added with ``in_domain = False``.  With a restricted
    row in ``opts`` only that row is listed."""
    counts = dict(counts)
    rows = [AssortmentRow(r.LA, r.MJA, r.V, r.K, r.n_joints, counts.pop((r.LA, r.MJA), 0))
            for r in number_synthesis(opts) if _in_restriction(opts, r.LA, r.MJA)]
    # chains outside the existence domain (found for F >= 3: cut joints of high
    # multiplicity) are listed too, flagged in_domain = False
    K = opts.K
    for (LA, MJA), c in sorted(counts.items()):
        V = sum((j - 1) * v for j, v in zip(range(2, 2 + len(MJA)), MJA))
        rows.append(AssortmentRow(LA, MJA, V, K, opts.p - V, c, in_domain=False))
    return rows


def _in_restriction(opts: SynthesisOptions, LA: tuple[int, ...], MJA: tuple[int, ...]) -> bool:
    return ((opts.la is None or _strip(opts.la) == LA)
            and (opts.mja is None or _strip(opts.mja) == MJA))
