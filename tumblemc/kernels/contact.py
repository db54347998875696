"""Contact state of a step: step data, free flight and lift-off, impulse consistency, peel, adhering area."""

from __future__ import annotations

import math

from ._jit import jit
from .field import field_dir, program_field
from .geometry import QS_Q, cross, quat_step, quat_to_rot
from .guesses import LOW_TOL, landing_guess
from .layout import (
    B_A1,
    B_FIXED,
    B_L,
    B_LO,
    B_LR,
    B_LT,
    B_SIG,
    P_ADHC,
    P_EB,
    P_ELECT_FLIGHT,
    P_FELECT,
    P_FIELD_ON,
    P_FPROG,
    P_G,
    P_IB,
    P_LINE_STRIP,
    P_LINEFRAC,
    P_LINEW,
    P_MASS,
    P_N,
    P_O,
    P_PEEL_LEN,
    P_POSE_W0,
    P_T,
    P_TORQ,
    P_TORQUE_END,
    S_B0,
    S_B1,
    S_FEXT,
    S_H,
    S_TM,
    ST_OK,
)
from .newton import solve
from .residual import residual
from .support import (
    lowest_point,
)

CONTACT_L_TOL = 1e-6  # l_i above this fraction of sum(l) marks constraint i as touching
CONTACT_LN_TOL = 1e-9  # normal force (units of the weight) above which a piece touches
FLIGHT_MARGIN = 1e-9  # clearance (scaled length) above which a free-flight end pose is accepted
IMPULSE_ACCEPT_LEN = 1e-3  # geometric and complementarity rows of a step kept by impulse_consistent (scaled length)
IMPULSE_PASS_DEPTH = 1e-6  # a kept attempt's contact point this far below the plane (scaled length) must not move further in


@jit
def norm3(a):  # type: ignore[no-untyped-def]
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


@jit
def step_fields(prm, t, h, sc, tmp):  # type: ignore[no-untyped-def]
    """The field at both ends of the step, in torque units, into ``sc[S_B0:]`` and ``sc[S_B1:]``
    (the end-of-step torque's field and the ledger's field work); the paper's field leaves its
    unit direction at ``t`` in ``tmp`` (the start-of-step torque's, as it always was computed)."""
    if prm[P_FPROG] > 0.5:
        program_field(prm, t + h, sc[S_B1 : S_B1 + 3])
        program_field(prm, t, sc[S_B0 : S_B0 + 3])
        return
    field_dir(prm, t + h, tmp)
    for i in range(3):
        sc[S_B1 + i] = prm[P_TORQ] * tmp[i]
    field_dir(prm, t, tmp)
    for i in range(3):
        sc[S_B0 + i] = prm[P_TORQ] * tmp[i]


@jit
def prepare_step(state, t, h, prm, area_prev, touching_prev, scr):  # type: ignore[no-untyped-def]
    """Step data ``scr.sc`` for a step of length ``h`` from ``state`` at ``t``; returns the push along -n."""
    sc = scr.sc
    R = scr.R
    tmp = scr.tmp
    tmp2 = scr.tmp2
    for i in range(13):
        sc[i] = state[i]
    sc[S_H] = h
    m = prm[P_MASS]
    push = prm[P_ADHC] * area_prev
    if touching_prev or prm[P_ELECT_FLIGHT] > 0.5:
        push += prm[P_FELECT]
    for i in range(3):
        sc[S_FEXT + i] = -push * prm[P_N + i]
    sc[S_FEXT + 2] -= m * prm[P_G]
    if prm[P_FIELD_ON] < 0.5:
        for i in range(3):
            sc[S_TM + i] = 0.0
            sc[S_B0 + i] = 0.0
            sc[S_B1 + i] = 0.0
        return push
    step_fields(prm, t, h, sc, tmp2)  # leaves the paper field's unit direction at t in tmp2
    if prm[P_TORQUE_END] < 1.0:  # the torque at the start of the step: (R e_b) x B(t)
        quat_to_rot(state, 3, R, 0)
        if prm[P_FPROG] > 0.5:  # a field program (kernels/field.py): V_m |E| B(t) directly
            for i in range(3):
                tmp[i] = R[3 * i] * prm[P_EB] + R[3 * i + 1] * prm[P_EB + 1] + R[3 * i + 2] * prm[P_EB + 2]
            cross(tmp, 0, sc, S_B0, sc, S_TM)
        else:
            for i in range(3):
                acc = 0.0
                for j in range(3):
                    acc += R[3 * i + j] * prm[P_EB + j]
                tmp[i] = acc
            cross(tmp, 0, tmp2, 0, sc, S_TM)
            for i in range(3):
                sc[S_TM + i] *= prm[P_TORQ]
    return push


