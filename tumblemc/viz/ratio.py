"""The progress-ratio figure of a robustness study (viz layer; matplotlib object API).

:func:`plot_ratio_distribution` draws every valid run's progress ratio, a box and a strip
per shape and incline. Ratios can span four orders of magnitude (a robot that slides
away reaches -5000 while the success threshold is 0.5); then the y axis is
symmetric-log, linear on [-:data:`RATIO_LINEAR`, :data:`RATIO_LINEAR`], where the
threshold and the climbing runs are, and logarithmic beyond (:func:`ratio_axis`).
"""

from __future__ import annotations

import itertools
import os
from typing import Any

import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import FixedLocator, FuncFormatter, NullLocator

from tumblemc.analysis.maps import decided_early_mask, sort_runs
from tumblemc.schema import SWEEP_DIMS
from tumblemc.viz.style import GOLDEN, MAX_FIG_W, panel_grid, panel_title, save_figure, sweep_rows

#: half-width of the linear part of the ratio axis: a full climb (1) and a short slide back
#: (-1) read on a linear scale, steeper slides on a log one
RATIO_LINEAR = 2.0


def _tick_label(v: float, _pos: Any = None) -> str:
    return "0" if v == 0 else f"{v:g}" if abs(v) < 1e4 else f"{v:.0e}".replace("e+0", "e")


def ratio_axis(ax: Axes, lo: float, hi: float, threshold: float) -> str:
    """Y axis for progress ratios in ``[lo, hi]`` with the success threshold drawn.

    Parameters
    ----------
    ax : Axes
        The panel.
    lo, hi : float
        Smallest and largest ratio to show (NaN: none).
    threshold : float
        Success threshold of the progress ratio, drawn as a dashed line and labelled.

    Returns
    -------
    str
        The axis label.

    Notes
    -----
    Ratios within ``[-RATIO_LINEAR, RATIO_LINEAR]`` get a linear axis. Wider ones get a
    symmetric-log axis whose linear part, that interval (shaded), takes at least half of
    the height (``linscale`` grows with the decades beyond it), so the boxes near the
    threshold stay apart however far the sliding runs go.
    """
    lin = RATIO_LINEAR
    lo, hi = (lo, hi) if np.isfinite(lo) and np.isfinite(hi) else (0.0, 1.0)
    if -lin <= lo and hi <= lin:
        lo, hi = min(lo, threshold, 0.0), max(hi, threshold, 1.0)
        ax.set_ylim(lo - 0.08 * (hi - lo), hi + 0.08 * (hi - lo))
        label = "progress ratio"
    else:
        lo, hi = min(lo * 1.5, -1.25 * lin), max(hi * 1.5, 1.25 * lin)
        decades = np.log10(max(-lo, lin) / lin) + np.log10(max(hi, lin) / lin)
        ax.set_yscale("symlog", linthresh=lin, linscale=max(0.5, decades / 2.0))
        ax.set_ylim(lo, hi)
        # beyond the linear part: 1-2-5 ticks over up to two decades, powers of ten beyond
        mantissas = (1.0, 2.0, 5.0) if decades <= 2.0 else (1.0,)
        mags = [m * 10.0**k for k in range(1, 12) for m in mantissas if lin < m * 10.0**k <= max(-lo, hi)]
        ticks = [-lin, -1.0, 0.0, 1.0, lin] + [t for v in mags for t in (-v, v) if lo <= t <= hi]
        ax.yaxis.set_major_locator(FixedLocator(sorted(ticks)))
        ax.yaxis.set_major_formatter(FuncFormatter(_tick_label))
        ax.yaxis.set_minor_locator(NullLocator())
        ax.axhspan(-lin, lin, color="0.93", zorder=0, lw=0)
        label = f"progress ratio\n(linear within \u00b1{lin:g}, log beyond)"
    ax.axhline(threshold, color="k", ls="--", lw=1.2, zorder=1)
    ax.annotate(
        f"success \u2265 {threshold:g}",
        (1.0, threshold),
        xycoords=("axes fraction", "data"),
        xytext=(3, 0),
        textcoords="offset points",
        va="center",
        ha="left",
        fontsize=8,
    )
    return label


def _legend_columns(handles: list[Line2D], width_in: float) -> int:
    """The most legend columns whose entries fit across ``width_in`` inches (8 pt text).

    A legend wider than the panels would widen the figure and leave the panels squeezed
    in its middle; entries that do not fit go to further rows instead.
    """
    widths = [0.45 + 0.065 * len(str(h.get_label())) for h in handles]  # marker, gap and about 0.065 in a character
    for ncol in range(len(widths), 1, -1):
        cols = [max(widths[i::ncol]) for i in range(ncol)]
        if sum(cols) <= width_in:
            return ncol
    return 1


def _bottom_strip(ax: Axes, frac: float = 0.1) -> None:
    """Lower the y limit by ``frac`` of the axis height (in its scale) for the invalid-run crosses."""
    tr = ax.yaxis.get_transform()
    lo, hi = ax.get_ylim()
    t_lo, t_hi = tr.transform(np.array([lo, hi]))
    ax.set_ylim(float(tr.inverted().transform(np.array([t_lo - frac * (t_hi - t_lo)]))[0]), hi)


