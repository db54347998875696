"""Residual ``Phi(z)`` of one time step and its analytic Jacobian.

The discrete model is the paper's geometrically implicit mixed NCP (Xie et al. 2019,
"Discrete-time dynamic model"; MODEL.md, "The discrete model"), written with forces
``lam = p / h`` as unknowns and in scaled units (:mod:`tumblemc.kernels.layout`).

Unknowns ``z = [v+, w+, block_0, ...]``; per convex piece ``k`` with constraints
``f_i(y) <= 0`` (body coordinates ``y``) the block is
``[a1, a2, lam_t, lam_o, lam_r, sigma, l_1..l_m, l_s, lam_n]``.

End-of-step pose: ``x+ = x + h v+``, ``Q+ = normalise(Q + h/2 E(Q) w+)``, ``R+ = R(Q+)``,
world inertia ``I+ = R+ Ib R+^T``; ``r = a1 - x+``; plane ``g(x) = n.x`` (substrate
``g <= 0``); ``N_i = R+ grad f_i(R+^T r)``.

Rows (``Fc = lam_n n + lam_t t + lam_o o``):

- Newton-Euler (6): ``m (v+ - v)/h - sum Fc - F_ext``;
  ``(I+ w+ - I w)/h - sum (r x Fc + lam_r n) - T_m`` (momentum form, ``I`` the world
  inertia at the start pose; with ``prm[P_ROT_PAPER]`` the paper's
  ``I+ (w+ - w)/h + w x (I+ w)``), where ``T_m`` is the
  start-of-step torque or, with ``torque="end"``, ``(R+ e_b) x B(t+h)`` scaled.
- per block:
  ``a1 - a2 - l_s n`` (3) and ``sum_i l_i N_i + n`` (3): the ECP / closest-point
  conditions with the plane's constraint as the distinguished index (MODEL.md);
  ``mu e_t lam_n v_t + (lam_t / e_t) sigma``, same for ``o`` and for ``r`` with
  ``v_r = n.w+`` (3): maximum dissipation, the paper's rows divided by ``e``;
  ``FB(sigma, mu^2 lam_n^2 - (lam_t/e_t)^2 - (lam_o/e_o)^2 - (lam_r/e_r)^2)``;
  ``FB(l_i, -f_i(a1))`` for each constraint; ``FB(l_s, -g(a2))``; ``FB(lam_n, g(a1))``.

``FB`` is the Fischer-Burmeister function ``a + b - sqrt(a^2 + b^2)`` in its
cancellation-free form. Its generalised Jacobian at ``a = b = 0`` takes the element of
De Luca, Facchinei and Kanzow (Math. Prog. 1996), built with ``z_i = 1`` on the degenerate
complementarity variables.
"""

from __future__ import annotations

import math
from collections import namedtuple

from ._jit import jit
from .geometry import CG_G, CG_H, N_CG, N_QS, QS_JTH, QS_Q, constraint_eval, cross, quat_step, quat_to_rot, skew
from .layout import (
    B_A1,
    B_A2,
    B_FIXED,
    B_L,
    B_LO,
    B_LR,
    B_LT,
    B_SIG,
    P_EB,
    P_EO,
    P_ER,
    P_ET,
    P_IB,
    P_MASS,
    P_MU,
    P_N,
    P_O,
    P_POSE_W0,
    P_ROT_PAPER,
    P_T,
    P_TORQUE_END,
    S_B1,
    S_FEXT,
    S_H,
    S_Q,
    S_TM,
    S_V,
    S_W,
    S_X,
)

Problem = namedtuple("Problem", ["sc", "prm", "ctype", "cdata", "pstart"])
Problem.__doc__ = """The system of one step (see :func:`residual`): step data, run constants and the
constraints (a ``pstart`` of length 1 is the free-flight system, no contact block). The
time loop builds its two problems once per run; ``sc`` is refilled in place every step."""

FB_DEGENERATE = 1e-14  # |(a, b)| below which the FB pair is treated as a kink


def fb(a: float, b: float) -> float:
    """Fischer-Burmeister ``a + b - hypot(a, b)`` without cancellation for a, b > 0.

    :func:`fb_r` with its ``r``; plain Python (the kernels call ``fb_r``, with ``r`` that
    they need again), for tests and callers outside the kernels.
    """
    return float(fb_r(a, b, math.hypot(a, b)))


