"""Fast landings refined in sub-steps (``SolverOptions.landing_work``, MODEL.md numerical traps).

A robot sliding down 70 deg aluminum at metres per second crosses several thicknesses in
one step; where it lands, the end-pose contact can throw it back out, so the converged
normal impulse does positive work (docs/stress.md, class ``energy_gain``). Such a step is
solved again as halves; the refinement is kept only if every sub-step converges and it
does less positive normal work than the step it replaces. The two steps are saved by
``tests/data/fast_landings.py`` from stress run 122 at the paper's fixed step.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

import tumblemc
from tests.tooling import load_tool, one_step
from tumblemc.claims import SNAP_HOP
from tumblemc.kernels import layout as L
from tumblemc.kernels.field import field_work_bound
from tumblemc.kernels.stepper import Start
from tumblemc.model.run import prepare, run_inputs

DATA = Path(__file__).resolve().parents[1] / "data" / "fast_landings.npz"
FAST_LANDINGS = load_tool("fast_landings")  # the runs the saved landings come from
RUN_122 = FAST_LANDINGS.RUN_122
SMALL_STEP = {**FAST_LANDINGS.SMALL_STEP, **SNAP_HOP}


def _step(case: str, run_kw: dict[str, Any], solver: tumblemc.SolverOptions, dt_factor: float = 1.0) -> tuple[Any, np.ndarray, Start, Any]:
    """One step of length ``dt_factor x dt`` from the saved start of ``case``: (status, failed, t_decided), record row, end, spec."""
    spec = prepare(run_inputs(**run_kw, solver=solver))
    out, row, start, buf = one_step(np.load(DATA), spec, f"{case}_", h=spec.h * dt_factor)
    return out, row, start, (spec, buf)


def _one_step(case: str, landing_work: float, pivot_row_test: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Record row, end state and last solution of the saved step; and the refusal threshold."""
    solver = tumblemc.SolverOptions(landing_work=landing_work, pivot_row_test=pivot_row_test)
    (status, failed, _), row, start, (spec, buf) = _step(case, RUN_122, solver)
    assert status == L.ST_OK and failed == 0
    scale = spec.prm[L.P_MASS] * spec.prm[L.P_G] + field_work_bound(spec.prm, spec.h)
    return row, start.state, buf.z.copy(), tumblemc.SolverOptions().landing_work * scale


def test_refined_landing_does_far_less_positive_normal_work() -> None:
    coarse, _, _, limit = _one_step("refined", 0.0)
    fine, _, _, _ = _one_step("refined", tumblemc.SolverOptions().landing_work)
    assert coarse[L.R_SUB] == 0 and coarse[L.R_LED + L.L_WN] > 10 * limit  # the landing the rule refuses
    assert fine[L.R_SUB] >= 2  # halved at least twice
    assert fine[L.R_LED + L.L_GAIN] < 0.05 * coarse[L.R_LED + L.L_GAIN]
    assert fine[L.R_RES] <= tumblemc.SolverOptions().tol


def test_refinement_that_stalls_keeps_the_full_step_bit_for_bit() -> None:
    """A refinement whose sub-steps stall keeps the full step, bit for bit.

    The saved landing at 17.8 m/s stalled in its sub-steps with the LU's matrix-wide pivot
    test (``pivot_row_test=0``, the rule when it was saved); with the row test they converge
    and the refinement is kept (the next test).
    """
    coarse, state0, z0, limit = _one_step("kept", 0.0, 0)
    fine, state1, z1, _ = _one_step("kept", tumblemc.SolverOptions().landing_work, 0)
    assert coarse[L.R_LED + L.L_WN] > 100 * limit
    assert fine[L.R_NIT] > coarse[L.R_NIT]  # it tried
    assert np.array_equal(state0, state1) and np.array_equal(z0, z1)
    skip = {L.R_NIT, L.R_FALLBACK}  # the solver's work counts the sub-steps tried
    cols = [c for c in range(fine.shape[0]) if c not in skip]
    assert np.array_equal(fine[cols], coarse[cols])


def test_fast_landing_refined_with_the_row_test() -> None:
    """With the LU's row test (the default), the 17.8 m/s landing's sub-steps converge: refined, less positive work."""
    coarse, _, _, limit = _one_step("kept", 0.0)
    fine, _, _, _ = _one_step("kept", tumblemc.SolverOptions().landing_work)
    assert coarse[L.R_LED + L.L_WN] > 100 * limit
    assert fine[L.R_SUB] >= 1 and fine[L.R_RES] <= tumblemc.SolverOptions().tol
    assert fine[L.R_LED + L.L_WN] < coarse[L.R_LED + L.L_WN]


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


