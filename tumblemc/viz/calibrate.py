"""Figure of a calibration (:func:`tumblemc.lab.calibrate.calibrate`): data against the fit, and the posterior."""

from __future__ import annotations

import os

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from tumblemc.viz.style import save_figure

AXIS_LABELS = {
    "field_mT": "static field |B| (mT)",
    "freq_hz": "field frequency (Hz)",
    "tilt_deg": "tilt (deg)",
    "speed_mm_s": "speed (mm/s)",
}


def plot_calibration(ds: xr.Dataset, path: str | os.PathLike[str] | None = None) -> Figure:
    """Left: the bench data, the model at the estimate and its 95% band. Right: the posterior of the first two free parameters."""
    fig = Figure(figsize=(10.0, 4.0))
    ax, ax2 = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.3, 1.0]})
    x, order = ds["x"].values, np.argsort(ds["x"].values)
    ax.fill_between(x[order], ds["band_lo"].values[order], ds["band_hi"].values[order], color="C0", alpha=0.25, label="95% band")
    ax.plot(x[order], ds["fit"].values[order], "-", color="C0", label="model at the estimate")
    ax.plot(x, ds["y"].values, "ko", ms=4, label="bench data")
    ax.set_xlabel(AXIS_LABELS.get(ds["x"].attrs.get("long_name", ""), ds["x"].attrs.get("long_name", "x")))
    ax.set_ylabel(AXIS_LABELS.get(ds["y"].attrs.get("long_name", ""), ds["y"].attrs.get("long_name", "y")))
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    ax.set_title(f"{ds.attrs['test']} of the {ds.attrs['shape']} robot: rms residual {ds.attrs['rms_residual']:.3g}", fontsize=10)
    names = list(ds["param"].values)

    def label(nm: str) -> str:
        return f"{nm} ({ds[nm].attrs.get('units', '')})"

    if len(names) >= 2:
        ax2.plot(ds[names[0]].values, ds[names[1]].values, ".", ms=2, alpha=0.3, color="C1")
        ax2.plot(float(ds[f"estimate_{names[0]}"]), float(ds[f"estimate_{names[1]}"]), "k+", ms=12, mew=2, label="estimate")
        ax2.set_xlabel(label(names[0]))
        ax2.set_ylabel(label(names[1]))
        ax2.legend(fontsize=8)
    else:
        ax2.hist(ds[names[0]].values, bins=40, color="C1")
        ax2.set_xlabel(label(names[0]))
        ax2.set_ylabel("posterior draws")
    ax2.ticklabel_format(style="sci", scilimits=(-3, 4))
    undet = ds.attrs.get("undetermined", "")
    ax2.set_title("posterior (Laplace)" + (f"; not determined: {undet}" if undet else ""), fontsize=10)
    ax2.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path)
    return fig


__all__ = ["plot_calibration"]