@jit
def fb_r(a, b, r):  # type: ignore[no-untyped-def]
    """:func:`fb` with ``r = hypot(a, b)`` already computed.

    The residual needs ``r`` again for the Jacobian and for the degeneracy test: computed
    once, it saves two libm calls per row and Jacobian (the same value, so the same bits).
    """
    s = a + b
    if s > 0.0:
        # a * b first would underflow for tiny a, b; ordering keeps fb(a, b) == fb(b, a);
        # the exact value never exceeds min(a, b)
        lo = min(a, b)
        return min(2.0 * (lo / (s + r)) * max(a, b), lo)
    return s - r


@jit
def fb_smooth(a, b, mu):  # type: ignore[no-untyped-def]
    """Smoothed FB ``a + b - sqrt(a^2 + b^2 + 2 mu^2)``, zero iff a, b > 0 and ab = mu^2
    (Kanzow 1996); cancellation-free for a + b > 0. Returns (value, rho)."""
    r = math.sqrt(a * a + b * b + 2.0 * mu * mu)
    s = a + b
    if s > 0.0:
        return 2.0 * (a * b - mu * mu) / (s + r), r
    return s - r, r


def n_unknowns(pstart) -> int:  # type: ignore[no-untyped-def]
    """Size of ``z`` for pieces delimited by ``pstart`` (plain Python helper)."""
    k = len(pstart) - 1
    return 6 + B_FIXED * k + int(pstart[-1] - pstart[0])


# ---- the residual's scratch: one flat float64[N_RS] array ----------------------------
# Views of a scratch array (``m33[0]``, ``z[0:3]``, ...) each cost Numba an atomic
# reference-count increment and decrement, about a tenth of a time step's cost, so the
# residual addresses one flat scratch array (and z, sc, prm) by offsets, and calls the
# geometry kernels (:mod:`.geometry`, the one implementation) with offsets.
# 3x3 matrices row-major (9 entries), vectors 3.
RS_R = 0  # R+ (rotation at the end of the step)
RS_IP = 9  # I+ (world inertia)
RS_M1 = 18  # 3x3 temporaries
RS_M2 = 27
RS_M3 = 36
RS_HL = 45  # sum_i l_i R Hb_i R^T
RS_XP = 54  # x+
RS_R1 = 57  # r = a1 - x+
RS_Y = 60  # r in body coordinates
RS_NI = 63  # the world normal of one constraint
RS_FC = 66  # contact force
RS_V1 = 69  # vector temporaries
RS_V2 = 72
RS_DL = 75  # w+ - w
RS_IPD = 78  # I+ (w+ - w)
RS_IPW = 81  # I+ w
RS_VC = 84  # velocity of the ECP
RS_NC = 87  # normal-cone row
RS_MW = 90  # R+ e_b
RS_IPZ = 93  # I+ w+ (momentum form)
RS_L0 = 96  # I w: angular momentum at the start of the step (momentum form)
RS_QS = 99  # quat_step's block (N_QS): Q+, E(Q), E(Q+), d(theta)/d(w+)
RS_QN = RS_QS + QS_Q  # Q+ (4)
RS_JTH = RS_QS + QS_JTH  # d(theta)/d(w+)
RS_CG = RS_QS + N_QS  # constraint_eval's block (N_CG): gradient and Hessian (body frame)
RS_GB = RS_CG + CG_G
RS_HB = RS_CG + CG_H
N_RS = RS_CG + N_CG


@jit
def _mm(s, ia, ib, io):  # type: ignore[no-untyped-def]
    """s[io] = s[ia] @ s[ib] for 3x3 row-major blocks of the scratch."""
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for k in range(3):
                acc += s[ia + 3 * i + k] * s[ib + 3 * k + j]
            s[io + 3 * i + j] = acc


@jit
def _friction_jac(J, z, prm, s, h, idx, coef):  # type: ignore[no-untyped-def]
    """Jacobian of ``cf/ln * ln * (axis . (v+ + w+ x r)) + lam/e * sigma`` (one tangent
    row; ``axis = prm[iax:iax+3]``, ``w+ = z[3:6]``, ``r`` at RS_R1).

    ``idx = (row, ilam, isg, iln, ia1, iax)`` (ints) and ``coef = (cf, dln, dsig, dlam)``.
    """
    row, ilam, isg, iln, ia1, iax = idx
    cf, dln, dsig, dlam = coef
    cross(prm, iax, z, 3, s, RS_V1)  # d v_axis / d a1
    cross(s, RS_R1, prm, iax, s, RS_V2)  # d v_axis / d w+
    for j in range(3):
        J[row, j] = cf * (prm[iax + j] - h * s[RS_V1 + j])
        J[row, 3 + j] = cf * s[RS_V2 + j]
        J[row, ia1 + j] = cf * s[RS_V1 + j]
    J[row, iln] = dln
    J[row, isg] = dsig
    J[row, ilam] = dlam


