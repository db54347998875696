"""Figures of the bench-test protocols (:mod:`tumblemc.lab`): one function per protocol Dataset."""

from __future__ import annotations

import os

import numpy as np
import xarray as xr
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from tumblemc.viz.style import save_figure


def _title(ds: xr.Dataset, what: str) -> str:
    return f"{what}: {ds.attrs.get('shape', '?')} robot, {ds.attrs.get('preset', '?')} preset"


def plot_static_tilt(ds: xr.Dataset, path: str | os.PathLike[str] | None = None) -> Figure:
    """Equilibrium tilt against field strength, the rocking range, and the closed form where it applies."""
    fig = Figure(figsize=(6.0, 4.0), layout="constrained")
    ax = fig.add_subplot()
    b = ds["field_mT"].values
    ax.fill_between(b, ds["tilt_min_deg"], ds["tilt_max_deg"], color="0.85", label="rocking range")
    ax.errorbar(b, ds["tilt_deg"], yerr=ds["tilt_spread_deg"], fmt="o", color="C0", ms=4, capsize=2, label="simulated equilibrium")
    if "tilt_closed_form_curve_deg" in ds:
        ax.plot(ds["field_fine_mT"], ds["tilt_closed_form_curve_deg"], "-", color="C3", lw=1.2, label="closed-form edge balance")
    ax.set_xlabel("static field |B| (mT)")
    ax.set_ylabel("tilt (deg)")
    ax.set_title(_title(ds, "Static tilt"), fontsize=10)
    ax.legend(fontsize=8, loc="lower right")
    ax.grid(alpha=0.3)
    save_figure(fig, path)
    return fig


def plot_step_out(ds: xr.Dataset, path: str | os.PathLike[str] | None = None) -> Figure:
    """Speed, phase lag and the share of the field's turns followed against frequency, with the step-out marked.

    The share is the magnet's turns in the rotation plane divided by the field's, after the
    first period: 1 when the robot follows every turn, near 0 once it stepped out and only
    rocks; the step-out is where it falls below ``ds.attrs["step_out_share"]`` (0.5).
    """
    fig = Figure(figsize=(6.4, 7.0), layout="constrained")
    ax1, ax2, ax3 = fig.subplots(3, 1, sharex=True)
    f = ds["freq_hz"].values
    ax1.plot(f, ds["speed"], "o-", ms=4, label="simulated")
    ax1.plot(f, ds["speed"].values / ds["progress_ratio"].values, "--", color="0.5", lw=1, label="no-slip tumbling")
    ax1.set_ylabel("speed (mm/s)")
    ax2.plot(f, ds["phase_lag_deg"], "o-", ms=4, color="C1")
    ax2.set_ylabel("mean phase lag\n(field - magnet, deg)")
    share = float(ds.attrs.get("step_out_share", 0.5))
    if "following_share" in ds:
        ax3.plot(f, ds["following_share"], "o-", ms=4, color="C2")
        ax3.axhline(share, color="0.5", lw=0.8, ls=":", label=f"follows at ≥ {share:g}")
        ax3.legend(fontsize=8, loc="center left")
    ax3.set_ylabel("turns made /\nfield turns")
    ax3.set_xlabel("field frequency (Hz)")
    so = float(ds["step_out_hz"])
    for ax in (ax1, ax2, ax3):
        ax.grid(alpha=0.3)
        if np.isfinite(so):
            ax.axvline(so, color="C3", lw=1, label=f"step-out {so:.4g} Hz" if ax is ax1 else None)
    ax1.legend(fontsize=8)
    head = f"step-out at {so:.4g} Hz" if np.isfinite(so) else "no step-out in the sweep"
    fig.suptitle(
        _title(ds, "Step-out") + f", {ds.attrs.get('field_mT', '?'):g} mT: {head}\n"
        "turns made / field turns: the magnet's turns over the field's after the first period",
        fontsize=9,
    )
    save_figure(fig, path)
    return fig


def plot_steering(ds: xr.Dataset, path: str | os.PathLike[str] | None = None) -> Figure:
    """Top view of the centre of mass's path over the two legs, with the turn."""
    fig = Figure(figsize=(5.0, 5.0), layout="constrained")
    ax = fig.add_subplot()
    t = ds["time"].values
    p = ds["position"].values * 1e3
    half = t <= float(ds.attrs["duration_s"]) / 2
    ax.plot(p[half, 0], p[half, 1], color="C0", label="leg 1")
    ax.plot(p[~half, 0], p[~half, 1], color="C1", label="leg 2")
    ax.plot(p[0, 0], p[0, 1], "ko", ms=4)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(
        _title(ds, "Steering") + f"\nturn {float(ds['turn_deg']):.1f} deg, field jump {float(ds['field_jump_deg']):.0f} deg", fontsize=10
    )
    save_figure(fig, path)
    return fig


def plot_critical_field(ds: xr.Dataset, path: str | os.PathLike[str] | None = None) -> Figure:
    """The bisection's trials (field against trial, by verdict) or, per sample, the critical fields' histogram."""
    fig = Figure(figsize=(6.0, 3.8), layout="constrained")
    ax = fig.add_subplot()
    if "sample" in ds.dims:
        ax.hist(ds["critical_mT"].values[np.isfinite(ds["critical_mT"].values)], bins=max(5, ds.sizes["sample"] // 3), color="C0")
        ax.axvline(float(ds["critical_mT_median"]), color="C3", lw=1.2, label="median")
        ax.set_xlabel("critical field (mT)")
        ax.set_ylabel("parameter samples")
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
        ax.legend(fontsize=8)
        head = f"Critical field over {ds.sizes['sample']} samples"
    else:
        k = ds["trial"].values
        ok = ds["tumbled"].values.astype(bool)
        ax.plot(k[ok], ds["tested_mT"].values[ok], "o", color="C2", label="tumbles")
        ax.plot(k[~ok], ds["tested_mT"].values[~ok], "x", color="C3", label="does not")
        c = float(ds["critical_mT"])
        if np.isfinite(c):
            ax.axhline(c, color="0.4", lw=1, ls="--", label=f"critical {c:.3g} mT")
        ax.set_xlabel("bisection trial")
        ax.set_ylabel("field |B| (mT)")
        ax.legend(fontsize=8)
        head = "Critical field"
    ax.grid(alpha=0.3)
    ax.set_title(
        f"{head}: {ds.attrs.get('shape', '?')}, {ds.attrs.get('preset', '?')}, {ds.attrs.get('freq_hz', '?')} Hz, "
        f"{ds.attrs.get('incline_deg', '?')} deg",
        fontsize=10,
    )
    save_figure(fig, path)
    return fig


PLOTS = {
    "critical_field": plot_critical_field,
    "critical_field_samples": plot_critical_field,
    "static_tilt": plot_static_tilt,
    "step_out": plot_step_out,
    "steering": plot_steering,
}


def plot_lab(ds: xr.Dataset, path: str | os.PathLike[str] | None = None) -> Figure | None:
    """The figure of a protocol Dataset (by its ``protocol`` attribute); None when it has none."""
    fn = PLOTS.get(str(ds.attrs.get("protocol")))
    return fn(ds, path) if fn else None


__all__ = ["plot_critical_field", "plot_lab", "plot_static_tilt", "plot_steering", "plot_step_out"]
