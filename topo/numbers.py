"""Structural numbers of a planar linkage with multiple joints (Pozhbelko & Kuts 2020).

Notation of Pozhbelko & Kuts: ``n_i`` links with i joints (the frame
included), ``n = Σ n_i``; ``V_j`` joints of multiplicity j (a pin on ``n'`` links has
``j = n' − 1``); ``p = Σ (n' − 1)`` pairs in simple-joint equivalent.

=========  ==========================================================================
symbol     formula (every one computed by the routes named; the routes must agree)
=========  ==========================================================================
V          ``Σ_{j>=2} (j − 1) V_j``
K          ``p − n + 1`` (cyclomatic number of the incidence graph) **and**
           ``1 + ½ (V + Σ_{i>=3} (i − 2) n_i)`` (Pozhbelko & Kuts 2020)
L          ``K + 1``
AVC        ``2(K − 1) − V − Σ_{i>=3} (i − 2) n_i`` with K from the graph (0 when valid)
F          ``3(n − 1) − 2p`` = ``(n − 1) − 2K`` = ``n2 − V − 3 − Σ_{i>=4} (i − 3) n_i``
rc         ``(N + V + 3) − (n2 − Σ_{i>=4} (i − 3) n_i)`` = ``N − F``
SL         ``2(F + 3K) − V`` = ``Σ i n_i``
F_λ        ``λ(n − 1) − Σ (λ − f_k) p_k`` (Dobrovolsky/Malyshev; f_k = 1 for R and P)
=========  ==========================================================================

Codes: [LA] lists ``n2 … n_imax`` with ``imax = max(K + 1, largest i)``; [MJA] lists
``V2 … V_jmax`` with ``jmax = max(K, largest j)`` (at least V2); counts are concatenated, a count
of two or more digits is separated from its neighbours by ``.``; [MJA] entries are
joined by ``-``.  ``Code = [LA]/V``, ``Code* = [LA]/[MJA]`` (e.g. ``[8110]/3``,
``[11.0001]/[0-0-0-1]``).

References
----------
.. [1] V. A. Pozhbelko, E. N. Kuts, "Structural analysis of multi-loop linkages with
   multiple joints" (2020) — Pozhbelko & Kuts 2020, eqs. for K, AVC, F, rc, SL and the codes.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import NamedTuple, Sequence

from .degeneracy import find_rigid_subchain, fractionation
from .errors import TopologyError, explain
from .isomorphism import canonical_form
from .loops import loop_assortment
from .mobility import actual_mobility
from .model import Mechanism

__all__ = ["StructuralReport", "structural_report", "StructuralCodes", "structural_codes",
           "format_counts", "link_assortment",
           "joint_assortment", "spatial_mobility"]


def format_counts(counts, sep: str = "") -> str:
    """Pozhbelko & Kuts 2020 formatting of a list of counts.

    Examples
    --------
    >>> format_counts([8, 1, 1, 0]), format_counts([11, 0, 0, 0, 1]), format_counts([10, 0, 1, 1])
    ('8110', '11.0001', '10.011')
    >>> format_counts([3, 0, 0], sep="-")
    '3-0-0'
    """
    tokens = [str(int(c)) for c in counts]
    if sep:
        return sep.join(tokens)
    out = ""
    for k, tok in enumerate(tokens):
        if k and (len(tok) > 1 or len(tokens[k - 1]) > 1):
            out += "."
        out += tok
    return out


def link_assortment(m: Mechanism, imax: int | None = None) -> tuple[int, ...]:
    """(n2, n3, …, n_imax): numbers of links by their number of joints."""
    degrees = [m.degree(x) for x in m.link_names]
    top = max(max(degrees), imax or 0)
    return tuple(sum(1 for d in degrees if d == i) for i in range(2, top + 1))


def joint_assortment(m: Mechanism, jmax: int | None = None) -> tuple[int, ...]:
    """(V2, V3, …, V_jmax): numbers of joints by multiplicity j >= 2."""
    mult = [j.multiplicity for j in m.joints]
    top = max(max(mult), jmax or 0, 1)
    return tuple(sum(1 for x in mult if x == j) for j in range(2, top + 1))


class StructuralCodes(NamedTuple):
    """Assortments and codes of a chain (see :func:`structural_codes`)."""

    LA: tuple[int, ...]
    MJA: tuple[int, ...]
    V: int
    K: int
    j_max: int
    code: str
    code_star: str


def structural_codes(degrees: Sequence[int], multiplicities: Sequence[int]) -> StructuralCodes:
    """[LA], [MJA], V, K and the Pozhbelko & Kuts 2020 codes from the raw incidence data: the number
    of joints on every link and the multiplicity ``j = n' − 1`` of every joint.

    The one place where the code formatting rules live (``structural_report``, the
    atlas and the catalogue listing all call it).

    Examples
    --------
    >>> structural_codes([2] * 8 + [3, 4], [1] * 7 + [2, 2, 2]).code_star
    '[8110]/[3-0-0]'
    """
    degrees, mult = list(degrees), list(multiplicities)
    K = sum(mult) - len(degrees) + 1
    j_max = max(mult)
    V = sum(j - 1 for j in mult if j >= 2)
    LA = tuple(degrees.count(i) for i in range(2, max(degrees) + 1))
    MJA = tuple(mult.count(j) for j in range(2, max(j_max, 1) + 1))
    imax_code = max(K + 1, max(degrees))
    jmax_code = max(K, j_max, 2)   # at least V2, so a chain with K = 1 reads [LA]/[0]
    la_code = format_counts([degrees.count(i) for i in range(2, imax_code + 1)])
    mja_code = format_counts([mult.count(j) for j in range(2, jmax_code + 1)], sep="-")
    return StructuralCodes(LA, MJA, V, K, j_max, f"[{la_code}]/{V}", f"[{la_code}]/[{mja_code}]")


def spatial_mobility(m: Mechanism, lam: int = 3) -> int:
    """Mobility in a space of ``lam`` freedoms: ``λ(n − 1) − (λ − 1) p`` (all pairs have
    one freedom).  ``lam = 6`` for a planar linkage seen in space gives the designer's
    count of redundant constraints ``q = F − F_6`` (3 for a four-bar)."""
    p = sum(j.n_pairs for j in m.joints)
    return lam * (m.n_links - 1) - (lam - 1) * p


@dataclass(frozen=True)
class StructuralReport:
    """All structural numbers of a chain or mechanism (Pozhbelko & Kuts 2020, the structural numbers (README)).

    ``as_dict()`` gives the stable JSON of ``multiloop analyse --json``.
    """

    name: str | None
    n: int
    p: int
    n_joints: int
    LA: tuple[int, ...]
    MJA: tuple[int, ...]
    V: int
    K: int
    K_formula: float
    L: int
    AVC: float
    F: int
    F_routes: tuple[float, float, float]
    N: int
    rc: int
    rc_formula: int
    SL: int
    SL_formula: int
    La: tuple[int, ...] | None
    L0: int | None
    planar: bool
    code: str
    code_star: str
    degenerate: bool
    rigid_subchain: tuple[str, ...] | None
    fractionated: bool
    cut_links: tuple[str, ...]
    cut_joints: tuple[str, ...]
    existence_ok: bool
    j_max: int
    F_space: int
    rc_space: int
    lam: int
    canonical: str
    has_frame: bool
    dangling: tuple[str, ...] = ()
    actual_F: int | None = None
    redundant: tuple[str, ...] | None = None
    warnings: tuple[str, ...] = field(default_factory=tuple)
    la_rule: str = ""

    @property
    def consistent(self) -> bool:
        """All routes agree (K, F, SL) and AVC = 0."""
        return (self.K == self.K_formula and self.AVC == 0 and self.SL == self.SL_formula
                and len(set(self.F_routes)) == 1)

    def _repr_html_(self) -> str:
        """Notebook view: the numbers and bars of [LA], [MJA] (:mod:`topo.svg`)."""
        from .svg import report_html  # noqa: PLC0415 - only when a notebook asks
        return report_html(self)

    def labelled(self) -> list[tuple[str, str]]:
        """The report as (name, value) rows in the order of Pozhbelko & Kuts 2020's bullet
        list: the names ``multiloop analyse`` prints and the workbench's Structure tab shows."""
        la = "-".join(map(str, self.La)) if self.La is not None else "— (non-planar)"
        rows = [
            ("name", self.name or "(unnamed)"),
            ("links n", self.n),
            ("joints / pairs p", f"{self.n_joints} / {self.p}"),
            ("link assortment [LA]", "[" + " ".join(f"n{i + 2}={c}" for i, c in enumerate(self.LA) if c) + "]"),
            ("multiple-joint assortment [MJA]", "[" + (" ".join(f"V{j + 2}={c}" for j, c in enumerate(self.MJA) if c) or "none") + "]"),
            ("MJ factor V", self.V),
            ("loops K (graph / formula)", f"{self.K} / {self.K_formula:g}"),
            ("all loops L = K + 1", self.L),
            ("AVC", f"{self.AVC:g}" + ("  (assembly check passed)" if self.AVC == 0 else "  (INCONSISTENT data)")),
            ("mobility F (3 routes)", " = ".join(f"{x:g}" for x in self.F_routes)),
            ("drivers N", self.N),
            ("redundant constraints rc = N - F", self.rc),
            ("sides of all loops SL (2 routes)", f"{self.SL} / {self.SL_formula}"),
            ("loop assortment [La]", la + (f"  (L0 = {self.L0})" if self.L0 is not None else "")),
            ("code", self.code),
            ("code*", self.code_star),
            ("planar", "yes" if self.planar else "no"),
            ("degenerate", ("yes: rigid sub-chain {" + ", ".join(self.rigid_subchain) + "}") if self.degenerate else "no"),
            ("fractionated", ("yes: " + ", ".join([f"cut link {x}" for x in self.cut_links] + [f"cut joint {x}" for x in self.cut_joints])) if self.fractionated else "no"),
            ("existence domain (j <= K, V <= 2(K-1))", ("ok" if self.existence_ok else "VIOLATED") + f"  (j_max = {self.j_max}, V = {self.V}, K = {self.K})"),
            (f"mobility in λ = {self.lam} space / redundant", f"{self.F_space} / {self.rc_space}"),
        ]
        if self.actual_F is not None:
            rows.append(("actual mobility (Jacobian rank)", str(self.actual_F) + (f"; redundant: {', '.join(self.redundant)}" if self.redundant else "")))
        rows.append(("canonical form", self.canonical if len(self.canonical) <= 60 else self.canonical[:57] + "..."))
        return [(k, str(v)) for k, v in rows]

    def to_text(self) -> str:
        """A readable table in the order of Pozhbelko & Kuts 2020's bullet list (``multiloop analyse``)."""
        rows = self.labelled()
        width = max(len(k) for k, _ in rows)
        lines = [f"  {k:<{width}}  {v}" for k, v in rows]
        lines.append(f"  [La] rule: {self.la_rule}")
        for w in self.warnings:
            lines.append(f"  warning: {w}")
        return "\n".join(lines)

    def as_dict(self) -> dict:
        """The stable JSON of ``multiloop analyse --json`` (and a few more, documented in the README)."""
        d = asdict(self)
        out = {k: d[k] for k in ("n", "p", "LA", "MJA", "V", "K", "L", "AVC", "F", "N", "rc",
                                 "SL", "La", "L0", "code", "code_star", "planar", "degenerate",
                                 "fractionated", "canonical")}
        out["LA"] = list(self.LA)
        out["MJA"] = list(self.MJA)
        out["La"] = None if self.La is None else list(self.La)
        for key in ("AVC",):
            out[key] = _intify(out[key])
        out.update({
            "name": self.name,
            "n_joints": self.n_joints,
            "K_formula": _intify(self.K_formula),
            "F_routes": [_intify(x) for x in self.F_routes],
            "SL_formula": self.SL_formula,
            "rigid_subchain": None if self.rigid_subchain is None else list(self.rigid_subchain),
            "cut_links": list(self.cut_links),
            "cut_joints": list(self.cut_joints),
            "existence_domain": {"ok": self.existence_ok, "j_max": self.j_max, "V": self.V,
                                 "K": self.K},
            "spatial": {"lambda": self.lam, "F": self.F_space, "rc": self.rc_space},
            "actual_F": self.actual_F,
            "redundant": None if self.redundant is None else list(self.redundant),
            "dangling": list(self.dangling),
            "consistent": self.consistent,
            "warnings": list(self.warnings),
            "La_rule": self.la_rule,
        })
        return out


