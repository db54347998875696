"""The look shared by the figures of :mod:`tumblemc.viz`: colour map, resolution, labels, layout.

Every figure module takes its colour map, saving resolution, labels of the swept field
settings and panel layout from here, so that the figures of a study match.
"""

from __future__ import annotations

import os

import numpy as np
from matplotlib.figure import Figure

CMAP = "viridis"


DPI = 150


SWEEP_LABELS = {"field_mT": ("B", "mT"), "freq_hz": ("f", "Hz")}


GOLDEN = 0.6180339887498949  # low-discrepancy strip offsets: deterministic, no RNG


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
