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
