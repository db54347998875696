"""Per-step cost of the time-stepper: ``python benchmarks/step_cost.py [--quick]`` (a benchmark, never a test).

Prints, for every shape (``--shapes`` to choose) on the 45 deg paper incline and on flat
paper at 1 and 10 Hz:
median wall time per step over several runs (after compilation), Newton iterations per
step, wall time per simulated second at the default dt, and the compile time of the
kernels in a fresh process with an empty (cold) and with a warm (cached) Numba cache.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from typing import Any

from tumblemc.kernels import layout as L
from tumblemc.model.run import DEFAULT_DT, prepare, run_inputs, run_spec
from tumblemc.model.shapes.library import SHAPES

SCENARIOS = (
    ("paper 45 deg, 1 Hz", dict(preset="paper", incline_deg=45.0, freq_hz=1.0)),
    ("flat paper, 1 Hz", dict(preset="paper", incline_deg=0.0, freq_hz=1.0)),
    ("flat paper, 10 Hz", dict(preset="paper", incline_deg=0.0, freq_hz=10.0)),
)


_COMPILE_SNIPPET = "import time; t=time.perf_counter(); import tumblemc; tumblemc.simulate(duration_s=0.002); print(time.perf_counter()-t)"


def compile_time(cache_dir: str) -> float:
    """Seconds for import + first simulate in a fresh interpreter using ``cache_dir``."""
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir)
    out = subprocess.run([sys.executable, "-c", _COMPILE_SNIPPET], env=env, capture_output=True, text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


def measure(kw: dict[str, Any], duration_s: float, repeats: int, dt: float | None = None) -> dict[str, float]:
    """Time the stepper on one scenario (compiled beforehand, outside the timing).

    Parameters
    ----------
    kw : dict
        Keyword arguments of :func:`tumblemc.simulate` that set the scenario (shape,
        preset, incline_deg, freq_hz, ...).
    duration_s : float
        Simulated seconds per run.
    repeats : int
        Runs; the median wall time is reported.
    dt : float, optional
        Time step, s (default: the model's default).

    Returns
    -------
    dict
        ``steps``, ``us_per_step`` (median wall µs per step), ``newton_per_step`` (mean
        solver iterations per step: Newton and chord, ``SolverOptions.chord_iter``), ``ms_per_sim_s`` (wall ms per simulated second) and
        ``spread_pct`` ((max - min) / median of the wall times, %).
    """
    spec = prepare(run_inputs(duration_s=duration_s, dt=dt, **kw))
    run_spec(prepare(run_inputs(duration_s=0.002, dt=dt, **kw)))  # compile outside the timing
    walls = []
    nit = 0.0
    for _ in range(repeats):
        t0 = time.perf_counter()
        rec, _, _ = run_spec(spec)
        walls.append(time.perf_counter() - t0)
        nit = float(rec[1:, L.R_NIT].sum()) / spec.n_steps
    med = statistics.median(walls)
    return {
        "steps": spec.n_steps,
        "us_per_step": 1e6 * med / spec.n_steps,
        "newton_per_step": nit,
        "ms_per_sim_s": 1e3 * med / duration_s,
        "spread_pct": 100 * (max(walls) - min(walls)) / med,
    }


def main(argv: Sequence[str] | None = None) -> int:
    """Run the benchmark from command-line arguments (``--help``); returns 0."""
    ap = argparse.ArgumentParser(prog="python benchmarks/step_cost.py", description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5, help="runs per scenario; the median is reported (default 5)")
    ap.add_argument("--duration-s", type=float, default=2.0, help="simulated seconds per run (default 2)")
    ap.add_argument("--quick", action="store_true", help="0.2 s runs, 3 repeats, no compile timing")
    ap.add_argument("--no-compile", action="store_true", help="skip the cold/cached compile timing")
    ap.add_argument("--shapes", default=",".join(SHAPES), help=f"comma-separated shapes (default: {','.join(SHAPES)})")
    a = ap.parse_args(argv)
    shapes = [s.strip() for s in a.shapes.split(",") if s.strip()]
    for s in shapes:
        if s not in SHAPES:
            ap.error(f"--shapes: {s!r} is unknown (allowed: {', '.join(SHAPES)})")
    dur = 0.2 if a.quick else a.duration_s
    reps = 3 if a.quick else a.repeats
    print(f"step_cost: dt = {DEFAULT_DT} s (default), {reps} runs of {dur} s each, median; one core")
    print(f"{'shape':12s} {'scenario':22s} {'steps':>7s} {'us/step':>8s} {'iters/step':>11s} {'ms per sim s':>12s} {'spread %':>8s}")
    for shape in shapes:
        for name, kw in SCENARIOS:
            r = measure(dict(kw, shape=shape), dur, reps)
            cost = f"{r['us_per_step']:8.2f} {r['newton_per_step']:11.2f} {r['ms_per_sim_s']:12.1f} {r['spread_pct']:8.1f}"
            print(f"{shape:12s} {name:22s} {int(r['steps']):7d} {cost}")
    if not (a.quick or a.no_compile):
        with tempfile.TemporaryDirectory() as d:
            cold = compile_time(d)
            warm = statistics.median(compile_time(d) for _ in range(3))
        print(f"compile + first run in a fresh process: cold cache {cold:.1f} s, cached {warm:.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