def test_slow_landing_converges_at_a_longer_step() -> None:
    """The saved slow landing (reproducer 1 at dt = 5e-6 s) is solvable: at 1.5 dt it converges."""
    (status, failed, _), row, _, _ = _step("small_step", SMALL_STEP, tumblemc.SolverOptions(), 1.5)
    assert status == L.ST_OK and failed == 0 and row[L.R_RES] <= tumblemc.SolverOptions().tol


def test_slow_landing_at_a_small_step_converges_with_the_row_test() -> None:
    """The saved slow landing at dt = 5e-6 s converges at dt with the LU's row test (the default).

    Its Newton matrices were called singular by the matrix-wide pivot test (docs/notes/solver_gaps.md,
    section 7), so that no strategy solved it at any depth.
    """
    (status, failed, _), row, _, _ = _step("small_step", SMALL_STEP, tumblemc.SolverOptions())
    assert status == L.ST_OK and failed == 0 and row[L.R_LOOSE] == 0
    assert row[L.R_RES] <= tumblemc.SolverOptions().tol


def test_slow_landing_at_a_small_step_is_kept_loose_not_failed() -> None:
    """The saved slow landing at dt = 5e-6 s is kept as loose, not failed (``impulse_accept_tol``).

    With the LU's matrix-wide pivot test (``pivot_row_test=0``, the rule before 2026-11-28), no
    strategy solves it to ``tol`` at any depth; its best attempt balances momentum to 2e-7 of
    the impact. With the rule off (0) the step fails, as before 2026-11-27. The failed step's
    rescue pass is off too (``rescue_iter=0``): it would keep its own best attempt as failed.
    """
    P0 = {"pivot_row_test": 0, "rescue_iter": 0}
    (status, failed, _), row, end, _ = _step("small_step", SMALL_STEP, tumblemc.SolverOptions(**P0))
    assert status == L.ST_OK and failed == 0 and row[L.R_LOOSE] == 1
    assert row[L.R_IMPULSE] == 1  # counted apart: kept by the impulse rule, not by accept_tol
    assert row[L.R_RES] > 0.1  # not converged in the absolute sense: the record says so
    assert row[L.R_SUB] == tumblemc.SolverOptions().max_substep_depth  # it got there at the smallest sub-step
    (status, failed, _), row0, end0, _ = _step("small_step", SMALL_STEP, tumblemc.SolverOptions(impulse_accept_tol=0.0, **P0))
    assert failed == 1 and row0[L.R_LOOSE] == 0 and row0[L.R_IMPULSE] == 0
    assert np.array_equal(end.state, end0.state)  # the same attempt, kept either way: only the label differs
    # the edge stops: the downward speed drops from 12 to below 1 (scaled), the ECP at the plane
    assert end.state[9] > -1.0 and row[L.R_PEN] < 1e-3
    # the scale matters: at 1e-8 of the step's momenta (the attempt balances them to 1.7e-7) it fails
    (status, failed, _), _, _, _ = _step("small_step", SMALL_STEP, tumblemc.SolverOptions(impulse_accept_tol=1e-8, **P0))
    assert failed == 1
    # a study stops a run at its first failed step (max_failed_steps = 1): kept loose, it runs on
    (status, failed, _), _, _, _ = _step("small_step", SMALL_STEP, tumblemc.SolverOptions(max_failed_steps=1, **P0))
    assert status == L.ST_OK and failed == 0
    (status, failed, _), _, _, _ = _step("small_step", SMALL_STEP, tumblemc.SolverOptions(max_failed_steps=1, impulse_accept_tol=0.0, **P0))
    assert status == L.ST_STOPPED


@pytest.mark.parametrize("bad", [-1, 2, 0.5, True])
def test_pivot_row_test_out_of_range_names_the_field(bad: object) -> None:
    with pytest.raises(ValueError, match="pivot_row_test"):
        tumblemc.SolverOptions(pivot_row_test=bad)  # type: ignore[arg-type]


@pytest.mark.parametrize("bad", [-1e-9, 2e-3, float("nan")])
def test_impulse_accept_tol_out_of_range_names_the_field(bad: float) -> None:
    with pytest.raises(ValueError, match="impulse_accept_tol"):
        tumblemc.SolverOptions(impulse_accept_tol=bad)
