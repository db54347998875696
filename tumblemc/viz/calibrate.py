"""Figure of a calibration (:func:`tumblemc.lab.calibrate.calibrate`): data, the fitted curve with its bands, and the posterior."""

from __future__ import annotations

import os
from typing import Any

import numpy as np
import xarray as xr
from matplotlib.figure import Figure
from matplotlib.ticker import ScalarFormatter

from tumblemc.model.params import get_preset
from tumblemc.viz.style import save_figure

#: units as written in labels (the Dataset carries CF/udunits names)
UNIT_WORDS = {"degree": "deg", "mm s-1": "mm/s", "mm/s": "mm/s"}

AXIS_LABELS = {
    "field_mT": "static field |B| (mT)",
    "freq_hz": "field frequency (Hz)",
    "tilt_deg": "tilt (deg)",
    "speed_mm_s": "speed (mm/s)",
}


def _data_panel(ax: Any, ds: xr.Dataset) -> None:
    """The data, the model at the estimate and its bands (on the fine grid, or at the data with the simulator)."""
    g = "grid_" if "x_grid" in ds.coords else ""
    xg = ds["x_grid"].values if g else ds["x"].values
    order = np.argsort(xg)
    bands = [
        ("predictive_", "C0", 0.15, 7.0, "95% band of new data (posterior predictive)"),
        ("band_", "C0", 0.35, 3.5, "95% band of the model"),
    ]
    for key, colour, alpha, width, name in bands:
        if f"{g}{key}lo" not in ds:  # the predictive band needs a noise model
            continue
        lo, hi = ds[f"{g}{key}lo"].values[order], ds[f"{g}{key}hi"].values[order]
        if g:
            ax.fill_between(xg[order], lo, hi, color=colour, alpha=alpha, lw=0, label=name)
        else:  # bands at the data's x only: bars, not a filled area interpolated between fields
            ax.vlines(xg[order], lo, hi, color=colour, alpha=alpha + 0.1, lw=width, label=name)
    if g:
        ax.plot(xg[order], ds["grid_fit"].values[order], "-", color="C0", label="model at the estimate")
    else:  # a simulator-based fit is known at the data's x only: no line through it
        ax.plot(xg[order], ds["fit"].values[order], "s", mfc="none", mec="C0", ms=6, label="model at the estimate (simulated at the data)")
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
    y_unit = str(ds["y"].attrs.get("units", ""))
    y_unit = " " + UNIT_WORDS.get(y_unit, y_unit) if y_unit else ""
    ax.set_title(
        f"{ds.attrs['test']} of the {ds.attrs['shape']} robot: rms residual {ds.attrs['rms_residual']:.3g}{y_unit}{check}", fontsize=9
    )


def plot_calibration(ds: xr.Dataset, path: str | os.PathLike[str] | None = None) -> Figure:
    """Left: the data, the model at the estimate, the 95% bands of the model and of new data. Right: the posterior, in pairs.

    The curve and the bands are drawn on ``x_grid`` (a fine grid with the closed form); a
    simulator-based fit is known at the data's x only, so the model is drawn there as open
    squares, not joined. Data points outside their predictive band are red crosses. A
    parameter axis far from 1 is scaled by a power of ten named in its label (no offset
    text in the corner).
    The posterior panels pair the first free field with the second (and the third).
    """
    three = ds.sizes.get("param", 0) >= 3
    fig = Figure(figsize=(15.5 if three else 11.0, 4.2), layout="constrained")
    axes = fig.subplots(1, 3 if three else 2, gridspec_kw={"width_ratios": [1.3, 1.0, 1.0] if three else [1.3, 1.0]})
    ax, ax2 = axes[0], axes[1]
    _data_panel(ax, ds)
    names = list(ds["param"].values)
    scales = str(ds.attrs.get("sampling_scale", "")).split(",")
    preset = str(ds.attrs.get("preset", "paper"))

    def spans_decades(nm: str) -> bool:  # a log axis for a log-scale field whose draws and preset span a decade or more
        v = np.append(ds[nm].values, float(getattr(get_preset(preset), nm)))
        return bool(v.min() > 0 and v.max() > 10.0 * v.min())

    log = {nm: i < len(scales) and scales[i] == "log" and spans_decades(nm) for i, nm in enumerate(names)}

    def label(nm: str, scale: float = 1.0) -> str:
        unit = str(ds[nm].attrs.get("units", ""))
        unit = UNIT_WORDS.get(unit, unit)
        return f"{nm} ({f'1e{round(np.log10(scale))} ' if scale != 1.0 else ''}{unit})".replace(" )", ")").replace("()", "")

    def scale_of(nm: str) -> float:
        """A power of ten that brings a linear axis's values near 1 (none for a log axis or values near 1)."""
        if log[nm]:
            return 1.0
        v = np.append(ds[nm].values, float(getattr(get_preset(preset), nm)))
        top = float(np.nanmax(np.abs(v))) if np.isfinite(v).any() else 0.0
        k = int(np.floor(np.log10(top))) if top > 0 else 0
        return 10.0**k if k <= -3 or k >= 4 else 1.0

    def no_offset(axis: Any) -> None:
        """Plain tick labels: the scale is in the axis label, never in matplotlib's corner offset text."""
        fmt = ScalarFormatter(useOffset=False)
        fmt.set_scientific(False)
        axis.set_major_formatter(fmt)

    def pair(axp: Any, a: str, b: str) -> None:
        sa, sb = scale_of(a), scale_of(b)
        axp.plot(ds[a].values / sa, ds[b].values / sb, ".", ms=2, alpha=0.3, color="C1", label="posterior draws")
        axp.plot(float(ds[f"estimate_{a}"]) / sa, float(ds[f"estimate_{b}"]) / sb, "k+", ms=12, mew=2, label="estimate")
        axp.plot(
            float(getattr(get_preset(preset), a)) / sa,
            float(getattr(get_preset(preset), b)) / sb,
            "s",
            mfc="none",
            mec="C3",
            ms=8,
            label=f"preset {preset!r}",
        )
        axp.set_xlabel(label(a, sa))
        axp.set_ylabel(label(b, sb))
        if log[a]:
            axp.set_xscale("log")
        else:
            no_offset(axp.xaxis)
        if log[b]:
            axp.set_yscale("log")
        else:
            no_offset(axp.yaxis)
        axp.legend(fontsize=7)
        axp.grid(alpha=0.3)

    if len(names) >= 2:
        pair(ax2, names[0], names[1])
        if three:
            pair(axes[2], names[0], names[2])
    else:
        s0 = scale_of(names[0])
        v = ds[names[0]].values / s0
        bins = np.geomspace(v.min(), v.max(), 41) if log[names[0]] and v.min() > 0 else 40
        ax2.hist(v, bins=bins, color="C1")
        if log[names[0]]:
            ax2.set_xscale("log")
        else:
            no_offset(ax2.xaxis)
        ax2.axvline(float(getattr(get_preset(preset), names[0])) / s0, color="C3", ls="--", label=f"preset {preset!r}")
        ax2.set_xlabel(label(names[0], s0))
        ax2.set_ylabel("posterior draws")
        ax2.legend(fontsize=7)
        ax2.grid(alpha=0.3)
    undet = ds.attrs.get("undetermined", "")
    method = {"mcmc": "MCMC", "laplace": "Laplace"}.get(str(ds.attrs.get("posterior_method", "laplace")), "")
    ax2.set_title(f"posterior ({method})" + (f"; not determined: {undet}" if undet else ""), fontsize=9)
    save_figure(fig, path)
    return fig


__all__ = ["plot_calibration"]
