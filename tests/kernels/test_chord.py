"""Chord iterations at the start of a step (``SolverOptions.chord_iter``, ``newton.solve``).

Kernel level on the free-flight system (6 unknowns, smooth): a chord start solves the next
step to ``tol`` without forming a Jacobian and lands on Newton's solution; factors of
another step length, of Levenberg-Marquardt or of a badly different matrix are not used
blindly; ``chord_iter = 0`` is the plain Newton rule bit for bit. Run level: the chord
start changes a climbing run's trajectory only at the tolerance's level, and a run in a
batch does not see its batch-mate's factors.
"""

from __future__ import annotations

import numpy as np
import pytest

import tumblemc
from tests.kernels.test_kernels import make_problem
from tumblemc.kernels import layout as L
from tumblemc.kernels.newton import _lm_direction, make_workspace, solve
from tumblemc.kernels.residual import Problem
from tumblemc.model.rows import TimeGrid, simulate_rows
from tumblemc.model.solver_options import SolverOptions

H = 0.05  # scaled step length of the test problems


def flight(seed: int, h: float = H) -> tuple[np.ndarray, Problem]:
    """A random free-flight step (no contact block): warm start and problem."""
    z, sc, prm, ctype, cdata, pstart = make_problem("cuboid", seed, False, 0.3, h, 0.0)
    return z[:6].copy(), Problem(sc, prm, ctype, cdata, pstart[:1])


def next_step(prob: Problem, seed: int, rel: float = 1e-3) -> Problem:
    """The same system a step later: start velocities and forces moved by ``rel``."""
    rng = np.random.default_rng(seed + 1000)
    sc = prob.sc.copy()
    for a in (L.S_V, L.S_W, L.S_FEXT, L.S_TM):
        sc[a : a + 3] *= 1.0 + rel * rng.normal(size=3)
    return Problem(sc, prob.prm, prob.ctype, prob.cdata, prob.pstart)


