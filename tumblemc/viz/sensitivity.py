"""Figures of sensitivity analysis and scenario discovery (viz layer).

:func:`plot_sobol` draws Sobol indices (:func:`tumblemc.analysis.sobol.sobol_indices`);
:func:`plot_success_vs_parameter` draws a study cell's outcome and success fraction
against each uncertain parameter; :func:`plot_prim` draws a PRIM peeling trajectory
(:mod:`tumblemc.analysis.prim`). Every function returns its
:class:`~matplotlib.figure.Figure` and saves it when given ``path``; nothing touches
pyplot.
"""

from __future__ import annotations

import os

import numpy as np
import xarray as xr
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from tumblemc.analysis.maps import ci_label, decided_early_mask, proportion_ci
from tumblemc.analysis.prim import PrimResult
from tumblemc.analysis.screening import cell_mask, uncertain_parameters, valid_mask
from tumblemc.viz.style import CMAP, panel_grid, save_figure


def plot_sobol(indices: xr.Dataset, path: str | os.PathLike[str] | None = None) -> Figure:
    """Bars of first-order and total Sobol indices with their confidence intervals.

    Parameters
    ----------
    indices : Dataset
        Indices from :func:`tumblemc.analysis.sobol.sobol_indices`.
    path : path-like, optional
        File to save the figure to (PNG, PDF, ... by its suffix); None saves nothing.

    Returns
    -------
    Figure
        Per parameter, ``S1`` and ``ST`` side by side; error bars span the bootstrap
        interval (``*_lower`` to ``*_upper``); the gap ``ST - S1`` is the share of
        variance from interactions.
    """
    names = [str(p) for p in indices["parameter"].values]
    x = np.arange(len(names), dtype=np.float64)
    fig = Figure(figsize=(max(3.5, 0.9 * len(names) + 1.5), 3.2), layout="constrained")
    ax = fig.add_subplot()
    width = 0.38
    for k, (key, label) in enumerate((("S1", "first order $S_1$"), ("ST", "total $S_T$"))):
        v = indices[key].values.astype(np.float64)
        lo = indices[f"{key}_lower"].values.astype(np.float64)
        hi = indices[f"{key}_upper"].values.astype(np.float64)
        err = np.vstack([np.clip(v - lo, 0.0, None), np.clip(hi - v, 0.0, None)])
        err = np.where(np.isfinite(err), err, 0.0)
        xs = x + (k - 0.5) * width
        ax.bar(xs, v, width, color=f"C{k}", alpha=0.8, label=label)
        ax.errorbar(xs, v, yerr=err, fmt="none", ecolor="k", elinewidth=1.0, capsize=3)
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_xticks(x, names)
    ax.set_ylabel("Sobol index")
    ax.grid(True, axis="y", alpha=0.3)
    ax.legend(fontsize=8, frameon=False)
    level = float(indices.attrs.get("confidence_level", float("nan")))
    n = indices.attrs.get("n_used", "?")
    dropped = int(indices.attrs.get("n_dropped", 0))
    note = f"N = {n} base rows" + (f" ({dropped} dropped: non-finite output)" if dropped else "")
    ax.set_title(f"Sobol indices; bars: {level:.0%} bootstrap interval; {note}", fontsize=8)
    save_figure(fig, path)
    return fig


