"""The workspace of a tracer point over the box of its drivers' usable ranges
(``check(..., workspace=POINT)``): its exact boundary and area.

Oracle: a boom and stick, each turned by a cylinder, move the tip as a two-link arm
``F + R(θ₁)(a + R(θ₂) b)``; each angle follows from its cylinder length by the law of
cosines, and the area of ``{R(θ₁) v(θ₂)}`` over a box of angles is the polar integral
``∫ r · |Φ(r)| dr``, with ``Φ(r)`` the union of the arcs ``[ψ + θ₁ˡᵒ, ψ + θ₁ʰⁱ]`` over the
``θ₂`` (at most two) where ``|v(θ₂)| = r`` (``ψ = arg v(θ₂)``), integrated by adaptive
Gauss-Kronrod (scipy ``quad``), independent of the solver and of the boundary tracing.
"""
from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy.integrate import quad

from multiloop.kin.check import check
from multiloop.kin.solve import solve
from multiloop.topo.model import MechanismBuilder

# boom foot F, boom cylinder base A (frame) and end E (boom), boom-stick pin P, stick
# cylinder base A2 (boom) and end E2 (stick), the tip T on the stick (the catalogue
# excavator's boom and stick, metres)
F, A, E = (0.6, 1.9), (1.0, 1.1), (2.6, 2.7)
P, A2, E2 = (6.2, 3.6), (3.0, 3.5), (6.0, 4.6)
T = (7.379008, -0.568595)


def _d(p, q):
    return math.hypot(q[0] - p[0], q[1] - p[1])


#: the stick cylinder's stroke end where its triangle P-A2-E2 is flat (the assembly limit)
STICK_LIMIT = _d(P, A2) + _d(P, E2) - _d(A2, E2)


#: a turret pivoted at the boom foot, turned by a cylinder from A3 (frame) to E3
A3, E3 = (-0.4, 1.2), (0.1, 2.6)

#: a bucket pinned on the stick at T, turned by a cylinder from A4 (stick) to E4
#: (bucket); its tip T4
A4, E4, T4 = (6.5, 2.2), (8.1, -0.2), (8.6, -1.3)
#: the bucket cylinder's stroke end where its triangle T-A4-E4 is flat
BUCKET_LIMIT = _d(T, A4) + _d(T, E4) - _d(A4, E4)


def boom_stick(stick_high: float, boom=(-0.6, 0.7), stick_low: float = -0.8, bucket=None):
    """The boom and stick, each turned by a cylinder; the tip T on the stick.  With
    ``bucket`` = (low, high), a third cylinder from the stick turns a bucket pinned at
    T, and the tracer point is its tip T4 (``bucket_tip``)."""
    b = MechanismBuilder()
    b.add_link("frame", frame=True)
    for x in ("boom", "stick", "boom_barrel", "boom_rod", "stick_barrel", "stick_rod"):
        b.add_link(x)
    if bucket is not None:
        for x in ("bucket", "bucket_barrel", "bucket_rod"):
            b.add_link(x)

    def cyl(name, base, end, barrel, rod, links_base, links_end):
        u = np.subtract(end, base) / _d(base, end)
        b.add_joint(f"{name}_base", "R", (links_base, barrel), at=base)
        b.add_joint(f"{name}_slide", "P", (barrel, rod), at=tuple((np.add(base, end)) / 2), axis=tuple(u))
        b.add_joint(f"{name}_end", "R", (rod, links_end), at=end)
    b.add_joint("foot", "R", ("frame", "boom"), at=F)
    b.add_joint("boom_stick", "R", ("boom", "stick"), at=P)
    cyl("boom_cyl", A, E, "boom_barrel", "boom_rod", "frame", "boom")
    cyl("stick_cyl", A2, E2, "stick_barrel", "stick_rod", "boom", "stick")
    b.add_driver("boom_cyl_slide", range=boom)
    b.add_driver("stick_cyl_slide", range=(stick_low, stick_high))
    b.add_point("tip", "stick", T)
    if bucket is not None:
        b.add_joint("stick_bucket", "R", ("stick", "bucket"), at=T)
        cyl("bucket_cyl", A4, E4, "bucket_barrel", "bucket_rod", "stick", "bucket")
        b.add_driver("bucket_cyl_slide", range=bucket)
        b.add_point("bucket_tip", "bucket", T4)
    return b.build()


