"""The ``runs`` group of a study file, and the file's root (CF/ACDD, provenance) attributes.

The group is built from the study's design and shards (grid and critical-incline modes,
with the numerical dt check).
"""

from __future__ import annotations

import datetime as _dt
import math
from typing import Any

import numpy as np
import xarray as xr

from tumblemc.analysis.critical import climbs_at
from tumblemc.model.step_check import tolerance
from tumblemc.schema import (
    CHECK_FLAG_ATTRS,
    CRITICAL_ATTRS,
    CRITICAL_CHECK_VARIABLES,
    CRITICAL_OUTCOMES,
    GRID_CHECK_VARIABLES,
    OUTCOME_ATTRS,
    OUTCOMES,
    STUDY_FILE_ATTRS,
)
from tumblemc.study.config import SAMPLING_SCHEME, StudyConfig
from tumblemc.study.design import check_inclines
from tumblemc.study.stepcfg import step_attrs
from tumblemc.version import __version__, build_info


def provenance(cfg: StudyConfig, cjson: str, chash: str) -> dict[str, Any]:
    """Root attributes of a study file: CF/ACDD-1.3 global attributes and provenance.

    The groups repeat none of them but ``config_hash`` (and the ``runs`` group
    ``uncertain`` and ``success_ratio``, which define its columns).
    """
    now = _dt.datetime.now(_dt.UTC).replace(microsecond=0).isoformat()
    return {
        "Conventions": "CF-1.10 ACDD-1.3",  # CF 2.6.1: blank-separated
        "title": f"tumblemc study {cfg.name}",
        "summary": cfg.description or f"Monte Carlo robustness study {cfg.name}",
        **STUDY_FILE_ATTRS,
        # the study's identity: the same id is the same config (seed included); the code
        # that ran it is tumblemc_version and git_sha
        "id": f"study-{cfg.name}-{chash[:16]}",
        "source": f"tumblemc {__version__}",
        "history": f"{now} tumblemc {__version__} run_study {cfg.name}",
        "date_created": now,
        "tumblemc_version": __version__,
        **build_info(),
        "study_name": cfg.name,
        "mode": cfg.mode,
        "config_json": cjson,
        "config_hash": chash,
        "seed": int(cfg.seed),
        "sampler": cfg.sampler,
        "sampling_scheme": SAMPLING_SCHEME,
        "success_ratio": float(cfg.success_ratio),
        "uncertain": ",".join(cfg.uncertain_names),
    }


def _with_outcomes(
    cfg: StudyConfig, des: xr.Dataset, main: dict[str, np.ndarray], columns: dict[str, type], attrs: dict[str, dict[str, Any]]
) -> xr.Dataset:
    """The design plus the outcome ``columns`` of every run (checked to be complete)."""
    n = des.sizes["run"]
    runs = des.copy()
    if len(main.get("run", ())) != n or not np.array_equal(main["run"], np.arange(n)):
        raise RuntimeError("internal error: the shards do not hold every run of the study")
    # the design's attributes are the study's and go to the root (provenance); the group
    # keeps what its columns need and the config hash that ties it to the root
    runs.attrs = {
        "title": "every run: design, outcome and numerical checks",
        "config_hash": des.attrs["config_hash"],
        "uncertain": des.attrs["uncertain"],
        "success_ratio": float(cfg.success_ratio),
    }
    runs["check_flag"] = runs["check_flag"].astype(np.int8)
    runs["check_flag"].attrs.update({**des["check_flag"].attrs, **CHECK_FLAG_ATTRS})
    for k, dtype in columns.items():
        runs[k] = ("run", main[k].astype(dtype))
        runs[k].attrs.update(attrs[k])
    runs["error"] = ("run", main["error"].astype(str))
    runs["error"].attrs.update(OUTCOME_ATTRS["error"])
    return runs


def _check_pos(check: dict[str, np.ndarray], check_idx: np.ndarray) -> np.ndarray:
    """Positions of the check runs ``check_idx`` in the (sorted) check shards."""
    pos = np.searchsorted(check["run"], check_idx)
    if not np.array_equal(check["run"][np.minimum(pos, len(check["run"]) - 1)], check_idx):
        raise RuntimeError("internal error: the shards do not hold every check run of the study")
    return pos


