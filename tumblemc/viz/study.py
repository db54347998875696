"""Figures of a robustness study (viz layer; matplotlib object API, no pyplot state).

:func:`plot_success_heatmap` and :func:`plot_success_curves` draw the maps of
:func:`tumblemc.analysis.maps.maps`; :func:`plot_ratio_distribution` draws the runs
themselves; :func:`plot_critical_distribution` and :func:`plot_critical_vs_grid` draw a
critical-incline study; :func:`plot_study` writes a study's figures to a folder. Every
function returns its :class:`~matplotlib.figure.Figure` and saves it when given ``path``.
The sensitivity figures are in :mod:`tumblemc.viz.sensitivity`.

Panels: one column per substrate; when the study sweeps the field (``field_mT`` or
``freq_hz`` is a dimension of the maps), one row per field setting.
"""

from __future__ import annotations

import itertools
import os
import textwrap
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Rectangle

from tumblemc.analysis.maps import check_summary, check_words, sort_runs
from tumblemc.schema import SWEEP_DIMS
from tumblemc.viz.style import CMAP, GOLDEN, SWEEP_LABELS, panel_grid, save_figure


def _sweep_rows(ds: xr.Dataset, dims: Sequence[str]) -> list[dict[str, Any]]:
    """One ``sel`` dict per combination of the swept field settings (``[{}]`` if none)."""
    return [dict(zip(dims, combo, strict=True)) for combo in itertools.product(*(np.unique(ds[d].values).tolist() for d in dims))]


def _row_label(sel: dict[str, Any]) -> str:
    return ", ".join(f"{SWEEP_LABELS[d][0]} = {v:g} {SWEEP_LABELS[d][1]}" for d, v in sel.items())


def _substrates(available: np.ndarray, substrate: str | Sequence[str] | None) -> list[str]:
    have = [str(s) for s in available]
    if substrate is None:
        return have
    wanted = [substrate] if isinstance(substrate, str) else [str(s) for s in substrate]
    unknown = [s for s in wanted if s not in have]
    if unknown:
        raise ValueError(f"substrate {unknown} not in the study; it has {have}")
    return wanted


def _title(sub: str, row: dict[str, Any]) -> str:
    label = _row_label(row)
    return f"substrate: {sub}" + (f"\n{label}" if label else "")


def _map_dims(maps: xr.Dataset) -> list[str]:
    return [d for d in SWEEP_DIMS if d in maps.dims]