def _turn(pivot, base, end, s):
    """Rotation of the link carrying ``end`` about ``pivot`` when the cylinder
    ``base``-``end`` grows by ``s`` (law of cosines)."""
    fa, fe, L0 = _d(pivot, base), _d(pivot, end), _d(base, end)
    u, v = np.subtract(base, pivot), np.subtract(end, pivot)
    sgn = math.copysign(1.0, u[0] * v[1] - u[1] * v[0])

    def g(L):
        return math.acos(max(-1.0, min(1.0, (fa * fa + fe * fe - L * L) / (2 * fa * fe))))
    return sgn * (g(L0 + s) - g(L0))


def _rot(t, v):
    return np.array([math.cos(t) * v[0] - math.sin(t) * v[1], math.sin(t) * v[0] + math.cos(t) * v[1]])


def two_link_area(a, b, t1, t2) -> float:
    """Area of ``{R(θ₁)(a + R(θ₂) b)}``, θ₁ ∈ t1, θ₂ ∈ t2 (span of θ₁ below 2π)."""
    la, lb = math.hypot(*a), math.hypot(*b)
    delta = math.atan2(b[1], b[0]) - math.atan2(a[1], a[0])     # a·R(θ)b = la lb cos(θ + δ)
    span = t1[1] - t1[0]

    def cover(r):
        c = (r * r - la * la - lb * lb) / (2 * la * lb)
        if abs(c) > 1:
            return 0.0
        starts = []
        for root in (math.acos(c), -math.acos(c)):
            th = root - delta + 2 * math.pi * math.ceil((t2[0] - (root - delta)) / (2 * math.pi))
            while th <= t2[1]:
                v = np.asarray(a) + _rot(th, b)
                starts.append((math.atan2(v[1], v[0]) + t1[0]) % (2 * math.pi))
                th += 2 * math.pi
        starts = sorted(set(starts))
        if not starts:
            return 0.0
        gaps = np.diff(starts + [starts[0] + 2 * math.pi])
        return float(np.sum(np.minimum(span, gaps)))

    def radius(th):
        return float(np.hypot(*(np.asarray(a) + _rot(th, b))))
    th = np.linspace(t2[0], t2[1], 20001)
    rs = [radius(x) for x in th]
    cuts = sorted({min(rs), max(rs), radius(t2[0]), radius(t2[1])})
    return sum(quad(lambda r: r * cover(r), lo, hi, limit=400, epsabs=0.0, epsrel=1e-12)[0]
               for lo, hi in zip(cuts[:-1], cuts[1:]))


def boom_stick_area(box) -> float:
    t1 = sorted(_turn(F, A, E, s) for s in box[0])
    t2 = sorted(_turn(P, A2, E2, s) for s in box[1])
    return two_link_area(np.subtract(P, F), np.subtract(T, P), t1, t2)


def _distance_outside(Q, loop):
    """Distance from each point of ``Q`` outside the closed polygon ``loop`` to it (0
    inside; matplotlib's point-in-polygon test, then point-segment distances)."""
    from matplotlib.path import Path

    out = np.zeros(len(Q))
    far = np.flatnonzero(~Path(loop).contains_points(Q))
    a, d = loop[:-1], np.diff(loop, axis=0)
    for i in far:
        t = np.clip(np.sum((Q[i] - a) * d, -1) / np.maximum(np.sum(d * d, -1), 1e-300), 0, 1)
        out[i] = np.min(np.hypot(*(Q[i] - a - t[:, None] * d).T))
    return out


