"""Shared helpers of the group kernels: planar vector algebra on ``(..., 2)``
arrays, Cramer's rule for the 2×2 systems and the singularity threshold.

Notation (Vasechkin et al. 2017 [1]_ with the OCR noise removed): ``perp(a) = (-a_y, a_x)``
(the left normal, ``n(φ)`` for ``a = e(φ)``), ``cross(a, b) = a_x b_y - a_y b_x``.
Useful identities: ``cross(perp a, perp b) = cross(a, b)``,
``cross(u, perp a) = u·a``.

References
----------
.. [1] Vasechkin M.A., Matveeva E.V., Sidorenko A.S., Chertov E.D. Mathematical
   model of kinematic calculation of flat lever mechanisms. Vestnik VGUIT 79(2)
   (2017) 73-79. doi:10.20914/2310-1202-2017-2-73-79.
"""
from __future__ import annotations

import functools

import numpy as np

from multiloop.topo.errors import SingularityError, explain

__all__ = ["SINGULAR_RTOL", "REACH_RTOL", "scalar", "scalar_inline", "SCALAR_HELPERS", "INLINE_HELPERS", "angle",
           "arctan2", "atan_pos", "sincos_medium", "SINCOS_MEDIUM",
           "carry", "turned", "place", "place_along", "place_like", "xy", "stack", "cramer", "is_singular",
           "sign_of", "quiet", "num", "pair", "length", "dot", "branch_sign", "put_rel", "put_off"]

#: ``|det| <= SINGULAR_RTOL · |c1| |c2|`` marks a singular system.  For a dyad
#: near a turning point the relative det behaves like sqrt(2δ) (δ the relative
#: distance to the limit), so 1e-8 flags positions within round-off (δ ≲ 1e-16)
#: of the singular configuration; the velocity error grows like eps/det_rel² before
#: that (see ``docs/groups.md``), and callers may apply their own threshold on ``det``.
SINGULAR_RTOL = 1e-8
#: a distance beyond reach by at most this relative amount (rounding) is clamped (tangency);
#: more is a failure, so a dead zone deeper than rounding is never assembled through.
REACH_RTOL = 1e-14


#: the scalar helpers that compiled steps call (:func:`scalar`)
SCALAR_HELPERS: list = []
#: those of them numba inlines into its callers' code (:func:`scalar_inline`)
INLINE_HELPERS: set = set()


def scalar(func):
    """Decorator: ``func`` is a scalar helper that the compiled steps of
    :mod:`kin.kernel` call; numba compiles it with them (``register_jitable`` when the
    kernel loads).  Without numba it stays a plain Python function."""
    SCALAR_HELPERS.append(func)
    return func


def scalar_inline(func):
    """:func:`scalar`, inlined by numba into its callers (``inline="always"``): a loop
    that calls it can then run in SIMD registers (LLVM does not vectorise over numba's
    calls)."""
    INLINE_HELPERS.add(func)
    return scalar(func)


@scalar
def angle(k, n, T, C, S, PP):
    """Link k's angle at position ``n`` in the compiled kernel's pose store: its row of
    ``T``, computed from its cos and sin when pending (``PP[k]`` set), as
    :meth:`kin.poses.Poses.angle`; a step that reads it at every position then clears
    ``PP[k]`` (the row is whole)."""
    if PP[k]:
        T[k, 2, n] = arctan2(S[k, n], C[k, n])
    return T[k, 2, n]


#: fdlibm's atan: breakpoints' arctangents (high and low parts) and the minimax coefficients
_ATAN_HI = (4.63647609000806093515e-01, 7.85398163397448278999e-01, 9.82793723247329054082e-01,
            1.57079632679489655800e+00)
_ATAN_LO = (2.26987774529616870924e-17, 3.06161699786838301793e-17, 1.39033110312309984516e-17,
            6.12323399573676603587e-17)
_AT = (3.33333333333329318027e-01, -1.99999999998764832476e-01, 1.42857142725034663711e-01,
       -1.11111104054623557880e-01, 9.09088713343650656196e-02, -7.69187620504482999495e-02,
       6.66107313738753120669e-02, -5.83357013379057348645e-02, 4.97687799461593236017e-02,
       -3.65315727442169155270e-02, 1.62858201153657823623e-02)
_PI, _PI_LO = 3.1415926535897931160e+00, 1.2246467991473531772e-16


