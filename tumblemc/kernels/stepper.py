"""The time loop: field, early decision, commit and record, one step after another.

One call of :func:`run` integrates one robot for ``n_steps`` steps of length ``h`` (scaled
units) and writes ``rec`` rows every ``record_every`` steps (columns ``R_*``). A step is
:func:`~.step.one_step` (sub-steps, refinement, rescue), each (sub-)step's solve
:func:`~.substep.solve_substep` (free flight, the warm start, the strategy ladder of
:mod:`.guesses`); the run's records are in :mod:`.runtypes`.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import jit, jit_alloc, jit_inline
from .decide import DECIDE_EVERY, climb_bound
from .field import field_work_bound
from .geometry import N_CG, N_QS, Geometry
from .layout import (
    L_KE,
    N_LED,
    N_SC,
    N_SV,
    O_DECIDE,
    O_DECIDE_NEED,
    O_DECIDE_STEP,
    O_MAXIT,
    O_NWORK,
    O_RESCUE,
    O_STALL,
    P_G,
    P_MASS,
    P_U,
    ST_DECIDED,
    ST_NAN,
    ST_OK,
    ST_STOPPED,
    SV_ANY_TOUCH,
    SV_AREA,
    SV_ECP,
    SV_FAIL,
    SV_IMPULSE,
    SV_LOOSE,
    SV_ORDER,
    SV_T,
)
from .ledger import N_LW, kinetic_energy
from .newton import Workspace
from .recording import empty_record, n_records, recentre, recentre_undo, record_row, reset_counters
from .residual import Problem
from .runtypes import Buffers, Clock, Frame, Loop, Model, Scratch, Start, make_buffers
from .step import one_step
from .substep import FAST_MAXIT, SMOOTH_MAXIT


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
    h = clock.h
    z = buf.z
    n = z.shape[0]
    K = geo.pstart.shape[0] - 1
    scr = make_scratch(model)
    # no factors from another run (a batch reuses its buffers): solve's chord start waits
    # for this run's first Newton matrix
    buf.ws.lu_h[0] = 0.0
    buf.ws6.lu_h[0] = 0.0
    opts_set = solver_options(opts)
    lp = Loop(
        zwarm=np.zeros(n),
        zbest=np.zeros(n),
        hist=np.zeros((6, n)),
        edir=np.zeros(3),
        ls=np.zeros(N_LED),
        lw=np.zeros(N_LW),
        xoff=np.zeros(3),
        xw=np.zeros(3),
        refine=Frame(np.zeros(state.shape[0]), np.zeros(n), np.zeros(K, np.int64), np.zeros(N_LED), np.zeros(N_SV)),
        rescue=Frame(np.zeros(state.shape[0]), np.zeros(n), np.zeros(K, np.int64), np.zeros(N_LED), np.zeros(N_SV)),
    )
    live = Frame(state, z, np.zeros(K, np.int64), np.zeros(N_LED), np.zeros(N_SV))
    live_start = Frame(state, buf.zsave, live.touching, live.led, live.sv)
    sv = live.sv
    led = live.led
    if start.touch0:
        live.touching[:] = 1
    sv[SV_T] = start.t0
    sv[SV_ORDER] = 2
    sv[SV_ECP] = -1
    # a contact (sub-)step whose normal impulse does more positive work than this is solved
    # again as halves (O_NWORK; a rigid contact cannot push: at a landing the robot crosses
    # several thicknesses in a step and the end-pose contact throws it back out)
    nwork_max = opts[O_NWORK] * (prm[P_MASS] * prm[P_G] + field_work_bound(prm, h))
    led[L_KE] = kinetic_energy(state, prm, lp.lw)
    for i in range(3):
        lp.xw[i] = state[i]
    record_row(rec, 0, state, z, sv, led, lp.xoff, prm)  # the start, with no contact summary yet
    sv[SV_AREA] = start.area0
    sv[SV_ANY_TOUCH] = 1.0 if start.touch0 else 0.0
    status, failed_total, t_decided = march(model, opts, start, clock, rec, buf, scr, opts_set, lp, live, live_start, nwork_max)
    # the final state and the last solution's positions in the caller's frame
    recentre_undo(state, z, lp.xoff, geo.pstart)
    return status, failed_total, t_decided


@jit
def march(model, opts, start, clock, rec, buf, scr, opts_set, lp, live, live_start, nwork_max):  # type: ignore[no-untyped-def]
    """The steps of :func:`run` once its records are set up; returns ``(status, failed_steps, t_decided)``.

    Compiled without the runtime and with every per-step stage inlined (:func:`~._jit.jit_inline`):
    a step makes no call but to the solver's own kernels.
    """
    prm = model.prm
    geo = model.geo
    state = live.state
    z = live.z
    sv = live.sv
    led = live.led
    h = clock.h
    n_steps = clock.n_steps
    # early decision (kernels/decide.py): the window's start position, the energy scale
    # without the potential released, and the first time the bound decided
    decide = int(opts[O_DECIDE])
    decide_need = opts[O_DECIDE_NEED]
    decide_step = int(opts[O_DECIDE_STEP])
    t_end = start.t0 + n_steps * h
    eref0 = led[L_KE] + prm[P_MASS] * prm[P_G] + field_work_bound(prm, n_steps * h)
    t_decided = math.nan
    row = 0
    status = ST_OK
    failed_total = 0
    for step in range(n_steps):
        recentre(state, z, lp.hist, lp.xoff, prm, geo.pstart)
        status, failed, loose, impulse = one_step(
            step, h, start.t0, model, opts_set, buf, scr, lp, live, live_start, failed_total, nwork_max
        )
        if failed:
            sv[SV_FAIL] += 1
            failed_total += 1
        elif loose:
            sv[SV_LOOSE] += 1
            if impulse:
                sv[SV_IMPULSE] += 1
        if status == ST_NAN or status == ST_STOPPED:
            break
        if (step + 1) % clock.record_every == 0 or step == n_steps - 1:
            row += 1
            record_row(rec, row, state, z, sv, led, lp.xoff, prm)
            reset_counters(sv)
        if decide > 0 and step + 1 >= decide_step and step < n_steps - 1 and math.isnan(t_decided):
            if decide_falls_short(step, decide_step, prm, state, led, sv, lp, scr.tmp, t_end, eref0, decide_need):
                t_decided = sv[SV_T]
                if decide == 2:
                    # the last record row holds the state at the decision (rows between: unwritten)
                    record_row(rec, rec.shape[0] - 1, state, z, sv, led, lp.xoff, prm)
                    status = ST_DECIDED
                    break
    return status, failed_total, t_decided


@jit_inline
def decide_falls_short(step, decide_step, prm, state, led, sv, lp, x, t_end, eref0, need):  # type: ignore[no-untyped-def]
    """The early decision after step ``step`` (:mod:`.decide`): at the window's start keep
    the position in ``lp.xw``; every ``DECIDE_EVERY`` steps after it, whether the uphill
    progress since then plus :func:`~.decide.climb_bound` falls short of ``need``. ``x``
    (3) receives the position in the caller's frame."""
    if step + 1 == decide_step:
        for i in range(3):
            lp.xw[i] = state[i] + lp.xoff[i]
        return False
    if (step + 1 - decide_step) % DECIDE_EVERY != 0:
        return False
    prog = 0.0
    for i in range(3):
        x[i] = state[i] + lp.xoff[i]
        prog += prm[P_U + i] * (x[i] - lp.xw[i])
    return prog + climb_bound(prm, x, led, sv[SV_T], t_end, eref0) < need


