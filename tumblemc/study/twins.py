"""The sensitivity twins of a grid study's dt check (``[check] twin_rel``; docs/studies.md, "The dt check").

A check run whose ratios at dt and at ``dt / dt_factor`` differ beyond the tolerance is
simulated twice more at the study dt with the magnetisation x (1 +- ``twin_rel``). Where
the twins move its ratio beyond the same tolerance, the model does not determine the ratio
to the tolerance and no dt can (the run is sensitive); elsewhere the ratio is limited by
dt. The engine runs them
(:func:`tumblemc.study.engine.run_study`, shard kinds :data:`TWIN_KINDS`) and
:func:`tumblemc.study.assemble.twin_sensitivity` classes them.
"""

from __future__ import annotations

from typing import cast

import numpy as np

from tumblemc.model.params import PRESETS
from tumblemc.model.rows import RunRow
from tumblemc.study.assemble import ratio_within
from tumblemc.study.config import StudyConfig

#: the sensitivity twins of the dt check: a check run outside the ratio tolerance again at the
#: study dt, with the magnetisation x (1 + twin_rel) and x (1 - twin_rel)
TWIN_KINDS = {"twin_up": 1.0, "twin_down": -1.0}


def twin_row(row: RunRow, sign: float, rel: float, param: str = "magnetization") -> RunRow:
    """``row`` with ``param`` (the row's value, else the preset's) times ``1 + sign x rel``."""
    value = float(row[param]) if param in row else float(getattr(PRESETS[row["preset"]], param))  # type: ignore[literal-required]
    return cast(RunRow, {**row, param: value * (1.0 + sign * rel)})


def outside_tol(cfg: StudyConfig, main: dict[str, np.ndarray], check: dict[str, np.ndarray], check_idx: np.ndarray) -> np.ndarray:
    """The check runs whose ratios at dt and at the finer dt differ beyond the tolerance (grid mode, twins on)."""
    if cfg.mode != "grid" or cfg.check.twin_rel == 0.0 or not len(check_idx):
        return np.zeros(0, np.int64)
    mpos, cpos = np.searchsorted(main["run"], check_idx), np.searchsorted(check["run"], check_idx)
    coarse = {k: main[k][mpos] for k in ("status", "progress_ratio", "decided_early")}
    _, within = ratio_within(cfg, coarse, {k: check[k][cpos] for k in ("status", "progress_ratio")})
    return np.asarray(check_idx, dtype=np.int64)[within == 0]


def with_twins(check: dict[str, np.ndarray], twins: dict[str, dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """The check runs' outcomes with the twins' ratios and statuses (NaN and -1 where none).

    The columns are :data:`tumblemc.study.assemble.TWIN_COLUMNS`.
    """
    out = dict(check)
    runs = np.asarray(check["run"], dtype=np.int64)
    for kind in TWIN_KINDS:
        tag = kind.removeprefix("twin_")
        ratio, status = np.full(runs.size, np.nan), np.full(runs.size, -1, np.int8)
        t = twins.get(kind, {})
        if t and len(t["run"]):
            pos = np.searchsorted(runs, t["run"])
            ratio[pos], status[pos] = t["progress_ratio"], t["status"]
        out[f"twin_ratio_{tag}"], out[f"twin_status_{tag}"] = ratio, status
    return out