@pytest.mark.parametrize("stick_high, where", [(0.8, "before"), (STICK_LIMIT, "at"), (2.0, "beyond")])
def test_two_cylinder_area_against_the_polar_integral(stick_high, where):
    m = boom_stick(stick_high)
    ws = check(m, workspace="tip").workspace
    box = np.array(ws.box)
    # the assembly limit to the floating point's resolution (was 2.2e-10 m short, which
    # put the tip 1e-4 m off at the corner: it moves like the square root of the stroke left)
    assert box[1, 1] == pytest.approx(min(stick_high, STICK_LIMIT), abs=1e-12)
    ref = boom_stick_area(box)
    assert ws.exact
    assert ws.area == pytest.approx(ref, rel=1e-6)
    # the dense solve's clipping (7.7e-6 off with the stick at or beyond its limit, on 33
    # and 65 points per driver: its fold meets the limit's edge, the closed form is the tight oracle)
    assert ws.area == pytest.approx(clipped_area(m, 0, box), rel=1e-5)
    # no position the solver returns lies outside the boundary (beyond the chords' sag)
    g = [np.linspace(lo, hi, 151) for lo, hi in box]
    X = np.array(np.meshgrid(*g, indexing="ij")).reshape(2, -1).T
    Q = solve(m, X, assemble=True).point_positions[:, 0]
    assert np.isfinite(Q).all()
    assert _distance_outside(Q, ws.boundary).max() < 1e-6
    if where != "before":
        # x is least on the edge where the stick's triangle is flat: the closed form's
        # minimum along it (was 8.7e-5 m off, read 1e-10 m inside the limit)
        from scipy.optimize import minimize_scalar

        def x_tip(s1):
            t1, t2 = _turn(F, A, E, s1), _turn(P, A2, E2, STICK_LIMIT)
            return float(F[0] + _rot(t1, np.subtract(P, F))[0] + _rot(t1 + t2, np.subtract(T, P))[0])
        best = min(x_tip(box[0, 1]), minimize_scalar(x_tip, bounds=tuple(box[0]), method="bounded",
                                                     options={"xatol": 1e-12}).fun)
        assert ws.x[0] == pytest.approx(best, abs=1e-5)     # √(2.9e-13 m left) × the lever
    labels = ws.arc_labels()
    limit = "stick_cyl_slide at its high end (an assembly limit)"
    assert (limit in labels) == (where != "before")
    # past the stick's straight position the stick folds back: a singular curve bounds it
    assert any(lab.startswith("singular curve") for lab in labels) == (where != "before")


def test_a_two_cylinder_limit_message_names_each_driver():
    """Issue 36 part 2, 4: the limit of a two-driver path read "limit at 0.82528 m, 0 m"."""
    m = boom_stick(2.0)
    st = solve(m, np.array([[0.0, 0.0], [0.0, 1.2]]))
    assert not st.ok[1]
    assert f"limit at boom_cyl_slide = 0 m, stick_cyl_slide = {STICK_LIMIT:.6g} m" in st.status[1]
    dc = check(m).drivers[1]
    assert any(f"stick_cyl_slide = {STICK_LIMIT:.6g} m" in g for g in dc.limit_groups)


def test_a_stroke_that_ends_at_its_assembly_limit_solves_at_its_usable_end():
    """Issue 36 part 2, 2: the stick's stroke ends at its assembly limit; every position
    at the usable range's end (as check reports it, within 1e-12 m of the limit) solves,
    alone and with the boom anywhere in its range (the path ends in a touch of the
    limit; it used to be a 'singular position' within 1e-8 m of it)."""
    m = boom_stick(STICK_LIMIT)
    lo, hi = check(m).drivers[1].usable
    assert hi == pytest.approx(STICK_LIMIT, abs=1e-12)
    for boom in np.linspace(-0.6, 0.7, 7):
        for end in (lo, hi):
            st = solve(m, np.array([[boom, end]]))
            assert st.ok.all(), (boom, end, list(st.status))



