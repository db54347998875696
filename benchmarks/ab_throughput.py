"""A/B throughput of two installed tumblemc versions, interleaved (issue 15's acceptance benchmark).

``python benchmarks/ab_throughput.py --a OLD_VENV/bin/python [--b NEW_VENV/bin/python]``

Two measurements, each side in its own processes (the order alternates between rounds,
so a slow spell of this shared machine hits both):

1. **One run alone**: milliseconds of wall time per simulated second (the time loop alone,
   ``run_spec``, after compilation and a warm-up), every shape on the paper preset at
   45 deg (1 Hz) and flat at 1 and 10 Hz. The target to report against is 20 ms.
2. **Study throughput**: runs per second through the batch kernel (``simulate_rows``, the
   engine's unit of work, in one process) on a slice of the default study: every shape on
   both presets at 0, 20, 40 and 60 deg, the first ``--samples`` samples of each cell of
   ``studies/default.toml`` (parameters drawn here, once, and given to both sides as
   numbers, so both simulate the same robots). Runs as a study runs them: a version
   with early decisions (``TimeGrid.early_decision``, since 2026-11-27) stops the runs
   that can no longer climb, as ``studies/default.toml`` has it; ``--no-early`` runs
   every run to the end.

The table gives medians over the rounds and the ratio B/A of times (below 1: B is faster);
the summary gives the speed-up A/B of each measurement (geometric mean over scenarios for
the single runs, total time for the study slice). Each side should use its own
``NUMBA_CACHE_DIR`` (``--cache-a``, ``--cache-b``).
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
from pathlib import Path
from typing import Any, cast

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))  # ab_step, run as a script or imported
from ab_step import add_ab_arguments, run_worker  # noqa: E402

SHAPES = ("cuboid", "spiked", "spiked_ends", "curved")
SINGLE: dict[str, dict[str, Any]] = {}
for _s in SHAPES:
    SINGLE[f"{_s}_paper_45deg_1Hz"] = {"shape": _s, "preset": "paper", "incline_deg": 45.0, "freq_hz": 1.0, "duration_s": 2.0}
    SINGLE[f"{_s}_paper_flat_1Hz"] = {"shape": _s, "preset": "paper", "incline_deg": 0.0, "freq_hz": 1.0, "duration_s": 2.0}
    SINGLE[f"{_s}_paper_flat_10Hz"] = {"shape": _s, "preset": "paper", "incline_deg": 0.0, "freq_hz": 10.0, "duration_s": 0.5}

# Runs inside the measured interpreter; works with the layout before and after issue 12's
# restructuring.
WORKER = r"""
import json, statistics, sys, time
try:
    from tumblemc.model.run import prepare, run_inputs, run_spec
    from tumblemc.model.rows import TimeGrid, simulate_rows
    def spec_of(kw):
        return prepare(run_inputs(**kw))
except ImportError:
    from tumblemc.simulate import prepare, run_spec
    from tumblemc.batch import TimeGrid, simulate_rows
    def spec_of(kw):
        return prepare(**kw)
single, slices, inner, early = json.loads(sys.argv[1]), json.loads(sys.argv[2]), int(sys.argv[3]), sys.argv[4] == "1"
out = {"single": {}, "study": {}}
for name, kw in single.items():
    spec = spec_of(kw)
    run_spec(spec)  # compile or load, and warm up
    ts = []
    for _ in range(inner):
        t = time.perf_counter()
        run_spec(spec)
        ts.append(time.perf_counter() - t)
    out["single"][name] = statistics.median(ts) / kw["duration_s"] * 1e3
grid = TimeGrid(periods=2.0, transient_periods=1.0, max_failed_steps=1)
if early and hasattr(grid, "early_decision"):  # as a study runs them (study.design.grid_of)
    import dataclasses
    grid = dataclasses.replace(grid, early_decision=True)
for shape, rows in slices.items():
    simulate_rows(shape, rows[:1], grid)  # compile or load
    t = time.perf_counter()
    simulate_rows(shape, rows, grid)
    out["study"][shape] = time.perf_counter() - t
