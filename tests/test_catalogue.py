"""The bundled catalogue (catalogue/mechanisms/*.toml).

Three layers:

* every file loads, names itself after its file and cites a source;
* the reconstructions of Pozhbelko & Kuts 2020 reproduce every published column of the structural numbers (README)
  (oracles below, each with its citation), computed by ``topo.numbers.structural_report``;
* every mechanism with geometry has the intended mobility at its reference
  configuration (rank of the constraint Jacobian: actual DOF = number of drivers,
  no redundant constraint) and moves through a range of its drivers by a small
  Newton continuation (residual <= 1e-9, no singular Jacobian on the way).

The geometric checks use a self-contained **pose formulation** (independent of
``kin/``): unknowns ``(x, y, θ)`` per link, every link at pose 0 in the reference
configuration (so a joint's local coordinates are its ``at``).  Equations: the frame
pose is 0 (3); an R joint on k links gives ``2(k − 1)``; a P joint gives 2 (equal
angles of guide and slider, zero normal offset of the slider point from the guide
line); a driver gives 1 (relative angle of an R joint's ``links[1]`` w.r.t.
``links[0]``, or the slide along a P joint's guide).  It has the same rank
information as the points formulation (2k − 3 distances per k-joint link).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from multiloop.catalogue.named import load_named, names, path
from multiloop.topo.model import JointKind, Mechanism
from multiloop.topo.numbers import structural_report

# ---------------------------------------------------------------------------
# geometry helpers (pose formulation)


class PoseSystem:
    """Constraint equations Φ(q, v) = 0 of a mechanism with geometry.

    ``q`` has shape ``(3 n,)``: ``(x, y, θ)`` of every link; ``v`` the driver values
    (radians or metres from the reference).  ``jacobian(q)`` is ∂Φ/∂q for the
    equations *with* the driver rows last; ``n_drivers`` rows are drivers.
    """

    def __init__(self, m: Mechanism):
        self.m = m
        self.index = {name: i for i, name in enumerate(m.link_names)}
        self.n = len(self.index)
        self.n_drivers = len(m.drivers)
        self.frame = self.index[m.frame]
        pts = np.array([j.at for j in m.joints], float)
        #: a length scale (joint spread) so that angle columns are comparable with x, y
        self.length = float(np.max(np.ptp(pts, axis=0))) or 1.0
        self.column_scale = np.tile([1.0, 1.0, self.length], self.n)

    def _pose(self, q, link):
        i = 3 * self.index[link]
        return q[i], q[i + 1], q[i + 2]

    def _point(self, q, link, a):
        x, y, t = self._pose(q, link)
        c, s = math.cos(t), math.sin(t)
        return np.array([x + c * a[0] - s * a[1], y + s * a[0] + c * a[1]])

    def _dpoint(self, q, link, a):
        """∂(point)/∂(x, y, θ) of the link: a 2×3 block and its column offset."""
        _, _, t = self._pose(q, link)
        c, s = math.cos(t), math.sin(t)
        return np.array([[1.0, 0.0, -s * a[0] - c * a[1]],
                         [0.0, 1.0, c * a[0] - s * a[1]]]), 3 * self.index[link]

    def residual_and_jacobian(self, q, v=None, drivers=True):
        rows, jac = [], []
        nq = 3 * self.n

        def row():
            return np.zeros(nq)

        f = 3 * self.frame
        for k in range(3):
            r = row()
            r[f + k] = 1.0
            rows.append(q[f + k])
            jac.append(r)
        for j in self.m.joints:
            a = np.asarray(j.at, float)
            if j.kind is JointKind.R:
                base = j.links[0]
                p0 = self._point(q, base, a)
                d0, c0 = self._dpoint(q, base, a)
                for other in j.links[1:]:
                    p1 = self._point(q, other, a)
                    d1, c1 = self._dpoint(q, other, a)
                    for k in range(2):
                        r = row()
                        r[c1:c1 + 3] += d1[k]
                        r[c0:c0 + 3] -= d0[k]
                        rows.append(p1[k] - p0[k])
                        jac.append(r)
            else:
                g, s = j.links
                r = row()
                r[3 * self.index[s] + 2] += 1.0
                r[3 * self.index[g] + 2] -= 1.0
                rows.append(self._pose(q, s)[2] - self._pose(q, g)[2])
                jac.append(r)
                val, grad = self._slide(q, j, normal=True)
                rows.append(val)
                jac.append(grad)
        if drivers:
            v = np.zeros(self.n_drivers) if v is None else np.atleast_1d(v)
            for d, value in zip(self.m.drivers, v):
                j = self.m.joint(d.joint)
                if j.kind is JointKind.R:
                    r = row()
                    r[3 * self.index[d.links[1]] + 2] += 1.0
                    r[3 * self.index[d.links[0]] + 2] -= 1.0
                    rows.append(self._pose(q, d.links[1])[2] - self._pose(q, d.links[0])[2] - value)
                    jac.append(r)
                else:
                    val, grad = self._slide(q, j, normal=False)
                    rows.append(val - value)
                    jac.append(grad)
        return np.array(rows), np.array(jac)

    def _slide(self, q, j, normal: bool):
        """Normal offset (or slide) of the slider's point from the guide's point,
        measured along the guide's (rotated) normal (or axis)."""
        g, s = j.links
        a = np.asarray(j.at, float)
        u = np.asarray(j.axis, float)
        u = u / np.hypot(*u)
        if normal:
            u = np.array([-u[1], u[0]])
        tg = self._pose(q, g)[2]
        c, sn = math.cos(tg), math.sin(tg)
        w = np.array([c * u[0] - sn * u[1], sn * u[0] + c * u[1]])
        dw = np.array([-sn * u[0] - c * u[1], c * u[0] - sn * u[1]])
        ps, pg = self._point(q, s, a), self._point(q, g, a)
        ds, cs = self._dpoint(q, s, a)
        dg, cg = self._dpoint(q, g, a)
        grad = np.zeros(3 * self.n)
        grad[cs:cs + 3] += w @ ds
        grad[cg:cg + 3] -= w @ dg
        grad[cg + 2] += dw @ (ps - pg)
        return float(w @ (ps - pg)), grad


