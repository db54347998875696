"""Threshold studies: each parameter sample's threshold on a grid, searched on the grid's indices.

In a ``mode = "threshold"`` study one run is one parameter sample. Success is taken to be
monotone along ``threshold_axis`` (a sample that climbs an incline climbs every gentler
one; one that climbs at a field climbs at every stronger one; one that climbs at a
frequency climbs at every slower one). Order the axis's grid from easiest to hardest
(the *difficulty order*: ascending inclines and frequencies, descending fields); a
sample's threshold is then the number ``J`` of grid values it passes, and its verdict at
every grid value follows from ``J``. The search never simulates between grid points:

- each probe halves the *prior* mass of ``J`` left in the bracket (:func:`next_probe`).
  With ``threshold_start = "pilot"`` the prior comes from the cell's check samples,
  which are swept over the whole grid first (:func:`pilot_prior`: kernels around their
  thresholds and a floor), so most searches take 2 or 3 runs;
- with a uniform prior (``"bisect"``, or a cell without a valid check sample) that is
  plain bisection from the middle: ``ceil(log2(m + 1))`` runs for ``m`` grid values.

Runs stop early when the energy bound shows they can no longer succeed (a failure,
:mod:`tumblemc.kernels.decide`). Both searches find the same ``J`` when the verdicts are
monotone; only the runs they spend differ.

A probe that ends invalid (a failed step, the energy ledger) stops the sample's search:
its verdicts stay known where the bracket already implies them (passes at or below the
last pass, fails at or above the first failure, in difficulty order), and unknown in
between, where the maps leave the sample out (as a grid study leaves out an invalid run).

The check subset is the audit: each checked sample is simulated at every grid value at
the study's dt, to the end (``decided_time`` says when the bound would have stopped it),
and at the two grid values around its first direct failure at ``dt / dt_factor``.
:mod:`tumblemc.study.assemble` compares the direct verdicts with those the threshold
implies (non-monotone samples, disagreements per grid value, early stops that the full
run contradicts) and writes the counts to the file; ``study status`` prints them.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import xarray as xr

from tumblemc.model.outcome import is_valid
from tumblemc.model.rows import RunRow, TimeGrid, simulate_rows
from tumblemc.study.config import StudyConfig
from tumblemc.study.design import batch_row, design_values
from tumblemc.study.modes import THRESHOLD_AXES

#: outcome columns of :func:`search_rows` (``grid``: one value per grid value, axis order)
THRESHOLD_OUTCOMES: dict[str, tuple[type, str]] = {
    "threshold": (np.float64, "run"),
    "threshold_fail": (np.float64, "run"),
    "n_pass": (np.int16, "run"),
    "pass_rank": (np.int16, "run"),
    "fail_rank": (np.int16, "run"),
    "censored": (np.int8, "run"),
    "search_start": (np.int16, "run"),
    "n_simulations": (np.int64, "run"),
    "status": (np.int8, "run"),
    "newton_iterations": (np.float64, "run"),
    "substeps": (np.int64, "run"),
    "failed_steps": (np.int64, "run"),
    "loose_steps": (np.int64, "run"),
    "impulse_steps": (np.int64, "run"),
    "probe_climbed": (np.int8, "grid"),
    "probe_decided_early": (np.int8, "grid"),
    "probe_status": (np.int8, "grid"),
}

#: columns of a threshold study's check runs (``grid``: per grid value, axis order;
#: ``pair``: the two grid values around the first direct failure)
THRESHOLD_CHECK_COLUMNS: dict[str, tuple[type, str, float]] = {
    "grid_climbed": (np.int8, "grid", 0),
    "grid_status": (np.int8, "grid", 3),
    "grid_ratio": (np.float64, "grid", np.nan),
    "grid_decided_time": (np.float64, "grid", np.nan),
    "pair_index": (np.int16, "pair", -1),
    "pair_climbed": (np.int8, "pair", 0),
    "pair_status": (np.int8, "pair", 3),
    "pair_climbed_fine": (np.int8, "pair", 0),
    "pair_status_fine": (np.int8, "pair", 3),
}


def difficulty_order(cfg: StudyConfig) -> np.ndarray:
    """Positions of the axis grid (ascending) from easiest to hardest."""
    m = len(cfg.axis_values)
    return np.arange(m) if THRESHOLD_AXES[cfg.threshold_axis] < 0 else np.arange(m)[::-1]


def sample_rows(cfg: StudyConfig, des: xr.Dataset, idx: Sequence[int] | np.ndarray) -> list[tuple[RunRow, ...]]:
    """For each run of ``idx``: its simulate rows at every grid value, in difficulty order."""
    values = np.asarray(cfg.axis_values)[difficulty_order(cfg)]
    per_value = [[batch_row(cfg, row) for row in design_values(cfg, des, idx, **{cfg.threshold_axis: float(v)})] for v in values]
    return [tuple(rows) for rows in zip(*per_value, strict=True)]


#: a pilot sample whose threshold is ``J`` gives weight ``PILOT_KERNEL ** |j - J|`` to threshold ``j``
PILOT_KERNEL = 1.0 / 3.0
#: share of the prior spread evenly over every threshold, so that no pilot can make a search
#: walk the grid value by value: at most 7 runs for 13 values (4 for plain bisection)
PILOT_FLOOR = 0.1


def pilot_prior(j: np.ndarray, m: int) -> np.ndarray:
    """The prior over a sample's threshold ``0 .. m`` (grid values passed) from pilot thresholds ``j``.

    ``(1 - PILOT_FLOOR)`` of the mass in geometric kernels of ratio :data:`PILOT_KERNEL`
    around the pilot thresholds, ``PILOT_FLOOR`` even. Measured on the main job
    (docs/notes/threshold_studies.md): 2.6 runs per sample against 3.8 for plain bisection;
    the kernel ratio and floor change only how many runs a search takes, never its result.
    """
    js = np.arange(m + 1)
    p = np.zeros(m + 1)
    for x in np.asarray(j, dtype=np.int64):
        p += PILOT_KERNEL ** np.abs(js - x)
    p = p / p.sum() if p.sum() > 0 else np.full(m + 1, 1.0 / (m + 1))
    return (1.0 - PILOT_FLOOR) * p + PILOT_FLOOR / (m + 1)


def pilot_priors(j: np.ndarray, status: np.ndarray, cell: np.ndarray, cells_of: np.ndarray, m: int) -> dict[str, tuple[float, ...]]:
    """Each cell's prior (:func:`pilot_prior`) from its valid pilot samples; a cell without one gets none (plain bisection)."""
    out = {}
    for c in np.unique(cells_of):
        v = j[(cell == c) & is_valid(status)]
        if len(v):
            out[str(c)] = tuple(float(x) for x in pilot_prior(v, m))
    return out


