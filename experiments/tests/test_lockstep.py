"""The archived lockstep and Jacobian-pattern experiments (experiments/lockstep_lu.py, lockstep_coverage.py, jacobian_patterns.py).

Moved out of the test tiers with the scripts: run with ``python -m pytest experiments/tests -m "slow or not slow"``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.tooling import load_tool


@pytest.mark.slow
def test_jacobian_pattern_survey_runs_small(tmp_path: Path) -> None:
    """The small version of experiments/jacobian_patterns.py (docs/notes/kernel_experiments.md): every scenario captured and tabled."""
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[2]
    cmd = [sys.executable, str(root / "experiments" / "jacobian_patterns.py"), "--seconds", "0.01"]
    out = subprocess.run(cmd, check=True, cwd=root, capture_output=True, text=True).stdout
    rows = [line for line in out.splitlines() if line.startswith("| ") and "scenario" not in line]
    assert len(rows) == 5 and all(int(r.split("|")[3].replace(",", "")) > 0 for r in rows)
    tool = load_tool("jacobian_patterns")
    a = np.array([[0.0, 2.0], [1.0, 1.0]])
    assert tool.guard_ratio(a, (0, 1)) == 0.0 and tool.guard_ratio(a, (1, 0)) == 1.0
    assert tool.group_guard(a, {}, [0, 1]) == 1.0  # every pivot free: partial pivoting, ratio 1
    assert tool.group_guard(a, {0: 0}, [1]) == 0.0 and tool.group_guard(a, {0: 1}, [0]) == 1.0


def _pivot_ties(A: np.ndarray) -> int:
    """Tied steps of ``newton.lu_factor``'s partial pivoting (first largest in position order).

    The elimination steps at which another candidate ties with the pivot's magnitude.
    """
    A = A.copy()
    n = A.shape[0]
    order = list(range(n))
    ties = 0
    for k in range(n):
        cand = [abs(A[order[i], k]) for i in range(k, n)]
        best = max(cand)
        if not best > 0.0 or not np.isfinite(best):
            return ties
        ties += sum(c == best for c in cand) > 1
        p = k + cand.index(best)
        order[k], order[p] = order[p], order[k]
        rk = order[k]
        for i in range(k + 1, n):
            r = order[i]
            if A[r, k] != 0.0:
                f = A[r, k] / A[rk, k]
                A[r, k + 1 :] -= f * A[rk, k + 1 :]
    return ties


@pytest.mark.parametrize(
    "seed", [pytest.param(0, marks=pytest.mark.slow), 2, pytest.param(5, marks=pytest.mark.slow)]
)  # K = 1, 7, 8 lanes; n = 6, 12, 21 (six compiled forms each: the fast tier keeps one)
def test_lockstep_lu_experiment_solves_bit_for_bit_like_the_sparse_lu(seed: int) -> None:
    """experiments/lockstep_lu.py's lockstep and dense LUs solve like the sparse LU, bit for bit.

    Every lane gets the scalar sparse LU's solution, bit pattern for bit pattern
    (docs/notes/kernel_experiments.md, "Lockstep LU"), in each lockstep form (rows swapped, rows
    in place, lanes unrolled, pattern masks): with pivots tied in magnitude (small
    integer matrices; the test counts the tied steps), signed zeros in the matrices and
    the right-hand sides, a singular lane and a lane with a NaN.
    """
    tool = load_tool("lockstep_lu")
    rng = np.random.default_rng(seed)
    n, K, M = 6 + 3 * seed, 1 + 3 * seed % 8, 4
    mats = []
    for i in range(M * K):
        if i % 2:  # small integers: tied pivots all along the elimination
            A = np.where(rng.random((n, n)) < 0.4, rng.integers(-2, 3, (n, n)).astype(float), 0.0)
            A[np.arange(n), rng.permutation(n)] = rng.choice([-2.0, 2.0], n)
        else:
            A = np.where(rng.random((n, n)) < 0.3, rng.standard_normal((n, n)), 0.0)
            A[np.arange(n), rng.permutation(n)] += rng.choice([-2.0, -1.0, 1.0, 2.0], n)
        A[rng.random((n, n)) < 0.05] = -0.0
        mats.append(A)
    mats[1][:, 0] = 0.0  # a singular lane
    mats[2][n // 2, n // 3] = np.nan  # a NaN
    assert sum(_pivot_ties(A) for A in mats[1::2] if np.isfinite(A).all()) > 0
    runs = [mats[r * M : (r + 1) * M] for r in range(K)]
    c = tool.compare(runs, K, reps=1, rounds=1, zeros=True)
    assert c["groups"] == M and c["ok_equal"]
    assert c["bit_lockstep"] == 1.0 and c["bit_inplace"] == 1.0  # rows swapped; rows in place, all three forms
    assert c["value_dense"] == 1.0  # the dense LU (for scale) turns some -0.0 into +0.0
    Js, _ = tool.groups(runs, K)
    assert np.array_equal(Js[1, :, :, 0], mats[1])  # lane 0 of group 1 is run 0's second matrix


@pytest.mark.parametrize("K", [3, 8])
def test_lockstep_block_forms_give_the_scalar_kernels_bits(K: int) -> None:
    """experiments/lockstep_lu.py's residual block in lockstep equals the scalar kernels, bit for bit.

    Its three forms (2-D, per statement, flat with K constant) against quat_step and
    quat_to_rot lane by lane.
    """
    b = load_tool("lockstep_lu").compare_block(K, M=64, reps=1, rounds=1, seed=K)
    assert b["bit"] is True


@pytest.mark.slow
def test_lockstep_lu_experiment_runs_small() -> None:
    """The small version of experiments/lockstep_lu.py: every scenario captured, compared bit for bit, tabled."""
    text = load_tool("lockstep_lu").main(["--seconds", "0.005", "--runs", "2", "--lanes", "1,4", "--reps", "1", "--rounds", "1"])
    rows = [line.split("|") for line in text.splitlines() if line.startswith("| ") and "scenario" not in line]
    assert len(rows) == 6
    assert all(r[4].strip() == "True" and float(r[5]) == 1.0 and float(r[6]) == 1.0 and float(r[11]) == 1.0 for r in rows)


def test_lockstep_coverage_counts_plain_lanes_and_the_slowest_lane() -> None:
    """experiments/lockstep_coverage.py's coverage and efficiency, on records worked by hand."""
    tool = load_tool("lockstep_coverage")
    rec = {
        "mode": np.array([[1, 1, 1, 0], [1, 1, 2, 2]], float),  # modes at every recorded instant
        "nit": np.array([[1, 2, 1], [3, 1, 1]], float),  # per step: cost 1 + iterations
        "sub": np.zeros((2, 3)),
        "fb": np.zeros((2, 3)),
    }
    # step 0: both plain (cost 2 and 4, the group waits for 4); step 1: run 1 changes mode;
    # step 2: run 0 lifts off, run 1 alone in face contact
    c, e = tool.coverage(rec, 2)
    assert (c, e) == pytest.approx((11 / 15, 11 / 13), rel=1e-15)
    rec["fb"][0, 0] = 1.0  # a fallback takes run 0's first step off the lockstep path
    assert tool.coverage(rec, 2) == pytest.approx((9 / 15, 1.0), rel=1e-15)
    assert tool.coverage(rec, 1) == pytest.approx((9 / 15, 1.0), rel=1e-15)  # one lane: nothing to wait for
    three = {"mode": np.ones((3, 2)), "nit": np.array([[1.0], [2.0], [5.0]]), "sub": np.zeros((3, 1)), "fb": np.zeros((3, 1))}
    assert tool.coverage(three, 3) == pytest.approx((1.0, 11 / 18), rel=1e-15)  # costs 2, 3, 6: all wait for 6
    assert tool.coverage(three, 3, leave=True) == pytest.approx((8 / 11, 8 / 9), rel=1e-15)  # wait for 3; 3 of 6 off the path
    need = tool.s_needed(0.9, 0.7, 2.5)
    assert tool.bound(0.9, 0.7, need) == pytest.approx(2.5) and tool.s_needed(0.5, 0.7, 2.5) == float("inf")


