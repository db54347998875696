"""The strategy ladder of one (sub-)step and the guesses it starts Newton from.

A (sub-)step is solved from the warm start first, then from fresh guesses of the contact
(the touching feature may change within the step: a face slapping down, an edge passing
over, a vertex switching, which the warm start alone cannot follow). :data:`STRATEGIES` is
the ladder, cheapest first; each row is one attempt ``(guess, projected line search,
smoothing parameter)``; a smoothing parameter > 0 runs the smoothing continuation
(``newton.solve``). The zero-velocity and snap attempts come after every other one, so
steps that converge without them are unchanged.

The guesses (``G_*``; :func:`build_guess` writes them into ``z``):

=====================  =====================================================================
``G_WARM``             the warm start (extrapolated on smooth contact steps: ``substep``)
``G_FACE``             ECP in the middle of the lowest face within ``RESTART_TOL`` at the
                       predicted pose, keeping the forces of touching blocks
``G_VERTEX``           the lowest vertex (or exactly tied edge) with impact and
                       predicted-sliding forces
``G_FACE_IMPACT``      the face of ``G_FACE`` with those forces (a face slapping down while
                       sliding)
``G_SNAP_FLAT``        the angular velocity that lays the most nearly flat face exactly flat
                       at the end of the step, the ECP at the edge that lands, the impact
                       forces of ``G_VERTEX`` (a face landing within the step, where the warm
                       start keeps the ECP at the pivot edge and Newton stalls at a spurious
                       point with a negative multiplier of the other face; :func:`snap_flat`)
``G_FACE_REST``,       ``G_FACE``, ``G_VERTEX``, ``G_FACE_IMPACT`` with the velocities started
``G_VERTEX_REST``,     at zero instead of the pre-impact ones (a violent impact after flight:
``G_FACE_IMPACT_REST`` the smoothed Newton from the incoming velocity can stall where it
                       converges from rest); ``G_VERTEX_REST`` also plain, as the rescue pass's
                       own last attempt (a corner landing that stops a turn about the
                       normal, where the smoothing continuation from it stalls and plain
                       Newton converges)
``G_SNAP_EDGE``        the angular velocity that lays the nearly level lowest edge exactly
                       level, the ECP in its middle, impact forces: an edge whose second end
                       lands while the first rests on the plane, where the ECP must move
                       inside the edge (:func:`snap_edge`)
``G_POINT_IMPACT``     the rigid-body impact at the lowest feature: the impulse that stops the
                       contact point, sticking if it lies in the friction cone (else cut to
                       the cone), and the velocities it leaves; a fast frictional landing
                       where the impact reverses the slip (:func:`~.impacts.impact_guess`)
``G_LEVEL_EDGE``       the rigid-body impact of a level edge that sticks along its whole
                       length (no roll, no turn about n): the ECP inside the edge where the
                       impulses of its two ends balance (:func:`~.support.level_edge`)
``G_TWIST_IMPACT``     ``G_POINT_IMPACT`` that also sticks in torsion (the torsional force as an
                       unknown): a vertex landing while the robot turns fast about the normal
=====================  =====================================================================

docs/notes/solver_gaps.md tells the steps each late guess was found on.
"""

from __future__ import annotations

import math

from ._jit import jit
from .geometry import CG_G, QS_Q, constraint_eval, cross, quat_step, quat_to_rot
from .impacts import impact_guess
from .layout import (
    B_A1,
    B_A2,
    B_FIXED,
    B_L,
    B_LO,
    B_LR,
    B_LT,
    B_SIG,
    C_PLANE,
    P_MASS,
    P_MU,
    P_N,
    P_O,
    P_T,
    S_FEXT,
)
from .support import (
    level_edge,
    lowest_point,
    lowest_three,
    support_height,
)

