"""The ``[field]`` table of a study: which field program its runs use (MODEL.md, "Field programs").

::

    [field]
    kind = "rotating"          # "paper" (default): rotating about world x from uphill;
                               # "rotating": about ``axis``, from ``start`` (default uphill)
    axis = [0.0, 1.0, 0.0]     # world frame (rotating only)
    start = [0.0, 0.0, 1.0]    # optional start direction (rotating only)
    cone_deg = 0.0             # field tilted out of its rotation plane toward +axis
    bias_mT = [0.0, 0.0, 0.0]  # static world vector added

The cells' ``field_mT`` and ``freq_hz`` are the program's magnitude and frequency (a
sampled ``field_mT`` too). The axis's pointing error is uncertain like any parameter:
``axis_yaw_deg`` turns the axis about world z, ``axis_pitch_deg`` tilts it out of the
horizontal plane (about ``axis x z``), both with nominal 0, in degrees. With either one
uncertain, or any kind other than ``paper``, each run gets a :class:`Rotating` program;
otherwise the paper's field shorthand (identical records to studies before programs).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from tumblemc.model.fields import Rotating
from tumblemc.study.checks import ConfigError, check_choice, check_no_unknown, check_num, check_table

KINDS = ("paper", "rotating")
#: uncertain parameters that act on the field program, not on Params (nominal 0, degrees)
AXIS_ERRORS = ("axis_yaw_deg", "axis_pitch_deg")


@dataclass(frozen=True)
class FieldConfig:
    """A study's field program (see the module docstring)."""

    kind: str = "paper"
    axis: tuple[float, float, float] = (1.0, 0.0, 0.0)
    start: tuple[float, float, float] | None = None
    cone_deg: float = 0.0
    bias_mT: tuple[float, float, float] = (0.0, 0.0, 0.0)


def _vec(key: str, value: Any, nonzero: bool) -> tuple[float, float, float]:
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise ConfigError(key, f"{key}={value!r} is not allowed (allowed: a list of three numbers, world frame)")
    vec = tuple(check_num(f"{key}[{i}]", v) for i, v in enumerate(value))
    if nonzero and not any(vec):
        raise ConfigError(key, f"{key}={value!r} is not allowed (allowed: a nonzero direction)")
    return (vec[0], vec[1], vec[2])


def parse_field(value: Any) -> FieldConfig:
    """Parse ``[field]``; each problem names its key, the value and what is allowed."""
    t = check_table("field", value)
    check_no_unknown(t, ("kind", "axis", "start", "cone_deg", "bias_mT"), "field")
    kind = check_choice("field.kind", t.get("kind", "paper"), KINDS)
    if kind == "paper" and set(t) - {"kind"}:
        raise ConfigError("field", f"field.{sorted(set(t) - {'kind'})[0]} needs field.kind = 'rotating' (the paper's field has none)")
    cfg = FieldConfig(
        kind=kind,
        axis=_vec("field.axis", t.get("axis", [1.0, 0.0, 0.0]), True),
        start=None if t.get("start") is None else _vec("field.start", t["start"], True),
        cone_deg=check_num("field.cone_deg", t.get("cone_deg", 0.0), 0.0, 89.0),
        bias_mT=_vec("field.bias_mT", t.get("bias_mT", [0.0, 0.0, 0.0]), False),
    )
    try:  # the program's own checks (a start along the axis, ...)
        Rotating(20.0, 1.0, axis=cfg.axis, start=cfg.start, cone_deg=cfg.cone_deg, bias_mT=cfg.bias_mT)
    except ValueError as e:
        raise ConfigError("field", f"field: {e}") from None
    return cfg


def turned_axis(axis: tuple[float, float, float], yaw_deg: float, pitch_deg: float) -> tuple[float, float, float]:
    """``axis`` turned by ``yaw_deg`` about world z, then tilted by ``pitch_deg`` about ``axis x z``."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    cy, sy = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    a = np.array([cy * a[0] - sy * a[1], sy * a[0] + cy * a[1], a[2]])
    k = np.cross(a, [0.0, 0.0, 1.0])
    if np.linalg.norm(k) > 1e-12 and pitch_deg:
        k /= np.linalg.norm(k)
        p = math.radians(pitch_deg)
        a = a * math.cos(p) + np.cross(k, a) * math.sin(p) + k * (k @ a) * (1 - math.cos(p))
    return (float(a[0]), float(a[1]), float(a[2]))


def program(cfg: FieldConfig, field_mT: float, freq_hz: float, yaw_deg: float | None, pitch_deg: float | None) -> Rotating | None:
    """The run's field program, or None for the paper's shorthand (``kind = "paper"`` without axis errors)."""
    if cfg.kind == "paper" and yaw_deg is None and pitch_deg is None:
        return None
    axis = turned_axis(cfg.axis, yaw_deg or 0.0, pitch_deg or 0.0)
    return Rotating(field_mT, freq_hz, axis=axis, start=cfg.start, cone_deg=cfg.cone_deg, bias_mT=cfg.bias_mT)


__all__ = ["AXIS_ERRORS", "KINDS", "FieldConfig", "parse_field", "program", "turned_axis"]
