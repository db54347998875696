"""Skipping the smoothing strategies once a step is kept anyway (``SolverOptions.smooth_stalled``).

The curved robot sliding down aluminum at 35 deg lifts off at t = 0.309 s in a step whose
landing refinement's sub-steps stall within ``accept_tol`` in their plain attempts: with
every strategy tried (``smooth_stalled = 1``, the rule before 2026-11-27) the step costs
7,601 Newton iterations, most of them in smoothing attempts that end at the same stall or
further from a solution. ``smooth_stalled = 0`` skips them (not the default: docs/notes/kernel_experiments.md).
"""

from __future__ import annotations

import numpy as np
import pytest

import tumblemc
from tumblemc.model.solver_options import SolverOptions

KW = {"shape": "curved", "preset": "aluminum", "incline_deg": 35.0, "duration_s": 0.32, "record_every": 1}


def test_a_stalled_step_skips_the_smoothing_strategies() -> None:
    old = tumblemc.simulate(**KW, solver=SolverOptions(smooth_stalled=1))  # type: ignore[arg-type]
    new = tumblemc.simulate(**KW, solver=SolverOptions(smooth_stalled=0))  # type: ignore[arg-type]
    for ds in (old, new):
        assert ds.attrs["status"] == 0 and int(ds["failed"].sum()) == 0
    it_old, it_new = old["newton_iterations"].values, new["newton_iterations"].values
    differ = np.flatnonzero(it_old != it_new)
    assert differ.size, "no step skipped a smoothing strategy"
    # identical up to the first step where an attempt stalled within accept_tol
    first = int(differ[0])
    assert np.array_equal(old["position"].values[:first], new["position"].values[:first])
    assert it_old[first] - it_new[first] >= 300  # at least one smoothing attempt (up to 300 iterations) left out
    assert it_new.sum() < it_old.sum()  # (19,492 against 21,345 on this machine)
    assert new.attrs["solver_smooth_stalled"] == 0 and old.attrs["solver_smooth_stalled"] == 1
    assert SolverOptions().smooth_stalled == 1  # every strategy by default


def test_without_accept_tol_the_option_changes_nothing() -> None:
    """accept_tol = 0: no step is kept on a stall, so nothing is skipped."""
    kw = KW  # through the lift-off at 0.309 s where the default skips smoothing attempts
    a = tumblemc.simulate(**kw, solver=SolverOptions(accept_tol=0.0, smooth_stalled=1))  # type: ignore[arg-type]
    b = tumblemc.simulate(**kw, solver=SolverOptions(accept_tol=0.0, smooth_stalled=0))  # type: ignore[arg-type]
    for v in ("position", "quaternion", "newton_iterations", "fallbacks"):
        assert a[v].values.tobytes() == b[v].values.tobytes()


@pytest.mark.parametrize("value", [2, -1, 0.5, True, np.bool_(True), np.float32(1.0)])
def test_smooth_stalled_takes_0_or_1(value: object) -> None:
    with pytest.raises(ValueError, match=r"smooth_stalled=.*allowed: (an integer|a finite value in \[0, 1\])"):
        SolverOptions(smooth_stalled=value)  # type: ignore[arg-type]
