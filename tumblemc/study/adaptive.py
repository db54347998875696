"""Adaptive sampling per cell: sample each cell until its success probability is known to ``precision``.

With ``precision`` set, a grid study runs in rounds. Round ``r`` brings every open cell up
to ``t_r`` runs (its samples ``0 .. t_r - 1``, the same runs a fixed-n study would draw);
then each open cell is closed at the least ``j <= t_r`` at which the half-width of the
anytime-valid interval (:func:`tumblemc.analysis.confseq.cs_interval`) over its valid runs
among samples ``0 .. j - 1`` is at most ``precision`` (:func:`~tumblemc.analysis.confseq.stop_count`),
or at ``samples`` (the cap). A cell keeps exactly its first ``j`` runs; runs simulated
beyond ``j`` in the round that closed it are dropped. So the result depends only on the
config and the runs' outcomes in sample order, never on round sizes, batch sizes, workers
or an interruption: ``j`` is the first prefix that qualifies, whichever round found it.

The schedule starts at the fewest runs after which any cell can stop
(:func:`~tumblemc.analysis.confseq.first_possible_stop`: 21 at precision 0.1, 45 at 0.05
with the default prior; 29 and 69 with the uniform one)
and grows by half each round. Because the interval is a confidence sequence, it covers
``p`` at the stopping time with probability at least ``ci_level`` (``docs/adaptive.md``
checks it by simulation); a Wilson interval at a data-dependent stop would not, so a
study with ``precision`` reports the confidence sequence.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from tumblemc.analysis.confseq import CS_METHODS, first_possible_stop, stop_count
from tumblemc.io import StudyStateError
from tumblemc.model.outcome import is_valid

if TYPE_CHECKING:
    from tumblemc.study.config import StudyConfig

GROWTH = 1.5  # each round brings open cells to 1.5x the runs of the last one


def rounds(first: int, cap: int) -> list[int]:
    """Run counts per cell at the end of each round: ``first`` (at most ``cap``), then x1.5, up to ``cap``."""
    t = min(cap, first)
    out = [t]
    while t < cap:
        t = min(cap, max(t + 1, math.ceil(GROWTH * t)))
        out.append(t)
    return out


def schedule(cfg: StudyConfig) -> list[int]:
    """The rounds of a study: from ``first_possible_stop`` of its precision and interval, up to ``samples``."""
    assert cfg.precision is not None
    cap = cfg.samples
    return rounds(first_possible_stop(cfg.precision, cfg.ci_level, cap, CS_METHODS[cfg.ci]), cap)


@dataclass(frozen=True)
class AdaptiveResult:
    """What adaptive sampling kept.

    ``used``: run indices of the design kept (sorted); ``kept``: runs kept per cell (design
    cell order); ``simulated``: main runs simulated in all (kept ones and those dropped
    beyond a cell's stop); ``capped``: cells that reached ``samples`` without the precision.
    """

    used: np.ndarray
    kept: np.ndarray
    simulated: int
    capped: int


def run_adaptive(
    cfg: StudyConfig,
    n_runs: int,
    read_main: Callable[[], dict[str, np.ndarray]],
    simulate: Callable[[np.ndarray], None],
    expect: Callable[[int], None] | None = None,
    redo: Callable[[int], None] | None = None,
    verdicts: Callable[[dict[str, np.ndarray]], tuple[np.ndarray, np.ndarray]] | None = None,
) -> AdaptiveResult:
    """Run the main runs of an adaptive study, round by round.

    Parameters
    ----------
    cfg : StudyConfig
        With ``precision`` set.
    n_runs : int
        Runs in the design (cells x ``samples``, cell by cell, sample fastest).
    read_main : callable
        Every finished main run: ``{"run", "status", "climbed", ...}`` sorted by run.
    simulate : callable
        Simulates (and stores) the given design runs.
    expect : callable, optional
        Told after each round how many main runs the study now expects to simulate in all.
    redo : callable, optional
        Told, before runs are simulated, how many of them were simulated before (found done
        at the start, or simulated in an earlier call) and are missing again because their
        shards were set aside: a progress bar takes them off its count.
    verdicts : callable, optional
        ``(valid, success)``, each (runs, values), of the finished runs (rows in the order
        of ``read_main()["run"]``): a cell closes once *every* value's interval meets the
        precision (a threshold study: one value per grid value, :func:`threshold_verdicts`).
        Default: one value per run, its ``status`` and ``climbed``.
    """
    assert cfg.precision is not None
    cap = cfg.samples
    ncell = n_runs // cap
    kept = np.full(ncell, -1, dtype=np.int64)  # -1: still open
    reached = np.zeros(ncell, dtype=np.int64)  # runs simulated per cell
    seen = np.zeros(n_runs, dtype=bool)  # found done or simulated so far
    seen[read_main().get("run", np.zeros(0, np.int64))] = True
    for target in schedule(cfg):
        open_cells = np.flatnonzero(kept < 0)
        if open_cells.size == 0:
            break
        want = (open_cells[:, None] * cap + np.arange(target)[None, :]).ravel()
        main = read_main()
        for _ in range(3):  # the round's runs not yet done; again for shards set aside while it ran
            missing = np.setdiff1d(want, main.get("run", np.zeros(0, np.int64)))
            if missing.size == 0:
                break
            again = int(np.count_nonzero(seen[missing]))
            if again and redo is not None:
                redo(again)
            seen[missing] = True
            simulate(missing)
            main = read_main()
        if np.setdiff1d(want, main.get("run", np.zeros(0, np.int64))).size:
            raise StudyStateError(
                f"adaptive round to {target} runs per cell: runs still missing after simulating them again "
                "(their shards keep being set aside); run the same command again"
            )
        v_rows, s_rows = verdicts(main) if verdicts is not None else _run_verdicts(main)
        valid = np.zeros((n_runs, v_rows.shape[1]), dtype=bool)
        success = np.zeros_like(valid)
        valid[main["run"]], success[main["run"]] = v_rows, s_rows & v_rows
        for c in open_cells:
            idx = c * cap + np.arange(target)
            stops = [
                stop_count(valid[idx, k], success[idx, k], cfg.precision, cfg.ci_level, CS_METHODS[cfg.ci]) for k in range(valid.shape[1])
            ]
            j = None if any(s is None for s in stops) else max(int(s) for s in stops if s is not None)
            reached[c] = target
            if j is not None:
                kept[c] = j
            elif target == cap:
                kept[c] = cap
        if expect is not None:
            expect(int(np.sum(np.where(kept < 0, cap, reached))))
    used = np.concatenate([c * cap + np.arange(k) for c, k in enumerate(kept)]) if ncell else np.zeros(0, np.int64)
    return AdaptiveResult(used.astype(np.int64), kept, int(reached.sum()), int(np.count_nonzero(kept == cap)))


def _run_verdicts(main: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """A grid study's runs: one verdict each (valid, and climbed)."""
    v = is_valid(main["status"])
    return v[:, None], (v & (main["climbed"] == 1))[:, None]


def threshold_verdicts(order: np.ndarray) -> Callable[[dict[str, np.ndarray]], tuple[np.ndarray, np.ndarray]]:
    """A threshold study's samples: the verdict at every grid value their bracket implies (``order``: difficulty order)."""
    from tumblemc.study.threshold import implied_verdicts

    def verdicts(main: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        v = implied_verdicts(main["pass_rank"], main["fail_rank"], order)
        return v >= 0, v == 1

    return verdicts


def adaptive_attrs(cfg: StudyConfig, res: AdaptiveResult) -> dict[str, float | int | str]:
    """Attributes of the ``runs`` group of an adaptive study: the rule and what it saved."""
    return {
        "precision": float(cfg.precision or 0.0),
        "precision_rule": f"each cell stops at the first run count at which the half-width of its {cfg.ci_level:.0%} "
        f"confidence sequence over its valid runs is at most {cfg.precision:g}, or at {cfg.samples} runs",
        "runs_simulated": int(res.simulated),
        "runs_kept": int(res.used.size),
        "cells_at_cap": int(res.capped),
    }


def restrict(
    des: xr.Dataset, main: dict[str, np.ndarray], check: dict[str, np.ndarray], used: np.ndarray, check_idx: np.ndarray
) -> tuple[xr.Dataset, dict[str, np.ndarray], dict[str, np.ndarray], np.ndarray]:
    """The design and shards cut to the runs kept, renumbered ``0 .. len(used) - 1``.

    ``check_idx`` (design indices, a subset of ``used``) becomes the kept runs' indices;
    the design's ``check_flag`` marks them. Identity stays in ``run_key`` and ``sample``.
    """
    keep = des.isel(run=used).assign_coords(run=np.arange(used.size))
    keep["check_flag"] = ("run", np.isin(used, check_idx), des["check_flag"].attrs)

    def cut(cols: dict[str, np.ndarray], want: np.ndarray) -> dict[str, np.ndarray]:
        pos = np.searchsorted(cols["run"], want) if want.size else np.zeros(0, np.int64)
        if want.size and not np.array_equal(cols["run"][np.minimum(pos, cols["run"].size - 1)], want):
            raise RuntimeError("internal error: the shards do not hold every run kept")
        return {k: v[pos] for k, v in cols.items()}

    main_u = cut(main, used)
    main_u["run"] = np.arange(used.size, dtype=np.int64)
    local = np.searchsorted(used, check_idx).astype(np.int64)
    check_u = cut(check, check_idx) if check_idx.size else check
    if check_idx.size:
        check_u["run"] = local
    return keep, main_u, check_u, local


__all__ = ["GROWTH", "AdaptiveResult", "adaptive_attrs", "restrict", "run_adaptive", "schedule", "threshold_verdicts"]
