"""Analysis of a robustness study: success maps with confidence intervals.

A study's ``runs`` Dataset has one row per simulated robot along the dimension ``run``:
the cell coordinates (``shape``, ``substrate``, ``incline_deg``, ``field_mT``,
``freq_hz``, ``sample``), the sampled parameters listed in ``runs.attrs["uncertain"]``,
and the outcomes (``progress_ratio``, ``mean_speed``, ``climbed``, ``status``, ...).

A run is *valid* when ``status == 0`` (finished, every step converged); a run is a
*success* when it is valid and ``climbed == 1``. :func:`maps` reduces the runs to one
value per cell, :func:`proportion_ci` gives the binomial confidence intervals, and
:func:`check_summary` summarises the numerical check subset (runs repeated with a finer
time step).

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
        than the others at fixed n; what adaptive sampling stopped on before 2026-11-28);
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


def maps(
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


def check_summary(runs: xr.Dataset) -> dict[str, Any]:
    """Summary of the numerical check subset (runs repeated with a finer time step).

    Parameters
    ----------
    runs : Dataset
        Study results; the subset lives in ``check_run`` (indices into ``run``, dim
        ``check``), ``check_progress_ratio_fine``, ``check_climbed_fine`` and optionally
        ``check_agree``, with ``attrs["check_dt_factor"]``.

    Returns
    -------
    dict
        ``n_checked`` (int, 0 without a subset), ``agreement_rate`` (fraction of checked
        runs whose climbed verdict is the same at the fine step), ``n_compared`` (checked
        runs with a finite ratio at both steps), ``median_abs_delta_ratio`` and
        ``max_abs_delta_ratio`` (|fine - nominal| progress ratio), ``n_fine_not_ok`` (fine
        re-runs with status != 0, from ``check_status_fine``), ``dt_factor`` (the fine
        step is ``dt / dt_factor``). Values that cannot be computed are None.
    """
    out: dict[str, Any] = {
        "n_checked": 0,
        "agreement_rate": None,
        "n_compared": 0,
        "median_abs_delta_ratio": None,
        "max_abs_delta_ratio": None,
        "n_fine_not_ok": None,
        "dt_factor": None,
    }
    if "check_run" not in runs.variables:
        return out
    sel = np.asarray(runs["check_run"].values, dtype=np.int64)
    n = int(sel.size)
    out["n_checked"] = n
    if "check_dt_factor" in runs.attrs:
        out["dt_factor"] = float(runs.attrs["check_dt_factor"])
    if n == 0:
        return out
    if "check_agree" in runs.variables:
        flag = np.asarray(runs["check_agree"].values)
        agree = flag[flag >= 0] == 1  # -1: not compared (a run at either dt is invalid)
        out["n_not_compared"] = int(np.count_nonzero(flag < 0))
    elif "check_climbed_fine" in runs.variables:
        agree = np.asarray(runs["climbed"].values)[sel] == np.asarray(runs["check_climbed_fine"].values)
    else:
        agree = None
    if agree is not None and agree.size:
        out["agreement_rate"] = float(np.count_nonzero(agree) / agree.size)
    if "check_status_fine" in runs.variables:
        out["n_fine_not_ok"] = int(np.count_nonzero(np.asarray(runs["check_status_fine"].values) != 0))
    if "check_progress_ratio_fine" in runs.variables:
        if "check_ratio_diff" in runs.variables:  # NaN where the ratio at dt is censored (an early decision)
            delta = np.abs(np.asarray(runs["check_ratio_diff"].values, dtype=np.float64))
        else:
            delta = np.abs(np.asarray(runs["check_progress_ratio_fine"].values, dtype=np.float64) - runs["progress_ratio"].values[sel])
        delta = delta[np.isfinite(delta)]
        out["n_compared"] = int(delta.size)
        if delta.size:
            out["median_abs_delta_ratio"] = float(np.median(delta))
            out["max_abs_delta_ratio"] = float(np.max(delta))
    return out


def decided_early_mask(runs: xr.Dataset) -> np.ndarray:
    """Boolean mask over ``run`` of the runs stopped by an early decision.

    Their ratio is censored. All False for a study written before early decisions.
    """
    if "decided_early" not in runs.variables:
        return np.zeros(runs.sizes["run"], dtype=bool)
    return np.asarray(runs["decided_early"].values) == 1


def early_words(runs: xr.Dataset) -> str | None:
    """The early decisions and their audit in words, or None in a study without them.

    "early decisions: 6912 of 20800 runs (33%) stopped once they could no longer climb
    (verdict failure, ratio censored); audit: of 402 check runs simulated to the end the
    bound decided 131, none climbed (at dt/4: 128 of 410, none climbed)".
    """
    if "decided_early" not in runs.variables or not runs.attrs.get("early_decision", 0):
        return None
    n = runs.sizes["run"]
    k = int(np.count_nonzero(decided_early_mask(runs)))
    text = f"early decisions: {k} of {n} runs ({k / max(n, 1):.0%}) stopped once they could no longer climb"
    text += " (verdict failure, ratio censored)"
    a = runs.attrs
    if "early_decision_audit_dt_runs" not in a:
        return text
    parts = []
    for tag, label in (("dt", ""), ("fine", f" at dt/{a.get('check_dt_factor', '?'):g}" if "check_dt_factor" in a else " at the finer dt")):
        dec, tot, cl = (int(a[f"early_decision_audit_{tag}_{x}"]) for x in ("decided", "runs", "climbed"))
        verdict = "none climbed" if cl == 0 else f"{cl} CLIMBED (the bound failed; please report)"
        inv = int(a.get(f"early_decision_audit_{tag}_invalid_after", 0))
        after = f", {inv} more decided turned invalid later" if inv else ""
        parts.append(f"{label.strip() + ': ' if label else ''}the bound decided {dec} of {tot} valid, {verdict}{after}")
    return f"{text}; audit on the check runs simulated to the end: {parts[0]} ({parts[1]})"


def check_words(runs: xr.Dataset, where: str = "the result file", worst: int = 3) -> str | None:
    """The dt check in words, or None without one.

    "dt converged in 95% of checked runs (55 of 58 valid at both steps); 3 runs differ
    (|ratio at dt/4 - ratio at dt| > 0.05 + 0.1 |ratio at dt/4|): run 122 (cuboid, aluminum,
    70 deg: -9847 vs -6170), ...; all in <where>, runs group, check_ratio_within_tol == 0".
    With the sensitivity twins (``check_sensitive``) it says how many of those runs are
    limited by dt and how many are sensitive, and lists the ones limited by dt first.
    """
    if "check_ratio_within_tol" not in runs.variables:
        return None
    flag = np.asarray(runs["check_ratio_within_tol"].values)
    sel = np.asarray(runs["check_run"].values, dtype=np.int64)
    compared = flag >= 0
    n_cmp = int(compared.sum())
    if n_cmp == 0:
        return f"dt check: none of the {flag.size} checked runs is valid at both steps"
    rate = float((flag[compared] == 1).mean())
    text = f"dt converged in {rate:.0%} of checked runs ({n_cmp} of {flag.size} valid at both steps)"
    bad = np.flatnonzero(flag == 0)
    if bad.size == 0:
        return text + "; none differs beyond tolerance"
    a = runs.attrs
    diff = np.abs(np.asarray(runs["check_ratio_diff"].values))
    fine = np.asarray(runs["check_progress_ratio_fine"].values)
    coarse = np.asarray(runs["progress_ratio"].values)
    sens = np.asarray(runs["check_sensitive"].values) if "check_sensitive" in runs.variables else np.full(flag.size, -1)
    # the runs limited by dt first (a smaller dt would change their ratio), then the sensitive ones
    order = bad[np.lexsort((-diff[bad], sens[bad] == 1))][:worst]
    items = []
    for k in order:
        r = int(sel[k])
        cell = ", ".join(str(runs[c].values[r]) for c in ("shape", "substrate") if c in runs.variables)
        inc = f", {float(runs['incline_deg'].values[r]):g} deg" if "incline_deg" in runs.variables else ""
        tag = ", sensitive" if sens[k] == 1 else ""
        if "check_twin_ratio_up" in runs.variables and "success_ratio" in a:  # a twin with the other verdict says so
            twin = np.array([runs["check_twin_ratio_up"].values[k], runs["check_twin_ratio_down"].values[k]])
            flips = np.isfinite(twin) & ((twin >= float(a["success_ratio"])) != (coarse[r] >= float(a["success_ratio"])))
            tag += (
                f", {int(flips.sum())} of 2 twins {'slide' if coarse[r] >= float(a['success_ratio']) else 'climb'}" if flips.any() else ""
            )
        items.append(f"run {r} ({cell}{inc}: {coarse[r]:.4g} vs {fine[k]:.4g}{tag})")
    fac, at, rt = (a.get(k, "?") for k in ("check_dt_factor", "check_ratio_abs_tol", "check_ratio_rel_tol"))
    fac, at, rt = (f"{v:g}" if isinstance(v, (int, float, np.number)) else v for v in (fac, at, rt))
    tol = f"|ratio at dt/{fac} - ratio at dt| > {at} + {rt} x |fine|"
    more = "" if bad.size <= worst else f" and {bad.size - worst} more"
    classes = ""
    if "check_sensitive" in runs.variables:
        n_s, n_d = int(np.count_nonzero(sens == 1)), int(np.count_nonzero(sens == 0))
        n_u = bad.size - n_s - n_d
        classes = (
            f"{n_d} limited by dt, {n_s} sensitive (a change of {a.get('check_twin_rel', '?'):g} in the magnetisation"
            f" moves the ratio beyond the tolerance: no dt resolves it){f', {n_u} not classified (a twin invalid)' if n_u else ''}; "
        )
    listed = f"{'; '.join(items)}{more}"
    return f"{text}; {bad.size} runs differ ({tol}): {classes}{listed}; all in {where}, runs group, check_ratio_within_tol == 0"