LOW_TOL = 1e-3  # support points this close (scaled length) to the lowest count as touching
RESTART_TOL = 5e-2  # the same, for the fresh face guess after a failed warm-started solve
VERTEX_TOL = 1e-9  # the same, for the fresh vertex/edge guess (ties only)
FACE_TOL = 2e-1  # the same, for the fresh face guess with impact forces
SNAP_MAX_TILT = 0.05  # G_SNAP_FLAT only turns a face that is within this angle (rad) of flat


G_WARM = 0
G_FACE = 1
G_VERTEX = 2
G_FACE_IMPACT = 3
G_SNAP_FLAT = 4
G_FACE_REST = 5
G_VERTEX_REST = 6
G_FACE_IMPACT_REST = 7
G_SNAP_EDGE = 8
G_POINT_IMPACT = 9
G_LEVEL_EDGE = 10
G_TWIST_IMPACT = 11

#: the ladder: one attempt a row, ``(guess, projected, smoothing)``
STRATEGIES = (
    (G_WARM, False, 0.0),
    (G_WARM, True, 0.0),
    (G_FACE, False, 0.0),
    (G_FACE, True, 0.0),
    (G_VERTEX, False, 0.0),
    (G_FACE_IMPACT, False, 0.0),
    (G_FACE, False, 1e-2),
    (G_WARM, False, 1e-2),
    (G_VERTEX, False, 1e-2),
    (G_FACE_IMPACT, False, 1e-2),
    (G_WARM, False, 1e-1),
    (G_FACE_IMPACT, False, 1e-1),
    (G_FACE_REST, False, 1e-2),
    (G_VERTEX_REST, False, 1e-2),
    (G_FACE_IMPACT_REST, False, 1e-2),
    (G_FACE_REST, False, 1e-1),
    (G_FACE_IMPACT_REST, False, 1e-1),
    (G_SNAP_FLAT, False, 0.0),
    (G_SNAP_FLAT, True, 0.0),
    (G_SNAP_EDGE, False, 0.0),
    (G_SNAP_EDGE, True, 0.0),
    (G_POINT_IMPACT, False, 0.0),
    (G_POINT_IMPACT, False, 1e-2),
    (G_LEVEL_EDGE, False, 0.0),
    (G_TWIST_IMPACT, False, 0.0),
    # the rescue pass's own attempts (a failed step solved once more: ``substep.climb_ladder``)
    (G_VERTEX_REST, False, 0.0),
)
# the table's columns, as the compiled ladder indexes them
STRATEGY_GUESS = tuple(row[0] for row in STRATEGIES)
STRATEGY_PROJECT = tuple(row[1] for row in STRATEGIES)
STRATEGY_SMOOTH = tuple(row[2] for row in STRATEGIES)
N_ATTEMPTS = len(STRATEGIES)
#: the last rows of :data:`STRATEGIES` that only the rescue pass of a failed step tries, so
#: that every step the ladder solves, or keeps loose, stays as it was
N_RESCUE_ONLY = 1
#: guesses whose Newton may need the full iteration limit (the snaps and the impacts start
#: far from the warm start), indexed by guess
GUESS_FULL_MAXIT = (False, False, False, False, True, False, False, False, True, True, True, True)


