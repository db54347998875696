"""The hard-steps suite: the solver on the steps that once broke it, replayed from saved starts.

Each section is one family of hard steps (``tests/data/*.npz``, written by the generator
beside it, replayed with ``tests.tooling.one_step``) or the solver option that handles
them, with its out-of-range values refused: landings that no strategy solved and the guesses
that solve them (docs/notes/solver_gaps.md), fast landings refined in sub-steps
(``landing_work``), late landings (``refine_halvings``), the rescue pass (``rescue_iter``),
skipped smoothing (``smooth_stalled``) and the smoothing's stall window (``stall_window``).
The section comments keep each family's story.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

import tumblemc
from tests.tooling import load_tool, one_step
from tumblemc.kernels import layout as L
from tumblemc.kernels.field import field_work_bound
from tumblemc.kernels.stepper import Model, Start
from tumblemc.model.run import prepare, run_inputs
from tumblemc.model.shapes.library import get_shape
from tumblemc.model.solver_options import SolverOptions
from tumblemc.testing import SNAP_HOP, SNAP_HOP_DT

# ---- Landings no strategy solved: the saved steps and their guesses ----------------------
# Landings that no solve strategy solved (docs/notes/solver_gaps.md).
#
# Two steps, saved with the state and warm start the time loop had before them, that every
# strategy and every halving used to fail (the best attempt was kept, a failed step):
#
# - ``edge``: an edge whose second end lands while the first rests on the plane (a 3-D run of
#   the paper robot, seed 2019 run 1 of the out-of-plane family, momentum form, t = 1.5439 s):
#   the single ECP must move inside the edge while an impact stops the roll (guess 8);
# - ``impact``: a fast frictional edge landing of the aluminum robot (the snap hop at
#   dt / 4, t = 0.4024 s), where the impact reverses the slip so every sliding guess pushes
#   friction the wrong way (guess 9, the rigid-body impact);
# - ``line``: the aluminum robot resting on its long bottom edge, exactly level, while it rolls
#   one end into the plane (stress 3-D run 39 with ``warm_order=4``, t = 0.5111 s): the
#   solution sticks along the whole edge with the ECP inside it (guess 10, the impact of a level
#   edge; saved by ``tests/data/line_landing.py``);
# - ``spin``: the aluminum robot, thrown up by the field, landing on a vertex while it turns
#   about the normal at 426 rad/s (run 110 of ``three_d_runs(n=400, seed=2)``, t = 0.0423 s):
#   the torsional friction stops the turn within the step (guess 11, the point impact that
#   sticks in torsion too; also saved by ``tests/data/line_landing.py``);
# - ``pivot``: an edge landing of reproducer 1 at dt = 3.125e-6 s (t = 0.42259 s) whose
#   sticking impact has a regular Newton matrix that ``lu_factor`` called singular, because
#   the torsional friction row (``mu e_r lam_n``) is 3e6 times the unit rows at an impact
#   force of 3,194 (scaled): solved since the pivot test looks at the pivot's own row
#   (docs/notes/solver_gaps.md, section 7; also saved by ``tests/data/line_landing.py``).
#
# The slow tests run the whole reproducers. The ``impact`` state sits 1.3 cm from the origin,
# so the time loop now moves its origin first (``recording.recentre``, docs/notes/solver_gaps.md, section 3).


LANDING_DATA = Path(__file__).resolve().parents[1] / "data" / "landing_steps.npz"
OUT_OF_PLANE_2019_1 = {"offset_deg": 19.553717386076162, "offset_axis": (-0.8541623, -0.69975145, -1.01436414)}
REPRO_1 = {**SNAP_HOP, "dt": SNAP_HOP_DT, "duration_s": 4.0}
LANDING_CASES = {
    "edge": {"preset": "paper", "incline_deg": 0.0, "duration_s": 2.0, **OUT_OF_PLANE_2019_1},
    "impact": {**REPRO_1, "dt": 1.25e-5},
    "line": {**load_tool("line_landing").run_39(), "duration_s": 0.6},
    "spin": {**load_tool("line_landing").run_2_110(), "duration_s": 0.6},
    "pivot": {**REPRO_1, "dt": 3.125e-6},
}


@pytest.mark.parametrize("case", ["edge", "impact", "line", "spin", "pivot"])
def test_saved_landing_step_converges(case: str) -> None:
    spec = prepare(run_inputs(get_shape("cuboid"), rotation="momentum", **LANDING_CASES[case]))  # type: ignore[arg-type]
    (status, failed, _), row, _, _ = one_step(np.load(LANDING_DATA), spec, f"{case}_")
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
    """The 20 runs of seed 2019 (tumblemc.reports.claims.nonplanar), momentum form."""
    rng = np.random.default_rng(2019)
    for _ in range(20):
        axis = rng.normal(size=3)
        ang = float(rng.uniform(0.0, 30.0))
        ds = tumblemc.simulate(preset="paper", incline_deg=0.0, offset_deg=ang, offset_axis=tuple(axis), duration_s=2.0)
        assert ds.attrs["failed_steps"] == 0 and ds.attrs["status"] == 0


@pytest.mark.slow
def test_reproducer_1_has_no_failed_landing_at_dt_and_dt_over_4() -> None:
    """Reproducer 1 of the solver's stress campaign: 4 failed landings at dt / 4 before guess 9, none now."""
    ratios = []
    for dt in (5e-5, 1.25e-5):
        ds = tumblemc.simulate(shape="cuboid", record_every=4, **{**REPRO_1, "dt": dt})  # type: ignore[arg-type]
        s = tumblemc.summarize(ds)
        assert s["failed_steps"] == 0 and s["status"] == 0
        ratios.append(s["progress_ratio"])
    # the hop is the model (docs/notes/energy_ledger.md); how far dt and dt / 4 agree is measured in
    # docs/notes/energy_ledger.md: 23.7 and 20.1, 18% of the dt/4 ratio apart, above the 10%
    assert abs(ratios[1] - ratios[0]) <= 0.2 * abs(ratios[1])