def mobility_at_reference(m: Mechanism) -> tuple[int, int]:
    """(actual DOF, redundant constraints) from the rank of ∂Φ/∂q without drivers."""
    sys_ = PoseSystem(m)
    q = np.zeros(3 * sys_.n)
    res, jac = sys_.residual_and_jacobian(q, drivers=False)
    assert np.max(np.abs(res)) < 1e-12, "the reference configuration must satisfy closure"
    sv = np.linalg.svd(jac * sys_.column_scale, compute_uv=False)
    rank = int(np.sum(sv > sv[0] * 1e-9))
    return 3 * sys_.n - rank, jac.shape[0] - rank


def continuation(m: Mechanism, path_values: np.ndarray, tol: float = 1e-9,
                 min_rcond: float = 1e-6, max_turn: float = 0.6) -> np.ndarray:
    """Follow the driver path (rows = steps, columns = drivers) from the reference by a
    tangent predictor and Newton corrector.  Returns the poses (steps × 3n).

    Fails (AssertionError) when Newton does not reach ``tol``, the square Jacobian
    gets near-singular (reciprocal condition number below ``min_rcond``, angle columns
    scaled by the joint spread) or a link turns more than ``max_turn`` rad in one step
    (a branch jump)."""
    sys_ = PoseSystem(m)
    q = np.zeros(3 * sys_.n)
    v_prev = np.zeros(sys_.n_drivers)
    out = []
    for v in np.atleast_2d(path_values):
        # predictor: dq = J^-1 (−∂Φ/∂v dv) ; ∂Φ/∂v = −I on the driver rows
        _, jac = sys_.residual_and_jacobian(q, v_prev)
        rhs = np.zeros(jac.shape[0])
        rhs[-sys_.n_drivers:] = v - v_prev
        q = q + np.linalg.solve(jac, rhs)
        for _ in range(30):
            res, jac = sys_.residual_and_jacobian(q, v)
            if np.max(np.abs(res)) <= tol * 1e-3:
                break
            q = q - np.linalg.solve(jac, res)
        res, jac = sys_.residual_and_jacobian(q, v)
        assert np.max(np.abs(res)) <= tol, f"{m.name}: Newton failed at driver values {v}"
        if out:
            turn = np.max(np.abs((q - out[-1])[2::3]))
            assert turn < max_turn, f"{m.name}: a link turned {turn:.2f} rad in one step at {v}"
        sv = np.linalg.svd(jac * sys_.column_scale, compute_uv=False)
        assert sv[-1] / sv[0] >= min_rcond, f"{m.name}: near-singular at driver values {v}"
        out.append(q.copy())
        v_prev = v
    return np.array(out)