@scalar
def atan_pos(x):
    """arctan of ``x >= 0`` (fdlibm ``s_atan.c``, Sun Microsystems 1993: argument
    reduction to |t| < 7/16 about 1/2, 1, 3/2 or ∞, then an odd minimax polynomial of
    degree 21; error below 1 ulp)."""
    if x >= 7.378697629483821e19:        # 2**66
        return _ATAN_HI[3] + _ATAN_LO[3]
    i = -1
    if x >= 0.4375:
        if x < 0.6875:
            i, x = 0, (2.0 * x - 1.0) / (2.0 + x)
        elif x < 1.1875:
            i, x = 1, (x - 1.0) / (x + 1.0)
        elif x < 2.4375:
            i, x = 2, (x - 1.5) / (1.0 + 1.5 * x)
        else:
            i, x = 3, -1.0 / x
    z = x * x
    w = z * z
    s1 = z * (_AT[0] + w * (_AT[2] + w * (_AT[4] + w * (_AT[6] + w * (_AT[8] + w * _AT[10])))))
    s2 = w * (_AT[1] + w * (_AT[3] + w * (_AT[5] + w * (_AT[7] + w * _AT[9]))))
    if i < 0:
        return x - x * (s1 + s2)
    return _ATAN_HI[i] - ((x * (s1 + s2) - _ATAN_LO[i]) - x)


@scalar
def arctan2(y, x):
    """``arctan2(y, x)`` for the compiled kernel (fdlibm ``e_atan2.c``; within 1 ulp of
    NumPy's, a few times faster than the libm call; NaN in, NaN out)."""
    if y != y or x != x:
        return x + y
    if y == 0.0:
        return y if x > 0.0 or (x == 0.0 and np.copysign(1.0, x) > 0.0) else np.copysign(_PI, y)
    if x == 0.0:
        return np.copysign(0.5 * _PI, y)
    z = atan_pos(abs(y) / abs(x))
    if x < 0.0:
        z = _PI - (z - _PI_LO)
    return z if y > 0.0 else -z


#: fdlibm's reduction by pi/2 (``e_rem_pio2.c``): 2/pi, and pi/2 in three 33-bit parts
#: with their tails
_INV_PIO2 = 6.36619772367581382433e-01
_PIO2 = (1.57079632673412561417e+00, 6.07710050630396597660e-11, 2.02226624871116645580e-21)
_PIO2_T = (6.07710050650619224932e-11, 2.02226624879595063154e-21, 8.47842766036889956997e-32)
#: how far (a share of |x|) the reduction's first parts may cancel before the next is taken
_CANCELLED = (1.0, 3.0517578125e-05, 3.552713678800501e-15)
#: the largest |x| that :func:`sincos_medium` reduces (about 2**20 pi/2, fdlibm's "medium" case)
SINCOS_MEDIUM = 1647099.0
#: fdlibm's ``k_sin.c`` and ``k_cos.c`` minimax coefficients on [-pi/4, pi/4]
_KS = (-1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04,
       2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10)
_KC = (4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05,
       -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11)


@scalar_inline
def sincos_medium(x):
    """``(cos x, sin x)`` for ``|x| <= 2**20 pi/2`` (fdlibm ``e_rem_pio2.c``, ``k_sin.c``,
    ``k_cos.c``, Sun Microsystems 1993): ``|x|`` reduced by pi/2 to ``y0 + y1``,
    ``|y0| <= pi/4``, by Cody-Waite in up to three parts, then minimax polynomials
    of degree 13 and 14 and the quadrant's signs.  Error below 1 ulp, so within 1 ulp of
    NumPy's (97 % of values bit for bit, tested).  Without a branch or a libm call, a
    loop over it runs in SIMD registers: 360 pairs in a third of glibc's ``sincos``
    time.  Larger ``|x|``: libm's (the caller's test on :data:`SINCOS_MEDIUM`)."""
    t = abs(x)
    fn = np.floor(t * _INV_PIO2 + 0.5)
    r = t - fn * _PIO2[0]
    w = fn * _PIO2_T[0]                    # good to 85 bits
    for i in range(1, 3):                 # fdlibm's next parts (118 bits, then 151) where
        p = fn * _PIO2[i]                 # r - w cancelled to 2**-15, then 2**-48, of |x|
        r2 = r - p                        # (fdlibm's test on exponents, widened: a part
        w2 = fn * _PIO2_T[i] - ((r - r2) - p)     # taken that fdlibm skips keeps its
        take = abs(r - w) < _CANCELLED[i] * t     # rounding error); selects, not branches
        r, w = (r2 if take else r), (w2 if take else w)
    y0 = r - w
    y1 = (r - y0) - w
    z = y0 * y0
    v = z * y0
    rs = _KS[1] + z * (_KS[2] + z * (_KS[3] + z * (_KS[4] + z * _KS[5])))
    s = y0 - ((z * (0.5 * y1 - v * rs) - y1) - v * _KS[0])
    zz = z * z
    rc = z * (_KC[0] + z * (_KC[1] + z * _KC[2])) + zz * zz * (_KC[3] + z * (_KC[4] + z * _KC[5]))
    hz = 0.5 * z
    h = 1.0 - hz
    c = h + (((1.0 - h) - hz) + (z * rc - y0 * y1))
    q = np.int64(fn) & 3                  # the quadrant: (c, s) turned by q quarter turns
    odd, half = (q & 1) == 1, q >= 2
    c, s = (-s if odd else c), (c if odd else s)
    c, s = (-c if half else c), (-s if half else s)
    return c, np.copysign(1.0, x) * s     # sin is odd (-0.0 kept)