@pytest.mark.slow
def test_reproducer_2_stays_near_the_plane() -> None:
    """Reproducer 2 of the solver's stress campaign (aluminum, offset 30 deg about body z).

    The paper form flew 2 m high; the momentum form hops at most 2.4 mm, with no failed step,
    no contact gain (6e-5 of its scale) and an energy excess of 0.2% of the energy received
    (the start-of-step torque's discretisation, issue 45).
    """
    ds = tumblemc.simulate(preset="aluminum", incline_deg=0.0, duration_s=2.0, offset_deg=30.0, offset_axis=(0.0, 0.0, 1.0))
    assert ds.attrs["failed_steps"] == 0 and ds.attrs["status"] == 0
    assert float(ds["position"][:, 2].max()) < 3e-3
    assert ds.attrs["contact_gain_ratio"] < 1e-3 and ds.attrs["energy_excess_ratio"] < 5e-3


def _line_step() -> tuple[Any, np.ndarray, np.ndarray]:
    d = np.load(LANDING_DATA)
    spec = prepare(run_inputs(get_shape("cuboid"), rotation="momentum", **LANDING_CASES["line"]))  # type: ignore[arg-type]
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

    d = np.load(LANDING_DATA)
    spec = prepare(run_inputs(get_shape("cuboid"), rotation="momentum", **LANDING_CASES["spin"]))  # type: ignore[arg-type]
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
    """Stress campaign 3-D run 39 (tumblemc.reports.stress.three_d_runs, seed 2026): aluminum, 20 deg.

    With ``warm_order=4`` its path meets the level-edge landing of ``line`` at t = 0.5111 s,
    which no strategy solved at any depth before guess 10 (a failed step, 1e6 Newton
    iterations; a strict xfail until 2026-11-28).
    """
    from tumblemc.model.solver_options import SolverOptions

    ds = tumblemc.simulate(shape="cuboid", duration_s=2.0, solver=SolverOptions(warm_order=4), **load_tool("line_landing").run_39())
    assert ds.attrs["failed_steps"] == 0 and ds.attrs["status"] == 0
    assert ds.attrs["energy_gain_ratio"] < 1e-2


# ---- Fast landings refined in sub-steps (landing_work) -----------------------------------
# Fast landings refined in sub-steps (``SolverOptions.landing_work``, MODEL.md numerical traps).
#
# A robot sliding down 70 deg aluminum at metres per second crosses several thicknesses in
# one step; where it lands, the end-pose contact can throw it back out, so the converged
# normal impulse does positive work (docs/stress.md, class ``energy_gain``). Such a step is
# solved again as halves; the refinement is kept only if every sub-step converges and it
# does less positive normal work than the step it replaces. The two steps are saved by
# ``tests/data/fast_landings.py`` from stress run 122 at the paper's fixed step.


