"""The look shared by the figures of :mod:`tumblemc.viz`: colour map, resolution, labels, layout.

Every figure module takes its colour map, saving resolution, labels of the swept field
settings and panel layout from here, so that the figures of a study match.
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Sequence
from typing import Any

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

CMAP = "viridis"


DPI = 150


SWEEP_LABELS = {"field_mT": ("B", "mT"), "freq_hz": ("f", "Hz")}


GOLDEN = 0.6180339887498949  # low-discrepancy strip offsets: deterministic, no RNG


#: widest figure, inches: a docs page shrinks a wider one and its text with it
MAX_FIG_W = 13.0


#: depths below this are round-off of positions of about a millimetre, m (1e-3 nm)
PENETRATION_FLOOR_M = 1e-12


def format_penetration(depth_m: float) -> str:
    """A penetration depth for a label: nm with 3 digits, ``"< 0.001 nm"`` below round-off.

    Parameters
    ----------
    depth_m : float
        Depth of the robot below the plane, m.

    Returns
    -------
    str
        E.g. ``"12.3 nm"``; depths under :data:`PENETRATION_FLOOR_M` (float64 round-off
        of millimetre positions is about 1e-19 m) read ``"< 0.001 nm"``.
    """
    if not np.isfinite(depth_m):
        return "n/a"
    if depth_m < PENETRATION_FLOOR_M:
        return f"< {PENETRATION_FLOOR_M * 1e9:g} nm"
    return f"{depth_m * 1e9:.3g} nm"


def sweep_rows(ds: xr.Dataset, dims: Sequence[str]) -> list[dict[str, Any]]:
    """One ``sel`` dict per combination of the swept field settings (``[{}]`` if none)."""
    return [dict(zip(dims, combo, strict=True)) for combo in itertools.product(*(np.unique(ds[d].values).tolist() for d in dims))]


def panel_title(substrate: str, row: dict[str, Any]) -> str:
    """Title of a study panel: the substrate, and the field setting of its row if swept."""
    label = ", ".join(f"{SWEEP_LABELS[d][0]} = {v:g} {SWEEP_LABELS[d][1]}" for d, v in row.items())
    return f"substrate: {substrate}" + (f"\n{label}" if label else "")


def save_figure(fig: Figure, path: str | os.PathLike[str] | None) -> None:
    """Save ``fig`` at :data:`DPI`, cropped to its contents; nothing when ``path`` is None.

    Parameters
    ----------
    fig : Figure
        The figure.
    path : path-like or None
        Output file; the suffix picks the format (PNG, PDF, SVG, ...).
    """
    if path is not None:
        fig.savefig(path, dpi=DPI, bbox_inches="tight")


def panel_grid(nrows: int, ncols: int, panel_w: float, panel_h: float) -> tuple[Figure, np.ndarray]:
    """A figure of ``nrows`` x ``ncols`` panels of about ``panel_w`` x ``panel_h`` inches.

    Parameters
    ----------
    nrows, ncols : int
        Panels down and across.
    panel_w, panel_h : float
        Size of one panel, inches (margins for labels are added).

    Returns
    -------
    fig : Figure
        A constrained-layout figure not registered with pyplot.
    axes : (nrows, ncols) object array of Axes
    """
    fig = Figure(figsize=(panel_w * ncols + 1.2, panel_h * nrows + 0.6), layout="constrained")
    axes = np.asarray(fig.subplots(nrows, ncols, squeeze=False))
    return fig, axes