@jit
def plain_residual(z, prob, ws):  # type: ignore[no-untyped-def]
    """Max-norm of the model's (unsmoothed) residual at ``z``."""
    residual(z, prob, ws.Ft, ws.J, (ws.Ft_isfb, ws.fbb, ws.rs), False, 0.0)
    r = 0.0
    for i in range(z.shape[0]):
        r = max(r, abs(ws.Ft[i]))
    return r


@jit
def impulse_consistent(z, state, hc, prob, ws, tol_rel):  # type: ignore[no-untyped-def]
    """Whether ``z``, the best attempt of a (sub-)step that failed at every depth, solves the
    step up to ``tol_rel`` of its momenta and impulses (``opts[O_IMPULSE]``).

    Force rows times ``hc`` (an impulse) against ``m (|v| + |v+|) + hc (m g + L)``, torque
    rows against ``I_max (|w| + |w+|) + hc L rho`` (``L`` the sum of the contact forces'
    magnitudes, ``rho`` the largest lever ``|a1 - x|``, at least one length unit), the
    friction rows against ``(1 + L) (1 + |v+| + rho |w+|)``, the friction-cone row against
    ``(1 + L)^2`` plus ``IMPULSE_ACCEPT_LEN``; the geometric and complementarity rows (lengths and multipliers) within
    ``IMPULSE_ACCEPT_LEN``. A contact point that ends more than ``IMPULSE_PASS_DEPTH`` below
    the plane must not be moving further in (an attempt whose normal force does nothing
    balances the other rows while the contact passes through the plane, a step's travel a
    step: docs/notes/solver_gaps.md, section 13). Fills ``ws.Ft`` with the residual."""
    plain_residual(z, prob, ws)
    F = ws.Ft
    prm = prob.prm
    pstart = prob.pstart
    K = pstart.shape[0] - 1
    lam = 0.0
    rho = 1.0
    off = 6
    for kp in range(K):
        mk = pstart[kp + 1] - pstart[kp]
        lam += abs(z[off + B_L + mk + 1]) + abs(z[off + B_LT]) + abs(z[off + B_LO]) + abs(z[off + B_LR])
        d2 = 0.0
        for i in range(3):
            d = z[off + B_A1 + i] - state[i]
            d2 += d * d
        rho = max(rho, math.sqrt(d2))
        off += B_FIXED + mk
    m = prm[P_MASS]
    imax = max(prm[P_IB], prm[P_IB + 4], prm[P_IB + 8])
    vs = norm3(state[7:10]) + norm3(z[0:3])
    ws_ = norm3(state[10:13]) + norm3(z[3:6])
    pscale = m * vs + hc * (m * prm[P_G] + lam)
    lscale = imax * ws_ + hc * lam * rho
    for i in range(3):
        if not abs(F[i]) * hc <= tol_rel * pscale or not abs(F[3 + i]) * hc <= tol_rel * lscale:
            return False
    dscale = (1.0 + lam) * (1.0 + norm3(z[0:3]) + rho * norm3(z[3:6]))
    off = 6
    for kp in range(K):
        mk = pstart[kp + 1] - pstart[kp]
        for i in range(off, off + B_LT):  # a1 - a2 - l_s n, sum l_i N_i + n
            if not abs(F[i]) <= IMPULSE_ACCEPT_LEN:
                return False
        for i in range(off + B_LT, off + B_SIG):  # maximum dissipation
            if not abs(F[i]) <= tol_rel * dscale:
                return False
        if not abs(F[off + B_SIG]) <= tol_rel * (1.0 + lam) ** 2 + IMPULSE_ACCEPT_LEN:  # the cone
            return False
        for i in range(off + B_L, off + B_L + mk + 2):  # FB(l_i), FB(l_s), FB(lam_n)
            if not abs(F[i]) <= IMPULSE_ACCEPT_LEN:
                return False
        if passes_through(z, state, hc, prm, off + B_A1):
            return False
        off += B_FIXED + mk
    return True


