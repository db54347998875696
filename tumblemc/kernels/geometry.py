"""Small fixed-size geometry kernels: quaternions, rotations, convex constraints.

Quaternions are scalar first, ``Q = (w, x, y, z)``; angular velocities are in the world
frame, so ``dQ/dt = 1/2 E(Q) omega`` with ``E`` from :func:`quat_E`.

Every kernel here is the one implementation used by both the residual and the time loop,
written on flat float64 arrays addressed by offsets (``a[ia:ia+3]`` a vector, ``o[io:io+9]``
a 3x3 matrix row-major): an array view costs Numba an atomic reference-count pair, about a
tenth of a time step in the residual. Plain :func:`~._jit.jit`: Numba's IR inlining
(``inline="always"``) was measured and not kept (per step 0.955 of d5c7070 with it, 0.946
without, within noise; cold compile 43 s with it, 37 s without): LLVM inlines these small
kernels into their callers anyway.
"""

from __future__ import annotations

import math
from collections import namedtuple

from ._jit import jit
from .layout import C_CYL_X, C_PLANE

Geometry = namedtuple("Geometry", ["ctype", "cdata", "carea", "cline", "pstart", "sup_pts", "sup_start", "sup_pad", "cllen", "cedge"])
Geometry.__doc__ = """Robot geometry in scaled body coordinates, as kernel arrays.

ctype, cdata : int64[M], float64[M, 4]   convex constraints (see ``constraint_eval``)
carea : float64[M]   adhering area when that constraint alone touches the plane
cline : int64[M]     1 if that constraint alone touching the plane is line contact
cllen : float64[M]   length of the touching segment(s) when that line constraint alone touches
cedge : float64[M, M]  length of the straight edge where two constraints of a piece meet (0: a
    point, a curved edge, or they do not meet); the strip rule of line adhesion (MODEL.md)
pstart : int64[K+1]  piece k owns constraints pstart[k]:pstart[k+1]
sup_pts : float64[P, 3], sup_start : int64[K+1], sup_pad : float64[K]
    points whose lowest one, minus the pad, bounds the piece from below in any direction
    (polytope vertices with pad 0; sampled arcs with their sagitta as pad)
"""

#: layout of :func:`quat_step`'s output block: Q+ (4), E(Q) (4x3), E(Q+) (4x3), d(theta)/d(w+) (3x3)
QS_Q = 0
QS_E1 = 4
QS_E2 = 16
QS_JTH = 28
N_QS = 37
#: layout of :func:`constraint_eval`'s output block: gradient (3), Hessian (3x3)
CG_G = 0
CG_H = 3
N_CG = 12


@jit
def cross(a, ia, b, ib, o, io):  # type: ignore[no-untyped-def]
    """o[io:io+3] = a[ia:ia+3] x b[ib:ib+3]."""
    o[io] = a[ia + 1] * b[ib + 2] - a[ia + 2] * b[ib + 1]
    o[io + 1] = a[ia + 2] * b[ib] - a[ia] * b[ib + 2]
    o[io + 2] = a[ia] * b[ib + 1] - a[ia + 1] * b[ib]


@jit
def skew(a, ia, o, io):  # type: ignore[no-untyped-def]
    """o[io:io+9] (3x3 row-major) = [a[ia:ia+3]]x, the matrix with [a]x b = a x b."""
    o[io] = 0.0
    o[io + 1] = -a[ia + 2]
    o[io + 2] = a[ia + 1]
    o[io + 3] = a[ia + 2]
    o[io + 4] = 0.0
    o[io + 5] = -a[ia]
    o[io + 6] = -a[ia + 1]
    o[io + 7] = a[ia]
    o[io + 8] = 0.0


@jit
def quat_to_rot(q, iq, R, iR):  # type: ignore[no-untyped-def]
    """R[iR:iR+9] (3x3 row-major) = rotation matrix of the unit quaternion q[iq:iq+4]."""
    w, x, y, z = q[iq], q[iq + 1], q[iq + 2], q[iq + 3]
    R[iR] = w * w + x * x - y * y - z * z
    R[iR + 1] = 2.0 * (x * y - w * z)
    R[iR + 2] = 2.0 * (x * z + w * y)
    R[iR + 3] = 2.0 * (x * y + w * z)
    R[iR + 4] = w * w - x * x + y * y - z * z
    R[iR + 5] = 2.0 * (y * z - w * x)
    R[iR + 6] = 2.0 * (x * z - w * y)
    R[iR + 7] = 2.0 * (y * z + w * x)
    R[iR + 8] = w * w - x * x - y * y + z * z


