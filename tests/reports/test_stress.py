"""The stress campaign (``tumblemc stress``): tallies, report, CLI."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from tumblemc.cli import main
from tumblemc.reports.stress import invalid_table, study_summary, three_d_runs


def _runs() -> xr.Dataset:
    n = 6
    return xr.Dataset(
        {
            "status": ("run", np.array([0, 0, 1, 4, 0, 2], dtype=np.int8)),
            "energy_gain_ratio": ("run", np.array([1e-5, 2e-3, np.nan, 0.3, 1e-4, np.nan])),
            "progress_ratio": ("run", np.array([0.9, -3.0, np.nan, -200.0, 1.1, np.nan])),
            "failed_steps": ("run", np.array([0, 0, 1, 0, 0, 0])),
            "loose_steps": ("run", np.array([0, 0, 0, 5, 0, 0])),
            "shape": ("run", np.array(["cuboid"] * n)),
            "substrate": ("run", np.array(["aluminum"] * n)),
            "incline_deg": ("run", np.array([0.0, 35.0, 70.0, 70.0, 0.0, 35.0])),
            "freq_hz": ("run", np.full(n, 0.5)),
            "mu": ("run", np.linspace(0.1, 1.0, n)),
            "check_run": ("check", np.array([0, 3])),
            "check_progress_ratio_fine": ("check", np.array([0.91, -150.0])),
            "check_status_fine": ("check", np.array([0, 0], dtype=np.int8)),
        }
    )


def test_summary_counts_statuses_and_ledger_margins() -> None:
    s = study_summary(_runs())
    assert s["runs"] == 6 and s["invalid"] == 3
    assert s["status_counts"] == {"ok": 3, "failed_steps": 1, "nonfinite": 1, "energy_gain": 1}
    assert s["ok_gain_ratio_max"] == 2e-3 and s["ok_over_energy_tol"] == 0
    assert s["checked"] == 2 and s["checked_both_ok"] == 1
    assert s["check_max_abs_diff_ok"] == pytest.approx(0.01)


def test_invalid_table_lists_each_invalid_run_with_its_class() -> None:
    rows = invalid_table(_runs())
    assert [r["run"] for r in rows] == [2, 3, 5]
    assert [r["status"] for r in rows] == ["failed_steps", "energy_gain", "nonfinite"]
    assert rows[1]["loose_steps"] == 5 and rows[0]["mu"] == pytest.approx(0.46)


def test_three_d_runs_are_keyed_by_seed_and_tilted_out_of_plane() -> None:
    a = three_d_runs(2, seed=7)
    assert all(r["status"] == 0 for r in a)
    b = three_d_runs(2, seed=7)
    assert [r["offset_axis"] for r in a] == [r["offset_axis"] for r in b]
    assert [r["preset"] for r in a] == ["paper", "paper"] and [r["incline_deg"] for r in a] == [0.0, 20.0]
    for r in a:
        assert 0.0 <= r["offset_deg"] <= 30.0
        for k in ("status", "energy_gain_ratio", "max_penetration_H", "lateral_drift", "heading_change_deg"):
            assert k in r


@pytest.mark.slow
def test_stress_cli_quick_writes_the_report(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    repo = Path(__file__).resolve().parents[2]
    out = tmp_path / "report"
    code = main(
        [
            "stress",
            "--quick",
            "--config",
            str(repo / "studies/stress_quick.toml"),
            "--result",
            str(tmp_path / "s.nc"),
            "--out",
            str(out),
            "--workers",
            "0",
        ]
    )
    assert code == 0
    text = (out / "stress.md").read_text()
    for section in ("## Study", "### Runs that are not valid, by class", "## 3-D runs", "## The solver's reproducers"):
        assert section in text
    assert (out / "stress.png").stat().st_size > 10_000
    assert "wrote" in capsys.readouterr().out
