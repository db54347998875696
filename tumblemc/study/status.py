"""How far a study got: :func:`study_status` from its config or its result file."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from tumblemc.analysis.words import check_words, early_words, threshold_words
from tumblemc.io import ShardStore, open_result, parts_dir, read_study_json, result_attrs
from tumblemc.study.config import load_config
from tumblemc.study.design import check_subset, design
from tumblemc.study.identity import config_hash, config_to_json
from tumblemc.study.partial import cell_map, config_of_parts, has_parts


def default_output(cfg: Any) -> Path:
    """Default result path of a study: ``results/<name>.nc``."""
    return Path("results") / f"{cfg.name}.nc"


def study_status(config_or_result: str | os.PathLike[str], out: str | os.PathLike[str] | None = None) -> dict[str, Any]:
    """How far a study got, from its config (and the default or given result path) or from its result path.

    The result path of an interrupted study (no file yet, its shards in ``<result>.parts``)
    reads the config from the shard folder. Keys: ``state`` ("not started", "partial",
    "complete"), ``done``, ``total``, ``failed``; when partial, ``cells`` (the runs done per
    cell as a text table, :func:`tumblemc.study.partial.cell_map`); when complete, the check
    summary.
    """
    p = Path(config_or_result)
    if p.suffix == ".nc" and (p.exists() or not has_parts(p)):
        if not p.exists():
            raise FileNotFoundError(
                f"{p} does not exist, nor its shard folder {parts_dir(p)}: the study has not started there "
                "(give its TOML to see what it would run)"
            )
        runs, _ = open_result(p)
        return _complete_status(runs, p)
    if p.suffix == ".nc":  # interrupted: its config is in the shard folder
        cfg, path = config_of_parts(p), p
    else:
        cfg = load_config(p)
        path = Path(out) if out is not None else default_output(cfg)
    chash = config_hash(cfg)
    if path.exists():
        stored = result_attrs(path).get("config_hash")
        if stored != chash:
            return _other_config(path, str(stored))
        runs, _ = open_result(path)
        return _complete_status(runs, path)
    store = ShardStore(path, config_to_json(cfg), chash)
    meta = store.dir / "study.json"
    if meta.exists():
        stored = str(read_study_json(meta).get("config_hash"))
        if stored != chash:
            return _other_config(store.dir, stored)
    des = design(cfg)
    n = des.sizes["run"]
    store.n_runs = n
    nc = len(check_subset(des))
    main = store.read("main", set_aside=False)
    damaged = list(store.damaged)
    check_done = len(store.read("check", set_aside=False).get("run", ()))
    damaged += store.damaged
    done = len(main.get("run", ()))
    failed = int(np.count_nonzero(main["status"] != 0)) if done else 0
    out_st: dict[str, Any] = {
        "state": "partial" if done or store.dir.exists() else "not started",
        "path": str(path),
        "done": done,
        "total": n,
        "check_done": check_done,
        "check_total": nc,
        "failed": failed,
    }
    if cfg.precision is not None:  # adaptive: the cells close early, so the totals are the most it may run
        out_st["total_is_cap"] = True  # total and check_total are the most it runs
        out_st["precision"] = cfg.precision
        out_st["note"] = (
            f"adaptive sampling (precision {cfg.precision:g}): total and check_total are the most it runs; "
            "cells stop once their interval's half-width is at most the precision"
        )
    if done:  # where they are: runs done per cell
        out_st["cells"] = cell_map(cfg, main["run"])
    if damaged:
        out_st["damaged_shards"] = f"{len(damaged)} (set aside and simulated again by the next `study run`): " + ", ".join(
            f"{f.name} {why}" for f, why in damaged
        )
    return out_st


def _other_config(where: Path, stored: str) -> dict[str, Any]:
    return {
        "state": "different config",
        "path": str(where),
        "message": f"{where} holds runs of another config (hash {stored[:12]}), not of this one; "
        "`study run --fresh` replaces them, or give another --out",
    }


def _complete_status(runs: xr.Dataset, path: Path) -> dict[str, Any]:
    st = runs["status"].values
    out: dict[str, Any] = {
        "state": "complete",
        "path": str(path),
        "done": int(runs.sizes["run"]),
        "total": int(runs.sizes["run"]),
        "failed": int(np.count_nonzero(st != 0)),
    }
    for k in (
        "precision",
        "runs_simulated",
        "cells_at_cap",
        "check_agreement_rate",
        "check_not_compared",
        "check_median_abs_ratio_diff",
        "check_max_abs_ratio_diff",
        "check_dt_factor",
    ):
        if k in runs.attrs:
            out[k] = runs.attrs[k]
    if "check_run" in runs:
        out["check_total"] = out["check_done"] = int(runs.sizes["check"])
    words = check_words(runs, str(path))
    if words:
        out["dt_check"] = words
    words = early_words(runs)
    if words:
        out["early_decisions"] = words
    words = threshold_words(runs)
    if words:
        out["threshold_search"] = words
    return out
