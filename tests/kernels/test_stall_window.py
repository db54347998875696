"""The smoothing continuation's stall window (``SolverOptions.stall_window``).

A smoothing attempt that neither halves its residual nor lowers its smoothing parameter in
``stall_window`` iterations stops there instead of running on to its 300-iteration limit.
The saved step (``tests/data/stall_step.py``) is a refined step of the curved robot sliding on
aluminum whose smoothing attempts never converge: the window changes the work, not what is
kept.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import tumblemc
from tests.tooling import load_tool, one_step
from tumblemc.kernels import layout as L
from tumblemc.model.run import prepare, run_inputs

DATA = Path(__file__).resolve().parents[1] / "data" / "stall_step.npz"
RUN = load_tool("stall_step").RUN


def _step(window: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Record row, end state and last solution of the saved step with ``stall_window = window``."""
    spec = prepare(run_inputs(**RUN, solver=tumblemc.SolverOptions(stall_window=window)))
    (status, failed, _), row, start, buf = one_step(np.load(DATA), spec)
    assert status == L.ST_OK and failed == 0
    return row, start.state, buf.z.copy()


def test_stall_window_cuts_the_work_of_a_stalled_step_and_keeps_its_answer() -> None:
    off, state_off, z_off = _step(0)
    on, state_on, z_on = _step(80)
    assert off[L.R_NIT] > 30_000  # 119 smoothing attempts at their 300-iteration limit
    assert on[L.R_NIT] < 0.5 * off[L.R_NIT]
    # the same plain attempt is kept (loose, within accept_tol), so the same end state
    assert off[L.R_RES] <= tumblemc.SolverOptions().accept_tol
    np.testing.assert_array_equal(state_on, state_off)
    np.testing.assert_array_equal(z_on, z_off)
    assert on[L.R_SUB] == off[L.R_SUB]


def test_a_window_longer_than_the_iteration_limit_changes_nothing() -> None:
    """The counter alone does not touch the arithmetic: a window no attempt can reach gives the bits of 0."""
    kw = {"shape": "curved", "preset": "aluminum", "incline_deg": 35.0, "duration_s": 0.9, "record_every": 50}
    a = tumblemc.simulate(solver=tumblemc.SolverOptions(stall_window=0), **kw)
    b = tumblemc.simulate(solver=tumblemc.SolverOptions(stall_window=10_000), **kw)
    for v in a.data_vars:
        np.testing.assert_array_equal(a[v].values, b[v].values)
    assert int(a["newton_iterations"].sum()) > 30_000  # it passes through the stalled step


@pytest.mark.parametrize("bad", [-1, 10_001, 2.5, True])
def test_stall_window_out_of_range_names_the_field(bad: object) -> None:
    with pytest.raises(ValueError, match="stall_window"):
        tumblemc.SolverOptions(stall_window=bad)  # type: ignore[arg-type]
