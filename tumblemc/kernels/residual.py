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
  ``I+ (w+ - w)/h + w x (I+ w) - sum (r x Fc + lam_r n) - T_m``, where ``T_m`` is the
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

from ._jit import jit
from .geometry import constraint_eval, cross, quat_step, quat_to_rot, skew
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
    P_T,
    P_TORQUE_END,
    S_BEND,
    S_FEXT,
    S_H,
    S_Q,
    S_TM,
    S_V,
    S_W,
    S_X,
)

FB_DEGENERATE = 1e-14  # |(a, b)| below which the FB pair is treated as a kink


@jit
def fb(a, b):  # type: ignore[no-untyped-def]
    """Fischer-Burmeister ``a + b - hypot(a, b)`` without cancellation for a, b > 0."""
    r = math.hypot(a, b)
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


@jit
def _mat3(a, b, out):  # type: ignore[no-untyped-def]
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for k in range(3):
                acc += a[i, k] * b[k, j]
            out[i, j] = acc


@jit
def _friction_jac(J, row, ilam, isg, iln, ia1, cf, dln, dsig, dlam, axis, wnew, r, h, t1, t2):  # type: ignore[no-untyped-def]
    """Jacobian of ``cf/ln * ln * (axis . (v+ + w+ x r)) + lam/e * sigma`` (one tangent row)."""
    cross(axis, wnew, t1)  # d v_axis / d a1
    cross(r, axis, t2)  # d v_axis / d w+
    for j in range(3):
        J[row, j] = cf * (axis[j] - h * t1[j])
        J[row, 3 + j] = cf * t2[j]
        J[row, ia1 + j] = cf * t1[j]
    J[row, iln] = dln
    J[row, isg] = dsig
    J[row, ilam] = dlam