def plot_ratio_distribution(runs: xr.Dataset, *, path: str | os.PathLike[str] | None = None) -> Figure:
    """Distribution of the progress ratio per cell: box and strip plots of the valid runs.

    Parameters
    ----------
    runs : Dataset
        Study runs (variables over ``run``).
    path : path-like, optional
        File to save the figure to (PNG, PDF, ... by its suffix); None saves nothing.

    Returns
    -------
    Figure
        A panel per substrate (and per swept field setting; stacked when side by side they
        would be too wide), inclines along x, a box per shape at each incline; a shared
        symmetric-log y axis (:func:`ratio_axis`: linear on the shaded band); the dashed
        line is the success threshold ``runs.attrs["success_ratio"]`` (default 0.5); runs
        that are not valid (status != 0, no ratio) are red crosses along the bottom edge
        (in the legend only when there are some);
        runs stopped by an early decision (``decided_early``) are open triangles at their
        ratio up to the decision, which the boxes include (their final ratio is only known
        to be below the threshold).
    """
    runs = sort_runs(runs)
    thr = float(runs.attrs.get("success_ratio", 0.5))
    subs = [str(s) for s in np.unique(runs["substrate"].values)]
    sweep = [d for d in SWEEP_DIMS if d in runs.variables and np.unique(runs[d].values).size > 1]
    rows = sweep_rows(runs, sweep)
    shapes = [str(s) for s in np.unique(runs["shape"].values)]
    incl = np.unique(runs["incline_deg"].values)
    ns = len(shapes)
    width = 0.8 / ns
    panel_w = float(np.clip(0.17 * incl.size * max(ns, 2) + 1.2, 4.0, MAX_FIG_W - 1.2))
    side = len(subs) * panel_w + 1.2 <= MAX_FIG_W
    fig, axes = panel_grid(len(rows) * (1 if side else len(subs)), len(subs) if side else 1, panel_w, 3.2)
    shape_v = runs["shape"].values.astype(str)
    sub_v = runs["substrate"].values.astype(str)
    inc_v = runs["incline_deg"].values
    ratio = runs["progress_ratio"].values.astype(np.float64)
    bad = runs["status"].values != 0
    # runs stopped by an early decision: their ratio is the one up to the decision (censored)
    early = decided_early_mask(runs)
    good = ratio[~bad & np.isfinite(ratio)]
    lo, hi = (float(good.min()), float(good.max())) if good.size else (np.nan, np.nan)
    for (r, row), (c, sub) in itertools.product(enumerate(rows), enumerate(subs)):
        in_row = np.ones(runs.sizes["run"], dtype=bool)
        for d, v in row.items():
            in_row &= runs[d].values == v
        ax = axes[r, c] if side else axes[r * len(subs) + c, 0]
        ylabel = ratio_axis(ax, lo, hi, thr)
        any_bad = bool(np.any(in_row & (sub_v == sub) & bad))
        if any_bad:
            _bottom_strip(ax)
        for (i, inc), (k, shp) in itertools.product(enumerate(incl), enumerate(shapes)):
            cell = in_row & (sub_v == sub) & (shape_v == shp) & (inc_v == inc)
            xc = i + (k - (ns - 1) / 2) * width
            colour = f"C{k % 10}"
            # the box holds every valid run, the decided-early ones at their ratio up to the decision
            y = ratio[cell & ~bad]
            y = y[np.isfinite(y)]
            yc = ratio[cell & ~bad & early]
            yc = yc[np.isfinite(yc)]
            if yc.size:
                jit_c = ((np.arange(yc.size) * GOLDEN) % 1.0 - 0.5) * 0.6 * width
                ax.plot(xc + jit_c, yc, "v", mfc="none", mec=colour, ms=3.0, mew=0.6, alpha=0.7)
            if y.size:
                bp = ax.boxplot([y], positions=[xc], widths=0.75 * width, showfliers=False, patch_artist=True, manage_ticks=False)
                for box in bp["boxes"]:
                    box.set(facecolor=colour, alpha=0.25, edgecolor=colour)
                for part in ("whiskers", "caps", "medians"):
                    for ln in bp[part]:
                        ln.set(color=colour, lw=0.9)
                yf = ratio[cell & ~bad & ~early]
                yf = yf[np.isfinite(yf)]
                jit = ((np.arange(yf.size) * GOLDEN) % 1.0 - 0.5) * 0.6 * width
                ax.plot(xc + jit, yf, ".", color=colour, ms=2.5, alpha=0.7)
            nbad = int(np.count_nonzero(cell & bad))
            if nbad:
                jit_bad = ((np.arange(nbad) * GOLDEN) % 1.0 - 0.5) * 0.6 * width
                ax.plot(xc + jit_bad, np.full(nbad, 0.045), "x", color="red", ms=4, mew=1.0, transform=ax.get_xaxis_transform())
        ax.set_xticks(np.arange(incl.size), [f"{v:g}" for v in incl])
        ax.set_xlim(-0.6, incl.size - 0.4)
        ax.set_xlabel("incline (deg)")
        if c == 0 or not side:
            ax.set_ylabel(ylabel, fontsize=9)
        ax.grid(True, axis="y", alpha=0.3)
        ax.set_title(panel_title(sub, row), fontsize=9)
    handles = [Line2D([], [], color=f"C{k % 10}", marker="s", ls="", alpha=0.5, label=shp) for k, shp in enumerate(shapes)]
    handles.append(Line2D([], [], color="k", ls="--", label=f"success threshold {thr:g}"))
    if early.any():
        lab = "decided early (ratio up to then, in the boxes; fails)"
        handles.append(Line2D([], [], color="0.3", marker="v", mfc="none", ls="", label=lab))
    if bad.any():
        handles.append(Line2D([], [], color="red", marker="x", ls="", label="not valid (status != 0)"))
    fig.legend(handles=handles, loc="outside upper center", ncol=_legend_columns(handles, fig.get_figwidth()), fontsize=8, frameon=False)
    save_figure(fig, path)
    return fig