def next_probe(lo: int, hi: int, prior: np.ndarray | None) -> int:
    """The grid value (difficulty rank) to probe in the bracket ``(lo, hi)``: the one that halves the prior's mass there.

    The threshold ``J`` lies in ``lo + 1 .. hi``; probing ``k`` fails iff ``J <= k``. The
    probe is the least ``k`` whose ``P(J <= k | bracket)`` is nearest 1/2. A uniform prior
    (``None``) gives plain bisection, ``(lo + hi) // 2``.
    """
    if prior is None:
        return (lo + hi) // 2
    w = np.asarray(prior[lo + 1 : hi + 1], dtype=np.float64)
    c = np.cumsum(w) / w.sum()  # c[i] = P(J <= lo + 1 + i)
    score = np.abs(c[:-1] - 0.5)  # probes k = lo + 1 .. hi - 1
    return lo + 1 + int(np.flatnonzero(score <= score.min() + 1e-12)[0])  # ties (to rounding): the least


def direct_passes(climbed: np.ndarray, status: np.ndarray) -> np.ndarray:
    """Grid values passed before the first direct failure (difficulty order), per row; -1 if a value before it is invalid."""
    n, m = climbed.shape
    j = np.full(n, m, dtype=np.int64)
    for i in range(n):
        fails = np.flatnonzero((climbed[i] == 0) | (status[i] != 0))
        if len(fails):
            k = int(fails[0])
            j[i] = k if status[i, k] == 0 else -1
    return j


