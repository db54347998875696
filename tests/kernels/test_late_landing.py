"""Late landings: one in the second half of a halved step, one whose refinement's half-step does not converge.

The first saved step (``tests/data/late_landing.py``: the spiked robot sliding down aluminum at 70 deg,
20 m/s) does not converge at dt and is halved; its second half lands. The landing
refinement checked only a step's first sub-step, so that landing was kept with a normal
impulse doing 16.6 energy scales of positive work (1.3e-6 J), the run's whole energy gain.

The second (the curved robot at 17 m/s, same tool) lands with 2.0e-6 J of positive normal
work at dt, and the first half-step of its refinement does not converge. The refinement
was then refused and the step kept at dt; now that half-step is halved again, at most
``SolverOptions.refine_halvings`` times (docs/notes/solver_gaps.md, section 10).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import tumblemc
from tests.tooling import load_tool, one_step
from tumblemc.kernels import layout as L
from tumblemc.kernels.field import field_work_bound
from tumblemc.model.run import prepare, run_inputs

DATA = Path(__file__).resolve().parents[1] / "data" / "late_landing.npz"
TOOL = load_tool("late_landing")


def _step(landing_work: float, case: str = "", **opts: int) -> tuple[np.ndarray, float]:
    """Record row of a saved step, and the step's energy scale (m g x 1e-4 m + the field's work bound)."""
    spec = prepare(run_inputs(**TOOL.CASES[case][0], solver=tumblemc.SolverOptions(landing_work=landing_work, **opts)))
    (status, failed, _), row, _, _ = one_step(np.load(DATA), spec, prefix=case)
    assert status == L.ST_OK and failed == 0
    assert row[L.R_RES] <= spec.solver.tol and row[L.R_LOOSE] == 0
    return row, spec.prm[L.P_MASS] * spec.prm[L.P_G] + field_work_bound(spec.prm, spec.h)


def test_a_landing_in_a_later_sub_step_is_refined() -> None:
    off, scale = _step(0.0)  # no refinement: the landing as the solver first finds it
    on, _ = _step(tumblemc.SolverOptions().landing_work)
    assert off[L.R_SUB] == 1  # halved once for convergence, then the second half lands
    assert off[L.R_LED + L.L_GAIN] > 10.0 * scale  # the energy the rigid contact made
    assert on[L.R_SUB] > off[L.R_SUB]  # refined further
    # a thousandth of the ledger's tolerance (1e-2 of the scale) at most
    assert on[L.R_LED + L.L_GAIN] < 1e-3 * scale


def test_a_refinement_whose_half_step_does_not_converge_is_halved_again() -> None:
    lw = tumblemc.SolverOptions().landing_work
    coarse, scale = _step(0.0, "halve_")  # the step at dt, as a refused refinement keeps it
    refused, _ = _step(lw, "halve_", refine_halvings=0)
    halved, _ = _step(lw, "halve_")
    assert coarse[L.R_LED + L.L_GAIN] > 10.0 * scale
    # refused: solved again at dt and kept, the same step bit for bit
    assert refused[L.R_SUB] == 0 and refused[L.R_LED + L.L_GAIN] == coarse[L.R_LED + L.L_GAIN]
    assert halved[L.R_SUB] >= 2  # a half-step halved again
    assert halved[L.R_LED + L.L_GAIN] < 1e-3 * scale


@pytest.mark.parametrize("bad", [-1, 31, 1.5, True])
def test_refine_halvings_out_of_range_names_the_field_and_the_range(bad: object) -> None:
    with pytest.raises(ValueError, match=r"refine_halvings.*allowed"):
        tumblemc.SolverOptions(refine_halvings=bad)  # type: ignore[arg-type]
