"""Which prior for adaptive sampling's confidence sequence? Expected runs per cell, computed exactly.

    python experiments/cs_prior.py [--precision 0.1] [--cap 200] [--study RESULT.nc]

A beta-binomial mixture is a confidence sequence whatever its prior (Ville's inequality,
``tumblemc/analysis/confseq.py``); the prior only decides where it is narrow, so how many
runs a cell needs. This script compares candidate priors by the expected runs a cell
simulates under a stated mix of cells: a quarter at p = 0, a quarter at p = 1 (every run
one verdict: the issue counted about 60 of the default study's 104 cells so) and half
spread evenly over (0, 1) (100 values from 0.005 to 0.995). For each p the distribution
of the stopping count is propagated exactly over the counts ``(n, k)`` (no sampling), and
a cell stopping at ``j`` simulates the first round end at or above ``j`` (the engine's
schedule: the first possible stop, then x1.5).

With ``--study`` it also applies each prior's rule to the outcomes of a fixed study (its
cells' runs in sample order): the runs an adaptive study would keep and simulate.

The default prior (``"ends"``: half uniform, half Beta(0.1, 0.1)) was chosen from this
table on 2026-11-28 (docs/guide/adaptive.md, "The prior").
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from tumblemc.analysis import confseq
from tumblemc.study.adaptive import rounds

CANDIDATES: dict[str, tuple[tuple[float, float, float], ...]] = {
    "uniform": ((1.0, 1.0, 1.0),),
    "jeffreys": ((1.0, 0.5, 0.5),),
    "beta(0.2, 0.2)": ((1.0, 0.2, 0.2),),
    "1/4 uniform + 3/4 beta(0.2, 0.2)": ((0.25, 1.0, 1.0), (0.75, 0.2, 0.2)),
    "1/2 uniform + 1/2 beta(0.05, 0.05)": ((0.5, 1.0, 1.0), (0.5, 0.05, 0.05)),
    "ends: 1/2 uniform + 1/2 beta(0.1, 0.1)": confseq.MIXTURES["ends"],
    "1/2 uniform + 1/2 beta(0.2, 0.2)": ((0.5, 1.0, 1.0), (0.5, 0.2, 0.2)),
    "3/4 uniform + 1/4 beta(0.1, 0.1)": ((0.75, 1.0, 1.0), (0.25, 0.1, 0.1)),
}


def half_width_table(cap: int, mixture: str) -> np.ndarray:
    """Half-widths ``hw[n, k]`` for ``0 <= k <= n <= cap`` (0.5 above the diagonal, never used)."""
    n, k = np.meshgrid(np.arange(cap + 1), np.arange(cap + 1), indexing="ij")
    hw = np.full(n.shape, 0.5)
    ok = k <= n
    hw[ok] = confseq.half_width(k[ok], n[ok], 0.95, mixture)
    return hw


def schedule(first: int, cap: int) -> np.ndarray:
    """The engine's round ends (:func:`tumblemc.study.adaptive.rounds`) as an array."""
    return np.array(rounds(first, cap))


def stop_distribution(hw: np.ndarray, precision: float, p: float) -> np.ndarray:
    """``P(stop at j)`` for ``j = 0 .. cap`` of a Bernoulli(p) cell whose runs are all valid."""
    cap = hw.shape[0] - 1
    dist = np.zeros(cap + 1)
    mass = np.zeros(cap + 1)
    mass[0] = 1.0  # over k, at the current n
    for n in range(1, cap + 1):
        new = np.zeros(cap + 1)
        new[1 : n + 1] += mass[:n] * p
        new[:n] += mass[:n] * (1.0 - p)
        mass = new
        if n == cap:
            dist[n] = mass.sum()
        else:
            stop = hw[n, : n + 1] <= precision
            dist[n] = mass[: n + 1][stop].sum()
            mass[: n + 1][stop] = 0.0
    return dist


def expected_runs(hw: np.ndarray, precision: float) -> tuple[int, float, float]:
    """First possible stop, expected runs simulated and kept per cell under the stated mix."""
    cap = hw.shape[0] - 1
    first = int(np.argmax(hw[np.arange(cap + 1), 0] <= precision)) or cap
    sched = schedule(first, cap)
    ps = np.r_[0.0, 1.0, np.linspace(0.005, 0.995, 100)]
    weights = np.r_[0.25, 0.25, np.full(100, 0.005)]
    j = np.arange(cap + 1)
    t = sched[np.searchsorted(sched, np.maximum(j, 1))]
    sim = kept = 0.0
    for p, w in zip(ps, weights, strict=True):
        d = stop_distribution(hw, precision, float(p))
        sim += w * float(d @ t)
        kept += w * float(d @ j)
    return first, sim, kept


def on_study(path: Path, mixture: str, precision: float) -> tuple[int, int]:
    """Runs kept and simulated if the fixed study at ``path`` had been sampled adaptively with ``mixture``."""
    from tumblemc.io import open_result
    from tumblemc.model.outcome import is_valid

    runs, _ = open_result(path)
    cap = int(runs["sample"].values.max()) + 1
    order = np.lexsort((runs["sample"].values, runs["cell_key"].values))
    status, climbed = runs["status"].values[order], runs["climbed"].values[order]
    sched = schedule(confseq.first_possible_stop(precision, 0.95, cap, mixture), cap)
    kept = sim = 0
    for c in range(status.size // cap):
        sl = slice(c * cap, (c + 1) * cap)
        valid = is_valid(status[sl])
        j = confseq.stop_count(valid, valid & (climbed[sl] == 1), precision, 0.95, mixture) or cap
        kept += j
        sim += int(sched[np.searchsorted(sched, j)])
    return kept, sim


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--precision", type=float, default=0.1)
    ap.add_argument("--cap", type=int, default=200)
    ap.add_argument("--study", type=Path, default=None, help="a fixed study's result: apply each rule to its outcomes")
    args = ap.parse_args()
    header = "| prior | first stop | E[runs simulated] | E[runs kept] | half-width at k = n/2 = cap/2 |"
    if args.study:
        header += " study: kept | study: simulated |"
    print(f"precision {args.precision:g}, cap {args.cap}\n")
    print(header)
    print("|---" * (header.count("|") - 1) + "|")
    for name, comps in CANDIDATES.items():
        key = f"_candidate {name}"
        confseq.MIXTURES[key] = comps  # a temporary entry: the functions look priors up by name
        try:
            hw = half_width_table(args.cap, key)
            first, sim, kept = expected_runs(hw, args.precision)
            row = f"| {name} | {first} | {sim:.1f} | {kept:.1f} | {hw[args.cap, args.cap // 2]:.4f} |"
            if args.study:
                k_s, s_s = on_study(args.study, key, args.precision)
                row += f" {k_s:,} | {s_s:,} |"
            print(row, flush=True)
        finally:
            del confseq.MIXTURES[key]


if __name__ == "__main__":
    main()