# ---------------------------------------------------------------------------
# the catalogue

SEED_002 = ("knitting_needle_drive", "radial_engine_5cyl", "excavator", "excavator_bucket", "linkage_24")
CLASSICS = ("four_bar", "crank_slider", "watt_1", "watt_2", "stephenson_1", "stephenson_2", "stephenson_3",
            "stephenson_3_triad", "six_bar_slider", "dyad_rrr", "dyad_rrp", "dyad_rpr", "dyad_prp", "dyad_rpp")

_REPORTS: dict[str, object] = {}


def report(name: str):
    """structural_report of a catalogue mechanism, computed once per session."""
    if name not in _REPORTS:
        _REPORTS[name] = structural_report(load_named(name), geometry=False)
    return _REPORTS[name]


def test_every_expected_file_is_bundled():
    assert set(SEED_002 + CLASSICS) <= set(names())


@pytest.mark.parametrize("name", names())
def test_file_loads_with_name_source_frame_and_drivers(name):
    m = load_named(name)
    assert path(name).suffix == ".toml"
    assert m.frame is not None
    assert m.drivers
    assert m.source
    if name in SEED_002 + CLASSICS:
        assert m.name == name
        assert m.description
        assert m.has_geometry


@pytest.mark.parametrize("name", SEED_002)
def test_reconstructions_say_so(name):
    m = load_named(name)
    assert m.source.startswith("Reconstruction of")
    assert "Pozhbelko & Kuts 2020" in m.source and "figure missing" in m.source


def test_unknown_name_is_a_clear_error():
    from multiloop.topo.errors import InputError
    with pytest.raises(InputError, match="four_bar"):
        path("no_such_mechanism")


# ---------------------------------------------------------------------------
# Pozhbelko & Kuts 2020: published numbers as oracles (the structural numbers (README) table)

PUBLISHED = {
    # Pozhbelko & Kuts 2020, example 1 (warp-knitting needle drive, fig. 6)
    "knitting_needle_drive": dict(n=10, LA=(8, 1, 1), MJA=(3,), V=3, K=4, L=5, F=1, SL=23,
                                  La=(4, 4, 5, 5, 5), L0=5, rc=0, code="[8110]/3",
                                  code_star="[8110]/[3-0-0]"),
    # Pozhbelko & Kuts 2020, example 2 (radial 5-cylinder aircraft engine, fig. 7)
    "radial_engine_5cyl": dict(n=12, LA=(11, 0, 0, 0, 1), MJA=(0, 0, 0, 1), V=4, K=5, L=6, F=1,
                               SL=28, La=(4, 4, 5, 5, 5, 5), L0=5, rc=0, code="[11.0001]/4",
                               code_star="[11.0001]/[0-0-0-1]"),
    # Pozhbelko & Kuts 2020, example 3 (hydraulic excavator, fig. 8)
    "excavator": dict(n=12, LA=(10, 0, 1, 1), MJA=(1,), V=1, K=4, L=5, F=3, SL=29,
                      La=(4, 4, 4, 4, 13), L0=13, rc=0, code="[10.011]/1", code_star="[10.011]/[1-0-0]"),
    # Pozhbelko & Kuts 2020, example 4 (excavator bucket drive, fig. 9)
    "excavator_bucket": dict(n=9, LA=(8, 0, 0, 1), MJA=(1,), V=1, K=3, L=4, F=2, SL=21,
                             La=(4, 4, 4, 9), L0=9, rc=0, code="[8001]/1", code_star="[8001]/[1-0]"),
    # Pozhbelko & Kuts 2020, remark after example 4 (24-link chain): n, n2, n3, V, K, p, F only
    "linkage_24": dict(n=24, LA=(6, 18), V=2, K=11, L=12, F=1, p=34),
}


