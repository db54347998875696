"""One time step: its sub-steps, halving, landing refinement, rescue pass and commits.

:func:`one_step` advances the run by one step ``h``. Each (sub-)step is solved by
:func:`~.substep.solve_substep`; a (sub-)step that does not converge is halved, down to
``h / 2**opts[O_MAXDEPTH]``; a converged contact (sub-)step whose normal impulse does too
much positive work is refined (solved again as halves); a step that fails at every depth is
solved once more from its start (the rescue pass); what is kept is committed by
:func:`commit`. The policies are documented at :func:`~.stepper.run`.
"""

from __future__ import annotations

import math

from ._jit import jit_inline
from .contact import CONTACT_LN_TOL, contact_state, impulse_consistent, peel_step, prepare_step
from .geometry import QS_Q, quat_step, quat_to_rot
from .guesses import LOW_TOL
from .layout import (
    B_FIXED,
    B_L,
    L_WN,
    N_SNAP,
    N_SNAP_STEP,
    O_IMPULSE,
    O_MAXDEPTH,
    O_MAXFAIL,
    O_REFINE_HALVE,
    O_RESCUE,
    O_WARM,
    P_PEEL,
    P_POSE_W0,
    ST_NAN,
    ST_OK,
    ST_STOPPED,
    SV_ANY_TOUCH,
    SV_AREA,
    SV_ECP,
    SV_LNSUM,
    SV_MODE,
    SV_NCONT,
    SV_ORDER,
    SV_PEEL,
    SV_PEEL_LEFT,
    SV_PEN,
    SV_RES,
    SV_SLIP,
    SV_SUB,
    SV_T,
)
from .ledger import ledger_add, ledger_step
from .runtypes import copy_frame
from .substep import OPTS_FULL, push_history, solve_substep
from .support import lowest_point


