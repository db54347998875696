"""Runs of a study result over a ladder of step sizes, with perturbed twins (docs/guide/study_results.md, "Sensitivity twins").

For each run: the progress ratio at ``dt / f`` for every ladder factor ``f`` (the study's
dt times ``1 / f``), and at the study's dt with one parameter changed by ``+- rel``
(relative). A run whose twins spread as wide as its ladder is sensitive; a run whose
twins agree while its ladder moves is limited by dt (and the ladder says whether it
settles). Every run is rebuilt from the result file alone (its stored config) and
simulated to the end with ``tumblemc.simulate``, which gives a study run's ratio.

::

    python tools/dt_ladder.py results/stress.nc                  # the check runs outside the ratio tolerance
    python tools/dt_ladder.py results/stress.nc --runs 127 257 --factors 1 2 4 8 16
    python tools/dt_ladder.py results/stress.nc --param mu --rel 1e-9

Prints a markdown table; ``--workers`` processes (default 2).
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any, cast

import numpy as np

import tumblemc
from tumblemc.io import open_result, result_attrs
from tumblemc.model.rows import RunRow
from tumblemc.study.config import StudyConfig, load_config
from tumblemc.study.design import design, run_kwargs
from tumblemc.study.twins import twin_row


def study_of(path: str | Path) -> StudyConfig:
    """The config a result file was made with (its ``config_json``)."""
    return load_config(json.loads(result_attrs(path)["config_json"]))


def outside_runs(path: str | Path) -> list[int]:
    """Run indices of the check runs outside the ratio tolerance (``check_ratio_within_tol == 0``)."""
    runs, _ = open_result(path)
    if "check_ratio_within_tol" not in runs.variables:
        return []
    sel = runs["check_run"].values
    return [int(r) for r in sel[runs["check_ratio_within_tol"].values == 0]]


def _one(job: tuple[dict[str, Any], float, str, float, float]) -> tuple[float, int]:
    kw, dt, param, sign, rel = job  # param "": the run itself; else a twin, changed as the study's (twin_row)
    kw = dict(twin_row(cast(RunRow, kw), sign, rel, param) if param else kw, dt=dt)
    s = tumblemc.summarize(tumblemc.simulate(**kw))
    return float(s["progress_ratio"]), int(s["status"])


def ladder(path: str | Path, runs: Sequence[int], factors: Sequence[int], param: str, rel: float, workers: int = 2) -> list[dict[str, Any]]:
    """One row per run: its cell, the ratio at ``dt / f`` per factor, and at dt with ``param`` x (1 +- rel)."""
    cfg = study_of(path)
    if cfg.mode != "grid":
        raise SystemExit(f"{path} is a {cfg.mode} study: its runs have no single incline to simulate again")
    des = design(cfg)
    jobs, rows = [], []
    for r in runs:
        kw = run_kwargs(cfg, des.isel(run=int(r)))
        dt = float(kw["dt"])  # the run's cell's step
        jobs += [(kw, dt / f, "", 0.0, 0.0) for f in factors] + [(kw, dt, param, s, rel) for s in (1.0, -1.0)]
        rows.append({"run": int(r), "cell": f"{kw['shape']}, {kw['preset']}, {kw.get('incline_deg', 0.0):g} deg, {kw['freq_hz']:g} Hz"})
    if workers <= 1:
        out = [_one(j) for j in jobs]
    else:
        with ProcessPoolExecutor(workers) as ex:
            out = list(ex.map(_one, jobs))
    per = len(factors) + 2
    names = [f"dt/{f}" for f in factors] + [f"{param} +{rel:g}", f"{param} -{rel:g}"]
    for i, row in enumerate(rows):
        res = out[i * per : (i + 1) * per]
        vals = [v for v, _ in res]
        for f, v in zip(factors, vals, strict=False):
            row[f"dt/{f}"] = v
        up, down = vals[-2], vals[-1]
        base = float(vals[list(factors).index(1)]) if 1 in factors else float("nan")
        row[f"{param} +{rel:g}"], row[f"{param} -{rel:g}"] = up, down
        row["twins' spread"] = max(abs(up - base), abs(down - base)) if 1 in factors else float("nan")
        # a run that is not valid (a failed step, the ledger): its ratio is not an answer
        row["not valid"] = ", ".join(n for n, (_, st) in zip(names, res, strict=True) if st != 0) or "-"
    return rows


def table(rows: list[dict[str, Any]]) -> str:
    """The rows as a markdown table."""
    if not rows:
        return "(no runs)\n"
    keys = list(rows[0])
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    for r in rows:
        lines.append("| " + " | ".join(f"{r[k]:.4g}" if isinstance(r[k], float) else str(r[k]) for k in keys) + " |")
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    ap.add_argument("result", help="a grid study's result file")
    ap.add_argument("--runs", type=int, nargs="+", help="run indices (default: the check runs outside the ratio tolerance)")
    ap.add_argument("--factors", type=int, nargs="+", default=[1, 2, 4, 8], help="dt divisors (default 1 2 4 8)")
    ap.add_argument("--param", default="magnetization", help="the parameter the twins change (default magnetization)")
    ap.add_argument("--rel", type=float, default=1e-6, help="its relative change (default 1e-6)")
    ap.add_argument("--workers", type=int, default=2)
    a = ap.parse_args(argv)
    runs = a.runs if a.runs else outside_runs(a.result)
    if np.any(np.asarray(a.factors) < 1):
        raise SystemExit("--factors must be integers >= 1")
    print(table(ladder(a.result, runs, a.factors, a.param, a.rel, a.workers)), end="")


if __name__ == "__main__":
    main()