@jit
def passes_through(z, state, hc, prm, ia1):  # type: ignore[no-untyped-def]
    """Whether the contact point ``z[ia1:ia1+3]`` ends more than ``IMPULSE_PASS_DEPTH`` below
    the plane and still moving into it (``v+ + w+ x (a1 - x+)`` along the normal, ``x+`` the
    end position): an attempt that has not landed."""
    gap = 0.0
    for i in range(3):
        gap += prm[P_N + i] * z[ia1 + i]
    if not gap < -IMPULSE_PASS_DEPTH:
        return False
    r0 = z[ia1] - (state[0] + hc * z[0])
    r1 = z[ia1 + 1] - (state[1] + hc * z[1])
    r2 = z[ia1 + 2] - (state[2] + hc * z[2])
    vn = (
        prm[P_N] * (z[0] + z[4] * r2 - z[5] * r1)
        + prm[P_N + 1] * (z[1] + z[5] * r0 - z[3] * r2)
        + prm[P_N + 2] * (z[2] + z[3] * r1 - z[4] * r0)
    )
    return vn < 0.0


@jit
def flight_clears(state, z6, hc, prm, geo, scr):  # type: ignore[no-untyped-def]
    """Whether the free-flight solution ``z6`` keeps every piece above the plane at the end
    of the step (then it is the exact solution of the step). ``scr.tmp3`` and ``scr.R``
    receive the end pose."""
    qs = scr.qs
    R = scr.R
    xend = scr.tmp3
    tmp = scr.tmp
    quat_step(state, 3, z6, 3, hc, qs, 0, state, 10, (1.0 - prm[P_POSE_W0]))
    quat_to_rot(qs, QS_Q, R, 0)
    for i in range(3):
        xend[i] = state[i] + hc * z6[i]
    for kp in range(geo.pstart.shape[0] - 1):
        if lowest_point(xend, R, prm, geo, kp, tmp, LOW_TOL, scr.hts) <= FLIGHT_MARGIN:
            return False
    return True


@jit
def set_flight(z, z6, hc, model, scr):  # type: ignore[no-untyped-def]
    """Write the free-flight solution into ``z``: velocities from ``z6``, contact blocks
    at their closest points with zero forces (a warm start for the next landing). The end
    pose is ``scr.tmp3``, ``scr.R`` (from :func:`flight_clears`)."""
    geo = model.geo
    for i in range(6):
        z[i] = z6[i]
    off = 6
    for kp in range(geo.pstart.shape[0] - 1):
        mk = geo.pstart[kp + 1] - geo.pstart[kp]
        landing_guess(z, off, kp, (scr.tmp3, z6[0:3], z6[3:6]), hc, model, scr, LOW_TOL, False)
        z[off + B_L + mk + 1] = 0.0
        z[off + B_SIG] = 0.0
        z[off + B_LT] = 0.0
        z[off + B_LO] = 0.0
        off += B_FIXED + mk


@jit
def lift_off(state, buf, hc, model, opts, max_turn, scr):  # type: ignore[no-untyped-def]
    """Free flight for a step whose explicit prediction penetrates: solve it from ``zsave``
    and, if it turns the body by at most ``max_turn`` (rad) and clears the plane, write it
    into ``z`` (it is then the exact solution of the step). Returns ``(code, residual)``:
    1 accepted, 0 the solve failed or the end pose does not clear, -1 it turns too far."""
    z = buf.z
    z6 = buf.z6
    zsave = buf.zsave
    prm = model.prm
    geo = model.geo
    for i in range(6):
        z6[i] = zsave[i]
    st6, res6 = solve(z6, scr.prob6, buf.ws6, opts, scr.iters, False, 0.0)
    if st6 != ST_OK:
        return 0, res6
    if norm3(z6[3:6]) * hc > max_turn:
        return -1, res6
    if not flight_clears(state, z6, hc, prm, geo, scr):
        return 0, res6
    for i in range(z.shape[0]):
        z[i] = zsave[i]
    set_flight(z, z6, hc, model, scr)
    return 1, res6