FAST_DATA = Path(__file__).resolve().parents[1] / "data" / "fast_landings.npz"
FAST_LANDINGS = load_tool("fast_landings")  # the runs the saved landings come from
RUN_122 = FAST_LANDINGS.RUN_122
SMALL_STEP = {**FAST_LANDINGS.SMALL_STEP, **SNAP_HOP}


def _fast_step(
    case: str, run_kw: dict[str, Any], solver: tumblemc.SolverOptions, dt_factor: float = 1.0
) -> tuple[Any, np.ndarray, Start, Any]:
    """One step of length ``dt_factor x dt`` from the saved start of ``case``: (status, failed, t_decided), record row, end, spec."""
    spec = prepare(run_inputs(**run_kw, solver=solver))
    out, row, start, buf = one_step(np.load(FAST_DATA), spec, f"{case}_", h=spec.h * dt_factor)
    return out, row, start, (spec, buf)


def _fast_one_step(case: str, landing_work: float, pivot_row_test: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Record row, end state and last solution of the saved step; and the refusal threshold."""
    solver = tumblemc.SolverOptions(landing_work=landing_work, pivot_row_test=pivot_row_test)
    (status, failed, _), row, start, (spec, buf) = _fast_step(case, RUN_122, solver)
    assert status == L.ST_OK and failed == 0
    scale = spec.prm[L.P_MASS] * spec.prm[L.P_G] + field_work_bound(spec.prm, spec.h)
    return row, start.state, buf.z.copy(), tumblemc.SolverOptions().landing_work * scale


def test_refined_landing_does_far_less_positive_normal_work() -> None:
    coarse, _, _, limit = _fast_one_step("refined", 0.0)
    fine, _, _, _ = _fast_one_step("refined", tumblemc.SolverOptions().landing_work)
    assert coarse[L.R_SUB] == 0 and coarse[L.R_LED + L.L_WN] > 10 * limit  # the landing the rule refuses
    assert fine[L.R_SUB] >= 2  # halved at least twice
    assert fine[L.R_LED + L.L_GAIN] < 0.05 * coarse[L.R_LED + L.L_GAIN]
    assert fine[L.R_RES] <= tumblemc.SolverOptions().tol


def test_refinement_that_stalls_keeps_the_full_step_bit_for_bit() -> None:
    """A refinement whose sub-steps stall keeps the full step, bit for bit.

    The saved landing at 17.8 m/s stalled in its sub-steps with the LU's matrix-wide pivot
    test (``pivot_row_test=0``, the rule when it was saved); with the row test they converge
    and the refinement is kept (the next test).
    """
    coarse, state0, z0, limit = _fast_one_step("kept", 0.0, 0)
    fine, state1, z1, _ = _fast_one_step("kept", tumblemc.SolverOptions().landing_work, 0)
    assert coarse[L.R_LED + L.L_WN] > 100 * limit
    assert fine[L.R_NIT] > coarse[L.R_NIT]  # it tried
    assert np.array_equal(state0, state1) and np.array_equal(z0, z1)
    skip = {L.R_NIT, L.R_FALLBACK}  # the solver's work counts the sub-steps tried
    cols = [c for c in range(fine.shape[0]) if c not in skip]
    assert np.array_equal(fine[cols], coarse[cols])


def test_fast_landing_refined_with_the_row_test() -> None:
    """With the LU's row test (the default), the 17.8 m/s landing's sub-steps converge: refined, less positive work."""
    coarse, _, _, limit = _fast_one_step("kept", 0.0)
    fine, _, _, _ = _fast_one_step("kept", tumblemc.SolverOptions().landing_work)
    assert coarse[L.R_LED + L.L_WN] > 100 * limit
    assert fine[L.R_SUB] >= 1 and fine[L.R_RES] <= tumblemc.SolverOptions().tol
    assert fine[L.R_LED + L.L_WN] < coarse[L.R_LED + L.L_WN]


def test_ordinary_runs_are_not_refined() -> None:
    """The paper's validation case and a hopping aluminum run land softly: nothing changes."""
    for kw in (
        {"preset": "paper", "incline_deg": 45.0, "duration_s": 1.0},
        {"preset": "aluminum", "incline_deg": 0.0, "freq_hz": 10.0, "duration_s": 0.3},
    ):
        a = tumblemc.simulate(**kw, solver=tumblemc.SolverOptions(landing_work=0.0))  # type: ignore[arg-type]
        b = tumblemc.simulate(**kw)  # type: ignore[arg-type]
        assert int(b["substeps"].sum()) == 0
        for v in ("position", "quaternion", "velocity", "omega", "energy_gain"):
            assert np.array_equal(a[v].values, b[v].values)


@pytest.mark.parametrize("bad", [-1e-3, 2.0, float("nan")])
def test_landing_work_out_of_range_names_the_field(bad: float) -> None:
    with pytest.raises(ValueError, match="landing_work"):
        tumblemc.SolverOptions(landing_work=bad)


def test_slow_landing_converges_at_a_longer_step() -> None:
    """The saved slow landing (reproducer 1 at dt = 5e-6 s) is solvable: at 1.5 dt it converges."""
    (status, failed, _), row, _, _ = _fast_step("small_step", SMALL_STEP, tumblemc.SolverOptions(), 1.5)
    assert status == L.ST_OK and failed == 0 and row[L.R_RES] <= tumblemc.SolverOptions().tol


def test_slow_landing_at_a_small_step_converges_with_the_row_test() -> None:
    """The saved slow landing at dt = 5e-6 s converges at dt with the LU's row test (the default).

    Its Newton matrices were called singular by the matrix-wide pivot test (docs/notes/solver_gaps.md,
    section 7), so that no strategy solved it at any depth.
    """
    (status, failed, _), row, _, _ = _fast_step("small_step", SMALL_STEP, tumblemc.SolverOptions())
    assert status == L.ST_OK and failed == 0 and row[L.R_LOOSE] == 0
    assert row[L.R_RES] <= tumblemc.SolverOptions().tol


def test_slow_landing_at_a_small_step_is_kept_loose_not_failed() -> None:
    """The saved slow landing at dt = 5e-6 s is kept as loose, not failed (``impulse_accept_tol``).

    With the LU's matrix-wide pivot test (``pivot_row_test=0``, the rule before 2026-11-28), no
    strategy solves it to ``tol`` at any depth; its best attempt balances momentum to 2e-7 of
    the impact. With the rule off (0) the step fails, as before 2026-11-27. The failed step's
    rescue pass is off too (``rescue_iter=0``): it would keep its own best attempt as failed.
    """
    P0 = {"pivot_row_test": 0, "rescue_iter": 0}
    (status, failed, _), row, end, _ = _fast_step("small_step", SMALL_STEP, tumblemc.SolverOptions(**P0))
    assert status == L.ST_OK and failed == 0 and row[L.R_LOOSE] == 1
    assert row[L.R_IMPULSE] == 1  # counted apart: kept by the impulse rule, not by accept_tol
    assert row[L.R_RES] > 0.1  # not converged in the absolute sense: the record says so
    assert row[L.R_SUB] == tumblemc.SolverOptions().max_substep_depth  # it got there at the smallest sub-step
    (status, failed, _), row0, end0, _ = _fast_step("small_step", SMALL_STEP, tumblemc.SolverOptions(impulse_accept_tol=0.0, **P0))
    assert failed == 1 and row0[L.R_LOOSE] == 0 and row0[L.R_IMPULSE] == 0
    assert np.array_equal(end.state, end0.state)  # the same attempt, kept either way: only the label differs
    # the edge stops: the downward speed drops from 12 to below 1 (scaled), the ECP at the plane
    assert end.state[9] > -1.0 and row[L.R_PEN] < 1e-3
    # the scale matters: at 1e-8 of the step's momenta (the attempt balances them to 1.7e-7) it fails
    (status, failed, _), _, _, _ = _fast_step("small_step", SMALL_STEP, tumblemc.SolverOptions(impulse_accept_tol=1e-8, **P0))
    assert failed == 1
    # a study stops a run at its first failed step (max_failed_steps = 1): kept loose, it runs on
    (status, failed, _), _, _, _ = _fast_step("small_step", SMALL_STEP, tumblemc.SolverOptions(max_failed_steps=1, **P0))
    assert status == L.ST_OK and failed == 0
    (status, failed, _), _, _, _ = _fast_step(
        "small_step", SMALL_STEP, tumblemc.SolverOptions(max_failed_steps=1, impulse_accept_tol=0.0, **P0)
    )
    assert status == L.ST_STOPPED


@pytest.mark.parametrize("bad", [-1, 2, 0.5, True])
def test_pivot_row_test_out_of_range_names_the_field(bad: object) -> None:
    with pytest.raises(ValueError, match="pivot_row_test"):
        tumblemc.SolverOptions(pivot_row_test=bad)  # type: ignore[arg-type]


@pytest.mark.parametrize("bad", [-1e-9, 2e-3, float("nan")])
def test_impulse_accept_tol_out_of_range_names_the_field(bad: float) -> None:
    with pytest.raises(ValueError, match="impulse_accept_tol"):
        tumblemc.SolverOptions(impulse_accept_tol=bad)


# ---- Late landings (refine_halvings) -----------------------------------------------------
# Late landings: one in the second half of a halved step, one whose refinement's half-step does not converge.
#
# The first saved step (``tests/data/late_landing.py``: the spiked robot sliding down aluminum at 70 deg,
# 20 m/s) does not converge at dt and is halved; its second half lands. The landing
# refinement checked only a step's first sub-step, so that landing was kept with a normal
# impulse doing 16.6 energy scales of positive work (1.3e-6 J), the run's whole energy gain.
#
# The second (the curved robot at 17 m/s, same tool) lands with 2.0e-6 J of positive normal
# work at dt, and the first half-step of its refinement does not converge. The refinement
# was then refused and the step kept at dt; now that half-step is halved again, at most
# ``SolverOptions.refine_halvings`` times (docs/notes/solver_gaps.md, section 10).


LATE_DATA = Path(__file__).resolve().parents[1] / "data" / "late_landing.npz"
LATE_TOOL = load_tool("late_landing")


def _late_step(landing_work: float, case: str = "", **opts: int) -> tuple[np.ndarray, float]:
    """Record row of a saved step, and the step's energy scale (m g x 1e-4 m + the field's work bound)."""
    spec = prepare(run_inputs(**LATE_TOOL.CASES[case][0], solver=tumblemc.SolverOptions(landing_work=landing_work, **opts)))
    (status, failed, _), row, _, _ = one_step(np.load(LATE_DATA), spec, prefix=case)
    assert status == L.ST_OK and failed == 0
    assert row[L.R_RES] <= spec.solver.tol and row[L.R_LOOSE] == 0
    return row, spec.prm[L.P_MASS] * spec.prm[L.P_G] + field_work_bound(spec.prm, spec.h)


def test_a_landing_in_a_later_sub_step_is_refined() -> None:
    off, scale = _late_step(0.0)  # no refinement: the landing as the solver first finds it
    on, _ = _late_step(tumblemc.SolverOptions().landing_work)
    assert off[L.R_SUB] == 1  # halved once for convergence, then the second half lands
    assert off[L.R_LED + L.L_GAIN] > 10.0 * scale  # the energy the rigid contact made
    assert on[L.R_SUB] > off[L.R_SUB]  # refined further
    # a thousandth of the ledger's tolerance (1e-2 of the scale) at most
    assert on[L.R_LED + L.L_GAIN] < 1e-3 * scale


def test_a_refinement_whose_half_step_does_not_converge_is_halved_again() -> None:
    lw = tumblemc.SolverOptions().landing_work
    coarse, scale = _late_step(0.0, "halve_")  # the step at dt, as a refused refinement keeps it
    refused, _ = _late_step(lw, "halve_", refine_halvings=0)
    halved, _ = _late_step(lw, "halve_")
    assert coarse[L.R_LED + L.L_GAIN] > 10.0 * scale
    # refused: solved again at dt and kept, the same step bit for bit
    assert refused[L.R_SUB] == 0 and refused[L.R_LED + L.L_GAIN] == coarse[L.R_LED + L.L_GAIN]
    assert halved[L.R_SUB] >= 2  # a half-step halved again
    assert halved[L.R_LED + L.L_GAIN] < 1e-3 * scale


@pytest.mark.parametrize("bad", [-1, 31, 1.5, True])
def test_refine_halvings_out_of_range_names_the_field_and_the_range(bad: object) -> None:
    with pytest.raises(ValueError, match=r"refine_halvings.*allowed"):
        tumblemc.SolverOptions(refine_halvings=bad)  # type: ignore[arg-type]


# ---- The failed step's rescue pass (rescue_iter) -----------------------------------------
# The failed step's rescue pass (``SolverOptions.rescue_iter``).
#
# A step that no strategy solves at any sub-step depth is solved once more from its start,
# every attempt allowed ``rescue_iter`` Newton iterations and no stall window, before it is
# kept as failed. The run below is one of the main job's 13 invalid runs at a97302c (curved
# robot, aluminum, 60 deg, the default study's run 20743): with the rescue off it fails a
# step at t = 0.96 s, with it on it fails none. (Since the rows' rounding test of
# ``kernels.rounding`` two deep landing sub-steps before it stop within rounding instead of
# at tol, and the run without the rescue fails a second step at 0.967 s, after the first.)


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
    assert failed.size >= 1 and abs(float(off["time"][failed[0]]) - 0.96155) < 1e-9
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


# ---- A vertex landing solved by the rescue pass's plain Newton from rest -------------------
# The saved step (tests/data/vertex_rest.py: a robot of cell 1 at the near-step-out default,
# 3.125e-7 s) lands a corner while the robot turns at 66 rad/s about the normal; the
# torsional friction stops that turn. Every attempt of the ladder stalls (the zero-velocity
# vertex guess is tried there only in a smoothing continuation) at every depth; the rescue
# pass's own last attempt, plain Newton from that guess, solves it (docs/notes/solver_gaps.md,
# section 12).

VERTEX_REST = load_tool("vertex_rest")


def _vertex_rest_step(rescue_iter: int) -> tuple[Any, np.ndarray, Start, Any]:
    saved = np.load(VERTEX_REST.OUT)
    spec = prepare(run_inputs(**VERTEX_REST.RUN, solver=SolverOptions(rescue_iter=rescue_iter)))
    out, row, end, _ = one_step(saved, spec)
    return out, row, end, (saved, spec)


def test_a_vertex_landing_that_stops_a_turn_fails_without_the_rescue() -> None:
    (status, failed, _), row, _, _ = _vertex_rest_step(0)
    assert failed == 1 and row[L.R_RES] > 1e-4 and row[L.R_SUB] == SolverOptions().max_substep_depth


def test_a_vertex_landing_that_stops_a_turn_is_solved_by_the_rescue_at_dt() -> None:
    (status, failed, _), row, end, (saved, spec) = _vertex_rest_step(SolverOptions().rescue_iter)
    assert status == L.ST_OK and failed == 0 and row[L.R_SUB] == 0 and row[L.R_LOOSE] == 0
    assert row[L.R_RES] <= spec.solver.tol
    n = spec.prm[L.P_N : L.P_N + 3]
    turn0, turn1 = float(saved["state"][10:13] @ n), float(end.state[10:13] @ n)
    assert abs(turn0) > 0.2 and abs(turn1) < 1e-3 * abs(turn0)  # the turn about the normal stops
    assert row[L.R_LN] > 100.0  # with a normal force of hundreds of weights (the torsional capacity)


# ---- A vertex impact that the impulse rule let through the plane --------------------------
# The saved step (tests/data/vertex_pass_through.py: a robot of cell 1 at 4x finer than the
# near-step-out default, 7.8e-8 s) starts with a corner on the plane, moving into it at 15.8
# (scaled; 0.49 m/s) while the robot turns about the normal. No attempt of the ladder
# solves the impact at any depth. The impulse rule used to keep, as loose, attempts with
# almost no normal force whose corner ended one step's travel below the plane (3.9e-4, under
# the rule's 1e-3 length tolerance); the next step did the same and the third failed. Now a
# kept attempt's contact point below the plane must not be moving further in
# (``contact.IMPULSE_PASS_DEPTH``), so the step goes on to the rescue pass, which solves the
# impact at dt (docs/notes/solver_gaps.md, section 13).

VERTEX_PASS = load_tool("vertex_pass_through")


def _vertex_pass_step(rescue_iter: int) -> tuple[Any, np.ndarray, Start, Any]:
    saved = np.load(VERTEX_PASS.OUT)
    spec = prepare(run_inputs(**VERTEX_PASS.RUN, solver=SolverOptions(rescue_iter=rescue_iter)))
    out, row, end, buf = one_step(saved, spec)
    return out, row, end, (saved, spec, buf)


def _corner_vn(state: np.ndarray, corner: np.ndarray) -> float:
    """The normal velocity (the plane is flat: along z) of the body point ``corner``."""
    return float(state[9] + np.cross(state[10:13], corner - state[0:3])[2])


def test_a_vertex_impact_is_not_kept_loose_through_the_plane() -> None:
    (status, failed, _), row, _, (saved, spec, _) = _vertex_pass_step(0)
    corner = saved["z"][6:9]  # the last step's contact point: the corner, on the plane
    travel = -_corner_vn(saved["state"], corner) * spec.h
    assert abs(corner[2]) < 1e-9 and travel > 3e-4  # the premise: on the plane, moving into it
    # without the rescue pass nothing solves it: failed, not kept loose a step's travel deep
    assert failed == 1 and row[L.R_LOOSE] == 0 and row[L.R_IMPULSE] == 0


def test_a_vertex_impact_is_solved_by_the_rescue_at_dt() -> None:
    (status, failed, _), row, end, (saved, spec, buf) = _vertex_pass_step(SolverOptions().rescue_iter)
    assert status == L.ST_OK and failed == 0 and row[L.R_LOOSE] == 0 and row[L.R_SUB] == 0
    assert row[L.R_RES] < 1e-6  # stopped on the rows' rounding (kernels.rounding), not kept loose
    vn0 = _corner_vn(saved["state"], saved["z"][6:9])
    vn1 = _corner_vn(end.state, buf.z[6:9])
    assert vn0 < -15.0 and abs(vn1) < 1e-3 * abs(vn0)  # the corner stops on the plane
    assert row[L.R_PEN] < 1e-6 and row[L.R_LN] > 1e4  # with an impact's normal force, not through it


def test_passes_through_against_its_numpy_twin() -> None:
    """``contact.passes_through`` on random planes, poses and attempts, against numpy."""
    from tumblemc.kernels.contact import IMPULSE_PASS_DEPTH, passes_through

    rng = np.random.default_rng(45)
    prm = np.zeros(L.N_PRM)
    seen = set()
    for _ in range(400):
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        prm[L.P_N : L.P_N + 3] = n
        z, state = rng.normal(size=24), rng.normal(size=13)
        z[6:9] += (rng.uniform(-3e-6, 1e-6) - n @ z[6:9]) * n  # the contact point near the plane
        hc = rng.uniform(1e-4, 1e-2)
        vn = n @ (z[0:3] + np.cross(z[3:6], z[6:9] - (state[0:3] + hc * z[0:3])))
        want = bool(n @ z[6:9] < -IMPULSE_PASS_DEPTH and vn < 0.0)
        assert passes_through(z, state, hc, prm, 6) == want
        seen.add(want)
    assert seen == {True, False}


# ---- Smoothing skipped once a step is kept anyway (smooth_stalled) -----------------------
# Skipping the smoothing strategies once a step is kept anyway (``SolverOptions.smooth_stalled``).
#
# The curved robot sliding down aluminum at 35 deg lifts off at t = 0.309 s in a step whose
# landing refinement's sub-steps stall within ``accept_tol`` in their plain attempts: with
# every strategy tried (``smooth_stalled = 1``, the rule before 2026-11-27) the step costs
# 7,601 Newton iterations, most of them in smoothing attempts that end at the same stall or
# further from a solution. ``smooth_stalled = 0`` skips them (not the default: docs/notes/kernel_experiments.md).


SMOOTH_KW = {"shape": "curved", "preset": "aluminum", "incline_deg": 35.0, "duration_s": 0.32, "record_every": 1}


def test_a_stalled_step_skips_the_smoothing_strategies() -> None:
    old = tumblemc.simulate(**SMOOTH_KW, solver=SolverOptions(smooth_stalled=1))  # type: ignore[arg-type]
    new = tumblemc.simulate(**SMOOTH_KW, solver=SolverOptions(smooth_stalled=0))  # type: ignore[arg-type]
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
    kw = SMOOTH_KW  # through the lift-off at 0.309 s where the default skips smoothing attempts
    a = tumblemc.simulate(**kw, solver=SolverOptions(accept_tol=0.0, smooth_stalled=1))  # type: ignore[arg-type]
    b = tumblemc.simulate(**kw, solver=SolverOptions(accept_tol=0.0, smooth_stalled=0))  # type: ignore[arg-type]
    for v in ("position", "quaternion", "newton_iterations", "fallbacks"):
        assert a[v].values.tobytes() == b[v].values.tobytes()


@pytest.mark.parametrize("value", [2, -1, 0.5, True, np.bool_(True), np.float32(1.0)])
def test_smooth_stalled_takes_0_or_1(value: object) -> None:
    with pytest.raises(ValueError, match=r"smooth_stalled=.*allowed: (an integer|a finite value in \[0, 1\])"):
        SolverOptions(smooth_stalled=value)  # type: ignore[arg-type]


# ---- The smoothing continuation's stall window (stall_window) ----------------------------
# The smoothing continuation's stall window (``SolverOptions.stall_window``).
#
# A smoothing attempt that neither halves its residual nor lowers its smoothing parameter in
# ``stall_window`` iterations stops there instead of running on to its 300-iteration limit.
# The saved step (``tests/data/stall_step.py``) is a refined step of the curved robot sliding on
# aluminum whose smoothing attempts never converge: the window changes the work, not what is
# kept.


STALL_DATA = Path(__file__).resolve().parents[1] / "data" / "stall_step.npz"
STALL_RUN = load_tool("stall_step").RUN


def _stall_step(window: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Record row, end state and last solution of the saved step with ``stall_window = window``."""
    spec = prepare(run_inputs(**STALL_RUN, solver=tumblemc.SolverOptions(stall_window=window)))
    (status, failed, _), row, start, buf = one_step(np.load(STALL_DATA), spec)
    assert status == L.ST_OK and failed == 0
    return row, start.state, buf.z.copy()


def test_stall_window_cuts_the_work_of_a_stalled_step_and_keeps_its_answer() -> None:
    off, state_off, z_off = _stall_step(0)
    on, state_on, z_on = _stall_step(80)
    assert off[L.R_NIT] > 30_000  # 119 smoothing attempts at their 300-iteration limit
    assert on[L.R_NIT] < 0.5 * off[L.R_NIT]
    # the same plain attempt is kept (loose, within accept_tol), so the same end state
    assert off[L.R_RES] <= tumblemc.SolverOptions().accept_tol
    np.testing.assert_array_equal(state_on, state_off)
    np.testing.assert_array_equal(z_on, z_off)
    assert on[L.R_SUB] == off[L.R_SUB]


def test_a_window_longer_than_the_iteration_limit_changes_nothing() -> None:
    """The counter alone does not touch the arithmetic: a window no attempt can reach gives the bits of 0."""
    kw = {"shape": "curved", "preset": "aluminum", "incline_deg": 35.0, "duration_s": 0.9, "record_every": 50}
    a = tumblemc.simulate(solver=tumblemc.SolverOptions(stall_window=0), **kw)
    b = tumblemc.simulate(solver=tumblemc.SolverOptions(stall_window=10_000), **kw)
    for v in a.data_vars:
        np.testing.assert_array_equal(a[v].values, b[v].values)
    assert int(a["newton_iterations"].sum()) > 30_000  # it passes through the stalled step


@pytest.mark.parametrize("bad", [-1, 10_001, 2.5, True])
def test_stall_window_out_of_range_names_the_field(bad: object) -> None:
    with pytest.raises(ValueError, match="stall_window"):
        tumblemc.SolverOptions(stall_window=bad)  # type: ignore[arg-type]


def test_a_fast_spin_in_flight_at_a_tiny_step_needs_no_fallbacks() -> None:
    """A fast spin in flight at a tiny step converges in an iteration or two.

    The paper cuboid spinning at 3000 rad/s, 1 mm above the plane, at 1.84e-8 s (the
    step-out bisection's 16x-finer step): each step's Newton-Euler rows resolve about 1e-9
    at best, so a test at tol alone cost 480,000 strategy fallbacks and a loose step in
    these 16,000 steps; the rounding floor ends each solve in a step or two.
    """
    ds = tumblemc.simulate(
        "cuboid", "paper", 0.0, 20.0, 212.5, duration_s=3e-4, dt=1.84e-8, lift_m=1e-3, omega0=(3000.0, 0.0, 0.0), max_wall_s=None
    )
    steps = ds.sizes["time"] - 1
    assert ds.attrs["status"] == 0 and int(ds["loose"].max()) == 0
    assert int(ds["fallbacks"].sum()) == 0
    assert float(ds["newton_iterations"].sum()) <= 2.5 * steps