def _audit(runs: xr.Dataset, check_idx: np.ndarray, check: dict[str, np.ndarray], pos: np.ndarray) -> dict[str, int]:
    """The early decision's audit over the check runs simulated to the end.

    At dt and at the finer dt: how many the energy bound decided, how many of those
    nevertheless climbed (must be 0), and how many it decided that ended invalid (a run
    stopped early counts as a failure, where the full run would have been left out).
    """
    out = {}
    for tag, decided, climbed_, status, early in (
        (
            "dt",
            runs["decided_time"].values[check_idx],
            runs["climbed"].values[check_idx],
            runs["status"].values[check_idx],
            runs["decided_early"].values[check_idx],
        ),
        ("fine", check["decided_time"][pos], check["climbed"][pos], check["status"][pos], np.zeros(len(pos), np.int8)),
    ):
        full = (early == 0) & (status == 0)
        hit = full & np.isfinite(decided)
        out[f"early_decision_audit_{tag}_runs"] = int(np.count_nonzero(full))
        out[f"early_decision_audit_{tag}_decided"] = int(np.count_nonzero(hit))
        out[f"early_decision_audit_{tag}_climbed"] = int(np.count_nonzero(hit & (climbed_ == 1)))
        # decided, then invalid later (a failed step, the ledger): stopped early, such a run counts as a failure
        out[f"early_decision_audit_{tag}_invalid_after"] = int(np.count_nonzero((early == 0) & (status != 0) & np.isfinite(decided)))
    return out


def ratio_tol(cfg: StudyConfig, fine_ratio: np.ndarray) -> np.ndarray:
    """The dt check's tolerance of each check run: ``ratio_abs_tol + ratio_rel_tol |ratio at the finer dt|``."""
    return tolerance(np.asarray(fine_ratio, dtype=np.float64), cfg.check.ratio_abs_tol, cfg.check.ratio_rel_tol)