@jit_inline
def one_step(step, h, t0, model, opts_set, buf, scr, lp, live, live_start, failed_total, nwork_max):  # type: ignore[no-untyped-def]  # noqa: C901
    """Advance the run by step ``step`` (length ``h``, the run starting at ``t0``).

    ``live`` is the run's frame (:class:`~.runtypes.Frame`: state, ``buf.z``, touching,
    ledger, scalars), ``live_start`` the same with ``buf.zsave`` for ``z`` (the (sub-)step's
    warm start, what its snapshots keep). ``failed_total``: failed steps so far (O_MAXFAIL).
    Returns ``(status, failed, loose, impulse)``: ``ST_OK``, ``ST_NAN`` (a non-finite
    solution) or ``ST_STOPPED`` (the failure limit), and whether the step failed, was kept
    loose, and kept by O_IMPULSE.
    """
    opts = opts_set[OPTS_FULL]
    prm = model.prm
    state = live.state
    sv = live.sv
    z = buf.z
    zsave = buf.zsave
    n = z.shape[0]
    maxdepth = int(opts[O_MAXDEPTH])
    maxfail = int(opts[O_MAXFAIL])
    rescue_on = opts[O_RESCUE] > 0.0
    ref_halve_max = int(opts[O_REFINE_HALVE])
    warm_max = int(opts[O_WARM])
    ls = lp.ls
    status = ST_OK
    remaining = h
    hc = h
    depth = 0
    step_failed = False
    step_loose = False
    step_impulse = False  # a (sub-)step kept by O_IMPULSE (also loose)
    refine_cap = maxdepth  # landings are halved (O_NWORK) while depth < refine_cap
    refining = False  # the step is being refined: its start is in lp.refine
    restart = False  # return to lp.refine: the refinement failed or did not help
    step_snap = False  # lp.rescue holds this step's start
    rescued = False  # the step is being solved again (O_RESCUE)
    ref_end = 0.0  # what remains of the step once the refused (sub-)step is refined
    snap_depth = 0  # the depth of the step's first refusal
    snap_remaining = 0.0  # what remained of the step at the refusal
    snap_loose = False  # the step's loose flags at the refusal
    snap_impulse = False
    wn_coarse = 0.0  # the positive normal work of the refused step
    wn_ref = 0.0  # the same, summed over the refinement's sub-steps so far
    ref_halved = 0  # halvings of the refinement's sub-steps for want of convergence (O_REFINE_HALVE)
    while remaining > 1e-12 * h:
        if restart:
            copy_frame(lp.refine, live, N_SNAP)
            refining = False
            restart = False
            remaining = snap_remaining
            hc = h * 0.5**snap_depth
            depth = snap_depth
            step_loose = snap_loose
            step_impulse = snap_impulse
        if hc > remaining:
            hc = remaining
        prepare_step(state, sv[SV_T], hc, prm, sv[SV_AREA] + sv[SV_PEEL], sv[SV_ANY_TOUCH] > 0.5, scr)
        st, res, res_best, flight, free, loose = solve_substep(
            state, hc, hc == h, model, opts_set, buf, scr, lp, live.touching, sv, rescued, depth
        )
        have_ls = False  # ls holds this (sub-)step's ledger terms
        unsolved = False  # kept by O_IMPULSE: not a warm start to extrapolate from (as if failed)
        step_loose = step_loose or loose
        if not flight:
            if st != ST_OK and refining and ref_halved < ref_halve_max and depth < maxdepth:
                # a sub-step of a refined landing does not converge: halve it, at most
                # O_REFINE_HALVE times within the refinement (the rest of the refined step goes
                # on at that length, so the refinement stays bounded)
                hc, depth = halve(z, zsave, sv, hc, depth)
                ref_halved += 1
                continue
            if st != ST_OK and refining:
                # a sub-step of a refined landing does not converge: start the step again and
                # refine less deep (at the depth of the first refusal the check is off: the
                # converged step that asked for refinement is solved again and kept)
                restart = True
                refine_cap = max(depth - ref_halved - 1, snap_depth)
                continue
            if st != ST_OK and depth < maxdepth:
                if rescue_on and not step_snap:
                    copy_frame(live_start, lp.rescue, N_SNAP_STEP)
                    step_snap = True
                hc, depth = halve(z, zsave, sv, hc, depth)
                continue
            if st != ST_OK and opts[O_IMPULSE] > 0.0 and res_best < math.inf:
                # nothing converged at the smallest sub-step, but the best attempt balances the
                # step's momenta to O_IMPULSE of its impulses (a landing in a tiny sub-step,
                # where the forces are impulse / hc): keep it, as loose
                for i in range(n):
                    z[i] = lp.zbest[i]
                if impulse_consistent(z, state, hc, scr.prob, buf.ws, opts[O_IMPULSE]):
                    st = ST_OK
                    res = res_best
                    step_loose = True
                    step_impulse = True
                    unsolved = True
            if st != ST_OK and rescue_on and not rescued:
                # nothing converged at the smallest sub-step: before counting a failure, solve
                # the whole step once more from its start with every attempt allowed O_RESCUE
                # iterations and no stall window (docs/notes/solver_gaps.md)
                if step_snap:
                    copy_frame(lp.rescue, live_start, N_SNAP_STEP)
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
                # nothing converged at the smallest sub-step: keep the best attempt and count
                # the step as failed
                step_failed = True
                res = res_best
                zkeep = lp.zbest if res_best < math.inf else zsave  # no residual at all: zbest is an older step's
                for i in range(n):
                    z[i] = zkeep[i]
                if maxfail > 0 and failed_total + 1 >= maxfail:
                    # the caller asked to give up: the rest of this step would run at the
                    # smallest sub-step
                    status = ST_STOPPED
                    break
            if st == ST_OK and not free and nwork_max > 0.0 and depth < refine_cap:
                quat_step(state, 3, z, 3, hc, scr.qs, 0, state, 10, (1.0 - prm[P_POSE_W0]))
                ledger_step(
                    state, z, hc, scr.qs, False, sv[SV_ANY_TOUCH] > 0.5, sv[SV_AREA] + sv[SV_PEEL], prm, model.geo.pstart, scr.sc, lp.lw, ls
                )
                have_ls = True
                if ls[L_WN] > nwork_max:
                    if not refining:
                        # nothing of this sub-step is committed yet: keep its start, to which a
                        # refinement that fails or does not help returns
                        if rescue_on and not step_snap and remaining == h:
                            copy_frame(live_start, lp.rescue, N_SNAP_STEP)
                            step_snap = True
                        refining = True
                        ref_halved = 0
                        snap_depth = depth
                        wn_coarse = ls[L_WN]
                        wn_ref = 0.0
                        copy_frame(live_start, lp.refine, N_SNAP)
                        ref_end = remaining - hc
                        snap_remaining = remaining
                        snap_loose = step_loose
                        snap_impulse = step_impulse
                    hc, depth = halve(z, zsave, sv, hc, depth)
                    continue
        if refining:
            # the refinement is kept only if its sub-steps' positive normal work stays below
            # that of the step it replaces (and its sub-steps are finite)
            finite = True
            for i in range(n):
                if not z[i] == z[i]:
                    finite = False
            if not finite:
                restart = True
                refine_cap = snap_depth
                continue
            if not have_ls:
                quat_step(state, 3, z, 3, hc, scr.qs, 0, state, 10, (1.0 - prm[P_POSE_W0]))
                ledger_step(
                    state,
                    z,
                    hc,
                    scr.qs,
                    flight or free,
                    sv[SV_ANY_TOUCH] > 0.5,
                    sv[SV_AREA] + sv[SV_PEEL],
                    prm,
                    model.geo.pstart,
                    scr.sc,
                    lp.lw,
                    ls,
                )
                have_ls = True
            wn_ref += max(ls[L_WN], 0.0)
            if not wn_ref <= wn_coarse:  # (NaN restarts too)
                restart = True
                refine_cap = snap_depth
                continue
        if res > sv[SV_RES]:
            sv[SV_RES] = res
        if flight or hc != h or st != ST_OK or unsolved:
            sv[SV_NCONT] = 0
            sv[SV_ORDER] = 2
        else:
            push_history(z, lp.zwarm, lp.hist, sv, warm_max)
        if not commit(step, h, t0, hc, remaining, flight or free, have_ls, model, scr, lp, live):
            status = ST_NAN
            break
        remaining -= hc
        if refining and remaining <= ref_end + 1e-12 * h:
            # the refused (sub-)step is refined and kept: the rest of the step goes on at the
            # refused step's length, as it would have without the refusal
            refining = False
            hc = h * 0.5**snap_depth
            depth = snap_depth
    return status, step_failed, step_loose, step_impulse