def plot_success_heatmap(
    maps: xr.Dataset,
    substrate: str | Sequence[str] | None = None,
    *,
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """Heatmap of the success probability: incline on x, shape on y, a panel per substrate.

    Parameters
    ----------
    maps : Dataset
        Maps from :func:`tumblemc.analysis.maps.maps`.
    substrate : str or sequence of str, optional
        A substrate name, a list of them, or None for every substrate.
    path : path-like, optional
        File to save the figure to (PNG, PDF, ... by its suffix); None saves nothing.

    Returns
    -------
    Figure
        Colour is ``p_success`` on [0, 1]; each cell reads ``p`` and its confidence
        interval ``[lower, upper]``; cells without valid runs are grey and hatched.
    """
    subs = _substrates(maps["substrate"].values, substrate)
    rows = _sweep_rows(maps, _map_dims(maps))
    shapes = [str(s) for s in maps["shape"].values]
    incl = maps["incline_deg"].values
    nx, ny = incl.size, len(shapes)
    fig, axes = panel_grid(len(rows), len(subs), max(3.2, 0.85 * nx + 1.0), max(2.0, 0.65 * ny + 1.0))
    norm = Normalize(0.0, 1.0)
    fontsize = 7.0 if nx <= 8 else 5.5
    mesh = None
    for r, row in enumerate(rows):
        for c, sub in enumerate(subs):
            ax = axes[r, c]
            m = maps.sel(substrate=sub, **row).transpose("shape", "incline_deg", ...)
            p = m["p_success"].values
            lo, hi = m["p_success_lower"].values, m["p_success_upper"].values
            nv = m["n_valid"].values
            nf = m["n_failed"].values
            mesh = ax.pcolormesh(
                np.arange(nx + 1) - 0.5,
                np.arange(ny + 1) - 0.5,
                np.ma.masked_invalid(p),
                cmap=CMAP,
                norm=norm,
                edgecolors="w",
                linewidth=0.5,
            )
            for j, i in itertools.product(range(ny), range(nx)):
                if nv[j, i] == 0:
                    ax.add_patch(Rectangle((i - 0.5, j - 0.5), 1.0, 1.0, facecolor="0.85", edgecolor="0.55", hatch="///", lw=0.0))
                    ax.text(i, j, "no valid\nruns", ha="center", va="center", fontsize=fontsize - 1, color="0.3")
                    continue
                colour = "w" if p[j, i] < 0.55 else "k"
                text = f"{p[j, i]:.2f}\n[{lo[j, i]:.2f}, {hi[j, i]:.2f}]"
                if nf[j, i] > 0:  # invalid runs are left out of p: say how many
                    text += f"\n{int(nf[j, i])} invalid"
                ax.text(i, j, text, ha="center", va="center", fontsize=fontsize, color=colour)
            ax.set_xticks(np.arange(nx), [f"{v:g}" for v in incl])
            ax.set_yticks(np.arange(ny), shapes)
            ax.set_xlim(-0.5, nx - 0.5)
            ax.set_ylim(ny - 0.5, -0.5)  # first shape on top
            ax.set_xlabel("incline (deg)")
            if c == 0:
                ax.set_ylabel("shape")
            ax.set_title(_title(sub, row), fontsize=9)
    if mesh is not None:
        cb = fig.colorbar(mesh, ax=list(axes.ravel()), shrink=0.9)
        method = maps["p_success_lower"].attrs.get("ci_method", "?")
        level = float(maps["p_success_lower"].attrs.get("confidence_level", float("nan")))
        cb.set_label(f"P(success)  (cells: p [{level:.0%} {method} CI])", fontsize=8)
    save_figure(fig, path)
    return fig


def plot_success_curves(maps: xr.Dataset, *, path: str | os.PathLike[str] | None = None) -> Figure:
    """Success probability against incline with confidence bands, one line per shape.

    Parameters
    ----------
    maps : Dataset
        Maps from :func:`tumblemc.analysis.maps.maps`.
    path : path-like, optional
        File to save the figure to (PNG, PDF, ... by its suffix); None saves nothing.

    Returns
    -------
    Figure
        A panel per substrate (and per swept field setting); the shaded band is the
        confidence interval of ``p_success``; cells without valid runs leave a gap.
    """
    subs = _substrates(maps["substrate"].values, None)
    rows = _sweep_rows(maps, _map_dims(maps))
    shapes = [str(s) for s in maps["shape"].values]
    x = maps["incline_deg"].values.astype(np.float64)
    fig, axes = panel_grid(len(rows), len(subs), 4.0, 2.8)
    for r, row in enumerate(rows):
        for c, sub in enumerate(subs):
            ax = axes[r, c]
            for k, shp in enumerate(shapes):
                m = maps.sel(substrate=sub, shape=shp, **row)
                colour = f"C{k % 10}"
                ax.fill_between(x, m["p_success_lower"].values, m["p_success_upper"].values, color=colour, alpha=0.2, lw=0)
                ax.plot(x, m["p_success"].values, "o-", color=colour, ms=3.5, lw=1.4, label=shp)
            ax.set_ylim(-0.03, 1.03)
            ax.set_xlabel("incline (deg)")
            if c == 0:
                ax.set_ylabel("P(success)")
            ax.grid(True, alpha=0.3)
            ax.set_title(_title(sub, row), fontsize=9)
            if r == 0 and c == 0:
                ax.legend(fontsize=7, frameon=False, title="shape", title_fontsize=7)
    level = float(maps["p_success_lower"].attrs.get("confidence_level", float("nan")))
    method = maps["p_success_lower"].attrs.get("ci_method", "?")
    fig.suptitle(f"success probability of valid runs; bands: {level:.0%} {method} confidence interval", fontsize=9)
    save_figure(fig, path)
    return fig


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
        A panel per substrate (and per swept field setting); inclines along x, a box per
        shape at each incline; the dashed line is the success threshold
        ``runs.attrs["success_ratio"]`` (default 0.5); runs that are not valid
        (status != 0, no ratio) are red crosses along the bottom edge.
    """
    runs = sort_runs(runs)
    thr = float(runs.attrs.get("success_ratio", 0.5))
    subs = [str(s) for s in np.unique(runs["substrate"].values)]
    sweep = [d for d in SWEEP_DIMS if d in runs.variables and np.unique(runs[d].values).size > 1]
    rows = _sweep_rows(runs, sweep)
    shapes = [str(s) for s in np.unique(runs["shape"].values)]
    incl = np.unique(runs["incline_deg"].values)
    ns = len(shapes)
    width = 0.8 / ns
    fig, axes = panel_grid(len(rows), len(subs), max(4.0, 0.6 * incl.size * max(ns, 2) / 2 + 1.5), 3.0)
    shape_v = runs["shape"].values.astype(str)
    sub_v = runs["substrate"].values.astype(str)
    inc_v = runs["incline_deg"].values
    ratio = runs["progress_ratio"].values.astype(np.float64)
    bad = runs["status"].values != 0
    for r, row in enumerate(rows):
        in_row = np.ones(runs.sizes["run"], dtype=bool)
        for d, v in row.items():
            in_row &= runs[d].values == v
        for c, sub in enumerate(subs):
            ax = axes[r, c]
            for (i, inc), (k, shp) in itertools.product(enumerate(incl), enumerate(shapes)):
                cell = in_row & (sub_v == sub) & (shape_v == shp) & (inc_v == inc)
                xc = i + (k - (ns - 1) / 2) * width
                colour = f"C{k % 10}"
                y = ratio[cell & ~bad]
                y = y[np.isfinite(y)]
                if y.size:
                    bp = ax.boxplot([y], positions=[xc], widths=0.75 * width, showfliers=False, patch_artist=True, manage_ticks=False)
                    for box in bp["boxes"]:
                        box.set(facecolor=colour, alpha=0.25, edgecolor=colour)
                    for part in ("whiskers", "caps", "medians"):
                        for ln in bp[part]:
                            ln.set(color=colour, lw=0.9)
                    jit = ((np.arange(y.size) * GOLDEN) % 1.0 - 0.5) * 0.6 * width
                    ax.plot(xc + jit, y, ".", color=colour, ms=2.5, alpha=0.7)
                nbad = int(np.count_nonzero(cell & bad))
                if nbad:
                    jit_bad = ((np.arange(nbad) * GOLDEN) % 1.0 - 0.5) * 0.6 * width
                    ax.plot(xc + jit_bad, np.full(nbad, 0.045), "x", color="red", ms=4, mew=1.0, transform=ax.get_xaxis_transform())
            ax.axhline(thr, color="k", ls="--", lw=1.0)
            if np.any(in_row & (sub_v == sub) & bad):
                lo, hi = ax.get_ylim()  # a strip along the bottom for the crosses, clear of the data
                ax.set_ylim(lo - 0.12 * (hi - lo), hi)
            ax.set_xticks(np.arange(incl.size), [f"{v:g}" for v in incl])
            ax.set_xlim(-0.6, incl.size - 0.4)
            ax.set_xlabel("incline (deg)")
            if c == 0:
                ax.set_ylabel("progress ratio")
            ax.grid(True, axis="y", alpha=0.3)
            ax.set_title(_title(sub, row), fontsize=9)
    handles = [Line2D([], [], color=f"C{k % 10}", marker="s", ls="", alpha=0.5, label=shp) for k, shp in enumerate(shapes)]
    handles.append(Line2D([], [], color="k", ls="--", label=f"success threshold {thr:g}"))
    handles.append(Line2D([], [], color="red", marker="x", ls="", label="not valid (status != 0)"))
    fig.legend(handles=handles, loc="outside upper center", ncol=len(handles), fontsize=7, frameon=False)
    save_figure(fig, path)
    return fig


def _check_note(runs: xr.Dataset) -> str | None:
    sm = check_summary(runs)
    if not sm["n_checked"]:
        return None
    parts = [f"numerical check: {sm['n_checked']} runs repeated"]
    if sm["dt_factor"] is not None:
        parts[0] += f" at dt / {sm['dt_factor']:g}"
    if sm["agreement_rate"] is not None:
        parts.append(f"climbed verdict agrees in {sm['agreement_rate']:.1%}")
    if sm["median_abs_delta_ratio"] is not None:
        parts.append(f"|delta progress ratio| median {sm['median_abs_delta_ratio']:.3g}, max {sm['max_abs_delta_ratio']:.3g}")
    words = check_words(runs, worst=1)
    if words:
        parts.append(words.split("; all in")[0])
    return "; ".join(parts)


def plot_study(runs: xr.Dataset, maps: xr.Dataset, out_dir: str | os.PathLike[str]) -> list[Path]:
    """Write the study figures to ``out_dir`` (created if needed).

    Parameters
    ----------
    runs : Dataset
        Study runs.
    maps : Dataset
        Its maps, from :func:`tumblemc.analysis.maps.maps`.
    out_dir : path-like
        Folder for ``success_heatmap.png``, ``success_curves.png`` and
        ``ratio_distribution.png`` (a critical-incline study: ``success_curves.png`` and
        ``critical_incline_distribution.png``).

    Returns
    -------
    list of Path
        The files written, in that order. When ``runs`` holds a numerical check subset,
        every figure carries a footnote with its verdict agreement rate.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if runs.attrs.get("mode") == "critical_incline":  # one run per sample, no incline grid
        a = runs.attrs
        note: str | None = (
            f"monotonicity check: {a.get('monotonicity_checked_samples', 0)} samples, disagreement rate "
            f"{a.get('monotonicity_disagreement_rate', float('nan')):.3f}; fine-dt verdicts agree in "
            f"{100 * a.get('check_agreement_rate', float('nan')):.1f}%"
        )
        figures = [
            ("success_curves.png", plot_success_curves(maps)),
            ("critical_incline_distribution.png", plot_critical_distribution(runs)),
        ]
    else:
        note = _check_note(runs)
        figures = [
            ("success_heatmap.png", plot_success_heatmap(maps)),
            ("success_curves.png", plot_success_curves(maps)),
            ("ratio_distribution.png", plot_ratio_distribution(runs)),
        ]
    paths = []
    for name, fig in figures:
        if note:
            # wrapped to the figure's width (about 7 pt characters per 0.055 inch)
            width = max(40, int(fig.get_figwidth() / 0.055))
            fig.text(0.01, 0.0, textwrap.fill(note, width), ha="left", va="top", fontsize=7, color="0.25")
        save_figure(fig, out / name)
        paths.append(out / name)
    return paths


def plot_critical_distribution(runs: xr.Dataset, path: str | os.PathLike[str] | None = None) -> Figure:
    """Histogram of the critical incline per shape, one panel per substrate.

    Parameters
    ----------
    runs : Dataset
        Runs of a ``mode = "critical_incline"`` study (``critical_incline_deg``,
        ``censored``, ``status`` over ``run``).
    path : path-like, optional
        File to save the figure to (PNG, PDF, ... by its suffix); None saves nothing.

    Returns
    -------
    Figure
        Samples outside the incline range are counted in the legend (fails at the
        minimum / climbs at the maximum), invalid runs too.
    """
    subs = sorted({str(v) for v in runs["substrate"].values})
    shapes = sorted({str(v) for v in runs["shape"].values})
    lo, hi = float(runs.attrs.get("incline_range_min", 0.0)), float(runs.attrs.get("incline_range_max", 60.0))
    tol = float(runs.attrs.get("incline_tol", 1.0))
    bins = np.arange(lo, hi + tol, max(tol, (hi - lo) / 40))
    fig = Figure(figsize=(6.0 * len(subs), 4.0), layout="constrained")
    axs = np.atleast_1d(fig.subplots(1, len(subs), squeeze=False)[0])
    for ax, sub in zip(axs, subs, strict=True):
        for j, shape in enumerate(shapes):
            m = (runs["substrate"].values == sub) & (runs["shape"].values == shape)
            ok = m & (runs["status"].values == 0)
            crit = runs["critical_incline_deg"].values[ok & (runs["censored"].values == 0)]
            n_lo = int(np.count_nonzero(ok & (runs["censored"].values == -1)))
            n_hi = int(np.count_nonzero(ok & (runs["censored"].values == 1)))
            n_bad = int(np.count_nonzero(m & ~ok))
            label = f"{shape} (n={int(ok.sum())}; below range {n_lo}, above {n_hi}, invalid {n_bad})"
            ax.hist(crit, bins=bins, histtype="step", lw=1.8, color=f"C{j}", label=label)
        ax.set(xlabel="critical incline (deg)", ylabel="samples", title=f"substrate: {sub}", xlim=(lo, hi))
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    if path is not None:
        save_figure(fig, Path(path))
    return fig


def plot_critical_vs_grid(crit_maps: xr.Dataset, grid_maps: xr.Dataset, path: str | os.PathLike[str] | None = None) -> Figure:
    """Compare the critical-incline curve with the direct grid map.

    Parameters
    ----------
    crit_maps : Dataset
        Maps of a critical-incline study: ``p_success`` and its interval over a fine
        ``incline_deg``.
    grid_maps : Dataset
        Maps of a grid study of the same cells.
    path : path-like, optional
        File to save the figure to (PNG, PDF, ... by its suffix); None saves nothing.

    Returns
    -------
    Figure
        One panel per substrate, a colour per shape: the critical-incline curve
        (continuous, with its CI band) and the grid's points with CI bars.
    """
    subs = [str(s) for s in grid_maps["substrate"].values]
    fig = Figure(figsize=(6.5 * len(subs), 4.2), layout="constrained")
    axs = np.atleast_1d(fig.subplots(1, len(subs), squeeze=False)[0])
    for ax, sub in zip(axs, subs, strict=True):
        for j, shape in enumerate(str(s) for s in grid_maps["shape"].values):
            col = f"C{j}"
            c = crit_maps.sel(shape=shape, substrate=sub).squeeze()
            th = c["incline_deg"].values
            ax.plot(th, c["p_success"].values, color=col, label=f"{shape}: critical incline")
            ax.fill_between(th, c["p_success_lower"].values, c["p_success_upper"].values, color=col, alpha=0.2, lw=0)
            g = grid_maps.sel(shape=shape, substrate=sub).squeeze()
            p = g["p_success"].values
            err = np.vstack([p - g["p_success_lower"].values, g["p_success_upper"].values - p])
            ax.errorbar(g["incline_deg"].values, p, yerr=err, fmt="o", color=col, mfc="white", capsize=3, label=f"{shape}: direct grid")
        ax.set(xlabel="incline (deg)", ylabel="P(climb)", ylim=(-0.03, 1.03), title=f"substrate: {sub}")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    if path is not None:
        fig.savefig(path, dpi=130)
    return fig
