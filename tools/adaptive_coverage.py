"""The coverage campaign of adaptive sampling: writes docs/notes/adaptive_coverage.md and its figure.

    python tools/adaptive_coverage.py [--reps 20000] [--out docs/notes/adaptive_coverage.md]

A study cell with the ``mc`` sampler is a sequence of independent Bernoulli(p) runs.
For each ``p`` (the issue's six values, and a fine grid for the figure), ``reps`` cells are
sampled with adaptive sampling's rule (stop at the first run count at which the interval's
half-width is at most ``precision``, or at the cap) and the interval reported at the stop
is checked against ``p`` (:func:`tumblemc.analysis.coverage.simulate_coverage`).

- the confidence sequence (what a study with ``precision`` reports, with its default
  ``"ends"`` prior and with Robbins' uniform prior, ``ci = "confidence-sequence"``):
  coverage must be at least the nominal 95% at every ``p``;
- the control: the same rule with the fixed-n Wilson interval, which has no such guarantee
  under optional stopping.

CI runs a small version (tests/study/test_adaptive.py).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from tumblemc.analysis.coverage import interval_table, simulate_coverage

P_ISSUE = (0.0, 0.02, 0.1, 0.5, 0.9, 1.0)
SETTINGS = ((0.1, 200), (0.05, 200), (0.05, 1000))  # (precision, cap)
METHODS = ("confidence-sequence-ends", "confidence-sequence", "wilson")
STYLE = {"confidence-sequence-ends": "-", "confidence-sequence": "--", "wilson": ":"}


def campaign(reps: int, p_grid: np.ndarray) -> tuple[list[dict[str, float]], dict[tuple[float, int, str], np.ndarray]]:
    """The table rows (issue's p values) and, per setting and method, coverage and mean runs on ``p_grid``."""
    rows = []
    curves: dict[tuple[float, int, str], np.ndarray] = {}
    for precision, cap in SETTINGS:
        tables = {m: interval_table(cap, 0.95, m) for m in METHODS}
        for i, p in enumerate(P_ISSUE):
            cs = simulate_coverage(p, precision, cap, reps=reps, seed=100 + i, table=tables["confidence-sequence-ends"])
            un = simulate_coverage(p, precision, cap, reps=reps, seed=100 + i, table=tables["confidence-sequence"])
            wi = simulate_coverage(p, precision, cap, reps=reps, seed=100 + i, table=tables["wilson"])
            rows.append(
                {
                    "precision": precision,
                    "cap": cap,
                    "p": p,
                    "coverage": cs["coverage"],
                    "coverage_se": cs["coverage_se"],
                    "mean_runs": cs["mean_runs"],
                    "share_capped": cs["share_capped"],
                    "uniform_coverage": un["coverage"],
                    "uniform_mean_runs": un["mean_runs"],
                    "wilson_coverage": wi["coverage"],
                    "wilson_mean_runs": wi["mean_runs"],
                }
            )
        for m, tab in tables.items():
            res = [
                simulate_coverage(float(p), precision, cap, reps=max(reps // 4, 200), seed=7 + j, table=tab) for j, p in enumerate(p_grid)
            ]
            curves[(precision, cap, m)] = np.array([[r["coverage"], r["mean_runs"]] for r in res])
    return rows, curves


def figure(curves: dict[tuple[float, int, str], np.ndarray], p_grid: np.ndarray, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    colors = {(0.1, 200): "C0", (0.05, 200): "C1", (0.05, 1000): "C2"}
    suffix = {"confidence-sequence-ends": "", "confidence-sequence": " uniform", "wilson": " Wilson"}
    for (precision, cap, m), arr in curves.items():
        label = f"{precision:g}, cap {cap}{suffix[m]}"
        ax1.plot(p_grid, arr[:, 0], STYLE[m], color=colors[(precision, cap)], label=label)
        if m != "wilson":
            ax2.plot(p_grid, arr[:, 1], STYLE[m], color=colors[(precision, cap)], label=label)
    ax1.axhline(0.95, color="k", lw=0.8, label="nominal 95%")
    ax1.set(xlabel="true p (success probability of the cell)", ylabel="coverage at the stop", ylim=(0.8, 1.005), xlim=(0, 1))
    ax1.set_title("Interval at the stop holds p", fontsize=11)
    title = "precision, cap (solid: the default CS; dashed: uniform prior; dotted: Wilson)"
    ax1.legend(fontsize=7, loc="lower center", ncol=3, title=title, title_fontsize=7)
    ax2.set(xlabel="true p (success probability of the cell)", ylabel="runs per cell (mean)", xlim=(0, 1), yscale="log")
    ax2.set_title("Runs used (solid: the default prior; dashed: uniform)", fontsize=11)
    ax2.legend(fontsize=8, loc="lower center", ncol=2)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def report(rows: list[dict[str, float]], reps: int, seconds: float, fig_name: str, grid_min: dict[str, tuple[float, float]]) -> str:
    lines = [
        "# Adaptive sampling: coverage of the interval at the stop",
        "",
        f"Regenerate with `python tools/adaptive_coverage.py` ({reps:,} simulated cells per row, {seconds:.0f} s on this machine).",
        "",
        "A study with `precision = h` samples each cell until the half-width of its 95% confidence sequence "
        "(a beta-binomial mixture, `tumblemc/analysis/confseq.py`) over its valid runs is at most `h`, "
        'or until `samples` runs (the cap). The default prior (`ci = "confidence-sequence-ends"`) is half uniform, half '
        'Beta(0.1, 0.1); `ci = "confidence-sequence"` is Robbins\' uniform prior, the rule before 2026-11-28. '
        "Each simulated cell below is a sequence of independent Bernoulli(p) runs "
        "(the `mc` sampler's runs are independent); *coverage* is the share of cells whose reported interval holds `p`. "
        "The control applies the same stopping rule with the fixed-n Wilson interval. Both sequences use the same "
        "simulated cells (same seed per row).",
        "",
        "| precision | cap | p | coverage (CS) | +- se | mean runs | share at cap | coverage (uniform prior) | mean runs (uniform) "
        "| Wilson coverage (control) | Wilson mean runs |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['precision']:g} | {r['cap']} | {r['p']:g} | {r['coverage']:.4f} | {r['coverage_se']:.4f} | "
            f"{r['mean_runs']:.1f} | {r['share_capped']:.3f} | {r['uniform_coverage']:.4f} | {r['uniform_mean_runs']:.1f} | "
            f"{r['wilson_coverage']:.4f} | {r['wilson_mean_runs']:.1f} |"
        )
    worst = min(r["coverage"] for r in rows)
    worst_u = min(r["uniform_coverage"] for r in rows)
    worst_w = min(r["wilson_coverage"] for r in rows)
    lines += [
        "",
        f"Lowest coverage of the confidence sequence: **{worst:.4f}** (target: at least 0.95 at every p); "
        f"with the uniform prior {worst_u:.4f}. "
        f"Lowest of the Wilson control: {worst_w:.4f}. On the figure's grid of 51 p values "
        f"({max(reps // 4, 200):,} cells each): confidence sequence at least {grid_min['confidence-sequence-ends'][0]:.4f} "
        f"(at p = {grid_min['confidence-sequence-ends'][1]:g}; uniform prior {grid_min['confidence-sequence'][0]:.4f} "
        f"at p = {grid_min['confidence-sequence'][1]:g}), Wilson control down to {grid_min['wilson'][0]:.4f} "
        f"(at p = {grid_min['wilson'][1]:g}).",
        "",
        f"![coverage and runs per cell]({fig_name})",
        "",
        "## Reading it",
        "",
        "- The confidence sequence covers at every p, and with room: it is valid at *every* run count at once "
        "(Ville's inequality, whatever the prior), so stopping when it is narrow cannot break it. The price is "
        "width: at n = 200 and p = 0.5 its half-width is 0.120 (0.115 with the uniform prior) where Wilson's is "
        "0.069, so a cell near p = 0.5 does not reach `precision = 0.1` within 200 runs and stops at the cap.",
        "- The savings are at the ends: a cell whose runs all climb (or all fail) stops after 21 runs at "
        "`precision = 0.1` (45 at 0.05), instead of 200; the uniform prior needs 29 (69). About half of the default "
        "study's cells are such cells. In between, the default prior needs a few runs more than the uniform one "
        "(the table's p = 0.1 and 0.9 rows).",
        "- Wilson under the same rule stops earlier but is not guaranteed: its coverage falls below 95% for "
        "cells between p of about 0.15 and 0.85 (it stops on a lucky run of one verdict, when its interval is "
        "narrow by chance). A study with "
        '`precision` therefore reports a confidence sequence (`ci = "confidence-sequence-ends"` or '
        '`"confidence-sequence"`, the only choices the config accepts with `precision`).',
        "- Invalid runs (status other than ok) are left out of the interval, as in the maps (`p_success` is "
        "conditional on a valid run); the rule counts valid runs, so a cell with invalid runs uses more runs.",
        "",
    ]
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=20_000)
    ap.add_argument("--out", default="docs/notes/adaptive_coverage.md")
    args = ap.parse_args()
    out = Path(args.out)
    t0 = time.perf_counter()
    p_grid = np.round(np.linspace(0.0, 1.0, 51), 4)
    rows, curves = campaign(args.reps, p_grid)
    fig = out.with_suffix(".png")
    figure(curves, p_grid, fig)
    grid_min = {}
    for m in METHODS:
        cov = np.array([curves[(pr, cap, m)][:, 0] for pr, cap in SETTINGS])
        i, j = np.unravel_index(np.argmin(cov), cov.shape)
        grid_min[m] = (float(cov[i, j]), float(p_grid[j]))
    out.write_text(report(rows, args.reps, time.perf_counter() - t0, fig.name, grid_min), encoding="utf-8")
    print(f"wrote {out} and {fig}")


if __name__ == "__main__":
    main()
