"""What a study may cost, checked when its config is read, before anything runs.

A config whose runs would all fail (a duration beyond the simulator's range) or that no
machine could run (billions of runs, a run of billions of steps) is refused with one line
naming the key, the value and the bound, instead of failing every run or dying of memory
later. The bounds on the total runs, a run's steps and a run's memory live in
``[execution]`` (``max_runs``, ``max_steps_per_run``, ``max_run_memory_gib``): they are
not part of the study's identity, and a user who means it raises them there.
"""

from __future__ import annotations

import math
import os
from typing import Any

from tumblemc.kernels.layout import N_REC
from tumblemc.kernels.stepper import n_records
from tumblemc.model.params import RANGES
from tumblemc.model.rows import record_stride
from tumblemc.study.checks import config_error
from tumblemc.study.stepcfg import cell_dt, searched_axis

#: defaults of the ``[execution]`` bounds: about 100x the default study's 20,800 runs (its
#: design table then takes a few hundred MB), 2,500x the steps of its runs (2 s at 5e-5 s:
#: 40,000; about 10 min per run on one core), and the simulator's own record limit
MAX_RUNS = 2_000_000
MAX_STEPS_PER_RUN = 100_000_000
MAX_RUN_MEMORY_GIB = 2.0


#: bytes of the design table per run (measured: 700 with 4 uncertain parameters, at the peak
#: of :func:`tumblemc.study.design.design`) and per sampled column; an upper estimate
DESIGN_BYTES_PER_RUN = 512
DESIGN_BYTES_PER_COLUMN = 128
_DIM_ATTRS = {"shape": "shapes", "substrate": "presets"}


def count_cells(cfg: Any) -> int:
    """The number of cells of a study, counted from its axes (the product of their lengths), not built."""
    return math.prod(len(getattr(cfg, _DIM_ATTRS.get(d, d))) for d in cfg.cell_dims)


def design_bytes(cfg: Any) -> int:
    """An upper estimate of the memory of the study's design table, bytes (before anything is allocated)."""
    cols = len(cfg.uncertain) + (len(cfg.posterior.params) if cfg.posterior is not None else 0)
    return int(cfg.n_runs) * (DESIGN_BYTES_PER_RUN + DESIGN_BYTES_PER_COLUMN * cols)


def usable_memory() -> int:
    """Half the machine's physical memory, bytes (64 GiB where the system does not say)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") // 2
    except (ValueError, OSError, AttributeError):
        return 64 * 2**30


def check_budget(cfg: Any) -> None:
    """Raise :class:`~tumblemc.study.checks.ConfigError` if ``cfg`` exceeds a bound (module docstring)."""
    ex = cfg.execution
    dur_hi = RANGES["duration_s"].hi
    for f in cfg.freq_hz:
        dur = cfg.periods / f
        if dur > dur_hi:
            raise config_error(
                "periods",
                cfg.periods,
                f"gives runs of {dur:g} s at freq_hz = {f:g}, beyond the simulator's {dur_hi:g} s",
                f"periods <= {dur_hi * min(cfg.freq_hz):g} (= {dur_hi:g} s x the lowest freq_hz)",
            )
    n = cfg.n_runs  # counted, not built: a grid of 10^12 cells costs nothing here
    if n > ex.max_runs:
        raise config_error(
            "samples",
            cfg.samples,
            f"gives {n:,} runs ({n // cfg.samples:,} cells x {cfg.samples:,} samples)",
            f"at most {ex.max_runs:,} runs in all; fewer samples or cells, or raise [execution] max_runs",
        )
    need, have = design_bytes(cfg), usable_memory()
    if need > have:
        raise config_error(
            "samples",
            cfg.samples,
            f"gives {n:,} runs whose design table alone needs about {need / 2**30:.3g} GiB",
            f"at most {have / 2**30:.3g} GiB, half this machine's memory; fewer samples or cells, or split the study",
        )
    key = "dt" if cfg.dt is not None else "periods"
    searched = searched_axis(cfg) == "freq_hz"  # one step per robot: the fastest frequency's (stepcfg.row_dt)
    for f in cfg.freq_hz:  # the finest cell step at each frequency (the strongest field)
        dt = min(cell_dt(cfg, shape, sub, None, None if searched else f) for shape in cfg.shapes for sub in cfg.presets)
        for fine in (False, True):
            h = dt / cfg.check.dt_factor if fine else dt
            steps = round(cfg.periods / f / h)
            what = f"at freq_hz = {f:g}" + (f" and the check's dt / {cfg.check.dt_factor}" if fine else "")
            if steps > ex.max_steps_per_run:
                raise config_error(
                    key,
                    cfg.dt if cfg.dt is not None else cfg.periods,
                    f"gives runs of {steps:,} steps {what}",
                    f"at most {ex.max_steps_per_run:,} steps per run; a larger dt or fewer periods, or raise [execution] max_steps_per_run",
                )
            i0 = round(cfg.transient_periods / f / h)
            gib = n_records(steps, record_stride(steps, i0)[0]) * N_REC * 8 / 2**30
            if gib > ex.max_run_memory_gib:
                raise config_error(
                    "transient_periods",
                    cfg.transient_periods,
                    f"makes each run record {gib:.3g} GiB {what} (transient and total periods share no step grid)",
                    f"at most {ex.max_run_memory_gib:g} GiB per run; whole-number periods, or raise [execution] max_run_memory_gib",
                )


__all__ = ["MAX_RUNS", "MAX_RUN_MEMORY_GIB", "MAX_STEPS_PER_RUN", "check_budget", "count_cells", "design_bytes", "usable_memory"]
