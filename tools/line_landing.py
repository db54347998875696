"""Save two 3-D landings of ``tests/test_landing_gap.py`` (``line_*``, ``spin_*`` in ``tests/data/landing_steps.npz``).

``line``: stress campaign 3-D run 39 (``tumblemc.stress.three_d_runs``, seed 2026: the cuboid on
aluminum at 20 deg, magnetisation tilted 23.4 deg about (-0.457, 0.455, -0.764)) with
``SolverOptions(warm_order=4)``, integrated up to the step before t = 0.5111 s. There the
robot rests on its long bottom edge, exactly level, while it rolls one end into the plane
at 0.04 m/s (docs/solver_gaps.md, section 5): the step that guess 10 solves.

``spin``: run 110 of ``three_d_runs(n=400, seed=2)`` (aluminum, flat, 29.9 deg about
(-0.650, 0.644, -0.404)), integrated up to the step before t = 0.0423 s, where the robot,
thrown up by the field, lands on a vertex while turning about the normal at 426 rad/s: the
torsional friction stops the turn at once (``e_r`` = 0.1 m), the step that guess 11 solves.

The state, the warm start and the contact before each step are saved; the other entries of
the file (``edge_*``, ``impact_*``) are kept as they are.

Run from the repository root: ``python tools/line_landing.py``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from tumblemc.kernels import layout as L
from tumblemc.kernels.residual import n_unknowns
from tumblemc.kernels.stepper import Clock, Model, Start, empty_record, make_buffers, run
from tumblemc.model.params import SolverOptions
from tumblemc.model.run import initial_contact, prepare, run_inputs

OUT = Path(__file__).resolve().parents[1] / "tests" / "data" / "landing_steps.npz"
STEPS = {"line": 10221, "spin": 845}  # steps taken before the landing


def run_2_110() -> dict[str, Any]:
    """Inputs of run 110 of ``three_d_runs(n=400, seed=2)``."""
    rng = np.random.default_rng(2)
    for _ in range(111):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        angle = float(rng.uniform(0.0, 30.0))
    return {
        "preset": "aluminum",
        "incline_deg": 0.0,
        "field_mT": 20.0,
        "freq_hz": 1.0,
        "offset_deg": angle,
        "offset_axis": tuple(float(a) for a in axis),
    }


def run_39() -> dict[str, Any]:
    """Inputs of 3-D run 39 (the 40th draw of ``default_rng(2026)``, as in ``three_d_runs``)."""
    rng = np.random.default_rng(2026)
    for _ in range(40):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        angle = float(rng.uniform(0.0, 30.0))
    return {
        "preset": "aluminum",
        "incline_deg": 20.0,
        "field_mT": 20.0,
        "freq_hz": 1.0,
        "offset_deg": angle,
        "offset_axis": tuple(float(a) for a in axis),
    }


def main() -> None:
    out = dict(np.load(OUT))
    for name, inputs, solver in (("line", run_39(), SolverOptions(warm_order=4)), ("spin", run_2_110(), SolverOptions())):
        sp = prepare(run_inputs(shape="cuboid", duration_s=0.6, solver=solver, **inputs))
        buf = make_buffers(n_unknowns(sp.geo.pstart))
        area0, resting = initial_contact(sp)
        start = Start(sp.state0.copy(), 0.0, area0, resting)
        k = STEPS[name]
        rec = empty_record(k, k)
        status, failed, _ = run(Model(sp.prm, sp.geo), sp.solver.as_array(), start, Clock(sp.h, k, k), rec, buf)
        assert status == L.ST_OK and failed == 0
        out[f"{name}_state"] = start.state
        out[f"{name}_z"] = buf.z.copy()
        out[f"{name}_t"] = np.float64(rec[-1, L.R_T])
        out[f"{name}_area"] = np.float64(rec[-1, L.R_AREA])
        out[f"{name}_mode"] = np.float64(rec[-1, L.R_MODE])
        print(f"{name}: t = {rec[-1, L.R_T] * sp.units.time:.5f} s")
    np.savez(OUT, allow_pickle=False, **out)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