@jit
def residual(z, prob, F, J, work, want_J, mu_s=0.0):  # type: ignore[no-untyped-def]  # noqa: C901
    """Evaluate ``Phi(z)`` into ``F`` and, if ``want_J``, its Jacobian into ``J``.

    Parameters
    ----------
    z : float64[n]
        Unknowns (layout in the module docstring).
    prob : Problem
        The step's system: ``sc`` float64[N_SC] (step data ``S_*``: start-of-step state,
        ``h``, ``F_ext``, torque data), ``prm`` float64[N_PRM] (run constants ``P_*``), and
        the constraints ``ctype``, ``cdata``, ``pstart`` (int64[M], float64[M, 4],
        int64[K + 1]; piece ``k`` owns ``pstart[k]:pstart[k+1]``; ``pstart`` of length 1:
        free flight, no contact block).
    F : float64[n]
        Receives the residual.
    J : float64[n, n]
        Receives the Jacobian when ``want_J``.
    work : (isfb, fbb, s)
        Workspaces: FB-row flags int64[n], the raw ``b`` of each FB pair float64[n], and
        the scratch float64[N_RS] (layout ``RS_*`` above; no allocation here).
    want_J : bool
    mu_s : float
        Smoothing of the FB rows (``fb_smooth``); 0 gives the plain FB of the model.

    Returns
    -------
    float
        ``0.5 * ||F||^2``.
    """
    sc, prm, ctype, cdata, pstart = prob
    isfb, fbb, s = work
    n = z.shape[0]
    h = sc[S_H]
    m = prm[P_MASS]
    mu = prm[P_MU]
    et = prm[P_ET]
    eo = prm[P_EO]
    er = prm[P_ER]
    # offsets: v+ = z[0:3], w+ = z[3:6], w = sc[S_W:], n = prm[P_N:], t = prm[P_T:], o = prm[P_O:]

    quat_step(sc, S_Q, z, 3, h, s, RS_QS, sc, S_W, (1.0 - prm[P_POSE_W0]))
    quat_to_rot(s, RS_QN, s, RS_R)
    for i in range(3):
        s[RS_XP + i] = sc[S_X + i] + h * z[i]
        s[RS_DL + i] = z[3 + i] - sc[S_W + i]
    # I+ = R Ib R^T
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for k in range(3):
                acc += prm[P_IB + 3 * i + k] * s[RS_R + 3 * j + k]
            s[RS_M1 + 3 * i + j] = acc
    _mm(s, RS_R, RS_M1, RS_IP)
    for i in range(3):
        a = 0.0
        b = 0.0
        for j in range(3):
            a += s[RS_IP + 3 * i + j] * s[RS_DL + j]
            b += s[RS_IP + 3 * i + j] * sc[S_W + j]
        s[RS_IPD + i] = a
        s[RS_IPW + i] = b
    rot_paper = prm[P_ROT_PAPER] > 0.5
    if not rot_paper:
        # momentum form (MODEL.md): I+ w+ and I w = R (Ib (R^T w)) at the start pose; R at
        # RS_M2 is free until the Jacobian (RS_M1 holds Ib R+^T, not needed any more)
        for i in range(3):
            acc = 0.0
            for j in range(3):
                acc += s[RS_IP + 3 * i + j] * z[3 + j]
            s[RS_IPZ + i] = acc
        quat_to_rot(sc, S_Q, s, RS_M2)
        for i in range(3):
            acc = 0.0
            for j in range(3):
                acc += s[RS_M2 + 3 * j + i] * sc[S_W + j]
            s[RS_V2 + i] = acc
        for i in range(3):
            acc = 0.0
            for j in range(3):
                acc += prm[P_IB + 3 * i + j] * s[RS_V2 + j]
            s[RS_V1 + i] = acc
        for i in range(3):
            acc = 0.0
            for j in range(3):
                acc += s[RS_M2 + 3 * i + j] * s[RS_V1 + j]
            s[RS_L0 + i] = acc

    for i in range(n):
        F[i] = 0.0
        isfb[i] = 0
    if want_J:
        for i in range(n):
            for j in range(n):
                J[i, j] = 0.0

    # ---- Newton-Euler, applied part --------------------------------------------------
    if rot_paper:  # the paper's form: forward Euler on Euler's equations (gains energy in 3-D)
        cross(sc, S_W, s, RS_IPW, s, RS_V1)
        for i in range(3):
            F[i] = m * (z[i] - sc[S_V + i]) / h - sc[S_FEXT + i]
            F[3 + i] = s[RS_IPD + i] / h + s[RS_V1 + i]
    else:  # momentum form: keeps the angular momentum of a free body exactly
        for i in range(3):
            F[i] = m * (z[i] - sc[S_V + i]) / h - sc[S_FEXT + i]
            F[3 + i] = (s[RS_IPZ + i] - s[RS_L0 + i]) / h
    # the magnetic torque: at the end pose (weight wend = 1, the paper's), at the start (0),
    # or their mean (0.5, the midpoint rule's trapezoid); 1 and 0 computed exactly as before
    wend = prm[P_TORQUE_END]
    torque_end = wend > 0.0
    if torque_end:
        for i in range(3):
            acc = 0.0
            for j in range(3):
                acc += s[RS_R + 3 * i + j] * prm[P_EB + j]
            s[RS_MW + i] = acc
        cross(s, RS_MW, sc, S_B1, s, RS_V2)
        if wend == 1.0:
            for i in range(3):
                F[3 + i] -= s[RS_V2 + i]
        else:
            for i in range(3):
                F[3 + i] -= wend * s[RS_V2 + i] + (1.0 - wend) * sc[S_TM + i]
    else:
        for i in range(3):
            F[3 + i] -= sc[S_TM + i]

    if want_J:
        for i in range(3):
            J[i, i] = m / h
        if rot_paper:
            # d/dw of I+ dl / h + w0 x (I+ w0): (-[I+ dl]x + I+ [dl]x) Jth / h + [w0]x(-[I+ w0]x + I+ [w0]x) Jth
            skew(s, RS_IPD, s, RS_M1)
            skew(s, RS_DL, s, RS_M2)
            _mm(s, RS_IP, RS_M2, RS_M3)
            for i in range(9):
                s[RS_M3 + i] = (s[RS_M3 + i] - s[RS_M1 + i]) / h
            skew(s, RS_IPW, s, RS_M1)
            skew(sc, S_W, s, RS_M2)
            _mm(s, RS_IP, RS_M2, RS_HL)
            for i in range(9):
                s[RS_HL + i] -= s[RS_M1 + i]
            _mm(s, RS_M2, RS_HL, RS_M1)  # [w0]x (...)
            for i in range(9):
                s[RS_M3 + i] += s[RS_M1 + i]
        else:
            # d/dw of (I+ w+) / h: (-[I+ w+]x + I+ [w+]x) Jth / h (dI+ = [dth]x I+ - I+ [dth]x)
            skew(s, RS_IPZ, s, RS_M1)
            skew(z, 3, s, RS_M2)
            _mm(s, RS_IP, RS_M2, RS_M3)
            for i in range(9):
                s[RS_M3 + i] = (s[RS_M3 + i] - s[RS_M1 + i]) / h
        if torque_end:
            # T = mw x B, d mw = -[mw]x dtheta -> dT = [B]x [mw]x dtheta
            skew(sc, S_B1, s, RS_M1)
            skew(s, RS_MW, s, RS_M2)
            _mm(s, RS_M1, RS_M2, RS_HL)
            for i in range(9):
                s[RS_M3 + i] -= wend * s[RS_HL + i]
        _mm(s, RS_M3, RS_JTH, RS_M1)
        for i in range(3):
            for j in range(3):
                J[3 + i, 3 + j] = s[RS_IP + 3 * i + j] / h + s[RS_M1 + 3 * i + j]

    # ---- contact blocks --------------------------------------------------------------
    K = pstart.shape[0] - 1
    off = 6
    for kp in range(K):
        c0 = pstart[kp]
        mk = pstart[kp + 1] - c0
        ia1 = off + B_A1
        ia2 = off + B_A2
        ilt = off + B_LT
        ilo = off + B_LO
        ilr = off + B_LR
        isg = off + B_SIG
        il0 = off + B_L
        ils = il0 + mk
        iln = il0 + mk + 1
        lt = z[ilt]
        lo = z[ilo]
        lr = z[ilr]
        sig = z[isg]
        ls = z[ils]
        ln = z[iln]
        for i in range(3):
            s[RS_R1 + i] = z[ia1 + i] - s[RS_XP + i]
            s[RS_FC + i] = ln * prm[P_N + i] + lt * prm[P_T + i] + lo * prm[P_O + i]
        for i in range(3):
            acc = 0.0
            for j in range(3):
                acc += s[RS_R + 3 * j + i] * s[RS_R1 + j]
            s[RS_Y + i] = acc
        cross(s, RS_R1, s, RS_FC, s, RS_V1)
        for i in range(3):
            F[i] -= s[RS_FC + i]
            F[3 + i] -= s[RS_V1 + i] + lr * prm[P_N + i]
            F[ia1 + i] = z[ia1 + i] - z[ia2 + i] - ls * prm[P_N + i]
            s[RS_NC + i] = prm[P_N + i]
        if want_J:
            for i in range(3):
                J[i, iln] -= prm[P_N + i]
                J[i, ilt] -= prm[P_T + i]
                J[i, ilo] -= prm[P_O + i]
                J[3 + i, ilr] -= prm[P_N + i]
            skew(s, RS_FC, s, RS_M1)
            for i in range(3):
                for j in range(3):
                    J[3 + i, ia1 + j] += s[RS_M1 + 3 * i + j]
                    J[3 + i, j] -= h * s[RS_M1 + 3 * i + j]
                    s[RS_HL + 3 * i + j] = 0.0
            cross(s, RS_R1, prm, P_N, s, RS_V1)
            cross(s, RS_R1, prm, P_T, s, RS_V2)
            for i in range(3):
                J[3 + i, iln] -= s[RS_V1 + i]
                J[3 + i, ilt] -= s[RS_V2 + i]
            cross(s, RS_R1, prm, P_O, s, RS_V1)
            for i in range(3):
                J[3 + i, ilo] -= s[RS_V1 + i]
                J[ia1 + i, ia1 + i] = 1.0
                J[ia1 + i, ia2 + i] = -1.0
                J[ia1 + i, ils] = -prm[P_N + i]

        # normal cone and the robot's constraint rows
        for ic in range(mk):
            c = c0 + ic
            li = z[il0 + ic]
            fval = constraint_eval(ctype[c], cdata, c, s, RS_Y, s, RS_CG)
            for i in range(3):
                acc = 0.0
                for j in range(3):
                    acc += s[RS_R + 3 * i + j] * s[RS_GB + j]
                s[RS_NI + i] = acc
            for i in range(3):
                s[RS_NC + i] += li * s[RS_NI + i]
            row = il0 + ic
            isfb[row] = 1
            fbb[row] = -fval
            if want_J:
                # raw d(-f_i) = -N_i . (da1 - h dv + [r]x Jth dw)
                cross(s, RS_R1, s, RS_NI, s, RS_V1)
                for j in range(3):
                    J[off + 3 + j, row] = s[RS_NI + j]  # d(normal cone)/d l_i
                    J[row, ia1 + j] = -s[RS_NI + j]
                    J[row, j] = h * s[RS_NI + j]
                    acc = 0.0
                    for k in range(3):
                        acc += s[RS_V1 + k] * s[RS_JTH + 3 * k + j]
                    J[row, 3 + j] = acc
                if li != 0.0 and (s[RS_HB + 4] != 0.0 or s[RS_HB + 8] != 0.0 or s[RS_HB] != 0.0):
                    # HL += l_i R Hb R^T
                    for i in range(3):
                        for j in range(3):
                            acc = 0.0
                            for k in range(3):
                                acc += s[RS_HB + 3 * i + k] * s[RS_R + 3 * j + k]
                            s[RS_M1 + 3 * i + j] = acc
                    _mm(s, RS_R, RS_M1, RS_M2)
                    for i in range(9):
                        s[RS_HL + i] += li * s[RS_M2 + i]
        for i in range(3):
            F[off + 3 + i] = s[RS_NC + i]
        if want_J:
            # d(sum l_i N_i) = HL (da1 - h dv + [r]x Jth dw) - [sum l_i N_i]x Jth dw
            skew(s, RS_R1, s, RS_M1)
            _mm(s, RS_HL, RS_M1, RS_M2)
            for i in range(3):
                s[RS_V1 + i] = s[RS_NC + i] - prm[P_N + i]
            skew(s, RS_V1, s, RS_M1)
            for i in range(9):
                s[RS_M2 + i] -= s[RS_M1 + i]
            _mm(s, RS_M2, RS_JTH, RS_M3)
            for i in range(3):
                for j in range(3):
                    J[off + 3 + i, ia1 + j] += s[RS_HL + 3 * i + j]
                    J[off + 3 + i, j] -= h * s[RS_HL + 3 * i + j]
                    J[off + 3 + i, 3 + j] += s[RS_M3 + 3 * i + j]

        # maximum dissipation
        cross(z, 3, s, RS_R1, s, RS_V1)
        for i in range(3):
            s[RS_VC + i] = z[i] + s[RS_V1 + i]
        vt = prm[P_T] * s[RS_VC] + prm[P_T + 1] * s[RS_VC + 1] + prm[P_T + 2] * s[RS_VC + 2]
        vo = prm[P_O] * s[RS_VC] + prm[P_O + 1] * s[RS_VC + 1] + prm[P_O + 2] * s[RS_VC + 2]
        vr = prm[P_N] * z[3] + prm[P_N + 1] * z[4] + prm[P_N + 2] * z[5]
        F[off + 6] = mu * et * ln * vt + lt / et * sig
        F[off + 7] = mu * eo * ln * vo + lo / eo * sig
        F[off + 8] = mu * er * ln * vr + lr / er * sig
        if want_J:
            _friction_jac(J, z, prm, s, h, (off + 6, ilt, isg, iln, ia1, P_T), (mu * et * ln, mu * et * vt, lt / et, sig / et))
            _friction_jac(J, z, prm, s, h, (off + 7, ilo, isg, iln, ia1, P_O), (mu * eo * ln, mu * eo * vo, lo / eo, sig / eo))
            cf = mu * er * ln
            for j in range(3):
                J[off + 8, 3 + j] = cf * prm[P_N + j]
            J[off + 8, iln] = mu * er * vr
            J[off + 8, isg] = lr / er
            J[off + 8, ilr] = sig / er

        # friction cone
        xi = (mu * ln) ** 2 - (lt / et) ** 2 - (lo / eo) ** 2 - (lr / er) ** 2
        isfb[isg] = 1
        fbb[isg] = xi
        if want_J:
            J[isg, iln] = 2.0 * mu * mu * ln
            J[isg, ilt] = -2.0 * lt / (et * et)
            J[isg, ilo] = -2.0 * lo / (eo * eo)
            J[isg, ilr] = -2.0 * lr / (er * er)
        # plane constraint at a2, non-penetration at a1
        isfb[ils] = 1
        fbb[ils] = -(prm[P_N] * z[ia2] + prm[P_N + 1] * z[ia2 + 1] + prm[P_N + 2] * z[ia2 + 2])
        isfb[iln] = 1
        fbb[iln] = prm[P_N] * z[ia1] + prm[P_N + 1] * z[ia1 + 1] + prm[P_N + 2] * z[ia1 + 2]
        if want_J:
            for j in range(3):
                J[ils, ia2 + j] = -prm[P_N + j]
                J[iln, ia1 + j] = prm[P_N + j]
        off += B_FIXED + mk

    # ---- Fischer-Burmeister rows (row index == its complementarity variable) ---------
    theta = 0.0
    # |(a, b)| of the plain FB rows, once: held in F[i] (an FB row's F is 0 until its value
    # is written below) for fb_r, the Jacobian's rho and the degeneracy test
    have_r = want_J and mu_s == 0.0
    if have_r:
        for i in range(n):
            if isfb[i] == 1:
                r = math.hypot(z[i], fbb[i])
                F[i] = r
                if r < FB_DEGENERATE:
                    isfb[i] = 2
    for i in range(n):
        if isfb[i] == 0:
            theta += F[i] * F[i]
            continue
        a = z[i]
        b = fbb[i]
        ca = 0.0
        cb = 0.0
        if mu_s > 0.0:
            val, rho = fb_smooth(a, b, mu_s)
            if want_J:
                ca = 1.0 - a / rho
                cb = 1.0 - b / rho
        else:
            r = F[i] if have_r else math.hypot(a, b)
            val = fb_r(a, b, r)
            if want_J and isfb[i] == 1:
                rho = r
                ca = 1.0 - a / rho
                cb = 1.0 - b / rho
            elif want_J:
                # DFK: z_j = 1 on degenerate variables; c = grad a . z = 1, d = grad b . z
                d = 0.0
                for j in range(n):
                    if isfb[j] == 2:
                        d += J[i, j]
                rho = math.hypot(1.0, d)
                ca = 1.0 - 1.0 / rho
                cb = 1.0 - d / rho
        F[i] = val
        theta += val * val
        if want_J:
            for j in range(n):
                J[i, j] *= cb
            J[i, i] += ca
    return 0.5 * theta
