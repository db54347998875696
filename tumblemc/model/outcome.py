"""What a run amounts to: its summary and the one verdict.

A run is *valid* when it finished with every step converged (outcome status ``ok``; a
step kept loose, between the solver's ``tol`` and ``accept_tol``, counts as converged).
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
from tumblemc.kernels.batch import BATCH_FAILED_STEPS, BATCH_NONFINITE, BATCH_OK
from tumblemc.model.params import check_number


def run_status(kernel_status: int, failed_steps: int, finite: bool = True) -> int:
    """Outcome status of a run (:data:`tumblemc.schema.STATUS_FLAGS`).

    Computed from the time loop's status and failed-step count, as the batch kernel
    computes it.

    ``ok`` (0): finished, every step converged; ``failed_steps`` (1): some step did not
    converge at the smallest sub-step (or the run stopped after too many); ``nonfinite``
    (2): stopped on a non-finite state.
    """
    if kernel_status == L.ST_STOPPED:
        return BATCH_FAILED_STEPS
    if kernel_status != L.ST_OK or not finite:
        return BATCH_NONFINITE
    return BATCH_FAILED_STEPS if failed_steps > 0 else BATCH_OK


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
        between the solver's ``tol`` and ``accept_tol``), ``mean_newton_iterations``,
        ``mean_slip_speed`` (m/s, over the window), ``substeps``, ``fallbacks``,
        ``status`` (:func:`run_status`: 0 ok; 1 failed_steps, a step kept unconverged, so
        the run is not valid and never climbed, its speed and ratio are still reported
        unless the run stopped early; 2 nonfinite, speed and ratio NaN).
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
    # runs written before 2026-11-23 hold the time loop's code in "status"
    kernel_status = int(ds.attrs.get("kernel_status", ds.attrs["status"]))
    if kernel_status != 0:  # the run stopped early (non-finite state, or too many failed steps)
        mean_speed = ratio = math.nan
    status = run_status(kernel_status, int(ds.attrs["failed_steps"]), math.isfinite(ratio))
    n_steps = max(int(ds.attrs["n_steps"]), 1)
    return {
        "mean_speed": float(mean_speed),
        "ideal_speed": ideal,
        "progress_ratio": float(ratio),
        "climbed": bool(climbed(ratio, status, threshold)),
        "max_penetration": float(ds["penetration"].max()),
        "failed_steps": int(ds.attrs["failed_steps"]),
        "loose_steps": int(ds["loose"].sum()) if "loose" in ds else 0,
        "mean_newton_iterations": float(ds["newton_iterations"].sum()) / n_steps,
        "mean_slip_speed": float(ds["slip_speed"].values[i0:].mean()),
        "substeps": int(ds["substeps"].sum()),
        "fallbacks": int(ds["fallbacks"].sum()),
        "status": status,
    }
