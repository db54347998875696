"""Figures of a design search (:mod:`tumblemc.design.result`).

- :func:`plot_front`: two objectives against each other, every design with its interval
  bars, the Pareto set joined and the recommended design marked; with one objective, the
  objective per design in the order evaluated with the model's mean and the confirmed
  estimate.
- :func:`plot_variables`: each objective against each design variable (colour: round).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from tumblemc.viz.style import panel_grid, save_figure


def _label(ds: xr.Dataset, name: str) -> str:
    if "label" in ds[name].attrs:
        return str(ds[name].attrs["label"])
    u = ds[name].attrs.get("units", "")
    unit = "um" if u == "m" else u
    return f"{name} ({unit})" if unit and unit != "1" else name


def _vals(ds: xr.Dataset, name: str) -> np.ndarray:
    v = ds[name].values.astype(float)
    return v * 1e6 if ds[name].attrs.get("units") == "m" else v


def _err(ds: xr.Dataset, name: str) -> np.ndarray:
    v, lo, hi = ds[name].values, ds[name + "_lo"].values, ds[name + "_hi"].values
    lo = np.where(np.isfinite(lo), lo, v)
    hi = np.where(np.isfinite(hi), hi, v)
    return np.vstack([np.maximum(v - lo, 0), np.maximum(hi - v, 0)])


def plot_front(tree: xr.DataTree, path: str | os.PathLike[str] | None = None) -> Figure:
    """The Pareto front with interval bars (two objectives), or the search trace (one)."""
    ds = tree["designs"].to_dataset()
    objs = [o for o in str(tree.attrs["objectives"]).split(",") if o]
    rec = int(tree.attrs.get("recommended", -1))
    fig, axs = panel_grid(1, 1, 6.0, 4.2)
    ax = axs[0, 0]
    if len(objs) >= 2:
        a, b = objs[0], objs[1]
        x, y = ds[a].values, ds[b].values
        ax.errorbar(
            x, y, xerr=_err(ds, a), yerr=_err(ds, b), fmt="o", ms=4, color="0.6", ecolor="0.8", lw=0.8, label="designs (95% intervals)"
        )
        par = ds["pareto"].values
        order = np.argsort(x[par])
        ax.plot(x[par][order], y[par][order], "o-", color="C3", ms=6, label="Pareto set (estimates)")
        ax.set_xlabel(_label(ds, a))
        ax.set_ylabel(_label(ds, b))
        ax.set_title(f"{tree.attrs['family']}: {len(x)} designs, {tree.attrs['simulations']} simulations")
    else:
        a = objs[0]
        n = ds.sizes["design"]
        stopped = ds["stopped_early"].values
        idx = np.arange(n)
        ax.errorbar(
            idx[~stopped],
            ds[a].values[~stopped],
            yerr=_err(ds, a)[:, ~stopped],
            fmt="o",
            ms=4,
            color="C0",
            lw=0.8,
            label="designs (95% intervals)",
        )
        if stopped.any():
            ax.errorbar(
                idx[stopped],
                ds[a].values[stopped],
                yerr=_err(ds, a)[:, stopped],
                fmt="x",
                ms=5,
                color="0.55",
                lw=0.8,
                label="stopped early",
            )
        if "model_mean" in ds:
            ax.plot(idx, ds["model_mean"].values, "_", color="C1", ms=10, mew=2, label="model mean")
        if rec >= 0:
            conf = tree["confirm"].to_dataset().sel(objective=a)
            ax.errorbar(
                [rec],
                [float(conf["value"])],
                yerr=[[float(conf["value"] - conf["lo"])], [float(conf["hi"] - conf["value"])]],
                fmt="*",
                ms=13,
                color="C3",
                label=f"recommended, on {int(conf['robots'])} fresh robots",
            )
        ax.set_xlabel("design (order evaluated)")
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        ax.set_ylabel(_label(ds, a))
        ax.set_title(f"{tree.attrs['family']}: {n} designs, {tree.attrs['simulations']} simulations ({tree.attrs['strategy']})")
    ax.legend(fontsize=8, loc="best")
    ax.grid(alpha=0.3)
    save_figure(fig, path)
    return fig


def plot_variables(tree: xr.DataTree, path: str | os.PathLike[str] | None = None) -> Figure:
    """Each objective (rows) against each design variable (columns), interval bars, colour by round."""
    ds = tree["designs"].to_dataset()
    objs = [o for o in str(tree.attrs["objectives"]).split(",") if o]
    variables = [str(v) for v in ds.data_vars if ds[v].attrs.get("long_name", "").startswith("design variable")]
    fig, axs = panel_grid(len(objs), len(variables), 3.6, 2.8)
    rounds = ds["round"].values
    rec = int(tree.attrs.get("recommended", -1))
    for r, o in enumerate(objs):
        for c, v in enumerate(variables):
            ax = axs[r, c]
            x = _vals(ds, v)
            ax.errorbar(x, ds[o].values, yerr=_err(ds, o), fmt="none", ecolor="0.8", lw=0.8)
            sc = ax.scatter(x, ds[o].values, c=rounds, cmap="viridis", s=16, zorder=3)
            if rec >= 0:
                ax.scatter([x[rec]], [ds[o].values[rec]], marker="*", s=160, color="C3", zorder=4, label="recommended")
                ax.legend(fontsize=7, loc="best")
            ax.set_xlabel(_label(ds, v).replace("(m)", "(um)"))
            ax.set_ylabel(_label(ds, o))
            ax.grid(alpha=0.3)
    fig.colorbar(sc, ax=axs.ravel().tolist(), label="round", shrink=0.8)
    save_figure(fig, path)
    return fig


def plot_design(tree: xr.DataTree, out_dir: str | os.PathLike[str]) -> list[Path]:
    """Write ``design_front.png`` and ``design_variables.png`` into ``out_dir``; returns the paths."""
    d = Path(out_dir)
    d.mkdir(parents=True, exist_ok=True)
    paths = [d / "design_front.png", d / "design_variables.png"]
    plot_front(tree, paths[0])
    plot_variables(tree, paths[1])
    return paths


def sweep_figure(df: Any, path: str | os.PathLike[str]) -> None:
    """Speed and critical incline against the spike size, both mass rules."""
    from tumblemc.design.sweep import RULES

    fig, axs = panel_grid(1, 2, 4.2, 3.2)
    for rule, ls, color in zip(RULES, ("-", "--"), ("C0", "C1"), strict=True):
        d = df[df["mass_rule"] == rule]
        axs[0, 0].plot(d["spike_um"], d["speed_mm_s"], "o" + ls, color=color, ms=4, label=f"mass rule {rule}")
        axs[0, 1].plot(d["spike_um"], d["climbs_deg"], "o" + ls, color=color, ms=4, label=f"{rule}: climbs (ratio >= 0.5)")
        axs[0, 1].plot(d["spike_um"], d["holds_deg"], "s" + ls, color=color, ms=4, mfc="none", label=f"{rule}: holds (ratio > 0)")
    axs[0, 0].set_ylabel("speed on flat aluminum (mm/s)")
    axs[0, 1].set_ylabel("critical incline (deg)")
    for ax in axs[0]:
        ax.set_xlabel("spike base = spike height (um)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("spiked-ends sweep, aluminum, 20 mT, 10 Hz (nominal robot)")
    save_figure(fig, path)


__all__ = ["sweep_figure", "plot_design", "plot_front", "plot_variables"]
