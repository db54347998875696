"""Many independent simulations in one call: parameter rows in, summary rows out.

One dask task of the Monte Carlo engine calls :func:`run_batch` once for a few dozen runs
that share a shape and a time grid, so that a task does a second or so of work instead
of one run, and the Python overhead per run is one row of arrays.
"""

from __future__ import annotations

import numpy as np

from ._jit import jit
from .layout import P_U, R_FALLBACK, R_LOOSE, R_NIT, R_PEN, R_SUB, R_T, R_X, ST_OK, ST_STOPPED
from .stepper import run

# ---- summary columns (one row per run) ----------------------------------------------
B_STATUS = 0  # BATCH_* status below
B_FAILED = 1  # steps that did not converge at the smallest sub-step
B_PROGRESS = 2  # uphill progress over the measurement window (scaled length)
B_WINDOW = 3  # length of the measurement window (scaled time)
B_NIT = 4  # Newton iterations, total
B_SUB = 5  # extra sub-steps, total
B_FALLBACK = 6  # damped/gradient fallbacks, total
B_PEN = 7  # max penetration (scaled length)
B_LOOSE = 8  # steps kept at a residual between tol and accept_tol, total
N_BATCH_OUT = 9

# ---- run status (also the engine's ``status`` flag values) -------------------------
BATCH_OK = 0  # finished, every step converged
BATCH_FAILED_STEPS = 1  # finished, but some steps did not converge at the smallest sub-step
BATCH_NONFINITE = 2  # stopped early on a non-finite state
BATCH_ERROR = 3  # never ran: invalid parameters (set by the Python layer)


@jit
def run_batch(geo, prms, states0, hs, area0, touch0, n_steps, record_every, i0_row, opts, ws, ws6, rec, out):  # type: ignore[no-untyped-def]
    """Simulate ``B`` independent runs of one shape on one time grid.

    Parameters
    ----------
    geo : Geometry
        The shape, shared by every run (scaled units).
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
    n_steps, record_every, i0_row : int
        Steps per run, recording stride and the record row that starts the measurement
        window (``i0_row * record_every`` steps after the start).
    opts : float64[N_OPT]
    ws, ws6 : Workspace
        Solver workspaces (full system, 6-unknown free-flight system), reused by all runs.
    rec : float64[n_records(n_steps, record_every), N_REC]
        Record workspace, reused by all runs.
    out : float64[B, N_BATCH_OUT]
        Receives one summary row per run (columns ``B_*``).

    Notes
    -----
    Each run is exactly :func:`tumblemc.kernels.stepper.run` from the same initial data
    as :func:`tumblemc.simulate`; nothing is shared between runs except workspaces, so a
    run's result does not depend on its batch or its position in it.
    """
    B = prms.shape[0]
    n = ws.F.shape[0]
    rows = rec.shape[0]
    z = np.zeros(n)
    z6 = np.zeros(6)
    zsave = np.zeros(n)
    state = np.zeros(13)
    for b in range(B):
        rec[:, :] = 0.0
        z[:] = 0.0
        z6[:] = 0.0
        zsave[:] = 0.0
        state[:] = states0[b]
        status, failed = run(geo, prms[b], state, 0.0, hs[b], n_steps, record_every, opts, rec, ws, ws6, z, z6, zsave, area0[b], touch0[b])
        prog = 0.0
        for i in range(3):
            prog += prms[b, P_U + i] * (rec[rows - 1, R_X + i] - rec[i0_row, R_X + i])
        nit = 0.0
        sub = 0.0
        fb = 0.0
        pen = 0.0
        loose = 0.0
        for r in range(1, rows):
            loose += rec[r, R_LOOSE]
            nit += rec[r, R_NIT]
            sub += rec[r, R_SUB]
            fb += rec[r, R_FALLBACK]
            pen = max(pen, rec[r, R_PEN])
        if status == ST_STOPPED:  # gave up after opts[O_MAXFAIL] failed steps
            code = BATCH_FAILED_STEPS
            prog = np.nan
        elif status != ST_OK or not np.isfinite(prog):
            code = BATCH_NONFINITE  # the stepper stops otherwise only on a non-finite state
        elif failed > 0:
            code = BATCH_FAILED_STEPS
        else:
            code = BATCH_OK
        out[b, B_STATUS] = code
        out[b, B_FAILED] = failed
        out[b, B_PROGRESS] = prog
        out[b, B_WINDOW] = rec[rows - 1, R_T] - rec[i0_row, R_T]
        out[b, B_NIT] = nit
        out[b, B_SUB] = sub
        out[b, B_FALLBACK] = fb
        out[b, B_PEN] = pen
        out[b, B_LOOSE] = loose
    return 0


__all__ = ["BATCH_ERROR", "BATCH_FAILED_STEPS", "BATCH_NONFINITE", "BATCH_OK", "N_BATCH_OUT", "run_batch"]
