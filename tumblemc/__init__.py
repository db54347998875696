"""tumblemc: non-point-contact simulation and Monte Carlo robustness studies of tumbling magnetic microrobots.

The model is that of Xie, Bi, Cappelleri & Chakraborty (IDETC 2019).

The public API: :func:`simulate` and :func:`summarize` (one run), :func:`load_config`,
:func:`run_study` and :func:`open_result` (studies), the shapes (``tumblemc.shapes``,
the module :mod:`tumblemc.model.shapes` as an attribute), :data:`PRESETS`, :class:`Params`
and :class:`SolverOptions`. Layers, lowest first (``tools/check_imports.py``): ``kernels``
(Numba) <- ``schema``, ``model``, ``testing`` <- ``io``, ``analysis`` <- ``study`` <-
``viz`` <- ``claims``, ``lab``, ``calibrate``, ``stress``, ``stepcost``, ``convergence``
<- ``cli``.
"""

from __future__ import annotations

from tumblemc.io import open_result
from tumblemc.model import shapes
from tumblemc.model.outcome import summarize
from tumblemc.model.params import PRESETS, Params
from tumblemc.model.run import simulate
from tumblemc.model.shapes import SHAPES, Shape, extruded, get_shape
from tumblemc.model.solver_options import SolverOptions
from tumblemc.version import __version__

_LAZY = {"load_config": "tumblemc.study.config", "run_study": "tumblemc.study.engine"}


def __getattr__(name: str) -> object:
    """Import the study API on first use.

    ``import tumblemc`` stays light: scipy.stats and the engine load only when a study runs.
    """
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'tumblemc' has no attribute {name!r}")


__all__ = [
    "PRESETS",
    "SHAPES",
    "Params",
    "Shape",
    "SolverOptions",
    "__version__",
    "extruded",
    "get_shape",
    "load_config",
    "open_result",
    "run_study",
    "shapes",
    "simulate",
    "summarize",
]
