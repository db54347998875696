"""Rigid-body impact guesses: the impulse that stops a landing contact point or a level edge."""

from __future__ import annotations

import math

import numpy as np

from ._jit import jit, jit_alloc
from .geometry import cross, quat_to_rot
from .layout import (
    B_A1,
    B_A2,
    B_L,
    B_LO,
    B_LR,
    B_LT,
    B_SIG,
    P_IB,
    P_MASS,
    P_MU,
    P_N,
    P_O,
    P_T,
    S_FEXT,
)


@jit_alloc
def impact_guess(z, off, mk, state, h, model, scr, edge, half):  # type: ignore[no-untyped-def]  # noqa: C901
    """Guesses 9, 10 and 11 for the contact block at ``off`` (``mk`` constraints, its ECP ``a1`` set): the rigid-body impact.

    Guess 9 (``half == 0``): the impulse ``P`` that brings the contact point's velocity
    ``v_c = v + w x r`` (start of step, ``r = a1 - (x + h v)``) to rest, ``K P = -v_c`` with
    ``K = I/m - [r]x I^-1 [r]x`` (world inertia at the start pose), cut to the friction cone
    along its tangential part if it leaves it; ``z`` receives ``v + P/m + h F_ext/m``,
    ``w + I^-1 (r x P)``, the forces ``P / h`` (the normal one plus the pressing load) and
    ``sigma = 0``.

    Guess 10 (``half > 0``: ``a1`` is the middle of a level edge of that half length and unit
    direction ``edge``, :func:`level_edge`): the impact that makes the whole edge stick,
    with the impulse ``P`` at ``a1`` and the angular impulses ``m_u`` about ``u = edge x n``
    and ``m_n`` about ``n`` as unknowns: the five linear conditions are ``v_c+ = 0`` and
    ``w+ . u = w+ . n = 0`` (no roll, no turn: every point of the edge at rest). A normal
    impulse ``P_n`` at ``a1 + s edge`` has the moment ``s P_n u``, so the ECP moves to
    ``s = m_u / P_n`` (cut to the edge), and the torsional force takes what is left of
    ``m_n`` after the moment ``s (edge x P) . n`` of the tangential impulse there.

    Guess 11 (``half < 0``): guess 10's system for a point, with ``m_u = 0`` in place of the
    roll condition: the impulse at ``a1`` and the angular impulse about ``n`` that leave the
    contact point at rest and stop the turn about ``n`` (torsional stick); the ECP stays.

    Returns False (``z`` as it was) when the contact point is not approaching the plane or the
    impulse does not push."""
    prm = model.prm
    sc = scr.sc
    R = scr.R
    quat_to_rot(state, 3, R, 0)
    # Ib^-1 by cofactors, then Iw^-1 = R Ib^-1 R^T (into a local 3x3)
    b = prm[P_IB : P_IB + 9]
    c00 = b[4] * b[8] - b[5] * b[7]
    c01 = b[5] * b[6] - b[3] * b[8]
    c02 = b[3] * b[7] - b[4] * b[6]
    det = b[0] * c00 + b[1] * c01 + b[2] * c02
    if det == 0.0:
        return False
    bi = np.empty(9)
    bi[0] = c00 / det
    bi[1] = (b[2] * b[7] - b[1] * b[8]) / det
    bi[2] = (b[1] * b[5] - b[2] * b[4]) / det
    bi[3] = c01 / det
    bi[4] = (b[0] * b[8] - b[2] * b[6]) / det
    bi[5] = (b[2] * b[3] - b[0] * b[5]) / det
    bi[6] = c02 / det
    bi[7] = (b[1] * b[6] - b[0] * b[7]) / det
    bi[8] = (b[0] * b[4] - b[1] * b[3]) / det
    iw = np.zeros(9)
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for k in range(3):
                for m in range(3):
                    acc += R[3 * i + k] * bi[3 * k + m] * R[3 * j + m]
            iw[3 * i + j] = acc
    r = np.empty(3)
    for i in range(3):
        r[i] = z[off + B_A1 + i] - state[i] - h * state[7 + i]
    vc = np.empty(3)
    cross(state, 10, r, 0, vc, 0)
    vn = 0.0
    for i in range(3):
        vc[i] += state[7 + i]
        vn += prm[P_N + i] * vc[i]
    if vn >= 0.0:
        return False
    if half != 0.0:
        return sticking_impact(z, off, mk, state, h, model, scr, edge, half, iw, r, vc)
    # K = I/m + [r]x^T Iw^-1 [r]x, column j from the unit impulse e_j
    Kmat = np.zeros((3, 3))
    e = np.zeros(3)
    tq = np.empty(3)
    dw = np.empty(3)
    dv = np.empty(3)
    for j in range(3):
        e[:] = 0.0
        e[j] = 1.0
        cross(r, 0, e, 0, tq, 0)
        for i in range(3):
            dw[i] = iw[3 * i] * tq[0] + iw[3 * i + 1] * tq[1] + iw[3 * i + 2] * tq[2]
        cross(dw, 0, r, 0, dv, 0)
        for i in range(3):
            Kmat[i, j] = dv[i] + (1.0 / prm[P_MASS] if i == j else 0.0)
    P = np.linalg.solve(Kmat, -vc)
    pn = prm[P_N] * P[0] + prm[P_N + 1] * P[1] + prm[P_N + 2] * P[2]
    if not pn > 0.0:
        return False
    pt = 0.0
    for i in range(3):
        pt += (P[i] - pn * prm[P_N + i]) ** 2
    pt = math.sqrt(pt)
    cut = prm[P_MU] * pn / pt if pt > prm[P_MU] * pn else 1.0
    for i in range(3):
        P[i] = pn * prm[P_N + i] + cut * (P[i] - pn * prm[P_N + i])
    cross(r, 0, P, 0, tq, 0)
    press = 0.0
    for i in range(3):
        z[i] = state[7 + i] + P[i] / prm[P_MASS] + h * sc[S_FEXT + i] / prm[P_MASS]
        z[3 + i] = state[10 + i] + iw[3 * i] * tq[0] + iw[3 * i + 1] * tq[1] + iw[3 * i + 2] * tq[2]
        press -= prm[P_N + i] * sc[S_FEXT + i]
    return impact_forces(z, off, mk, P, pn, press, h, model.prm)


