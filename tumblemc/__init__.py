"""tumblemc: non-point-contact simulation and Monte Carlo robustness studies of tumbling magnetic microrobots.

The model is that of Xie, Bi, Cappelleri & Chakraborty (IDETC 2019).

The public API: :func:`simulate`, :func:`summarize` and :func:`check_step` (one run and
whether its step sets its answer), :func:`load_config`,
:func:`run_study` and :func:`open_result` (studies), the shapes (``tumblemc.shapes``,
the module :mod:`tumblemc.model.shapes` as an attribute), :data:`PRESETS`, :class:`Params`
and :class:`SolverOptions`. The subpackages and modules below are attributes after
``import tumblemc``, imported on first use (``tumblemc.lab.static_tilt``,
``tumblemc.fields.Rotating``: :data:`SUBMODULES`). Layers, lowest first
(``tools/check_imports.py``): ``kernels`` (Numba) <- ``schema``, ``model``, ``testing`` <-
``io``, ``analysis`` <- ``study``, ``lab`` <- ``viz`` <- ``reports`` <- ``cli``.
"""

from __future__ import annotations

from tumblemc.io import open_result
from tumblemc.model import shapes
from tumblemc.model.outcome import summarize
from tumblemc.model.params import PRESETS, Params
from tumblemc.model.run import simulate
from tumblemc.model.shapes import SHAPES, Shape, extruded, get_shape
from tumblemc.model.solver_options import SolverOptions
from tumblemc.model.step_check import check_step
from tumblemc.version import __version__

_LAZY = {"load_config": "tumblemc.study.config", "run_study": "tumblemc.study.engine"}

#: the documented submodules, as attributes of the package: ``{attribute: module}``
SUBMODULES = {
    "analysis": "tumblemc.analysis",
    "cli": "tumblemc.cli",
    "fields": "tumblemc.model.fields",
    "io": "tumblemc.io",
    "kernels": "tumblemc.kernels",
    "lab": "tumblemc.lab",
    "model": "tumblemc.model",
    "reports": "tumblemc.reports",
    "schema": "tumblemc.schema",
    "study": "tumblemc.study",
    "testing": "tumblemc.testing",
    "viz": "tumblemc.viz",
}


def __getattr__(name: str) -> object:
    """Import the study API and the submodules on first use (as scipy does).

    ``import tumblemc`` stays light: scipy.stats, the engine, dask and matplotlib load only
    when a study runs or a figure is drawn.
    """
    import importlib

    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    if name in SUBMODULES:
        return importlib.import_module(SUBMODULES[name])
    raise AttributeError(f"module 'tumblemc' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY) | set(SUBMODULES))


__all__ = [
    "PRESETS",
    "SHAPES",
    "Params",
    "Shape",
    "SolverOptions",
    "__version__",
    "check_step",
    "extruded",
    "get_shape",
    "load_config",
    "open_result",
    "run_study",
    "shapes",
    "simulate",
    "summarize",
]
