"""What every subcommand shares: exit codes, the usage error, value parsers, tables, --set."""

from __future__ import annotations

import argparse
import math
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from tumblemc.model.params import PRESETS, Params
from tumblemc.model.shapes.library import SHAPES

EXIT_OK = 0
EXIT_RUN_FAILED = 1
EXIT_USAGE = 2

SHAPE_CHOICES = tuple(SHAPES)
PRESET_CHOICES = tuple(PRESETS)
SHAPE_HELP = f"robot shape: {', '.join(SHAPE_CHOICES)} (default: cuboid)"
PRESET_HELP = f"parameter preset: {', '.join(PRESET_CHOICES)} (default: paper)"


class UsageError(Exception):
    """Bad command-line input detected by the CLI itself (exit status 2)."""


def parse_value(text: str) -> Any:
    """Parse a ``--set`` value.

    ``true``/``false`` -> bool, a number -> float, ``a,b,c`` -> tuple of floats (e.g.
    ``offset_axis=1,0,0``); anything else stays a string (the API rejects it with a message
    naming the parameter).
    """
    low = text.strip().lower()
    if low in ("true", "yes", "on"):
        return True
    if low in ("false", "no", "off"):
        return False
    try:
        return float(text)
    except ValueError:
        pass
    if "," in text:
        try:
            return tuple(float(part) for part in text.split(","))
        except ValueError:
            pass
    return text


def parse_overrides(items: Sequence[str] | None) -> dict[str, Any]:
    """``["mu=0.4", "offset_deg=10"]`` -> ``{"mu": 0.4, "offset_deg": 10.0}``."""
    out: dict[str, Any] = {}
    for item in items or ():
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or not name or not value.strip():
            raise UsageError(f"--set {item!r} is not NAME=VALUE (allowed: e.g. --set mu=0.4)")
        if name in out:
            raise UsageError(f"--set {name} given twice (allowed: once per parameter)")
        if name not in Params.field_names():
            raise UsageError(
                f"--set {name}: unknown parameter (allowed: {', '.join(Params.field_names())}; options such as --dt have their own flags)"
            )
        out[name] = parse_value(value)
    return out


#: units of the run summary (:func:`tumblemc.summarize`) as the CLI prints it (a ratio
#: names what it is a fraction of); names not listed are counts, flags or the status code
SUMMARY_UNITS = {
    "mean_speed": "m/s",
    "ideal_speed": "m/s",
    "progress_ratio": "x ideal_speed",
    "energy_gain_ratio": "x the run's energy scale",
    "mean_newton_iterations": "per step",
    "max_penetration": "m",
    "mean_slip_speed": "m/s",
    "energy_gain_J": "J",
    "field_work_bound_J": "J",
    "lateral_drift": "m",
    "heading_change_deg": "deg",
    "duration": "s",
    "progress": "m",
}


def format_table(d: dict[str, Any], units: dict[str, str] | None = None) -> str:
    """Aligned ``name  value [unit]`` lines."""
    if not d:
        return ""
    width = max(len(k) for k in d)
    lines = []
    for k, v in d.items():
        if isinstance(v, float) and not isinstance(v, bool):
            text = f"{v:.6g}" if math.isfinite(v) else str(v)
        else:
            text = str(v)
        unit = (units or {}).get(k)
        lines.append(f"{k:<{width}}  {text}" + (f" {unit}" if unit else ""))
    return "\n".join(lines)


#: how a netCDF ``units`` attribute reads in a printed column header
_UNIT_TEXT = {"mm s-1": "mm/s", "m s-1": "m/s", "degree": "deg"}


def labelled_table(ds: Any, cols: Sequence[str]) -> str:
    """A protocol's variables ``cols`` along its one dimension as a table whose headers carry units.

    A header gets ``(unit)`` from the variable's ``units`` unless its name already ends
    with it (``tilt_deg``) or it is dimensionless; NaN prints as ``-``.
    """
    df = ds[list(cols)].to_dataframe()[list(cols)].round(3)
    names = {}
    for c in [*cols, *df.index.names]:
        unit = _UNIT_TEXT.get(str(ds[c].attrs.get("units", "1")), str(ds[c].attrs.get("units", "1")))
        names[c] = c if unit == "1" or c.endswith(("_deg", "_mT", "_hz", "_Hz", "_s")) else f"{c} ({unit})"
    df = df.rename(columns=names)
    df.index.names = [names[str(n)] for n in df.index.names]
    return str(df.to_string(na_rep="-"))


