"""A landing in the second half of a halved step is refined too (``SolverOptions.landing_work``).

The saved step (``tools/late_landing.py``: the spiked robot sliding down aluminum at 70 deg,
20 m/s) does not converge at dt and is halved; its second half lands. The landing
refinement checked only a step's first sub-step, so that landing was kept with a normal
impulse doing 16.6 energy scales of positive work (1.3e-6 J), the run's whole energy gain.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import tumblemc
from tests.tooling import load_tool, one_step
from tumblemc.kernels import layout as L
from tumblemc.kernels.field import field_work_bound
from tumblemc.model.run import prepare, run_inputs

DATA = Path(__file__).parent / "data" / "late_landing.npz"
RUN = load_tool("late_landing").RUN


def _step(landing_work: float) -> tuple[np.ndarray, float]:
    """Record row of the saved step, and the step's energy scale (m g x 1e-4 m + the field's work bound)."""
    spec = prepare(run_inputs(**RUN, solver=tumblemc.SolverOptions(landing_work=landing_work)))
    (status, failed, _), row, _, _ = one_step(np.load(DATA), spec)
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
