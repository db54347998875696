"""The stress campaign's figure (:mod:`tumblemc.reports.stress`)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from tumblemc.model.energy import ENERGY_GAIN_TOL


def stress_figure(runs: xr.Dataset, three_d: list[dict[str, Any]], path: Path | None = None) -> Figure:
    """Draw the stress report's figure, into ``path`` when given; returns the Figure.

    Left, the energy ledger's gains (study runs, 3-D runs); right, the dt check's progress
    ratios at dt against dt / 4.
    """
    fig = Figure(figsize=(11, 4.2), layout="constrained")
    ax1, ax2 = fig.subplots(1, 2)
    st = runs["status"].values
    gain = np.asarray(runs["energy_gain_ratio"].values, dtype=float)
    floor = 1e-9
    bins = np.logspace(-9, 3, 49)
    ax1.hist(np.clip(gain[st == 0], floor, None), bins=bins, color="tab:blue", alpha=0.8, label="status ok")
    bad = (st != 0) & (gain > 0)  # runs stopped at a failed step have no ledger total
    if bad.any():
        ax1.hist(np.clip(gain[bad], floor, None), bins=bins, color="tab:red", alpha=0.7, label="not valid")
    if three_d:
        g3 = np.array([r["energy_gain_ratio"] for r in three_d], dtype=float)
        ax1.hist(np.clip(g3[np.isfinite(g3)], floor, None), bins=bins, histtype="step", color="k", lw=1.5, label="3-D runs")
    ax1.axvline(ENERGY_GAIN_TOL, color="gray", ls="--", label=f"tolerance {ENERGY_GAIN_TOL:g}")
    ax1.set(xscale="log", xlabel="numerical energy gain / energy scale (below 1e-9 shown at 1e-9)", ylabel="runs", title="Energy ledger")
    ax1.legend(fontsize=8)
    if "check_run" in runs.variables:
        idx = runs["check_run"].values.astype(int)
        coarse = runs["progress_ratio"].values[idx]
        fine = runs["check_progress_ratio_fine"].values
        both_ok = (st[idx] == 0) & (runs["check_status_fine"].values == 0)
        lim = 10.0 ** math.ceil(math.log10(max(2.0, float(np.nanmax(np.abs(np.r_[coarse, fine]))))))
        ax2.plot([-lim, lim], [-lim, lim], color="gray", lw=0.8)
        ax2.axhline(0.5, color="gray", ls=":", lw=0.8)
        ax2.axvline(0.5, color="gray", ls=":", lw=0.8)
        ax2.scatter(coarse[both_ok], fine[both_ok], s=14, label="both ok")
        if "check_sensitive" in runs.variables:  # the runs outside the tolerance, by the twins' class
            sens = runs["check_sensitive"].values
            for code, style, label in (
                (0, dict(marker="s", edgecolor="tab:orange"), "outside tolerance: limited by dt"),
                (1, dict(marker="D", edgecolor="tab:purple"), "outside tolerance: sensitive"),
            ):
                m = sens == code
                if m.any():
                    ax2.scatter(coarse[m], fine[m], s=60, facecolor="none", lw=1.4, label=label, **style)
        if (~both_ok).any():
            ax2.scatter(coarse[~both_ok], fine[~both_ok], s=18, marker="x", color="tab:red", label="a run not valid")
        ax2.set_xscale("symlog", linthresh=1.0)
        ax2.set_yscale("symlog", linthresh=1.0)
        ticks = _symlog_ticks(lim)
        for axis in (ax2.xaxis, ax2.yaxis):
            axis.set_ticks(ticks, labels=[_decade_label(t) for t in ticks])
        ax2.set(xlim=(-lim, lim), ylim=(-lim, lim), xlabel="progress ratio at dt", ylabel="progress ratio at dt / 4")
        ax2.set_title("dt check (dotted: the climb threshold 0.5)")
        ax2.legend(fontsize=8)
    if path is not None:
        fig.savefig(path, dpi=110)
    return fig


def _symlog_ticks(lim: float) -> list[float]:
    """Ticks of a symlog axis up to ``lim``: 0, +-1 and every second decade (readable at any range)."""
    top = round(math.log10(lim))
    step = 2 if top > 4 else 1
    pos = [10.0**k for k in range(0, top + 1, step)]
    return [-v for v in reversed(pos)] + [0.0] + pos


def _decade_label(v: float) -> str:
    """``-10^4``, ``-1``, ``0``, ``1``, ``10^2`` in mathtext."""
    if v == 0:
        return "0"
    k = round(math.log10(abs(v)))
    sign = "-" if v < 0 else ""
    return f"${sign}1$" if k == 0 else f"${sign}10^{{{k}}}$"
