"""Assur-group kernels in point form: the five dyad kinds, the class III triad
and the class IV (order 2) four-link group.

These are *low-level* kernels: they know nothing about mechanisms, names or
decompositions.  They take the current positions of the points and guide lines
of the already solved ("known") links as arrays and return the unknown points.
The whole-mechanism solver (:mod:`kin.solve`) calls them group by group; the
generic Newton solver for any group lives in :mod:`kin.groups.newton` (not
re-exported here).

Conventions (all kernels)
-------------------------
* **Class/order** (Artobolevsky): dyad = class II order 2, triad = class III
  order 3, four-link group with a closed quadrilateral = class IV order 2.
* **Shapes.**  A point is ``(..., 2)`` with the coordinate last; scalars per
  position are ``(...)``.  Every dyad kernel broadcasts its array arguments with
  NumPy rules, so ``(N, 2)`` points with scalar dimensions give ``(N, 2)`` /
  ``(N,)`` outputs, and a single ``(2,)`` point gives ``(2,)`` / ``()`` outputs.
  Constant dimensions (lengths, offsets, angles) are scalars or broadcastable
  arrays.  Triad / class IV kernels take a leading batch axis ``(N, ...)`` or no
  batch axis at all (then outputs have no batch axis either).
* **Guide lines.**  A prismatic guide of a known link is a point ``P`` of that
  link on (or near) the line plus a unit direction ``u`` ``(..., 2)``, both moving
  with the link; ``n(u) = (-u_y, u_x)`` is the left normal, and ``h`` the signed
  offset of the sliding point's track along ``n(u)``:  track = ``P + s u + h n(u)``.
  The guide link's rates are given as ``omega`` / ``eps`` (angular velocity and
  acceleration, CCW positive, shape ``(...)``) and the velocity / acceleration
  ``vP`` / ``aP`` of ``P`` as a point of the guide link.
* **Batch failures never raise.**  Unreachable positions give ``NaN`` in every
  output and ``ok = False``.  Rates return ``det`` (the determinant of the 2×2 or
  3×3 matrix, Vasechkin et al. 2017's sign convention for dyads) and ``singular = |det| <=
  1e-8 · scale`` (scale = product of the column/row norms; i.e. within round-off
  of a singular configuration — apply a larger threshold on ``det`` if you want
  an earlier warning); where exactly singular the rates are ``inf``/``NaN`` (no
  exception, no NumPy warning).
* **Branch sign.**  ``sign`` is ``+1`` / ``-1`` (scalar or ``(...)`` array), read
  from the reference configuration with the ``*_branch`` helpers; ``+1`` is
  Vasechkin et al. 2017's "assembly No. 1".  ``*_branch`` raise :class:`topo.errors.SingularityError`
  when the reference itself is at the branch boundary (sign undefined).
* **Rates.**  ``*_rates(...)`` solve the velocity system and, if the
  accelerations of the knowns are given (all of them, else ``None``), the
  acceleration system with the same matrix.  Acceleration fields are ``None``
  when not requested.  Vasechkin et al. 2017's *analogues* (d/dφ, d²/dφ²) are the same calls
  with input velocities = d/dφ and input accelerations = d²/dφ².
* Results are ``NamedTuple`` s (unpack or use the field names).

Dyads (kind numbers are Vasechkin et al. 2017's "виды" 1–5)
---------------------------------------------
Outer joints attach to known links; the dyad's links are 2 and 3 as in Vasechkin et al. 2017.

``rrr_position(A, C, l2, l3, sign=1.0) -> RRRPosition(B, ok, det)``   kind 1
    Link 2 = A–B (length l2), link 3 = C–B (length l3); ``B`` ``(..., 2)``.
    ``sign=+1``: B to the left of directed A→C, ``cross(C-A, B-A) > 0`` (then
    ``det < 0``).  ``det = cross(B-C, B-A) = l2 l3 sin(φ2-φ3)``.
``rrr_branch(A, C, B) -> sign``
``rrr_rates(A, C, B, vA, vC, aA=None, aC=None) -> RRRRates(w2, w3, vB, e2, e3, aB, det, singular)``
    ``w2, w3``: angular velocities of links A–B and C–B; ``e2, e3`` their angular
    accelerations.

``rrp_position(A, P, u, l2, h=0.0, sign=1.0) -> RRPPosition(B, s, ok, det)``   kind 2
    Link 2 = A–B (length l2); B (on slider link 3) moves on the line
    ``P + s u + h n(u)`` fixed in the known guide link.  Link 3 keeps the guide's
    orientation.  ``sign=+1``: ``(B-A)·u > 0`` (seed's ``s = A_x1 + x2``); ``det =
    (B-A)·u = l2 cos(φ2-φ3)`` so ``sign(det) == sign``.
``rrp_branch(A, B, u) -> sign``
``rrp_rates(A, B, P, u, vA, vP, omega, aA=None, aP=None, eps=None) -> RRPRates(w2, sd, vB, e2, sdd, aB, det, singular)``
    ``sd, sdd``: slide rate/acceleration along ``u`` (relative to the guide link).

``rpr_position(A, C, h=0.0, sign=1.0) -> RPRPosition(u, s, ok, det)``   kind 3
    Block 2 pivoted at A slides on guide link 3 pivoted at C;
    ``A = C + s u + h n(u)``; returns the guide direction ``u`` ``(..., 2)`` of link
    3 (block 2 turns with it) and the slide ``s``.  ``sign=+1``: ``s > 0``;
    ``det = s``.  (Guide on the link pivoted at A instead: swap A and C and negate
    ``u`` / ``h`` accordingly.)
``rpr_branch(A, C, u) -> sign``
``rpr_rates(A, C, u, vA, vC, aA=None, aC=None) -> RPRRates(sd, w3, sdd, e3, det, singular)``

``prp_position(P1, u1, h1, P2, u2, h2) -> PRPPosition(B, s1, s2, ok, det)``   kind 4
    B = P1 + s1 u1 + h1 n(u1) = P2 + s2 u2 + h2 n(u2); linear, no branch.
    ``det = cross(u2, u1) = sin(φ2-φ3)``; ``ok = False`` for parallel guides.
``prp_rates(B, P1, u1, P2, u2, vP1, omega1, vP2, omega2, aP1=None, eps1=None, aP2=None, eps2=None)
-> PRPRates(s1d, s2d, vB, s1dd, s2dd, aB, det, singular)``

``rpp_position(A, P, u, alpha, h=0.0) -> RPPPosition(Q, s1, s2, ok, det)``   kind 5
    Link 3 slides on the known guide (P, u): its point ``Q = P + s1 u``; link 2
    (pivoted at known A) slides along link 3 in direction ``w = R(alpha) u``:
    ``A = Q + s2 w + h n(w)``.  Links 2, 3 keep the guide link's orientation.
    ``det = cross(u, w) = sin(alpha)`` (alpha = 0 or π is a design error).
``rpp_rates(A, Q, P, u, alpha, vA, vP, omega, aA=None, aP=None, eps=None)
-> RPPRates(s1d, s2d, vQ, s1dd, s2dd, aQ, det, singular)``
    ``vQ, aQ``: velocity/acceleration of link 3's point Q.

Class III triad (:mod:`kin.groups.triad`)
-----------------------------------------
Ternary link with inner joints P1, P2, P3; binary link i joins the known outer
pin ``A_i`` to ``P_i`` with length ``l_i``.  ``A`` is ``(N, 3, 2)`` (or ``(3, 2)``),
``b`` ``(3, 2)`` the positions of P1, P2, P3 in the reference configuration (any
rigid copy of the ternary), ``l`` ``(3,)``.  The ternary's pose is
``theta`` = its rotation from ``b``: a point that sat at ``r`` in ``b``'s frame is
at ``P1 + R(theta)(r - b[0])``.

``triad_modes(A, b, l) -> TriadModes(P, theta, n_modes, residual, det)``
    All real assembly modes (degree-6 polynomial, companion eigenvalues, Newton
    polish), ``P`` ``(N, 6, 3, 2)``, ``theta`` ``(N, 6)``, ``residual`` / ``det``
    ``(N, 6)``, padded with NaN beyond ``n_modes`` ``(N,)`` (modes sorted by theta).
``triad_track(A, b, l, start, *, stride=32) -> TriadTrack(P, theta, ok, det, status)``
    Follows along the batch the mode nearest to ``start`` (``(3, 2)`` points of
    P1..P3 near the wanted mode at ``A[0]``, e.g. the reference configuration).
    All modes every ``stride`` positions, Newton-polished Taylor predictions in
    between (guarded; refused intervals are redone at full resolution);
    ``stride=1`` = all modes at every position (same result, slower).
    ``P`` ``(N, 3, 2)``, ``theta``/``det`` ``(N,)``, ``ok`` ``(N,)``; once the mode
    is lost (collision with another mode / turning point / ambiguous step)
    ``ok`` is False from there on, and ``status`` ``(N,)`` int says why
    (0 ok, 1 no assembly, 2 ambiguous / mode collision, 3 after a loss).
``triad_rates(A, P, vA, aA=None, *, vl=None) -> TriadRates(vP, omega, aP, eps, w_bin, e_bin, det, singular)``
    ``P``, ``vA``, ``aA``: ``(N, 3, 2)``; ``omega``/``eps`` of the ternary ``(N,)``,
    ``w_bin``/``e_bin`` of the binaries ``(N, 3)``.  ``det`` of the 3×3 system
    (zero when the three binary lines are concurrent or parallel).  ``vl``
    ``(N, 3)``: rates of the binary lengths (only for reductions; default 0).
``follow_modes(P, valid, pred, start)`` (in :mod:`kin.groups.triad`): the
    generic guarded matcher used by the trackers (any group with a mode list).

Class IV order 2 (:mod:`kin.groups.class4`)
-------------------------------------------
Ternary T1 with outer pin O1 and inner joints J1, J2; ternary T2 with outer pin
O2 and inner joints J3, J4; binaries J1–J3 (length m[0]) and J2–J4 (m[1]).
``O`` ``(N, 2, 2)`` (O1, O2), ``r`` ``(4, 2)``: ``J1 - O1``, ``J2 - O1``,
``J3 - O2``, ``J4 - O2`` in the reference configuration, ``m`` ``(2,)``.
``theta`` ``(..., 2)`` = rotations of T1, T2 from the reference;
``J = (O1 + R(θ1) r0, O1 + R(θ1) r1, O2 + R(θ2) r2, O2 + R(θ2) r3)``.

``class4_modes(O, r, m) -> Class4Modes(J, theta, n_modes, residual, det)``
    ``J`` ``(N, 6, 4, 2)``, ``theta`` ``(N, 6, 2)`` (same polynomial as the triad).
``class4_track(O, r, m, start, *, stride=32) -> Class4Track(J, theta, ok, det, status)``
    ``start`` ``(2,)`` rotations (θ1, θ2) near the wanted mode at ``O[0]``.
``class4_points(O, r, theta) -> J`` ``(..., 4, 2)``.
``class4_rates(O, J, vO, aO=None) -> Class4Rates(omega, vJ, eps, aJ, w_bin, e_bin, det, singular)``
    ``omega``/``eps`` ``(N, 2)`` of T1, T2; ``vJ``/``aJ`` ``(N, 4, 2)``.

References
----------
.. [1] Vasechkin M.A., Matveeva E.V., Sidorenko A.S., Chertov E.D. Mathematical
   model of kinematic calculation of flat lever mechanisms. Vestnik VGUIT 79(2)
   (2017) 73-79. doi:10.20914/2310-1202-2017-2-73-79 (Vasechkin et al. 2017).
"""
from __future__ import annotations

