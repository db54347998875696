"""Many independent simulations in one call: parameter rows in, summary rows out.

One dask task of the Monte Carlo engine calls :func:`run_batch` once for a few dozen runs
that share a shape and a time grid, so that a task does a second or so of work instead
of one run, and the Python overhead per run is one row of arrays.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ._jit import jit, jit_alloc
from .field import field_energy_range, field_work_bound
from .layout import (
    ENERGY_GAIN_TOL,
    L_GAIN,
    L_KE,
    L_MAGMAX,
    L_POTMAX,
    L_XGAIN,
    O_DECIDE,
    O_DECIDE_NEED,
    O_DECIDE_STEP,
    P_FIELD_ON,
    P_G,
    P_MASS,
    P_O,
    P_T,
    P_U,
    R_FALLBACK,
    R_IMPULSE,
    R_LED,
    R_LOOSE,
    R_NIT,
    R_PEN,
    R_Q,
    R_SUB,
    R_T,
    R_X,
    ST_DECIDED,
    ST_OK,
    ST_STOPPED,
)
from .stepper import Clock, Model, Start, run

# ---- summary columns (one row per run) ----------------------------------------------
OUT_STATUS = 0  # BATCH_* status below
OUT_FAILED = 1  # steps that did not converge at the smallest sub-step
OUT_PROGRESS = 2  # uphill progress over the measurement window (scaled length)
OUT_WINDOW = 3  # length of the measurement window (scaled time)
OUT_NIT = 4  # Newton iterations, total
OUT_SUB = 5  # extra sub-steps, total
OUT_FALLBACK = 6  # damped/gradient fallbacks, total
OUT_PEN = 7  # max penetration (scaled length)
OUT_LOOSE = 8  # steps kept at a residual between tol and accept_tol, total
OUT_EGAIN = 9  # numerical energy gain of the energy ledger (kernels/ledger.py)
OUT_EREF = 10  # the energy scale of its tolerance (model/energy.py: energy_reference)
OUT_LATERAL = 11  # lateral drift of the CM along the plane tangent t over the run (scaled length)
OUT_HEADING = 12  # heading change, degrees (heading_change below)
OUT_IMPULSE = 13  # steps kept by impulse_accept_tol alone, total (a subset of OUT_LOOSE)
OUT_DECIDED = 14  # time (scaled, from the run's start) at which the energy bound decided failure; NaN: never
OUT_STOPPED = 15  # 1: the run stopped there (decided early; progress and window up to then)
OUT_STEPS = 16  # steps taken
N_OUT = 17

# ---- run status (also the engine's ``status`` flag values) -------------------------
BATCH_OK = 0  # finished, every step converged
BATCH_FAILED_STEPS = 1  # finished, but some steps did not converge at the smallest sub-step
BATCH_NONFINITE = 2  # stopped early on a non-finite state
BATCH_ERROR = 3  # never ran: invalid parameters (set by the Python layer)
BATCH_ENERGY_GAIN = 4  # finished, every step converged, but the ledger's numerical energy gain is above tolerance


Batch = namedtuple("Batch", ["prms", "states0", "hs", "area0", "touch0", "need", "decide"])
Batch.__doc__ = """Runs of one shape on one time grid, one row each: ``prms`` float64[B, N_PRM], ``states0``
float64[B, 13], ``hs`` float64[B], ``area0`` float64[B], ``touch0`` bool[B], ``need``
float64[B] and ``decide`` int64[B] (see :func:`run_batch`)."""


@jit
def heading_change(q, iq, prm):  # type: ignore[no-untyped-def]
    """Heading change (degrees) of the pose ``q[iq:iq+4]``: the angle about the plane normal
    ``n`` from the plane tangent ``t`` (the start heading of the body x axis, the paper's
    tumbling axis) to the body x axis projected onto the plane, folded to ``(-90, 90]`` (an
    axis, not a direction: tumbling over the side flips it)."""
    w, x, y, z = q[iq], q[iq + 1], q[iq + 2], q[iq + 3]
    a0 = w * w + x * x - y * y - z * z  # first column of R: body x in the world frame
    a1 = 2.0 * (x * y + w * z)
    a2 = 2.0 * (x * z - w * y)
    at = a0 * prm[P_T] + a1 * prm[P_T + 1] + a2 * prm[P_T + 2]
    ao = a0 * prm[P_O] + a1 * prm[P_O + 1] + a2 * prm[P_O + 2]
    psi = math.degrees(math.atan2(ao, at))
    if psi > 90.0:
        psi -= 180.0
    elif psi <= -90.0:
        psi += 180.0
    return psi


@jit_alloc
def run_batch(geo, batch, grid, opts, buf, rec, out):  # type: ignore[no-untyped-def]
    """Simulate ``B`` independent runs of one shape on one time grid.

    Parameters
    ----------
    geo : Geometry
        The shape, shared by every run (scaled units).
    batch : Batch
        The runs: ``prms``, ``states0``, ``hs``, ``area0``, ``touch0`` below.
    prms : float64[B, N_PRM]
        Kernel parameters of each run (scaled, as built by ``simulate.prepare``).
    states0 : float64[B, 13]
        Initial states (scaled); not modified.
    hs : float64[B]
        Step length of each run (scaled time; equal ``dt`` may scale differently).
    area0 : float64[B]
        Adhering area at ``t = 0`` (scaled).
    touch0 : bool[B]
        Whether each robot starts touching the plane.
    need : float64[B]
        Uphill progress over the measurement window that success needs (scaled length).
    decide : int64[B]
        Early decision per run (``opts[O_DECIDE]`` of :func:`~.stepper.run`): 0 off, 1 note
        when the energy bound decides failure (``OUT_DECIDED``), 2 also stop there.
    grid : (n_steps, record_every, i0_row), ints
        Steps per run, recording stride and the record row that starts the measurement
        window (``i0_row * record_every`` steps after the start).
    opts : float64[N_OPT]
    buf : Buffers
        Solver workspaces and unknowns (:func:`~.stepper.make_buffers`), reused by all runs.
    rec : float64[n_records(n_steps, record_every), N_REC]
        Record workspace, reused by all runs.
    out : float64[B, N_OUT]
        Receives one summary row per run (columns ``B_*``).

    Notes
    -----
    Each run is exactly :func:`tumblemc.kernels.stepper.run` from the same initial data
    as :func:`tumblemc.simulate`; nothing is shared between runs except workspaces, so a
    run's result does not depend on its batch or its position in it. A run stopped by an
    early decision reports its progress, window, counters and energy ledger up to the
    decision (``OUT_STOPPED`` = 1).
    """
    prms, states0, hs, area0, touch0, need, decide = batch
    n_steps, record_every, i0_row = grid
    B = prms.shape[0]
    rows = rec.shape[0]
    z = buf.z
    z6 = buf.z6
    zsave = buf.zsave
    state = np.zeros(13)
    opts_b = opts.copy()
    opts_b[O_DECIDE_STEP] = i0_row * record_every
    for b in range(B):
        opts_b[O_DECIDE] = decide[b]
        opts_b[O_DECIDE_NEED] = need[b]
        rec[:, :] = 0.0
        z[:] = 0.0
        z6[:] = 0.0
        zsave[:] = 0.0
        state[:] = states0[b]
        status, failed, t_decided = run(
            Model(prms[b], geo), opts_b, Start(state, 0.0, area0[b], touch0[b]), Clock(hs[b], n_steps, record_every), rec, buf
        )
        prog = 0.0
        for i in range(3):
            prog += prms[b, P_U + i] * (rec[rows - 1, R_X + i] - rec[i0_row, R_X + i])
        nit = 0.0
        sub = 0.0
        fb = 0.0
        pen = 0.0
        loose = 0.0
        impulse = 0.0
        for r in range(1, rows):
            loose += rec[r, R_LOOSE]
            impulse += rec[r, R_IMPULSE]
            nit += rec[r, R_NIT]
            sub += rec[r, R_SUB]
            fb += rec[r, R_FALLBACK]
            pen = max(pen, rec[r, R_PEN])
        # the energy ledger's two accounts (model/energy.py: energy_accounts): the contact
        # gain against the energy scale with the field's work bound, the energy excess
        # against the energy the run received; the larger ratio decides
        t_run = rec[rows - 1, R_T] - rec[0, R_T]
        base = rec[0, R_LED + L_KE] + prms[b, P_MASS] * prms[b, P_G] + rec[rows - 1, R_LED + L_POTMAX]
        eref = base
        if prms[b, P_FIELD_ON] > 0.5:
            # a run stopped by an early decision: the whole run's field bound (its tolerance
            # and the field_work_bound column are the whole run's; the gain only grows)
            eref += field_work_bound(prms[b], n_steps * hs[b] if status == ST_DECIDED else t_run)
        gain = rec[rows - 1, R_LED + L_GAIN]
        xref = base + rec[rows - 1, R_LED + L_MAGMAX] + field_energy_range(prms[b])
        xgain = rec[rows - 1, R_LED + L_XGAIN]
        if xgain * eref > gain * xref:  # xgain / xref > gain / eref (both references > 0)
            gain = xgain
            eref = xref
        if status == ST_STOPPED:  # gave up after opts[O_MAXFAIL] failed steps
            code = BATCH_FAILED_STEPS
            prog = np.nan
        elif (status != ST_OK and status != ST_DECIDED) or not np.isfinite(prog):
            code = BATCH_NONFINITE  # the stepper stops otherwise only on a non-finite state
        elif failed > 0:
            code = BATCH_FAILED_STEPS
        elif gain / eref > ENERGY_GAIN_TOL:
            code = BATCH_ENERGY_GAIN
        else:
            code = BATCH_OK
        out[b, OUT_STATUS] = code
        out[b, OUT_FAILED] = failed
        out[b, OUT_PROGRESS] = prog
        out[b, OUT_WINDOW] = rec[rows - 1, R_T] - rec[i0_row, R_T]
        out[b, OUT_NIT] = nit
        out[b, OUT_SUB] = sub
        out[b, OUT_FALLBACK] = fb
        out[b, OUT_PEN] = pen
        out[b, OUT_LOOSE] = loose
        out[b, OUT_IMPULSE] = impulse
        out[b, OUT_EGAIN] = gain
        out[b, OUT_EREF] = eref
        lat = 0.0
        for i in range(3):
            lat += prms[b, P_T + i] * (rec[rows - 1, R_X + i] - rec[0, R_X + i])
        out[b, OUT_LATERAL] = lat
        out[b, OUT_HEADING] = heading_change(rec[rows - 1], R_Q, prms[b])
        out[b, OUT_DECIDED] = t_decided
        out[b, OUT_STOPPED] = 1.0 if status == ST_DECIDED else 0.0
        out[b, OUT_STEPS] = round(t_run / hs[b]) if status == ST_DECIDED else n_steps
    return 0


__all__ = ["BATCH_ENERGY_GAIN", "BATCH_ERROR", "BATCH_FAILED_STEPS", "BATCH_NONFINITE", "BATCH_OK", "N_OUT", "heading_change", "run_batch"]