@scalar
def carry(k, n, T, C, S, rx, ry):
    """The material point of link k at ``(rx, ry)`` from its reference point, at position
    ``n`` of the compiled kernel's pose store (:meth:`kin.poses.Poses.carry`)."""
    return T[k, 0, n] + (C[k, n] * rx - S[k, n] * ry), T[k, 1, n] + (S[k, n] * rx + C[k, n] * ry)


@scalar
def turned(k, n, C, S, vx, vy):
    """A direction ``(vx, vy)`` of link k's reference turned with the link
    (:meth:`kin.poses.Poses.direction`)."""
    return C[k, n] * vx - S[k, n] * vy, S[k, n] * vx + C[k, n] * vy


@scalar
def place(k, n, T, C, S, px, py, ox, oy, c, s):
    """Link k at position ``n``: its material point with reference point at ``(-ox, -oy)``
    from the link's is at ``(px, py)``, rotated by ``(c, s)`` (:meth:`kin.poses.Poses.place_k`;
    the angle row is the caller's)."""
    T[k, 0, n] = px + (c * ox - s * oy)
    T[k, 1, n] = py + (s * ox + c * oy)
    C[k, n] = c
    S[k, n] = s


@scalar
def place_along(k, n, T, C, S, px, py, ox, oy, dx, dy, ux, uy):
    """As :func:`place`, turned by the rotation taking the unit ``(ux, uy)`` to the
    direction ``(dx, dy)`` (:meth:`kin.poses.Poses.place_dir_xy`); the angle pending."""
    inv = 1.0 / np.sqrt(dx * dx + dy * dy)
    nx, ny = dx * inv, dy * inv
    place(k, n, T, C, S, px, py, ox, oy, nx * ux + ny * uy, ny * ux - nx * uy)


@scalar
def place_like(k, o, n, T, C, S, px, py, ox, oy, PP):
    """As :func:`place`, turned as link ``o`` (:meth:`kin.poses.Poses.place_like`)."""
    place(k, n, T, C, S, px, py, ox, oy, C[o, n], S[o, n])
    T[k, 2, n] = angle(o, n, T, C, S, PP)


def quiet(func):
    """Decorator: batch kernels never warn on 0/0 or inf·0 (NaN/inf is the answer
    there and the ``ok`` / ``singular`` masks say so)."""
    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            return func(*args, **kwargs)
    return wrapper


def xy(a):
    """Return the x and y components (views) of a ``(..., 2)`` array as floats."""
    a = np.asarray(a, dtype=float)
    if a.shape[-1:] != (2,):
        raise ValueError(explain("point array", expected="shape (..., 2)",
                                 got=f"shape {a.shape}"))
    return a[..., 0], a[..., 1]


def stack(x, y):
    """Stack components into a ``(..., 2)`` array (broadcast to one shape)."""
    out = np.empty(np.broadcast_shapes(np.shape(x), np.shape(y)) + (2,))
    out[..., 0], out[..., 1] = x, y
    return out


def cramer(c1x, c1y, c2x, c2y, bx, by):
    """Solve ``x1 c1 + x2 c2 = b`` by Cramer's rule (Vasechkin et al. 2017's method).

    Returns ``x1, x2, det`` with ``det = cross(c1, c2)``; where ``det == 0`` the
    unknowns are ``±inf`` / ``nan`` without a NumPy warning.
    """
    det = c1x * c2y - c1y * c2x
    with np.errstate(divide="ignore", invalid="ignore"):
        x1 = (bx * c2y - by * c2x) / det
        x2 = (c1x * by - c1y * bx) / det
    return x1, x2, det


