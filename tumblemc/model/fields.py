"""Field programs: the applied field ``B(t)`` as a sequence of segments (MODEL.md, "Field programs").

Three building blocks, directions in the world frame (z up, the plane inclined about x)::

    Static(mT, direction)                      a constant field |B| d
    Rotating(mT, hz, axis=(1, 0, 0), start=None, cone_deg=0, bias_mT=(0, 0, 0))
                                               |B| (cos psi s + sin psi (a x s)) + bias,
                                               psi = 2 pi f (t - t0)
    Sequence((duration_s, field), ...)         segments one after the other

``Rotating(mT, hz)`` with the default axis and ``start=None`` (the uphill direction of the
plane) is the paper's field; ``simulate(field_mT=..., freq_hz=...)`` is its shorthand and
runs the kernel's own code for it. ``cone_deg`` tilts the field out of the rotation plane
toward ``+axis`` (the magnitude stays ``mT``); ``bias_mT`` adds a static world vector.
In a :class:`Sequence`, a rotating segment with ``start=None`` starts where the previous
segment's field ended (projected onto its rotation plane), so the field turns without a
jump; the last segment lasts until the run ends.

A program compiles to a float array, one row of :data:`N_SEG` numbers per segment (SI):
start time, frequency, rotating amplitude, start direction ``s``, ``a x s`` and the static
part, which the kernels read (:func:`tumblemc.kernels.field.program_field`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from tumblemc.kernels import layout as L
from tumblemc.model.frames import plane_frame
from tumblemc.model.params import RANGES, check_number

#: columns of a compiled program (SI: s, Hz, T), one row per segment
SEG_T0, SEG_FREQ, SEG_PSI0, SEG_AMP, SEG_S, SEG_W, SEG_BIAS = L.FS_T0, L.FS_FREQ, L.FS_PSI0, L.FS_AMP, L.FS_S, L.FS_W, L.FS_BIAS
N_SEG = L.FSEG


def _unit(name: str, vec: Any) -> np.ndarray:
    try:
        arr = np.asarray(vec, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        arr = np.full(1, np.nan)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)) or not np.linalg.norm(arr) > 0:
        raise ValueError(f"{name}={vec!r} is not allowed (allowed: a finite nonzero 3-vector, world frame)")
    return arr / np.linalg.norm(arr)


def _mT(name: str, value: Any) -> float:
    return RANGES["field_mT"].check(name, value)


@dataclass(frozen=True)
class Static:
    """A constant field of ``mT`` along the unit world ``direction``."""

    mT: float
    direction: tuple[float, float, float] = (0.0, 0.0, -1.0)

    def __post_init__(self) -> None:
        object.__setattr__(self, "mT", _mT("Static.mT", self.mT))
        object.__setattr__(self, "direction", tuple(float(v) for v in _unit("Static.direction", self.direction)))


@dataclass(frozen=True)
class Rotating:
    """A field of ``mT`` rotating at ``hz`` about the world ``axis`` (right hand).

    ``start``: the field's direction at the segment's start (projected onto the plane
    normal to ``axis``); ``None`` takes the plane's uphill direction (the paper's field),
    or in a :class:`Sequence` the previous segment's final direction. ``cone_deg``: angle
    between the field and its rotation plane, toward ``+axis`` (0 to < 90). ``bias_mT``:
    a static world vector added.
    """

    mT: float
    hz: float
    axis: tuple[float, float, float] = (1.0, 0.0, 0.0)
    start: tuple[float, float, float] | None = None
    cone_deg: float = 0.0
    bias_mT: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        object.__setattr__(self, "mT", _mT("Rotating.mT", self.mT))
        object.__setattr__(self, "hz", RANGES["freq_hz"].check("Rotating.hz", self.hz))
        object.__setattr__(self, "axis", tuple(float(v) for v in _unit("Rotating.axis", self.axis)))
        if self.start is not None:
            s = _unit("Rotating.start", self.start)
            if np.linalg.norm(s - (s @ np.asarray(self.axis)) * np.asarray(self.axis)) < 1e-6:
                raise ValueError(f"Rotating.start={self.start!r} is parallel to axis={self.axis!r} (allowed: a direction off the axis)")
            object.__setattr__(self, "start", tuple(float(v) for v in s))
        object.__setattr__(self, "cone_deg", check_number("Rotating.cone_deg", self.cone_deg, "deg", 0.0, 89.999))
        try:
            bias = np.asarray(self.bias_mT, dtype=float).reshape(3)
        except (TypeError, ValueError):
            bias = np.full(3, np.nan)
        if not np.all(np.isfinite(bias)) or np.linalg.norm(bias) > 10_000.0:
            raise ValueError(f"Rotating.bias_mT={self.bias_mT!r} is not allowed (allowed: a finite 3-vector, |bias| <= 10000 mT)")
        object.__setattr__(self, "bias_mT", tuple(float(v) for v in bias))


Segment = Static | Rotating


@dataclass(frozen=True)
class Sequence:
    """Segments ``(duration_s, field)`` one after the other; the last one lasts until the run ends."""

    segments: tuple[tuple[float, Segment], ...]

    def __init__(self, *segments: tuple[float, Segment] | Iterable[tuple[float, Segment]]) -> None:
        if len(segments) == 1 and not isinstance(segments[0], tuple):
            segments = tuple(segments[0])  # Sequence([(1, a), (1, b)])
        if not segments:
            raise ValueError("Sequence() has no segments (allowed: one or more (duration_s, field) pairs)")
        out = []
        for i, item in enumerate(segments):
            if not (isinstance(item, tuple) and len(item) == 2 and isinstance(item[1], (Static, Rotating))):
                raise ValueError(f"Sequence segment {i} = {item!r} is not allowed (allowed: (duration_s, Static or Rotating))")
            dur = check_number(f"Sequence segment {i} duration_s", item[0], "s", 0.0, 1e4)
            if not dur > 0:
                raise ValueError(f"Sequence segment {i} duration_s={item[0]!r} is out of range (allowed: > 0 s)")
            out.append((dur, item[1]))
        object.__setattr__(self, "segments", tuple(out))

    @property
    def duration_s(self) -> float:
        """Total duration of the segments (the last one continues past it)."""
        return float(sum(d for d, _ in self.segments))


Field = Static | Rotating | Sequence


def _perp(vec: np.ndarray, axis: np.ndarray) -> np.ndarray | None:
    p = vec - (vec @ axis) * axis
    n = float(np.linalg.norm(p))
    return p / n if n > 1e-6 else None


def compile_program(field: Field, incline_deg: float) -> np.ndarray:
    """The program's segment table (SI), float64[n_segments, N_SEG]."""
    items = field.segments if isinstance(field, Sequence) else ((math.inf, field),)
    uphill = plane_frame(incline_deg)["u"]
    rows = np.zeros((len(items), N_SEG))
    t0 = 0.0
    prev_dir: np.ndarray | None = None
    for k, (dur, seg) in enumerate(items):
        row = rows[k]
        row[SEG_T0] = t0
        if isinstance(seg, Static):
            row[SEG_BIAS : SEG_BIAS + 3] = seg.mT * 1e-3 * np.asarray(seg.direction)
            end_dir = np.asarray(seg.direction)
        else:
            a = np.asarray(seg.axis)
            if seg.start is not None:
                s = _perp(np.asarray(seg.start), a)
            else:
                cands = ([prev_dir] if prev_dir is not None else []) + [uphill, np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0])]
                s = next(p for p in (_perp(c, a) for c in cands) if p is not None)
            assert s is not None
            w = np.cross(a, s)
            cone = math.radians(seg.cone_deg)
            row[SEG_FREQ] = seg.hz
            row[SEG_AMP] = seg.mT * 1e-3 * math.cos(cone)
            row[SEG_S : SEG_S + 3] = s
            row[SEG_W : SEG_W + 3] = w
            row[SEG_BIAS : SEG_BIAS + 3] = seg.mT * 1e-3 * math.sin(cone) * a + np.asarray(seg.bias_mT) * 1e-3
            if math.isfinite(dur):
                psi = 2.0 * math.pi * seg.hz * dur
                end_dir = math.cos(psi) * s + math.sin(psi) * w
            else:
                end_dir = s
        prev_dir = end_dir
        t0 += dur
    return rows