@pytest.mark.parametrize("name", SEED_002)
def test_seed002_published_numbers(name):
    r = report(name)
    got = {key: getattr(r, key) for key in PUBLISHED[name]}
    assert got == PUBLISHED[name]
    assert r.consistent and not r.degenerate
    assert r.N == r.F            # the paper's rc is for N = F drivers: the files have F drivers


def test_knitting_drive_structure_formula():
    """Pozhbelko & Kuts 2020, example 1: I(0,1) -> II(2,3) -> II(4,5) -> II(6,7) -> II(8,9):
    each pair in the paper's order is an RRR dyad whose outer pins lie on known links."""
    m = load_named("knitting_needle_drive")
    known = {"frame", "crank_1"}
    pairs = [("link_2", "rocker_3"), ("rocker_4", "link_5"), ("needle_lever_6", "link_7"),
             ("link_8", "link_9")]
    for a, b in pairs:
        # joints of the dyad's links that touch the known part or the other dyad link
        # (pins for later groups are ignored)
        ja = [j for j in m.joints_of(a) if set(j.links) & (known | {b})]
        jb = [j for j in m.joints_of(b) if set(j.links) & (known | {a})]
        assert len(ja) == 2 and len(jb) == 2
        inner = {j.name for j in ja} & {j.name for j in jb}
        assert len(inner) == 1
        for joints in (ja, jb):
            (outer,) = [j for j in joints if j.name not in inner]
            assert outer.kind is JointKind.R and set(outer.links) & known
        known |= {a, b}
    assert known == set(m.link_names)
    assert sorted(j.name for j in m.joints if j.is_multiple) == ["A", "B", "C"]


def test_radial_engine_rods_share_one_pin():
    """Pozhbelko & Kuts 2020, example 2: crank and five con-rods on one pin (j = 5)."""
    m = load_named("radial_engine_5cyl")
    (pin,) = [j for j in m.joints if j.is_multiple]
    assert pin.multiplicity == 5 and "crank" in pin.links
    assert sum(1 for j in m.joints if j.kind is JointKind.P) == 5


def test_excavator_drivers_are_cylinders():
    """Pozhbelko & Kuts 2020, example 3: F = 3, three hydraulic cylinders drive."""
    m = load_named("excavator")
    assert len(m.drivers) == 3
    assert all(m.joint(d.joint).kind is JointKind.P for d in m.drivers)


@pytest.mark.parametrize("name", ["four_bar", "crank_slider", "dyad_rrr", "dyad_rrp", "dyad_rpr",
                                  "dyad_prp", "dyad_rpp"])
def test_four_link_classics(name):
    r = report(name)
    assert (r.n, r.K, r.F, r.rc, r.La) == (4, 1, 1, 0, (4, 4))


@pytest.mark.parametrize("name,la", [("watt_1", (4, 4, 6)), ("watt_2", (4, 4, 6)),
                                     ("six_bar_slider", (4, 4, 6)), ("stephenson_1", (4, 5, 5)),
                                     ("stephenson_2", (4, 5, 5)), ("stephenson_3", (4, 5, 5)),
                                     ("stephenson_3_triad", (4, 5, 5))])
def test_six_bar_classics(name, la):
    """Watt chain: the ternary links share a pin (loops 4-4-6); Stephenson: they do not (4-5-5)."""
    m = load_named(name)
    r = report(name)
    assert (r.n, r.LA, r.K, r.F, r.rc, r.La) == (6, (4, 2), 2, 1, 0, la)
    ternary = [x for x in m.link_names if m.degree(x) == 3]
    adjacent = any(set(ternary) <= set(j.links) for j in m.joints)
    assert adjacent == name.startswith(("watt", "six_bar"))


