"""The time step of a study's cells: its config's ``dt``, or the simulator's default per cell."""

from __future__ import annotations

import functools
from collections.abc import Mapping
from typing import Any

import numpy as np

from tumblemc.model.params import get_preset
from tumblemc.model.shapes.library import get_shape
from tumblemc.model.step_size import default_step


def cell_dt(cfg: Any, shape: str, substrate: str, field_mT: float | None = None, freq_hz: float | None = None) -> float:
    """The time step of one cell of a study (a ``StudyConfig``; this module sits below the config's), s.

    ``dt`` of the config, or the simulator's default step (:mod:`tumblemc.model.step_size`)
    of the cell: its shape, the substrate preset's nominal magnet and mass, its nominal
    field (plus the field's bias) and its frequency. ``field_mT`` or ``freq_hz`` None: the
    study's most demanding value of that axis (a threshold study searching it, or a cell
    without it; for the field, the finer step of its strongest and its weakest value), so
    that one robot's runs along a searched axis share one step. The
    sampled parameters (magnetisation, mass) do not enter: every run of a cell shares the
    cell's step, and the check re-simulates it at ``dt / dt_factor``.
    """
    if cfg.dt is not None:
        return float(cfg.dt)
    bias = float(np.linalg.norm(cfg.field.bias_mT))
    # a searched field: its strongest value (the magnet turns fastest) and its weakest (a fast
    # field is nearest the magnet's natural frequency) are the candidates
    fields = {max(cfg.field_mT), min(cfg.field_mT)} if field_mT is None else {float(field_mT)}
    hz = tuple(cfg.freq_hz) if freq_hz is None else (float(freq_hz),)
    return min(_default_step(shape, substrate, mT + bias, hz) for mT in fields)


@functools.lru_cache(maxsize=4096)
def _default_step(shape: str, substrate: str, field_mT: float, freqs: tuple[float, ...]) -> float:
    """:func:`default_step` of a shape with a preset's nominal magnet (memoised: a study asks it per row)."""
    p = get_preset(substrate)
    return float(default_step(get_shape(shape).inertia(p.mass), p.V_m * p.magnetization, field_mT, list(freqs)).dt)


def searched_axis(cfg: Any) -> str | None:
    """The axis a threshold study searches (its runs share the axis's most demanding step), else None."""
    return str(cfg.threshold_axis) if cfg.mode == "threshold" else None


def row_dt(cfg: Any, row: Mapping[str, Any] | Any) -> float:
    """:func:`cell_dt` of a run-table row (``shape``, ``substrate``, nominal ``field_mT``, ``freq_hz``).

    A threshold study's searched axis, and a dimension the row does not hold, count at the
    study's most demanding value.
    """
    searched = searched_axis(cfg)
    vals = {k: (None if k == searched or k not in row else float(np.asarray(row[k]).item())) for k in ("field_mT", "freq_hz")}
    return cell_dt(cfg, str(np.asarray(row["shape"]).item()), str(np.asarray(row["substrate"]).item()), **vals)


def study_dt(cfg: Any) -> float:
    """The smallest time step of a study's cells, s (``dt`` of the config when given).

    The step of the most demanding cell (:func:`cell_dt` over every shape and substrate at
    the strongest field and the fastest frequency): the per-run budget's bound and the
    step the file attributes quote; each cell runs at its own :func:`cell_dt`.
    """
    if cfg.dt is not None:
        return float(cfg.dt)
    return min(cell_dt(cfg, shape, sub) for shape in cfg.shapes for sub in cfg.presets)


def step_attrs(cfg: Any) -> dict[str, Any]:
    """The file attributes of a study's step: ``dt`` (:func:`study_dt`), and ``dt_rule`` where the cells' steps differ."""
    from tumblemc.study.config import cells

    attrs: dict[str, Any] = {"dt": study_dt(cfg)}
    if cfg.dt is None and len({row_dt(cfg, c) for c in cells(cfg)}) > 1:
        attrs["dt_rule"] = "each cell at its own default step (the runs' dt); dt is the smallest"
    return attrs


__all__ = ["cell_dt", "row_dt", "searched_axis", "step_attrs", "study_dt"]