def test_lockstep_coverage_weights_the_cells_over_the_main_job() -> None:
    """experiments/lockstep_coverage.py's main-job bound and the gain it needs, worked by hand."""
    tool = load_tool("lockstep_coverage")
    cells = {
        ("cuboid", "paper", 45.0): (1.0, 0.5),  # at s = 2: time fraction 1
        ("spiked", "paper", 20.0): (1.0, 1.0),  # 0.5; the paper class takes the mean, 0.75
        ("cuboid", "aluminum", 30.0): (0.5, 1.0),  # 0.5 + 0.25
        ("curved", "aluminum", 35.0): (0.0, 1.0),  # nothing in lockstep: 1
    }
    shares = {"paper": 0.5, "aluminum, not curved": 0.3, "curved, aluminum": 0.2}
    assert tool.weighted(cells, shares, 2.0, False) == pytest.approx(1.0 / 0.8, rel=1e-14)
    assert tool.weighted(cells, shares, 2.0, True) == pytest.approx(1.0 / 0.675, rel=1e-14)  # every e = 1
    assert tool.s_for(cells, shares, 1.25, False) == pytest.approx(2.0, rel=1e-9)
    assert tool.weighted(cells, shares, 1e12, False) == pytest.approx(1.0 / 0.35, rel=1e-9)  # the ceiling
    assert tool.s_for(cells, shares, 3.0, False) == float("inf")
    doubled = {k: 2.0 * v for k, v in shares.items()}  # shares are normalised
    assert tool.weighted(cells, doubled, 2.0, False) == pytest.approx(1.0 / 0.8, rel=1e-14)
    with pytest.raises(ValueError, match="no measured cell"):
        tool.weighted({k: v for k, v in cells.items() if k[1] == "paper"}, shares, 2.0, False)
    with pytest.raises(ValueError, match="no class"):
        tool.weighted({**cells, ("cuboid", "glass", 5.0): (0.5, 0.5)}, shares, 2.0, False)
    undefined = {**cells, ("cuboid", "aluminum", 30.0): (0.5, float("nan"))}  # e of an empty cell
    with pytest.raises(ValueError, match="NaN"):
        tool.s_for(undefined, shares, 1.1, False)


@pytest.mark.slow
def test_lockstep_coverage_runs_small() -> None:
    """The small version of experiments/lockstep_coverage.py: every cell simulated and tabled."""
    text = load_tool("lockstep_coverage").main(["--runs", "2", "--lanes", "2", "--duration", "0.05"])
    rows = [line.split("|") for line in text.splitlines() if line.startswith("| ") and " deg | " in line]
    assert len(rows) == 4 and all(0.0 < float(r[3]) <= 1.0 and 0.0 < float(r[4]) <= 1.0 for r in rows)
    weighted = [line.split("|") for line in text.splitlines() if line.startswith("| 2 | ")]
    gain = [float(r[4].strip().rstrip("x")) for r in weighted]
    assert len(weighted) == 9
    assert gain[2] <= gain[3] <= gain[6] and gain[3] <= gain[4]  # s = 4, 6.6, the ceiling; e = 1 above measured e