@pytest.mark.parametrize("name,frame_degree", [("watt_1", 2), ("watt_2", 3), ("stephenson_1", 2),
                                               ("stephenson_2", 3), ("stephenson_3", 2)])
def test_six_bar_inversions(name, frame_degree):
    """Inversions (Tsai 2001): Watt I binary frame, Watt II ternary frame; Stephenson I frame
    binary joining both ternaries, II ternary frame, III binary frame joining one ternary."""
    m = load_named(name)
    assert m.degree(m.frame) == frame_degree
    neighbours = {x for j in m.joints_of(m.frame) for x in j.links} - {m.frame}
    n_ternary = sum(1 for x in neighbours if m.degree(x) == 3)
    expected = {"watt_1": 1, "watt_2": 1, "stephenson_1": 2, "stephenson_2": 0, "stephenson_3": 1}
    assert n_ternary == expected[name]


def test_stephenson_3_triad_driver_is_the_ternary_link():
    m = load_named("stephenson_3_triad")
    (d,) = m.drivers
    assert m.degree(d.links[1]) == 3 and m.frame == d.links[0]
    # the other four links: one ternary and three binaries, with three outer pins
    rest = set(m.link_names) - {m.frame, d.links[1]}
    assert sorted(m.degree(x) for x in rest) == [2, 2, 2, 3]
    outer = [j for j in m.joints if set(j.links) & rest and set(j.links) - rest]
    assert len(outer) == 3


@pytest.mark.parametrize("name,kinds", [("dyad_rrr", "RRR"), ("dyad_rrp", "RRP"), ("dyad_rpr", "RPR"),
                                        ("dyad_prp", "PRP"), ("dyad_rpp", "RPP")])
def test_dyad_kind(name, kinds):
    """The dyad (links 2 and 3): pairs outer–inner–outer as in docs/groups.md"""
    m = load_named(name)
    (l2,) = [x for x in m.link_names if x.endswith("_2")]
    (l3,) = [x for x in m.link_names if x.endswith("_3")]
    inner = [j for j in m.joints if set(j.links) == {l2, l3}][0]
    outer2 = [j for j in m.joints_of(l2) if j is not inner][0]
    outer3 = [j for j in m.joints_of(l3) if j is not inner][0]
    got = outer2.kind.value + inner.kind.value + outer3.kind.value
    assert got in (kinds, kinds[::-1])


# ---------------------------------------------------------------------------
# geometry: mobility at the reference and motion through a driver range

def driver_path(name: str, m: Mechanism) -> np.ndarray:
    """The driver values (steps × drivers) each catalogue mechanism must move through."""
    deg = np.radians
    if name == "dyad_prp":            # the guides become parallel at 0 and 180 deg of the crank
        return deg(np.r_[np.arange(5, 40, 5), np.arange(30, -40, -5)])[:, None]
    if name == "linkage_24":
        return deg(np.r_[np.arange(5, 65, 5), np.arange(55, -65, -5)])[:, None]
    if name == "excavator":           # cylinder extensions (m), all three at once
        t = np.linspace(0.0, 1.0, 37)[1:]
        return np.stack([0.35 * np.sin(2 * np.pi * t), 0.40 * np.sin(2 * np.pi * t + 2.1),
                         0.35 * np.sin(2 * np.pi * t + 4.2)], axis=1)
    if name == "excavator_bucket":
        t = np.linspace(0.0, 1.0, 37)[1:]
        return np.stack([0.30 * np.sin(2 * np.pi * t), 0.20 * np.sin(2 * np.pi * t + 2.1)], axis=1)
    if all(d.range is not None for d in m.drivers) and len(m.drivers) > 1:   # the hydraulic machines
        t = np.linspace(0.0, 1.0, 37)[1:]        # each cylinder to 90 % of its range ends, out of phase
        sn = np.stack([np.sin(2 * np.pi * t + 2.1 * k) for k in range(len(m.drivers))], axis=1)
        return 0.9 * np.where(sn > 0, sn * [d.range[1] for d in m.drivers], -sn * [d.range[0] for d in m.drivers])
    assert len(m.drivers) == 1 and m.joint(m.drivers[0].joint).kind is JointKind.R
    return deg(np.arange(10, 370, 10))[:, None]     # a full turn of the crank in 10 deg steps