def parse_values(name: str, text: str) -> list[float]:
    """``a:b:step`` (inclusive) or a comma list of numbers."""
    try:
        if ":" in text:
            a, b, s = (float(v) for v in text.split(":"))
            if not s > 0 or b < a:
                raise ValueError
            return list(np.round(np.arange(a, b + s / 2, s), 12))
        return [float(v) for v in text.split(",")]
    except ValueError:
        raise ValueError(f"{name}={text!r} is not allowed (allowed: START:STOP:STEP or a comma list, e.g. 3:15:1 or 1,5,10)") from None


def parse_vector(name: str, text: str) -> tuple[float, float, float]:
    """Three comma-separated numbers."""
    try:
        vals = tuple(float(v) for v in text.split(","))
    except ValueError:
        vals = ()
    if len(vals) != 3:
        raise ValueError(f"{name}={text!r} is not allowed (allowed: three comma-separated numbers, e.g. 0,0,-1)")
    return (vals[0], vals[1], vals[2])


def add_robot_and_output(p: argparse.ArgumentParser, out: str) -> None:
    """Add ``--shape``, ``--preset``, ``--set``, ``--out`` (default ``out``) and ``--plot``: a bench test's or a fit's."""
    p.add_argument("--shape", default="cuboid", choices=SHAPE_CHOICES, help=SHAPE_HELP)
    p.add_argument("--preset", default="paper", choices=PRESET_CHOICES, help=PRESET_HELP)
    add_set(p)
    p.add_argument("--out", default=out, help=f"output netCDF path (default: {out})")
    p.add_argument("--plot", action="store_true", help="also write a PNG figure next to the netCDF file")


def add_set(p: argparse.ArgumentParser) -> None:
    """Add the repeatable ``--set NAME=VALUE`` parameter override to ``p``."""
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", dest="overrides", help="override a parameter (repeatable)")


def write_dataset(ds: Any, args: argparse.Namespace) -> int:
    """Write a protocol's or a calibration's Dataset to ``--out`` and, with ``--plot``, its figure next to it."""
    from tumblemc.ncformat import write_dataset as write_netcdf

    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_netcdf(ds, out)
    print(f"wrote {out}")
    if args.plot:
        from tumblemc.viz.calibrate import plot_calibration
        from tumblemc.viz.lab import plot_lab

        png = out.with_suffix(".png")
        if (plot_calibration(ds, png) if "test" in ds.attrs else plot_lab(ds, png)) is not None:
            print(f"wrote {png}")
    return 0


#: what a cold compile costs, said before it starts (measured: docs/notes/performance.md, "Compile time")
COMPILE_ESTIMATE = "1-4 minutes on 2 cores, by the machine's load; once per install"


def warm_kernels_saying(say: bool = True, tick_s: float | None = None) -> float:
    """Compile or load the kernels (:func:`tumblemc.study.cluster.warm_kernels`), saying which and the time elapsed.

    On stderr: one line that says whether the kernels are loaded from Numba's cache or
    compiled (with :data:`COMPILE_ESTIMATE`), then the elapsed seconds, updated in place
    each second on a terminal and on a new line every 10 s in a log (``tick_s`` overrides
    the interval), and the time it took. Returns the seconds taken.
    """
    from tumblemc.study.cluster import kernels_cached, warm_kernels

    if not say:
        return warm_kernels()
    cached = kernels_cached()
    what = "loading the compiled kernels from the cache" if cached else f"compiling the kernels ({COMPILE_ESTIMATE})"
    tty = sys.stderr.isatty()
    print(what + " ...", end="" if tty else "\n", file=sys.stderr, flush=True)
    done = threading.Event()
    t0 = time.perf_counter()

    def tick() -> None:
        every = tick_s or (1.0 if tty else 10.0)
        while not done.wait(every):
            s = time.perf_counter() - t0
            if tty:
                print(f"\r{what} ... {s:.0f} s", end="", file=sys.stderr, flush=True)
            else:
                print(f"  still {'loading' if cached else 'compiling'}: {s:.0f} s", file=sys.stderr, flush=True)

    ticker = threading.Thread(target=tick, daemon=True)
    ticker.start()
    try:
        took = warm_kernels()
    finally:
        done.set()
        ticker.join()
    took_s = f"{time.perf_counter() - t0:.0f} s"
    print(f"\r{what} ... ready in {took_s}" if tty else f"kernels ready in {took_s}", file=sys.stderr, flush=True)
    return took