def newton(z0: np.ndarray, prob: Problem, o: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
    z = z0.copy()
    out = np.zeros(3, np.int64)
    st, _ = solve(z, prob, make_workspace(z.size), o, out, False, 0.0, False)
    return st, z, out


OPTS = SolverOptions(chord_iter=4).as_array()
TOL = OPTS[L.O_TOL]


@pytest.mark.parametrize("seed", range(6))
def test_chord_start_solves_the_next_step_without_a_jacobian(seed: int) -> None:
    z0, prob = flight(seed)
    ws = make_workspace(6)
    out = np.zeros(3, np.int64)
    z = z0.copy()
    st, _ = solve(z, prob, ws, OPTS, out, False, 0.0, False)
    assert st == L.ST_OK and ws.lu_h[0] == H  # factors of a plain Newton matrix of this step length
    prob2 = next_step(prob, seed)
    ws.J[:] = np.nan  # any Jacobian formed would overwrite this
    zc = z.copy()
    st, res = solve(zc, prob2, ws, OPTS, out, False, 0.0, True)
    assert st == L.ST_OK and res <= TOL
    assert 1 <= out[0] <= OPTS[L.O_CHORD] and out[1] == 0
    assert np.isnan(ws.J).all(), "the chord start formed a Jacobian"
    st_n, zn, _ = newton(z, prob2, OPTS)
    assert st_n == L.ST_OK
    assert np.abs(zc - zn).max() <= 1e-8 * (1.0 + np.abs(zn).max())


def test_factors_of_another_step_length_are_not_used() -> None:
    z0, prob = flight(1)
    ws = make_workspace(6)
    out = np.zeros(3, np.int64)
    z = z0.copy()
    assert solve(z, prob, ws, OPTS, out, False, 0.0, False)[0] == L.ST_OK
    z_half, half = flight(1, h=H / 2)
    ws.J[:] = np.nan
    st, _ = solve(z_half, half, ws, OPTS, out, False, 0.0, True)
    assert st == L.ST_OK and not np.isnan(ws.J).any()  # Newton, with its own Jacobian
    assert ws.lu_h[0] == H / 2


def test_levenberg_marquardt_clears_the_factors() -> None:
    z0, prob = flight(2)
    ws = make_workspace(6)
    out = np.zeros(3, np.int64)
    assert solve(z0.copy(), prob, ws, OPTS, out, False, 0.0, False)[0] == L.ST_OK
    assert ws.lu_h[0] == H
    g = np.ones(6)
    assert _lm_direction(np.eye(6), np.ones(6), g, np.zeros(6), 6, 1.0, ws)
    assert ws.lu_h[0] == 0.0  # A now holds J^T J + nu I's factors


def test_stale_factors_hand_over_to_newton() -> None:
    """Factors of a very different matrix (same size and step length) do not contract: Newton takes over."""
    z0, prob = flight(3)
    ws = make_workspace(6)
    out = np.zeros(3, np.int64)
    assert solve(z0.copy(), prob, ws, OPTS, out, False, 0.0, False)[0] == L.ST_OK
    z_other, other = flight(4)
    ws.J[:] = np.nan
    zc = z_other.copy()
    st, res = solve(zc, other, ws, OPTS, out, False, 0.0, True)
    assert st == L.ST_OK and res <= TOL
    assert not np.isnan(ws.J).any()  # Newton formed its Jacobian
    st_n, zn, _ = newton(z_other, other, OPTS)
    assert st_n == L.ST_OK and np.abs(zc - zn).max() <= 1e-8 * (1.0 + np.abs(zn).max())


@pytest.mark.parametrize("seed", range(3))
def test_chord_off_is_newton_bit_for_bit(seed: int) -> None:
    off = SolverOptions(chord_iter=0).as_array()
    z0, prob = flight(seed)
    ws = make_workspace(6)
    out = np.zeros(3, np.int64)
    z = z0.copy()
    assert solve(z, prob, ws, off, out, False, 0.0, False)[0] == L.ST_OK
    prob2 = next_step(prob, seed)
    zc = z.copy()
    out_c = np.zeros(3, np.int64)
    st, res = solve(zc, prob2, ws, off, out_c, False, 0.0, True)
    zn = z.copy()
    out_n = np.zeros(3, np.int64)
    st_n, res_n = solve(zn, prob2, make_workspace(6), off, out_n, False, 0.0, False)
    assert (st, res) == (st_n, res_n)
    assert zc.tobytes() == zn.tobytes() and out_c.tolist() == out_n.tolist()


def test_climbing_run_agrees_with_newton_to_the_tolerance() -> None:
    """Paper robot, 45 deg, 10 Hz, 0.3 s: chord start against a fresh Jacobian at every iteration."""
    kw = {"shape": "cuboid", "preset": "paper", "incline_deg": 45.0, "freq_hz": 10.0, "duration_s": 0.3}
    a = tumblemc.simulate(**kw, solver=SolverOptions(chord_iter=0))
    b = tumblemc.simulate(**kw, solver=SolverOptions(chord_iter=4))
    # the chord iterations are counted: about two per step instead of about one Newton iteration
    assert float(b["newton_iterations"].sum()) > 1.3 * float(a["newton_iterations"].sum())
    for ds in (a, b):
        assert int(ds["failed"].sum()) == 0 and int(ds["loose"].sum()) == 0
        assert float(ds["residual"].max()) <= SolverOptions().tol
    length = 1e-4  # the scaled length unit (m): the solutions agree to tol of it and the rocking amplifies that a little
    assert float(np.abs(a["position"] - b["position"]).max()) <= 1e-6 * length
    assert float(np.abs(a["quaternion"] - b["quaternion"]).max()) <= 1e-6
    sa, sb = tumblemc.summarize(a), tumblemc.summarize(b)
    assert sb["progress_ratio"] == pytest.approx(sa["progress_ratio"], rel=1e-6)


def test_a_run_does_not_use_its_batch_mates_factors() -> None:
    """The batch kernel reuses its buffers from run to run; each run starts without factors."""
    rows = [
        {"preset": "aluminum", "incline_deg": 20.0, "field_mT": 20.0, "freq_hz": 10.0, "mu": 0.5},
        {"preset": "paper", "incline_deg": 30.0, "field_mT": 18.0, "freq_hz": 10.0, "offset_deg": 20.0},
    ]
    grid = TimeGrid(periods=2.0, transient_periods=1.0)
    both = simulate_rows("cuboid", rows, grid)
    alone = simulate_rows("cuboid", rows[1:], grid)
    for k, v in alone.items():
        assert np.asarray(both[k])[1:].tobytes() == np.asarray(v).tobytes(), k