def search_rows(
    shape: str, rows: Sequence[Sequence[RunRow]], grid: TimeGrid, prior: Sequence[float] | np.ndarray | None = None
) -> dict[str, np.ndarray]:
    """The threshold of every sample by a search on grid indices (the module docstring).

    ``rows[i][k]``: sample ``i`` at grid value ``k`` in difficulty order. ``prior``: over
    the number of grid values passed, ``0 .. m`` (:func:`pilot_prior`; None: plain
    bisection). Returns the :data:`THRESHOLD_OUTCOMES` columns in *difficulty order*
    (``threshold`` and ``threshold_fail`` are filled by :func:`to_axis_order`, which knows
    the values) plus ``error``.
    """
    n, m = len(rows), len(rows[0])
    pr = None if prior is None or len(prior) == 0 else np.asarray(prior, dtype=np.float64)
    out = _blank(n, m)
    nit = np.zeros(n)
    err = np.full(n, "", dtype=object)
    lo, hi = np.full(n, -1), np.full(n, m)
    first = next_probe(-1, m, pr)
    out["search_start"][:] = first
    nxt = np.full(n, first)
    active = np.ones(n, dtype=bool)
    while active.any():
        idx = np.flatnonzero(active)
        ks = nxt[idx]
        res = simulate_rows(shape, [rows[int(i)][int(k)] for i, k in zip(idx, ks, strict=True)], grid)
        for j, (i, k) in enumerate(zip(idx, ks, strict=True)):
            s = int(res["status"][j])
            out["n_simulations"][i] += 1
            out["probe_status"][i, k] = s
            out["probe_decided_early"][i, k] = res["decided_early"][j]
            nit[i] += np.nan_to_num(res["newton_iterations"][j])
            for c in ("substeps", "failed_steps", "loose_steps", "impulse_steps"):
                out[c][i] += res[c][j]
            if not is_valid(s):
                out["status"][i] = s
                err[i] = err[i] or res["error"][j]
                active[i] = False
                continue
            ok = bool(res["climbed"][j])
            out["probe_climbed"][i, k] = int(ok)
            if ok:
                lo[i] = k
            else:
                hi[i] = k
            if hi[i] - lo[i] <= 1:
                active[i] = False
            else:
                nxt[i] = next_probe(int(lo[i]), int(hi[i]), pr)
    out["pass_rank"][:] = lo
    out["fail_rank"][:] = hi
    done = hi - lo == 1
    out["n_pass"][:] = np.where(done, hi, -1)
    out["censored"][:] = np.where(done & (hi == 0), -1, np.where(done & (lo == m - 1), 1, 0))
    out["newton_iterations"] = nit / np.maximum(out["n_simulations"], 1)
    out["error"] = err
    return out


def sweep_rows(shape: str, rows: Sequence[Sequence[RunRow]], grid: TimeGrid, fine: TimeGrid) -> dict[str, np.ndarray]:
    """The audit of checked samples: every grid value at ``grid`` to the end, the pair around the first failure at ``fine``.

    Columns of :data:`THRESHOLD_CHECK_COLUMNS`, in difficulty order.
    """
    n, m = len(rows), len(rows[0])
    flat = [r for rs in rows for r in rs]
    res = simulate_rows(shape, flat, grid, full=[True] * len(flat))
    climbed = res["climbed"].reshape(n, m).astype(np.int8)
    status = res["status"].reshape(n, m).astype(np.int8)
    j = direct_passes(climbed, status)
    k1 = np.clip(np.where(j < 0, 0, j), 0, m - 1)  # the first failure (or the last value)
    ij = np.stack([np.maximum(k1 - 1, 0), k1], axis=1)
    fine_res = simulate_rows(shape, [rows[i][k] for i in range(n) for k in ij[i]], fine)
    ri = np.arange(n)[:, None]
    return {
        "grid_climbed": climbed,
        "grid_status": status,
        "grid_ratio": res["progress_ratio"].reshape(n, m),
        "grid_decided_time": res["decided_time"].reshape(n, m),
        "pair_index": ij.astype(np.int16),
        "pair_climbed": climbed[ri, ij],
        "pair_status": status[ri, ij],
        "pair_climbed_fine": fine_res["climbed"].reshape(n, 2).astype(np.int8),
        "pair_status_fine": fine_res["status"].reshape(n, 2).astype(np.int8),
    }


