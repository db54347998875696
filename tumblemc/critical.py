"""Critical incline per parameter sample: bracketing and bisection on the incline.

In a ``mode = "critical_incline"`` study one run is one parameter sample. Instead of
simulating every incline of a grid, the engine finds the steepest incline the sample
climbs to ``incline_tol``: it simulates both ends of ``incline_range``, then bisects the
bracket (climbs at ``a``, fails at ``b``) until ``b - a <= incline_tol``. The runs of a
batch bisect in lockstep, so every round is one call of the batch kernel.

This rests on an assumption: climbing is monotone in the incline (a sample that climbs
``theta`` climbs every gentler incline). It is checked, not assumed: for the runs of the
check subset the engine also simulates every incline of the study's ``incline_deg`` grid
and records where the verdict disagrees with ``theta <= critical_incline_deg``.

Then ``P(climb theta)`` is the fraction of valid samples whose critical incline is at
least ``theta``: a whole curve, with a binomial CI band, from one set of samples.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from .batch import STATUS_FLAGS, TimeGrid, simulate_rows

#: outcome columns of :func:`bisect_rows`
CRITICAL_OUTCOMES: dict[str, type] = {
    "critical_incline_deg": np.float64,
    "fails_at_deg": np.float64,
    "censored": np.int8,
    "n_simulations": np.int64,
    "status": np.int8,
    "newton_iterations": np.float64,
    "substeps": np.int64,
    "failed_steps": np.int64,
    "loose_steps": np.int64,
}

CRITICAL_ATTRS: dict[str, dict[str, Any]] = {
    "critical_incline_deg": {
        "units": "degree",
        "long_name": "steepest incline the sample was seen to climb (lower end of the final bracket); NaN if it fails at incline_range.min",
    },
    "fails_at_deg": {
        "units": "degree",
        "long_name": "gentlest incline the sample was seen to fail (upper end of the final bracket); NaN if it climbs incline_range.max",
    },
    "censored": {
        "units": "1",
        "long_name": "critical incline outside incline_range (meaningful where status is ok)",
        "flag_values": np.array([-1, 0, 1], dtype=np.int8),
        "flag_meanings": "fails_at_min bracketed climbs_at_max",
    },
    "n_simulations": {"units": "1", "long_name": "simulations used by the bisection"},
    "status": {"units": "1", "long_name": "worst status of the run's simulations", **STATUS_FLAGS},
    "newton_iterations": {"units": "1", "long_name": "mean Newton iterations per time step over the run's simulations"},
    "substeps": {"units": "1", "long_name": "extra sub-steps (halvings of dt), total over the run's simulations"},
    "failed_steps": {"units": "1", "long_name": "time steps that did not converge at the smallest sub-step, total"},
    "loose_steps": {"units": "1", "long_name": "time steps kept at a residual between the solver's tol and accept_tol, total"},
}


def bisect_rows(shape: str, rows: Sequence[Mapping[str, Any]], grid: TimeGrid, lo: float, hi: float, tol: float) -> dict[str, np.ndarray]:
    """Critical incline of every row (``simulate`` keywords without ``incline_deg``).

    Returns the :data:`CRITICAL_OUTCOMES` columns plus ``error`` (messages of rows that
    could not run). A row whose simulation fails (status != 0) at any incline stops
    bisecting and keeps that status: its critical incline is unknown (NaN).
    """
    n = len(rows)
    out: dict[str, np.ndarray] = {k: np.zeros(n, dt) for k, dt in CRITICAL_OUTCOMES.items()}
    nit_sum = np.zeros(n)
    err = np.full(n, "", dtype=object)

    def sim(idx: np.ndarray, inc: np.ndarray) -> np.ndarray:
        res = simulate_rows(shape, [dict(rows[i], incline_deg=float(t)) for i, t in zip(idx, inc, strict=True)], grid)
        out["n_simulations"][idx] += 1
        out["status"][idx] = np.maximum(out["status"][idx], res["status"])
        nit_sum[idx] += np.nan_to_num(res["newton_iterations"])
        out["substeps"][idx] += res["substeps"]
        out["failed_steps"][idx] += res["failed_steps"]
        out["loose_steps"][idx] += res["loose_steps"]
        for j, i in enumerate(idx):
            if res["error"][j] and not err[i]:
                err[i] = res["error"][j]
        return res["climbed"].astype(bool)

    allr = np.arange(n)
    c_lo = sim(allr, np.full(n, lo))
    c_hi = np.zeros(n, dtype=bool)
    up = np.flatnonzero(c_lo & (out["status"] == 0))  # only samples that climb the minimum
    if len(up):
        c_hi[up] = sim(up, np.full(len(up), hi))
    a = np.full(n, lo)
    b = np.full(n, hi)
    out["censored"][:] = np.where(~c_lo, -1, np.where(c_hi, 1, 0))
    active = (out["status"] == 0) & c_lo & ~c_hi
    while True:
        idx = np.flatnonzero(active & (b - a > tol))
        if len(idx) == 0:
            break
        mid = 0.5 * (a[idx] + b[idx])
        climbed = sim(idx, mid)
        ok = out["status"][idx] == 0
        a[idx] = np.where(climbed & ok, mid, a[idx])
        b[idx] = np.where(~climbed & ok, mid, b[idx])
        active[idx[~ok]] = False
    valid = out["status"] == 0
    out["critical_incline_deg"] = np.where(valid & (out["censored"] >= 0), a, np.nan)
    out["critical_incline_deg"] = np.where(valid & (out["censored"] == 1), hi, out["critical_incline_deg"])
    out["fails_at_deg"] = np.where(valid & (out["censored"] <= 0), np.where(out["censored"] == -1, lo, b), np.nan)
    out["newton_iterations"] = nit_sum / np.maximum(out["n_simulations"], 1)
    out["error"] = err
    return out


def monotonicity_rows(
    shape: str, rows: Sequence[Mapping[str, Any]], grid: TimeGrid, inclines: Sequence[float] | np.ndarray
) -> dict[str, np.ndarray]:
    """Verdicts of every row at every incline of ``inclines`` (the check of the
    monotonicity assumption): ``climbed`` and ``status`` of shape (rows, inclines)."""
    n, m = len(rows), len(inclines)
    flat = [dict(r, incline_deg=float(t)) for r in rows for t in inclines]
    res = simulate_rows(shape, flat, grid)
    return {
        "climbed": res["climbed"].reshape(n, m),
        "status": res["status"].reshape(n, m),
    }


def climbs_at(crit: np.ndarray, inclines: Sequence[float] | np.ndarray) -> np.ndarray:
    """int8 (samples, inclines): 1 where ``incline <= critical incline`` (the monotonicity
    assumption); a sample with no critical incline (NaN: fails at the range minimum or
    invalid) climbs none."""
    th = np.asarray(inclines, dtype=float)
    return (np.nan_to_num(np.asarray(crit, dtype=float), nan=-np.inf)[:, None] >= th[None, :] - 1e-9).astype(np.int8)


def expand_to_grid(runs: xr.Dataset, inclines: Sequence[float] | np.ndarray) -> xr.Dataset:
    """Virtual grid runs of a critical-incline study: one per sample and incline, with
    ``climbed = critical_incline_deg >= incline`` (a sample failing at the range minimum
    climbs none), so that :func:`tumblemc.analysis.maps` gives ``P(climb theta)``."""
    th = np.asarray(inclines, dtype=float)
    n, m = runs.sizes["run"], len(th)
    climbed = climbs_at(runs["critical_incline_deg"].values, th)
    rep = {k: np.repeat(runs[k].values, m) for k in ("shape", "substrate", "field_mT", "freq_hz", "sample", "status")}
    return xr.Dataset(
        {
            "climbed": ("run", climbed.ravel()),
            "progress_ratio": ("run", np.full(n * m, math.nan)),
            "mean_speed": ("run", np.full(n * m, math.nan)),
            "status": ("run", rep.pop("status")),
        },
        coords={**{k: ("run", v) for k, v in rep.items()}, "incline_deg": ("run", np.tile(th, n))},
        attrs=dict(runs.attrs),
    )


__all__ = ["CRITICAL_ATTRS", "CRITICAL_OUTCOMES", "bisect_rows", "climbs_at", "expand_to_grid", "monotonicity_rows"]


def compare_with_grid(crit_maps: xr.Dataset, grid_maps: xr.Dataset) -> xr.Dataset:
    """The critical-incline curve against a direct grid map at the grid's inclines.

    Both inputs are ``maps`` groups (:func:`tumblemc.io.open_result`). Returns, per shape,
    substrate and grid incline: both probabilities with their intervals, and ``agree``
    (1 where the two confidence intervals overlap: the two estimates, from independent
    samples, are consistent).
    """
    th = grid_maps["incline_deg"].values
    c = crit_maps.sel(incline_deg=th, method="nearest")
    if not np.allclose(c["incline_deg"].values, th, atol=1e-6):
        raise ValueError(f"the critical-incline curve does not cover the grid inclines {th.tolist()} (its step is incline_tol)")
    c = c.assign_coords(incline_deg=th)
    out = xr.Dataset()
    for src, m in (("critical", c), ("grid", grid_maps)):
        for k in ("p_success", "p_success_lower", "p_success_upper", "n_valid"):
            out[f"{k}_{src}"] = m[k]
            out[f"{k}_{src}"].attrs = {**m[k].attrs, "long_name": f"{m[k].attrs.get('long_name', k)} ({src})"}
    lo = np.maximum(out["p_success_lower_critical"], out["p_success_lower_grid"])
    hi = np.minimum(out["p_success_upper_critical"], out["p_success_upper_grid"])
    out["agree"] = (lo <= hi).astype(np.int8)
    out["agree"].attrs = {
        "units": "1",
        "long_name": "confidence intervals of the two estimates overlap",
        "flag_values": np.array([0, 1], dtype=np.int8),
        "flag_meanings": "no yes",
    }
    return out


__all__ += ["compare_with_grid"]