@jit
def peel_step(peel, left, area_old, area_new, h, z, prm):  # type: ignore[no-untyped-def]
    """Peeling of a released face (``adhesion_release = "peel"``): ``(peel, left)`` after a step.

    The paper's adhesion is a force that vanishes with the face. Peeling instead holds the
    released area's adhesion ``C x released`` on the body until it has done the work of
    adhesion ``C x peel_length`` per released area against it, counted as the force times
    the centre of mass's rise along ``n`` in the step (``h n . v+``): releasing a face
    costs that energy. A contact whose area grows again (the face lands back) ends the
    peel."""
    c = prm[P_ADHC]
    if peel > 0.0:
        rise = h * (prm[P_N] * z[0] + prm[P_N + 1] * z[1] + prm[P_N + 2] * z[2])
        if rise > 0.0:
            left -= c * peel * rise
        if left <= 0.0:
            peel = 0.0
            left = 0.0
    if area_new < area_old:
        peel += area_old - area_new
        left += c * prm[P_PEEL_LEN] * (area_old - area_new)
    elif area_new > area_old:
        peel = 0.0
        left = 0.0
    return peel, left


@jit
def line_area(prm, geo, nact, ca, cb, amin):  # type: ignore[no-untyped-def]
    """Adhering area of a line or point contact (MODEL.md, "Forces").

    Strip rule (``P_LINE_STRIP``): a strip of width ``w = P_LINEW`` along the touching
    segment, ``w x l``: one line constraint alone (a cylinder's line, a hull face bridging
    edges) touches along ``cllen``; two constraints meet in a straight edge of length
    ``cedge`` (0: a point or curved edge, or a hull face bridging edges); three or more, or
    an edge of length 0, are point contact, ``w^2``. The paper's rule (``face_fraction``):
    ``P_LINEFRAC`` x the smallest active face's area."""
    if prm[P_LINE_STRIP] < 0.5:
        return prm[P_LINEFRAC] * amin
    w = prm[P_LINEW]
    if nact == 1:
        return w * geo.cllen[ca]
    if nact == 2 and geo.cedge[ca, cb] > 0.0:
        return w * geo.cedge[ca, cb]
    return w * w


@jit
def contact_state(z, state, prm, geo, scr):  # type: ignore[no-untyped-def]
    """Contact mode, adhering area, total normal force, slip speed and ECP piece offset at
    the pose and velocities of ``state``."""
    tmp = scr.tmp
    tmp2 = scr.tmp2
    K = geo.pstart.shape[0] - 1
    off = 6
    mode = 0
    area = 0.0
    lnsum = 0.0
    slip = 0.0
    ecp_off = -1
    for kp in range(K):
        c0 = geo.pstart[kp]
        mk = geo.pstart[kp + 1] - c0
        ln = z[off + B_L + mk + 1]
        if ln > CONTACT_LN_TOL:
            lnsum += ln
            if ecp_off < 0:
                ecp_off = off
            ltot = 0.0
            for ic in range(mk):
                ltot += max(z[off + B_L + ic], 0.0)
            nact = 0
            amin = math.inf
            single_line = 0
            ca = -1
            cb = -1
            for ic in range(mk):
                if z[off + B_L + ic] > CONTACT_L_TOL * ltot:
                    nact += 1
                    amin = min(amin, geo.carea[c0 + ic])
                    single_line = geo.cline[c0 + ic]
                    if ca < 0:
                        ca = c0 + ic
                    else:
                        cb = c0 + ic
            if nact == 1 and single_line == 0:
                area += amin
                mode = 2
            elif nact >= 1:
                area += line_area(prm, geo, nact, ca, cb, amin)
                if mode == 0:
                    mode = 1
            for i in range(3):
                tmp[i] = z[off + B_A1 + i] - state[i]
            cross(state, 10, tmp, 0, tmp2, 0)
            vt = 0.0
            vo = 0.0
            for i in range(3):
                vt += prm[P_T + i] * (state[7 + i] + tmp2[i])
                vo += prm[P_O + i] * (state[7 + i] + tmp2[i])
            slip = max(slip, math.hypot(vt, vo))
        off += B_FIXED + mk
    return mode, area, lnsum, slip, ecp_off
