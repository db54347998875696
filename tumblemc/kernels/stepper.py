"""Time loop: field, applied forces, warm starts, free flight, sub-steps, contact modes.

One call of :func:`run` integrates one robot for ``n_steps`` steps of length ``h`` (scaled
units) and writes ``rec`` rows every ``record_every`` steps (columns ``R_*``).
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ._jit import jit, jit_alloc
from .decide import DECIDE_EVERY, climb_bound
from .field import field_dir, field_work_bound, program_field
from .geometry import CG_G, N_CG, N_QS, QS_Q, Geometry, constraint_eval, cross, quat_step, quat_to_rot
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
    L_KE,
    L_WN,
    N_LED,
    N_REC,
    N_SC,
    O_ACCEPT,
    O_DECIDE,
    O_DECIDE_NEED,
    O_DECIDE_STEP,
    O_IMPULSE,
    O_MAXDEPTH,
    O_MAXFAIL,
    O_MAXIT,
    O_NWORK,
    O_REFINE_HALVE,
    O_RESCUE,
    O_SMOOTH_STALLED,
    O_STALL,
    O_WARM,
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
    P_MU,
    P_N,
    P_O,
    P_PEEL,
    P_PEEL_LEN,
    P_T,
    P_TORQ,
    P_TORQUE_END,
    P_U,
    R_ADH,
    R_AREA,
    R_ECP,
    R_FAIL,
    R_FALLBACK,
    R_IMPULSE,
    R_LED,
    R_LN,
    R_LOOSE,
    R_MODE,
    R_NIT,
    R_PEN,
    R_Q,
    R_RES,
    R_SLIP,
    R_SUB,
    R_T,
    R_V,
    R_W,
    R_X,
    S_BEND,
    S_FEXT,
    S_H,
    S_TM,
    ST_DECIDED,
    ST_NAN,
    ST_OK,
    ST_STOPPED,
)
from .ledger import N_LW, kinetic_energy, ledger_add, ledger_step
from .newton import Workspace, make_workspace, solve
from .residual import Problem, residual

Model = namedtuple("Model", ["prm", "geo"])
Model.__doc__ = """One robot on one substrate: its run constants ``prm`` (float64[N_PRM], ``P_*``) and
its :class:`Geometry`."""

Start = namedtuple("Start", ["state", "t0", "area0", "touch0"])
Start.__doc__ = """Where a run starts: ``state`` float64[13] (``x (3), Q (4), v (3), w (3)``, scaled;
updated in place), the time ``t0``, the adhering area ``area0`` and whether it touches
(``touch0``): the robot starts lying on a face, so the first step already feels that face's
adhesion."""

Clock = namedtuple("Clock", ["h", "n_steps", "record_every"])
Clock.__doc__ = """The time grid of a run: step length ``h`` (scaled), ``n_steps``, and a record row
every ``record_every`` steps."""

Buffers = namedtuple("Buffers", ["ws", "ws6", "z", "z6", "zsave"])
Buffers.__doc__ = """A run's solver memory, reusable across runs: the workspaces of the full system and
of the 6-unknown free-flight system (:class:`~.newton.Workspace`) and the unknowns ``z``
(warm start in, last solution out), ``z6`` and ``zsave`` (float64[n], [6], [n]). Build with
:func:`make_buffers`."""

Scratch = namedtuple("Scratch", ["sc", "R", "tmp", "tmp2", "tmp3", "cg", "qs", "iters", "prob", "prob6", "hts"])
Scratch.__doc__ = """The time loop's small temporaries, allocated once per run: step data ``sc`` (N_SC),
the rotation ``R`` (9, row-major), three 3-vectors, the blocks of ``constraint_eval`` (N_CG)
and ``quat_step`` (N_QS), the solver's iteration counters ``iters`` (int64[3]), the two
systems a step solves (:class:`~.residual.Problem`, sharing ``sc``): with contact (``prob``)
and in free flight (``prob6``), and the support points' heights ``hts`` (float64, at least
the most support points of a piece; :func:`lowest_point`)."""

CONTACT_L_TOL = 1e-6  # l_i above this fraction of sum(l) marks constraint i as touching
CONTACT_LN_TOL = 1e-9  # normal force (units of the weight) above which a piece touches
LOW_TOL = 1e-3  # support points this close (scaled length) to the lowest count as touching
RESTART_TOL = 5e-2  # the same, for the fresh face guess after a failed warm-started solve
VERTEX_TOL = 1e-9  # the same, for the fresh vertex/edge guess (ties only)
FACE_TOL = 2e-1  # the same, for the fresh face guess with impact forces
# Deterministic solve strategies of one (sub-)step, cheapest first. Guess 0: the warm
# start; 1: a fresh contact guess at the predicted pose (ECP in the middle of the lowest
# face within RESTART_TOL) keeping the forces of touching blocks; 2: a fresh guess at the
# lowest vertex (or exactly tied edge) with impact and predicted-sliding forces; 3: the
# face of guess 1 with those forces (a face slapping down while sliding); 5, 6, 7: guesses
# 1, 2, 3 with the velocities started at zero instead of the pre-impact ones (a violent
# impact after flight: the smoothed Newton from the incoming velocity can stall where it
# converges from rest). Guess 4: the angular velocity that lays the most nearly flat face
# exactly flat at the end of the step, with the ECP at the lowest vertex or edge of the
# pose predicted without it (the edge that lands) and the impact forces of guess 2: a face
# landing within the step, where the warm start keeps the ECP at the edge the robot pivots
# about and Newton stalls at a spurious point with a negative multiplier of the other face
# (found on short steps; see _snap_flat). Guess 8: the angular velocity that lays the
# nearly level lowest edge exactly level at the end of the step, with the ECP in its middle
# and impact forces: an edge whose second end lands while the first rests on the plane,
# where the single ECP of a piece must move inside the edge and an impact must stop the roll
# within the step (every other guess keeps the ECP at one end and Newton stalls; found on
# 3-D runs, docs/solver_gaps.md; see _snap_edge). Guess 9: the rigid-body impact at the
# lowest feature (guess 2's ECP): the impulse that stops the contact point, sticking if it
# lies in the friction cone (else cut to the cone), and the velocities it leaves; a fast
# frictional landing where the impact reverses the slip, so that every sliding guess pushes
# friction the wrong way and Newton stalls with sigma < 0 (see _impact_guess). Guess 10: the
# rigid-body impact of a level edge that sticks along its whole length (no roll, no turn about
# n): an edge lying level on the plane at the start of the step while the robot rolls one end
# into it, whose solution has the ECP inside the edge where the impulses of its two ends
# balance; every point guess puts it at an end or in the middle and Newton stalls (found on a
# 3-D run, docs/solver_gaps.md; see _level_edge and _impact_guess). Guess 11: guess 9's point
# impact that also sticks in torsion (no turn about n, the torsional force as an unknown): a
# vertex landing while the robot turns fast about the normal, where the torsional friction
# (e_r = 0.1 m, MODEL.md) stops the turn within the step and guess 9, which leaves the turn,
# starts Newton too far away (found on a 3-D run, docs/solver_gaps.md). Then plain, projected
# or smoothed Newton.
# The zero-velocity and snap attempts come after every other one, so steps that converge
# without them are unchanged.
STRATEGY_GUESS = (0, 0, 1, 1, 2, 3, 1, 0, 2, 3, 0, 3, 5, 6, 7, 5, 7, 4, 4, 8, 8, 9, 9, 10, 11)
STRATEGY_PROJECT = (False, True, False, True, False, False, False, False, False, False, False, False, False, False, False, False, False, False, True, False, True, False, False, False, False)  # noqa: E501  # fmt: skip
STRATEGY_SMOOTH = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1e-2, 1e-2, 1e-2, 1e-2, 1e-1, 1e-1, 1e-2, 1e-2, 1e-2, 1e-1, 1e-1, 0.0, 0.0, 0.0, 0.0, 0.0, 1e-2, 0.0, 0.0)  # noqa: E501  # fmt: skip
SNAP_MAX_TILT = 0.05  # guess 4 only turns a face that is within this angle (rad) of flat
N_ATTEMPTS = len(STRATEGY_GUESS)
FLIGHT_BEFORE = 6  # a step whose explicit prediction penetrates tries free flight before this attempt
EARLY_FLIGHT_TURN = 0.05  # ... when the body turns by at most this angle (rad) in the step
FAST_MAXIT = 15  # iteration limit of the plain and projected strategies
SMOOTH_MAXIT = 300  # iteration limit of the smoothing continuation
FLIGHT_MARGIN = 1e-9  # clearance (scaled length) above which a free-flight end pose is accepted
RECENTRE_AT = 100.0  # distance (scaled length, 1 cm) from the origin along t or o beyond which _recentre shifts it
FLIGHT_PRECHECK = 1e-6  # an explicit prediction this deep (scaled length) below the plane skips the flight solve
IMPULSE_ACCEPT_LEN = 1e-3  # geometric and complementarity rows of a step kept by _impulse_consistent (scaled length)


@jit
def _norm3(a):  # type: ignore[no-untyped-def]
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


@jit
def _prepare(state, t, h, prm, area_prev, touching_prev, scr):  # type: ignore[no-untyped-def]
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
            sc[S_BEND + i] = 0.0
    elif prm[P_FPROG] > 0.5:  # a field program (kernels/field.py): V_m |E| B(t) directly
        if prm[P_TORQUE_END] > 0.5:
            program_field(prm, t + h, sc[S_BEND : S_BEND + 3])
        else:
            quat_to_rot(state, 3, R, 0)
            for i in range(3):
                tmp[i] = R[3 * i] * prm[P_EB] + R[3 * i + 1] * prm[P_EB + 1] + R[3 * i + 2] * prm[P_EB + 2]
            program_field(prm, t, tmp2)
            cross(tmp, 0, tmp2, 0, sc, S_TM)
    elif prm[P_TORQUE_END] > 0.5:  # the residual forms (R+ e_b) x B(t + h) itself
        field_dir(prm, t + h, tmp2)
        for i in range(3):
            sc[S_BEND + i] = prm[P_TORQ] * tmp2[i]
    else:  # torque at the start of the step: (R e_b) x B(t)
        quat_to_rot(state, 3, R, 0)
        for i in range(3):
            acc = 0.0
            for j in range(3):
                acc += R[3 * i + j] * prm[P_EB + j]
            tmp[i] = acc
        field_dir(prm, t, tmp2)
        cross(tmp, 0, tmp2, 0, sc, S_TM)
        for i in range(3):
            sc[S_TM + i] *= prm[P_TORQ]
    return push


@jit
def _touching_centroid(x, R, geo, s0, s1, hts, cut, out):  # type: ignore[no-untyped-def]
    """``out`` = the centroid (world) of support points ``s0 .. s1 - 1`` whose height in
    ``hts`` is at most ``cut`` (:func:`lowest_point`, :func:`_lowest_many`)."""
    for i in range(3):
        out[i] = 0.0
    cnt = 0
    for p in range(s0, s1):
        if hts[p - s0] <= cut:
            cnt += 1
            for i in range(3):
                wi = x[i]
                for j in range(3):
                    wi += R[3 * i + j] * geo.sup_pts[p, j]
                out[i] += wi
    for i in range(3):
        out[i] /= cnt


#: pieces with more support points than this take :func:`_lowest_many` (the curved robot's
#: 226; the others have 8 to 16)
FAST_HEIGHT_POINTS = 32
#: relative margin of :func:`_lowest_many`'s screening heights (see there)
FAST_HEIGHT_REL = 1e-12


@jit
def _lowest_many(x, R, prm, geo, kp, out, tol, hts):  # type: ignore[no-untyped-def]
    """:func:`lowest_point` for a piece of many support points, bit for bit, at about a
    quarter of the arithmetic: a screening pass computes ``(R^T n) . p`` (three products
    per point instead of twelve), and only the points that can be within ``tol`` of the
    lowest get ``lowest_point``'s height, in its order of operations.

    The screening height plus ``n . x`` and ``lowest_point``'s height are ``n . (x + R p)``
    computed in two orders, each within about 20 ulps of ``|x|_1 + |p|_1`` of it
    (``|n_i|, |R_ij| <= 1``); ``mg``, 1e-12 of that sum plus 1, bounds their difference
    with a factor of over a hundred to spare. A point screened at more than ``tol + 2 mg``
    above the lowest screened one is then more than ``tol`` above the lowest point, and
    the lowest point is among those kept: the minimum, the touching set and the centroid
    are ``lowest_point``'s. ``hts`` holds the heights of the points kept and ``inf``
    elsewhere."""
    s0 = geo.sup_start[kp]
    s1 = geo.sup_start[kp + 1]
    xs = 1.0
    for i in range(3):
        xs += abs(x[i])
    m0 = prm[P_N] * R[0] + prm[P_N + 1] * R[3] + prm[P_N + 2] * R[6]
    m1 = prm[P_N] * R[1] + prm[P_N + 1] * R[4] + prm[P_N + 2] * R[7]
    m2 = prm[P_N] * R[2] + prm[P_N + 1] * R[5] + prm[P_N + 2] * R[8]
    fbest = math.inf
    pmax = 0.0
    for p in range(s0, s1):
        p0 = geo.sup_pts[p, 0]
        p1 = geo.sup_pts[p, 1]
        p2 = geo.sup_pts[p, 2]
        hf = m0 * p0 + m1 * p1 + m2 * p2
        hts[p - s0] = hf
        fbest = min(fbest, hf)
        pmax = max(pmax, abs(p0) + abs(p1) + abs(p2))
    cut = fbest + tol + 2.0 * FAST_HEIGHT_REL * (xs + pmax)
    best = math.inf
    for p in range(s0, s1):
        if hts[p - s0] <= cut:
            hgt = 0.0
            for i in range(3):
                wi = x[i]
                for j in range(3):
                    wi += R[3 * i + j] * geo.sup_pts[p, j]
                hgt += prm[P_N + i] * wi
            hts[p - s0] = hgt
            if hgt < best:
                best = hgt
        else:
            hts[p - s0] = math.inf
    _touching_centroid(x, R, geo, s0, s1, hts, best + tol, out)
    return best - geo.sup_pad[kp]


@jit
def lowest_point(x, R, prm, geo, kp, out, tol, hts):  # type: ignore[no-untyped-def]
    """Lowest point of piece ``kp``: returns its height minus the pad; ``out`` receives the
    centroid (world) of the support points within ``tol`` of the lowest one, the
    middle of the touching face or edge, a good first guess of the ECP. ``hts`` (float64,
    at least the piece's support points) receives their heights: one pass computes them,
    the second only compares. Pieces of more than ``FAST_HEIGHT_POINTS`` points (the curved
    robot's 226) take :func:`_lowest_many`, the same results, where ``hts`` holds the
    heights of the points near the lowest only. ``tol`` >= 0."""
    s0 = geo.sup_start[kp]
    s1 = geo.sup_start[kp + 1]
    if s1 - s0 > FAST_HEIGHT_POINTS:
        return _lowest_many(x, R, prm, geo, kp, out, tol, hts)
    best = math.inf
    for p in range(s0, s1):
        hgt = 0.0
        for i in range(3):
            wi = x[i]
            for j in range(3):
                wi += R[3 * i + j] * geo.sup_pts[p, j]
            hgt += prm[P_N + i] * wi
        hts[p - s0] = hgt
        if hgt < best:
            best = hgt
    _touching_centroid(x, R, geo, s0, s1, hts, best + tol, out)
    return best - geo.sup_pad[kp]


@jit
def _landing_guess(z, off, kp, motion, h, model, scr, tol, keep_forces):  # type: ignore[no-untyped-def]
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
def _snap_flat(R, prm, geo, h, w, out):  # type: ignore[no-untyped-def]
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


@jit_alloc
def _impact_guess(z, off, mk, state, h, model, scr, edge, half):  # type: ignore[no-untyped-def]
    """Guesses 9, 10 and 11 for the contact block at ``off`` (``mk`` constraints, its ECP ``a1`` set): the rigid-body impact.

    Guess 9 (``half == 0``): the impulse ``P`` that brings the contact point's velocity
    ``v_c = v + w x r`` (start of step, ``r = a1 - (x + h v)``) to rest, ``K P = -v_c`` with
    ``K = I/m - [r]x I^-1 [r]x`` (world inertia at the start pose), cut to the friction cone
    along its tangential part if it leaves it; ``z`` receives ``v + P/m + h F_ext/m``,
    ``w + I^-1 (r x P)``, the forces ``P / h`` (the normal one plus the pressing load) and
    ``sigma = 0``.

    Guess 10 (``half > 0``: ``a1`` is the middle of a level edge of that half length and unit
    direction ``edge``, :func:`_level_edge`): the impact that makes the whole edge stick,
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
        return _sticking_impact(z, off, mk, state, h, model, scr, edge, half, iw, r, vc)
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
    return _impact_forces(z, off, mk, P, pn, press, h, model.prm)


@jit_alloc
def _sticking_impact(z, off, mk, state, h, model, scr, edge, half, iw, r, vc):  # type: ignore[no-untyped-def]
    """The impacts of guesses 10 and 11 (:func:`_impact_guess`, ``half != 0``): ``iw`` the world inverse inertia
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
    _impact_forces(z, off, mk, P, pn, press, h, prm)
    z[off + B_LR] = mrest / h
    return True


@jit
def _level_edge(x, R, prm, geo, kp, tol, edge):  # type: ignore[no-untyped-def]
    """Guess 10's edge: the half length of the segment joining the two lowest support points
    of piece ``kp`` at the pose ``x``, ``R`` when they lie within ``tol`` of each other in
    height and every other support point lies more than ``tol`` above the lowest (a level
    edge, not a vertex or a face; a curved piece's line has more points and returns 0);
    ``edge`` receives its unit direction (world). Returns 0 otherwise."""
    p0, p1, h0, h1, h2 = _lowest_three(x, R, prm, geo, kp)
    if p1 < 0 or h1 - h0 > tol or h2 - h0 <= tol:
        return 0.0
    el = 0.0
    for i in range(3):
        d = 0.0
        for j in range(3):
            d += R[3 * i + j] * (geo.sup_pts[p1, j] - geo.sup_pts[p0, j])
        edge[i] = d
        el += d * d
    el = math.sqrt(el)
    if el < 1e-9:
        return 0.0
    for i in range(3):
        edge[i] /= el
    return 0.5 * el


@jit
def _impact_forces(z, off, mk, P, pn, press, h, prm):  # type: ignore[no-untyped-def]
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


@jit
def _support_height(x, R, prm, geo, p):  # type: ignore[no-untyped-def]
    """Height along ``n`` of support point ``p`` at the pose ``x``, ``R``."""
    hgt = 0.0
    for i in range(3):
        wi = x[i]
        for j in range(3):
            wi += R[3 * i + j] * geo.sup_pts[p, j]
        hgt += prm[P_N + i] * wi
    return hgt


@jit
def _lowest_three(x, R, prm, geo, kp):  # type: ignore[no-untyped-def]
    """The lowest and second-lowest support points of piece ``kp`` at the pose ``x``, ``R``
    and the heights of the three lowest: ``(p0, p1, h0, h1, h2)`` (``-1`` and ``inf`` where
    the piece has fewer points; a tie goes to the point listed first)."""
    p0 = -1
    p1 = -1
    h0 = math.inf
    h1 = math.inf
    h2 = math.inf
    for p in range(geo.sup_start[kp], geo.sup_start[kp + 1]):
        hgt = _support_height(x, R, prm, geo, p)
        if hgt < h0:
            h2 = h1
            p1 = p0
            h1 = h0
            p0 = p
            h0 = hgt
        elif hgt < h1:
            h2 = h1
            p1 = p
            h1 = hgt
        elif hgt < h2:
            h2 = hgt
    return p0, p1, h0, h1, h2


@jit
def _snap_edge(x, R, prm, geo, h, w, out):  # type: ignore[no-untyped-def]
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
            hgt = _support_height(x, R, prm, geo, p)
            if hgt < best:
                best = hgt
                kbest = kp
    if kbest < 0:
        return False
    # the lowest and second-lowest distinct support points of that piece
    p0, p1, h0, h1, _ = _lowest_three(x, R, prm, geo, kbest)
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
def _plain_residual(z, prob, ws):  # type: ignore[no-untyped-def]
    """Max-norm of the model's (unsmoothed) residual at ``z``."""
    residual(z, prob, ws.Ft, ws.J, (ws.Ft_isfb, ws.fbb, ws.rs), False, 0.0)
    r = 0.0
    for i in range(z.shape[0]):
        r = max(r, abs(ws.Ft[i]))
    return r


@jit
def _impulse_consistent(z, state, hc, prob, ws, tol_rel):  # type: ignore[no-untyped-def]
    """Whether ``z``, the best attempt of a (sub-)step that failed at every depth, solves the
    step up to ``tol_rel`` of its momenta and impulses (``opts[O_IMPULSE]``).

    Force rows times ``hc`` (an impulse) against ``m (|v| + |v+|) + hc (m g + L)``, torque
    rows against ``I_max (|w| + |w+|) + hc L rho`` (``L`` the sum of the contact forces'
    magnitudes, ``rho`` the largest lever ``|a1 - x|``, at least one length unit), the
    friction rows against ``(1 + L) (1 + |v+| + rho |w+|)``, the friction-cone row against
    ``(1 + L)^2`` plus ``IMPULSE_ACCEPT_LEN``; the geometric and complementarity rows (lengths and multipliers) within
    ``IMPULSE_ACCEPT_LEN``. Fills ``ws.Ft`` with the residual."""
    _plain_residual(z, prob, ws)
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
    vs = _norm3(state[7:10]) + _norm3(z[0:3])
    ws_ = _norm3(state[10:13]) + _norm3(z[3:6])
    pscale = m * vs + hc * (m * prm[P_G] + lam)
    lscale = imax * ws_ + hc * lam * rho
    for i in range(3):
        if not abs(F[i]) * hc <= tol_rel * pscale or not abs(F[3 + i]) * hc <= tol_rel * lscale:
            return False
    dscale = (1.0 + lam) * (1.0 + _norm3(z[0:3]) + rho * _norm3(z[3:6]))
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
        off += B_FIXED + mk
    return True


@jit
def _flight_clears(state, z6, hc, prm, geo, scr):  # type: ignore[no-untyped-def]
    """Whether the free-flight solution ``z6`` keeps every piece above the plane at the end
    of the step (then it is the exact solution of the step). ``scr.tmp3`` and ``scr.R``
    receive the end pose."""
    qs = scr.qs
    R = scr.R
    xend = scr.tmp3
    tmp = scr.tmp
    quat_step(state, 3, z6, 3, hc, qs, 0)
    quat_to_rot(qs, QS_Q, R, 0)
    for i in range(3):
        xend[i] = state[i] + hc * z6[i]
    for kp in range(geo.pstart.shape[0] - 1):
        if lowest_point(xend, R, prm, geo, kp, tmp, LOW_TOL, scr.hts) <= FLIGHT_MARGIN:
            return False
    return True


@jit
def _set_flight(z, z6, hc, model, scr):  # type: ignore[no-untyped-def]
    """Write the free-flight solution into ``z``: velocities from ``z6``, contact blocks
    at their closest points with zero forces (a warm start for the next landing). The end
    pose is ``scr.tmp3``, ``scr.R`` (from :func:`_flight_clears`)."""
    geo = model.geo
    for i in range(6):
        z[i] = z6[i]
    off = 6
    for kp in range(geo.pstart.shape[0] - 1):
        mk = geo.pstart[kp + 1] - geo.pstart[kp]
        _landing_guess(z, off, kp, (scr.tmp3, z6[0:3], z6[3:6]), hc, model, scr, LOW_TOL, False)
        z[off + B_L + mk + 1] = 0.0
        z[off + B_SIG] = 0.0
        z[off + B_LT] = 0.0
        z[off + B_LO] = 0.0
        off += B_FIXED + mk


@jit
def _lift_off(state, buf, hc, model, opts, max_turn, scr):  # type: ignore[no-untyped-def]
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
    if _norm3(z6[3:6]) * hc > max_turn:
        return -1, res6
    if not _flight_clears(state, z6, hc, prm, geo, scr):
        return 0, res6
    for i in range(z.shape[0]):
        z[i] = zsave[i]
    _set_flight(z, z6, hc, model, scr)
    return 1, res6


@jit
def _peel(peel, left, area_old, area_new, h, z, prm):  # type: ignore[no-untyped-def]
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
def _line_area(prm, geo, nact, ca, cb, amin):  # type: ignore[no-untyped-def]
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
def _contact_state(z, state, prm, geo, scr):  # type: ignore[no-untyped-def]
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
                area += _line_area(prm, geo, nact, ca, cb, amin)
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


@jit
def _best_order(z, zs, pmax):  # type: ignore[no-untyped-def]
    """The order (2 to ``pmax``, at most 5) of the extrapolation through the last solutions
    that predicted ``z`` best, in the max-norm; ``zs = (z1, .., z6)``, ``z1`` the latest.

    ``SolverOptions.warm_order``: the next step's warm start takes this order, chosen the
    way variable-order predictors choose theirs, by the error each would have made on the
    step just solved. Ties go to the lower order; with ``pmax = 3`` this is the cubic-or-
    quadratic rule of ``warm_order = 3`` bit for bit (the same sums in the same order).
    """
    z1, z2, z3, z4, z5, z6 = zs
    e2 = 0.0
    e3 = 0.0
    e4 = 0.0
    e5 = 0.0
    for i in range(z.shape[0]):
        zi = z[i]
        e2 = max(e2, abs(zi - (3.0 * z1[i] - 3.0 * z2[i] + z3[i])))
        if pmax >= 3:
            e3 = max(e3, abs(zi - (4.0 * z1[i] - 6.0 * z2[i] + 4.0 * z3[i] - z4[i])))
        if pmax >= 4:
            e4 = max(e4, abs(zi - (5.0 * z1[i] - 10.0 * z2[i] + 10.0 * z3[i] - 5.0 * z4[i] + z5[i])))
        if pmax >= 5:
            e5 = max(e5, abs(zi - (6.0 * z1[i] - 15.0 * z2[i] + 20.0 * z3[i] - 15.0 * z4[i] + 6.0 * z5[i] - z6[i])))
    best = 2
    eb = e2
    if pmax >= 3 and e3 < eb:
        best = 3
        eb = e3
    if pmax >= 4 and e4 < eb:
        best = 4
        eb = e4
    if pmax >= 5 and e5 < eb:
        best = 5
    return best


@jit
def _recentre(state, zs, xoff, prm, pstart):  # type: ignore[no-untyped-def]
    """Move the origin along the plane to the centre of mass once it is ``RECENTRE_AT`` away
    along either in-plane axis (``t`` or ``o``).

    The system is invariant under translations along the plane (uniform gravity and field,
    the plane through the origin), but its rows subtract absolute positions: the lever
    ``r = a1 - x+`` of a robot 20 m down an incline (2e5 length units) carries an absolute
    rounding error of about 4e-11, which the friction and torque rows multiply by impulses
    and spin rates of hundreds, a residual floor above ``tol`` (loose steps, thousands of
    Newton iterations, energy in the ledger). Shifting ``x`` and the positions ``a1, a2``
    of every unknown vector in ``zs`` by the in-plane part ``s`` of ``x`` keeps every
    position O(1); ``xoff`` accumulates the shifts, which the record adds back. Runs that
    stay within ``RECENTRE_AT`` of the origin are never touched (the same arithmetic as
    before). Returns True if it shifted.
    """
    xt = prm[P_T] * state[0] + prm[P_T + 1] * state[1] + prm[P_T + 2] * state[2]
    xo = prm[P_O] * state[0] + prm[P_O + 1] * state[1] + prm[P_O + 2] * state[2]
    if abs(xt) <= RECENTRE_AT and abs(xo) <= RECENTRE_AT:
        return False
    for i in range(3):
        si = xt * prm[P_T + i] + xo * prm[P_O + i]
        state[i] -= si
        xoff[i] += si
        for zz in zs:
            off = 6
            for kp in range(pstart.shape[0] - 1):
                zz[off + B_A1 + i] -= si
                zz[off + B_A2 + i] -= si
                off += B_FIXED + pstart[kp + 1] - pstart[kp]
    return True


@jit
def _recentre_undo(state, z, xoff, pstart):  # type: ignore[no-untyped-def]
    """Add the shifts :func:`_recentre` made back to ``x`` and to ``a1, a2`` of ``z``."""
    for i in range(3):
        state[i] += xoff[i]
        off = 6
        for kp in range(pstart.shape[0] - 1):
            z[off + B_A1 + i] += xoff[i]
            z[off + B_A2 + i] += xoff[i]
            off += B_FIXED + pstart[kp + 1] - pstart[kp]


@jit
def _keep_start(state, z, touching, led, state_to, z_to, touching_to, led_to):  # type: ignore[no-untyped-def]
    """Copy a step's start (state, solution guess, touching flags, ledger) into the ``*_to`` arrays."""
    for i in range(state.shape[0]):
        state_to[i] = state[i]
    for i in range(z.shape[0]):
        z_to[i] = z[i]
    for i in range(touching.shape[0]):
        touching_to[i] = touching[i]
    for i in range(led.shape[0]):
        led_to[i] = led[i]


@jit_alloc
def run(model, opts, start, clock, rec, buf):  # type: ignore[no-untyped-def]
    """Integrate ``n_steps`` steps; returns ``(status, failed_steps, t_decided)``.

    Parameters
    ----------
    model : Model
        ``prm`` and ``geo``.
    opts : float64[N_OPT]
    start : Start
        Initial state (updated in place: the final state), time and contact.
    clock : Clock
        Step length, number of steps, recording stride.
    rec : float64[n_steps // record_every + 1, N_REC]
        Row 0 receives the initial state; row k the state after ``k * record_every`` steps.
    buf : Buffers
        Workspaces and unknowns (``buf.z`` holds the warm start in and the last solution out).

    Notes
    -----
    A step is first predicted in free flight (the same residual with no contact block);
    if every support point stays above the plane that prediction is the exact solution
    of the step (MODEL.md, numerical traps). Otherwise the full NCP is solved from the
    warm start, then by the fresh guesses of ``STRATEGY_GUESS``. When the explicit
    prediction hid a lift-off (it penetrates, yet the robot leaves the plane), the
    free-flight solution is tried again before the costly smoothing strategies
    (``FLIGHT_BEFORE``) if the body turns by at most ``EARLY_FLIGHT_TURN`` in the step,
    and after every strategy otherwise. A step whose solve fails is retried as halved
    sub-steps down to ``h / 2**opts[O_MAXDEPTH]``; below that the best iterate is kept and the step counted
    as failed, or as loose if that iterate balances the step's momenta and impulses to
    ``opts[O_IMPULSE]`` (:func:`_impulse_consistent`; the same iterate either way).
    Before any halving, an attempt whose residual is within ``opts[O_ACCEPT]`` is kept
    instead (a loose step; a step counts as loose at most once, and not when it also
    failed). A converged contact (sub-)step whose normal impulse does more positive work
    than ``opts[O_NWORK]`` x (``m g`` + the field's work bound over a step) is refined:
    solved again as halves, while the depth is below ``refine_cap``. A sub-step of the
    refinement that does not converge is halved again, at most ``opts[O_REFINE_HALVE]``
    times within the refinement; if one still does not converge, or the sub-steps do
    more positive normal work than the step they replace, the step starts again from its
    snapshot with a shallower cap (at the depth of the first refusal the check is off, so
    the refused step is solved again and kept). A sub-step kept loose counts as converged
    there, as everywhere. The record's sub-steps, largest residual and penetration are those
    of the sub-steps kept; its Newton iterations and fallbacks count every attempt.
    Returns ``ST_NAN`` if the state becomes non-finite, ``ST_STOPPED`` after
    ``opts[O_MAXFAIL]`` failed steps when that is > 0 (the rest of the record is unwritten).

    Early decision (``opts[O_DECIDE]`` > 0): from the window's start (step
    ``opts[O_DECIDE_STEP]``), every ``DECIDE_EVERY`` steps, the uphill progress since then
    plus :func:`~.decide.climb_bound` is compared with ``opts[O_DECIDE_NEED]``; ``t_decided``
    is the first time it falls short (NaN if never). With ``opts[O_DECIDE] == 2`` the run
    stops there with ``ST_DECIDED``: the last record row holds that state and the counters
    since the previous row, the rows between are unwritten. The check reads the state and
    never changes it, so a run's arithmetic up to ``t_decided`` is the same in every mode.
    """
    prm = model.prm
    geo = model.geo
    state = start.state
    t0 = start.t0
    area0 = start.area0
    touch0 = start.touch0
    h = clock.h
    n_steps = clock.n_steps
    record_every = clock.record_every
    ws = buf.ws
    ws6 = buf.ws6
    z = buf.z
    z6 = buf.z6
    zsave = buf.zsave
    n = z.shape[0]
    K = geo.pstart.shape[0] - 1
    pempty = geo.pstart[:1]
    sc = np.zeros(N_SC)
    nsup = 1
    for kp in range(K):
        nsup = max(nsup, geo.sup_start[kp + 1] - geo.sup_start[kp])
    scr = Scratch(
        sc=sc,
        R=np.zeros(9),  # 3x3 row-major
        tmp=np.zeros(3),
        tmp2=np.zeros(3),
        tmp3=np.zeros(3),
        cg=np.zeros(N_CG),  # constraint_eval's gradient and Hessian
        qs=np.zeros(N_QS),  # quat_step's block: Q+ at QS_Q
        iters=np.zeros(3, np.int64),
        prob=Problem(sc=sc, prm=prm, ctype=geo.ctype, cdata=geo.cdata, pstart=geo.pstart),
        prob6=Problem(sc=sc, prm=prm, ctype=geo.ctype, cdata=geo.cdata, pstart=pempty),
        hts=np.zeros(nsup),  # lowest_point's support heights
    )
    hts = scr.hts
    prob = scr.prob
    prob6 = scr.prob6
    R = scr.R
    tmp = scr.tmp
    tmp3 = scr.tmp3
    qs = scr.qs
    iters = scr.iters
    # no factors from another run (a batch reuses its buffers): solve's chord start waits
    # for this run's first Newton matrix
    ws.lu_h[0] = 0.0
    ws6.lu_h[0] = 0.0
    zwarm = np.zeros(n)
    zprev = np.zeros(n)
    zprev2 = np.zeros(n)
    zprev3 = np.zeros(n)
    zprev4 = np.zeros(n)
    zprev5 = np.zeros(n)
    zprev6 = np.zeros(n)
    # O_WARM >= 3: the order of the next step's extrapolated warm start (set at each commit)
    order_next = 2
    zbest = np.zeros(n)
    edir = np.zeros(3)  # guess 10's edge direction
    ncont = 0  # consecutive full-length contact solves (for the extrapolated warm start)
    touching = np.zeros(K, np.int64)
    if touch0:
        touching[:] = 1
    maxdepth = int(opts[O_MAXDEPTH])
    maxfail = int(opts[O_MAXFAIL])
    accept_tol = opts[O_ACCEPT]
    smooth_stalled = opts[O_SMOOTH_STALLED] > 0.5
    warm_max = int(opts[O_WARM])
    # a contact (sub-)step whose normal impulse does more positive work than this is solved
    # again as halves (O_NWORK; a rigid contact cannot push: at a landing the robot crosses
    # several thicknesses in a step and the end-pose contact throws it back out)
    nwork_max = opts[O_NWORK] * (prm[P_MASS] * prm[P_G] + field_work_bound(prm, h))
    # plain and projected attempts that have not converged after FAST_MAXIT iterations
    # rarely do: move on to the next strategy (the smoothing continuation and sub-steps
    # keep max_iter)
    opts_fast = opts.copy()
    opts_fast[O_MAXIT] = min(opts[O_MAXIT], FAST_MAXIT)
    # the smoothing continuation converges slowly (100-300 iterations) but finds the
    # impulsive feature switches that the plain attempts miss; it only runs at such events
    # (an attempt that stops progressing for O_STALL iterations is cut: SolverOptions.stall_window)
    opts_smooth = opts.copy()
    opts_smooth[O_MAXIT] = max(opts[O_MAXIT], SMOOTH_MAXIT)
    # a failed step's rescue pass: every attempt up to O_RESCUE iterations, no stall window
    opts_rescue = opts.copy()
    opts_rescue[O_MAXIT] = max(opts[O_MAXIT], SMOOTH_MAXIT, opts[O_RESCUE])
    opts_rescue[O_STALL] = 0.0

    area_prev = area0
    # peeling (P_PEEL): area released by the contact that still adheres, and the work of
    # adhesion C x peel_length x released area left before it lets go (_peel)
    peel = 0.0
    peel_left = 0.0
    any_touch = touch0
    mode = 0
    lnsum = 0.0
    slip = 0.0
    ecp_off = -1
    adh = 0.0
    t = t0
    failed_total = 0
    # accumulators over a record interval
    acc_nit = 0
    acc_res = 0.0
    acc_fb = 0
    acc_sub = 0
    acc_pen = 0.0
    acc_fail = 0
    acc_loose = 0
    acc_impulse = 0

    xoff = np.zeros(3)  # the shifts of the origin along the plane (_recentre), added back in the record
    led = np.zeros(N_LED)  # the energy ledger (ledger.py), cumulative over the run
    ls = np.zeros(N_LED)  # the ledger terms of the step being committed
    # the start of a step whose landing is refined (O_NWORK)
    snap_state = np.zeros(state.shape[0])
    snap_z = np.zeros(n)
    snap_touch = np.zeros(K, np.int64)
    snap_led = np.zeros(N_LED)
    snap_scal = (t, area_prev, peel, peel_left, any_touch, ncont, acc_pen, acc_res, acc_sub)
    # the step's start, kept at its first halving (nothing of it is committed yet): a step
    # that fails at every depth is solved again from there (O_RESCUE)
    rescue_on = opts[O_RESCUE] > 0.0
    step_state = np.zeros(state.shape[0])
    step_z = np.zeros(n)
    step_touch = np.zeros(K, np.int64)
    step_led = np.zeros(N_LED)
    step_scal = (t, area_prev, peel, peel_left, any_touch, ncont, acc_pen, acc_res, acc_sub, order_next)
    ref_end = 0.0  # what remains of the step once the refused (sub-)step is refined
    snap_depth = 0  # the depth of the step's first refusal
    snap_remaining = 0.0  # what remained of the step at the refusal (h unless a sub-step was committed before it)
    snap_loose = False  # the step's loose flags at the refusal
    snap_impulse = False
    wn_coarse = 0.0  # the positive normal work of the refused step
    wn_ref = 0.0  # the same, summed over the refinement's sub-steps so far
    ref_halve_max = int(opts[O_REFINE_HALVE])
    ref_halved = 0  # halvings of the refinement's sub-steps for want of convergence (O_REFINE_HALVE)
    lw = np.zeros(N_LW)
    led[L_KE] = kinetic_energy(state, prm, lw)
    # early decision (opts[O_DECIDE], kernels/decide.py): the window's start position, the
    # energy scale without the potential released, and the first time the bound decided
    decide = int(opts[O_DECIDE])
    decide_need = opts[O_DECIDE_NEED]
    decide_step = int(opts[O_DECIDE_STEP])
    t_end = t0 + n_steps * h
    eref0 = led[L_KE] + prm[P_MASS] * prm[P_G] + field_work_bound(prm, n_steps * h)
    xw = np.zeros(3)
    for i in range(3):
        xw[i] = state[i]
    t_decided = math.nan
    row = 0
    _record(rec, row, t, state, z, 0.0, (0, 0.0, 0.0, 0.0, -1), (0, 0.0, 0, 0, 0.0, 0, 0, 0), led, xoff)
    status = ST_OK
    for step in range(n_steps):
        _recentre(state, (z, zprev, zprev2, zprev3, zprev4, zprev5, zprev6), xoff, prm, geo.pstart)
        remaining = h
        hc = h
        depth = 0
        step_failed = False
        step_loose = False
        step_impulse = False  # a (sub-)step kept by O_IMPULSE (also loose)
        refine_cap = maxdepth  # landings are halved (O_NWORK) while depth < refine_cap
        refining = False  # the step is being refined: its start is in the snapshot
        restart = False  # return to the snapshot: the refinement failed or did not help
        step_snap = False  # step_* hold this step's start
        rescued = False  # the step is being solved again (O_RESCUE)
        while remaining > 1e-12 * h:
            if restart:
                state[:] = snap_state
                for i in range(n):
                    z[i] = snap_z[i]
                for kp in range(K):
                    touching[kp] = snap_touch[kp]
                led[:] = snap_led
                t, area_prev, peel, peel_left, any_touch, ncont, acc_pen, acc_res, acc_sub = snap_scal
                refining = False
                restart = False
                remaining = snap_remaining
                hc = h * 0.5**snap_depth
                depth = snap_depth
                step_loose = snap_loose
                step_impulse = snap_impulse
            if hc > remaining:
                hc = remaining
            _prepare(state, t, hc, prm, area_prev + peel, any_touch, scr)
            # --- free-flight prediction; an explicit pose that clearly penetrates skips it
            flight = False
            free = False  # solved without contact (for the ledger)
            have_ls = False  # ls holds this (sub-)step's ledger terms
            unsolved = False  # kept by O_IMPULSE: not a warm start to extrapolate from (as if failed)
            st6 = ST_NAN
            res6 = 0.0
            quat_step(state, 3, state, 10, hc, qs, 0)
            quat_to_rot(qs, QS_Q, R, 0)
            for i in range(3):
                tmp3[i] = state[i] + hc * (state[7 + i] + hc * sc[S_FEXT + i] / prm[P_MASS])
            clear = True
            for kp in range(K):
                if lowest_point(tmp3, R, prm, geo, kp, tmp, LOW_TOL, hts) < -FLIGHT_PRECHECK:
                    clear = False
                    break
            if clear:
                for i in range(6):
                    z6[i] = z[i]
                st6, res6 = solve(z6, prob6, ws6, opts, iters, False, 0.0, True)
                acc_nit += iters[0]
            if st6 == ST_OK:
                flight = _flight_clears(state, z6, hc, prm, geo, scr)
            if flight:
                _set_flight(z, z6, hc, model, scr)
                st = ST_OK
                res = res6
            else:
                for i in range(n):
                    zsave[i] = z[i]
                # warm start: blocks that were not touching get a landing guess
                quat_to_rot(state, 3, R, 0)
                off = 6
                for kp in range(K):
                    mk = geo.pstart[kp + 1] - geo.pstart[kp]
                    if touching[kp] == 0:
                        _landing_guess(z, off, kp, (state[0:3], state[7:10], state[10:13]), hc, model, scr, LOW_TOL, False)
                    off += B_FIXED + mk
                # deterministic strategies (STRATEGY_*): the touching feature may change
                # within the step (a face slapping down, an edge passing over, a vertex
                # switching), which the warm start alone cannot follow
                st = ST_NAN
                res = math.inf
                for i in range(n):
                    zwarm[i] = z[i]
                res_best = math.inf
                flight_failed = False  # the early free-flight check ran and did not clear
                for attempt in range(N_ATTEMPTS):
                    if attempt == FLIGHT_BEFORE and not clear and _norm3(state[10:13]) * hc <= EARLY_FLIGHT_TURN:
                        # lift-off that the explicit pre-check hid: before the costly
                        # smoothing strategies, the free-flight solution, if it clears the
                        # plane and turns the body little (no corner can dip through the
                        # plane within the step), is the exact solution of the step
                        code, res6 = _lift_off(state, buf, hc, model, opts, EARLY_FLIGHT_TURN, scr)
                        acc_nit += iters[0]
                        flight_failed = code == 0
                        if code == 1:
                            flight = True
                            st = ST_OK
                            res = res6
                            break
                    if STRATEGY_SMOOTH[attempt] > 0.0 and res_best <= accept_tol and not smooth_stalled:
                        # an attempt already stalled within accept_tol, so the (sub-)step will
                        # not be halved for want of convergence (the lift-off check, a landing
                        # refinement or a refinement's restart still apply); the smoothing
                        # continuations (up to SMOOTH_MAXIT iterations each) are not tried for a
                        # lower stall, the cheap strategies still are for a converged solution
                        continue
                    guess = STRATEGY_GUESS[attempt]
                    if guess == 0 and attempt == 0 and ncont >= 2 and hc == h:
                        # smooth motion: extrapolate the last solutions (O(h^3) warm start, or
                        # a higher order where it predicted the last step better: O_WARM)
                        if order_next == 5:
                            for i in range(n):
                                z[i] = 6.0 * zwarm[i] - 15.0 * zprev[i] + 20.0 * zprev2[i] - 15.0 * zprev3[i] + 6.0 * zprev4[i] - zprev5[i]
                        elif order_next == 4:
                            for i in range(n):
                                z[i] = 5.0 * zwarm[i] - 10.0 * zprev[i] + 10.0 * zprev2[i] - 5.0 * zprev3[i] + zprev4[i]
                        elif order_next == 3:
                            for i in range(n):
                                z[i] = 4.0 * zwarm[i] - 6.0 * zprev[i] + 4.0 * zprev2[i] - zprev3[i]
                        elif ncont >= 3:
                            for i in range(n):
                                z[i] = 3.0 * zwarm[i] - 3.0 * zprev[i] + zprev2[i]
                        else:
                            for i in range(n):
                                z[i] = 2.0 * zwarm[i] - zprev[i]
                        off = 6
                        for kp in range(K):
                            mk = geo.pstart[kp + 1] - geo.pstart[kp]
                            for i in range(off + B_SIG, off + B_L + mk + 2):  # sigma, l_i, l_s, lam_n
                                z[i] = max(z[i], 0.0)
                            off += B_FIXED + mk
                    elif guess == 0:
                        for i in range(n):
                            z[i] = zwarm[i]
                    else:
                        # fresh contact guess at the predicted end pose (STRATEGY_GUESS)
                        for i in range(n):
                            z[i] = zsave[i]
                        if guess == 9 or guess == 11:
                            quat_step(state, 3, state, 10, hc, qs, 0)
                            quat_to_rot(qs, QS_Q, R, 0)
                            for i in range(3):
                                tmp3[i] = state[i] + hc * state[7 + i]
                            off = 6
                            kl = -1
                            ml = 0
                            low = math.inf
                            for kp in range(K):
                                mk = geo.pstart[kp + 1] - geo.pstart[kp]
                                _landing_guess(z, off, kp, (tmp3, state[7:10], state[10:13]), hc, model, scr, VERTEX_TOL, False)
                                hk = lowest_point(tmp3, R, prm, geo, kp, tmp, VERTEX_TOL, hts)
                                if hk < low:
                                    low = hk
                                    kl = off
                                    ml = mk
                                off += B_FIXED + mk
                            if not _impact_guess(z, kl, ml, state, hc, model, scr, edir, 0.0 if guess == 9 else -1.0):
                                continue
                        elif guess == 10:
                            # the level edge at the start pose, sticking at once
                            quat_to_rot(state, 3, R, 0)
                            off = 6
                            kl = -1
                            ml = 0
                            kpl = 0
                            low = math.inf
                            for kp in range(K):
                                mk = geo.pstart[kp + 1] - geo.pstart[kp]
                                _landing_guess(z, off, kp, (state[0:3], state[7:10], state[10:13]), hc, model, scr, LOW_TOL, False)
                                hk = lowest_point(state[0:3], R, prm, geo, kp, tmp, LOW_TOL, hts)
                                if hk < low:
                                    low = hk
                                    kl = off
                                    ml = mk
                                    kpl = kp
                                off += B_FIXED + mk
                            half = _level_edge(state[0:3], R, prm, geo, kpl, LOW_TOL, edir)
                            if half == 0.0 or not _impact_guess(z, kl, ml, state, hc, model, scr, edir, half):
                                continue
                        elif guess == 8:
                            # the nearly level edge laid level: pre-impact v, snapped w, the
                            # ECP in the middle of the edge at the snapped pose
                            quat_step(state, 3, state, 10, hc, qs, 0)
                            quat_to_rot(qs, QS_Q, R, 0)
                            for i in range(3):
                                tmp3[i] = state[i] + hc * state[7 + i]
                            if not _snap_edge(tmp3, R, prm, geo, hc, state[10:13], tmp):
                                continue
                            for i in range(3):
                                z[i] = state[7 + i]
                                z[3 + i] = tmp[i]
                            quat_step(state, 3, z, 3, hc, qs, 0)
                            quat_to_rot(qs, QS_Q, R, 0)
                            off = 6
                            for kp in range(K):
                                mk = geo.pstart[kp + 1] - geo.pstart[kp]
                                _landing_guess(z, off, kp, (tmp3, state[7:10], state[10:13]), hc, model, scr, LOW_TOL, False)
                                off += B_FIXED + mk
                        else:
                            if guess >= 5:
                                guess -= 4
                                for i in range(6):
                                    z[i] = 0.0
                            quat_step(state, 3, state, 10, hc, qs, 0)
                            quat_to_rot(qs, QS_Q, R, 0)
                            if guess == 4:
                                # the nearly flat face laid flat: pre-impact v, snapped w; the
                                # ECP at the lowest vertex or edge of the pose predicted without
                                # the snap, the edge that lands
                                if not _snap_flat(R, prm, geo, hc, state[10:13], tmp):
                                    continue
                                for i in range(3):
                                    z[i] = state[7 + i]
                                    z[3 + i] = tmp[i]
                            for i in range(3):
                                tmp3[i] = state[i] + hc * state[7 + i]
                            off = 6
                            for kp in range(K):
                                mk = geo.pstart[kp + 1] - geo.pstart[kp]
                                tolg = VERTEX_TOL if guess == 2 or guess == 4 else (RESTART_TOL if guess == 1 else FACE_TOL)
                                w_guess = z[3:6] if guess == 4 else state[10:13]
                                _landing_guess(
                                    z, off, kp, (tmp3, state[7:10], w_guess), hc, model, scr, tolg, guess == 1 and touching[kp] == 1
                                )
                                off += B_FIXED + mk
                    smooth = STRATEGY_SMOOTH[attempt]
                    if rescued:
                        opts_use = opts_rescue
                    elif smooth > 0.0:
                        opts_use = opts_smooth
                    elif depth > 0 or guess >= 8 or guess == 4:
                        opts_use = opts  # the snaps can need more than FAST_MAXIT iterations
                    else:
                        opts_use = opts_fast
                    # the first attempt may start with chord iterations (SolverOptions.chord_iter)
                    st, res = solve(z, prob, ws, opts_use, iters, STRATEGY_PROJECT[attempt], smooth, attempt == 0)
                    acc_nit += iters[0]
                    acc_fb += iters[1] + (1 if attempt > 0 else 0)
                    if st == ST_OK:
                        break
                    # remember the attempt with the smallest residual of the model itself
                    # (a smoothed attempt reports its smoothed residual)
                    if smooth > 0.0:
                        res = _plain_residual(z, prob, ws)
                    if res < res_best:
                        res_best = res
                        for i in range(n):
                            zbest[i] = z[i]
                if st != ST_OK and not clear and not flight_failed:
                    # lift-off that the explicit pre-check hid: the free-flight solution, if
                    # it clears the plane, is the exact solution of the step (also when the
                    # early check refused it for turning too far)
                    code, res6 = _lift_off(state, buf, hc, model, opts, math.inf, scr)
                    acc_nit += iters[0]
                    if code == 1:
                        st = ST_OK
                        res = res6
                        free = True
                if st != ST_OK and res_best <= accept_tol:
                    # no strategy reached tol, but the best attempt is within accept_tol:
                    # keep it (a loose step) rather than sub-step. Where the residual
                    # stalls just above tol (a rounding floor at metres per second), the
                    # sub-steps fare worse: that floor grows as the step shrinks
                    res = res_best
                    for i in range(n):
                        z[i] = zbest[i]
                    st = ST_OK
                    step_loose = True
                if st != ST_OK and refining and ref_halved < ref_halve_max and depth < maxdepth:
                    # a sub-step of a refined landing does not converge: halve it, at most
                    # O_REFINE_HALVE times within the refinement (the rest of the refined step
                    # goes on at that length, so the refinement stays bounded: a landing that
                    # every sub-step depth refused made runs ten times dearer)
                    for i in range(n):
                        z[i] = zsave[i]
                    hc *= 0.5
                    depth += 1
                    acc_sub += 1
                    ref_halved += 1
                    continue
                if st != ST_OK and refining:
                    # a sub-step of a refined landing does not converge: start the step again
                    # and refine less deep (at the depth of the first refusal the check is off:
                    # the converged step that asked for refinement is solved again and kept;
                    # the depth counted is that of the landing halvings, not of the halvings
                    # above)
                    restart = True
                    refine_cap = max(depth - ref_halved - 1, snap_depth)
                    continue
                if st != ST_OK and depth < maxdepth:
                    if rescue_on and not step_snap:
                        _keep_start(state, zsave, touching, led, step_state, step_z, step_touch, step_led)
                        step_scal = (t, area_prev, peel, peel_left, any_touch, ncont, acc_pen, acc_res, acc_sub, order_next)
                        step_snap = True
                    for i in range(n):
                        z[i] = zsave[i]
                    hc *= 0.5
                    depth += 1
                    acc_sub += 1
                    continue
                if st != ST_OK and opts[O_IMPULSE] > 0.0 and res_best < math.inf:
                    # nothing converged at the smallest sub-step, but the best attempt balances
                    # the step's momenta to O_IMPULSE of its impulses (a landing in a tiny
                    # sub-step, where the forces are impulse / hc): keep it, as loose
                    for i in range(n):
                        z[i] = zbest[i]
                    if _impulse_consistent(z, state, hc, prob, ws, opts[O_IMPULSE]):
                        st = ST_OK
                        res = res_best
                        step_loose = True
                        step_impulse = True
                        unsolved = True
                if st != ST_OK and rescue_on and not rescued:
                    # nothing converged at the smallest sub-step: before counting a failure,
                    # solve the whole step once more from its start with every attempt
                    # allowed O_RESCUE iterations and no stall window (opts_rescue). Found on
                    # fast aluminum sliders: a sub-step whose plain Newton converges only
                    # after more than its 60 iterations (up to a few hundred), and smoothing
                    # attempts the stall window cut. Steps that do not fail are untouched
                    # (SolverOptions.rescue_iter; docs/solver_gaps.md, section 8)
                    if step_snap:
                        _keep_start(step_state, step_z, step_touch, step_led, state, zsave, touching, led)
                        t, area_prev, peel, peel_left, any_touch, ncont, acc_pen, acc_res, acc_sub, order_next = step_scal
                    for i in range(n):
                        z[i] = zsave[i]
                    rescued = True
                    refining = False
                    refine_cap = maxdepth
                    remaining = h
                    hc = h
                    depth = 0
                    step_loose = False
                    step_impulse = False
                    continue
                if st != ST_OK:
                    # nothing converged at the smallest sub-step: keep the best attempt and
                    # count the step as failed
                    step_failed = True
                    res = res_best
                    if res_best < math.inf:
                        for i in range(n):
                            z[i] = zbest[i]
                    else:  # no attempt gave a residual (every one NaN or skipped): zbest is an older step's
                        for i in range(n):
                            z[i] = zsave[i]
                    if maxfail > 0 and failed_total + 1 >= maxfail:
                        # the caller asked to give up (a study discards such runs anyway):
                        # the rest of this step would run at the smallest sub-step
                        status = ST_STOPPED
                        break
                if st == ST_OK and not flight and not free and nwork_max > 0.0 and depth < refine_cap:
                    quat_step(state, 3, z, 3, hc, qs, 0)
                    ledger_step(state, z, hc, qs, False, any_touch, area_prev + peel, prm, geo.pstart, sc, lw, ls)
                    have_ls = True
                    if ls[L_WN] > nwork_max:
                        if not refining:
                            # nothing of this sub-step is committed yet: keep its start, to which
                            # a refinement that fails or does not help returns (a sub-step after
                            # an earlier one was committed, too: the landing can come in the
                            # second half of a halved step)
                            if rescue_on and not step_snap and remaining == h:
                                _keep_start(state, zsave, touching, led, step_state, step_z, step_touch, step_led)
                                step_scal = (t, area_prev, peel, peel_left, any_touch, ncont, acc_pen, acc_res, acc_sub, order_next)
                                step_snap = True
                            refining = True
                            ref_halved = 0
                            snap_depth = depth
                            wn_coarse = ls[L_WN]
                            wn_ref = 0.0
                            snap_state[:] = state
                            for i in range(n):
                                snap_z[i] = zsave[i]
                            for kp in range(K):
                                snap_touch[kp] = touching[kp]
                            snap_led[:] = led
                            snap_scal = (t, area_prev, peel, peel_left, any_touch, ncont, acc_pen, acc_res, acc_sub)
                            ref_end = remaining - hc
                            snap_remaining = remaining
                            snap_loose = step_loose
                            snap_impulse = step_impulse
                        for i in range(n):
                            z[i] = zsave[i]
                        hc *= 0.5
                        depth += 1
                        acc_sub += 1
                        continue
            if refining:
                # the refinement is kept only if its sub-steps' positive normal work stays
                # below that of the step it replaces (and its sub-steps are finite)
                finite = True
                for i in range(n):
                    if not z[i] == z[i]:
                        finite = False
                if not finite:
                    restart = True
                    refine_cap = snap_depth
                    continue
                if not have_ls:
                    quat_step(state, 3, z, 3, hc, qs, 0)
                    ledger_step(state, z, hc, qs, flight or free, any_touch, area_prev + peel, prm, geo.pstart, sc, lw, ls)
                    have_ls = True
                wn_ref += max(ls[L_WN], 0.0)
                if not wn_ref <= wn_coarse:  # (NaN restarts too)
                    restart = True
                    refine_cap = snap_depth
                    continue
            if res > acc_res:
                acc_res = res
            if flight or hc != h or st != ST_OK or unsolved:
                ncont = 0
                order_next = 2
            else:
                if warm_max >= 5:
                    for i in range(n):
                        zprev6[i] = zprev5[i]
                if warm_max >= 4:
                    for i in range(n):
                        zprev5[i] = zprev4[i]
                if warm_max >= 3:
                    for i in range(n):
                        zprev4[i] = zprev3[i]
                        zprev3[i] = zprev2[i]
                for i in range(n):
                    zprev2[i] = zprev[i]
                    zprev[i] = zwarm[i]
                if warm_max >= 3 and ncont >= 4:
                    # the next step's order: the extrapolation that predicted this step's
                    # solution z best (zprev .. zprev6: the solutions before it; an order p
                    # needs p + 1 of them, and ncont of them are contact solutions)
                    order_next = _best_order(z, (zprev, zprev2, zprev3, zprev4, zprev5, zprev6), min(warm_max, ncont - 1))
                ncont += 1
            # --- commit
            for i in range(n):
                if not z[i] == z[i]:
                    status = ST_NAN
            if status == ST_NAN:
                break
            quat_step(state, 3, z, 3, hc, qs, 0)
            if not have_ls:
                ledger_step(state, z, hc, qs, flight or free, any_touch, area_prev + peel, prm, geo.pstart, sc, lw, ls)
            ledger_add(led, ls)
            area_old = area_prev
            for i in range(3):
                state[i] += hc * z[i]
                state[7 + i] = z[i]
                state[10 + i] = z[3 + i]
            for i in range(4):
                state[3 + i] = qs[QS_Q + i]
            t += hc
            if remaining - hc <= 1e-12 * h:
                t = t0 + (step + 1) * h  # whole steps: no accumulated rounding in time
            remaining -= hc
            mode, area_prev, lnsum, slip, ecp_off = _contact_state(z, state, prm, geo, scr)
            if prm[P_PEEL] > 0.5:
                peel, peel_left = _peel(peel, peel_left, area_old, area_prev, hc, z, prm)
            adh = prm[P_ADHC] * (area_prev + peel)
            any_touch = mode > 0
            off = 6
            for kp in range(K):
                mk = geo.pstart[kp + 1] - geo.pstart[kp]
                touching[kp] = 1 if z[off + B_L + mk + 1] > CONTACT_LN_TOL else 0
                off += B_FIXED + mk
            quat_to_rot(state, 3, R, 0)
            for kp in range(K):
                pen = -lowest_point(state[0:3], R, prm, geo, kp, tmp, LOW_TOL, hts)
                if pen > acc_pen:
                    acc_pen = pen
            if refining and remaining <= ref_end + 1e-12 * h:
                # the refused (sub-)step is refined and kept: the rest of the step goes on
                # at the refused step's length, as it would have without the refusal
                refining = False
                hc = h * 0.5**snap_depth
                depth = snap_depth
        if step_failed:
            acc_fail += 1
            failed_total += 1
        elif step_loose:
            acc_loose += 1
            if step_impulse:
                acc_impulse += 1
        if status == ST_NAN or status == ST_STOPPED:
            break
        if (step + 1) % record_every == 0 or step == n_steps - 1:
            row += 1
            _record(
                rec, row, t, state, z, adh,
                (mode, area_prev, lnsum, slip, ecp_off),
                (acc_nit, acc_res, acc_fb, acc_sub, acc_pen, acc_fail, acc_loose, acc_impulse), led, xoff,
            )  # fmt: skip
            acc_loose = 0
            acc_impulse = 0
            acc_nit = 0
            acc_res = 0.0
            acc_fb = 0
            acc_sub = 0
            acc_pen = 0.0
            acc_fail = 0
        if decide > 0 and step + 1 >= decide_step and step < n_steps - 1 and math.isnan(t_decided):
            if step + 1 == decide_step:
                for i in range(3):
                    xw[i] = state[i] + xoff[i]
            elif (step + 1 - decide_step) % DECIDE_EVERY == 0:
                prog = 0.0
                for i in range(3):
                    tmp[i] = state[i] + xoff[i]
                    prog += prm[P_U + i] * (tmp[i] - xw[i])
                if prog + climb_bound(prm, tmp, led, t, t_end, eref0) < decide_need:
                    t_decided = t
                    if decide == 2:
                        # the last record row holds the state at the decision (rows between: unwritten)
                        _record(
                            rec, rec.shape[0] - 1, t, state, z, adh,
                            (mode, area_prev, lnsum, slip, ecp_off),
                            (acc_nit, acc_res, acc_fb, acc_sub, acc_pen, acc_fail, acc_loose, acc_impulse), led, xoff,
                        )  # fmt: skip
                        status = ST_DECIDED
                        break
    # the final state and the last solution's positions in the caller's frame
    _recentre_undo(state, z, xoff, geo.pstart)
    return status, failed_total, t_decided


@jit
def _record(rec, row, t, state, z, adh, cs, acc, led, xoff):  # type: ignore[no-untyped-def]
    """Write record row ``row``: time, state and ECP (positions plus the origin's shift
    ``xoff``, :func:`_recentre`), applied adhesion ``adh``, the contact
    summary ``cs = (mode, area, lnsum, slip, ecp_off)`` (:func:`_contact_state`), the
    interval's counters ``acc = (nit, res, nfb, nsub, pen, nfail, nloose, nimpulse)`` and the
    energy ledger ``led`` (:mod:`.ledger`)."""
    mode, area, lnsum, slip, ecp_off = cs
    nit, res, nfb, nsub, pen, nfail, nloose, nimpulse = acc
    rec[row, R_T] = t
    for i in range(3):
        rec[row, R_X + i] = state[i] + xoff[i]
        rec[row, R_V + i] = state[7 + i]
        rec[row, R_W + i] = state[10 + i]
        rec[row, R_ECP + i] = z[ecp_off + B_A1 + i] + xoff[i] if ecp_off >= 0 else np.nan
    for i in range(4):
        rec[row, R_Q + i] = state[3 + i]
    rec[row, R_LN] = lnsum
    rec[row, R_ADH] = adh
    rec[row, R_AREA] = area
    rec[row, R_MODE] = mode
    rec[row, R_SLIP] = slip
    rec[row, R_NIT] = nit
    rec[row, R_RES] = res
    rec[row, R_FALLBACK] = nfb
    rec[row, R_SUB] = nsub
    rec[row, R_PEN] = max(pen, 0.0)
    rec[row, R_FAIL] = nfail
    rec[row, R_LOOSE] = nloose
    rec[row, R_IMPULSE] = nimpulse
    for i in range(N_LED):
        rec[row, R_LED + i] = led[i]


def n_records(n_steps: int, record_every: int) -> int:
    """Rows of ``rec`` for a run."""
    return -(-n_steps // record_every) + 1  # the last step is always recorded


def empty_record(n_steps: int, record_every: int) -> np.ndarray:
    """A ``rec`` array for a run."""
    return np.zeros((n_records(n_steps, record_every), N_REC))


def make_buffers(n: int) -> Buffers:
    """Solver memory for a system of ``n`` unknowns (:class:`Buffers`)."""
    return Buffers(ws=make_workspace(n), ws6=make_workspace(6), z=np.zeros(n), z6=np.zeros(6), zsave=np.zeros(n))


__all__ = [
    "Buffers",
    "Clock",
    "Geometry",
    "Model",
    "Scratch",
    "Start",
    "Workspace",
    "empty_record",
    "make_buffers",
    "n_records",
    "run",
]
