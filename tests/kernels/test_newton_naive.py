"""The Newton solve against a slow, obvious twin on tiny problems.

``kernels.newton.solve`` (sparse LU with row tests, Armijo line search, Levenberg-Marquardt
fallback, chord starts) is compared with :func:`naive_newton`: textbook damped Newton on
:func:`tests.naive.naive_residual` (written from the equations, not from the kernel) with a
central-difference Jacobian and ``numpy.linalg.solve``. Started from the same point, both
must reach the same root: the free-flight step (6 unknowns, smooth, one root near the
start) always, and a resting contact step (one piece, 24 unknowns, semismooth) whenever
the twin converges.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from tests.kernels.test_kernels import make_problem
from tests.naive import naive_residual
from tumblemc.kernels import layout as L
from tumblemc.kernels.newton import make_workspace, solve
from tumblemc.kernels.residual import Problem
from tumblemc.kernels.rounding import momentum_floor
from tumblemc.model.solver_options import SolverOptions

OPTS = SolverOptions().as_array()
TOL = OPTS[L.O_TOL]
#: the two roots agree to this, relative to the root's size (both are solved to TOL)
ROOT_REL = 1e-6


def fd_jacobian(F: Callable[[np.ndarray], np.ndarray], z: np.ndarray) -> np.ndarray:
    """Central differences, one column per unknown."""
    n = z.size
    J = np.zeros((n, n))
    for j in range(n):
        dz = 1e-6 * (1.0 + abs(z[j]))
        zp, zm = z.copy(), z.copy()
        zp[j] += dz
        zm[j] -= dz
        J[:, j] = (F(zp) - F(zm)) / (2.0 * dz)
    return J


def naive_newton(F: Callable[[np.ndarray], np.ndarray], z0: np.ndarray, tol: float, maxit: int = 60) -> tuple[bool, np.ndarray]:
    """Damped Newton: full step, halved until ``||F||_2`` falls (Armijo, 1e-4); ``(converged, z)``."""
    z = z0.copy()
    f = F(z)
    for _ in range(maxit):
        if np.abs(f).max() <= tol:
            return True, z
        try:
            d = np.linalg.solve(fd_jacobian(F, z), -f)
        except np.linalg.LinAlgError:
            return False, z
        t, fn0 = 1.0, np.linalg.norm(f)
        while t > 1e-12:
            zt = z + t * d
            ft = F(zt)
            if np.linalg.norm(ft) <= (1.0 - 1e-4 * t) * fn0:
                break
            t *= 0.5
        else:
            return False, z
        z, f = zt, ft
    return bool(np.abs(f).max() <= tol), z


def kernel_solve(z0: np.ndarray, prob: Problem) -> tuple[int, np.ndarray]:
    z = z0.copy()
    out = np.zeros(3, np.int64)
    st, _ = solve(z, prob, make_workspace(z.size), OPTS, out, False, 0.0, False)
    return st, z


@pytest.mark.parametrize("seed", range(8))
def test_free_flight_step_reaches_the_twins_root(seed: int) -> None:
    z, sc, prm, ctype, cdata, pstart = make_problem("cuboid", seed, False, 0.3, 0.05, 0.0)
    z0 = z[:6].copy()
    prob = Problem(sc, prm, ctype, cdata, pstart[:1])

    def F(zz: np.ndarray) -> np.ndarray:
        return np.asarray(naive_residual(zz, sc, prm, ctype, cdata, pstart[:1]), dtype=float)

    ok, z_twin = naive_newton(F, z0, TOL)
    st, z_kernel = kernel_solve(z0, prob)
    assert ok, "the twin did not converge on a smooth 6-unknown system"
    assert st == L.ST_OK
    assert np.abs(F(z_kernel)).max() <= 10 * TOL, "the kernel's root is not a root of the twin's residual"
    assert np.abs(z_kernel - z_twin).max() <= ROOT_REL * (1.0 + np.abs(z_twin).max())


def _fast_spin_flight(h: float, seed: int = 3) -> tuple[np.ndarray, Problem]:
    """A free-flight step of the paper cuboid (its scaled inertia) spinning at 20 scaled units (6000 rad/s)."""
    z, sc, prm, ctype, cdata, pstart = make_problem("cuboid", seed, False, 0.3, h, 0.0)
    prm[L.P_MASS] = 1.0
    prm[L.P_IB : L.P_IB + 9] = np.diag([65.0, 17.0, 80.0]).ravel() / 12.0  # 5.42, 1.42, 6.67
    sc[L.S_W : L.S_W + 3] *= 20.0 / np.abs(sc[L.S_W : L.S_W + 3]).sum()
    z[3:6] = sc[L.S_W : L.S_W + 3]
    return z[:6].copy(), Problem(sc, prm, ctype, cdata, pstart[:1])


def test_the_rounding_floor_is_below_tol_at_the_papers_step() -> None:
    """At 5e-5 s (0.0157 scaled) a 6000 rad/s spin leaves the test at tol alone."""
    _, prob = _fast_spin_flight(0.0157)
    assert momentum_floor(prob) < 0.05 * TOL


@pytest.mark.parametrize("seed", range(4))
def test_a_fast_spin_at_a_tiny_step_stops_on_its_rounding_floor(seed: int) -> None:
    """The solve stops within the rounding floor, which covers the rows' resolution.

    At 1.8e-8 s (5.8e-6 scaled) one ulp of w+ moves the rows by about tol: the solve stops
    within the floor, without the fallbacks that tol alone cost (the old rule: 480,000 of
    them in 16,000 such steps, docs/notes/step_size.md), and the floor covers that
    resolution without being far above it.
    """
    z0, prob = _fast_spin_flight(5.8e-6, seed)
    z = z0.copy()
    out = np.zeros(3, np.int64)
    st, res = solve(z, prob, make_workspace(6), OPTS, out, False, 0.0, False)
    floor = momentum_floor(prob)
    assert floor > TOL
    assert st == L.ST_OK and out[1] == 0 and out[0] <= 4
    assert res <= floor

    def F(zz: np.ndarray) -> np.ndarray:
        return np.asarray(naive_residual(zz, prob.sc, prob.prm, prob.ctype, prob.cdata, prob.pstart), dtype=float)

    base = F(z)
    resolution = 0.0  # how far the rows move for one ulp of a component of w+
    for j in range(3, 6):
        zu = z.copy()
        zu[j] = np.nextafter(z[j], np.inf)
        resolution = max(resolution, float(np.abs(F(zu) - base).max()))
    assert 0.3 * TOL < resolution <= floor <= 100.0 * resolution