def plot_success_vs_parameter(
    runs: xr.Dataset,
    shape: str,
    substrate: str,
    incline_deg: float | None = None,
    path: str | os.PathLike[str] | None = None,
    *,
    outcome: str = "progress_ratio",
    bins: int = 8,
    level: float = 0.95,
    method: str = "wilson",
    field_mT: float | None = None,
    freq_hz: float | None = None,
) -> Figure:
    """Outcome and success fraction against each uncertain parameter of a cell.

    Parameters
    ----------
    runs : Dataset
        Study runs.
    shape, substrate : str
        The cell.
    incline_deg : float, optional
        One incline (degree), or None for every incline of the shape and substrate (a
        colour per incline).
    path : path-like, optional
        File to save the figure to (PNG, PDF, ... by its suffix); None saves nothing.
    outcome : str
        Per-run variable scattered on the left axis.
    bins : int
        Equal-count bins of the parameter for the success curve, >= 1.
    level : float
        Confidence level of the interval of the success fraction per bin.
    method : {"wilson", "clopper-pearson"}
        Its method (:func:`tumblemc.analysis.maps.proportion_ci`).
    field_mT, freq_hz : float, optional
        The field setting (mT, Hz), needed when the study sweeps it.

    Returns
    -------
    Figure
        A panel per uncertain parameter. Dots: ``outcome`` of each valid run (left axis;
        dashed: the success threshold when the outcome is the progress ratio). Line and
        band (right axis): fraction of valid runs that climbed per bin, at the bin's
        median parameter, with its confidence interval. Red crosses on the bottom edge:
        runs that are not valid. Open triangles: runs stopped by an early decision (their
        outcome up to the decision; they failed).
    """
    if bins < 1:
        raise ValueError(f"bins must be >= 1, got {bins!r}")
    params = uncertain_parameters(runs, None)
    names = [p for p, _ in params]
    mask = cell_mask(runs, shape, substrate, incline_deg, field_mT=field_mT, freq_hz=freq_hz)
    inclines = np.unique(np.asarray(runs["incline_deg"].values, dtype=np.float64)[mask])
    valid = valid_mask(runs)
    y_all = np.asarray(runs[outcome].values, dtype=np.float64)
    climbed = np.asarray(runs["climbed"].values) == 1
    inc_all = np.asarray(runs["incline_deg"].values, dtype=np.float64)
    # runs stopped by an early decision: their outcome up to the decision (censored)
    early = decided_early_mask(runs)
    thr = float(runs.attrs.get("success_ratio", 0.5))
    ncols = min(len(names), 3)
    nrows = -(-len(names) // ncols)
    fig, axes = panel_grid(nrows, ncols, 3.6, 2.8)
    for ax in axes.ravel()[len(names) :]:
        ax.set_visible(False)
    for p, (name, var) in enumerate(params):
        ax = axes.ravel()[p]
        x_all = np.asarray(runs[var].values, dtype=np.float64)
        right = ax.twinx()
        for k, inc in enumerate(inclines):
            colour = f"C{k % 10}"
            sel = mask & (inc_all == inc)
            good = sel & valid & np.isfinite(x_all)
            ok = good & np.isfinite(y_all)
            ax.plot(x_all[ok & ~early], y_all[ok & ~early], ".", color=colour, ms=3, alpha=0.45)
            if np.any(ok & early):
                ax.plot(x_all[ok & early], y_all[ok & early], "v", mfc="none", mec=colour, ms=3, mew=0.6, alpha=0.6)
            bad = sel & ~valid & np.isfinite(x_all)
            if np.any(bad):
                ax.plot(x_all[bad], np.full(int(np.count_nonzero(bad)), 0.03), "x", color="red", ms=4, transform=ax.get_xaxis_transform())
            xs = x_all[good]
            if xs.size == 0:
                continue
            edges = np.unique(np.quantile(xs, np.linspace(0.0, 1.0, bins + 1)))
            which = np.clip(np.searchsorted(edges, xs, side="right") - 1, 0, max(edges.size - 2, 0))
            nb = max(edges.size - 1, 1)
            n = np.bincount(which, minlength=nb)
            s = np.bincount(which, weights=climbed[good].astype(np.float64), minlength=nb).astype(np.int64)
            keep = n > 0
            centre = np.array([np.median(xs[which == b]) for b in np.flatnonzero(keep)])
            lo, hi = proportion_ci(s[keep], n[keep], level, method)
            right.fill_between(centre, lo, hi, color=colour, alpha=0.18, lw=0)
            right.plot(centre, s[keep] / n[keep], "o-", color=colour, ms=3.5, lw=1.3, label=f"{inc:g} deg")
        if outcome == "progress_ratio":
            ax.axhline(thr, color="k", ls="--", lw=0.8)
        right.set_ylim(-0.03, 1.03)
        units = str(runs[var].attrs.get("units", ""))
        ax.set_xlabel(f"{name} ({units})" if units else name)
        if p % ncols == 0:
            ax.set_ylabel(outcome.replace("_", " "))
        if p % ncols == ncols - 1 or p == len(names) - 1:
            right.set_ylabel("fraction climbed")
        ax.grid(True, alpha=0.3)
        if p == 0 and inclines.size > 1:
            right.legend(fontsize=7, frameon=False, title="incline", title_fontsize=7)
    where = f"{shape} on {substrate}" + (f", incline {float(incline_deg):g} deg" if incline_deg is not None else "")
    early_note = "; open triangles: decided early (censored)" if np.any(mask & early & valid) else ""
    band = f"{level:.0%} {ci_label(method)} band"
    fig.suptitle(f"{where}: dots {outcome} of valid runs{early_note}; lines fraction climbed per bin ({band})", fontsize=9)
    save_figure(fig, path)
    return fig


def plot_prim(trajectory: xr.Dataset | PrimResult, path: str | os.PathLike[str] | None = None) -> Figure:
    """PRIM peeling trade-off: density against coverage, the chosen box marked.

    Parameters
    ----------
    trajectory : Dataset or PrimResult
        The ``trajectory`` Dataset of a :class:`~tumblemc.analysis.prim.PrimResult`, or
        the result itself.
    path : path-like, optional
        File to save the figure to (PNG, PDF, ... by its suffix); None saves nothing.

    Returns
    -------
    Figure
        One point per peeling step coloured by support (fraction of all points in the
        box); the star is the chosen box (``attrs["chosen_step"]``), annotated with its
        bounds; the dotted line is the density of the whole sample.
    """
    traj = trajectory.trajectory if isinstance(trajectory, PrimResult) else trajectory
    cov = traj["coverage"].values.astype(np.float64)
    den = traj["density"].values.astype(np.float64)
    sup = traj["support"].values.astype(np.float64)
    k = int(traj.attrs.get("chosen_step", int(np.argmax(den))))
    fig = Figure(figsize=(5.2, 3.8), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(cov, den, "-", color="0.6", lw=0.8)
    sc = ax.scatter(cov, den, c=sup, cmap=CMAP, norm=Normalize(0.0, 1.0), s=18, zorder=3)
    ax.plot(cov[k], den[k], "*", color="red", ms=14, mec="k", zorder=4, label=f"chosen box (step {k})")
    ax.axhline(den[0], color="k", ls=":", lw=0.8, label=f"base density {den[0]:.3f}")
    lines = []
    names = [str(p) for p in traj["parameter"].values]
    for j, name in enumerate(names):
        lo, hi = float(traj["lower"].values[k, j]), float(traj["upper"].values[k, j])
        if np.isfinite(lo) or np.isfinite(hi):
            lines.append(
                f"{lo:.4g} < {name} < {hi:.4g}"
                if np.isfinite(lo) and np.isfinite(hi)
                else (f"{name} > {lo:.4g}" if np.isfinite(lo) else f"{name} < {hi:.4g}")
            )
    lines.append(f"coverage {cov[k]:.3f}, density {den[k]:.3f}, support {sup[k]:.3f}")
    ax.annotate(
        "\n".join(lines),
        (cov[k], den[k]),
        xytext=(0.03, 0.04),
        textcoords="axes fraction",
        fontsize=7,
        va="bottom",
        ha="left",
        bbox={"boxstyle": "round", "fc": "w", "ec": "0.7", "alpha": 0.9},
        arrowprops={"arrowstyle": "->", "color": "0.4", "lw": 0.8},
    )
    ax.set_xlim(-0.02, 1.02)
    ax.set_ylim(min(0.0, float(np.min(den))) - 0.02, 1.02)
    ax.set_xlabel("coverage (fraction of targets inside the box)")
    ax.set_ylabel("density (fraction of the box that are targets)")
    ax.grid(True, alpha=0.3)
    # below the panel: the peeling path may pass anywhere inside it
    fig.legend(fontsize=7, frameon=False, loc="outside lower center", ncol=2)
    fig.colorbar(sc, ax=ax, label="support")
    target = traj.attrs.get("target", "target")
    ax.set_title(f"PRIM peeling; targets: {target}", fontsize=9)
    save_figure(fig, path)
    return fig