def _intify(x):
    return int(x) if float(x).is_integer() else float(x)


def structural_report(m: Mechanism, n_drivers: int | None = None, lam: int = 3,
                      geometry: bool = True, loops: bool = True) -> StructuralReport:
    """Compute every structural number of the structural numbers (README) for a chain or mechanism.

    Parameters
    ----------
    m : Mechanism
    n_drivers : int, optional
        N; defaults to the number of drivers in the file.
    lam : int
        λ of the mobility check in a λ-space (default 3, planar; 6 gives the
        designer's count of redundant constraints, e.g. 3 for a four-bar).
    geometry : bool
        When the file has geometry, also compute the actual mobility from the rank of
        the constraint Jacobian at the reference configuration (``topo.mobility``).
    loops : bool
        Compute the loop assortment (planar embedding search).

    Raises
    ------
    TopologyError
        A joint on fewer than two links (cannot be built through the model anyway).

    Examples
    --------
    >>> from multiloop.topo.model import chain_from_joint_lists
    >>> r = structural_report(chain_from_joint_lists([["a", "b"], ["b", "c"], ["c", "d"], ["d", "a"]]))
    >>> r.K, r.F, r.code, r.La
    (1, 1, '[4]/0', (4, 4))
    """
    if any(len(j.links) < 2 for j in m.joints):  # pragma: no cover - builder forbids it
        raise TopologyError(explain("joint", expected="two or more links", got="fewer"))
    c = _counts(m, len(m.drivers) if n_drivers is None else int(n_drivers))
    codes = structural_codes(list(c.degrees.values()), [j.multiplicity for j in m.joints])
    if loops:
        la = loop_assortment(m)
        La, L0, planar, rule = la.sizes, la.outer, la.planar, la.rule
    else:
        La, L0, planar, rule = None, None, False, "not computed"
    rigid = find_rigid_subchain(m)
    frac = fractionation(m)
    existence_ok = codes.j_max <= c.K and c.V <= 2 * (c.K - 1)
    F_space = spatial_mobility(m, lam)
    dangling = tuple(x for x, d in c.degrees.items() if d < 2)
    warnings = _count_warnings(c, dangling, existence_ok, codes.j_max)
    actual_F, redundant = None, None
    if geometry and m.has_geometry and m.frame is not None:
        mob = actual_mobility(m)
        actual_F, redundant = int(mob.actual_F), tuple(mob.redundant)
        if actual_F != c.F1:
            warnings.append(f"the geometry moves with {actual_F} DOF although the formula "
                            f"gives F = {c.F1}: special dimensions (redundant constraints: "
                            f"{', '.join(redundant) or 'see decompose'})")
    rc_space = (actual_F if actual_F is not None else c.F1) - F_space
    return StructuralReport(
        name=m.name, n=c.n, p=c.p, n_joints=m.n_joints, LA=codes.LA, MJA=codes.MJA, V=c.V, K=c.K,
        K_formula=c.K_formula, L=c.K + 1, AVC=c.AVC, F=c.F1, F_routes=(c.F1, c.F2, c.F3), N=c.N,
        rc=c.N - c.F1, rc_formula=c.rc_formula, SL=c.SL, SL_formula=c.SL_formula, La=La, L0=L0,
        planar=planar, code=codes.code, code_star=codes.code_star, degenerate=rigid is not None,
        rigid_subchain=rigid, fractionated=frac.is_fractionated, cut_links=frac.cut_links,
        cut_joints=frac.cut_joints, existence_ok=existence_ok, j_max=codes.j_max, F_space=F_space,
        rc_space=rc_space, lam=lam, canonical=canonical_form(m, "chain"), has_frame=m.frame is not None,
        dangling=dangling, actual_F=actual_F, redundant=redundant, warnings=tuple(warnings),
        la_rule=rule)