@jit
def landing_guess(z, off, kp, motion, h, model, scr, tol, keep_forces):  # type: ignore[no-untyped-def]
    """Fresh guess of a contact block: ECP at the middle of the lowest feature, its normal
    cone multipliers, and (unless ``keep_forces``, used when the block was touching) the
    impact and predicted-sliding forces (MODEL.md numerical traps). ``motion`` is
    ``(x, v, w)`` (float64[3] each) with the pose's rotation in ``scr.R``."""
    x, v, w = motion
    prm = model.prm
    geo = model.geo
    sc = scr.sc
    R = scr.R
    tmp = scr.tmp
    tmp2 = scr.tmp2
    cg = scr.cg
    mk = geo.pstart[kp + 1] - geo.pstart[kp]
    a1 = z[off + B_A1 : off + B_A1 + 3]
    hgt = lowest_point(x, R, prm, geo, kp, a1, tol, scr.hts)
    gap = max(hgt, 0.0)
    for i in range(3):
        z[off + B_A2 + i] = a1[i] - gap * prm[P_N + i]
    z[off + B_L + mk] = gap
    # constraints through that point: l_i ~ max(0, -N_i . n), scaled so sum l_i N_i . n = -1
    c0 = geo.pstart[kp]
    for i in range(3):
        tmp[i] = 0.0
        for j in range(3):
            tmp[i] += R[3 * j + i] * (a1[j] - x[j])
    s = 0.0
    for ic in range(mk):
        f = constraint_eval(geo.ctype[c0 + ic], geo.cdata, c0 + ic, tmp, 0, cg, 0)
        dn = 0.0
        for i in range(3):
            ni = 0.0
            for j in range(3):
                ni += R[3 * i + j] * cg[CG_G + j]
            dn += ni * prm[P_N + i]
        li = max(0.0, -dn) if f > -1e-6 else 0.0
        z[off + B_L + ic] = li
        s += li * dn
    if s < 0.0:
        for ic in range(mk):
            z[off + B_L + ic] /= -s
    if keep_forces:
        return
    # an impact needs lam_n ~ m |v_n| / h plus the pressing load; slide at predicted values
    for i in range(3):
        tmp[i] = a1[i] - x[i]
    cross(w, 0, tmp, 0, tmp2, 0)
    vn = 0.0
    vt = 0.0
    vo = 0.0
    press = 0.0
    for i in range(3):
        vi = v[i] + tmp2[i]
        vn += prm[P_N + i] * vi
        vt += prm[P_T + i] * vi
        vo += prm[P_O + i] * vi
        press -= prm[P_N + i] * sc[S_FEXT + i]
    ln = prm[P_MASS] * max(0.0, -vn) / h + max(press, 0.0)
    z[off + B_L + mk + 1] = ln
    vs = math.hypot(vt, vo)
    mu = prm[P_MU]
    z[off + B_SIG] = vs
    z[off + B_LR] = 0.0
    if vs > 0.0:
        z[off + B_LT] = -mu * ln * vt / vs
        z[off + B_LO] = -mu * ln * vo / vs
    else:
        z[off + B_LT] = 0.0
        z[off + B_LO] = 0.0


@jit
def snap_flat(R, prm, geo, h, w, out):  # type: ignore[no-untyped-def]
    """Angular velocity for guess 4: ``w`` plus the rotation over ``h`` that turns the
    half-space face whose outward normal (at the end pose ``R`` predicted with ``w``) is
    closest to ``-n`` exactly onto ``-n``. Returns False (``out`` untouched) when no face
    is within ``SNAP_MAX_TILT`` of flat."""
    best = -2.0
    nw0 = 0.0
    nw1 = 0.0
    nw2 = 0.0
    for c in range(geo.ctype.shape[0]):
        if geo.ctype[c] != C_PLANE:
            continue
        # outward normal of face c in the world, and its alignment with -n
        m0 = 0.0
        m1 = 0.0
        m2 = 0.0
        for j in range(3):
            m0 += R[j] * geo.cdata[c, j]
            m1 += R[3 + j] * geo.cdata[c, j]
            m2 += R[6 + j] * geo.cdata[c, j]
        a = -m0 * prm[P_N] - m1 * prm[P_N + 1] - m2 * prm[P_N + 2]
        if a > best:
            best = a
            nw0 = m0
            nw1 = m1
            nw2 = m2
    # axis N_w x (-n), |.| = sin(tilt)
    n0 = -prm[P_N]
    n1 = -prm[P_N + 1]
    n2 = -prm[P_N + 2]
    a0 = nw1 * n2 - nw2 * n1
    a1 = nw2 * n0 - nw0 * n2
    a2 = nw0 * n1 - nw1 * n0
    sn = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    if best <= 0.0 or sn > math.sin(SNAP_MAX_TILT):
        return False
    c = math.asin(sn) / (h * sn) if sn > 0.0 else 0.0
    out[0] = w[0] + c * a0
    out[1] = w[1] + c * a1
    out[2] = w[2] + c * a2
    return True


