"""TODO docstring (split from tumblemc/plotting_study.py)."""

from __future__ import annotations

import os

from matplotlib.figure import Figure

CMAP = "viridis"


DPI = 150


SWEEP_LABELS = {"field_mT": ("B", "mT"), "freq_hz": ("f", "Hz")}


GOLDEN = 0.6180339887498949  # low-discrepancy strip offsets: deterministic, no RNG


def save_figure(fig: Figure, path: str | os.PathLike[str] | None) -> None:
    if path is not None:
        fig.savefig(path, dpi=DPI, bbox_inches="tight")