@dataclass(frozen=True)
class _Counts:
    """The counting formulas of Pozhbelko & Kuts 2020, each by every route."""

    degrees: dict[str, int]
    n: int
    p: int
    N: int
    K: int
    K_formula: float
    V: int
    AVC: float
    F1: int
    F2: int
    F3: int
    rc_formula: int
    SL: int
    SL_formula: int


def _counts(m: Mechanism, N: int) -> _Counts:
    """Loops K, multiple-joint factor V, AVC, mobility F (three routes), rc and SL."""
    n, p = m.n_links, sum(j.n_pairs for j in m.joints)
    degrees = {x: m.degree(x) for x in m.link_names}
    K = p - n + 1
    V = sum(j.multiplicity - 1 for j in m.joints if j.multiplicity >= 2)
    sum_i3 = sum(d - 2 for d in degrees.values() if d >= 3)
    sum_i4 = sum(d - 3 for d in degrees.values() if d >= 4)
    n2 = sum(1 for d in degrees.values() if d == 2)
    F1 = 3 * (n - 1) - 2 * p
    return _Counts(degrees, n, p, N, K, K_formula=1 + 0.5 * (V + sum_i3), V=V,
                   AVC=2 * (K - 1) - V - sum_i3, F1=F1, F2=(n - 1) - 2 * K, F3=n2 - V - 3 - sum_i4,
                   rc_formula=(N + V + 3) - (n2 - sum_i4), SL=sum(degrees.values()),
                   SL_formula=2 * (F1 + 3 * K) - V)


def _count_warnings(c: _Counts, dangling, existence_ok: bool, j_max: int) -> list[str]:
    """Dangling links, routes that disagree, and a chain outside the existence domain."""
    out = []
    if dangling:
        out.append(f"link(s) {', '.join(dangling)} lie on fewer than two joints: "
                   "the paper's K formula assumes every link has two or more joints, so AVC != 0")
    if c.K != c.K_formula or c.AVC != 0:
        out.append(f"inconsistent structure: K from the graph = {c.K}, formula = {c.K_formula:g}, "
                   f"AVC = {c.AVC:g} (expected 0)")
    if not existence_ok:
        out.append(f"outside the existence domain of Pozhbelko & Kuts 2020 fig. 10: j_max = {j_max} "
                   f"(<= K = {c.K}?), V = {c.V} (<= 2(K-1) = {2 * (c.K - 1)}?)")
    return out
