"""Energy ledger of one run (MODEL.md, "Energy ledger").

Per committed (sub-)step, with the end-of-step velocities ``V+ = (v+, w+)`` and the step's
impulses, :func:`ledger_step` adds to the cumulative array ``led`` (columns ``L_*``):

- the work of the magnetic torque ``h T_m . w+`` (``T_m`` as the step used it: at the start
  of the step, or at the end pose for ``torque="end"``), of gravity, of the electrostatic
  force and of the adhesion (each its impulse ``. v+``), of the normal contact impulse
  ``h p_n n . v_c+`` and of friction ``h (p_t t + p_o o) . v_c+ + h p_r n . w+``, with
  ``v_c+ = v+ + w+ x (a1 - x+)`` the end-of-step velocity of the contact point ``a1``, the
  lever arm of the residual's Newton-Euler rows;
- backward Euler's dissipation ``1/2 dV . M dV`` (``M`` at the start pose): with the
  Newton-Euler rows satisfied and the momentum-form rotation row, kinetic energy changes by
  exactly the work minus this, up to the pose update's change of the world inertia
  (``-1/2 w+ . (I+ - I) w+``, zero in planar tumbling);
- the step's balance ``b = dKE + 1/2 dV . M dV - W`` (``W`` the work of every force): the
  energy that no force did, which only the rotation row's explicit gyroscopic term (the
  paper's form), the pose update, or an unconverged solve kept as the step's answer make;
- the numerical energy gain ``max(b + max(W_n, 0), 0)``: the balance plus any positive
  work of the normal impulse (a rigid contact cannot push; the position-level contact
  pushing the body out, or an unconverged impulse, does), counted per step so that
  dissipation elsewhere cannot hide it;
- the magnetic energy ``U = -m . B`` (``m = R e_b`` in torque units) at both ends of the
  step, its change split symmetrically into the field's own work
  ``-1/2 (m + m+) . (B+ - B)`` (the energy the field supplies, ``L_WFIELD``) and the
  rotation's exchange ``1/2 (m+ - m) . (B + B+)`` (what the torque's work approximates,
  ``L_WMAGX``);
- the energy excess ``b - 1/2 dV.M dV + (W_mag - exchange)``: the mechanical energy
  (kinetic, magnetic, potential) gained beyond the field's work and every non-conservative
  force's, cumulative (``L_EXCESS``) with its running maximum (``L_XGAIN``): the torque's
  time discretisation, which the first account books as field work, shows here.

With the midpoint rule (``prm[P_POSE_W0] = 1/2``: the pose turned by the mean of ``w`` and
``w+``) the rotation's works use that velocity, ``w_theta``, and its dissipation is
``(theta - 1/2) dw . I dw`` (none at the midpoint, backward Euler's at ``theta = 1``).

Units are the kernels' (energy in ``m g x 1e-4 m``).
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import jit
from .geometry import QS_Q, cross, quat_to_rot
from .layout import (
    B_A1,
    B_FIXED,
    B_L,
    B_LO,
    B_LR,
    B_LT,
    L_BAL,
    L_DISS,
    L_EXCESS,
    L_GAIN,
    L_KE,
    L_MAGMAX,
    L_POTMAX,
    L_WADH,
    L_WELECT,
    L_WFIELD,
    L_WFRIC,
    L_WGRAV,
    L_WMAG,
    L_WMAGX,
    L_WN,
    L_XGAIN,
    P_ADHC,
    P_EB,
    P_ELECT_FLIGHT,
    P_FELECT,
    P_G,
    P_IB,
    P_MASS,
    P_N,
    P_O,
    P_POSE_W0,
    P_T,
    P_TORQUE_END,
    S_B0,
    S_B1,
    S_TM,
)

N_LW = 15  # ledger scratch: R (9), a 3-vector and the rotation's velocity w_theta (3)


@jit
def _ke_rot(R, Ib, w):  # type: ignore[no-untyped-def]
    """``1/2 w . (R Ib R^T) w`` for ``R`` row-major (9) and ``Ib`` at ``prm[P_IB:]``."""
    b0 = R[0] * w[0] + R[3] * w[1] + R[6] * w[2]
    b1 = R[1] * w[0] + R[4] * w[1] + R[7] * w[2]
    b2 = R[2] * w[0] + R[5] * w[1] + R[8] * w[2]
    acc = 0.0
    acc += b0 * (Ib[P_IB + 0] * b0 + Ib[P_IB + 1] * b1 + Ib[P_IB + 2] * b2)
    acc += b1 * (Ib[P_IB + 3] * b0 + Ib[P_IB + 4] * b1 + Ib[P_IB + 5] * b2)
    acc += b2 * (Ib[P_IB + 6] * b0 + Ib[P_IB + 7] * b1 + Ib[P_IB + 8] * b2)
    return 0.5 * acc


@jit
def kinetic_energy(state, prm, lw):  # type: ignore[no-untyped-def]
    """Kinetic energy of ``state`` (``x, Q, v, w``)."""
    quat_to_rot(state, 3, lw, 0)
    v2 = state[7] * state[7] + state[8] * state[8] + state[9] * state[9]
    return 0.5 * prm[P_MASS] * v2 + _ke_rot(lw, prm, state[10:13])


@jit
def ledger_step(state, z, hc, qs, flight, touching_prev, area_prev, prm, pstart, sc, lw, ls):  # type: ignore[no-untyped-def]
    """The ledger terms of one (sub-)step of length ``hc`` into ``ls`` (columns ``L_*``).

    :func:`ledger_add` adds them to the run's ledger once the step is committed; the stepper
    reads ``ls[L_WN]`` first (a landing whose normal impulse does positive work is re-solved
    in sub-steps, ``O_NWORK``).

    ``state`` is the start-of-step state (``x, Q, v, w``), ``z`` the step's solution,
    ``qs`` the :func:`~.geometry.quat_step` block of the end pose (``Q+`` at ``QS_Q``),
    ``flight`` whether the step was solved without contact (its contact blocks carry no
    forces), ``touching_prev`` and ``area_prev`` the contact of the previous step (which set
    this step's electrostatic and adhesion impulses, as in :func:`~.stepper._prepare`),
    ``sc`` the step data, ``lw`` scratch (``N_LW``).
    """
    m = prm[P_MASS]
    # kinetic energy and dissipation at the start pose
    quat_to_rot(state, 3, lw, 0)
    dv2 = 0.0
    v02 = 0.0
    for i in range(3):
        d = z[i] - state[7 + i]
        dv2 += d * d
        v02 += state[7 + i] * state[7 + i]
        lw[9 + i] = z[3 + i] - state[10 + i]
    # the rotation's velocity as the pose update used it, w_theta = theta w+ + (1 - theta) w
    # (geometry.quat_step), at lw[12:15]; its dissipation (theta - 1/2) dw . I dw (backward
    # Euler's 1/2 dw . I dw at theta = 1, none at the midpoint)
    theta = 1.0 - prm[P_POSE_W0]
    if theta == 1.0:
        diss = 0.5 * m * dv2 + _ke_rot(lw, prm, lw[9:12])
        for i in range(3):
            lw[12 + i] = z[3 + i]
    else:
        diss = 0.5 * m * dv2 + (2.0 * theta - 1.0) * _ke_rot(lw, prm, lw[9:12])
        for i in range(3):
            lw[12 + i] = theta * z[3 + i] + (1.0 - theta) * state[10 + i]
    ke0 = 0.5 * m * v02 + _ke_rot(lw, prm, state[10:13])
    # the magnet's direction times the field at both ends of the step: start pose (a0*) ...
    a00, a01 = _mb(lw, prm, sc)
    # applied forces (impulse . v+)
    nv = prm[P_N] * z[0] + prm[P_N + 1] * z[1] + prm[P_N + 2] * z[2]
    w_grav = -hc * m * prm[P_G] * z[2]
    w_elect = 0.0
    if touching_prev or prm[P_ELECT_FLIGHT] > 0.5:
        w_elect = -hc * prm[P_FELECT] * nv
    w_adh = -hc * prm[P_ADHC] * area_prev * nv
    # end pose: R+ into lw[0:9]
    quat_to_rot(qs, QS_Q, lw, 0)
    a10, a11 = _mb(lw, prm, sc)  # ... and end pose (a1*)
    wend = prm[P_TORQUE_END]  # the torque as the step used it (residual.py)
    if wend > 0.0:
        for i in range(3):
            lw[9 + i] = lw[3 * i] * prm[P_EB] + lw[3 * i + 1] * prm[P_EB + 1] + lw[3 * i + 2] * prm[P_EB + 2]
        t0 = lw[10] * sc[S_B1 + 2] - lw[11] * sc[S_B1 + 1]
        t1 = lw[11] * sc[S_B1] - lw[9] * sc[S_B1 + 2]
        t2 = lw[9] * sc[S_B1 + 1] - lw[10] * sc[S_B1]
        if wend < 1.0:
            t0 = wend * t0 + (1.0 - wend) * sc[S_TM]
            t1 = wend * t1 + (1.0 - wend) * sc[S_TM + 1]
            t2 = wend * t2 + (1.0 - wend) * sc[S_TM + 2]
    else:
        t0 = sc[S_TM]
        t1 = sc[S_TM + 1]
        t2 = sc[S_TM + 2]
    w_mag = hc * (t0 * lw[12] + t1 * lw[13] + t2 * lw[14])
    v12 = z[0] * z[0] + z[1] * z[1] + z[2] * z[2]
    ke1 = 0.5 * m * v12 + _ke_rot(lw, prm, z[3:6])
    # contact impulses at a1, lever r = a1 - x+ (x+ = x + hc v+)
    w_n = 0.0
    w_f = 0.0
    if not flight:
        off = 6
        for kp in range(pstart.shape[0] - 1):
            mk = pstart[kp + 1] - pstart[kp]
            ln = z[off + B_L + mk + 1]
            lt = z[off + B_LT]
            lo = z[off + B_LO]
            lr = z[off + B_LR]
            for i in range(3):
                lw[9 + i] = z[off + B_A1 + i] - state[i] - hc * z[i]
            # v_c = v+ + w_theta x r, written into lw[0:3] (R+ is no longer needed)
            cross(lw, 12, lw, 9, lw, 0)
            vn = 0.0
            vt = 0.0
            vo = 0.0
            wn = 0.0
            for i in range(3):
                vc = z[i] + lw[i]
                vn += prm[P_N + i] * vc
                vt += prm[P_T + i] * vc
                vo += prm[P_O + i] * vc
                wn += prm[P_N + i] * lw[12 + i]
            w_n += hc * ln * vn
            w_f += hc * (lt * vt + lo * vo + lr * wn)
            off += B_FIXED + mk
    work = w_mag + w_grav + w_elect + w_adh + w_n + w_f
    bal = ke1 - ke0 + diss - work
    ls[L_WMAG] = w_mag
    ls[L_WGRAV] = w_grav
    ls[L_WELECT] = w_elect
    ls[L_WADH] = w_adh
    ls[L_WN] = w_n
    ls[L_WFRIC] = w_f
    ls[L_DISS] = diss
    ls[L_BAL] = bal
    ls[L_GAIN] = max(bal + max(w_n, 0.0), 0.0)
    if not math.isfinite(bal):
        ls[L_GAIN] = np.inf
    ls[L_KE] = ke1
    # magnetic energy U = -m . B: its change over the step split symmetrically into the
    # field's own variation (the energy the field supplies) and the rotation's (the energy
    # the magnet exchanges with the body, which the torque's work h T . w+ approximates)
    ls[L_WFIELD] = -0.5 * ((a01 - a00) + (a11 - a10))
    # the rotation's exact exchange, -dU_rot; w_mag minus it is the torque's discretisation
    ls[L_WMAGX] = 0.5 * ((a10 - a00) + (a11 - a01))
    # the energy (kinetic, magnetic, potential) gained beyond the field's work and the
    # work of every non-conservative force: bal - diss + (w_mag + dU_rot)
    ls[L_EXCESS] = bal - diss + (w_mag - ls[L_WMAGX])


@jit
def _mb(R, prm, sc):  # type: ignore[no-untyped-def]
    """``(R e_b) . B(t)`` and ``(R e_b) . B(t + h)`` for ``R`` row-major (9), the fields at ``sc[S_B0:]``, ``sc[S_B1:]``."""
    d0 = 0.0
    d1 = 0.0
    for i in range(3):
        mi = R[3 * i] * prm[P_EB] + R[3 * i + 1] * prm[P_EB + 1] + R[3 * i + 2] * prm[P_EB + 2]
        d0 += mi * sc[S_B0 + i]
        d1 += mi * sc[S_B1 + i]
    return d0, d1


@jit
def ledger_add(led, ls):  # type: ignore[no-untyped-def]
    """Add a committed step's terms ``ls`` (:func:`ledger_step`) to the run's ledger ``led``."""
    for k in (L_WMAG, L_WGRAV, L_WELECT, L_WADH, L_WN, L_WFRIC, L_DISS, L_BAL):
        led[k] += ls[k]
    led[L_GAIN] += ls[L_GAIN]
    if ls[L_GAIN] == np.inf:
        led[L_GAIN] = np.inf
    led[L_KE] = ls[L_KE]
    led[L_POTMAX] = max(led[L_POTMAX], led[L_WGRAV] + led[L_WELECT])
    led[L_WFIELD] += ls[L_WFIELD]
    led[L_EXCESS] += ls[L_EXCESS]
    led[L_XGAIN] = max(led[L_XGAIN], led[L_EXCESS])
    if not math.isfinite(ls[L_EXCESS]):
        led[L_XGAIN] = np.inf
    led[L_WMAGX] += ls[L_WMAGX]
    led[L_MAGMAX] = max(led[L_MAGMAX], led[L_WMAGX])


__all__ = ["N_LW", "kinetic_energy", "ledger_add", "ledger_step"]
