"""Fast landings refined in sub-steps (``SolverOptions.landing_work``, MODEL.md numerical traps).

A robot sliding down 70 deg aluminum at metres per second crosses several thicknesses in
one step; where it lands, the end-pose contact can throw it back out, so the converged
normal impulse does positive work (docs/stress.md, class ``energy_gain``). Such a step is
solved again as halves; the refinement is kept only if every sub-step converges and it
does less positive normal work than the step it replaces. The two steps are saved by
``tools/fast_landings.py`` from stress run 122 at the paper's fixed step.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import tumblemc
from tumblemc.kernels import layout as L
from tumblemc.kernels.field import field_work_bound
from tumblemc.kernels.stepper import Clock, Model, Start, empty_record, make_buffers, run
from tumblemc.model.run import prepare, run_inputs

DATA = Path(__file__).parent / "data" / "fast_landings.npz"
RUN_122 = {
    "shape": "cuboid",
    "preset": "aluminum",
    "incline_deg": 70.0,
    "field_mT": 20.95,
    "freq_hz": 0.5,
    "duration_s": 4.0,
    "mu": 0.8118,
    "adhesion_C": 75.41,
    "offset_deg": 26.94,
}


def _one_step(case: str, landing_work: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Record row, end state and last solution of the saved step; and the refusal threshold."""
    d = np.load(DATA)
    solver = tumblemc.SolverOptions(landing_work=landing_work)
    spec = prepare(run_inputs(**RUN_122, solver=solver))  # type: ignore[arg-type]
    buf = make_buffers(d[f"{case}_z"].shape[0])
    buf.z[:] = d[f"{case}_z"]
    start = Start(d[f"{case}_state"].copy(), float(d[f"{case}_t"]), float(d[f"{case}_area"]), bool(d[f"{case}_mode"] > 0))
    rec = empty_record(1, 1)
    status, failed = run(Model(spec.prm, spec.geo), solver.as_array(), start, Clock(spec.h, 1, 1), rec, buf)
    assert status == L.ST_OK and failed == 0
    scale = spec.prm[L.P_MASS] * spec.prm[L.P_G] + field_work_bound(spec.prm, spec.h)
    return rec[1], start.state, buf.z.copy(), tumblemc.SolverOptions().landing_work * scale


def test_refined_landing_does_far_less_positive_normal_work() -> None:
    coarse, _, _, limit = _one_step("refined", 0.0)
    fine, _, _, _ = _one_step("refined", tumblemc.SolverOptions().landing_work)
    assert coarse[L.R_SUB] == 0 and coarse[L.R_LED + L.L_WN] > 10 * limit  # the landing the rule refuses
    assert fine[L.R_SUB] >= 2  # halved at least twice
    assert fine[L.R_LED + L.L_GAIN] < 0.05 * coarse[L.R_LED + L.L_GAIN]
    assert fine[L.R_RES] <= tumblemc.SolverOptions().tol


def test_refinement_that_stalls_keeps_the_full_step_bit_for_bit() -> None:
    coarse, state0, z0, limit = _one_step("kept", 0.0)
    fine, state1, z1, _ = _one_step("kept", tumblemc.SolverOptions().landing_work)
    assert coarse[L.R_LED + L.L_WN] > 100 * limit
    assert fine[L.R_NIT] > coarse[L.R_NIT]  # it tried
    assert np.array_equal(state0, state1) and np.array_equal(z0, z1)
    skip = {L.R_NIT, L.R_FALLBACK}  # the solver's work counts the sub-steps tried
    cols = [c for c in range(fine.shape[0]) if c not in skip]
    assert np.array_equal(fine[cols], coarse[cols])


def test_ordinary_runs_are_not_refined() -> None:
    """The paper's validation case and a hopping aluminum run land softly: nothing changes."""
    for kw in (
        {"preset": "paper", "incline_deg": 45.0, "duration_s": 1.0},
        {"preset": "aluminum", "incline_deg": 0.0, "freq_hz": 10.0, "duration_s": 0.3},
    ):
        a = tumblemc.simulate(**kw, solver=tumblemc.SolverOptions(landing_work=0.0))  # type: ignore[arg-type]
        b = tumblemc.simulate(**kw)  # type: ignore[arg-type]
        assert int(b["substeps"].sum()) == 0
        for v in ("position", "quaternion", "velocity", "omega", "energy_gain"):
            assert np.array_equal(a[v].values, b[v].values)


@pytest.mark.parametrize("bad", [-1e-3, 2.0, float("nan")])
def test_landing_work_out_of_range_names_the_field(bad: float) -> None:
    with pytest.raises(ValueError, match="landing_work"):
        tumblemc.SolverOptions(landing_work=bad)
