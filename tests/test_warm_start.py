"""The extrapolated warm start of smooth contact steps (``SolverOptions.warm_order``).

Kernel level: the order chosen for the next step (``stepper._cubic_predicts_better``)
against a NumPy twin and on sequences where the answer is known. Run level: the cubic
start changes a climbing run only at the solver's tolerance and takes fewer iterations;
``warm_order = 2`` keeps the quadratic start; the option's range is checked.
"""

from __future__ import annotations

import numpy as np
import pytest

import tumblemc
from tumblemc.kernels.stepper import _cubic_predicts_better
from tumblemc.model.params import SolverOptions


def twin(z: np.ndarray, z1: np.ndarray, z2: np.ndarray, z3: np.ndarray, z4: np.ndarray) -> bool:
    """The obvious version: each polynomial through the last points, evaluated one step on."""
    e2 = np.abs(z - (3.0 * z1 - 3.0 * z2 + z3)).max()
    e3 = np.abs(z - (4.0 * z1 - 6.0 * z2 + 4.0 * z3 - z4)).max()
    return bool(e3 < e2)


def sequence(coef: np.ndarray, t0: float, h: float) -> list[np.ndarray]:
    """Solutions z(t) = sum_k coef[k] t^k at t0 + 4h (the new one) down to t0 (the oldest)."""
    t = t0 + h * np.arange(4, -1, -1)
    return [np.polynomial.polynomial.polyval(ti, coef.T) for ti in t]


@pytest.mark.parametrize("seed", range(20))
def test_order_choice_matches_twin(seed: int) -> None:
    rng = np.random.default_rng(seed)
    zs = [rng.normal(size=24) for _ in range(5)]
    assert _cubic_predicts_better(*zs) == twin(*zs)


def test_cubic_wins_on_a_cubic_and_loses_on_a_kink() -> None:
    rng = np.random.default_rng(1)
    coef = rng.normal(size=(4, 24))  # cubic in time: the cubic predicts it exactly
    zs = sequence(coef, 0.3, 0.05)
    assert _cubic_predicts_better(*zs)
    # a kink: the oldest point from another branch (a force that has just switched on)
    # spoils the cubic, which reaches further back, and not the quadratic
    quad = sequence(np.vstack([coef[:3], np.zeros((1, 24))]), 0.3, 0.05)
    quad[4] = quad[4] + 0.1
    assert not _cubic_predicts_better(*quad)


def test_warm_order_range() -> None:
    for bad in (1, 4, 2.5, True):
        with pytest.raises(ValueError, match="warm_order"):
            SolverOptions(warm_order=bad)


def test_cubic_start_agrees_to_the_tolerance_and_saves_iterations() -> None:
    """Paper robot climbing 45 deg at 1 Hz, 0.3 s: quadratic against cubic warm start."""
    kw = {"shape": "cuboid", "preset": "paper", "incline_deg": 45.0, "freq_hz": 1.0, "duration_s": 0.3}
    a = tumblemc.simulate(**kw, solver=SolverOptions(warm_order=2))
    b = tumblemc.simulate(**kw, solver=SolverOptions(warm_order=3))
    for ds in (a, b):
        assert int(ds["failed"].sum()) == 0 and int(ds["loose"].sum()) == 0
        assert float(ds["residual"].max()) <= SolverOptions().tol
    assert float(b["newton_iterations"].sum()) < 0.97 * float(a["newton_iterations"].sum())
    length = 1e-4  # the scaled length unit (m)
    assert float(np.abs(a["position"] - b["position"]).max()) <= 1e-6 * length
    assert float(np.abs(a["quaternion"] - b["quaternion"]).max()) <= 1e-6
    assert b.attrs["solver_warm_order"] == 3 and a.attrs["solver_warm_order"] == 2
