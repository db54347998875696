"""The ``runs`` and ``maps`` groups of a threshold study (study/threshold.py).

``runs``: the design, each sample's threshold with its bracket, the verdict at every grid
value it implies (``grid_verdict``), the search's probes, and the audit of the check
subset. ``maps``: ``P(success)`` at every grid value from the same samples (the share of
valid samples that pass it), with the study's interval method, and the audit's counts
per cell and grid value.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import xarray as xr

from tumblemc.analysis.maps import maps as make_maps
from tumblemc.schema import CHECK_FLAG_ATTRS, COORD_ATTRS, CRITICAL_ATTRS, OUTCOME_ATTRS, STATUS_FLAGS
from tumblemc.study.config import StudyConfig
from tumblemc.study.modes import THRESHOLD_AXES
from tumblemc.study.stepcfg import step_attrs
from tumblemc.study.threshold import THRESHOLD_OUTCOMES, difficulty_order, direct_passes, implied_verdicts

_YES_NO = {"flag_values": np.array([0, 1], dtype=np.int8), "flag_meanings": "no yes"}


def _attrs(cfg: StudyConfig) -> dict[str, dict[str, Any]]:
    ax = cfg.threshold_axis
    units = COORD_ATTRS[ax].get("units", "1")
    hardest = {"incline_deg": "steepest incline", "field_mT": "weakest field", "freq_hz": "fastest frequency"}[ax]
    easiest = {"incline_deg": "gentlest incline", "field_mT": "strongest field", "freq_hz": "slowest frequency"}[ax]
    return {
        "threshold": {"units": units, "long_name": f"{hardest} of the grid the sample passes (NaN: none)"},
        "threshold_fail": {"units": units, "long_name": f"{easiest} of the grid the sample fails (NaN: none)"},
        "n_pass": {"units": "1", "long_name": "grid values the sample passes (the threshold as a count; -1: unknown, see status)"},
        "pass_rank": {"units": "1", "long_name": "difficulty rank of the last grid value passed (-1: none)"},
        "fail_rank": {"units": "1", "long_name": "difficulty rank of the first grid value failed (grid size: none)"},
        "censored": {
            "units": "1",
            "long_name": "threshold outside the grid (meaningful where status is ok)",
            "flag_values": np.array([-1, 0, 1], dtype=np.int8),
            "flag_meanings": "fails_every_value bracketed passes_every_value",
        },
        "search_start": {"units": "1", "long_name": "difficulty rank of the grid value the search probed first (the prior's median)"},
        "n_simulations": {"units": "1", "long_name": "simulations the search used"},
        "status": {"units": "1", "long_name": "status of the search (the first invalid probe's; ok: every probe valid)", **STATUS_FLAGS},
        # the solver's counts over a sample's simulations: as a critical-incline study reports them
        **{k: CRITICAL_ATTRS[k] for k in ("newton_iterations", "substeps", "failed_steps", "loose_steps", "impulse_steps")},
        "probe_climbed": {
            "units": "1",
            "long_name": "verdict of the search's simulation at the grid value",
            "flag_values": np.array([-1, 0, 1], dtype=np.int8),
            "flag_meanings": "not_simulated no yes",
        },
        "probe_decided_early": {"units": "1", "long_name": "the search's simulation there was stopped by the early decision", **_YES_NO},
        "probe_status": {"units": "1", "long_name": "status of the search's simulation at the grid value (-1: not simulated)"},
    }


def assemble_threshold(
    cfg: StudyConfig, des: xr.Dataset, main: dict[str, np.ndarray], check_idx: np.ndarray, check: dict[str, np.ndarray]
) -> xr.Dataset:
    """The ``runs`` group of a threshold study (the module docstring)."""
    n = des.sizes["run"]
    if len(main.get("run", ())) != n or not np.array_equal(main["run"], np.arange(n)):
        raise RuntimeError("internal error: the shards do not hold every run of the study")
    ax = cfg.threshold_axis
    vals = np.asarray(cfg.axis_values, dtype=float)
    order = difficulty_order(cfg)
    runs = des.copy().assign_coords({ax: (ax, vals, dict(COORD_ATTRS[ax]))})
    runs.attrs = {
        "title": "every sample: design, threshold, the search's probes and the audit",
        "config_hash": des.attrs["config_hash"],
        "uncertain": des.attrs["uncertain"],
        "success_ratio": float(cfg.success_ratio),
    }
    runs["run"].attrs.update({"units": "1", "long_name": "run index (one parameter sample each)"})
    runs["check_flag"] = runs["check_flag"].astype(np.int8)
    runs["check_flag"].attrs.update({**des["check_flag"].attrs, **CHECK_FLAG_ATTRS})
    attrs = _attrs(cfg)
    for k, (dtype, width) in THRESHOLD_OUTCOMES.items():
        runs[k] = (("run", ax) if width == "grid" else "run", main[k].astype(dtype))
        runs[k].attrs.update(attrs[k])
    runs["threshold"].attrs["ancillary_variables"] = "status censored threshold_fail"
    runs["error"] = ("run", main["error"].astype(str))
    runs["error"].attrs.update(OUTCOME_ATTRS["error"])
    verdict = implied_verdicts(main["pass_rank"], main["fail_rank"], order)
    runs["grid_verdict"] = (("run", ax), verdict)
    runs["grid_verdict"].attrs.update(
        {
            "units": "1",
            "long_name": "verdict at the grid value implied by the threshold (unknown: inside the bracket of an invalid search)",
            "flag_values": np.array([-1, 0, 1], dtype=np.int8),
            "flag_meanings": "unknown no yes",
        }
    )
    runs.attrs.update(
        {
            "mode": "threshold",
            "threshold_axis": ax,
            "threshold_direction": THRESHOLD_AXES[ax],
            "threshold_start": cfg.threshold_start,
            "early_decision": int(cfg.early_decision),
            "check_dt_factor": float(cfg.check.dt_factor),
            **step_attrs(cfg),
            "simulations_total": int(runs["n_simulations"].sum()),
            "simulations_grid_equivalent": int(n * len(vals)),
            "decided_early_runs": int(np.count_nonzero(main["probe_decided_early"] == 1)),
        }
    )
    if len(check_idx):
        runs = _with_audit(runs, cfg, check_idx, check, verdict, order)
    return runs


def _with_audit(
    runs: xr.Dataset, cfg: StudyConfig, check_idx: np.ndarray, check: dict[str, np.ndarray], verdict: np.ndarray, order: np.ndarray
) -> xr.Dataset:
    ax = cfg.threshold_axis
    pos = np.searchsorted(check["run"], check_idx)
    if not np.array_equal(check["run"][np.minimum(pos, len(check["run"]) - 1)], check_idx):
        raise RuntimeError("internal error: the shards do not hold every check run of the study")
    g = check["grid_climbed"][pos].astype(np.int8)
    gs = check["grid_status"][pos].astype(np.int8)
    imp = verdict[check_idx]
    ok = (gs == 0) & (imp >= 0)
    dis = (g != imp) & ok
    gd, okd = g[:, order], (gs == 0)[:, order]  # difficulty order: a pass after a failure is non-monotone
    nonmono = np.array([bool(np.any(np.diff(r[o].astype(int)) > 0)) for r, o in zip(gd, okd, strict=True)])
    direct_j = direct_passes(g[:, order], gs[:, order])  # grid values passed before the first direct failure
    searched_j = runs["n_pass"].values[check_idx].astype(np.int64)
    both = (direct_j >= 0) & (searched_j >= 0)
    mismatch = both & (direct_j != searched_j)
    early = runs["probe_decided_early"].values[check_idx] == 1
    early_climbed = early & (gs == 0) & (g == 1)  # stopped as failures by the search, climbed when run to the end
    bound = np.isfinite(check["grid_decided_time"][pos]) & (gs == 0)  # the bound fired on a full direct run
    runs = runs.assign_coords(check=np.arange(len(check_idx)), pair=["last_pass", "first_fail"])
    runs["check"].attrs.update({"units": "1", "long_name": "index of an audited (check) sample"})
    runs["pair"].attrs.update({"long_name": "the last grid value passed and the first failed in the direct runs"})
    cols: dict[str, tuple[tuple[str, ...], np.ndarray, dict[str, Any]]] = {
        "check_run": (("check",), check_idx, {"units": "1", "long_name": "index (along run) of a checked sample"}),
        "check_grid_climbed": (("check", ax), g, {"units": "1", "long_name": "verdict of a direct simulation to the end", **_YES_NO}),
        "check_grid_status": (("check", ax), gs, {"units": "1", "long_name": "status of the direct simulation", **STATUS_FLAGS}),
        "check_grid_progress_ratio": (("check", ax), check["grid_ratio"][pos], {"units": "1", "long_name": "progress ratio there"}),
        "check_disagree": (
            ("check", ax),
            dis.astype(np.int8),
            {"units": "1", "long_name": "the direct verdict differs from the one the threshold implies", **_YES_NO},
        ),
        "check_nonmonotone": (
            ("check",),
            nonmono.astype(np.int8),
            {"units": "1", "long_name": "the sample passes a grid value harder than one it fails (direct runs)", **_YES_NO},
        ),
        "check_n_pass_direct": (
            ("check",),
            direct_j.astype(np.int16),
            {"units": "1", "long_name": "grid values passed before the first direct failure (-1: an invalid direct run first)"},
        ),
        "check_early_stop_climbed": (
            ("check", ax),
            early_climbed.astype(np.int8),
            {"units": "1", "long_name": "the search's run there was stopped early, the direct run to the end climbed", **_YES_NO},
        ),
    }
    pc, pf = check["pair_climbed"][pos].astype(np.int8), check["pair_climbed_fine"][pos].astype(np.int8)
    compared = np.all((check["pair_status_fine"][pos] == 0) & (check["pair_status"][pos] == 0), axis=1)
    agree = np.where(compared, np.all(pc == pf, axis=1).astype(np.int8), -1).astype(np.int8)
    vals = np.asarray(cfg.axis_values)[order]
    cols["check_pair_value"] = (
        ("check", "pair"),
        vals[check["pair_index"][pos].astype(np.int64)],
        {"units": COORD_ATTRS[ax].get("units", "1"), "long_name": "grid values around the first direct failure"},
    )
    cols["check_climbed_fine"] = (("check", "pair"), pf, {"units": "1", "long_name": "verdicts there at dt / check_dt_factor"})
    cols["check_agree"] = (
        ("check",),
        agree,
        {
            "units": "1",
            "long_name": "verdicts around the first direct failure equal those at dt / check_dt_factor (compared where all four are valid)",
            "flag_values": np.array([-1, 0, 1], dtype=np.int8),
            "flag_meanings": "not_compared no yes",
        },
    )
    for k, (dims, v, a) in cols.items():
        runs[k] = (dims, v)
        runs[k].attrs.update(a)
    n_ok = int(ok.sum())
    runs.attrs.update(
        {
            "audit_checked_samples": len(check_idx),
            "audit_nonmonotone_samples": int(nonmono.sum()),
            "audit_compared_verdicts": n_ok,
            "audit_disagreements": int(dis.sum()),
            "audit_thresholds_compared": int(both.sum()),
            "audit_threshold_mismatches": int(mismatch.sum()),
            "audit_disagreement_rate": float(dis.sum() / n_ok) if n_ok else math.nan,
            "audit_early_stopped_probes": int(early.sum()),
            "audit_early_stopped_climbed": int(early_climbed.sum()),
            "early_decision_audit_dt_runs": int(np.count_nonzero(gs == 0)),
            "early_decision_audit_dt_decided": int(bound.sum()),
            "early_decision_audit_dt_climbed": int(np.count_nonzero(bound & (g == 1))),
            "check_agreement_rate": float((agree[compared] == 1).mean()) if compared.any() else math.nan,
            "check_not_compared": int(np.count_nonzero(~compared)),
        }
    )
    return runs


def virtual_grid_runs(runs: xr.Dataset) -> xr.Dataset:
    """One virtual run per sample and grid value with the implied verdict (unknown verdicts: the search's status)."""
    ax = str(runs.attrs["threshold_axis"])
    vals = runs[ax].values
    n, m = runs.sizes["run"], len(vals)
    v = runs["grid_verdict"].values
    st = np.where(v >= 0, 0, np.maximum(np.repeat(runs["status"].values[:, None], m, axis=1), 1)).astype(np.int8)
    dims = [d for d in ("shape", "substrate", "incline_deg", "field_mT", "freq_hz", "sample") if d != ax and d in runs.coords]
    rep = {k: np.repeat(runs[k].values, m) for k in dims}
    return xr.Dataset(
        {
            "climbed": ("run", (v == 1).astype(np.int8).ravel()),
            "progress_ratio": ("run", np.full(n * m, math.nan)),
            "mean_speed": ("run", np.full(n * m, math.nan)),
            "status": ("run", st.ravel()),
        },
        coords={**{k: ("run", r) for k, r in rep.items()}, ax: ("run", np.tile(vals, n))},
        attrs=dict(runs.attrs),
    )


def threshold_maps(runs: xr.Dataset, level: float, method: str) -> xr.Dataset:
    """The ``maps`` group: :func:`tumblemc.analysis.maps.maps` of :func:`virtual_grid_runs`, plus the audit per cell."""
    out = make_maps(virtual_grid_runs(runs), level=level, method=method)
    ax = str(runs.attrs["threshold_axis"])
    for k in ("progress_ratio_mean", "mean_speed_mean", "progress_ratio_quantile"):  # no ratio is measured at every value
        if k in out:
            out = out.drop_vars(k)
    out.attrs["mode"] = "threshold"
    out.attrs["threshold_axis"] = ax
    out.attrs["p_success_definition"] = (
        f"share of valid samples whose threshold passes the {ax} grid value (samples common to the cell row)"
    )
    if "check_run" not in runs:
        return out
    cr = runs["check_run"].values
    key = {d: runs[d].values[cr] for d in out.dims if d in runs.coords and d != ax}
    checked = np.zeros(out["p_success"].shape, np.int64)
    disagree = np.zeros_like(checked)
    nonmono = np.zeros_like(checked)
    early = np.zeros_like(checked)
    dims = list(out["p_success"].dims)
    ok = runs["check_grid_status"].values == 0
    for c in range(len(cr)):
        base = tuple(slice(None) if d == ax else int(np.flatnonzero(out[d].values == key[d][c])[0]) for d in dims)
        axis_pos = dims.index(ax) if ax in dims else None
        sel = (ok[c], runs["check_disagree"].values[c], runs["check_early_stop_climbed"].values[c])
        if axis_pos is None:  # a single grid value cannot happen (config), kept general
            continue
        checked[base] += sel[0]
        disagree[base] += sel[1]
        early[base] += sel[2]
        nonmono[base] += int(runs["check_nonmonotone"].values[c])
    for name, arr, long in (
        ("audit_checked", checked, "checked samples with a valid direct run at this grid value (the audit)"),
        ("audit_disagree", disagree, "of those, direct verdicts that differ from the threshold's"),
        ("audit_nonmonotone", nonmono, "checked samples of the cell row that are not monotone along the axis"),
        ("audit_early_stop_climbed", early, "runs the search stopped early whose direct run to the end climbed (must be 0)"),
    ):
        out[name] = (dims, arr, {"units": "1", "long_name": long})
    return out