def to_axis_order(cfg: StudyConfig, cols: dict[str, np.ndarray], kind: str) -> dict[str, np.ndarray]:
    """``cols`` (difficulty order, as :func:`search_rows` or :func:`sweep_rows` return them) in the axis's ascending order.

    For ``kind == "main"`` also the threshold values: ``threshold`` is the hardest grid
    value passed (NaN: none), ``threshold_fail`` the easiest failed (NaN: none).
    """
    order = difficulty_order(cfg)
    vals = np.asarray(cfg.axis_values)[order]
    spec: dict[str, Any] = THRESHOLD_OUTCOMES if kind == "main" else THRESHOLD_CHECK_COLUMNS
    out = dict(cols)
    inv = np.argsort(order)
    for k, v in spec.items():
        if v[1] == "grid":
            out[k] = np.asarray(cols[k])[:, inv]
    if kind == "main":
        lo, hi = cols["pass_rank"].astype(np.int64), cols["fail_rank"].astype(np.int64)
        m = len(vals)
        out["threshold"] = np.where(lo >= 0, vals[np.clip(lo, 0, m - 1)], np.nan)
        out["threshold_fail"] = np.where(hi < m, vals[np.clip(hi, 0, m - 1)], np.nan)
    return out


def implied_verdicts(pass_rank: np.ndarray, fail_rank: np.ndarray, order: np.ndarray) -> np.ndarray:
    """Verdict of each sample at each grid value (axis order) implied by its bracket: 1 pass, 0 fail, -1 unknown."""
    m = len(order)
    rank = np.empty(m, dtype=np.int64)
    rank[order] = np.arange(m)  # difficulty rank of each grid value
    lo, hi = np.asarray(pass_rank)[:, None], np.asarray(fail_rank)[:, None]
    return np.where(rank[None, :] <= lo, 1, np.where(rank[None, :] >= hi, 0, -1)).astype(np.int8)


def _blank(n: int, m: int) -> dict[str, np.ndarray]:
    """:data:`THRESHOLD_OUTCOMES` of ``n`` samples on ``m`` grid values, zero; the probes not simulated (-1)."""
    out: dict[str, np.ndarray] = {k: np.zeros((n, m) if w == "grid" else n, dt) for k, (dt, w) in THRESHOLD_OUTCOMES.items()}
    out["probe_climbed"][:] = -1
    out["probe_status"][:] = -1
    return out


def error_columns(kind: str, n: int, m: int) -> dict[str, np.ndarray]:
    """The columns of ``n`` runs that raised (status error)."""
    if kind == "check":
        return {k: np.full((n, m if w == "grid" else 2), fill, dt) for k, (dt, w, fill) in THRESHOLD_CHECK_COLUMNS.items()}
    out = _blank(n, m)
    for k in ("threshold", "threshold_fail", "newton_iterations"):
        out[k][:] = np.nan
    out["pass_rank"][:] = -1
    out["fail_rank"][:] = m
    out["n_pass"][:] = -1
    out["status"][:] = 3
    return out


__all__ = [
    "THRESHOLD_CHECK_COLUMNS",
    "THRESHOLD_OUTCOMES",
    "difficulty_order",
    "direct_passes",
    "error_columns",
    "implied_verdicts",
    "next_probe",
    "pilot_prior",
    "pilot_priors",
    "sample_rows",
    "search_rows",
    "sweep_rows",
    "to_axis_order",
]