@jit_inline
def halve(z, zsave, sv, hc, depth):  # type: ignore[no-untyped-def]
    """Solve the (sub-)step again as its first half, from its warm start: ``(hc / 2, depth + 1)``."""
    for i in range(z.shape[0]):
        z[i] = zsave[i]
    sv[SV_SUB] += 1
    return hc * 0.5, depth + 1


@jit_inline
def commit(step, h, t0, hc, remaining, free, have_ls, model, scr, lp, live):  # type: ignore[no-untyped-def]
    """Commit the (sub-)step ``hc`` solved in ``buf.z`` (``live.z``): the ledger, the state,
    the time, the contact state, the touching flags and the penetration. ``free``: solved
    without contact; ``have_ls``: ``lp.ls`` already holds its ledger terms. Returns False
    (and changes nothing) if the solution is not finite."""
    prm = model.prm
    geo = model.geo
    state = live.state
    z = live.z
    sv = live.sv
    for i in range(z.shape[0]):
        if not z[i] == z[i]:
            return False
    qs = scr.qs
    quat_step(state, 3, z, 3, hc, qs, 0, state, 10, (1.0 - prm[P_POSE_W0]))
    if not have_ls:
        ledger_step(state, z, hc, qs, free, sv[SV_ANY_TOUCH] > 0.5, sv[SV_AREA] + sv[SV_PEEL], prm, geo.pstart, scr.sc, lp.lw, lp.ls)
    ledger_add(live.led, lp.ls)
    area_old = sv[SV_AREA]
    for i in range(3):
        state[i] += hc * z[i]
        state[7 + i] = z[i]
        state[10 + i] = z[3 + i]
    for i in range(4):
        state[3 + i] = qs[QS_Q + i]
    sv[SV_T] += hc
    if remaining - hc <= 1e-12 * h:
        sv[SV_T] = t0 + (step + 1) * h  # whole steps: no accumulated rounding in time
    mode, area, lnsum, slip, ecp_off = contact_state(z, state, prm, geo, scr)
    sv[SV_MODE] = mode
    sv[SV_AREA] = area
    sv[SV_LNSUM] = lnsum
    sv[SV_SLIP] = slip
    sv[SV_ECP] = ecp_off
    if prm[P_PEEL] > 0.5:
        sv[SV_PEEL], sv[SV_PEEL_LEFT] = peel_step(sv[SV_PEEL], sv[SV_PEEL_LEFT], area_old, area, hc, z, prm)
    sv[SV_ANY_TOUCH] = 1.0 if mode > 0 else 0.0
    off = 6
    for kp in range(geo.pstart.shape[0] - 1):
        mk = geo.pstart[kp + 1] - geo.pstart[kp]
        live.touching[kp] = 1 if z[off + B_L + mk + 1] > CONTACT_LN_TOL else 0
        off += B_FIXED + mk
    R = scr.R
    quat_to_rot(state, 3, R, 0)
    for kp in range(geo.pstart.shape[0] - 1):
        pen = -lowest_point(state[0:3], R, prm, geo, kp, scr.tmp, LOW_TOL, scr.hts)
        if pen > sv[SV_PEN]:
            sv[SV_PEN] = pen
    return True