@pytest.mark.parametrize("name", names())
def test_mobility_at_reference_equals_drivers(name):
    m = load_named(name)
    dof, redundant = mobility_at_reference(m)
    assert (dof, redundant) == (len(m.drivers), 0)


@pytest.mark.parametrize("name", names())
def test_moves_through_driver_range(name):
    m = load_named(name)
    poses = continuation(m, driver_path(name, m))
    assert np.all(np.isfinite(poses))


def test_continuation_detects_a_dead_end():
    """The checker itself: a PRP dyad driven to parallel guides must fail."""
    m = load_named("dyad_prp")
    with pytest.raises(AssertionError):
        continuation(m, np.radians(np.arange(10, 130, 10))[:, None])


# ---------------------------------------------------------------------------
# `multiloop catalogue`

def test_cli_catalogue_json(capsys):
    import json

    from multiloop.cli import main
    assert main(["catalogue", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["name"] for r in rows] == names()
    for r in rows:
        assert set(r) >= {"name", "n", "F", "K", "code", "source"}
        if r["name"] in SEED_002 + CLASSICS:
            rep = report(r["name"])
            assert (r["n"], r["F"], r["K"], r["code"]) == (rep.n, rep.F, rep.K, rep.code)


def test_cli_catalogue_table(capsys):
    from multiloop.cli import main
    assert main(["catalogue"]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[0].split() == ["name", "n", "F", "K", "code", "source"]
    assert "[8110]/3" in out and "radial_engine_5cyl" in out


# ---------------------------------------------------------------------------
# Assur groups the catalogue entries are meant to exhibit (topo.assur)

@pytest.mark.parametrize("name,expected", [
    ("knitting_needle_drive", [(2, "RRR")] * 4),       # Pozhbelko & Kuts 2020, example 1, fig. 6e
    ("radial_engine_5cyl", [(2, "RRP")] * 5),
    ("stephenson_3_triad", [(3, None)]),
    ("stephenson_3", [(4, None)]),
    ("six_bar_slider", [(2, "RRR"), (2, "RRP")]),
    ("dyad_rrr", [(2, "RRR")]), ("dyad_rrp", [(2, "RRP")]), ("dyad_rpr", [(2, "RPR")]),
    ("dyad_prp", [(2, "PRP")]), ("dyad_rpp", [(2, "RPP")]),
])
def test_assur_groups(name, expected):
    import multiloop.topo.assur as assur
    plan = assur.decompose(load_named(name))
    got = [(g.cls, g.kind if g.cls == 2 else None) for g in plan.groups]
    assert got == expected


@pytest.mark.parametrize("name", names())
def test_mobility_agrees_with_topo_mobility(name):
    import multiloop.topo.mobility as mobility
    m = load_named(name)
    r = mobility.actual_mobility(m)
    assert (r.actual_F, tuple(r.redundant)) == (len(m.drivers), ())


def joint_positions(m: Mechanism, poses: np.ndarray) -> np.ndarray:
    """Joint positions (steps × joints × 2) from link poses: an R joint on its first link,
    a P joint as the point of the slider (``links[1]``) that was at ``at``."""
    sys_ = PoseSystem(m)
    return np.array([[sys_._point(q, j.links[0 if j.kind is JointKind.R else 1], j.at)
                      for j in m.joints] for q in poses])




@pytest.mark.parametrize("name", names())
def test_kin_solve_agrees_with_continuation(name):
    """Cross-check of two independent solvers: kin.solve (closed-form groups, branch from
    the reference) and the Newton continuation above, along the same driver path."""
    import multiloop.kin.solve as solve
    m = load_named(name)
    values = driver_path(name, m)
    expected = joint_positions(m, continuation(m, values))
    state = solve.solve(m, values)
    assert all(s == "ok" for s in state.status)
    scale = PoseSystem(m).length
    assert np.max(np.abs(state.positions - expected)) <= 1e-8 * scale
