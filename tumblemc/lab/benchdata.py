"""Bench data files: the CSV format of :func:`tumblemc.lab.calibrate.calibrate`, read and checked.

A file is CSV with a header naming the test (:data:`KINDS`) and one row per setting:
``field_mT,tilt_deg`` (static tilt), ``freq_hz,speed_mm_s`` (speed against frequency) or
``incline_deg,climbed`` (read, not fitted yet). Lines starting with ``#`` are comments.

Everything is checked before a fit costs anything, and each problem is one ``ValueError``
line naming the file, the line and the value: the file's kind and size (a regular file of
at most :data:`MAX_BENCH_BYTES`), its encoding (UTF-8), the row count (at most
:data:`MAX_BENCH_ROWS`), each value's physical range (:data:`COLUMN_RANGES`, with the
reason), and repeated settings (one row per setting: two rows of one field are either a
copy or replicates, which go in as their mean).
"""

from __future__ import annotations

import csv
import io
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tumblemc.model.params import RANGES
from tumblemc.study.checks import read_limited

#: header -> (test, x column, y column, y units)
KINDS: dict[tuple[str, str], tuple[str, str, str, str]] = {
    ("field_mT", "tilt_deg"): ("static_tilt", "field_mT", "tilt_deg", "degree"),
    ("freq_hz", "speed_mm_s"): ("speed", "freq_hz", "speed_mm_s", "mm s-1"),
    ("incline_deg", "climbed"): ("critical_incline", "incline_deg", "climbed", "1"),
}
#: the most data rows a file may have: a bench test has tens of settings; the closed-form
#: fit of 2,000 rows takes about 10 s, and every row of a simulator fit is a run per evaluation
MAX_BENCH_ROWS = 2000
#: the largest file read (2,000 rows are about 40 kB; comments may add some)
MAX_BENCH_BYTES = 4 * 2**20

_FIELD, _FREQ = RANGES["field_mT"], RANGES["freq_hz"]
#: column -> (lo, hi, lo excluded, unit, why): the values a bench test can give
COLUMN_RANGES: dict[str, tuple[float, float, bool, str, str]] = {
    "field_mT": (0.0, _FIELD.plausible_hi, False, "mT", f"a field magnitude; its direction is --direction; {_FIELD.why}"),
    "tilt_deg": (
        *(-10.0, 180.0, False, "degree"),
        "the angle between the robot's bottom face and the substrate; a reading below 0 is a flat robot's measurement noise, "
        "more than 10 deg of it is not noise",
    ),
    "freq_hz": (0.0, _FREQ.hi, True, "Hz", "the field's rotation rate, as the simulator takes it"),
    "speed_mm_s": (-1e4, 1e4, False, "mm/s", "10 m/s; a 0.1 mm robot tumbling at 10 kHz makes about 4 m/s"),
    "incline_deg": (RANGES["incline_deg"].lo, RANGES["incline_deg"].hi, False, "degree", "the simulator's incline range"),
    "climbed": (0.0, 1.0, False, "", "0 (did not climb) or 1 (climbed)"),
}


@dataclass(frozen=True)
class BenchData:
    """One bench test's data: ``test`` (static_tilt or speed), ``x`` and ``y`` columns."""

    test: str
    x_name: str
    y_name: str
    y_units: str
    x: np.ndarray
    y: np.ndarray
    source: str


def _text(path: str | os.PathLike[str]) -> str:
    raw = read_limited(Path(path), MAX_BENCH_BYTES, "a bench CSV such as field_mT,tilt_deg with a row per setting")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as e:
        line = raw.count(b"\n", 0, e.start) + 1
        raise ValueError(f"{path}, line {line}: not UTF-8 text (byte 0x{raw[e.start]:02x}; save the file as UTF-8)") from None


def _check_value(path: object, i: int, name: str, v: float) -> None:
    lo, hi, lo_open, unit, why = COLUMN_RANGES[name]
    if not ((v > lo if lo_open else v >= lo) and v <= hi) or (name == "climbed" and v not in (0.0, 1.0)):
        rng = f"{'(' if lo_open else '['}{lo:g}, {hi:g}]" + (f" {unit}" if unit else "")
        raise ValueError(f"{path}, line {i}: {name}={v:g} is out of range (allowed: {rng}; {why})")


def read_bench(path: str | os.PathLike[str]) -> BenchData:  # noqa: C901
    """Read a bench CSV; raise ValueError naming the file, the line and the problem (module docstring)."""
    rows = [
        (i, r) for i, r in enumerate(csv.reader(io.StringIO(_text(path), newline="")), start=1) if r and not r[0].lstrip().startswith("#")
    ]
    if not rows:
        raise ValueError(f"{path}: empty (allowed: a header such as field_mT,tilt_deg and data rows)")
    header = tuple(c.strip() for c in rows[0][1])
    if header not in KINDS:
        allowed = "; ".join(",".join(k) for k in KINDS)
        raise ValueError(f"{path}, line {rows[0][0]}: header {','.join(header)!r} is not a bench test (allowed: {allowed})")
    test, xn, yn, yu = KINDS[header]
    if len(rows) - 1 > MAX_BENCH_ROWS:
        raise ValueError(f"{path}: {len(rows) - 1:,} data rows (allowed: at most {MAX_BENCH_ROWS:,}, one per setting; average repeats)")
    vals: list[tuple[float, float]] = []
    first: dict[float, tuple[int, float]] = {}
    for i, r in rows[1:]:
        try:
            x, y = (float(v) for v in r)
        except ValueError:
            raise ValueError(f"{path}, line {i}: {','.join(r)!r} is not two numbers") from None
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError(f"{path}, line {i}: {','.join(r)!r} is not finite")
        _check_value(path, i, xn, x)
        _check_value(path, i, yn, y)
        if x in first:
            j, y0 = first[x]
            same = "repeats" if y0 == y else f"gives another {yn} ({y:g}, not {y0:g}) for"
            raise ValueError(
                f"{path}, line {i}: {same} {xn}={x:g} of line {j} (allowed: one row per {xn}; a copied row weighs double "
                "in the fit, and repeated measurements go in as their mean)"
            )
        first[x] = (i, y)
        vals.append((x, y))
    if len(vals) < 2:
        raise ValueError(f"{path}: {len(vals)} data row(s) (allowed: at least 2)")
    arr = np.asarray(vals)  # distinct settings, each >= 0: a static tilt has a field > 0
    return BenchData(test, xn, yn, yu, arr[:, 0], arr[:, 1], os.fspath(path))


def write_bench(path: str | os.PathLike[str], x_name: str, y_name: str, x: Sequence[float], y: Sequence[float]) -> None:
    """Write bench data in the format :func:`read_bench` reads."""
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow([x_name, y_name])
        for a, b in zip(x, y, strict=True):
            w.writerow([f"{a:.10g}", f"{b:.10g}"])


__all__ = ["COLUMN_RANGES", "KINDS", "MAX_BENCH_BYTES", "MAX_BENCH_ROWS", "BenchData", "read_bench", "write_bench"]
