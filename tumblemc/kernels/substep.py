"""One (sub-)step's solve: the free-flight prediction, the warm start and the strategy ladder.

:func:`solve_substep` is the solve of one (sub-)step of length ``hc`` from the run's state;
what happens when it does not converge (halving, refinement, rescue) is :mod:`.step`'s.
"""

from __future__ import annotations

import math

from ._jit import jit, jit_inline
from .contact import flight_clears, lift_off, norm3, plain_residual, set_flight
from .geometry import QS_Q, quat_step, quat_to_rot
from .guesses import (
    G_WARM,
    GUESS_FULL_MAXIT,
    LOW_TOL,
    N_ATTEMPTS,
    N_RESCUE_ONLY,
    STRATEGY_GUESS,
    STRATEGY_PROJECT,
    STRATEGY_SMOOTH,
    build_guess,
    landing_guess,
)
from .layout import B_FIXED, B_L, B_SIG, O_ACCEPT, O_SMOOTH_STALLED, P_MASS, S_FEXT, ST_NAN, ST_OK, SV_FB, SV_NCONT, SV_NIT, SV_ORDER
from .newton import solve
from .support import lowest_point

FLIGHT_BEFORE = 6  # a step whose explicit prediction penetrates tries free flight before this attempt
EARLY_FLIGHT_TURN = 0.05  # ... when the body turns by at most this angle (rad) in the step
FAST_MAXIT = 15  # iteration limit of the plain and projected strategies
SMOOTH_MAXIT = 300  # iteration limit of the smoothing continuation
FLIGHT_PRECHECK = 1e-6  # an explicit prediction this deep (scaled length) below the plane skips the flight solve

#: the solver options of an attempt, in the tuple ``opts_set`` that :func:`solve_substep` takes
OPTS_FULL = 0  # the run's options (sub-steps, snaps and impacts)
OPTS_FAST = 1  # FAST_MAXIT: plain and projected attempts that have not converged by then rarely do
OPTS_SMOOTH = 2  # at least SMOOTH_MAXIT: the smoothing continuation converges slowly
OPTS_RESCUE = 3  # a failed step's rescue pass: every attempt up to O_RESCUE iterations, no stall window


@jit
def best_order(z, hist, pmax):  # type: ignore[no-untyped-def]
    """The order (2 to ``pmax``, at most 5) of the extrapolation through the last solutions
    that predicted ``z`` best, in the max-norm; ``hist`` the last six solutions, row 0 the latest.

    ``SolverOptions.warm_order``: the next step's warm start takes this order, chosen the
    way variable-order predictors choose theirs, by the error each would have made on the
    step just solved. Ties go to the lower order; with ``pmax = 3`` this is the cubic-or-
    quadratic rule of ``warm_order = 3`` bit for bit (the same sums in the same order).
    """
    z1 = hist[0]
    z2 = hist[1]
    z3 = hist[2]
    z4 = hist[3]
    z5 = hist[4]
    z6 = hist[5]
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


@jit_inline
def extrapolate(z, zwarm, hist, sv, geo):  # type: ignore[no-untyped-def]
    """The warm start of a smooth contact step: the last solutions extrapolated (O(h^3), or
    a higher order where it predicted the last step better: ``sv[SV_ORDER]``, O_WARM), with
    the complementarity variables kept >= 0."""
    n = z.shape[0]
    order_next = sv[SV_ORDER]
    if order_next == 5:
        for i in range(n):
            z[i] = 6.0 * zwarm[i] - 15.0 * hist[0, i] + 20.0 * hist[1, i] - 15.0 * hist[2, i] + 6.0 * hist[3, i] - hist[4, i]
    elif order_next == 4:
        for i in range(n):
            z[i] = 5.0 * zwarm[i] - 10.0 * hist[0, i] + 10.0 * hist[1, i] - 5.0 * hist[2, i] + hist[3, i]
    elif order_next == 3:
        for i in range(n):
            z[i] = 4.0 * zwarm[i] - 6.0 * hist[0, i] + 4.0 * hist[1, i] - hist[2, i]
    elif sv[SV_NCONT] >= 3:
        for i in range(n):
            z[i] = 3.0 * zwarm[i] - 3.0 * hist[0, i] + hist[1, i]
    else:
        for i in range(n):
            z[i] = 2.0 * zwarm[i] - hist[0, i]
    off = 6
    for kp in range(geo.pstart.shape[0] - 1):
        mk = geo.pstart[kp + 1] - geo.pstart[kp]
        for i in range(off + B_SIG, off + B_L + mk + 2):  # sigma, l_i, l_s, lam_n
            z[i] = max(z[i], 0.0)
        off += B_FIXED + mk


