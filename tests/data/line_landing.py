"""Save three landings of ``tests/kernels/test_hard_steps.py`` (``line_*``, ``spin_*``, ``pivot_*`` in ``tests/data/landing_steps.npz``).

``line``: stress campaign 3-D run 39 (``tumblemc.reports.stress.three_d_runs``, seed 2026: the cuboid on
aluminum at 20 deg, magnetisation tilted 23.4 deg about (-0.457, 0.455, -0.764)) with
``SolverOptions(warm_order=4)``, integrated up to the step before t = 0.5111 s. There the
robot rests on its long bottom edge, exactly level, while it rolls one end into the plane
at 0.04 m/s (docs/notes/solver_gaps.md, section 5): the step that guess 10 solves.

``spin``: run 110 of ``three_d_runs(n=400, seed=2)`` (aluminum, flat, 29.9 deg about
(-0.650, 0.644, -0.404)), integrated up to the step before t = 0.0423 s, where the robot,
thrown up by the field, lands on a vertex while turning about the normal at 426 rad/s: the
torsional friction stops the turn at once (``e_r`` = 0.1 m), the step that guess 11 solves.

``pivot``: the snap hop (``tumblemc.testing.SNAP_HOP``, cuboid) at dt = 3.125e-6 s,
integrated up to the step before t = 0.42259 s: the edge that touched in the last step
lands at 0.06 m/s while sliding at 0.14 m/s, and the impact sticks. Every strategy and
every halving failed there until ``lu_factor`` tested its pivots against their own row
(docs/notes/solver_gaps.md, section 7). The committed entry was written with the code before that
change (37292ac): since then the run takes another path (the row test changes other steps
by rounding), so the tool at a later commit writes another state.

The state, the warm start and the contact before each step are saved; the other entries of
the file (``edge_*``, ``impact_*``) are kept as they are.

Run from the repository root: ``python tests/data/line_landing.py [NAME ...]`` (default: all three).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np

from tumblemc.model.run import prepare, run_inputs
from tumblemc.model.solver_options import SolverOptions
from tumblemc.testing import SNAP_HOP

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fast_landings import before_step  # noqa: E402

OUT = Path(__file__).resolve().parent / "landing_steps.npz"
STEPS = {"line": 10221, "spin": 845, "pivot": 135227}  # steps taken before the landing
PIVOT = {"shape": "cuboid", "duration_s": 1.0, "dt": 3.125e-6, **SNAP_HOP}


def three_d_inputs(seed: int, k: int) -> dict[str, Any]:
    """Inputs of run ``k`` of ``tumblemc.reports.stress.three_d_runs(n, seed)`` (any ``n > k``): its draws replayed."""
    rng = np.random.default_rng(seed)
    for _ in range(k + 1):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        angle = float(rng.uniform(0.0, 30.0))
    preset, incline = [(p, inc) for p in ("paper", "aluminum") for inc in (0.0, 20.0)][k % 4]
    return {
        "preset": preset,
        "incline_deg": incline,
        "field_mT": 20.0,
        "freq_hz": 1.0,
        "offset_deg": angle,
        "offset_axis": tuple(float(a) for a in axis),
    }


def run_39() -> dict[str, Any]:
    """Inputs of the stress campaign's 3-D run 39 (seed 2026)."""
    return three_d_inputs(2026, 39)


def run_2_110() -> dict[str, Any]:
    """Inputs of run 110 of ``three_d_runs(n=400, seed=2)``."""
    return three_d_inputs(2, 110)


def main(names: list[str]) -> None:
    out = dict(np.load(OUT))
    for name in names or list(STEPS):
        if name == "pivot":
            sp = prepare(run_inputs(**PIVOT))  # type: ignore[arg-type]
        elif name in STEPS:
            inputs, solver = (run_39(), SolverOptions(warm_order=4)) if name == "line" else (run_2_110(), SolverOptions())
            sp = prepare(run_inputs(shape="cuboid", duration_s=0.6, solver=solver, **inputs))
        else:
            raise SystemExit(f"unknown landing {name!r} (allowed: {', '.join(STEPS)})")
        print(name, end=": ")
        for key, val in before_step(sp, STEPS[name]).items():
            out[f"{name}_{key}"] = val
    np.savez(OUT, allow_pickle=False, **out)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main(sys.argv[1:])
