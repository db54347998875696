"""Analysis of a robustness study: success maps with confidence intervals.

A study's ``runs`` Dataset has one row per simulated robot along the dimension ``run``:
the cell coordinates (``shape``, ``substrate``, ``incline_deg``, ``field_mT``,
``freq_hz``, ``sample``), the sampled parameters listed in ``runs.attrs["uncertain"]``,
and the outcomes (``progress_ratio``, ``mean_speed``, ``climbed``, ``status``, ...).

A run is *valid* when ``status == 0`` (finished, every step converged); a run is a
*success* when it is valid and ``climbed == 1``. :func:`maps` reduces the runs to one
value per cell, :func:`proportion_ci` gives the binomial confidence intervals
(:mod:`tumblemc.analysis.words` summarises the numerical checks).

Every reduction sorts before it sums, so the maps are bit-identical for the same runs in
any order.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike
from scipy.special import ndtri
from scipy.stats import beta

from tumblemc.analysis.confseq import CS_METHODS, cs_interval
from tumblemc.model.outcome import is_valid
from tumblemc.schema import CELL_DIMS, CI_METHODS, COORD_ATTRS, MAP_VARIABLES, MAPS_FROM_RUNS_ATTRS, SWEEP_DIMS, annotate

REQUIRED = ("shape", "substrate", "incline_deg", "status", "climbed", "progress_ratio", "mean_speed")


def _check_ci_args(level: float, method: str) -> None:
    if not (isinstance(level, (int, float, np.floating)) and 0.0 < float(level) < 1.0):
        raise ValueError(f"level must be in (0, 1), got {level!r}")
    if method not in CI_METHODS:
        raise ValueError(f"method must be one of {CI_METHODS}, got {method!r}")


CI_LABELS = {
    "wilson": "Wilson",
    "clopper-pearson": "Clopper-Pearson",
    "confidence-sequence": "confidence-sequence (uniform prior)",
    "confidence-sequence-ends": "confidence-sequence (ends prior)",
}


def ci_label(method: str) -> str:
    """How plots name an interval method (``ci_method`` of a map); unknown names as they are."""
    return CI_LABELS.get(str(method), str(method))


def proportion_ci(k: ArrayLike, n: ArrayLike, level: float = 0.95, method: str = "wilson") -> tuple[Any, Any]:
    """Two-sided confidence interval of a binomial proportion, vectorised.

    Parameters
    ----------
    k : int array_like
        Number of successes, ``0 <= k <= n``.
    n : int array_like
        Number of trials, ``n >= 0``; broadcast against ``k``.
    level : float
        Confidence level in (0, 1).
    method : {"wilson", "clopper-pearson", "confidence-sequence", "confidence-sequence-ends"}
        ``"wilson"``: Wilson score interval without continuity correction;
        ``"clopper-pearson"``: the exact interval (``method="exact"`` of scipy);
        ``"confidence-sequence"``: the anytime-valid beta-binomial mixture interval of
        :func:`tumblemc.analysis.confseq.cs_interval` with Robbins' uniform prior (wider
        than the others at fixed n; what adaptive sampling stopped on in earlier versions);
        ``"confidence-sequence-ends"``: the same with the ``"ends"`` prior (adaptive
        sampling's default since then).

    Returns
    -------
    (lo, hi) : float64 arrays of the broadcast shape (NumPy floats for scalar input).
        ``lo = 0`` at ``k = 0`` and ``hi = 1`` at ``k = n``; NaN where ``n = 0``.

    Notes
    -----
    Same values as ``scipy.stats.binomtest(k, n).proportion_ci(level, method)`` with
    ``method="wilson"`` or ``"exact"`` (Newcombe 1998, methods 3 and 5), but for arrays
    and without root finding: Clopper-Pearson bounds are beta quantiles,
    ``lo = B^-1(a/2; k, n-k+1)`` and ``hi = B^-1(1-a/2; k+1, n-k)`` with ``a = 1 - level``.
    """
    _check_ci_args(level, method)
    k_arr, n_arr = np.broadcast_arrays(np.asarray(k), np.asarray(n))
    kf = k_arr.astype(np.float64)
    nf = n_arr.astype(np.float64)
    if not (np.all(np.isfinite(kf)) and np.all(np.isfinite(nf))):
        raise ValueError("k and n must be finite")
    if np.any(kf != np.round(kf)) or np.any(nf != np.round(nf)):
        raise ValueError("k and n must be whole numbers")
    if np.any(nf < 0) or np.any(kf < 0) or np.any(kf > nf):
        raise ValueError("proportion_ci needs 0 <= k <= n")
    empty = nf == 0
    ns = np.where(empty, 1.0, nf)  # placeholder trials where n = 0, masked below
    ks = np.where(empty, 0.0, kf)
    if method == "wilson":
        z = float(ndtri(0.5 + 0.5 * float(level)))
        p = ks / ns
        denom = 2.0 * (ns + z * z)
        center = (2.0 * ns * p + z * z) / denom
        delta = z / denom * np.sqrt(4.0 * ns * p * (1.0 - p) + z * z)
        lo = center - delta
        hi = center + delta
    elif method in CS_METHODS:
        lo, hi = (np.asarray(b, dtype=np.float64) for b in cs_interval(ks, ns, level, CS_METHODS[method]))
    else:
        a = 0.5 * (1.0 - float(level))
        # beta needs positive shape parameters: placeholders where the bound is fixed
        lo = beta.ppf(a, np.where(ks > 0, ks, 1.0), ns - ks + 1.0)
        hi = beta.ppf(1.0 - a, ks + 1.0, np.where(ks < ns, ns - ks, 1.0))
    lo = np.where(ks == 0, 0.0, np.clip(lo, 0.0, 1.0))
    hi = np.where(ks == ns, 1.0, np.clip(hi, 0.0, 1.0))
    lo = np.where(empty, np.nan, lo).astype(np.float64)
    hi = np.where(empty, np.nan, hi).astype(np.float64)
    return lo[()], hi[()]


def _check_runs(runs: xr.Dataset) -> None:
    missing = [v for v in REQUIRED if v not in runs.variables]
    if missing:
        raise ValueError(f"runs lacks variable(s) {missing}; a runs Dataset needs {list(REQUIRED)}")
    for name in REQUIRED:
        if runs[name].dims != ("run",):
            raise ValueError(f"runs[{name!r}] must be 1-D over 'run', got dims {runs[name].dims}")
    for name in ("incline_deg", *SWEEP_DIMS):
        if name in runs.variables and not np.all(np.isfinite(runs[name].values.astype(np.float64))):
            raise ValueError(f"runs[{name!r}] has non-finite values; cell coordinates must be finite")


def sort_runs(runs: xr.Dataset) -> xr.Dataset:
    """``runs`` in canonical order: by cell, then ``sample``, then the outcomes.

    The order does not depend on the input order, so reductions over the result are
    reproducible to the bit. Variables along other dims (the check subset) are left as
    they are, so ``check_run`` no longer indexes the sorted runs.
    """
    keys: list[np.ndarray] = []
    for name in (*CELL_DIMS, *SWEEP_DIMS, "sample", "status", "climbed", "progress_ratio", "mean_speed"):
        if name in runs.variables:
            # integer codes: lexsort of mixed str/float keys; NaN gets the last code
            keys.append(np.unique(np.asarray(runs[name].values), return_inverse=True)[1].ravel())
    order = np.lexsort(tuple(reversed(keys)))  # the last key of lexsort is the primary one
    return runs.isel(run=order)


def _cell_dims(runs: xr.Dataset) -> tuple[list[str], dict[str, np.ndarray]]:
    """Dims of the maps and the sorted unique values of every cell coordinate."""
    values = {name: np.unique(runs[name].values) for name in (*CELL_DIMS, *SWEEP_DIMS) if name in runs.variables}
    dims = list(CELL_DIMS) + [d for d in SWEEP_DIMS if d in values and values[d].size > 1]
    return dims, values


def cell_groups(runs: xr.Dataset, dims: Sequence[str]) -> tuple[dict[str, np.ndarray], tuple[int, ...], np.ndarray, list[np.ndarray]]:
    """Cells of ``runs`` over the coordinates ``dims``.

    Returns
    -------
    values : dict of str to np.ndarray
        The sorted unique values per dim.
    shape : tuple of int
        The grid shape.
    index : np.ndarray
        The flat (C-order) cell index of every run.
    members : list of np.ndarray
        The run indices of every cell (in run order).
    """
    values = {d: np.unique(runs[d].values) for d in dims}
    shape = tuple(values[d].size for d in dims)
    idx = np.zeros(runs.sizes["run"], dtype=np.int64)
    for d, size in zip(dims, shape, strict=True):
        idx = idx * size + np.searchsorted(values[d], runs[d].values)
    order = np.argsort(idx, kind="stable")
    bounds = np.searchsorted(idx[order], np.arange(int(np.prod(shape)) + 1))
    return values, shape, idx, [order[bounds[c] : bounds[c + 1]] for c in range(bounds.size - 1)]


def _sorted_mean(x: np.ndarray) -> float:
    return float(np.sum(np.sort(x)) / x.size) if x.size else np.nan


def maps(  # noqa: C901
    runs: xr.Dataset,
    *,
    level: float = 0.95,
    method: str = "wilson",
    quantiles: Sequence[float] = (0.05, 0.25, 0.5, 0.75, 0.95),
) -> xr.Dataset:
    """Success maps of a study: one value per cell ``shape x incline_deg x substrate``.

    Parameters
    ----------
    runs : Dataset
        Study results, variables 1-D over ``run`` (see the module docstring).
    level : float
        Confidence level of the interval of ``p_success``.
    method : {"wilson", "clopper-pearson", "confidence-sequence", "confidence-sequence-ends"}
        Interval method, see :func:`proportion_ci`.
    quantiles : sequence of float
        Quantile levels in [0, 1] of ``progress_ratio_quantile`` (sorted in the output).

    Returns
    -------
    Dataset
        Dims ``shape``, ``incline_deg``, ``substrate`` (sorted), then ``field_mT`` and
        ``freq_hz`` when the study has more than one value of them (otherwise they are
        scalar coordinates), and ``quantile`` for ``progress_ratio_quantile``. Variables:
        ``p_success`` with ``p_success_lower``/``p_success_upper``; counts ``n_success``,
        ``n_valid``, ``n_failed``, ``n_runs`` (int64); ``progress_ratio_mean``,
        ``progress_ratio_quantile`` and ``mean_speed_mean`` (m/s) over valid runs.
        ``n_decided_early`` counts the runs stopped by an early decision: their final
        ratio is only known to be below the success threshold, so in their cells the
        means are NaN and a quantile is given only where it is at or above the threshold
        (there it is exact). Cells without valid runs hold NaN (and cells without runs
        count 0).

    Notes
    -----
    ``p_success`` is conditional on a valid run: runs that did not finish cleanly are
    counted in ``n_failed`` and left out of numerator and denominator. Means sum sorted
    values, so the output is bit-identical for any order of the runs.
    """
    _check_runs(runs)
    q = np.asarray(quantiles, dtype=np.float64).ravel()
    if q.size == 0 or not np.all((q >= 0.0) & (q <= 1.0)):
        raise ValueError(f"quantiles must be a non-empty sequence of levels in [0, 1], got {quantiles!r}")
    if np.unique(q).size != q.size:
        raise ValueError(f"quantiles must be distinct, got {quantiles!r}")
    q = np.sort(q)
    _check_ci_args(level, method)

    # the dt check's per-run flag (-2: not checked), carried along the sort
    # and the sensitivity twins' class (1 sensitive, 0 limited by dt, else -2)
    check_flag = np.full(runs.sizes["run"], -2, dtype=np.int8)
    sens_flag = np.full(runs.sizes["run"], -2, dtype=np.int8)
    if "check_ratio_within_tol" in runs.variables and "check_run" in runs.variables:
        check_flag[np.asarray(runs["check_run"].values, dtype=np.int64)] = runs["check_ratio_within_tol"].values
    if "check_sensitive" in runs.variables:
        sens_flag[np.asarray(runs["check_run"].values, dtype=np.int64)] = runs["check_sensitive"].values
    runs = sort_runs(runs.assign(_check_flag=("run", check_flag), _sens_flag=("run", sens_flag)))
    check_flag, sens_flag = runs["_check_flag"].values, runs["_sens_flag"].values
    runs = runs.drop_vars(["_check_flag", "_sens_flag"])
    dims, values = _cell_dims(runs)
    _, shape, idx, groups = cell_groups(runs, dims)
    ncell = len(groups)
    n_check = np.bincount(idx, weights=check_flag >= 0, minlength=ncell).astype(np.int64)
    n_within = np.bincount(idx, weights=check_flag == 1, minlength=ncell).astype(np.int64)

    status = runs["status"].values
    valid = is_valid(status)
    success = valid & (runs["climbed"].values == 1)
    n_runs = np.bincount(idx, minlength=ncell)
    n_valid = np.bincount(idx, weights=valid, minlength=ncell).astype(np.int64)
    n_success = np.bincount(idx, weights=success, minlength=ncell).astype(np.int64)

    ratio = runs["progress_ratio"].values.astype(np.float64)
    speed = runs["mean_speed"].values.astype(np.float64)
    # runs stopped by an early decision have censored ratios: left out of the ratio statistics
    early = decided_early_mask(runs)
    n_early = np.bincount(idx, weights=early, minlength=ncell).astype(np.int64)
    ratio_mean = np.full(ncell, np.nan)
    speed_mean = np.full(ncell, np.nan)
    ratio_q = np.full((ncell, q.size), np.nan)
    thr = float(runs.attrs.get("success_ratio", 0.5))
    for c, rows in enumerate(groups):
        rows = rows[valid[rows]]
        cens = early[rows]
        r = ratio[rows]
        keep = np.isfinite(r) | cens
        r, cens = r[keep], cens[keep]
        s = speed[rows]
        s = s[np.isfinite(s)]
        if cens.any():
            # a censored run's final ratio is only known to be below the threshold: the mean
            # is unknown, a quantile is exact where it is at or above the threshold (ranked
            # with the censored runs at -inf) and unknown below it
            if r.size:
                with np.errstate(invalid="ignore"):  # interpolating next to -inf gives NaN: unknown
                    qv = np.quantile(np.where(cens, -np.inf, r), q)
                    ratio_q[c] = np.where(qv >= thr, qv, np.nan)
            continue
        ratio_mean[c] = _sorted_mean(r)
        speed_mean[c] = _sorted_mean(s)
        if r.size:
            ratio_q[c] = np.quantile(r, q)

    with np.errstate(invalid="ignore", divide="ignore"):
        p = np.where(n_valid > 0, n_success / np.maximum(n_valid, 1), np.nan)
    lo, hi = proportion_ci(n_success, n_valid, level, method)

    def grid(a: np.ndarray) -> np.ndarray:
        return np.asarray(a).reshape(shape + a.shape[1:])

    ci_attrs = {"ci_method": method, "confidence_level": float(level)}
    pct = f"{100 * float(level):g}%"
    n_bad = (n_runs - n_valid).astype(np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        # what p would be if every invalid run had failed / had succeeded: the range the
        # invalid runs leave open (they are not a random subset where the robot slides fast)
        p_bad_fail = np.where(n_runs > 0, n_success / np.maximum(n_runs, 1), np.nan)
        p_bad_success = np.where(n_runs > 0, (n_success + n_bad) / np.maximum(n_runs, 1), np.nan)
    data = {
        "p_success": (dims, grid(p)),
        "p_success_invalid_as_failure": (dims, grid(p_bad_fail)),
        "p_success_invalid_as_success": (dims, grid(p_bad_success)),
        "p_success_lower": (dims, grid(np.asarray(lo, dtype=np.float64))),
        "p_success_upper": (dims, grid(np.asarray(hi, dtype=np.float64))),
        "n_success": (dims, grid(n_success)),
        "n_valid": (dims, grid(n_valid)),
        "n_failed": (dims, grid((n_runs - n_valid).astype(np.int64))),
        "n_runs": (dims, grid(n_runs.astype(np.int64))),
        "progress_ratio_mean": (dims, grid(ratio_mean)),
        "progress_ratio_quantile": ([*dims, "quantile"], grid(ratio_q)),
        "mean_speed_mean": (dims, grid(speed_mean)),
    }
    if "decided_early" in runs.variables:
        data["n_decided_early"] = (dims, grid(n_early))
    if "check_ratio_within_tol" in runs.variables:
        with np.errstate(invalid="ignore", divide="ignore"):
            share = np.where(n_check > 0, n_within / np.maximum(n_check, 1), np.nan)
        data["check_within_tol_share"] = (dims, grid(share))
        data["n_check_compared"] = (dims, grid(n_check))
    if "check_sensitive" in runs.variables:
        for name, code in (("n_check_dt_limited", 0), ("n_check_sensitive", 1)):
            data[name] = (dims, grid(np.bincount(idx, weights=sens_flag == code, minlength=ncell).astype(np.int64)))
    coords: dict[str, Any] = {d: (d, values[d]) for d in dims}
    for d in SWEEP_DIMS:
        if d in values and d not in dims and values[d].size == 1:
            coords[d] = ((), values[d][0])
    coords["quantile"] = ("quantile", q)
    out = annotate(xr.Dataset(data, coords=coords), {**MAP_VARIABLES, **COORD_ATTRS})
    for name in ("p_success_lower", "p_success_upper"):
        out[name].attrs.update(ci_attrs)
        out[name].attrs["long_name"] = out[name].attrs["long_name"].replace("confidence interval", f"{pct} {method} confidence interval")
    out["p_success"].attrs.update(ci_attrs)
    out["progress_ratio_quantile"].attrs["quantile_method"] = "linear"
    out.attrs.update({k: runs.attrs[k] for k in MAPS_FROM_RUNS_ATTRS if k in runs.attrs})
    out.attrs.update(
        {
            "title": "success maps per cell",
            "success_definition": "valid run (status 0) with climbed == 1; p_success = n_success / n_valid",
            "ci_method": method,
            "confidence_level": float(level),
        }
    )
    return out


def decided_early_mask(runs: xr.Dataset) -> np.ndarray:
    """Boolean mask over ``run`` of the runs stopped by an early decision.

    Their ratio is censored. All False for a study written before early decisions.
    """
    if "decided_early" not in runs.variables:
        return np.zeros(runs.sizes["run"], dtype=bool)
    return np.asarray(runs["decided_early"].values) == 1
