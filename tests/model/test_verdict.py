"""The one verdict (``tumblemc.model.outcome``): a run that is not valid never climbed.

Every path decides through :func:`climbed`: :func:`tumblemc.summarize`, the batch path
(:func:`tumblemc.model.rows.simulate_rows`, hence the study engine and the
critical-incline bisection), the maps and the screening analyses.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

import tumblemc
from tumblemc.analysis.maps import maps
from tumblemc.kernels import layout as L
from tumblemc.kernels.batch import BATCH_ERROR, BATCH_FAILED_STEPS, BATCH_NONFINITE, BATCH_OK
from tumblemc.model.outcome import climbed, is_valid, run_status
from tumblemc.model.rows import TimeGrid, simulate_rows


def test_verdict_table() -> None:
    ratio = np.array([0.9, 0.9, 0.9, 0.9, 0.1, np.nan])
    status = np.array([BATCH_OK, BATCH_FAILED_STEPS, BATCH_NONFINITE, BATCH_ERROR, BATCH_OK, BATCH_OK])
    assert climbed(ratio, status, 0.5).tolist() == [True, False, False, False, False, False]
    assert is_valid(status).tolist() == [True, False, False, False, True, True]


def test_run_status_mirrors_the_batch_kernel() -> None:
    assert run_status(L.ST_OK, 0) == BATCH_OK
    assert run_status(L.ST_OK, 3) == BATCH_FAILED_STEPS  # finished with failed steps: not valid
    assert run_status(L.ST_STOPPED, 1) == BATCH_FAILED_STEPS
    assert run_status(L.ST_NAN, 0) == BATCH_NONFINITE
    assert run_status(L.ST_OK, 0, finite=False) == BATCH_NONFINITE


@pytest.fixture(scope="module")
def climbing_run() -> xr.Dataset:
    ds = tumblemc.simulate(preset="paper", duration_s=2.0, dt=2e-4)
    assert tumblemc.summarize(ds)["climbed"]
    return ds


def test_simulate_reports_the_outcome_status(climbing_run: xr.Dataset) -> None:
    assert climbing_run.attrs["status"] == BATCH_OK and climbing_run.attrs["kernel_status"] == L.ST_OK


def test_summarize_failed_steps_never_climbed(climbing_run: xr.Dataset) -> None:
    ds = climbing_run.copy()
    ds.attrs["failed_steps"] = 1  # a step kept unconverged: the run is not valid
    s = tumblemc.summarize(ds)
    assert s["status"] == BATCH_FAILED_STEPS
    assert s["progress_ratio"] >= 0.5  # the ratio is still reported ...
    assert not s["climbed"]  # ... but it is no success


def test_summarize_loose_steps_still_count(climbing_run: xr.Dataset) -> None:
    ds = climbing_run.copy(deep=True)
    ds["loose"].values[len(ds.time) // 2] = 1  # a step kept within accept_tol is converged
    s = tumblemc.summarize(ds)
    assert s["loose_steps"] == 1 and s["climbed"]


def test_batch_and_summarize_agree_on_the_same_run(climbing_run: xr.Dataset) -> None:
    row = {"preset": "paper", "incline_deg": 0.0, "field_mT": 20.0, "freq_hz": 1.0}
    res = simulate_rows("cuboid", [row], TimeGrid(periods=2.0, dt=2e-4))
    s = tumblemc.summarize(climbing_run)
    assert res["status"][0] == BATCH_OK and bool(res["climbed"][0]) == s["climbed"]


def test_maps_count_invalid_runs_as_neither(climbing_run: xr.Dataset) -> None:
    """A run with failed steps and a ratio above the threshold is not a success in the maps.

    Whatever its stored ``climbed`` says.
    """
    n = 4
    runs = xr.Dataset(
        {
            "status": ("run", np.array([BATCH_OK, BATCH_OK, BATCH_FAILED_STEPS, BATCH_FAILED_STEPS], np.int8)),
            "climbed": ("run", np.array([1, 0, 1, 0], np.int8)),
            "progress_ratio": ("run", np.array([0.9, 0.1, 0.9, 0.1])),
            "mean_speed": ("run", np.zeros(n)),
        },
        coords={
            "shape": ("run", ["cuboid"] * n),
            "substrate": ("run", ["paper"] * n),
            "incline_deg": ("run", np.zeros(n)),
            "field_mT": ("run", np.full(n, 20.0)),
            "freq_hz": ("run", np.ones(n)),
            "sample": ("run", np.arange(n)),
        },
    )
    m = maps(runs)
    cell = m.sel(shape="cuboid", substrate="paper", incline_deg=0.0)
    assert int(cell["n_valid"]) == 2 and int(cell["n_success"]) == 1 and int(cell["n_failed"]) == 2