@jit
def residual(z, sc, prm, ctype, cdata, pstart, F, J, want_J, isfb, fbb, v3, m33, q4, e43, mu_s=0.0):  # type: ignore[no-untyped-def]
    """Evaluate ``Phi(z)`` into ``F`` and, if ``want_J``, its Jacobian into ``J``.

    Parameters
    ----------
    z : float64[n]
        Unknowns (layout in the module docstring).
    sc : float64[N_SC]
        Step data (``S_*``): start-of-step state, ``h``, ``F_ext``, torque data.
    prm : float64[N_PRM]
        Run constants (``P_*``).
    ctype, cdata, pstart : int64[M], float64[M, 4], int64[K + 1]
        Constraints of all pieces; piece ``k`` owns ``pstart[k]:pstart[k+1]``.
    F : float64[n]
        Receives the residual.
    J : float64[n, n]
        Receives the Jacobian when ``want_J``.
    isfb, fbb : int64[n], float64[n]
        Workspaces: FB-row flags and the raw ``b`` of each FB pair.
    v3, m33, q4, e43 : float64[16, 3], float64[8, 3, 3], float64[2, 4], float64[2, 4, 3]
        Small scratch arrays (no allocation here).
    mu_s : float
        Smoothing of the FB rows (``fb_smooth``); 0 gives the plain FB of the model.

    Returns
    -------
    float
        ``0.5 * ||F||^2``.
    """
    n = z.shape[0]
    h = sc[S_H]
    m = prm[P_MASS]
    mu = prm[P_MU]
    et = prm[P_ET]
    eo = prm[P_EO]
    er = prm[P_ER]
    nrm = prm[P_N : P_N + 3]
    tt = prm[P_T : P_T + 3]
    oo = prm[P_O : P_O + 3]
    w0 = sc[S_W : S_W + 3]
    vnew = z[0:3]
    wnew = z[3:6]

    R = m33[0]
    Jth = m33[1]
    Ip = m33[2]
    T1 = m33[3]
    T2 = m33[4]
    T3 = m33[5]
    HL = m33[6]
    Hb = m33[7]
    qn = q4[0]
    xp = v3[0]
    r = v3[1]
    y = v3[2]
    gb = v3[3]
    Ni = v3[4]
    Fc = v3[5]
    t1 = v3[6]
    t2 = v3[7]
    dl = v3[8]
    Ipd = v3[9]
    Ipw = v3[10]
    vc = v3[11]
    nc = v3[12]
    mw = v3[13]

    quat_step(sc[S_Q : S_Q + 4], wnew, h, qn, e43[0], e43[1], Jth)
    quat_to_rot(qn, R)
    for i in range(3):
        xp[i] = sc[S_X + i] + h * vnew[i]
        dl[i] = wnew[i] - w0[i]
    # I+ = R Ib R^T
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for k in range(3):
                acc += prm[P_IB + 3 * i + k] * R[j, k]
            T1[i, j] = acc
    _mat3(R, T1, Ip)
    for i in range(3):
        a = 0.0
        b = 0.0
        for j in range(3):
            a += Ip[i, j] * dl[j]
            b += Ip[i, j] * w0[j]
        Ipd[i] = a
        Ipw[i] = b

    for i in range(n):
        F[i] = 0.0
        isfb[i] = 0
    if want_J:
        for i in range(n):
            for j in range(n):
                J[i, j] = 0.0

    # ---- Newton-Euler, applied part --------------------------------------------------
    cross(w0, Ipw, t1)
    for i in range(3):
        F[i] = m * (vnew[i] - sc[S_V + i]) / h - sc[S_FEXT + i]
        F[3 + i] = Ipd[i] / h + t1[i]
    torque_end = prm[P_TORQUE_END] > 0.5
    if torque_end:
        for i in range(3):
            acc = 0.0
            for j in range(3):
                acc += R[i, j] * prm[P_EB + j]
            mw[i] = acc
        cross(mw, sc[S_BEND : S_BEND + 3], t2)
        for i in range(3):
            F[3 + i] -= t2[i]
    else:
        for i in range(3):
            F[3 + i] -= sc[S_TM + i]

    if want_J:
        for i in range(3):
            J[i, i] = m / h
        # d/dw of I+ dl / h + w0 x (I+ w0): (-[I+ dl]x + I+ [dl]x) Jth / h + [w0]x(-[I+ w0]x + I+ [w0]x) Jth
        skew(Ipd, T1)
        skew(dl, T2)
        _mat3(Ip, T2, T3)
        for i in range(3):
            for j in range(3):
                T3[i, j] = (T3[i, j] - T1[i, j]) / h
        skew(Ipw, T1)
        skew(w0, T2)
        _mat3(Ip, T2, HL)
        for i in range(3):
            for j in range(3):
                HL[i, j] -= T1[i, j]
        _mat3(T2, HL, T1)  # [w0]x (...)
        for i in range(3):
            for j in range(3):
                T3[i, j] += T1[i, j]
        if torque_end:
            # T = mw x B, d mw = -[mw]x dtheta -> dT = [B]x [mw]x dtheta
            skew(sc[S_BEND : S_BEND + 3], T1)
            skew(mw, T2)
            _mat3(T1, T2, HL)
            for i in range(3):
                for j in range(3):
                    T3[i, j] -= HL[i, j]
        _mat3(T3, Jth, T1)
        for i in range(3):
            for j in range(3):
                J[3 + i, 3 + j] = Ip[i, j] / h + T1[i, j]

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
        a1 = z[ia1 : ia1 + 3]
        a2 = z[ia2 : ia2 + 3]
        for i in range(3):
            r[i] = a1[i] - xp[i]
            Fc[i] = ln * nrm[i] + lt * tt[i] + lo * oo[i]
        for i in range(3):
            acc = 0.0
            for j in range(3):
                acc += R[j, i] * r[j]
            y[i] = acc
        cross(r, Fc, t1)
        for i in range(3):
            F[i] -= Fc[i]
            F[3 + i] -= t1[i] + lr * nrm[i]
            F[ia1 + i] = a1[i] - a2[i] - ls * nrm[i]
            nc[i] = nrm[i]
        if want_J:
            for i in range(3):
                J[i, iln] -= nrm[i]
                J[i, ilt] -= tt[i]
                J[i, ilo] -= oo[i]
                J[3 + i, ilr] -= nrm[i]
            skew(Fc, T1)
            for i in range(3):
                for j in range(3):
                    J[3 + i, ia1 + j] += T1[i, j]
                    J[3 + i, j] -= h * T1[i, j]
                    HL[i, j] = 0.0
            cross(r, nrm, t1)
            cross(r, tt, t2)
            for i in range(3):
                J[3 + i, iln] -= t1[i]
                J[3 + i, ilt] -= t2[i]
            cross(r, oo, t1)
            for i in range(3):
                J[3 + i, ilo] -= t1[i]
                J[ia1 + i, ia1 + i] = 1.0
                J[ia1 + i, ia2 + i] = -1.0
                J[ia1 + i, ils] = -nrm[i]

        # normal cone and the robot's constraint rows
        for ic in range(mk):
            c = c0 + ic
            li = z[il0 + ic]
            fval = constraint_eval(ctype[c], cdata[c], y, gb, Hb)
            for i in range(3):
                acc = 0.0
                for j in range(3):
                    acc += R[i, j] * gb[j]
                Ni[i] = acc
            for i in range(3):
                nc[i] += li * Ni[i]
            row = il0 + ic
            isfb[row] = 1
            fbb[row] = -fval
            if want_J:
                # raw d(-f_i) = -N_i . (da1 - h dv + [r]x Jth dw)
                cross(r, Ni, t1)
                for j in range(3):
                    J[off + 3 + j, row] = Ni[j]  # d(normal cone)/d l_i
                    J[row, ia1 + j] = -Ni[j]
                    J[row, j] = h * Ni[j]
                    acc = 0.0
                    for k in range(3):
                        acc += t1[k] * Jth[k, j]
                    J[row, 3 + j] = acc
                if li != 0.0 and (Hb[1, 1] != 0.0 or Hb[2, 2] != 0.0 or Hb[0, 0] != 0.0):
                    # HL += l_i R Hb R^T
                    for i in range(3):
                        for j in range(3):
                            acc = 0.0
                            for k in range(3):
                                acc += Hb[i, k] * R[j, k]
                            T1[i, j] = acc
                    _mat3(R, T1, T2)
                    for i in range(3):
                        for j in range(3):
                            HL[i, j] += li * T2[i, j]
        for i in range(3):
            F[off + 3 + i] = nc[i]
        if want_J:
            # d(sum l_i N_i) = HL (da1 - h dv + [r]x Jth dw) - [sum l_i N_i]x Jth dw
            skew(r, T1)
            _mat3(HL, T1, T2)
            for i in range(3):
                t1[i] = nc[i] - nrm[i]
            skew(t1, T1)
            for i in range(3):
                for j in range(3):
                    T2[i, j] -= T1[i, j]
            _mat3(T2, Jth, T3)
            for i in range(3):
                for j in range(3):
                    J[off + 3 + i, ia1 + j] += HL[i, j]
                    J[off + 3 + i, j] -= h * HL[i, j]
                    J[off + 3 + i, 3 + j] += T3[i, j]

        # maximum dissipation
        cross(wnew, r, t1)
        for i in range(3):
            vc[i] = vnew[i] + t1[i]
        vt = tt[0] * vc[0] + tt[1] * vc[1] + tt[2] * vc[2]
        vo = oo[0] * vc[0] + oo[1] * vc[1] + oo[2] * vc[2]
        vr = nrm[0] * wnew[0] + nrm[1] * wnew[1] + nrm[2] * wnew[2]
        F[off + 6] = mu * et * ln * vt + lt / et * sig
        F[off + 7] = mu * eo * ln * vo + lo / eo * sig
        F[off + 8] = mu * er * ln * vr + lr / er * sig
        if want_J:
            _friction_jac(J, off + 6, ilt, isg, iln, ia1, mu * et * ln, mu * et * vt, lt / et, sig / et, tt, wnew, r, h, t1, t2)
            _friction_jac(J, off + 7, ilo, isg, iln, ia1, mu * eo * ln, mu * eo * vo, lo / eo, sig / eo, oo, wnew, r, h, t1, t2)
            cf = mu * er * ln
            for j in range(3):
                J[off + 8, 3 + j] = cf * nrm[j]
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
        fbb[ils] = -(nrm[0] * a2[0] + nrm[1] * a2[1] + nrm[2] * a2[2])
        isfb[iln] = 1
        fbb[iln] = nrm[0] * a1[0] + nrm[1] * a1[1] + nrm[2] * a1[2]
        if want_J:
            for j in range(3):
                J[ils, ia2 + j] = -nrm[j]
                J[iln, ia1 + j] = nrm[j]
        off += B_FIXED + mk

    # ---- Fischer-Burmeister rows (row index == its complementarity variable) ---------
    theta = 0.0
    if want_J and mu_s == 0.0:
        for i in range(n):
            if isfb[i] == 1 and math.hypot(z[i], fbb[i]) < FB_DEGENERATE:
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
            val = fb(a, b)
            if want_J and isfb[i] == 1:
                rho = math.hypot(a, b)
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
