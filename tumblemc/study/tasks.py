"""A study's unit of work: :class:`Task` (one batch of runs of one shape) and :func:`execute_task`.

Split from :mod:`tumblemc.study.engine`, which plans the tasks and hands them to dask.
A task carries everything its worker needs (rows of keywords, time grids); executing it
never touches the study's files.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import cast

import numpy as np
import xarray as xr

from tumblemc.model.rows import RunRow, TimeGrid, simulate_rows
from tumblemc.schema import CHECK_COLUMNS, CRITICAL_OUTCOMES, OUTCOMES
from tumblemc.study.config import StudyConfig
from tumblemc.study.critical import bisect_rows, monotonicity_rows
from tumblemc.study.design import batch_row, design_values
from tumblemc.study.threshold import error_columns, search_rows, sweep_rows, to_axis_order


@dataclass(frozen=True)
class Task:
    """One batch: runs of one shape on one time grid (a dask task)."""

    kind: str  # "main" or "check"
    key: str
    shape: str
    run: tuple[int, ...]
    rows: tuple[RunRow, ...]
    grid: TimeGrid
    mode: str = "grid"
    # critical_incline mode: incline range and tolerance, check grid, fine time grid
    lo: float = 0.0
    hi: float = 0.0
    tol: float = 0.0
    inclines: tuple[float, ...] = ()
    fine: TimeGrid | None = None
    full: tuple[bool, ...] = ()  # rows run to the end despite grid.early_decision (the dt-check runs: the audit)
    # threshold mode: each run's rows at every grid value (difficulty order), the cell's prior
    axis_rows: tuple[tuple[RunRow, ...], ...] = ()
    prior: tuple[float, ...] = ()  # over the threshold 0 .. m (study/threshold.py; empty: plain bisection)
    cfg: StudyConfig | None = None


def one_run_tasks(task: Task) -> list[Task]:
    """``task`` split into one task per run.

    Each keeps its row and its ``full`` flag and gets its own key (:func:`plan`'s form for
    a batch of one).
    """
    stem = task.key.rsplit("-", 2)[0]
    return [
        dataclasses.replace(
            task,
            key=f"{stem}-{r:09d}-1",
            run=(r,),
            rows=task.rows[k : k + 1],
            full=task.full[k : k + 1],
            axis_rows=task.axis_rows[k : k + 1],
        )
        for k, r in enumerate(task.run)
    ]


def execute_task(task: Task) -> tuple[str, np.ndarray, dict[str, np.ndarray]]:
    """Run one batch (the function every dask task calls).

    A batch that raises is rerun row by row; a row that still raises is recorded with status
    ``error`` and the message, so one bad run never stops a study.
    """
    try:
        return _execute_task(task)
    except Exception:  # noqa: BLE001 - any failure of a run is data, not a crash
        if len(task.run) == 1:
            return _error_result(task)
        parts = [execute_task(t) for t in one_run_tasks(task)]
        return task.kind, np.asarray(task.run, dtype=np.int64), {k: np.concatenate([p[2][k] for p in parts]) for k in parts[0][2]}


def _error_result(task: Task) -> tuple[str, np.ndarray, dict[str, np.ndarray]]:
    import traceback

    msg = traceback.format_exc(limit=2).strip().splitlines()[-1]
    if task.mode == "threshold":
        assert task.cfg is not None
        cols = error_columns(task.kind, 1, len(task.cfg.axis_values))
        if task.kind == "main":
            cols["error"] = np.array([f"internal error: {msg}"], dtype=object)
            cols = to_axis_order(task.cfg, cols, task.kind)
        return task.kind, np.asarray(task.run, dtype=np.int64), cols
    spec = CRITICAL_OUTCOMES if (task.mode != "grid" and task.kind == "main") else OUTCOMES
    out: dict[str, np.ndarray] = {}
    for k, dt in spec.items():
        out[k] = np.full(1, np.nan) if np.dtype(dt).kind == "f" else np.zeros(1, dt)
    out["status"][:] = 3
    out["error"] = np.array([f"internal error: {msg}"], dtype=object)
    if task.mode != "grid" and task.kind == "check":  # the check columns of a critical study
        out = {
            k: np.full((1, len(task.inclines) if width == "grid" else 2), fill, dtype) for k, (dtype, width, fill) in CHECK_COLUMNS.items()
        }
    return task.kind, np.asarray(task.run, dtype=np.int64), out


def _execute_task(task: Task) -> tuple[str, np.ndarray, dict[str, np.ndarray]]:
    run = np.asarray(task.run, dtype=np.int64)
    if task.mode == "grid":
        return task.kind, run, simulate_rows(task.shape, task.rows, task.grid, task.full or None)
    if task.mode == "threshold":
        assert task.cfg is not None and task.fine is not None
        if task.kind == "main":
            cols = search_rows(task.shape, task.axis_rows, task.grid, task.prior or None)
        else:
            cols = sweep_rows(task.shape, task.axis_rows, task.grid, task.fine)
        return task.kind, run, to_axis_order(task.cfg, cols, task.kind)
    if task.kind == "main":
        return task.kind, run, bisect_rows(task.shape, task.rows, task.grid, task.lo, task.hi, task.tol)
    return task.kind, run, _critical_check(task)


def _critical_check(task: Task) -> dict[str, np.ndarray]:
    """Check runs of a critical-incline study.

    Verdicts at every grid incline (the monotonicity check) and, at the two grid inclines
    around the first failure, the verdicts at the finer dt (the numerical check).
    """
    th = np.asarray(task.inclines, dtype=float)
    mono = monotonicity_rows(task.shape, task.rows, task.grid, th)
    n = len(task.rows)
    # th is sorted (plan): the pair is the last climbing and the first failing grid incline
    ij = np.zeros((n, 2), np.int64)
    for i in range(n):
        fails = np.flatnonzero(mono["climbed"][i] == 0)
        k = int(fails[0]) if len(fails) else len(th) - 1
        ij[i] = (max(k - 1, 0), k)
    pair = th[ij]
    assert task.fine is not None
    fine = simulate_rows(
        task.shape, [cast(RunRow, dict(r, incline_deg=float(t))) for r, p in zip(task.rows, pair, strict=True) for t in p], task.fine
    )
    rows_i = np.arange(n)[:, None]
    return {
        "grid_climbed": mono["climbed"],
        "grid_status": mono["status"],
        "pair_incline": pair,
        "pair_climbed": mono["climbed"][rows_i, ij].astype(np.int8),
        "pair_status": mono["status"][rows_i, ij].astype(np.int8),
        "pair_climbed_fine": fine["climbed"].reshape(n, 2),
        "pair_status_fine": fine["status"].reshape(n, 2),
    }


def design_rows(cfg: StudyConfig, des: xr.Dataset, idx: Sequence[int] | np.ndarray) -> list[RunRow]:
    """:func:`tumblemc.study.design.batch_row` of runs ``idx`` (columns read once, not per run)."""
    return [batch_row(cfg, row) for row in design_values(cfg, des, idx)]
