"""Critical incline per parameter sample: bracketing and bisection on the incline.

In a ``mode = "critical_incline"`` study one run is one parameter sample. Instead of
simulating every incline of a grid, the engine finds the steepest incline the sample
climbs to ``incline_tol``: it simulates both ends of ``incline_range``, then bisects the
bracket (climbs at ``a``, fails at ``b``) until ``b - a <= incline_tol``. The runs of a
batch bisect in lockstep, so every round is one call of the batch kernel.

This rests on an assumption: climbing is monotone in the incline (a sample that climbs
``theta`` climbs every gentler incline). It is checked, not assumed: for the runs of the
check subset the engine also simulates every incline of the study's ``incline_deg`` grid
and records where the verdict disagrees with ``theta <= critical_incline_deg``.

Then ``P(climb theta)`` is the fraction of valid samples whose critical incline is at
least ``theta``: a whole curve, with a binomial CI band, from one set of samples.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import numpy as np

from tumblemc.model.outcome import is_valid
from tumblemc.model.rows import RunRow, TimeGrid, simulate_rows
from tumblemc.schema import CRITICAL_OUTCOMES


def bisect_rows(shape: str, rows: Sequence[RunRow], grid: TimeGrid, lo: float, hi: float, tol: float) -> dict[str, np.ndarray]:
    """Critical incline of every row (``simulate`` keywords without ``incline_deg``).

    Returns the :data:`CRITICAL_OUTCOMES` columns plus ``error`` (messages of rows that
    could not run). A row whose simulation fails (status != 0) at any incline stops
    bisecting and keeps that status: its critical incline is unknown (NaN).
    """
    n = len(rows)
    out: dict[str, np.ndarray] = {k: np.zeros(n, dt) for k, dt in CRITICAL_OUTCOMES.items()}
    nit_sum = np.zeros(n)
    err = np.full(n, "", dtype=object)

    def sim(idx: np.ndarray, inc: np.ndarray) -> np.ndarray:
        res = simulate_rows(shape, [cast(RunRow, dict(rows[i], incline_deg=float(t))) for i, t in zip(idx, inc, strict=True)], grid)
        out["n_simulations"][idx] += 1
        out["status"][idx] = np.maximum(out["status"][idx], res["status"])
        nit_sum[idx] += np.nan_to_num(res["newton_iterations"])
        out["substeps"][idx] += res["substeps"]
        out["failed_steps"][idx] += res["failed_steps"]
        out["loose_steps"][idx] += res["loose_steps"]
        out["impulse_steps"][idx] += res["impulse_steps"]
        for j, i in enumerate(idx):
            if res["error"][j] and not err[i]:
                err[i] = res["error"][j]
        return res["climbed"].astype(bool)

    allr = np.arange(n)
    c_lo = sim(allr, np.full(n, lo))
    c_hi = np.zeros(n, dtype=bool)
    up = np.flatnonzero(c_lo & is_valid(out["status"]))  # only samples that climb the minimum
    if len(up):
        c_hi[up] = sim(up, np.full(len(up), hi))
    a = np.full(n, lo)
    b = np.full(n, hi)
    out["censored"][:] = np.where(~c_lo, -1, np.where(c_hi, 1, 0))
    active = is_valid(out["status"]) & c_lo & ~c_hi
    while True:
        idx = np.flatnonzero(active & (b - a > tol))
        if len(idx) == 0:
            break
        mid = 0.5 * (a[idx] + b[idx])
        climbed = sim(idx, mid)
        ok = is_valid(out["status"][idx])
        a[idx] = np.where(climbed & ok, mid, a[idx])
        b[idx] = np.where(~climbed & ok, mid, b[idx])
        active[idx[~ok]] = False
    valid = is_valid(out["status"])
    out["critical_incline_deg"] = np.where(valid & (out["censored"] >= 0), a, np.nan)
    out["critical_incline_deg"] = np.where(valid & (out["censored"] == 1), hi, out["critical_incline_deg"])
    out["fails_at_deg"] = np.where(valid & (out["censored"] <= 0), np.where(out["censored"] == -1, lo, b), np.nan)
    out["newton_iterations"] = nit_sum / np.maximum(out["n_simulations"], 1)
    out["error"] = err
    return out


def monotonicity_rows(shape: str, rows: Sequence[RunRow], grid: TimeGrid, inclines: Sequence[float] | np.ndarray) -> dict[str, np.ndarray]:
    """Verdicts of every row at every incline of ``inclines`` (the check of the monotonicity assumption).

    Returns ``climbed`` and ``status``, each of shape (rows, inclines).
    """
    n, m = len(rows), len(inclines)
    flat = [cast(RunRow, dict(r, incline_deg=float(t))) for r in rows for t in inclines]
    res = simulate_rows(shape, flat, grid)
    return {
        "climbed": res["climbed"].reshape(n, m),
        "status": res["status"].reshape(n, m),
    }