@jit_inline
def push_history(z, zwarm, hist, sv, warm_max):  # type: ignore[no-untyped-def]
    """A full-length contact step converged: its warm start ``zwarm`` (the last solution)
    joins the history, and the next step's extrapolation order is chosen (O_WARM >= 3)."""
    n = z.shape[0]
    if warm_max >= 5:
        for i in range(n):
            hist[5, i] = hist[4, i]
    if warm_max >= 4:
        for i in range(n):
            hist[4, i] = hist[3, i]
    if warm_max >= 3:
        for i in range(n):
            hist[3, i] = hist[2, i]
            hist[2, i] = hist[1, i]
    for i in range(n):
        hist[1, i] = hist[0, i]
        hist[0, i] = zwarm[i]
    ncont = int(sv[SV_NCONT])
    if warm_max >= 3 and ncont >= 4:
        # an order p needs p + 1 of the solutions before this step's, ncont of them contact solutions
        sv[SV_ORDER] = best_order(z, hist, min(warm_max, ncont - 1))
    sv[SV_NCONT] = ncont + 1


@jit_inline
def predict_flight(state, hc, model, opts, buf, scr, sv):  # type: ignore[no-untyped-def]
    """The free-flight prediction of a (sub-)step: ``(clear, flight, res)``. ``clear``: the
    explicit pose stays above the plane (else the flight solve is skipped); ``flight``: the
    free-flight solution clears the plane (then it is the exact solution, written into
    ``buf.z``)."""
    prm = model.prm
    geo = model.geo
    R = scr.R
    tmp3 = scr.tmp3
    sc = scr.sc
    z = buf.z
    z6 = buf.z6
    st6 = ST_NAN
    res6 = 0.0
    quat_step(state, 3, state, 10, hc, scr.qs, 0, state, 10, 1.0)
    quat_to_rot(scr.qs, QS_Q, R, 0)
    for i in range(3):
        tmp3[i] = state[i] + hc * (state[7 + i] + hc * sc[S_FEXT + i] / prm[P_MASS])
    clear = True
    for kp in range(geo.pstart.shape[0] - 1):
        if lowest_point(tmp3, R, prm, geo, kp, scr.tmp, LOW_TOL, scr.hts) < -FLIGHT_PRECHECK:
            clear = False
            break
    if clear:
        for i in range(6):
            z6[i] = z[i]
        st6, res6 = solve(z6, scr.prob6, buf.ws6, opts, scr.iters, False, 0.0, True)
        sv[SV_NIT] += scr.iters[0]
    flight = False
    if st6 == ST_OK:
        flight = flight_clears(state, z6, hc, prm, geo, scr)
    if flight:
        set_flight(z, z6, hc, model, scr)
    return clear, flight, res6


@jit_inline
def climb_ladder(state, hc, full, model, opts_set, buf, scr, lp, touching, sv, clear, rescued, depth):  # type: ignore[no-untyped-def]  # noqa: C901
    """The strategy ladder (:data:`~.guesses.STRATEGIES`) from the warm start ``buf.zsave``.

    Its last ``N_RESCUE_ONLY`` attempts only in a failed step's rescue pass (``rescued``).
    ``full``: a full-length step (the extrapolated warm start applies). Returns ``(st, res,
    res_best, flight, flight_failed)``: the status and residual of the attempt that ended
    the ladder, the smallest plain residual over the attempts (that attempt in
    ``lp.zbest``), whether the early lift-off check took free flight, and whether it ran
    and did not clear. Newton iterations and fallbacks go to ``sv``.
    """
    opts = opts_set[OPTS_FULL]
    accept_tol = opts[O_ACCEPT]
    smooth_stalled = opts[O_SMOOTH_STALLED] > 0.5
    z = buf.z
    zwarm = lp.zwarm
    n = z.shape[0]
    prob = scr.prob
    ws = buf.ws
    iters = scr.iters
    st = ST_NAN
    res = math.inf
    for i in range(n):
        zwarm[i] = z[i]
    res_best = math.inf
    flight = False
    flight_failed = False
    n_attempts = N_ATTEMPTS if rescued else N_ATTEMPTS - N_RESCUE_ONLY
    for attempt in range(n_attempts):
        if attempt == FLIGHT_BEFORE and not clear and norm3(state[10:13]) * hc <= EARLY_FLIGHT_TURN:
            # lift-off that the explicit pre-check hid: before the costly smoothing
            # strategies, the free-flight solution, if it clears the plane and turns the body
            # little (no corner can dip through the plane within the step), is the exact
            # solution of the step
            code, res6 = lift_off(state, buf, hc, model, opts, EARLY_FLIGHT_TURN, scr)
            sv[SV_NIT] += iters[0]
            flight_failed = code == 0
            if code == 1:
                flight = True
                st = ST_OK
                res = res6
                break
        smooth = STRATEGY_SMOOTH[attempt]
        if smooth > 0.0 and res_best <= accept_tol and not smooth_stalled:
            # an attempt already stalled within accept_tol, so the (sub-)step will not be
            # halved for want of convergence: the smoothing continuations are not tried for
            # a lower stall, the cheap strategies still are for a converged solution
            continue
        guess = STRATEGY_GUESS[attempt]
        if guess == G_WARM and attempt == 0 and sv[SV_NCONT] >= 2 and full:
            extrapolate(z, zwarm, lp.hist, sv, model.geo)
        elif guess == G_WARM:
            for i in range(n):
                z[i] = zwarm[i]
        elif not build_guess(guess, z, buf.zsave, state, hc, model, scr, touching, lp.edir):
            continue
        if rescued:
            opts_use = opts_set[OPTS_RESCUE]
        elif smooth > 0.0:
            opts_use = opts_set[OPTS_SMOOTH]
        elif depth > 0 or GUESS_FULL_MAXIT[guess]:
            opts_use = opts
        else:
            opts_use = opts_set[OPTS_FAST]
        # the first attempt may start with chord iterations (SolverOptions.chord_iter)
        st, res = solve(z, prob, ws, opts_use, iters, STRATEGY_PROJECT[attempt], smooth, attempt == 0)
        sv[SV_NIT] += iters[0]
        sv[SV_FB] += iters[1] + (1 if attempt > 0 else 0)
        if st == ST_OK:
            break
        # remember the attempt with the smallest residual of the model itself (a smoothed
        # attempt reports its smoothed residual)
        if smooth > 0.0:
            res = plain_residual(z, prob, ws)
        if res < res_best:
            res_best = res
            for i in range(n):
                lp.zbest[i] = z[i]
    return st, res, res_best, flight, flight_failed


