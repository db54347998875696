"""The time step of a study: its config's ``dt``, or the simulator's default for its cells."""

from __future__ import annotations

from typing import Any

import numpy as np

from tumblemc.model.params import get_preset
from tumblemc.model.run import DEFAULT_DT
from tumblemc.model.shapes.library import get_shape
from tumblemc.model.step_size import default_step


def study_dt(cfg: Any) -> float:
    """The time step of a study (a ``StudyConfig``; this module sits below the config's), s.

    ``dt`` of the config, or the simulator's default step (:mod:`tumblemc.model.step_size`)
    of its most demanding cell (the fastest field, the strongest field with its bias, the
    preset magnet with the fastest natural frequency), so that every cell of the study
    shares one time grid.
    """
    if cfg.dt is not None:
        return float(cfg.dt)
    bias = float(np.linalg.norm(cfg.field.bias_mT))
    steps = [
        default_step(get_shape(shape).inertia(p.mass), p.V_m * p.magnetization, max(cfg.field_mT) + bias, cfg.freq_hz).dt
        for shape in cfg.shapes
        for p in (get_preset(name) for name in cfg.presets)
    ]
    return float(min(steps, default=DEFAULT_DT))


__all__ = ["study_dt"]
