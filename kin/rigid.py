"""Moving a point rigidly with its link: position, velocity, acceleration.

The one home of the planar rigid-body transport used by the solvers and the
results.  A link's pose is its reference point ``c`` and its rotation ``θ`` from the
reference configuration; its material point that sat at ``r`` (relative to ``c``)
is at

    P = c + R(θ) r,   v = v_c + ω × r',   a = a_c + ε × r' − ω² r',   r' = R(θ) r

with ``ω × r' = ω perp(r')`` in the plane, ``perp(x, y) = (−y, x)`` (any textbook,
e.g. Vasechkin et al. 2017, eqs. (4)–(8) for the links of a dyad).  Arrays have a
leading batch axis; the coordinate is last.
"""
from __future__ import annotations

import numpy as np

__all__ = ["rotate", "perp", "transport", "move_point"]


def rotate(v, theta):
    """``R(θ) v`` for ``v`` (2,) or (..., 2) and ``θ`` (...)."""
    v = np.asarray(v, float)
    c, s = np.cos(theta), np.sin(theta)
    x, y = v[..., 0], v[..., 1]
    return _pair(c * x - s * y, s * x + c * y)


def perp(v):
    """The left normal ``(−v_y, v_x)`` of (..., 2) vectors."""
    v = np.asarray(v)
    out = np.empty(v.shape, np.result_type(v, float))
    np.negative(v[..., 1], out=out[..., 0])
    out[..., 1] = v[..., 0]
    return out


def _pair(x, y) -> np.ndarray:
    """``(x, y)`` of equal shapes as one (..., 2) array (``np.stack``'s result, built
    without its per-call overhead: these run per group and per solve)."""
    out = np.empty(np.shape(x) + (2,))
    out[..., 0], out[..., 1] = x, y
    return out


def transport(rho, v0=None, a0=None, omega=None, eps=None):
    """Velocity and acceleration of a point at offset ``rho`` (N, ..., 2) from a point of
    the same link with velocity ``v0`` and acceleration ``a0``; ``omega``, ``eps`` (N, ...)
    the link's angular velocity and acceleration.  Returns ``(v, a)`` (``None`` where not
    given)."""
    if v0 is None or omega is None:
        return None, None
    w = np.asarray(omega)[..., None]
    pr = perp(rho)
    v = v0 + w * pr
    a = None
    if a0 is not None and eps is not None:
        a = a0 + np.asarray(eps)[..., None] * pr - w * w * rho
    return v, a


def move_point(c, theta, r, vc=None, omega=None, ac=None, eps=None):
    """Position (and velocity, acceleration) of the material point ``c + R(θ) r``.

    Parameters
    ----------
    c : (N, 2)
        The link's reference point; ``vc``, ``ac`` its velocity and acceleration.
    theta, omega, eps : (N,)
        The link's rotation, angular velocity and acceleration.
    r : (2,) or (N, 2)
        The point's offset from ``c`` in the reference configuration.

    Returns
    -------
    (P, v, a) : (N, 2) arrays, ``v``/``a`` ``None`` when their inputs are not given.
    """
    rho = rotate(r, theta)
    v, a = transport(rho, vc, ac, omega, eps)
    return np.asarray(c) + rho, v, a