def test_two_drivers_that_turn_one_link_fall_back_to_the_samples():
    """A turret and a boom cylinder both turn the boom about its foot: the Jacobian has
    rank one everywhere, no fold to trace; the workspace (an annular sector) is the
    samples' outline, computed in the usual time (the exact construction refuses it)."""
    b = MechanismBuilder()
    b.add_link("frame", frame=True)
    for x in ("turret", "boom", "t_barrel", "t_rod", "b_barrel", "b_rod"):
        b.add_link(x)
    b.add_joint("foot", "R", ("frame", "turret", "boom"), at=F)
    for name, base, end, barrel, rod, lb, le in (("t", A3, E3, "t_barrel", "t_rod", "frame", "turret"),
                                                 ("b", A, E, "b_barrel", "b_rod", "turret", "boom")):
        u = np.subtract(end, base) / _d(base, end)
        b.add_joint(f"{name}_base", "R", (lb, barrel), at=base)
        b.add_joint(f"{name}_slide", "P", (barrel, rod), at=tuple(np.add(base, end) / 2), axis=tuple(u))
        b.add_joint(f"{name}_end", "R", (rod, le), at=end)
    b.add_driver("t_slide", range=(-0.3, 0.3))
    b.add_driver("b_slide", range=(-0.6, 0.7))
    b.add_point("tip", "boom", P)
    ws = check(b.build(), workspace="tip").workspace
    assert not ws.exact and ws.area >= 0.0
    assert "rank one" in ws.reason


#: the polygon clipping's agreement with the exact area, Richardson-extrapolated over 33
#: and 65 points per driver, the cells across a fold subdivided 8 × 8 (measured: 3.1e-7
#: and 7.2e-7 on the boom, stick and bucket with strokes before and at their limits).
#: Without the subdivision the cells' triangles miss a sliver along each singular curve
#: (1.1e-3 m² of the 1.5e-3 m² between the two on 257 points per driver), an O(h²) that
#: is not a clean power of the step (the fold crosses the cells anywhere): 1.4e-6 to
#: 4.8e-6 over 65 and 129 points
REL_3 = 1e-6


def _chebyshev(w):
    """Fractions of a driver's range at ``w`` in [0, 1], dense at both ends (where a
    stroke ending at an assembly limit moves the point like the square root of the
    stroke left)."""
    return 0.5 * (1.0 - np.cos(np.pi * w))


def _triangles(Q):
    """The two triangles (K, 3, 2) of each cell of a grid of positions (a, b, 2) (a
    cell across a fold maps to a bow tie, which a polygon cannot be)."""
    a, b, c, d = Q[:-1, :-1], Q[1:, :-1], Q[1:, 1:], Q[:-1, 1:]
    return np.concatenate([np.stack([a, b, c], 2).reshape(-1, 3, 2), np.stack([a, c, d], 2).reshape(-1, 3, 2)])


