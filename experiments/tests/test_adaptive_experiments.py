"""The archived adaptive-sampling experiments (experiments/adaptive_vs_fixed.py, adaptive_acceptance.py, cs_prior.py).

Moved out of the test tiers with the scripts: run with ``python -m pytest experiments/tests``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.study.test_engine import tiny
from tests.tooling import load_tool
from tumblemc.analysis.coverage import interval_table, simulate_coverage
from tumblemc.study.engine import run_study


def test_comparison_tool_keys_cells_by_every_swept_axis(tmp_path: Path) -> None:
    """experiments/adaptive_vs_fixed.py on a field sweep: one row per (incline, field) cell, each the fixed study's prefix."""
    tool = load_tool("adaptive_vs_fixed")
    sweep = {"incline_deg": [0, 15], "field_mT": [10.0, 20.0], "samples": 8}
    run_study(tiny(**sweep), out=tmp_path / "f.nc", progress=False)
    run_study(tiny(**sweep, precision=0.3, ci="confidence-sequence-ends"), out=tmp_path / "a.nc", progress=False)
    rows, totals = tool.compare(tmp_path / "f.nc", tmp_path / "a.nc")
    assert sorted((r["incline_deg"], r["field_mT"]) for r in rows) == [(0, 10), (0, 20), (15, 10), (15, 20)]
    assert totals["prefix"] == 4 and sum(int(r["kept"]) for r in rows) == totals["kept"]
    assert all(r["fixed_in_cs"] == (r["adaptive_lo"] <= r["p_fixed"] <= r["adaptive_hi"]) for r in rows)
    text = tool.report(rows, totals, "x.png", (None, None))
    assert "| shape | substrate | incline | field (mT) | runs kept |" in text and "| 15 | 20 | " in text


def test_acceptance_what_if_against_hand_counts() -> None:
    """experiments/adaptive_acceptance.py: a cell with one failure in 200 stops at 21 runs and misses it with P = 179/200."""
    tool = load_tool("adaptive_acceptance")
    k, n = np.array([199, 200, 0]), np.array([200, 200, 200])
    res = tool.what_if(k, n, 0.1, 0, reps=2000, seed=3)
    # all-success and all-failure cells stop at 21 and lie inside; the 199/200 cell is outside
    # exactly when its first 21 runs miss the failure (then P = 1 > Wilson's upper end 0.9991)
    assert res["mean_outside"] == pytest.approx(179 / 200, abs=0.03)
    # the 199/200 cell stops at 21 runs when they miss the failure, else at 40 (39 of 40, inside Wilson)
    assert res["runs_kept"] == pytest.approx(2 * 21 + (179 / 200) * 21 + (21 / 200) * 40, abs=0.6)
    assert tool.what_if(k, n, 0.1, 200, reps=50)["mean_outside"] == 0.0
    kt, nt = tool.cells_from_table(Path(__file__).resolve().parents[2] / "docs" / "notes" / "adaptive_default.md")
    assert kt.size == 104 and np.all((kt >= 0) & (kt <= nt)) and 0 < np.count_nonzero((kt > 0) & (kt < nt)) < 104


@pytest.mark.parametrize("p", [0.0, 0.3, 0.97])
def test_prior_tool_expected_runs_match_simulated_cells(p: float) -> None:
    """experiments/cs_prior.py propagates the stopping count exactly; simulated cells give the same mean."""
    tool = load_tool("cs_prior")
    hw = tool.half_width_table(60, "ends")
    dist = tool.stop_distribution(hw, 0.2, p)
    assert dist.sum() == pytest.approx(1.0, abs=1e-12)
    exact = float(dist @ np.arange(61))
    sim = simulate_coverage(p, 0.2, 60, reps=20_000, seed=5, table=interval_table(60, 0.95))
    se = max(float(np.sqrt(dist @ (np.arange(61) - exact) ** 2 / 20_000)), 1e-9)
    assert abs(sim["mean_runs"] - exact) <= 4 * se + 1e-9
