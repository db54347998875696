"""The rows' rounding scales (``kernels.rounding``) and the stop within them.

The scales must cover what one unit in the last place of any unknown does to a row (else a
stall on rounding would go unrecognised), and the stop must end a solve only where no row
can get closer to zero: the tiny-step landing of ``tests/data/tiny_step_landing.py``.
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.kernels.test_kernels import GEOMETRIES, kernel, make_problem
from tumblemc.kernels.residual import Problem


def _scales(z: np.ndarray, sc: np.ndarray, prm: np.ndarray, ctype: np.ndarray, cdata: np.ndarray, pstart: np.ndarray) -> np.ndarray:
    from tumblemc.kernels.rounding import rounding_scales

    out = np.zeros(z.size)
    rounding_scales(z, Problem(sc, prm, ctype, cdata, pstart), out)
    return out


@pytest.mark.parametrize("geom", sorted(GEOMETRIES))
@pytest.mark.parametrize("h", [0.05, 5e-6])
def test_the_scales_cover_one_ulp_of_every_unknown(geom: str, h: float) -> None:
    """One ulp up or down of any unknown moves no row by more than its rounding allowance.

    And the allowance is not loose: the largest such move is within 20x of it. (An unknown at
    exactly zero is skipped: its ulp is a subnormal number, and a row whose terms vanish with
    it, such as the friction rows at ``lam_n = 0``, is allowed no residual at all.)
    """
    from tumblemc.kernels.rounding import EPS, ROUND_ULPS

    worst = 0.0
    for seed in range(12):
        z, sc, prm, ctype, cdata, pstart = make_problem(geom, seed, seed % 2 == 0, 0.3 * (seed % 3), h, 0.3)
        allow = ROUND_ULPS * EPS * _scales(z, sc, prm, ctype, cdata, pstart)
        base = kernel(z, sc, prm, ctype, cdata, pstart, want_J=False)[0]
        for j in np.flatnonzero(z):
            for direction in (np.inf, -np.inf):
                zu = z.copy()
                zu[j] = np.nextafter(z[j], direction)
                moved = np.abs(kernel(zu, sc, prm, ctype, cdata, pstart, want_J=False)[0] - base)
                assert np.all(moved[allow == 0.0] == 0.0)
                worst = max(worst, float((moved[allow > 0.0] / allow[allow > 0.0]).max()))
    assert 0.05 < worst <= 1.0


def test_a_landing_at_a_tiny_step_stops_within_the_rows_rounding() -> None:
    """The saved edge landing at 1.6e-8 s: solved, though no iterate can reach ``tol``.

    Its impact force is 5e5 weights, so one ulp of the friction cone's row, quadratic in the
    forces, is 6e-6. Before the rounding stop every strategy and every halving failed on it
    (42 s, 3.8 million Newton iterations, a failed step; tests/data/tiny_step_landing.py).
    """
    from tests.tooling import load_tool, one_step
    from tumblemc import SolverOptions
    from tumblemc.kernels import layout as L
    from tumblemc.kernels.contact import prepare_step
    from tumblemc.kernels.geometry import cross
    from tumblemc.kernels.rounding import EPS, ROUND_ULPS
    from tumblemc.kernels.stepper import Model, make_scratch
    from tumblemc.model.run import prepare, run_inputs

    tool = load_tool("tiny_step_landing")
    saved = np.load(tool.OUT)
    spec = prepare(run_inputs(**tool.RUN))
    (status, failed, _), row, _, buf = one_step(saved, spec)
    assert status == L.ST_OK and failed == 0 and row[L.R_LOOSE] == 0 and row[L.R_SUB] == 0
    # the step's system, rebuilt, at the solution
    scr = make_scratch(Model(spec.prm, spec.geo))
    prepare_step(saved["state"], float(saved["t"]), spec.h, spec.prm, float(saved["area"]), saved["mode"] > 0, scr)
    sc, prm = scr.sc, spec.prm
    z = buf.z.copy()
    F = kernel(z, sc, prm, spec.geo.ctype, spec.geo.cdata, spec.geo.pstart, want_J=False)[0]
    allow = ROUND_ULPS * EPS * _scales(z, sc, prm, spec.geo.ctype, spec.geo.cdata, spec.geo.pstart)
    tol = SolverOptions().tol
    cone = 6 + L.B_SIG
    assert np.abs(F).max() > tol and int(np.argmax(np.abs(F))) == cone  # tol is out of reach, in the cone's row
    assert np.all(np.abs(F) <= allow)
    # the physics of the solution: a sliding impact that reverses the slip (friction on the
    # cone, opposing the end slip, which runs against the incoming one)
    mk = int(spec.geo.pstart[1] - spec.geo.pstart[0])
    lam_n, lam_o = z[6 + L.B_L + mk + 1], z[6 + L.B_LO]
    assert lam_n > 1e5 and lam_o == pytest.approx(prm[L.P_MU] * lam_n, rel=1e-6)
    r = z[6:9] - (sc[L.S_X : L.S_X + 3] + spec.h * z[0:3])
    wxr = np.zeros(3)
    cross(z, 3, r, 0, wxr, 0)
    o = prm[L.P_O : L.P_O + 3]
    start_state = saved["state"]
    wxr0 = np.zeros(3)
    cross(start_state, 10, r, 0, wxr0, 0)
    slip_in, slip_out = float(o @ (start_state[7:10] + wxr0)), float(o @ (z[0:3] + wxr))
    assert slip_in > 0.1 and slip_out < -0.1
