"""Figure of a calibration (:func:`tumblemc.lab.calibrate.calibrate`): data, the fitted curve with its bands, and the posterior."""

from __future__ import annotations

import os
from typing import Any

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from tumblemc.model.params import get_preset
from tumblemc.viz.style import save_figure

AXIS_LABELS = {
    "field_mT": "static field |B| (mT)",
    "freq_hz": "field frequency (Hz)",
    "tilt_deg": "tilt (deg)",
    "speed_mm_s": "speed (mm/s)",
}


def plot_calibration(ds: xr.Dataset, path: str | os.PathLike[str] | None = None) -> Figure:
    """Left: the data, the model at the estimate, the 95% bands of the model and of new data. Right: the posterior, in pairs.

    The curve and the bands are drawn on ``x_grid`` (a fine grid with the closed form; the
    data's x with the simulator); data points outside their predictive band are red crosses.
    The posterior panels pair the first free field with the second (and the third).
    """
    three = ds.sizes.get("param", 0) >= 3
    fig = Figure(figsize=(15.5 if three else 11.0, 4.2))
    axes = fig.subplots(1, 3 if three else 2, gridspec_kw={"width_ratios": [1.3, 1.0, 1.0] if three else [1.3, 1.0]})
    ax, ax2 = axes[0], axes[1]
    g = "grid_" if "x_grid" in ds.coords else ""
    xg = ds["x_grid"].values if g else ds["x"].values
    order = np.argsort(xg)
    if f"{g}predictive_lo" in ds:
        lo, hi = ds[f"{g}predictive_lo"].values[order], ds[f"{g}predictive_hi"].values[order]
        ax.fill_between(xg[order], lo, hi, color="C0", alpha=0.15, lw=0, label="95% band of new data (posterior predictive)")
    ax.fill_between(
        xg[order],
        ds[f"{g}band_lo"].values[order],
        ds[f"{g}band_hi"].values[order],
        color="C0",
        alpha=0.35,
        lw=0,
        label="95% band of the model",
    )
    ax.plot(xg[order], ds[f"{g}fit" if g else "fit"].values[order], "-", color="C0", label="model at the estimate")
    x, y = ds["x"].values, ds["y"].values
    inside = (y >= ds["predictive_lo"].values) & (y <= ds["predictive_hi"].values) if "predictive_lo" in ds else np.ones(len(y), bool)
    ax.plot(x[inside], y[inside], "ko", ms=4, label="bench data")
    if not inside.all():
        ax.plot(x[~inside], y[~inside], "rx", ms=7, mew=2, label="outside its predictive band")
    ax.set_xlabel(AXIS_LABELS.get(ds["x"].attrs.get("long_name", ""), ds["x"].attrs.get("long_name", "x")))
    ax.set_ylabel(AXIS_LABELS.get(ds["y"].attrs.get("long_name", ""), ds["y"].attrs.get("long_name", "y")))
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    share = ds.attrs.get("predictive_share")
    check = f"; {int(inside.sum())}/{len(y)} data in the predictive band" if share is not None else ""
    ax.set_title(f"{ds.attrs['test']} of the {ds.attrs['shape']} robot: rms residual {ds.attrs['rms_residual']:.3g}{check}", fontsize=9)
    names = list(ds["param"].values)
    scales = str(ds.attrs.get("sampling_scale", "")).split(",")
    preset = str(ds.attrs.get("preset", "paper"))

    def spans_decades(nm: str) -> bool:  # a log axis for a log-scale field whose draws and preset span a decade or more
        v = np.append(ds[nm].values, float(getattr(get_preset(preset), nm)))
        return bool(v.min() > 0 and v.max() > 10.0 * v.min())

    log = {nm: i < len(scales) and scales[i] == "log" and spans_decades(nm) for i, nm in enumerate(names)}

    def label(nm: str) -> str:
        return f"{nm} ({ds[nm].attrs.get('units', '')})"

    def pair(axp: Any, a: str, b: str) -> None:
        axp.plot(ds[a].values, ds[b].values, ".", ms=2, alpha=0.3, color="C1", label="posterior draws")
        axp.plot(float(ds[f"estimate_{a}"]), float(ds[f"estimate_{b}"]), "k+", ms=12, mew=2, label="estimate")
        axp.plot(
            float(getattr(get_preset(preset), a)),
            float(getattr(get_preset(preset), b)),
            "s",
            mfc="none",
            mec="C3",
            ms=8,
            label=f"preset {preset!r}",
        )
        axp.set_xlabel(label(a))
        axp.set_ylabel(label(b))
        if log[a]:
            axp.set_xscale("log")
        if log[b]:
            axp.set_yscale("log")
        axp.legend(fontsize=7)
        axp.grid(alpha=0.3)

    if len(names) >= 2:
        pair(ax2, names[0], names[1])
        if three:
            pair(axes[2], names[0], names[2])
    else:
        v = ds[names[0]].values
        bins = np.geomspace(v.min(), v.max(), 41) if log[names[0]] and v.min() > 0 else 40
        ax2.hist(v, bins=bins, color="C1")
        if log[names[0]]:
            ax2.set_xscale("log")
        ax2.axvline(float(getattr(get_preset(preset), names[0])), color="C3", ls="--", label=f"preset {preset!r}")
        ax2.set_xlabel(label(names[0]))
        ax2.set_ylabel("posterior draws")
        ax2.legend(fontsize=7)
        ax2.grid(alpha=0.3)
    if not any(log.values()):
        ax2.ticklabel_format(style="sci", scilimits=(-3, 4))
    undet = ds.attrs.get("undetermined", "")
    method = {"mcmc": "MCMC", "laplace": "Laplace"}.get(str(ds.attrs.get("posterior_method", "laplace")), "")
    ax2.set_title(f"posterior ({method})" + (f"; not determined: {undet}" if undet else ""), fontsize=9)
    fig.tight_layout()
    save_figure(fig, path)
    return fig


__all__ = ["plot_calibration"]
