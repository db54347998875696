"""Landings that no solve strategy solved (docs/notes/solver_gaps.md, issue 13).

Two steps, saved with the state and warm start the time loop had before them, that every
strategy and every halving used to fail (the best attempt was kept, a failed step):

- ``edge``: an edge whose second end lands while the first rests on the plane (a 3-D run of
  the paper robot, seed 2019 run 1 of the out-of-plane family, momentum form, t = 1.5439 s):
  the single ECP must move inside the edge while an impact stops the roll (guess 8);
- ``impact``: a fast frictional edge landing of the aluminum robot (issue 13 reproducer 1 at
  dt / 4, t = 0.4024 s), where the impact reverses the slip so every sliding guess pushes
  friction the wrong way (guess 9, the rigid-body impact);
- ``line``: the aluminum robot resting on its long bottom edge, exactly level, while it rolls
  one end into the plane (stress 3-D run 39 with ``warm_order=4``, t = 0.5111 s): the
  solution sticks along the whole edge with the ECP inside it (guess 10, the impact of a level
  edge; saved by ``tests/data/line_landing.py``);
- ``spin``: the aluminum robot, thrown up by the field, landing on a vertex while it turns
  about the normal at 426 rad/s (run 110 of ``three_d_runs(n=400, seed=2)``, t = 0.0423 s):
  the torsional friction stops the turn within the step (guess 11, the point impact that
  sticks in torsion too; also saved by ``tests/data/line_landing.py``);
- ``pivot``: an edge landing of reproducer 1 at dt = 3.125e-6 s (t = 0.42259 s) whose
  sticking impact has a regular Newton matrix that ``lu_factor`` called singular, because
  the torsional friction row (``mu e_r lam_n``) is 3e6 times the unit rows at an impact
  force of 3,194 (scaled): solved since the pivot test looks at the pivot's own row
  (docs/notes/solver_gaps.md, section 7; also saved by ``tests/data/line_landing.py``).

The slow tests run the whole reproducers. The ``impact`` state sits 1.3 cm from the origin,
so the time loop now moves its origin first (``recording.recentre``, docs/notes/solver_gaps.md, section 3).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

import tumblemc
from tests.tooling import load_tool, one_step
from tumblemc.claims import SNAP_HOP
from tumblemc.kernels import layout as L
from tumblemc.kernels.field import field_work_bound
from tumblemc.kernels.stepper import Model
from tumblemc.model.run import prepare, run_inputs
from tumblemc.model.shapes.library import get_shape

DATA = Path(__file__).resolve().parents[1] / "data" / "landing_steps.npz"
OUT_OF_PLANE_2019_1 = {"offset_deg": 19.553717386076162, "offset_axis": (-0.8541623, -0.69975145, -1.01436414)}
REPRO_1 = {**SNAP_HOP, "duration_s": 4.0}
CASES = {
    "edge": {"preset": "paper", "incline_deg": 0.0, "duration_s": 2.0, **OUT_OF_PLANE_2019_1},
    "impact": {**REPRO_1, "dt": 1.25e-5},
    "line": {**load_tool("line_landing").run_39(), "duration_s": 0.6},
    "spin": {**load_tool("line_landing").run_2_110(), "duration_s": 0.6},
    "pivot": {**REPRO_1, "dt": 3.125e-6},
}


@pytest.mark.parametrize("case", ["edge", "impact", "line", "spin", "pivot"])
def test_saved_landing_step_converges(case: str) -> None:
    spec = prepare(run_inputs(get_shape("cuboid"), rotation="momentum", **CASES[case]))  # type: ignore[arg-type]
    (status, failed, _), row, _, _ = one_step(np.load(DATA), spec, f"{case}_")
    assert status == L.ST_OK and failed == 0
    assert row[L.R_RES] <= spec.solver.tol
    assert row[L.R_LN] > 0.0  # it landed
    if case == "pivot":
        # Newton solves it once the matrix is factored: a few strategies, no sub-step (before
        # the row test: 741,372 iterations over every strategy and 8 halvings, then failed)
        assert row[L.R_NIT] < 100 and row[L.R_SUB] == 0
    else:
        assert row[L.R_NIT] > 100  # still a hard step: the warm start alone does not solve it
    if case == "line":
        # energy made: 2.3e-3 m g x 0.1 mm, positive normal work that halves with the step (first
        # order, as at every landing: docs/notes/solver_gaps.md, section 4), below the landing
        # refinement's threshold: landing_work x (m g x 0.1 mm + the field's work bound per step)
        assert row[L.R_LED + L.L_GAIN] <= spec.solver.landing_work * (1.0 + field_work_bound(spec.prm, spec.h))
    else:
        assert row[L.R_LED + L.L_GAIN] <= 1e-3  # energy made: under 0.1% of m g x 0.1 mm


@pytest.mark.slow
def test_out_of_plane_family_has_no_failed_step() -> None:
    """The 20 runs of seed 2019 (tumblemc.claims.nonplanar), momentum form."""
    rng = np.random.default_rng(2019)
    for _ in range(20):
        axis = rng.normal(size=3)
        ang = float(rng.uniform(0.0, 30.0))
        ds = tumblemc.simulate(preset="paper", incline_deg=0.0, offset_deg=ang, offset_axis=tuple(axis), duration_s=2.0)
        assert ds.attrs["failed_steps"] == 0 and ds.attrs["status"] == 0


@pytest.mark.slow
def test_reproducer_1_has_no_failed_landing_at_dt_and_dt_over_4() -> None:
    """Issue 13, reproducer 1: 4 failed landings at dt / 4 before guess 9, none now."""
    ratios = []
    for dt in (5e-5, 1.25e-5):
        ds = tumblemc.simulate(shape="cuboid", dt=dt, record_every=4, **REPRO_1)  # type: ignore[arg-type]
        s = tumblemc.summarize(ds)
        assert s["failed_steps"] == 0 and s["status"] == 0
        ratios.append(s["progress_ratio"])
    # the hop is the model (docs/notes/energy_ledger.md); how far dt and dt / 4 agree is measured in
    # docs/notes/energy_ledger.md: 23.7 and 20.1, 18% of the dt/4 ratio apart, above the 10%
    assert abs(ratios[1] - ratios[0]) <= 0.2 * abs(ratios[1])


@pytest.mark.slow
def test_reproducer_2_stays_near_the_plane() -> None:
    """Issue 13, reproducer 2 (aluminum, offset 30 deg about body z).

    The paper form flew 2 m high; the momentum form hops at most 2.4 mm, with no failed step
    and no energy gain.
    """
    ds = tumblemc.simulate(preset="aluminum", incline_deg=0.0, duration_s=2.0, offset_deg=30.0, offset_axis=(0.0, 0.0, 1.0))
    assert ds.attrs["failed_steps"] == 0 and ds.attrs["status"] == 0
    assert float(ds["position"][:, 2].max()) < 3e-3
    assert ds.attrs["energy_gain_ratio"] < 1e-3


def _line_step() -> tuple[Any, np.ndarray, np.ndarray]:
    d = np.load(DATA)
    spec = prepare(run_inputs(get_shape("cuboid"), rotation="momentum", **CASES["line"]))  # type: ignore[arg-type]
    return spec, d["line_state"].copy(), d["line_z"].copy()


def _rot(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


@pytest.mark.parametrize("mu", [100.0, None])
def test_line_impact_guess_stops_the_whole_edge(mu: float | None) -> None:
    """Guess 10 against a NumPy twin on the saved level-edge state.

    With a friction coefficient that does not cut the impulse (mu = 100) the guess leaves the
    edge's middle at rest and neither roll nor turn (the five conditions), the ECP inside the
    edge, and forces whose wrench about the predicted centre of mass is the angular impulse
    the guess gave: ``I (w+ - w) = h ((a1 - x - h v) x F + lam_r n)``. With the robot's own mu,
    the tangential impulse lies in the friction cone.
    """
    from tumblemc.kernels.geometry import N_CG, N_QS
    from tumblemc.kernels.impacts import impact_guess
    from tumblemc.kernels.layout import N_SC, S_FEXT
    from tumblemc.kernels.runtypes import Scratch
    from tumblemc.kernels.support import level_edge

    spec, state, z = _line_step()
    prm = spec.prm.copy()
    if mu is not None:
        prm[L.P_MU] = mu
    geo = spec.geo
    scr = Scratch(
        sc=np.zeros(N_SC), R=np.zeros(9), tmp=np.zeros(3), tmp2=np.zeros(3), tmp3=np.zeros(3),
        cg=np.zeros(N_CG), qs=np.zeros(N_QS), iters=np.zeros(3, np.int64), prob=None, prob6=None, hts=np.zeros(8),
    )  # fmt: skip
    fext = np.array([0.1, -0.3, -1.2])
    scr.sc[S_FEXT : S_FEXT + 3] = fext
    R = _rot(state[3:7])
    edge = np.zeros(3)
    half = level_edge(state[0:3], R.ravel(), prm, geo, 0, 1e-3, edge)
    # twin: the two lowest vertices of the cuboid, level at this pose
    verts = state[0:3] + geo.sup_pts[:8] @ R.T
    hts = verts @ prm[L.P_N : L.P_N + 3]
    lo = np.argsort(hts)[:2]
    assert abs(hts[lo[0]] - hts[lo[1]]) < 1e-12 and np.sort(hts)[2] > 0.1
    assert half == pytest.approx(0.5 * np.linalg.norm(verts[lo[1]] - verts[lo[0]]), rel=1e-14)
    assert abs(abs(edge @ (verts[lo[1]] - verts[lo[0]])) - 2 * half) < 1e-12
    mid = verts[lo].mean(axis=0)
    z[6:9] = mid
    z[9:12] = mid
    h = spec.h
    assert impact_guess(z, 6, 6, state, h, Model(prm, geo), scr, edge, half)
    n = prm[L.P_N : L.P_N + 3]
    v_plus = z[0:3] - h * fext
    w_plus = z[3:6]
    r = mid - state[0:3] - h * state[7:10]
    ib = prm[L.P_IB : L.P_IB + 9].reshape(3, 3)
    iw = R @ ib @ R.T
    s = (z[6:9] - mid) @ edge
    assert abs(s) <= half * (1 + 1e-12) and np.allclose(z[6:9] - mid, s * edge, atol=1e-12)
    assert np.allclose(z[9:12] - z[6:9], 0.0)
    ln = z[23] - max(-(n @ fext), 0.0)
    F = ln * n + z[12] * prm[L.P_T : L.P_T + 3] + z[13] * prm[L.P_O : L.P_O + 3]
    assert ln > 0 and z[15] == 0.0  # it pushes; sigma = 0 (sticking)
    if mu is None:  # the robot's mu: in the cone
        assert np.hypot(z[12], z[13]) <= spec.prm[L.P_MU] * ln * (1 + 1e-12)
        return
    u = np.cross(edge, n)
    u /= np.linalg.norm(u)
    scale = np.abs(state[7:13]).max()
    assert np.abs(v_plus + np.cross(w_plus, r)).max() < 1e-12 * scale
    assert abs(w_plus @ u) < 1e-12 * scale and abs(w_plus @ n) < 1e-12 * scale
    assert np.allclose(v_plus - state[7:10], h * F, rtol=0, atol=1e-12 * np.abs(h * F).max())
    lever = z[6:9] - state[0:3] - h * state[7:10]
    wrench = np.cross(lever, F) + z[14] * n
    assert np.allclose(iw @ (w_plus - state[10:13]), h * wrench, rtol=0, atol=1e-11 * np.abs(h * wrench).max())


def test_point_impact_guess_sticks_in_torsion() -> None:
    """Guess 11 against a NumPy twin on the saved spinning landing (``half < 0``).

    The impulse at the ECP (which stays at the landing vertex) and the angular impulse about
    ``n`` leave the contact point at rest and the turn about ``n`` stopped, and the forces'
    wrench about the predicted centre of mass is the angular impulse the guess gave.
    """
    from tumblemc.kernels.geometry import N_CG, N_QS
    from tumblemc.kernels.impacts import impact_guess
    from tumblemc.kernels.layout import N_SC, S_FEXT
    from tumblemc.kernels.runtypes import Scratch

    d = np.load(DATA)
    spec = prepare(run_inputs(get_shape("cuboid"), rotation="momentum", **CASES["spin"]))  # type: ignore[arg-type]
    state, z = d["spin_state"].copy(), d["spin_z"].copy()
    prm = spec.prm.copy()
    prm[L.P_MU] = 100.0  # no cut to the cone
    scr = Scratch(
        sc=np.zeros(N_SC), R=np.zeros(9), tmp=np.zeros(3), tmp2=np.zeros(3), tmp3=np.zeros(3),
        cg=np.zeros(N_CG), qs=np.zeros(N_QS), iters=np.zeros(3, np.int64), prob=None, prob6=None, hts=np.zeros(8),
    )  # fmt: skip
    fext = np.array([0.0, 0.0, -1.0])
    scr.sc[S_FEXT : S_FEXT + 3] = fext
    R = _rot(state[3:7])
    n = prm[L.P_N : L.P_N + 3]
    verts = state[0:3] + spec.geo.sup_pts[:8] @ R.T
    low = verts[np.argmin(verts @ n)]
    z[6:9] = low
    z[9:12] = low
    h = spec.h
    assert abs(state[10:13] @ n) > 1.0  # turning fast about n (scaled; 426 rad/s)
    assert impact_guess(z, 6, 6, state, h, Model(prm, spec.geo), scr, np.zeros(3), -1.0)
    assert np.array_equal(z[6:9], low)  # the ECP stays at the vertex
    v_plus = z[0:3] - h * fext
    w_plus = z[3:6]
    r = low - state[0:3] - h * state[7:10]
    scale = np.abs(state[7:13]).max()
    assert np.abs(v_plus + np.cross(w_plus, r)).max() < 1e-12 * scale
    assert abs(w_plus @ n) < 1e-12 * scale
    ln = z[23] - max(-(n @ fext), 0.0)
    F = ln * n + z[12] * prm[L.P_T : L.P_T + 3] + z[13] * prm[L.P_O : L.P_O + 3]
    assert ln > 0.0 and z[15] == 0.0
    iw = R @ prm[L.P_IB : L.P_IB + 9].reshape(3, 3) @ R.T
    wrench = np.cross(r, F) + z[14] * n
    assert np.allclose(iw @ (w_plus - state[10:13]), h * wrench, rtol=0, atol=1e-11 * np.abs(h * wrench).max())
    assert abs(z[14]) > 1.0  # a torsional force: the turn is stopped by friction about n


def test_level_edge_refuses_a_vertex_and_a_face() -> None:
    """``level_edge`` returns 0 unless exactly two support points are within tol of the lowest."""
    from tumblemc.kernels.support import level_edge

    spec, state, _ = _line_step()
    edge = np.zeros(3)
    R = _rot(state[3:7])
    assert level_edge(state[0:3], R.ravel(), spec.prm, spec.geo, 0, 1e-3, edge) > 0.0
    # the same pose tilted about the plane normal's perpendicular: one vertex lowest
    tilt = np.cross(edge, spec.prm[L.P_N : L.P_N + 3])
    tilt /= np.linalg.norm(tilt)
    c, s_ = np.cos(0.01), np.sin(0.01)
    K = np.array([[0, -tilt[2], tilt[1]], [tilt[2], 0, -tilt[0]], [-tilt[1], tilt[0], 0]])
    Rv = (np.eye(3) + s_ * K + (1 - c) * K @ K) @ R
    edge_v = np.zeros(3)
    assert level_edge(state[0:3], Rv.ravel(), spec.prm, spec.geo, 0, 1e-3, edge_v) == 0.0
    # lying flat on its bottom face (body z along the plane normal): four points tie
    n = spec.prm[L.P_N : L.P_N + 3]
    t = spec.prm[L.P_T : L.P_T + 3]
    flat = np.column_stack([t, np.cross(n, t), n])
    assert level_edge(np.zeros(3), flat.ravel(), spec.prm, spec.geo, 0, 1e-3, edge_v) == 0.0
    # turned 0.5 deg about t: two points, the edge along t
    c, s_ = np.cos(0.0087), np.sin(0.0087)
    turn = np.array([[1, 0, 0], [0, c, -s_], [0, s_, c]])
    assert level_edge(np.zeros(3), (turn @ flat).ravel(), spec.prm, spec.geo, 0, 1e-3, edge_v) > 0.0


@pytest.mark.slow
def test_stress_3d_run_39_with_the_quartic_warm_start_has_no_failed_step() -> None:
    """Stress campaign 3-D run 39 (tumblemc.stress.three_d_runs, seed 2026): aluminum, 20 deg.

    With ``warm_order=4`` its path meets the level-edge landing of ``line`` at t = 0.5111 s,
    which no strategy solved at any depth before guess 10 (a failed step, 1e6 Newton
    iterations; a strict xfail until 2026-11-28).
    """
    from tumblemc.model.solver_options import SolverOptions

    ds = tumblemc.simulate(shape="cuboid", duration_s=2.0, solver=SolverOptions(warm_order=4), **load_tool("line_landing").run_39())
    assert ds.attrs["failed_steps"] == 0 and ds.attrs["status"] == 0
    assert ds.attrs["energy_gain_ratio"] < 1e-2