@jit_alloc
def sticking_impact(z, off, mk, state, h, model, scr, edge, half, iw, r, vc):  # type: ignore[no-untyped-def]  # noqa: C901
    """The impacts of guesses 10 and 11 (:func:`impact_guess`, ``half != 0``): ``iw`` the world inverse inertia
    (9, row-major), ``r`` the lever of the edge's middle, ``vc`` its velocity."""
    prm = model.prm
    sc = scr.sc
    u = np.empty(3)
    nv = prm[P_N : P_N + 3]
    point = half < 0.0  # guess 11: a point that sticks, in torsion too (m_u = 0, the ECP stays)
    if point:
        for i in range(3):
            u[i] = prm[P_T + i]
    else:
        cross(edge, 0, nv, 0, u, 0)
        ul = math.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
        if ul < 0.5:  # the edge is far from level
            return False
        for i in range(3):
            u[i] /= ul
    # columns: unit impulses along x, y, z at a1, unit angular impulses about u and n
    A = np.zeros((5, 5))
    tq = np.empty(3)
    dw = np.empty(3)
    dv = np.empty(3)
    for j in range(5):
        for i in range(3):
            tq[i] = 0.0
        if j < 3:
            e = np.zeros(3)
            e[j] = 1.0
            cross(r, 0, e, 0, tq, 0)
        for i in range(3):
            tq[i] += u[i] if j == 3 else (nv[i] if j == 4 else 0.0)
        for i in range(3):
            dw[i] = iw[3 * i] * tq[0] + iw[3 * i + 1] * tq[1] + iw[3 * i + 2] * tq[2]
        cross(dw, 0, r, 0, dv, 0)
        for i in range(3):
            A[i, j] = dv[i] + (1.0 / prm[P_MASS] if i == j else 0.0)
        A[3, j] = (1.0 if j == 3 else 0.0) if point else dw[0] * u[0] + dw[1] * u[1] + dw[2] * u[2]
        A[4, j] = dw[0] * nv[0] + dw[1] * nv[1] + dw[2] * nv[2]
    b = np.empty(5)
    for i in range(3):
        b[i] = -vc[i]
    b[3] = 0.0 if point else -(state[10] * u[0] + state[11] * u[1] + state[12] * u[2])
    b[4] = -(state[10] * nv[0] + state[11] * nv[1] + state[12] * nv[2])
    if abs(np.linalg.det(A)) < 1e-300:
        return False
    sol = np.linalg.solve(A, b)
    P = sol[:3].copy()
    pn = nv[0] * P[0] + nv[1] * P[1] + nv[2] * P[2]
    if not pn > 0.0:
        return False
    sof = 0.0 if point else min(max(sol[3] / pn, -half), half)
    # the torque of the solved impulses, r x P + m_u u + m_n n; where the friction cone
    # cuts P below, v+ takes the cut impulse and w+ keeps these (a guess either way: Newton
    # balances the two)
    cross(r, 0, P, 0, tq, 0)
    press = 0.0
    for i in range(3):
        tq[i] += sol[3] * u[i] + sol[4] * nv[i]
        press -= nv[i] * sc[S_FEXT + i]
    ep = np.empty(3)
    cross(edge, 0, P, 0, ep, 0)
    mrest = sol[4] - sof * (ep[0] * nv[0] + ep[1] * nv[1] + ep[2] * nv[2])
    pt = 0.0
    for i in range(3):
        pt += (P[i] - pn * nv[i]) ** 2
    pt = math.sqrt(pt)
    cut = prm[P_MU] * pn / pt if pt > prm[P_MU] * pn else 1.0
    for i in range(3):
        P[i] = pn * nv[i] + cut * (P[i] - pn * nv[i])
        z[i] = state[7 + i] + P[i] / prm[P_MASS] + h * sc[S_FEXT + i] / prm[P_MASS]
        z[3 + i] = state[10 + i] + iw[3 * i] * tq[0] + iw[3 * i + 1] * tq[1] + iw[3 * i + 2] * tq[2]
        z[off + B_A1 + i] += sof * edge[i]
        z[off + B_A2 + i] += sof * edge[i]
    impact_forces(z, off, mk, P, pn, press, h, prm)
    z[off + B_LR] = mrest / h
    return True


@jit
def impact_forces(z, off, mk, P, pn, press, h, prm):  # type: ignore[no-untyped-def]
    """Write the impact guess's forces into the contact block at ``off`` (``mk`` constraints); returns True."""
    z[off + B_L + mk + 1] = pn / h + max(press, 0.0)
    pt = 0.0
    po = 0.0
    for i in range(3):
        pt += prm[P_T + i] * P[i]
        po += prm[P_O + i] * P[i]
    z[off + B_LT] = pt / h
    z[off + B_LO] = po / h
    z[off + B_LR] = 0.0
    z[off + B_SIG] = 0.0
    return True