@jit
def snap_edge(x, R, prm, geo, h, w, out):  # type: ignore[no-untyped-def]
    """Angular velocity for guess 8: ``w`` plus the rotation over ``h`` that turns the line
    through the two lowest support points (of the piece with the lowest one, at the pose
    ``x``, ``R`` predicted with ``w``) exactly parallel to the plane. Returns False
    (``out`` untouched) when that line is already level or tilts by more than
    ``SNAP_MAX_TILT``."""
    kbest = -1
    best = math.inf
    K = geo.pstart.shape[0] - 1
    for kp in range(K):
        for p in range(geo.sup_start[kp], geo.sup_start[kp + 1]):
            hgt = support_height(x, R, prm, geo, p)
            if hgt < best:
                best = hgt
                kbest = kp
    if kbest < 0:
        return False
    # the lowest and second-lowest distinct support points of that piece
    p0, p1, h0, h1, _ = lowest_three(x, R, prm, geo, kbest)
    if p1 < 0:
        return False
    e0 = 0.0
    e1 = 0.0
    e2 = 0.0
    for j in range(3):
        d = geo.sup_pts[p1, j] - geo.sup_pts[p0, j]
        e0 += R[j] * d
        e1 += R[3 + j] * d
        e2 += R[6 + j] * d
    el = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
    if el < 1e-9:
        return False
    e0 /= el
    e1 /= el
    e2 /= el
    en = e0 * prm[P_N] + e1 * prm[P_N + 1] + e2 * prm[P_N + 2]
    q0 = e0 - en * prm[P_N]
    q1 = e1 - en * prm[P_N + 1]
    q2 = e2 - en * prm[P_N + 2]
    ql = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2)
    if ql < 1e-12:
        return False
    q0 /= ql
    q1 /= ql
    q2 /= ql
    # axis e x (its projection onto the plane), |.| = sin(tilt)
    a0 = e1 * q2 - e2 * q1
    a1 = e2 * q0 - e0 * q2
    a2 = e0 * q1 - e1 * q0
    sn = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    if sn == 0.0 or sn > math.sin(SNAP_MAX_TILT):
        return False
    c = math.asin(sn) / (h * sn)
    out[0] = w[0] + c * a0
    out[1] = w[1] + c * a1
    out[2] = w[2] + c * a2
    return True


