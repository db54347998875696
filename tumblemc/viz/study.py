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
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from tumblemc.analysis.maps import ci_label
from tumblemc.analysis.words import check_summary, check_words, early_words
from tumblemc.schema import SWEEP_DIMS
from tumblemc.viz.ratio import plot_ratio_distribution
from tumblemc.viz.style import CMAP, MAX_FIG_W, panel_grid, panel_title, save_figure, sweep_rows


def _substrates(available: np.ndarray, substrate: str | Sequence[str] | None) -> list[str]:
    have = [str(s) for s in available]
    if substrate is None:
        return have
    wanted = [substrate] if isinstance(substrate, str) else [str(s) for s in substrate]
    unknown = [s for s in wanted if s not in have]
    if unknown:
        raise ValueError(f"substrate {unknown} not in the study; it has {have}")
    return wanted


def _map_dims(maps: xr.Dataset) -> list[str]:
    return [d for d in SWEEP_DIMS if d in maps.dims]


#: font sizes of the heatmap cells, points: the probability and the interval line below it
CELL_FONT, CELL_FONT_SMALL = 10.0, 8.0


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
        Colour is ``p_success`` on [0, 1]; cells without valid runs are grey and hatched.
        Panels sit side by side, or stacked when that would make the figure wider than
        :data:`~tumblemc.viz.style.MAX_FIG_W`. Cell text is never smaller than
        :data:`CELL_FONT_SMALL`: each cell reads ``p`` (:data:`CELL_FONT`), its confidence
        interval and the number of invalid runs when the cell is big enough on the
        page; ``p`` alone (a ``*`` where runs are invalid) when only that fits; nothing
        when not even that fits (the colour bar still reads).
    """
    subs = _substrates(maps["substrate"].values, substrate)
    rows = sweep_rows(maps, _map_dims(maps))
    shapes = [str(s) for s in maps["shape"].values]
    incl = maps["incline_deg"].values
    nx, ny = incl.size, len(shapes)
    cell_w = float(np.clip(10.5 / nx, 0.15, 0.8))  # inches: 0.8 fits "0.93-1.00" at 8 pt
    panel_w, panel_h = nx * cell_w + 1.4, ny * 0.6 + 1.0
    side = len(subs) * panel_w + 1.2 <= MAX_FIG_W
    fig, axes = panel_grid(len(rows) * (1 if side else len(subs)), len(subs) if side else 1, panel_w, panel_h)
    norm = Normalize(0.0, 1.0)
    varying = np.unique(maps["n_runs"].values).size > 1  # adaptive sampling: say how many runs each cell kept
    mesh = None
    cells: list[tuple[Any, list[tuple[float, float, str, str, str]]]] = []
    for (r, row), (c, sub) in itertools.product(enumerate(rows), enumerate(subs)):
        ax = axes[r, c] if side else axes[r * len(subs) + c, 0]
        m = maps.sel(substrate=sub, **row).transpose("shape", "incline_deg", ...)
        p = m["p_success"].values
        lo, hi = m["p_success_lower"].values, m["p_success_upper"].values
        nv, nf, nr = m["n_valid"].values, m["n_failed"].values, m["n_runs"].values
        mesh = ax.pcolormesh(
            np.arange(nx + 1) - 0.5, np.arange(ny + 1) - 0.5, np.ma.masked_invalid(p), cmap=CMAP, norm=norm, edgecolors="w", linewidth=0.5
        )
        texts: list[tuple[float, float, str, str, str]] = []
        for j, i in itertools.product(range(ny), range(nx)):
            if nv[j, i] == 0:
                ax.add_patch(Rectangle((i - 0.5, j - 0.5), 1.0, 1.0, facecolor="0.85", edgecolor="0.55", hatch="///", lw=0.0))
                texts.append((i, j, "none\nvalid", "", "0.3"))
                continue
            # at most two detail lines, so that a cell with invalid runs fits as the others do
            bad = ([f"{int(nf[j, i])} inv" if varying else f"{int(nf[j, i])} invalid"]) if nf[j, i] > 0 else []
            extra = ([f"n={int(nr[j, i])}"] if varying else []) + bad
            detail = f"{lo[j, i]:.2f}\u2013{hi[j, i]:.2f}" + ("\n" + ", ".join(extra) if extra else "")
            texts.append((i, j, f"{p[j, i]:.2f}", detail, "w" if p[j, i] < 0.55 else "k"))
        cells.append((ax, texts))
        ax.set_xticks(np.arange(nx), [f"{v:g}" for v in incl])
        ax.set_yticks(np.arange(ny), shapes)
        ax.set_xlim(-0.5, nx - 0.5)
        ax.set_ylim(ny - 0.5, -0.5)  # first shape on top
        ax.set_xlabel("incline (deg)")
        if c == 0 or not side:
            ax.set_ylabel("shape")
        ax.set_title(panel_title(sub, row), fontsize=10)
    level = float(maps["p_success_lower"].attrs.get("confidence_level", float("nan")))
    method = ci_label(maps["p_success_lower"].attrs.get("ci_method", "?"))
    if mesh is not None:
        cb = fig.colorbar(mesh, ax=list(axes.ravel()), shrink=0.9)
        cb.set_label("P(success) of valid runs", fontsize=9)
    # lay the panels out, so that cell sizes on the page are known, and keep one renderer
    # to measure the texts with (Agg, as savefig uses for PNG)
    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw_without_rendering()
    shown = {_annotate_cells(ax, texts, nx, ny, renderer) for ax, texts in cells}
    notes = {
        "full": f"cells: P(success), its {level:.0%} {method} interval, "
        + ("runs kept (n) and runs not valid ('inv', left out of P)" if varying else "runs not valid (left out of P)"),
        "p": f"cells: P(success); * some runs not valid (left out of P); {level:.0%} {method} intervals in success_curves",
    }
    words = "; ".join(notes[k] for k in ("full", "p") if k in shown)
    if words:
        fig.suptitle(words, fontsize=9)
    save_figure(fig, path)
    return fig


def _annotate_cells(ax: Any, texts: list[tuple[float, float, str, str, str]], nx: int, ny: int, renderer: Any) -> str:
    """Write the cell texts that fit the cells as laid out; returns the level written.

    ``"full"`` (probability and detail lines), ``"p"`` (probability only) or ``"none"``;
    a level is kept only if the texts of every cell fit inside it with a margin.
    """
    box = ax.get_window_extent()
    cw, ch = 0.92 * box.width / nx, 0.92 * box.height / ny
    for level in ("full", "p"):
        made, fits = [], True
        for i, j, top, detail, colour in texts:
            if level == "full" and detail:
                cell = [
                    ax.text(i, j, top, ha="center", va="bottom", fontsize=CELL_FONT, color=colour),
                    ax.text(i, j + 0.02, detail, ha="center", va="top", fontsize=CELL_FONT_SMALL, color=colour),
                ]
            else:
                top += "*" if " inv" in detail else ""
                size = CELL_FONT if detail else CELL_FONT_SMALL
                cell = [ax.text(i, j, top, ha="center", va="center", fontsize=size, color=colour)]
            made += cell
            ext = [t.get_window_extent(renderer) for t in cell]
            # the two lines hang from the cell's centre: each half must fit
            half = 2 * max(e.height for e in ext) if len(cell) > 1 else ext[0].height
            fits &= max(e.width for e in ext) <= cw and half <= ch
        if fits:
            return level
        for t in made:
            t.remove()
    return "none"


#: marker per shape of the success curves (cycled), so that shapes differ by more than colour
CURVE_MARKERS = ("o", "s", "^", "D", "v", "P", "X", "<", ">", "*")


def plot_success_curves(maps: xr.Dataset, *, path: str | os.PathLike[str] | None = None) -> Figure:
    """Success probability against incline with confidence intervals, one line per shape.

    Parameters
    ----------
    maps : Dataset
        Maps from :func:`tumblemc.analysis.maps.maps`.
    path : path-like, optional
        File to save the figure to (PNG, PDF, ... by its suffix); None saves nothing.

    Returns
    -------
    Figure
        A panel per substrate (and per swept field setting); each shape has its colour
        and marker, and its confidence interval of ``p_success`` as an error bar; the
        shapes are offset along x by a small fraction of the incline step so that their
        bars do not hide each other (the offset is said in the title); cells without
        valid runs leave a gap.
    """
    subs = _substrates(maps["substrate"].values, None)
    rows = sweep_rows(maps, _map_dims(maps))
    shapes = [str(s) for s in maps["shape"].values]
    x = maps["incline_deg"].values.astype(np.float64)
    step = float(np.min(np.diff(x))) if x.size > 1 else 1.0
    dodge = 0.12 * step if len(shapes) > 1 else 0.0
    fig, axes = panel_grid(len(rows), len(subs), float(np.clip(0.35 * x.size, 4.0, 5.5)), 2.8)
    for r, row in enumerate(rows):
        for c, sub in enumerate(subs):
            ax = axes[r, c]
            for k, shp in enumerate(shapes):
                m = maps.sel(substrate=sub, shape=shp, **row)
                p = m["p_success"].values
                err = np.vstack([p - m["p_success_lower"].values, m["p_success_upper"].values - p])
                xk = x + (k - (len(shapes) - 1) / 2) * dodge
                ax.errorbar(
                    xk,
                    p,
                    yerr=err,
                    color=f"C{k % 10}",
                    marker=CURVE_MARKERS[k % len(CURVE_MARKERS)],
                    ms=3.5,
                    lw=1.2,
                    elinewidth=0.9,
                    capsize=2.0,
                    label=shp,
                )
            ax.set_ylim(-0.05, 1.05)
            ax.set_xlabel("incline (deg)")
            if c == 0:
                ax.set_ylabel("P(success)")
            ax.grid(True, alpha=0.3)
            ax.set_title(panel_title(sub, row), fontsize=9)
            if r == 0 and c == 0:
                ax.legend(fontsize=8, frameon=False, title="shape", title_fontsize=8)
    level = float(maps["p_success_lower"].attrs.get("confidence_level", float("nan")))
    method = ci_label(maps["p_success_lower"].attrs.get("ci_method", "?"))
    shift = f"\nshapes offset by {dodge:g} deg so that their bars stay apart" if dodge else ""
    fig.suptitle(f"success probability of valid runs; bars: {level:.0%} {method} interval{shift}", fontsize=9)
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
    early = early_words(runs)
    if early:
        parts.append(early.split("; audit")[0])
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
        ``ratio_distribution.png`` (a threshold study: ``threshold_distribution.png``, after
        the heatmap and curves when the axis is the incline; a critical-incline study:
        ``success_curves.png`` and ``critical_incline_distribution.png``).

    Returns
    -------
    list of Path
        The files written, in that order. When ``runs`` holds a numerical check subset,
        every figure carries a footnote with its verdict agreement rate.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    note: str | None
    if runs.attrs.get("mode") == "threshold":
        note = _threshold_note(runs)
        figures = [("threshold_distribution.png", plot_threshold_distribution(runs))]
        if runs.attrs.get("threshold_axis") == "incline_deg":
            figures = [("success_heatmap.png", plot_success_heatmap(maps)), ("success_curves.png", plot_success_curves(maps)), *figures]
    elif runs.attrs.get("mode") == "critical_incline":  # one run per sample, no incline grid
        a = runs.attrs
        note = (
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
        if "precision" in runs.attrs:
            a = runs.attrs
            adaptive = (
                f"adaptive sampling: {int(a['runs_kept']):,} runs kept ({int(a['runs_simulated']):,} simulated); each cell stops "
                f"once its interval's half-width is at most {float(a['precision']):g}, {int(a['cells_at_cap'])} cells reached the cap"
            )
            note = adaptive + ("; " + note if note else "")
        figures = [
            ("success_heatmap.png", plot_success_heatmap(maps)),
            ("success_curves.png", plot_success_curves(maps)),
            ("ratio_distribution.png", plot_ratio_distribution(runs)),
        ]
    paths = []
    for name, fig in figures:
        if note:
            # wrapped to the figure's width (about one 8 pt character per 0.065 inch)
            width = max(40, int(fig.get_figwidth() / 0.065))
            fig.text(0.01, 0.0, textwrap.fill(note, width), ha="left", va="top", fontsize=8, color="0.25")
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
        Samples outside the incline range are counted in the legend under each panel
        (fails at the minimum / climbs at the maximum), invalid runs too.
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
        # below the panel: the counts make the entries long, and the data fill the panel
        ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.14), frameon=False)
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


_AXIS_WORDS = {
    "incline_deg": ("critical incline", "deg"),
    "field_mT": ("critical field", "mT"),
    "freq_hz": ("highest frequency climbed", "Hz"),
}


def _threshold_note(runs: xr.Dataset) -> str:
    a = runs.attrs
    sims, grid = int(a.get("simulations_total", 0)), int(a.get("simulations_grid_equivalent", 0))
    parts = [f"threshold search: {sims:,} simulations for {runs.sizes['run']:,} samples ({grid:,} on the full grid)"]
    if "audit_checked_samples" in a:
        parts.append(
            f"audit: {int(a['audit_checked_samples'])} samples simulated at every grid value, "
            f"{int(a['audit_nonmonotone_samples'])} non-monotone, {int(a['audit_disagreements'])} of "
            f"{int(a['audit_compared_verdicts'])} verdicts differ from the threshold's, "
            f"{int(a['audit_early_stopped_climbed'])} early stops contradicted"
        )
    return "; ".join(parts)


def plot_threshold_distribution(runs: xr.Dataset, level: float = 0.95, path: str | os.PathLike[str] | None = None) -> Figure:
    """Empirical distribution of the per-sample thresholds of a threshold study, with a simultaneous band.

    One panel per substrate (rows) and shape (columns): the share of valid samples that
    pass each grid value (a step function of the grid: ``P(success)`` of the maps) and its
    simultaneous ``level`` band from the Dvoretzky-Kiefer-Wolfowitz inequality
    (``+- sqrt(ln(2 / (1 - level)) / (2 n))``, Massart's constant: the whole curve lies in
    it with probability ``level``), with the number of samples at each threshold as bars.
    """
    ax_name = str(runs.attrs["threshold_axis"])
    word, units = _AXIS_WORDS[ax_name]
    vals = runs[ax_name].values.astype(float)
    subs = sorted({str(v) for v in runs["substrate"].values})
    shapes = sorted({str(v) for v in runs["shape"].values})
    fig, axes = panel_grid(len(subs), len(shapes), 2.6, 2.2)
    verdict = runs["grid_verdict"].values
    width = 0.8 * float(np.min(np.diff(vals))) if len(vals) > 1 else 1.0
    for r, sub in enumerate(subs):
        for c, shp in enumerate(shapes):
            ax = axes[r, c]
            m = (runs["substrate"].values == sub) & (runs["shape"].values == shp)
            ok = m & (runs["status"].values == 0)
            n = int(ok.sum())
            if n:
                share = (verdict[ok] == 1).mean(axis=0)
                eps = float(np.sqrt(np.log(2.0 / (1.0 - level)) / (2.0 * n)))
                ax.fill_between(vals, np.clip(share - eps, 0, 1), np.clip(share + eps, 0, 1), step="mid", color="C0", alpha=0.25, lw=0)
                ax.step(vals, share, where="mid", color="C0", lw=1.6)
                thr = runs["threshold"].values[ok]
                counts = np.array([np.count_nonzero(thr == v) for v in vals]) / n
                ax.bar(vals, counts, width=width, color="0.55", alpha=0.6)
            ax.set_ylim(-0.02, 1.02)
            ax.set_title(f"{shp} on {sub} (n = {n}, invalid {int(np.count_nonzero(m & ~ok))})", fontsize=8)
            ax.grid(alpha=0.3)
            if r == len(subs) - 1:
                ax.set_xlabel(f"{ax_name.split('_')[0]} ({units})")
            if c == 0:
                ax.set_ylabel("share of samples")
    fig.suptitle(
        textwrap.fill(
            f"line: share of samples passing each grid value; band: {level:.0%} simultaneous (DKW); bars: share whose {word} is that value",
            max(40, int(fig.get_figwidth() / 0.075)),
        ),
        fontsize=9,
    )
    save_figure(fig, path)
    return fig
