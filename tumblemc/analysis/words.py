"""The numerical checks of a study in numbers and words, and what an incline's sign means.

:func:`check_summary` (the dt-check subset), :func:`early_words` and :func:`check_words`;
:func:`incline_words` and :func:`verdict_name` for a negative (downhill) incline.

Split from :mod:`tumblemc.analysis.maps`; ``study status``, ``study plot`` and the figures'
footnotes use them.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from tumblemc.analysis.maps import decided_early_mask


def verdict_name(incline_deg: float) -> str:
    """The name of the success verdict at ``incline_deg``: "climbed", or "descended" on a downhill slope.

    The substrate is tilted by the incline about world x and the field drives the robot along
    the plane's direction ``u = (0, -cos θ, sin θ)`` (docs/guide/model.md, Frames): uphill for
    θ > 0, downhill for θ < 0. The verdict itself (progress ratio at least the success ratio,
    a valid run) is the same either way.
    """
    return "descended" if incline_deg < 0 else "climbed"


def incline_words(incline_deg: float) -> str | None:
    """A sentence for a negative incline (the robot tumbles down the slope), or None for θ >= 0."""
    if not incline_deg < 0:
        return None
    return (
        f"incline {incline_deg:g} deg: a downhill slope of {-incline_deg:g} deg (the field drives the robot down it); "
        "speed and progress are measured downhill"
    )


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
    a = runs.attrs
    if bad.size == 0:  # the tolerance in words: a large |difference| on a large ratio is within it
        tol = f"{a['check_ratio_abs_tol']:g} + {a['check_ratio_rel_tol']:g} x |ratio|" if "check_ratio_abs_tol" in a else "the tolerance"
        return text + f"; none differs beyond {tol}"
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


def threshold_words(runs: xr.Dataset) -> str | None:
    """A threshold study's search and audit in words, or None for another study.

    "4,012 simulations for 1,600 samples (0.19 of the 20,800 of the full grid); audit: 32
    samples simulated at every grid value to the end: 0 non-monotone, thresholds identical
    in 32 of 32, 0 of 416 verdicts differ from the threshold's, 0 of 11 early stops
    contradicted (the direct run climbed)".
    """
    a = runs.attrs
    if a.get("mode") != "threshold":
        return None
    sims, grid = int(a.get("simulations_total", 0)), int(a.get("simulations_grid_equivalent", 0))
    n = runs.sizes["run"]
    text = f"{sims:,} simulations for {n:,} samples ({sims / max(grid, 1):.2f} of the {grid:,} of the full grid)"
    if "audit_checked_samples" not in a:
        return text + "; no audit (no check samples)"
    tc, tm = int(a["audit_thresholds_compared"]), int(a["audit_threshold_mismatches"])
    ec = int(a["audit_early_stopped_climbed"])
    cr = np.asarray(runs["check_run"].values, dtype=np.int64)
    bad = (runs["check_nonmonotone"].values == 1) | (runs["check_disagree"].values.sum(axis=1) > 0)
    where = sorted({f"{runs['shape'].values[r]} on {runs['substrate'].values[r]}" for r in cr[bad]})
    cells = f" (in {', '.join(where)}: maps.audit_nonmonotone, maps.audit_disagree)" if where else ""
    return (
        f"{text}; audit: {int(a['audit_checked_samples'])} samples simulated at every grid value to the end: "
        f"{int(a['audit_nonmonotone_samples'])} non-monotone, thresholds identical in {tc - tm} of {tc}, "
        f"{int(a['audit_disagreements'])} of {int(a['audit_compared_verdicts'])} verdicts differ from the threshold's, "
        f"{ec} of {int(a['audit_early_stopped_probes'])} early stops contradicted (the direct run climbed)"
        + ("" if ec == 0 else " (the bound failed; please report)")
        + cells
        + _nonmonotone_warning(int(a["audit_nonmonotone_samples"]), int(a["audit_checked_samples"]))
    )


def _nonmonotone_warning(k: int, n: int) -> str:
    if k == 0:
        return ""
    return (
        f". WARNING: {k} of {n} audited samples are not monotone along the axis, which a threshold study assumes: "
        "each is counted by the one crossing its search found, so the maps can be wrong between crossings; "
        'run this study with mode = "grid" (or another operating point) before trusting them'
    )
