"""A/B per-step cost of two installed tumblemc versions, interleaved.

``python benchmarks/ab_step.py --a OLD_VENV/bin/python --b NEW_VENV/bin/python``

Each round starts one process per interpreter (the order alternates between rounds, so a
slow spell of this shared machine hits both); a process compiles (or loads from its
cache), warms every scenario up, then times the time loop alone (``run_spec``: no
Dataset building) ``--inner`` times per scenario and reports the median. The table gives,
per scenario, the median over the rounds of each side in microseconds per step, the ratio
B/A, and the geometric mean of the ratios. Each side should use its own
``NUMBA_CACHE_DIR`` (``--cache-a``, ``--cache-b``); a fresh one makes the first round
include compilation, which is not timed.

The scenarios are the seven of the kernel work (README, "Validation and performance").
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
from typing import Any

SCENARIOS: dict[str, dict[str, object]] = {
    "cuboid_paper_45deg_1Hz": {"shape": "cuboid", "preset": "paper", "incline_deg": 45.0, "freq_hz": 1.0, "duration_s": 2.0},
    "cuboid_paper_flat_1Hz": {"shape": "cuboid", "preset": "paper", "incline_deg": 0.0, "freq_hz": 1.0, "duration_s": 2.0},
    "cuboid_paper_flat_10Hz": {"shape": "cuboid", "preset": "paper", "incline_deg": 0.0, "freq_hz": 10.0, "duration_s": 0.5},
    "cuboid_aluminum_30deg_1Hz": {"shape": "cuboid", "preset": "aluminum", "incline_deg": 30.0, "freq_hz": 1.0, "duration_s": 2.0},
    "curved_aluminum_35deg_1Hz": {"shape": "curved", "preset": "aluminum", "incline_deg": 35.0, "freq_hz": 1.0, "duration_s": 2.0},
    "spiked_paper_flat_10Hz": {"shape": "spiked", "preset": "paper", "incline_deg": 0.0, "freq_hz": 10.0, "duration_s": 0.5},
    "spiked_ends_aluminum_20deg_1Hz": {
        "shape": "spiked_ends",
        "preset": "aluminum",
        "incline_deg": 20.0,
        "freq_hz": 1.0,
        "duration_s": 2.0,
    },
}

#: more scenarios, by ``--scenarios`` (the curved robot on paper: its climbing and its
#: rolling on the flat, where its many support points matter most)
EXTRA: dict[str, dict[str, object]] = {
    "curved_paper_45deg_1Hz": {"shape": "curved", "preset": "paper", "incline_deg": 45.0, "freq_hz": 1.0, "duration_s": 2.0},
    "curved_paper_flat_10Hz": {"shape": "curved", "preset": "paper", "incline_deg": 0.0, "freq_hz": 10.0, "duration_s": 0.5},
}

# Runs inside the measured interpreter; works with the layout before and after the
# restructuring (tumblemc.simulate.prepare(**kw) or model.run.prepare(run_inputs(**kw))).
WORKER = r"""
import json, statistics, sys, time
try:
    from tumblemc.model.run import prepare, run_inputs, run_spec
    def spec_of(kw):
        return prepare(run_inputs(**kw))
except ImportError:
    from tumblemc.simulate import prepare, run_spec
    def spec_of(kw):
        return prepare(**kw)
scen, inner = json.loads(sys.argv[1]), int(sys.argv[2])
out = {}
for name, kw in scen.items():
    spec = spec_of(kw)
    run_spec(spec)  # compile or load, and warm up
    ts = []
    for _ in range(inner):
        t = time.perf_counter()
        run_spec(spec)
        ts.append(time.perf_counter() - t)
    out[name] = statistics.median(ts) / spec.n_steps * 1e6
print(json.dumps(out))
"""


def run_worker(python: str, cache: str | None, worker: str, *args: str) -> Any:
    """Run ``worker`` (Python source) in ``python`` outside any source tree, with its own Numba cache; its last stdout line, as JSON."""
    env = dict(os.environ)
    if cache:
        env["NUMBA_CACHE_DIR"] = os.path.abspath(cache)
    proc = subprocess.run(
        [os.path.abspath(python), "-c", worker, *args],
        env=env,
        capture_output=True,
        text=True,
        check=True,
        cwd="/",  # not a source tree: each side imports its installed package
    )
    return json.loads(proc.stdout.strip().splitlines()[-1])


def add_ab_arguments(ap: argparse.ArgumentParser) -> None:
    """The options every A/B benchmark takes: the two interpreters and their Numba caches."""
    ap.add_argument("--a", required=True, help="python of the reference version (A), e.g. d5c7070's venv")
    ap.add_argument("--b", default=sys.executable, help="python of the measured version (B; default: this one)")
    ap.add_argument("--cache-a", default=None, help="NUMBA_CACHE_DIR for A")
    ap.add_argument("--cache-b", default=None, help="NUMBA_CACHE_DIR for B")


def _run(python: str, cache: str | None, inner: int, scen: dict[str, dict[str, object]]) -> dict[str, float]:
    return dict(run_worker(python, cache, WORKER, json.dumps(scen), str(inner)))


def main(argv: list[str] | None = None) -> int:
    """Run the interleaved A/B measurement and print the table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_ab_arguments(ap)
    ap.add_argument("--rounds", type=int, default=5, help="processes per side (default 5)")
    ap.add_argument("--inner", type=int, default=3, help="timed runs per scenario and process (default 3)")
    ap.add_argument("--scenarios", default=None, help=f"comma-separated names (default: the seven above; more: {', '.join(EXTRA)})")
    args = ap.parse_args(argv)
    every = {**SCENARIOS, **EXTRA}
    names = list(SCENARIOS) if args.scenarios is None else args.scenarios.split(",")
    unknown = [n for n in names if n not in every]
    if unknown:
        ap.error(f"--scenarios: unknown {unknown} (allowed: {', '.join(every)})")
    scen = {n: every[n] for n in names}
    res: dict[str, list[dict[str, float]]] = {"a": [], "b": []}
    for r in range(args.rounds):
        order = ("a", "b") if r % 2 == 0 else ("b", "a")
        for side in order:
            py, cache = (args.a, args.cache_a) if side == "a" else (args.b, args.cache_b)
            res[side].append(_run(py, cache, args.inner, scen))
        print(f"round {r + 1}/{args.rounds} done", file=sys.stderr)
    print(f"{'scenario':34s} {'A us/step':>10s} {'B us/step':>10s} {'B/A':>7s}")
    ratios = []
    for name in scen:
        a = statistics.median(x[name] for x in res["a"])
        b = statistics.median(x[name] for x in res["b"])
        ratios.append(b / a)
        print(f"{name:34s} {a:10.3f} {b:10.3f} {b / a:7.3f}")
    gm = math.exp(sum(math.log(x) for x in ratios) / len(ratios))
    print(f"{'geometric mean of B/A':34s} {'':10s} {'':10s} {gm:7.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
