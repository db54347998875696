"""The failed step's rescue pass (``SolverOptions.rescue_iter``).

A step that no strategy solves at any sub-step depth is solved once more from its start,
every attempt allowed ``rescue_iter`` Newton iterations and no stall window, before it is
kept as failed. The run below is one of the main job's 13 invalid runs at a97302c (curved
robot, aluminum, 60 deg, the default study's run 20743): with the rescue off it fails one
step at t = 0.96 s, with it on it fails none.
"""

from __future__ import annotations

import numpy as np
import pytest

import tumblemc

RUN_20743 = {
    "shape": "curved",
    "preset": "aluminum",
    "incline_deg": 60.0,
    "field_mT": 20.0,
    "freq_hz": 1.0,
    "adhesion_C": 31.51220421860525,
    "magnetization": 48246.97266617909,
    "mu": 0.520270937291733,
    "offset_deg": 1.8997199164311511,
    "periods": 2.0,
}


def test_rescue_solves_the_step_that_failed_and_changes_nothing_before_it() -> None:
    off = tumblemc.simulate(**RUN_20743, solver=tumblemc.SolverOptions(rescue_iter=0))
    on = tumblemc.simulate(**RUN_20743)
    failed = np.nonzero(off["failed"].values)[0]
    assert failed.size == 1 and abs(float(off["time"][failed[0]]) - 0.96155) < 1e-9
    assert int(off.attrs["status"]) != 0  # a failed step makes the run invalid
    assert int(on["failed"].sum()) == 0 and int(on.attrs["status"]) == 0
    k = int(failed[0])
    # the rescue only acts on a step that fails: every row before it is the same, bit for bit
    for v in ("position", "quaternion", "velocity", "omega", "energy_balance", "newton_iterations", "substeps"):
        np.testing.assert_array_equal(on[v].values[:k], off[v].values[:k], err_msg=v)
    # the rescued step is solved to tol, and the run's energy ledger stays balanced
    assert float(on["residual"][k]) <= tumblemc.SolverOptions().tol
    s = tumblemc.summarize(on)
    assert s["energy_gain_ratio"] < 0.01


def test_rescue_changes_nothing_in_a_run_without_failed_steps() -> None:
    """The step-start snapshot kept at each halving does not touch the arithmetic."""
    kw = {"shape": "curved", "preset": "aluminum", "incline_deg": 35.0, "duration_s": 0.9, "record_every": 50}
    a = tumblemc.simulate(solver=tumblemc.SolverOptions(rescue_iter=0), **kw)
    b = tumblemc.simulate(**kw)
    assert int(a["failed"].sum()) == 0 and int(a["substeps"].sum()) > 0
    for v in a.data_vars:
        np.testing.assert_array_equal(a[v].values, b[v].values, err_msg=v)


@pytest.mark.parametrize("bad", [-1, 10_001, 2.5, True])
def test_rescue_iter_out_of_range_names_the_field(bad: object) -> None:
    with pytest.raises(ValueError, match="rescue_iter"):
        tumblemc.SolverOptions(rescue_iter=bad)  # type: ignore[arg-type]