print(json.dumps(out))
"""


def study_slice(samples: int) -> dict[str, list[dict[str, Any]]]:
    """Rows per shape: both presets at 0/20/40/60 deg, the first ``samples`` runs of each cell of the default study."""
    sys.path.insert(0, str(ROOT))
    from tumblemc.study.config import load_config
    from tumblemc.study.design import batch_row, design

    d = dict(tomllib_load(ROOT / "studies" / "default.toml"))
    d.update({"incline_deg": [0, 20, 40, 60], "samples": samples})
    cfg = load_config(d)
    des = design(cfg)
    out: dict[str, list[dict[str, Any]]] = {s: [] for s in cfg.shapes}
    for i in range(des.sizes["run"]):
        row = des.isel(run=i)
        kw = batch_row(cfg, row).items()
        out[str(row["shape"].values)].append({k: (v if isinstance(v, str) else float(cast(float, v))) for k, v in kw})
    return out


def tomllib_load(path: Path) -> dict[str, Any]:
    import tomllib

    return tomllib.loads(path.read_text())


def _run(python: str, cache: str | None, slices: dict[str, list[dict[str, Any]]], inner: int, early: bool) -> dict[str, dict[str, float]]:
    return dict(run_worker(python, cache, WORKER, json.dumps(SINGLE), json.dumps(slices), str(inner), "1" if early else "0"))


def main(argv: list[str] | None = None) -> int:
    """Run the interleaved A/B measurement and print the tables."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_ab_arguments(ap)
    ap.add_argument("--rounds", type=int, default=3, help="processes per side (default 3)")
    ap.add_argument("--inner", type=int, default=3, help="timed runs per single-run scenario and process (default 3)")
    ap.add_argument("--samples", type=int, default=4, help="runs per cell of the study slice (default 4: 128 runs)")
    ap.add_argument("--no-early", action="store_true", help="study slice without early decisions (every run to the end)")
    args = ap.parse_args(argv)
    slices = study_slice(args.samples)
    n_runs = sum(len(v) for v in slices.values())
    res: dict[str, list[dict[str, dict[str, float]]]] = {"a": [], "b": []}
    for r in range(args.rounds):
        for side in ("a", "b") if r % 2 == 0 else ("b", "a"):
            py, cache = (args.a, args.cache_a) if side == "a" else (args.b, args.cache_b)
            res[side].append(_run(py, cache, slices, args.inner, not args.no_early))
        print(f"round {r + 1}/{args.rounds} done", file=sys.stderr)

    def med(side: str, part: str, name: str) -> float:
        return statistics.median(x[part][name] for x in res[side])

    print(f"{'one run alone (ms per simulated second)':42s} {'A':>9s} {'B':>9s} {'B/A':>7s}")
    ratios = []
    for name in SINGLE:
        a, b = med("a", "single", name), med("b", "single", name)
        ratios.append(b / a)
        print(f"{name:42s} {a:9.1f} {b:9.1f} {b / a:7.3f}")
    gm = math.exp(sum(math.log(x) for x in ratios) / len(ratios))
    print(f"{'geometric mean of B/A':42s} {'':9s} {'':9s} {gm:7.3f}")
    print()
    print(f"{'study slice (s through simulate_rows)':42s} {'A':>9s} {'B':>9s} {'B/A':>7s}")
    ta = tb = 0.0
    for shape in slices:
        a, b = med("a", "study", shape), med("b", "study", shape)
        ta, tb = ta + a, tb + b
        print(f"{shape + f' ({len(slices[shape])} runs)':42s} {a:9.2f} {b:9.2f} {b / a:7.3f}")
    print(f"{f'all ({n_runs} runs): runs per second':42s} {n_runs / ta:9.2f} {n_runs / tb:9.2f} {tb / ta:7.3f}")
    print()
    print(f"speed-up of B over A: one run alone {1 / gm:.2f}x (target 2.5x), study throughput {ta / tb:.2f}x (target 5x)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