@jit
def quat_E(q, iq, o, io):  # type: ignore[no-untyped-def]
    """o[io:io+12] (4x3 row-major) = E(Q) with dQ/dt = 1/2 E(Q) omega (world-frame omega)."""
    w, x, y, z = q[iq], q[iq + 1], q[iq + 2], q[iq + 3]
    o[io] = -x
    o[io + 1] = -y
    o[io + 2] = -z
    o[io + 3] = w
    o[io + 4] = z
    o[io + 5] = -y
    o[io + 6] = -z
    o[io + 7] = w
    o[io + 8] = x
    o[io + 9] = y
    o[io + 10] = -x
    o[io + 11] = w


@jit
def quat_step(q, iq, w, iw, h, o, io, w0, iw0, theta):  # type: ignore[no-untyped-def]
    """End-of-step orientation and its derivative into the block o[io:io+N_QS].

    ``Q+ = normalise(Q + h/2 E(Q) w_theta)`` (MODEL.md, discrete model) at ``io + QS_Q``, with
    ``Q = q[iq:iq+4]``, ``w+ = w[iw:iw+3]`` and ``w_theta = theta w+ + (1 - theta) w0[iw0:iw0+3]``
    (``theta = 1``: the paper's ``w+``, computed exactly as before; 0.5: the midpoint rule's
    mean of the start and end velocities); ``d(theta)/d(w+)`` (3x3) at ``io + QS_JTH``:
    a perturbation ``dw`` of ``w+`` rotates the end pose by the small world-frame angle
    ``Jth @ dw``, i.e. ``dR = [Jth dw]x R``. E(Q) and E(Q+) are left at ``QS_E1``,
    ``QS_E2``. Returns |Q~| before normalisation.
    """
    e1 = io + QS_E1
    e2 = io + QS_E2
    qn = io + QS_Q
    quat_E(q, iq, o, e1)
    ss = 0.0
    if theta == 1.0:
        for k in range(4):
            acc = q[iq + k]
            for j in range(3):
                acc += 0.5 * h * o[e1 + 3 * k + j] * w[iw + j]
            o[qn + k] = acc
            ss += acc * acc
    else:
        for k in range(4):
            acc = q[iq + k]
            for j in range(3):
                acc += 0.5 * h * o[e1 + 3 * k + j] * (theta * w[iw + j] + (1.0 - theta) * w0[iw0 + j])
            o[qn + k] = acc
            ss += acc * acc
    nrm = math.sqrt(ss)
    for k in range(4):
        o[qn + k] /= nrm
    quat_E(o, qn, o, e2)
    c = h / nrm if theta == 1.0 else theta * h / nrm
    jt = io + QS_JTH
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for k in range(4):
                acc += o[e2 + 3 * k + i] * o[e1 + 3 * k + j]
            o[jt + 3 * i + j] = c * acc
    return nrm


@jit
def constraint_eval(ct, cdata, c, y, iy, o, io):  # type: ignore[no-untyped-def]
    """Value, gradient and Hessian (body frame) of constraint ``c`` at y[iy:iy+3].

    Parameters
    ----------
    ct : int
        Its kind. ``C_PLANE``: ``f = n.y - d`` with ``cdata[c] = (n, d)``, |n| = 1.
        ``C_CYL_X``: ``f = |(y1, y2) - (cy, cz)| - R`` with ``cdata[c] = (cy, cz, R, 0)``:
        a circular cylinder along the body x axis (the curved robot's outer arc).
    cdata : float64[M, 4]
    c : int
        Row of ``cdata``.
    y, iy : float64 array, int
        The point (body coordinates, scaled length) at ``y[iy:iy+3]``.
    o, io : float64 array, int
        Receives the gradient at ``io + CG_G`` and the Hessian (3x3 row-major) at
        ``io + CG_H``.

    Returns
    -------
    float
        ``f(y)``; the body is ``f <= 0``.
    """
    g = io + CG_G
    hs = io + CG_H
    for i in range(9):
        o[hs + i] = 0.0
    if ct == C_PLANE:
        o[g] = cdata[c, 0]
        o[g + 1] = cdata[c, 1]
        o[g + 2] = cdata[c, 2]
        return cdata[c, 0] * y[iy] + cdata[c, 1] * y[iy + 1] + cdata[c, 2] * y[iy + 2] - cdata[c, 3]
    elif ct == C_CYL_X:
        d1 = y[iy + 1] - cdata[c, 0]
        d2 = y[iy + 2] - cdata[c, 1]
        rho = math.sqrt(d1 * d1 + d2 * d2)
        if rho < 1e-300:
            rho = 1e-300
        g1 = d1 / rho
        g2 = d2 / rho
        o[g] = 0.0
        o[g + 1] = g1
        o[g + 2] = g2
        o[hs + 4] = (1.0 - g1 * g1) / rho
        o[hs + 5] = -g1 * g2 / rho
        o[hs + 7] = o[hs + 5]
        o[hs + 8] = (1.0 - g2 * g2) / rho
        return rho - cdata[c, 2]
    o[g] = math.nan
    o[g + 1] = math.nan
    o[g + 2] = math.nan
    return math.nan