def field_at(program: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The field (T, world frame) of a compiled ``program`` at times ``t`` (s), float64[len(t), 3].

    The NumPy twin of the kernel's :func:`tumblemc.kernels.field.program_field`.
    """
    t = np.asarray(t, dtype=float)
    k = np.searchsorted(program[:, SEG_T0], t, side="right") - 1
    k = np.clip(k, 0, len(program) - 1)
    seg = program[k]
    psi = 2.0 * np.pi * seg[:, SEG_FREQ] * (t - seg[:, SEG_T0]) + seg[:, SEG_PSI0]
    amp = seg[:, SEG_AMP, None]
    return (
        amp * (np.cos(psi)[:, None] * seg[:, SEG_S : SEG_S + 3] + np.sin(psi)[:, None] * seg[:, SEG_W : SEG_W + 3])
        + seg[:, SEG_BIAS : SEG_BIAS + 3]
    )


def _overlaps(program: np.ndarray, duration_s: float) -> np.ndarray:
    t0 = program[:, SEG_T0]
    t1 = np.append(t0[1:], math.inf)
    return np.clip(np.minimum(t1, duration_s) - t0, 0.0, None)


def revolutions(program: np.ndarray, duration_s: float) -> float:
    """Field revolutions in ``[0, duration_s]``: the nominal gait's number of tumbles."""
    return float(np.sum(program[:, SEG_FREQ] * _overlaps(program, duration_s)))


def segment_mT(program: np.ndarray) -> np.ndarray:
    """Each segment's largest field magnitude (its amplitude plus its bias), mT."""
    return (program[:, SEG_AMP] + np.linalg.norm(program[:, SEG_BIAS : SEG_BIAS + 3], axis=1)) * 1e3


def peak_mT(program: np.ndarray) -> float:
    """The largest field magnitude of any segment, mT."""
    return float(np.max(segment_mT(program)))


def scale_program(program: np.ndarray, time_unit: float, torque_per_tesla: float) -> np.ndarray:
    """The kernel's copy: times in time units, frequencies per time unit, fields as torque magnitudes."""
    out = program.copy()
    out[:, SEG_T0] /= time_unit
    out[:, SEG_FREQ] *= time_unit
    out[:, SEG_AMP] *= torque_per_tesla
    out[:, SEG_BIAS : SEG_BIAS + 3] *= torque_per_tesla
    return out


def describe(field: Field) -> str:
    """One line naming the program (for attributes and plots)."""
    if isinstance(field, Sequence):
        return "; ".join(f"{d:g} s: {describe(f)}" for d, f in field.segments)
    if isinstance(field, Static):
        return f"static {field.mT:g} mT along ({', '.join(f'{v:.4g}' for v in field.direction)})"
    text = f"rotating {field.mT:g} mT at {field.hz:g} Hz about ({', '.join(f'{v:.4g}' for v in field.axis)})"
    if field.cone_deg:
        text += f", cone {field.cone_deg:g} deg"
    if any(field.bias_mT):
        text += f", bias ({', '.join(f'{v:.4g}' for v in field.bias_mT)}) mT"
    return text


__all__ = [
    "N_SEG",
    "Field",
    "Rotating",
    "Sequence",
    "Static",
    "compile_program",
    "describe",
    "field_at",
    "peak_mT",
    "revolutions",
    "scale_program",
    "segment_mT",
]