def _face_image(m, ip, box, i, j, fixed, n, sub=8):
    """The union (shapely) of the images of an ``n`` × ``n`` grid's cells over the face
    of drivers ``i``, ``j`` (the others at ``fixed``); each cell whose triangles' images
    turn differently from each other or from a neighbour's (a fold crosses it or one
    next to it) is solved again on a ``sub`` × ``sub`` grid of its own."""
    import shapely
    from scipy.ndimage import binary_dilation

    def positions(WI, WJ):
        X = np.tile(fixed, (WI.size, 1))
        X[:, i] = box[i][0] + (box[i][1] - box[i][0]) * _chebyshev(WI.ravel())
        X[:, j] = box[j][0] + (box[j][1] - box[j][0]) * _chebyshev(WJ.ravel())
        Q = solve(m, X, assemble=True).point_positions[:, ip]
        assert np.isfinite(Q).all()
        return Q.reshape(WI.shape + (2,))
    w = np.linspace(0.0, 1.0, n)
    Q = positions(*np.meshgrid(w, w, indexing="ij"))
    T = _triangles(Q).reshape(2, n - 1, n - 1, 3, 2)
    u, v = T[:, :, :, 1] - T[:, :, :, 0], T[:, :, :, 2] - T[:, :, :, 0]
    turn = np.sign(u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0])
    fold = turn[0] != turn[1]
    fold[:-1] |= turn[0, 1:] != turn[0, :-1]
    fold[1:] |= turn[0, 1:] != turn[0, :-1]
    fold[:, :-1] |= turn[0, :, 1:] != turn[0, :, :-1]
    fold[:, 1:] |= turn[0, :, 1:] != turn[0, :, :-1]
    cells = np.argwhere(binary_dilation(fold))
    parts = [shapely.unary_union(shapely.polygons(_triangles(Q)))]
    if len(cells):
        t = np.linspace(0.0, 1.0, sub + 1) * (w[1] - w[0])
        F = positions(w[cells[:, 0], None, None] + t[None, :, None] + 0 * t[None, None, :],
                      w[cells[:, 1], None, None] + 0 * t[None, :, None] + t[None, None, :])
        parts.append(shapely.unary_union(shapely.polygons(np.concatenate([_triangles(f) for f in F]))))
    return shapely.unary_union(parts)


def clipped_image(m, ip, box, n):
    """The union of the images of every two-dimensional face of the box (``n`` points
    per driver), by polygon clipping."""
    import shapely

    box = np.asarray(box)
    k, parts = len(box), []
    for i, j in itertools.combinations(range(k), 2):
        others = [q for q in range(k) if q not in (i, j)]
        for ends in itertools.product((0, 1), repeat=len(others)):
            fixed = np.zeros(k)
            for q, e in zip(others, ends):
                fixed[q] = box[q][e]
            parts.append(_face_image(m, ip, box, i, j, fixed, n))
    return shapely.unary_union(parts)


def clipped_area(m, ip, box, n=33) -> float:
    """The clipped image's area on ``n`` and ``2n - 1`` points per driver, Richardson-
    extrapolated: the union of the cells' images misses (or, where the boundary is
    concave, adds) the chords' segments, an error ``c h²`` in the grid step ``h``
    (which halves), so ``(4 A(h/2) - A(h)) / 3``."""
    coarse = clipped_image(m, ip, box, n).area
    fine = clipped_image(m, ip, box, 2 * n - 1).area
    return (4.0 * fine - coarse) / 3.0


def _outside_by(m, ip, box, ws, k):
    """The largest distance outside the reported boundary of a solved position of a
    ``k^n`` grid of the box (its interior included)."""
    g = [np.linspace(lo, hi, k) for lo, hi in box]
    X = np.array(np.meshgrid(*g, indexing="ij")).reshape(len(box), -1).T
    Q = solve(m, X, assemble=True).point_positions[:, ip]
    assert np.isfinite(Q).all()
    return _distance_outside(Q, ws.boundary).max()


@pytest.mark.parametrize("stick_high, bucket_high, where", [
    (0.8, 0.5, "before"), (STICK_LIMIT, BUCKET_LIMIT, "at"),
    # 31 s of CPU: a benchmark (the suite's 10 minutes on 2 cores); the two-cylinder
    # tests above run "beyond" in the suite, and so does the excavator below
    pytest.param(2.0, 1.5, "beyond", marks=pytest.mark.benchmark)])