@jit
def build_guess(guess, z, zsave, state, hc, model, scr, touching, edir):  # type: ignore[no-untyped-def]  # noqa: C901
    """Write the fresh guess ``guess`` (not ``G_WARM``) into ``z``, starting from the step's
    warm start ``zsave``, at the pose predicted from ``state`` over ``hc``. Returns False
    where the guess does not apply (no nearly flat face, no level edge, no impact): the
    attempt is skipped. ``touching`` (int64[K]) marks the blocks whose forces ``G_FACE``
    keeps; ``edir`` (3) receives ``G_LEVEL_EDGE``'s edge direction."""
    prm = model.prm
    geo = model.geo
    R = scr.R
    tmp = scr.tmp
    tmp3 = scr.tmp3
    qs = scr.qs
    hts = scr.hts
    K = geo.pstart.shape[0] - 1
    for i in range(z.shape[0]):
        z[i] = zsave[i]
    if guess == G_POINT_IMPACT or guess == G_TWIST_IMPACT:
        quat_step(state, 3, state, 10, hc, qs, 0, state, 10, 1.0)
        quat_to_rot(qs, QS_Q, R, 0)
        for i in range(3):
            tmp3[i] = state[i] + hc * state[7 + i]
        off = 6
        kl = -1
        ml = 0
        low = math.inf
        for kp in range(K):
            mk = geo.pstart[kp + 1] - geo.pstart[kp]
            landing_guess(z, off, kp, (tmp3, state[7:10], state[10:13]), hc, model, scr, VERTEX_TOL, False)
            hk = lowest_point(tmp3, R, prm, geo, kp, tmp, VERTEX_TOL, hts)
            if hk < low:
                low = hk
                kl = off
                ml = mk
            off += B_FIXED + mk
        return impact_guess(z, kl, ml, state, hc, model, scr, edir, 0.0 if guess == G_POINT_IMPACT else -1.0)
    if guess == G_LEVEL_EDGE:
        # the level edge at the start pose, sticking at once
        quat_to_rot(state, 3, R, 0)
        off = 6
        kl = -1
        ml = 0
        kpl = 0
        low = math.inf
        for kp in range(K):
            mk = geo.pstart[kp + 1] - geo.pstart[kp]
            landing_guess(z, off, kp, (state[0:3], state[7:10], state[10:13]), hc, model, scr, LOW_TOL, False)
            hk = lowest_point(state[0:3], R, prm, geo, kp, tmp, LOW_TOL, hts)
            if hk < low:
                low = hk
                kl = off
                ml = mk
                kpl = kp
            off += B_FIXED + mk
        half = level_edge(state[0:3], R, prm, geo, kpl, LOW_TOL, edir)
        if half == 0.0:
            return False
        return impact_guess(z, kl, ml, state, hc, model, scr, edir, half)
    if guess == G_SNAP_EDGE:
        # the nearly level edge laid level: pre-impact v, snapped w, the ECP in the middle
        # of the edge at the snapped pose
        quat_step(state, 3, state, 10, hc, qs, 0, state, 10, 1.0)
        quat_to_rot(qs, QS_Q, R, 0)
        for i in range(3):
            tmp3[i] = state[i] + hc * state[7 + i]
        if not snap_edge(tmp3, R, prm, geo, hc, state[10:13], tmp):
            return False
        for i in range(3):
            z[i] = state[7 + i]
            z[3 + i] = tmp[i]
        quat_step(state, 3, z, 3, hc, qs, 0, state, 10, 1.0)  # a guess: the paper's pose update
        quat_to_rot(qs, QS_Q, R, 0)
        off = 6
        for kp in range(K):
            mk = geo.pstart[kp + 1] - geo.pstart[kp]
            landing_guess(z, off, kp, (tmp3, state[7:10], state[10:13]), hc, model, scr, LOW_TOL, False)
            off += B_FIXED + mk
        return True
    if guess == G_FACE_REST or guess == G_VERTEX_REST or guess == G_FACE_IMPACT_REST:
        guess -= G_FACE_REST - G_FACE  # the same guess, from rest
        for i in range(6):
            z[i] = 0.0
    quat_step(state, 3, state, 10, hc, qs, 0, state, 10, 1.0)
    quat_to_rot(qs, QS_Q, R, 0)
    if guess == G_SNAP_FLAT:
        # the nearly flat face laid flat: pre-impact v, snapped w; the ECP at the lowest
        # vertex or edge of the pose predicted without the snap, the edge that lands
        if not snap_flat(R, prm, geo, hc, state[10:13], tmp):
            return False
        for i in range(3):
            z[i] = state[7 + i]
            z[3 + i] = tmp[i]
    for i in range(3):
        tmp3[i] = state[i] + hc * state[7 + i]
    off = 6
    for kp in range(K):
        mk = geo.pstart[kp + 1] - geo.pstart[kp]
        tolg = VERTEX_TOL if guess == G_VERTEX or guess == G_SNAP_FLAT else (RESTART_TOL if guess == G_FACE else FACE_TOL)
        w_guess = z[3:6] if guess == G_SNAP_FLAT else state[10:13]
        landing_guess(z, off, kp, (tmp3, state[7:10], w_guess), hc, model, scr, tolg, guess == G_FACE and touching[kp] == 1)
        off += B_FIXED + mk
    return True