def ratio_within(cfg: StudyConfig, coarse: dict[str, np.ndarray], fine: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The dt check's ratio comparison of check runs: ``(fine - coarse ratio, within)``.

    ``coarse``: ``status``, ``progress_ratio`` and ``decided_early`` of the runs at the study
    dt; ``fine``: ``status`` and ``progress_ratio`` at ``dt / dt_factor``. ``within`` is 1
    where ``|diff| <= ratio_abs_tol + ratio_rel_tol |fine|``, 0 where not, -1 where not
    compared: a run invalid at either step, or stopped by an early decision (its ratio is
    censored: its verdict is compared, not its ratio; the planned check runs run to the
    end, an adaptive study's may not). ``diff`` is NaN where censored.
    """
    compared = (np.asarray(fine["status"]) == 0) & (np.asarray(coarse["status"]) == 0)
    censored = np.asarray(coarse["decided_early"]) == 1
    fine_ratio = np.asarray(fine["progress_ratio"], dtype=np.float64)
    diff = np.where(censored, np.nan, fine_ratio - np.asarray(coarse["progress_ratio"], dtype=np.float64))
    with np.errstate(invalid="ignore"):
        within = np.where(compared & ~censored, (np.abs(diff) <= ratio_tol(cfg, fine_ratio)).astype(np.int8), -1).astype(np.int8)
    return diff, within


#: columns of the sensitivity twins, carried in the check runs' outcomes (NaN and -1 where not simulated)
TWIN_COLUMNS = ("twin_ratio_up", "twin_ratio_down", "twin_status_up", "twin_status_down")


def twin_sensitivity(ratio: np.ndarray, twins: dict[str, np.ndarray], tol: np.ndarray, within: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Whether a check run outside the ratio tolerance is resolved by its model at all: ``(spread, sensitive)``.

    ``spread`` is the larger move of the ratio at the study dt when the magnetisation is
    changed by ``+- check.twin_rel`` (NaN where the twins were not simulated or either is
    invalid). ``sensitive`` is 1 where ``spread > tol`` (the dt check's tolerance of that
    run): a change far below any measurement already moves the ratio beyond the tolerance,
    so the model does not determine the ratio to the tolerance and no dt can; 0 where the
    twins stay within it (the ratio at this dt is limited by dt); -1 where not classified
    (within tolerance, not compared, or no valid twins).
    """
    ok = (np.asarray(twins["twin_status_up"]) == 0) & (np.asarray(twins["twin_status_down"]) == 0) & (within == 0)
    with np.errstate(invalid="ignore"):
        spread = np.maximum(np.abs(twins["twin_ratio_up"] - ratio), np.abs(twins["twin_ratio_down"] - ratio))
        spread = np.where(ok, spread, np.nan)
        sensitive = np.where(ok, (spread > tol).astype(np.int8), -1).astype(np.int8)
    return spread, sensitive


def assemble_runs(
    cfg: StudyConfig, des: xr.Dataset, main: dict[str, np.ndarray], check_idx: np.ndarray, check: dict[str, np.ndarray]
) -> xr.Dataset:
    """The ``runs`` group: the design plus every run's outcome and the check subset."""
    runs = _with_outcomes(cfg, des, main, OUTCOMES, OUTCOME_ATTRS)
    runs["climbed"].attrs["ancillary_variables"] = "status progress_ratio"
    runs["progress_ratio"].attrs["ancillary_variables"] = "status"
    if len(check_idx):
        pos = _check_pos(check, check_idx)
        fine_ratio = check["progress_ratio"][pos]
        fine_climbed = check["climbed"][pos].astype(np.int8)
        runs["check_run"] = ("check", check_idx)
        runs["check_run"].attrs.update(GRID_CHECK_VARIABLES["check_run"])
        runs["check_progress_ratio_fine"] = ("check", fine_ratio)
        runs["check_progress_ratio_fine"].attrs.update(GRID_CHECK_VARIABLES["check_progress_ratio_fine"])
        runs["check_climbed_fine"] = ("check", fine_climbed)
        runs["check_climbed_fine"].attrs.update(GRID_CHECK_VARIABLES["check_climbed_fine"])
        runs["check_status_fine"] = ("check", check["status"][pos].astype(np.int8))
        runs["check_status_fine"].attrs.update(GRID_CHECK_VARIABLES["check_status_fine"])
        compared = (check["status"][pos] == 0) & (runs["status"].values[check_idx] == 0)
        agree = np.where(compared, (fine_climbed == runs["climbed"].values[check_idx]).astype(np.int8), -1).astype(np.int8)
        runs["check_agree"] = ("check", agree)
        runs["check_agree"].attrs.update(GRID_CHECK_VARIABLES["check_agree"])
        coarse = {k: runs[k].values[check_idx] for k in ("status", "progress_ratio", "decided_early")}
        diff, within = ratio_within(cfg, coarse, {k: check[k][pos] for k in ("status", "progress_ratio")})
        d = np.abs(diff)
        runs["check_ratio_diff"] = ("check", diff)
        runs["check_ratio_diff"].attrs.update(GRID_CHECK_VARIABLES["check_ratio_diff"])
        runs["check_ratio_within_tol"] = ("check", within)
        runs["check_ratio_within_tol"].attrs.update(GRID_CHECK_VARIABLES["check_ratio_within_tol"])
        runs.attrs["check_ratio_abs_tol"] = cfg.check.ratio_abs_tol
        runs.attrs["check_ratio_rel_tol"] = cfg.check.ratio_rel_tol
        runs.attrs["check_within_tol_rate"] = float((within[within >= 0] == 1).mean()) if (within >= 0).any() else math.nan
        runs.attrs["check_n_outside_tol"] = int(np.count_nonzero(within == 0))
        if "twin_ratio_up" in check:
            tol = ratio_tol(cfg, check["progress_ratio"][pos])
            spread, sensitive = twin_sensitivity(coarse["progress_ratio"], {k: check[k][pos] for k in TWIN_COLUMNS}, tol, within)
            runs["check_twin_spread"] = ("check", spread)
            runs["check_twin_spread"].attrs.update(GRID_CHECK_VARIABLES["check_twin_spread"])
            for tag in ("up", "down"):  # each twin's ratio (NaN where not simulated or not valid)
                name, ok = f"check_twin_ratio_{tag}", check[f"twin_status_{tag}"][pos] == 0
                runs[name] = ("check", np.where(ok, check[f"twin_ratio_{tag}"][pos], np.nan))
                runs[name].attrs.update(GRID_CHECK_VARIABLES[name])
            runs["check_sensitive"] = ("check", sensitive)
            runs["check_sensitive"].attrs.update(GRID_CHECK_VARIABLES["check_sensitive"])
            runs.attrs["check_twin_rel"] = cfg.check.twin_rel
            runs.attrs["check_n_sensitive"] = int(np.count_nonzero(sensitive == 1))
            runs.attrs["check_n_dt_limited"] = int(np.count_nonzero(sensitive == 0))
        runs.attrs["check_agreement_rate"] = float((agree[compared] == 1).mean()) if compared.any() else math.nan
        runs.attrs["check_not_compared"] = int(np.count_nonzero(~compared))
        runs.attrs["check_median_abs_ratio_diff"] = float(np.nanmedian(d)) if np.isfinite(d).any() else math.nan
        runs.attrs["check_max_abs_ratio_diff"] = float(np.nanmax(d)) if np.isfinite(d).any() else math.nan
        runs.attrs.update(_audit(runs, check_idx, check, pos))
        runs = runs.assign_coords(check=np.arange(len(check_idx)))
        runs["check"].attrs.update(GRID_CHECK_VARIABLES["check"])
    if "run" in runs.coords:
        runs["run"].attrs.update(GRID_CHECK_VARIABLES["run"])
    runs.attrs["check_dt_factor"] = float(cfg.check.dt_factor)
    runs.attrs["early_decision"] = int(cfg.early_decision)
    runs.attrs["decided_early_runs"] = int(np.count_nonzero(runs["decided_early"].values == 1))
    runs.attrs.update(step_attrs(cfg))
    return runs


def assemble_critical(
    cfg: StudyConfig, des: xr.Dataset, main: dict[str, np.ndarray], check_idx: np.ndarray, check: dict[str, np.ndarray]
) -> xr.Dataset:
    """The ``runs`` group of a critical-incline study.

    The design, each sample's critical incline, and the monotonicity and numerical checks
    of the check subset.
    """
    n = des.sizes["run"]
    runs = _with_outcomes(cfg, des, main, CRITICAL_OUTCOMES, CRITICAL_ATTRS)
    runs["critical_incline_deg"].attrs["ancillary_variables"] = "status censored fails_at_deg"
    runs["run"].attrs.update(CRITICAL_CHECK_VARIABLES["run"])
    lo, hi = cfg.incline_range
    th = np.array(check_inclines(cfg))
    runs.attrs.update(
        {
            "mode": cfg.mode,
            "incline_range_min": lo,
            "incline_range_max": hi,
            "incline_tol": cfg.incline_tol,
            "check_dt_factor": float(cfg.check.dt_factor),
        }
    )
    runs.attrs.update(step_attrs(cfg))
    if len(check_idx):
        pos = _check_pos(check, check_idx)
        g = check["grid_climbed"][pos].astype(np.int8)
        gs = check["grid_status"][pos].astype(np.int8)
        pred = climbs_at(runs["critical_incline_deg"].values[check_idx], th)
        ok = (gs == 0) & (runs["status"].values[check_idx] == 0)[:, None]
        dis = (g != pred) & ok
        # a verdict sequence along the incline is monotone if it never climbs after a failure
        nonmono = np.array([bool(np.any(np.diff(row[okr].astype(int)) > 0)) for row, okr in zip(g, ok, strict=True)])
        runs = runs.assign_coords(check=np.arange(len(check_idx)), check_incline_deg=th)
        runs["check"].attrs.update(CRITICAL_CHECK_VARIABLES["check"])
        runs["check_incline_deg"].attrs.update(CRITICAL_CHECK_VARIABLES["check_incline_deg"])
        runs["check_run"] = ("check", check_idx)
        runs["check_run"].attrs.update(CRITICAL_CHECK_VARIABLES["check_run"])
        runs["check_grid_climbed"] = (("check", "check_incline_deg"), g)
        runs["check_grid_climbed"].attrs.update(CRITICAL_CHECK_VARIABLES["check_grid_climbed"])
        runs["check_grid_status"] = (("check", "check_incline_deg"), gs)
        runs["check_grid_status"].attrs.update(CRITICAL_CHECK_VARIABLES["check_grid_status"])
        runs["check_disagree"] = (("check", "check_incline_deg"), dis.astype(np.int8))
        runs["check_disagree"].attrs.update(CRITICAL_CHECK_VARIABLES["check_disagree"])
        runs["check_nonmonotone"] = ("check", nonmono.astype(np.int8))
        runs["check_nonmonotone"].attrs.update(CRITICAL_CHECK_VARIABLES["check_nonmonotone"])
        pc, pf = check["pair_climbed"][pos].astype(np.int8), check["pair_climbed_fine"][pos].astype(np.int8)
        compared = np.all((check["pair_status_fine"][pos] == 0) & (check["pair_status"][pos] == 0), axis=1)
        agree = np.where(compared, np.all(pc == pf, axis=1).astype(np.int8), -1).astype(np.int8)
        runs["check_agree"] = ("check", agree)
        runs["check_agree"].attrs.update(CRITICAL_CHECK_VARIABLES["check_agree"])
        runs["check_climbed_fine"] = (("check", "pair"), pf)
        runs["check_climbed_fine"].attrs.update(CRITICAL_CHECK_VARIABLES["check_climbed_fine"])
        runs["check_pair_incline_deg"] = (("check", "pair"), check["pair_incline"][pos])
        runs["check_pair_incline_deg"].attrs.update(CRITICAL_CHECK_VARIABLES["check_pair_incline_deg"])
        n_ok = int(ok.sum())
        runs.attrs["monotonicity_disagreement_rate"] = float(dis.sum() / n_ok) if n_ok else math.nan
        runs.attrs["monotonicity_nonmonotone_samples"] = int(nonmono.sum())
        runs.attrs["monotonicity_checked_samples"] = len(check_idx)
        runs.attrs["check_agreement_rate"] = float((agree[compared] == 1).mean()) if compared.any() else math.nan
        runs.attrs["check_not_compared"] = int(np.count_nonzero(~compared))
    runs.attrs["simulations_total"] = int(runs["n_simulations"].sum())
    runs.attrs["simulations_grid_equivalent"] = int(n * len(th))
    return runs