@jit_alloc
def make_scratch(model):  # type: ignore[no-untyped-def]
    """The time loop's temporaries for ``model`` (:class:`~.runtypes.Scratch`)."""
    prm = model.prm
    geo = model.geo
    K = geo.pstart.shape[0] - 1
    sc = np.zeros(N_SC)
    nsup = 1
    for kp in range(K):
        nsup = max(nsup, geo.sup_start[kp + 1] - geo.sup_start[kp])
    return Scratch(
        sc=sc,
        R=np.zeros(9),  # 3x3 row-major
        tmp=np.zeros(3),
        tmp2=np.zeros(3),
        tmp3=np.zeros(3),
        cg=np.zeros(N_CG),  # constraint_eval's gradient and Hessian
        qs=np.zeros(N_QS),  # quat_step's block: Q+ at QS_Q
        iters=np.zeros(3, np.int64),
        prob=Problem(sc=sc, prm=prm, ctype=geo.ctype, cdata=geo.cdata, pstart=geo.pstart),
        prob6=Problem(sc=sc, prm=prm, ctype=geo.ctype, cdata=geo.cdata, pstart=geo.pstart[:1]),
        hts=np.zeros(nsup),  # lowest_point's support heights
    )


@jit_alloc
def solver_options(opts):  # type: ignore[no-untyped-def]
    """The attempts' solver options (``substep.OPTS_*``): the run's, fast, smoothing, rescue."""
    # plain and projected attempts that have not converged after FAST_MAXIT iterations
    # rarely do: move on to the next strategy (the smoothing continuation and sub-steps
    # keep max_iter)
    opts_fast = opts.copy()
    opts_fast[O_MAXIT] = min(opts[O_MAXIT], FAST_MAXIT)
    # the smoothing continuation converges slowly (100-300 iterations) but finds the
    # impulsive feature switches that the plain attempts miss; it only runs at such events
    opts_smooth = opts.copy()
    opts_smooth[O_MAXIT] = max(opts[O_MAXIT], SMOOTH_MAXIT)
    # a failed step's rescue pass: every attempt up to O_RESCUE iterations, no stall window
    opts_rescue = opts.copy()
    opts_rescue[O_MAXIT] = max(opts[O_MAXIT], SMOOTH_MAXIT, opts[O_RESCUE])
    opts_rescue[O_STALL] = 0.0
    return (opts, opts_fast, opts_smooth, opts_rescue)


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
