"""Figures of the validation report, ``tumblemc validate`` (viz layer; matplotlib object API).

:mod:`tumblemc.reports.claims` runs the scenarios and hands the numbers here:
:func:`plot_paper_inclines` (progress against time on the paper inclines),
:func:`plot_frequency_sweep` and :func:`plot_shape_speeds` (speeds on the flat),
:func:`plot_adhesion_series` (the adhesion plateaus on the 45 deg incline) and
:func:`plot_convergence` (progress ratio against dt, from the rows of the convergence
table, so that the figure can be redrawn from ``convergence.csv`` alone).
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import FixedLocator, NullLocator

from tumblemc.viz.style import save_figure


def plot_paper_inclines(
    traces: Sequence[tuple[str, np.ndarray, np.ndarray]],
    title: str,
    *,
    ylim_mm: tuple[float, float] = (-3.0, 4.0),
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """Uphill progress against time, one line per run, in a fixed window.

    Parameters
    ----------
    traces : sequence of (label, time, progress)
        Per run: legend label, time (s, shape (n,)) and uphill progress (m, shape (n,)).
    title : str
        Figure title.
    ylim_mm : (float, float)
        Progress window, mm.
    path : path-like, optional
        File to save the figure to; None saves nothing.

    Returns
    -------
    Figure
        A run that leaves the window (a robot sliding away) is marked with a triangle
        where it leaves, and its legend entry gives its progress at the end.
    """
    fig = Figure(figsize=(8, 4.5), layout="constrained")
    ax = fig.add_subplot()
    lo, hi = ylim_mm
    for k, (label, t, prog) in enumerate(traces):
        mm = np.asarray(prog) * 1e3
        out = np.flatnonzero((mm < lo) | (mm > hi))
        if out.size:
            end = f"{mm[-1]:+,.0f}" if abs(mm[-1]) >= 100 else f"{mm[-1]:+.3g}"
            label += f" (off the plot: {end} mm at {t[-1]:g} s)"
        ax.plot(t, mm, color=f"C{k % 10}", label=label)
        if out.size:
            edge = lo if mm[out[0]] < lo else hi
            ax.plot(t[out[0]], edge, "v" if edge == lo else "^", color=f"C{k % 10}", ms=9, clip_on=False, zorder=3)
    ax.set(xlabel="time (s)", ylabel="uphill progress (mm)", title=title, ylim=ylim_mm)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    save_figure(fig, path)
    return fig


def plot_frequency_sweep(
    freq_hz: np.ndarray,
    speed: np.ndarray,
    slip_speed: np.ndarray,
    no_slip_speed: np.ndarray,
    title: str,
    *,
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """Mean speed and mean slip speed against field frequency, with the no-slip line.

    Parameters
    ----------
    freq_hz : (n,) ndarray
        Field frequencies, Hz.
    speed, slip_speed, no_slip_speed : (n,) ndarray
        Simulated mean speed, mean slip speed and the no-slip speed ``2 (L + H) f``, m/s.
    title : str
        Figure title.
    path : path-like, optional
        File to save the figure to; None saves nothing.

    Returns
    -------
    Figure
    """
    fig = Figure(figsize=(7, 4), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(freq_hz, np.asarray(no_slip_speed) * 1e3, "k--", label="no slip, 2(L+H)f")
    ax.plot(freq_hz, np.asarray(speed) * 1e3, "o-", label="simulated mean speed")
    ax.plot(freq_hz, np.asarray(slip_speed) * 1e3, "s-", label="mean slip speed")
    ax.set(xlabel="field frequency (Hz)", ylabel="speed (mm/s)", title=title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=9)
    save_figure(fig, path)
    return fig


def plot_shape_speeds(
    speeds: Mapping[str, Mapping[str, float]],
    no_slip: Mapping[str, float],
    title: str,
    *,
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """Mean speed per shape as bars, a group per shape and a bar per substrate preset.

    Parameters
    ----------
    speeds : mapping of preset to (mapping of shape to float)
        Simulated mean speed, m/s.
    no_slip : mapping of shape to float
        No-slip speed (hull perimeter x f), m/s, drawn as a black bar across each group.
    title : str
        Figure title.
    path : path-like, optional
        File to save the figure to; None saves nothing.

    Returns
    -------
    Figure
        Each bar is labelled with its speed.
    """
    shapes = list(no_slip)
    presets = list(speeds)
    fig = Figure(figsize=(8, 4), layout="constrained")
    ax = fig.add_subplot()
    x = np.arange(len(shapes))
    w = 0.8 / len(presets)
    for j, preset in enumerate(presets):
        bars = ax.bar(x + w * (j - (len(presets) - 1) / 2), [speeds[preset][k] * 1e3 for k in shapes], w, label=preset)
        ax.bar_label(bars, fmt="%.1f", fontsize=9, label_type="center", color="w")
    ax.hlines([no_slip[k] * 1e3 for k in shapes], x - 0.45, x + 0.45, colors="k", lw=2, label="no slip (hull perimeter x f)")
    ax.set(xticks=x, xticklabels=shapes, ylabel="mean speed (mm/s)", title=title)
    ax.set_ylim(0, 1.15 * max(max(no_slip.values()), *(max(v.values()) for v in speeds.values())) * 1e3)
    ax.legend(fontsize=8, loc="upper left")
    save_figure(fig, path)
    return fig


def plot_adhesion_series(
    time: np.ndarray,
    adhesion: np.ndarray,
    plateaus: Mapping[str, float],
    title: str,
    *,
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """Adhesion force against time with the expected plateaus drawn and labelled.

    Parameters
    ----------
    time : (n,) ndarray
        Time, s.
    adhesion : (n,) ndarray
        Adhesion force, N.
    plateaus : mapping of str to float
        Label (e.g. ``"face: C L W"``) to expected force, N.
    title : str
        Figure title.
    path : path-like, optional
        File to save the figure to; None saves nothing.

    Returns
    -------
    Figure
        The plateau labels sit inside the axes, above their lines, with their values.
    """
    fig = Figure(figsize=(8, 3.5), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(time, np.asarray(adhesion) * 1e6, lw=0.8)
    top = max([*plateaus.values(), float(np.max(adhesion))]) * 1e6
    for lab, v in plateaus.items():
        ax.axhline(v * 1e6, ls=":", c="gray")
        ax.annotate(
            f"{lab} = {v * 1e6:.3g} \u00b5N",
            (0.99, v * 1e6),
            xycoords=("axes fraction", "data"),
            xytext=(0, 2),
            textcoords="offset points",
            va="bottom",
            ha="right",
            fontsize=8,
            bbox={"boxstyle": "square,pad=0.1", "fc": "w", "ec": "none", "alpha": 0.8},
        )
    ax.set(xlabel="time (s)", ylabel="adhesion force (\u00b5N)", title=title, ylim=(-0.05 * top, 1.15 * top))
    save_figure(fig, path)
    return fig


def plot_convergence(
    table: Sequence[Mapping[str, Any]],
    cases: Sequence[str],
    *,
    threshold: float = 0.5,
    mark_dt: float | None = None,
    path: str | os.PathLike[str] | None = None,
) -> Figure:
    """Progress ratio against the time step, a panel per torque option.

    Parameters
    ----------
    table : sequence of mappings
        Rows of the convergence table (``case``, ``torque``, ``dt`` in s,
        ``progress_ratio``), as :func:`tumblemc.reports.convergence.convergence` returns them
        or as read back from ``convergence.csv``.
    cases : sequence of str
        Cases to draw, in legend order.
    threshold : float
        Success threshold of the progress ratio.
    mark_dt : float, optional
        The default time step, s, marked with a dotted vertical line.
    path : path-like, optional
        File to save the figure to; None saves nothing.

    Returns
    -------
    Figure
        x: dt on a log axis, ticked at the table's steps in microseconds. Top row: the
        cases whose median ratio reaches the threshold (climbing, where the ratio should
        converge); bottom row: the others (sliding down, where only the verdict must); each
        row on its own linear scale with the threshold dashed where it is in range.
    """
    rows = [{**r, "dt": float(r["dt"]), "progress_ratio": float(r["progress_ratio"])} for r in table]
    dts = sorted({r["dt"] for r in rows})
    climbs = {c: float(np.median([r["progress_ratio"] for r in rows if r["case"] == c])) >= threshold for c in cases}
    groups = [g for g in ([c for c in cases if climbs[c]], [c for c in cases if not climbs[c]]) if g]
    fig = Figure(figsize=(10, 2.2 + 2.6 * len(groups)), layout="constrained")
    axs = np.asarray(fig.subplots(len(groups), 2, sharex=True, sharey="row", squeeze=False))
    for g, group in enumerate(groups):
        for ax, torque in zip(axs[g], ("start", "end"), strict=True):
            for name in group:
                sel = sorted((r for r in rows if r["case"] == name and r["torque"] == torque), key=lambda r: r["dt"])
                colour = f"C{list(cases).index(name) % 10}"
                ax.plot([r["dt"] for r in sel], [r["progress_ratio"] for r in sel], "o-", color=colour, ms=5, label=name)
            ax.grid(alpha=0.3)
            if mark_dt is not None:
                ax.axvline(mark_dt, color="0.4", ls=":", lw=1.2)
            if g == 0:
                ax.set_title(f"torque at the {torque} of the step", fontsize=10)
        lo, hi = axs[g, 0].get_ylim()
        if lo - 0.1 * (hi - lo) <= threshold <= hi + 0.1 * (hi - lo):
            # a threshold near the edge gets room, so that it does not sit on the frame
            span = max(hi, threshold) - min(lo, threshold)
            axs[g, 0].set_ylim(min(lo, threshold - 0.06 * span), max(hi, threshold + 0.06 * span))
            for ax in axs[g]:
                ax.axhline(threshold, color="k", ls="--", lw=1.0)
        kind = "climbing cases" if climbs[group[0]] else "cases sliding down"
        axs[g, 0].set_ylabel(f"progress ratio\n({kind})", fontsize=9)
        axs[g, 1].legend(fontsize=8, frameon=False, loc="center left", bbox_to_anchor=(1.01, 0.5))
    for ax in axs[-1]:
        ax.set_xscale("log")
        ax.xaxis.set_major_locator(FixedLocator(dts))
        ax.xaxis.set_minor_locator(NullLocator())
        ax.set_xticks(dts, [f"{d * 1e6:g}" for d in dts])
        ax.set_xlabel("dt (\u00b5s)")
    marked = f"; dotted: the default dt, {mark_dt * 1e6:g} \u00b5s" if mark_dt is not None else ""
    fig.suptitle(f"dt convergence (dashed: success threshold {threshold:g}{marked})", fontsize=10)
    save_figure(fig, path)
    return fig
