"""tumblemc: non-point-contact simulation and Monte Carlo robustness studies of tumbling
magnetic microrobots (Xie, Bi, Cappelleri & Chakraborty, IDETC 2019)."""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("tumblemc")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.1.0.dev0"

from .params import PRESETS, Params, SolverOptions
from .simulate import simulate, summarize

__all__ = ["PRESETS", "Params", "SolverOptions", "__version__", "simulate", "summarize"]
