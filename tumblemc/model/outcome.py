"""What a run amounts to: its summary and the one verdict.

A run is *valid* when it finished with every step converged (outcome status ``ok``; a
step kept loose, between the solver's ``tol`` and ``accept_tol`` or balancing its momenta
to ``impulse_accept_tol``, counts as converged).
:func:`climbed` is the one verdict: a valid run whose progress ratio reaches the
threshold. :func:`summarize`, :func:`tumblemc.model.rows.simulate_rows` (and so the
study engine and the critical-incline bisection), the maps and the screening analyses
all decide through it: a run that is not valid is never "climbed".
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from tumblemc.kernels import layout as L
from tumblemc.kernels.batch import BATCH_ENERGY_GAIN, BATCH_FAILED_STEPS, BATCH_NONFINITE, BATCH_OK, heading_change
from tumblemc.model.frames import plane_frame
from tumblemc.model.params import check_number


def run_status(kernel_status: int, failed_steps: int, finite: bool = True, energy_gain_ratio: float = 0.0) -> int:
    """Outcome status of a run (:data:`tumblemc.schema.STATUS_FLAGS`).

    Computed from the time loop's status, failed-step count and the energy ledger's gain
    (over its energy scale, :func:`tumblemc.model.energy.energy_summary`), as the batch
    kernel computes it.

    ``ok`` (0): finished, every step converged, energy within tolerance; ``failed_steps``
    (1): some step did not converge at the smallest sub-step (or the run stopped after too
    many); ``nonfinite`` (2): stopped on a non-finite state; ``energy_gain`` (4): the
    ledger's numerical energy gain exceeds :data:`~tumblemc.model.energy.ENERGY_GAIN_TOL`
    of the energy scale (a cause found first, failed steps, wins).
    """
    if kernel_status == L.ST_STOPPED:
        return BATCH_FAILED_STEPS
    if kernel_status != L.ST_OK or not finite:
        return BATCH_NONFINITE
    if failed_steps > 0:
        return BATCH_FAILED_STEPS
    return BATCH_ENERGY_GAIN if energy_gain_ratio > L.ENERGY_GAIN_TOL else BATCH_OK


def is_valid(status: ArrayLike) -> np.ndarray:
    """Whether runs with outcome ``status`` are valid (status ``ok``), elementwise."""
    return np.asarray(status) == BATCH_OK


def climbed(progress_ratio: ArrayLike, status: ArrayLike, threshold: float) -> np.ndarray:
    """The one verdict: valid and ``progress_ratio >= threshold`` (elementwise)."""
    return is_valid(status) & (np.asarray(progress_ratio) >= threshold)


def summarize(ds: xr.Dataset, transient_periods: float = 1.0, threshold: float = 0.5, min_window_periods: float = 1.0) -> dict[str, Any]:
    """Summary of a run measured after the transient.

    Speeds and progress are measured over ``[transient_periods / f, t_end]`` (with phi > 0
    the robot first tips backwards, so the start depends on the initial field phase).

    Returns
    -------
    dict
        ``mean_speed`` (uphill, m/s), ``ideal_speed`` (hull perimeter x f, m/s),
        ``progress_ratio``, ``climbed`` (:func:`climbed`: valid and
        ``progress_ratio >= threshold``; a run with failed steps never climbed),
        ``max_penetration`` (m), ``failed_steps``, ``loose_steps`` (kept at a residual
        between the solver's ``tol`` and ``accept_tol``, or at the smallest sub-step by
        ``impulse_accept_tol``), ``impulse_steps`` (those of the loose steps kept by
        ``impulse_accept_tol``), ``mean_newton_iterations``,
        ``mean_slip_speed`` (m/s, over the window), ``substeps``, ``fallbacks``,
        ``status`` (:func:`run_status`: 0 ok; 1 failed_steps, a step kept unconverged, so
        the run is not valid and never climbed, its speed and ratio are still reported
        unless the run stopped early; 2 nonfinite, speed and ratio NaN; 4 energy_gain, the
        energy ledger's numerical gain is above tolerance, the run is not valid),
        ``energy_gain_J``, ``field_work_bound_J``, ``energy_gain_ratio``
        (:mod:`tumblemc.model.energy`; NaN for runs written before the ledger),
        ``lateral_drift`` (m) and ``heading_change_deg`` (:func:`drift_and_heading`).

        The progress ratio is measured against the nominal gait, tumbling without slip over
        the hull's length-height perimeter (``ideal_speed``) whatever the robot does: a
        ratio above 1 means it travelled uphill faster than that gait, by hopping or
        sliding forward, or by tumbling over a longer perimeter after turning onto its side
        in a 3-D run.
    """
    transient_periods = check_number("transient_periods", transient_periods, "", 0.0, 1e6)
    threshold = check_number("threshold", threshold, "", -1e6, 1e6)
    min_window_periods = check_number("min_window_periods", min_window_periods, "", 0.0, 1e6)
    f = float(ds.attrs["freq_hz"])
    if not f > 0:
        raise ValueError("summarize needs a rotating field (freq_hz > 0)")
    t = ds["time"].values
    t0 = transient_periods / f
    window = t[-1] - t0
    if window < min_window_periods / f - 1e-9:
        raise ValueError(
            f"run too short: duration {t[-1]:.6g} s leaves {window:.6g} s after the transient of "
            f"{t0:.6g} s (allowed: at least {min_window_periods} field period(s) = {min_window_periods / f:.6g} s)"
        )
    i0 = int(np.searchsorted(t, t0 - 1e-9 * float(ds.attrs["dt"])))
    prog = ds["progress"].values
    dur = t[-1] - t[i0]
    mean_speed = (prog[-1] - prog[i0]) / dur
    ideal = float(ds.attrs["ideal_speed"])
    ratio = mean_speed / ideal
    # runs written by earlier versions hold the time loop's code in "status"
    kernel_status = int(ds.attrs.get("kernel_status", ds.attrs["status"]))
    if kernel_status != 0:  # the run stopped early (non-finite state, or too many failed steps)
        mean_speed = ratio = math.nan
    gain_ratio = float(ds.attrs.get("energy_gain_ratio", 0.0))  # runs written before the ledger: 0
    status = run_status(kernel_status, int(ds.attrs["failed_steps"]), math.isfinite(ratio), gain_ratio)
    lateral = heading = math.nan
    if "incline_deg" in ds.attrs and "position" in ds and "quaternion" in ds:
        lateral, heading = drift_and_heading(ds["position"].values, ds["quaternion"].values[-1], float(ds.attrs["incline_deg"]))
    n_steps = max(int(ds.attrs["n_steps"]), 1)
    return {
        "mean_speed": float(mean_speed),
        "ideal_speed": ideal,
        "progress_ratio": float(ratio),
        "climbed": bool(climbed(ratio, status, threshold)),
        "max_penetration": float(ds["penetration"].max()),
        "failed_steps": int(ds.attrs["failed_steps"]),
        "loose_steps": int(ds["loose"].sum()) if "loose" in ds else 0,
        "impulse_steps": int(ds["impulse_kept"].sum()) if "impulse_kept" in ds else 0,
        "mean_newton_iterations": float(ds["newton_iterations"].sum()) / n_steps,
        "mean_slip_speed": float(ds["slip_speed"].values[i0:].mean()),
        "substeps": int(ds["substeps"].sum()),
        "fallbacks": int(ds["fallbacks"].sum()),
        "status": status,
        "energy_gain_J": float(ds.attrs.get("energy_gain_J", math.nan)),
        "field_work_bound_J": float(ds.attrs.get("field_work_bound_J", math.nan)),
        "energy_gain_ratio": float(ds.attrs.get("energy_gain_ratio", math.nan)),
        "lateral_drift": lateral,
        "heading_change_deg": heading,
    }


def drift_and_heading(position: np.ndarray, q_end: np.ndarray, incline_deg: float) -> tuple[float, float]:
    """Lateral drift (m) and heading change (degrees) of a run, as the batch kernel computes them.

    The drift is the centre of mass's displacement along the plane tangent ``t`` (world x,
    the field's rotation axis); the heading change is the angle about the plane normal from
    ``t`` (where the body x axis, the tumbling axis, starts) to the body x axis projected
    onto the plane, folded to ``(-90, 90]`` (:func:`tumblemc.kernels.batch.heading_change`).
    """
    fr = plane_frame(incline_deg)
    prm = np.zeros(L.N_PRM)
    prm[L.P_T : L.P_T + 3] = fr["t"]
    prm[L.P_O : L.P_O + 3] = fr["o"]
    lateral = float((position[-1] - position[0]) @ fr["t"])
    return lateral, float(heading_change(np.ascontiguousarray(q_end, dtype=np.float64), 0, prm))
