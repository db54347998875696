"""Small fixed-size geometry kernels: quaternions, rotations, convex constraints.

Quaternions are scalar first, ``Q = (w, x, y, z)``; angular velocities are in the world
frame, so ``dQ/dt = 1/2 E(Q) omega`` with ``E`` from :func:`quat_E`.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import jit
from .layout import C_CYL_X, C_PLANE


@jit
def cross(a, b, out):  # type: ignore[no-untyped-def]
    """out = a x b (float64[3] each)."""
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@jit
def skew(a, out):  # type: ignore[no-untyped-def]
    """out (3x3) = [a]x, the matrix with [a]x b = a x b."""
    out[0, 0] = 0.0
    out[0, 1] = -a[2]
    out[0, 2] = a[1]
    out[1, 0] = a[2]
    out[1, 1] = 0.0
    out[1, 2] = -a[0]
    out[2, 0] = -a[1]
    out[2, 1] = a[0]
    out[2, 2] = 0.0


@jit
def quat_to_rot(q, R):  # type: ignore[no-untyped-def]
    """Rotation matrix of the unit quaternion ``q`` (scalar first) into ``R`` (3x3)."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    R[0, 0] = w * w + x * x - y * y - z * z
    R[0, 1] = 2.0 * (x * y - w * z)
    R[0, 2] = 2.0 * (x * z + w * y)
    R[1, 0] = 2.0 * (x * y + w * z)
    R[1, 1] = w * w - x * x + y * y - z * z
    R[1, 2] = 2.0 * (y * z - w * x)
    R[2, 0] = 2.0 * (x * z - w * y)
    R[2, 1] = 2.0 * (y * z + w * x)
    R[2, 2] = w * w - x * x - y * y + z * z


@jit
def quat_E(q, E):  # type: ignore[no-untyped-def]
    """E (4x3) with dQ/dt = 1/2 E(Q) omega for a world-frame angular velocity omega."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    E[0, 0] = -x
    E[0, 1] = -y
    E[0, 2] = -z
    E[1, 0] = w
    E[1, 1] = z
    E[1, 2] = -y
    E[2, 0] = -z
    E[2, 1] = w
    E[2, 2] = x
    E[3, 0] = y
    E[3, 1] = -x
    E[3, 2] = w


@jit
def quat_step(q, w_new, h, q_out, Eq, Eqn, Jth):  # type: ignore[no-untyped-def]
    """End-of-step orientation and its derivative.

    ``q_out = normalise(q + h/2 E(q) w_new)`` (MODEL.md, discrete model). ``Jth`` (3x3)
    receives d(theta)/d(w_new): a perturbation ``dw`` of ``w_new`` rotates the end pose by
    the small world-frame angle ``Jth @ dw``, i.e. ``dR = [Jth dw]x R``. Returns |q~|.
    ``Eq``, ``Eqn`` are 4x3 workspaces.
    """
    quat_E(q, Eq)
    s = 0.0
    for k in range(4):
        acc = q[k]
        for j in range(3):
            acc += 0.5 * h * Eq[k, j] * w_new[j]
        q_out[k] = acc
        s += acc * acc
    nrm = math.sqrt(s)
    for k in range(4):
        q_out[k] /= nrm
    quat_E(q_out, Eqn)
    c = h / nrm
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for k in range(4):
                acc += Eqn[k, i] * Eq[k, j]
            Jth[i, j] = c * acc
    return nrm


@jit
def constraint_eval(ctype, cdata, y, grad, hess):  # type: ignore[no-untyped-def]
    """Value, gradient and Hessian (body frame) of one convex constraint at ``y``.

    Parameters
    ----------
    ctype : int
        ``C_PLANE``: ``f = n.y - d`` with ``cdata = (n, d)``, |n| = 1.
        ``C_CYL_X``: ``f = |(y1, y2) - (cy, cz)| - R`` with ``cdata = (cy, cz, R, 0)``: a
        circular cylinder along the body x axis (the curved robot's outer arc).
    cdata : float64[4]
    y : float64[3]
        Point in body coordinates (scaled length).
    grad, hess : float64[3], float64[3, 3]
        Receive the gradient and Hessian.

    Returns
    -------
    float
        ``f(y)``; the body is ``f <= 0``.
    """
    for i in range(3):
        for j in range(3):
            hess[i, j] = 0.0
    if ctype == C_PLANE:
        grad[0] = cdata[0]
        grad[1] = cdata[1]
        grad[2] = cdata[2]
        return cdata[0] * y[0] + cdata[1] * y[1] + cdata[2] * y[2] - cdata[3]
    elif ctype == C_CYL_X:
        d1 = y[1] - cdata[0]
        d2 = y[2] - cdata[1]
        rho = math.sqrt(d1 * d1 + d2 * d2)
        if rho < 1e-300:
            rho = 1e-300
        grad[0] = 0.0
        grad[1] = d1 / rho
        grad[2] = d2 / rho
        hess[1, 1] = (1.0 - grad[1] * grad[1]) / rho
        hess[1, 2] = -grad[1] * grad[2] / rho
        hess[2, 1] = hess[1, 2]
        hess[2, 2] = (1.0 - grad[2] * grad[2]) / rho
        return rho - cdata[2]
    grad[0] = np.nan
    grad[1] = np.nan
    grad[2] = np.nan
    return np.nan
