"""A study's modes and the threshold mode's keys (split from :mod:`tumblemc.study.config`).

- ``grid``: every run is one cell of the full grid (shape x substrate x incline x field x
  frequency) and one sample.
- ``threshold``: every run is one parameter sample; the engine searches the grid of
  ``threshold_axis`` for the sample's threshold (:mod:`tumblemc.study.threshold`), and
  the maps at every grid value follow from the thresholds. ``threshold_axis``:
  ``"incline_deg"`` (default: the steepest grid incline climbed), ``"field_mT"`` (the
  weakest grid field that climbs) or ``"freq_hz"`` (the fastest grid frequency still
  climbed); that axis's list is the grid searched (at least 2 values; sorted).
  ``threshold_start``: ``"pilot"`` (default: the search starts at the cell's median
  threshold among its check samples, which are swept over the whole grid first) or
  ``"bisect"`` (plain bisection from the middle of the grid).
- ``critical_incline``: one sample per run, bisected on a continuous incline range
  (``incline_range``) to ``incline_tol``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from tumblemc.study.checks import ConfigError, check_choice, config_error

MODES = ("grid", "threshold", "critical_incline")


#: axes a threshold study may search, with the direction of success along each: -1 where
#: success falls as the value rises (the robot climbs gentle inclines, follows slow
#: fields), +1 where it rises (a stronger field); the other axes (shape, substrate) have no order
THRESHOLD_AXES: dict[str, int] = {"incline_deg": -1, "field_mT": 1, "freq_hz": -1}


#: where a threshold search starts: "pilot" (each cell's median threshold among its
#: check samples, swept first) or "bisect" (the middle of the grid)
THRESHOLD_STARTS = ("pilot", "bisect")


#: the cell coordinates of a full grid, in run-table order
GRID_DIMS = ("shape", "substrate", "incline_deg", "field_mT", "freq_hz")


#: what the three ordered axes are called in the config (their lists are the grids)
_AXIS_INDEX = {"incline_deg": 0, "field_mT": 1, "freq_hz": 2}


def parse_threshold(
    d: Mapping[str, Any], mode: str, grids: tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]
) -> tuple[str, str, tuple[tuple[float, ...], ...]]:
    """``threshold_axis`` and ``threshold_start`` of a config, and the axis lists (the searched one sorted).

    Other modes take neither key (the caller refuses unknown keys): the defaults are returned.
    """
    if mode != "threshold":
        return "incline_deg", "pilot", grids
    axis = d.get("threshold_axis", "incline_deg")
    if axis in ("shape", "shapes", "substrate", "presets", "preset"):
        raise config_error("threshold_axis", axis, "has no order to search", f"an ordered numeric axis: {', '.join(THRESHOLD_AXES)}")
    axis = check_choice("threshold_axis", axis, tuple(THRESHOLD_AXES))
    start = check_choice("threshold_start", d.get("threshold_start", "pilot"), THRESHOLD_STARTS)
    k = _AXIS_INDEX[axis]
    grid = grids[k]
    if len(set(grid)) < 2:
        raise config_error(axis, list(grid), "is not a grid to search", "at least 2 distinct values: the threshold is searched on them")
    out = list(grids)
    out[k] = tuple(sorted(grid))
    return axis, start, tuple(out)


def check_threshold_uncertain(mode: str, axis: str, uncertain: Any) -> None:
    """Refuse an uncertain ``field_mT`` in a study that searches the field."""
    if mode == "threshold" and axis == "field_mT" and any(u.param == "field_mT" for u in uncertain):
        raise ConfigError(
            "uncertain.field_mT",
            "uncertain.field_mT cannot vary the field that threshold_axis = 'field_mT' searches "
            "(allowed: leave it out, or search another axis)",
        )