@jit_inline
def contact_warm_start(state, hc, model, buf, scr, touching):  # type: ignore[no-untyped-def]
    """Keep the warm start in ``buf.zsave``; blocks that were not touching get a landing guess."""
    z = buf.z
    geo = model.geo
    for i in range(z.shape[0]):
        buf.zsave[i] = z[i]
    quat_to_rot(state, 3, scr.R, 0)
    off = 6
    for kp in range(geo.pstart.shape[0] - 1):
        mk = geo.pstart[kp + 1] - geo.pstart[kp]
        if touching[kp] == 0:
            landing_guess(z, off, kp, (state[0:3], state[7:10], state[10:13]), hc, model, scr, LOW_TOL, False)
        off += B_FIXED + mk


@jit_inline
def solve_substep(state, hc, full, model, opts_set, buf, scr, lp, touching, sv, rescued, depth):  # type: ignore[no-untyped-def]
    """Solve the (sub-)step ``hc`` from ``state`` (step data in ``scr.sc``, warm start in ``buf.z``).

    First the free-flight prediction (:func:`predict_flight`); then the contact system from
    the warm start and the ladder (:func:`climb_ladder`); then, for a lift-off that the
    explicit pre-check hid, free flight once more (also when the early check refused it for
    turning too far); and last, a best attempt within ``opts[O_ACCEPT]`` is kept (a loose
    step) rather than sub-stepped: where the residual stalls just above tol (a rounding
    floor at metres per second) the sub-steps fare worse, as that floor grows as the step
    shrinks. ``full``: a full-length step; ``rescued``: the rescue pass; ``depth``: the
    halvings so far. Returns ``(st, res, res_best, flight, free, loose)``: the status and
    residual of the solution in ``buf.z``, the best attempt's residual (its ``z`` in
    ``lp.zbest``), solved in free flight by the prediction or the early lift-off check, by
    the late one, and kept loose.
    """
    opts = opts_set[OPTS_FULL]
    clear, flight, res6 = predict_flight(state, hc, model, opts, buf, scr, sv)
    if flight:
        return ST_OK, res6, math.inf, True, False, False
    contact_warm_start(state, hc, model, buf, scr, touching)
    st, res, res_best, flight, flight_failed = climb_ladder(
        state, hc, full, model, opts_set, buf, scr, lp, touching, sv, clear, rescued, depth
    )
    free = False
    loose = False
    if st != ST_OK and not clear and not flight_failed:
        code, res6 = lift_off(state, buf, hc, model, opts, math.inf, scr)
        sv[SV_NIT] += scr.iters[0]
        if code == 1:
            st = ST_OK
            res = res6
            free = True
    if st != ST_OK and res_best <= opts[O_ACCEPT]:
        res = res_best
        for i in range(buf.z.shape[0]):
            buf.z[i] = lp.zbest[i]
        st = ST_OK
        loose = True
    return st, res, res_best, flight, free, loose
