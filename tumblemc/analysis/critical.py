"""Critical-incline results as functions of Datasets.

The verdict at a given incline, the expansion onto a grid of inclines (so that
:func:`tumblemc.analysis.maps.maps` applies) and the comparison with a grid study.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import xarray as xr


def climbs_at(crit: np.ndarray, inclines: Sequence[float] | np.ndarray) -> np.ndarray:
    """Verdicts of samples at given inclines from their critical inclines.

    Parameters
    ----------
    crit : np.ndarray
        Critical incline of each sample, degrees (NaN: none).
    inclines : sequence of float or np.ndarray
        Inclines, degrees.

    Returns
    -------
    np.ndarray
        int8 (samples, inclines): 1 where ``incline <= critical incline`` (the monotonicity
        assumption); a sample with no critical incline (NaN: fails at the range minimum or
        invalid) climbs none.
    """
    th = np.asarray(inclines, dtype=float)
    return (np.nan_to_num(np.asarray(crit, dtype=float), nan=-np.inf)[:, None] >= th[None, :] - 1e-9).astype(np.int8)


def expand_to_grid(runs: xr.Dataset, inclines: Sequence[float] | np.ndarray) -> xr.Dataset:
    """Virtual grid runs of a critical-incline study.

    One run per sample and incline, with ``climbed = critical_incline_deg >= incline`` (a
    sample failing at the range minimum climbs none), so that :func:`tumblemc.analysis.maps`
    gives ``P(climb theta)``.
    """
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