def test_three_cylinder_area_against_polygon_clipping(stick_high, bucket_high, where):
    """Three drivers: the exact boundary's area against the union of the images of a
    dense solve of every 2-face of the box (shapely polygon clipping, Richardson-
    extrapolated over 33 and 65 points per driver, :data:`REL_3`), and no position of a 31³ grid of
    the box (its interior) outside the boundary (beyond the chords' sag)."""
    m = boom_stick(stick_high, bucket=(-0.5, bucket_high))
    ws = check(m, workspace="bucket_tip").workspace
    box = np.array(ws.box)
    assert box[1, 1] == pytest.approx(min(stick_high, STICK_LIMIT), abs=1e-12)
    assert box[2, 1] == pytest.approx(min(bucket_high, BUCKET_LIMIT), abs=1e-12)
    assert ws.exact and ws.reason == ""
    ref = clipped_area(m, 1, box)
    assert ws.area == pytest.approx(ref, rel=REL_3)
    assert _outside_by(m, 1, box, ws, 31) < 1e-6
    labels = ws.arc_labels()
    # a stroke that ends exactly at its limit may be read as its range's end
    limit = "bucket_cyl_slide at its high end (an assembly limit)"
    if where != "at":
        assert any(limit in lab for lab in labels) == (where == "beyond")
    assert any("bucket_cyl_slide at its high end" in lab for lab in labels)


def arm3():
    """A serial arm of three revolute drivers whose tip is straight out at the
    reference: the Jacobian has rank one on the line θ₂ = θ₃ = 0 inside the box, whose
    image (the full reach) bounds the workspace and lies on no face's image."""
    b = MechanismBuilder()
    b.add_link("frame", frame=True)
    for x in ("l1", "l2", "l3"):
        b.add_link(x)
    b.add_joint("j1", "R", ("frame", "l1"), at=(0.0, 0.0))
    b.add_joint("j2", "R", ("l1", "l2"), at=(1.0, 0.0))
    b.add_joint("j3", "R", ("l2", "l3"), at=(1.8, 0.0))
    for name, rng in (("j1", (-0.5, 1.0)), ("j2", (-0.4, 0.6)), ("j3", (-0.3, 0.5))):
        b.add_driver(name, range=rng)
    b.add_point("tip", "l3", (2.5, 0.0))
    return b.build()


def test_a_critical_curve_inside_the_box_falls_back_to_the_samples():
    """The faces' images do not reach the full reach (2.5 m from the base), which the
    interior's critical line does: the union of the faces is not the workspace, so the
    exact construction refuses and says why."""
    import shapely

    m = arm3()
    ws = check(m, workspace="tip").workspace
    assert not ws.exact
    assert "rank one inside the box" in ws.reason
    faces = clipped_image(m, 0, ws.box, 33)
    reach = shapely.Point(2.5 * math.cos(0.25), 2.5 * math.sin(0.25))      # θ₁ = 0.25, θ₂ = θ₃ = 0
    assert faces.distance(reach) > 1e-3
    assert np.max(np.hypot(*ws.samples.T)) == pytest.approx(2.5, abs=1e-9)


def test_the_excavator_area_against_polygon_clipping():
    """The catalogue excavator (three cylinders, the bucket through a rocker and a link,
    its stroke cut at the linkage's assembly limit): exact area against the clipping."""
    from multiloop.catalogue.named import load_named

    m = load_named("excavator")
    ws = check(m, workspace="bucket_tip").workspace
    assert ws.exact
    # 33 and 65 points per driver are not yet in the clipping's O(h²) regime here
    # (-2.1e-5; on 65 and 129, the benchmark below, -2.0e-8)
    assert ws.area == pytest.approx(clipped_area(m, 0, np.array(ws.box)), rel=3e-5)


@pytest.mark.benchmark
def test_the_excavator_area_against_finer_clipping():
    """As above on 65 and 129 points per driver (-2.0e-8; about 75 s on one core)."""
    from multiloop.catalogue.named import load_named

    m = load_named("excavator")
    ws = check(m, workspace="bucket_tip").workspace
    assert ws.exact
    assert ws.area == pytest.approx(clipped_area(m, 0, np.array(ws.box), 65), rel=REL_3)