from .rrr import RRRPosition, RRRRates, rrr_branch, rrr_position, rrr_rates
from .rrp import RRPPosition, RRPRates, rrp_branch, rrp_position, rrp_rates
from .rpr import RPRPosition, RPRRates, rpr_branch, rpr_position, rpr_rates
from .prp import PRPPosition, PRPRates, prp_position, prp_rates
from .rpp import RPPPosition, RPPRates, rpp_position, rpp_rates
from .triad import (TriadModes, TriadRates, TriadTrack, triad_modes,
                    triad_rates, triad_track)
from .class4 import (Class4Modes, Class4Rates, Class4Track, class4_modes,
                     class4_points, class4_rates, class4_track)

__all__ = [
    "RRRPosition", "RRRRates", "rrr_branch", "rrr_position", "rrr_rates",
    "RRPPosition", "RRPRates", "rrp_branch", "rrp_position", "rrp_rates",
    "RPRPosition", "RPRRates", "rpr_branch", "rpr_position", "rpr_rates",
    "PRPPosition", "PRPRates", "prp_position", "prp_rates",
    "RPPPosition", "RPPRates", "rpp_position", "rpp_rates",
    "TriadModes", "TriadRates", "TriadTrack", "triad_modes", "triad_rates",
    "triad_track",
    "Class4Modes", "Class4Rates", "Class4Track", "class4_modes", "class4_points",
    "class4_rates",
    "class4_track",
]
