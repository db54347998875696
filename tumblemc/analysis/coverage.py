"""Coverage of adaptive sampling's intervals, by simulation (Bernoulli cells).

A cell of a study is a sequence of independent Bernoulli(p) runs (with the ``mc``
sampler). :func:`simulate_coverage` draws many such sequences, applies the stopping rule
of adaptive sampling (stop at the first run count at which the interval's half-width is at
most ``precision``, or at ``cap``) and counts how often the interval reported at the stop
holds ``p``. With the confidence sequence (:mod:`tumblemc.analysis.confseq`) that is at
least ``level`` for every ``p`` (Ville's inequality); the same rule with the fixed-n
Wilson interval is the control the campaign compares it with (``tools/adaptive_coverage.py``,
``docs/adaptive.md``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from tumblemc.analysis.confseq import CS_METHODS, cs_interval
from tumblemc.analysis.maps import proportion_ci


def interval_table(cap: int, level: float = 0.95, method: str = "confidence-sequence-ends") -> tuple[np.ndarray, np.ndarray]:
    """Interval ends for every ``(n, k)``, ``0 <= k <= n <= cap``: arrays ``[n, k]`` (NaN above the diagonal)."""
    n, k = np.meshgrid(np.arange(cap + 1), np.arange(cap + 1), indexing="ij")
    ok = k <= n
    lo = np.full(n.shape, np.nan)
    hi = np.full(n.shape, np.nan)
    if method in CS_METHODS:
        a, b = cs_interval(k[ok], n[ok], level, CS_METHODS[method])
    else:
        a, b = proportion_ci(k[ok], n[ok], level, method)
    lo[ok], hi[ok] = a, b
    return lo, hi


def simulate_coverage(
    p: float,
    precision: float,
    cap: int,
    *,
    level: float = 0.95,
    reps: int = 10_000,
    seed: int = 0,
    method: str = "confidence-sequence-ends",
    table: tuple[np.ndarray, np.ndarray] | None = None,
) -> dict[str, Any]:
    """Adaptive sampling of ``reps`` Bernoulli(``p``) cells: coverage and runs used.

    Returns
    -------
    dict
        ``coverage`` (share of cells whose interval at the stop holds ``p``),
        ``coverage_se`` (its binomial standard error), ``mean_runs``, ``median_runs``,
        ``share_capped`` (cells that reached ``cap``), ``max_half_width`` (largest
        half-width reported), ``reps``.
    """
    lo, hi = table if table is not None else interval_table(cap, level, method)
    rng = np.random.default_rng(seed)
    x = rng.random((reps, cap)) < p
    n = np.arange(1, cap + 1)
    k = np.cumsum(x, axis=1)
    lo_n, hi_n = lo[n, k], hi[n, k]
    narrow = 0.5 * (hi_n - lo_n) <= precision
    stop = np.where(narrow.any(axis=1), np.argmax(narrow, axis=1), cap - 1)
    rows = np.arange(reps)
    a, b = lo_n[rows, stop], hi_n[rows, stop]
    covered = (a <= p) & (p <= b)
    cov = float(covered.mean())
    return {
        "coverage": cov,
        "coverage_se": float(np.sqrt(max(cov * (1.0 - cov), 1e-12) / reps)),
        "mean_runs": float(np.mean(stop + 1)),
        "median_runs": float(np.median(stop + 1)),
        "share_capped": float(np.mean(~narrow.any(axis=1))),
        "max_half_width": float(np.max(0.5 * (b - a))),
        "reps": int(reps),
    }


__all__ = ["interval_table", "simulate_coverage"]
