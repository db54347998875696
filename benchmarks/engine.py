"""Benchmark of the Monte Carlo engine (a benchmark, never a test).

Measures, on one fixed study (cuboid, aluminum, 0/15/30 deg, 1 Hz, 2 periods):

- the bare batch kernel (``tumblemc.model.rows.simulate_rows`` over the design, in-process);
- the engine in-process (``run_study(client=None)``): its overhead per run over the bare
  kernel (sampling, planning, shards, assembly, netCDF);
- the engine on an embedded LocalCluster with 1 and 2 worker processes: runs per second
  (cluster start-up excluded) and the parallel efficiency ``rate_2 / (2 rate_1)``;
- the default study (``studies/default.toml``): one run of every cell through the bare
  kernel, extrapolated to the whole study on 2 workers at the measured efficiency
  (an estimate; ``tumblemc study run studies/default.toml`` gives the real figure).

Usage::

    python benchmarks/engine.py [--repeats 3] [--samples 8] [--skip-default]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

# benchmark the checkout this script sits in, even where another copy is installed
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tumblemc.model.rows import simulate_rows
from tumblemc.study.config import load_config
from tumblemc.study.design import design, grid_of
from tumblemc.study.engine import design_rows, local_client, run_study, warm_kernels

ROOT = Path(__file__).resolve().parents[1]


def study(samples: int) -> dict:
    return {
        "name": "bench",
        "shapes": ["cuboid"],
        "presets": ["aluminum"],
        "incline_deg": [0, 15, 30],
        "field_mT": 20,
        "freq_hz": 1,
        "samples": samples,
        "seed": 1,
        "check": {"min_runs": 0, "fraction": 0.0},
        "execution": {"batch_size": 4},
    }


def bare(cfg_d: dict) -> float:
    cfg = load_config(cfg_d)
    des = design(cfg)
    t0 = time.perf_counter()
    for key in dict.fromkeys(des["cell_key"].values):
        idx = np.flatnonzero(des["cell_key"].values == key)
        simulate_rows(str(des["shape"].values[idx[0]]), design_rows(cfg, des, idx), grid_of(cfg))
    return time.perf_counter() - t0


def engine(cfg_d: dict, client: Any = None) -> float:
    with tempfile.TemporaryDirectory() as d:
        t0 = time.perf_counter()
        run_study(cfg_d, client, out=Path(d) / "b.nc", progress=False)
        return time.perf_counter() - t0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--samples", type=int, default=8, help="samples per cell of the fixed study (3 cells)")
    ap.add_argument("--skip-default", action="store_true", help="skip the default-study estimate")
    a = ap.parse_args()
    cfg_d = study(a.samples)
    n = 3 * a.samples
    warm_kernels()
    bare(study(1))  # compile and warm caches
    t_bare = statistics.median(bare(cfg_d) for _ in range(a.repeats))
    t_eng = statistics.median(engine(cfg_d) for _ in range(a.repeats))
    print(f"fixed study: {n} runs (cuboid, aluminum, 0/15/30 deg, 1 Hz, 2 periods); medians of {a.repeats}")
    print(f"  bare batch kernel, in-process : {t_bare:7.2f} s  ({n / t_bare:.2f} runs/s, {1e3 * t_bare / n:.0f} ms/run)")
    overhead = f"overhead per run {100 * (t_eng - t_bare) / t_bare:+.1f}% ({1e3 * (t_eng - t_bare) / n:+.1f} ms)"
    print(f"  engine, in-process            : {t_eng:7.2f} s  {overhead}")
    rates = {}
    for w in (1, 2):
        client = local_client(w)
        try:
            engine(study(1), client)  # workers load the kernels
            t = statistics.median(engine(cfg_d, client) for _ in range(a.repeats))
        finally:
            cluster = client.cluster
            client.close()
            cluster.close()
        rates[w] = n / t
        print(f"  engine, LocalCluster {w} worker{'s' if w > 1 else ' '}: {t:7.2f} s  ({rates[w]:.2f} runs/s)")
    eff = rates[2] / (2 * rates[1])
    print(f"  parallel efficiency (2 workers): {100 * eff:.0f}%")
    if not a.skip_default:
        cfg = load_config(ROOT / "studies" / "default.toml")
        des = design(cfg)
        first = np.unique(des["cell_key"].values, return_index=True)[1]
        t0 = time.perf_counter()
        per_cell = []
        for i in sorted(first):
            t1 = time.perf_counter()
            simulate_rows(str(des["shape"].values[i]), design_rows(cfg, des, [i]), grid_of(cfg))
            per_cell.append(time.perf_counter() - t1)
        wall = time.perf_counter() - t0
        mean = float(np.mean(per_cell))
        checks = int(des["check_flag"].sum())
        cpu = mean * (des.sizes["run"] + checks * cfg.check.dt_factor)
        print(f"default study: {des.sizes['run']} runs + {checks} check runs at dt/{cfg.check.dt_factor}")
        print(f"  one run per cell ({len(first)} cells): mean {mean:.3f} s/run, max {max(per_cell):.2f} s ({wall:.0f} s)")
        print(f"  estimate: {cpu / 60:.0f} CPU-min; on 2 workers at {100 * eff:.0f}% efficiency about {cpu / (2 * eff) / 60:.0f} min")
    return 0


if __name__ == "__main__":
    sys.exit(main())
