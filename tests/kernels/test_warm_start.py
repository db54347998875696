"""The extrapolated warm start of smooth contact steps (``SolverOptions.warm_order``).

Kernel level: the order chosen for the next step (``substep.best_order``) against a NumPy
twin and on sequences where the answer is known. Run level: each higher order changes a
climbing run only at the solver's tolerance and takes fewer iterations; ``warm_order =
2`` keeps the quadratic start; the option's range is checked.
"""

from __future__ import annotations

from math import comb

import numpy as np
import pytest

import tumblemc
from tumblemc.kernels.substep import best_order
from tumblemc.model.solver_options import SolverOptions


def extrapolate(zs: list[np.ndarray], p: int) -> np.ndarray:
    """The polynomial of degree p through the p + 1 latest solutions (``zs[0]`` the latest), one step on."""
    return sum((-1) ** j * comb(p + 1, j + 1) * zs[j] for j in range(p + 1))


def twin(z: np.ndarray, zs: list[np.ndarray], pmax: int) -> int:
    """The obvious version: the order with the smallest max-norm error, the lower one on a tie."""
    errs = [np.abs(z - extrapolate(zs, p)).max() for p in range(2, pmax + 1)]
    return 2 + int(np.argmin(errs))


def sequence(coef: np.ndarray, t0: float, h: float) -> list[np.ndarray]:
    """Solutions z(t) = sum_k coef[k] t^k at t0 + 6h (the new one) down to t0 (the oldest)."""
    t = t0 + h * np.arange(6, -1, -1)
    return [np.polynomial.polynomial.polyval(ti, coef.T) for ti in t]


def test_extrapolation_weights() -> None:
    """The twin's weights are the stepper's: 3, -3, 1 / 4, -6, 4, -1 / 5, -10, ... / 6, -15, ..."""
    e = np.eye(6)
    rows = [extrapolate(list(e), p)[: p + 1] for p in (2, 3, 4, 5)]
    assert rows[0].tolist() == [3, -3, 1]
    assert rows[1].tolist() == [4, -6, 4, -1]
    assert rows[2].tolist() == [5, -10, 10, -5, 1]
    assert rows[3].tolist() == [6, -15, 20, -15, 6, -1]


@pytest.mark.parametrize("pmax", [2, 3, 4, 5])
@pytest.mark.parametrize("seed", range(10))
def test_order_choice_matches_twin(seed: int, pmax: int) -> None:
    rng = np.random.default_rng(seed)
    z, *zs = [rng.normal(size=24) for _ in range(7)]
    assert best_order(z, np.array(zs), pmax) == twin(z, zs, pmax)


@pytest.mark.parametrize("degree", [3, 4, 5])
def test_a_polynomial_picks_an_order_that_reaches_its_degree(degree: int) -> None:
    """An exact polynomial: every order from its degree up predicts it to rounding.

    Which of those wins is rounding; every lower order misses.
    """
    rng = np.random.default_rng(degree)
    coef = rng.normal(size=(degree + 1, 24))
    z, *zs = sequence(coef, 0.3, 0.05)
    assert best_order(z, np.array(zs), 5) >= degree
    assert np.abs(z - extrapolate(zs, degree - 1)).max() > 1e-8


def test_a_kink_in_the_history_keeps_the_order_low() -> None:
    """A kink in the history keeps the quadratic.

    The oldest points from another branch (a force that has just switched on) spoil every
    extrapolation that reaches that far back, and not the quadratic.
    """
    rng = np.random.default_rng(1)
    z, *zs = sequence(np.vstack([rng.normal(size=(3, 24)), np.zeros((3, 24))]), 0.3, 0.05)
    zs[3] = zs[3] + 0.1  # z4 and older belong to the other branch
    zs[4] = zs[4] + 0.2
    zs[5] = zs[5] + 0.3
    assert best_order(z, np.array(zs), 5) == 2


def test_warm_order_range() -> None:
    for bad in (1, 6, 2.5, True):
        with pytest.raises(ValueError, match="warm_order"):
            SolverOptions(warm_order=bad)


@pytest.fixture(scope="module")
def climbs() -> dict[int, object]:
    """Paper robot climbing 45 deg at 1 Hz, 0.3 s, with each warm start."""
    kw = {"shape": "cuboid", "preset": "paper", "incline_deg": 45.0, "freq_hz": 1.0, "duration_s": 0.3}
    return {w: tumblemc.simulate(**kw, solver=SolverOptions(warm_order=w)) for w in (2, 3, 4, 5)}


@pytest.mark.parametrize("w", [3, 4, 5])
def test_higher_orders_agree_to_the_tolerance_and_save_iterations(climbs, w: int) -> None:
    a, b = climbs[w - 1], climbs[w]
    for ds in (a, b):
        assert int(ds["failed"].sum()) == 0 and int(ds["loose"].sum()) == 0
        assert float(ds["residual"].max()) <= SolverOptions().tol
    if w <= 4:  # the quintic takes 2% more iterations than the quartic on this climb (10,484 vs 10,281)
        assert float(b["newton_iterations"].sum()) < 0.99 * float(a["newton_iterations"].sum())
    length = 1e-4  # the scaled length unit (m)
    assert float(np.abs(a["position"] - b["position"]).max()) <= 1e-6 * length
    assert float(np.abs(a["quaternion"] - b["quaternion"]).max()) <= 1e-6
    assert b.attrs["solver_warm_order"] == w and a.attrs["solver_warm_order"] == w - 1


def test_the_default_is_the_cubic() -> None:
    """3, not 4: docs/notes/kernel_experiments.md, "Warm starts up to the quartic"."""
    assert SolverOptions().warm_order == 3