def is_singular(det, c1x, c1y, c2x, c2y):
    """``|det| <= SINGULAR_RTOL · |c1| |c2|`` (NaN counts as singular)."""
    scale = np.sqrt((c1x * c1x + c1y * c1y) * (c2x * c2x + c2y * c2y))
    return ~(np.abs(det) > SINGULAR_RTOL * scale)


def sign_of(value, scale, what, strict: bool = True):
    """``±1`` array of ``sign(value)``; raise if ``|value| <= SINGULAR_RTOL·scale``, or
    with ``strict=False`` (designs in a batch) give NaN there: that design fails.

    Raises
    ------
    SingularityError
        The reference configuration sits on the boundary between branches.
    """
    value = np.asarray(value, dtype=float)
    bad = ~(np.abs(value) > SINGULAR_RTOL * np.asarray(scale, dtype=float))
    if not strict:
        return np.where(bad, np.nan, np.where(value > 0, 1.0, -1.0))
    if np.any(bad):
        raise SingularityError(explain(
            what, expected="a reference configuration off the branch boundary",
            got=f"a singular reference at {int(np.count_nonzero(bad))} position(s)",
            hint="move the reference so that the group's links are not collinear"))
    return np.where(value > 0, 1.0, -1.0)


@scalar
def branch_sign(value, scale):
    """:func:`sign_of` of one design of a batch (``strict=False``) for the compiled
    lowering: ``±1``, NaN where ``|value| <= SINGULAR_RTOL·scale`` (or NaN)."""
    if not abs(value) > SINGULAR_RTOL * scale:
        return np.nan
    return 1.0 if value > 0 else -1.0


@scalar
def put_rel(out, d, i, x, y, O, k) -> None:
    """``out[d, i:i+2]``: the point ``(x, y)`` of design d relative to link k's reference
    point ``O[d, k]`` (:meth:`~kin.groups.step.GroupStep.rel`, the same floats)."""
    out[d, i] = x - O[d, k, 0]
    out[d, i + 1] = y - O[d, k, 1]


@scalar
def put_off(out, d, i, x, y, O, k) -> None:
    """``out[d, i:i+2]``: link k's reference point relative to its point ``(x, y)``
    (:meth:`~kin.groups.step.GroupStep.off`)."""
    out[d, i] = -(x - O[d, k, 0])
    out[d, i + 1] = -(y - O[d, k, 1])


def num(a):
    """A step's number: a Python float for one design, the array ``(D, 1)`` for designs."""
    return float(a) if np.ndim(a) == 0 else a


def pair(v):
    """A 2-vector's components: two floats ``(2,)``, or two arrays ``(D, 1)`` from
    ``(D, 1, 2)``."""
    return tuple(v.tolist()) if np.ndim(v) == 1 else (v[..., 0], v[..., 1])


def length(v):
    """|v| of 2-vectors ``(..., 2)``: a float for one vector."""
    return num(np.hypot(v[..., 0], v[..., 1]))


def dot(a, b):
    """a·b of 2-vectors ``(..., 2)`` (written out: the same rounding for one design and a
    batch): a float for one pair."""
    return num(a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1])


def square_curvature(rel, vrel, arel):
    """|d²(|rel|²)/dx²| = 2 |ṙ·ṙ + r·r̈| along a motion with rates ``vrel``, ``arel``
    (all (N, 2))."""
    return 2.0 * np.abs(np.sum(vrel * vrel, axis=-1) + np.sum(rel * arel, axis=-1))


#: rounding of a reach margin, in units of eps × the magnitudes it is computed from
MARGIN_ROUNDING = 4.0


def margin_tol(P, Q, lengths: float, squared: bool = False) -> np.ndarray:
    """Rounding of a reach margin computed from the points ``P``, ``Q`` (N, 2) and link
    lengths summing to ``lengths`` (a margin in m, or in m² when ``squared``): below it
    the margin is numerically zero (the tolerance follows the coordinates' magnitude:
    translating a mechanism far from the origin coarsens it, as it coarsens every
    coordinate)."""
    mag = np.abs(P).sum(axis=-1) + np.abs(Q).sum(axis=-1) + lengths
    return MARGIN_ROUNDING * np.finfo(float).eps * (mag * mag if squared else mag)
