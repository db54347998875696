"""``tumblemc design``: a search end to end from the command line, kill -9 and resume, the sweep, errors."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from tumblemc.cli import main
from tumblemc.design.result import open_design

ROOT = Path(__file__).resolve().parents[2]

TOML = """
name = "cli"
family = "spiked_ends"
seed = 2
budget = {budget}
samples = 8
stage = 4
initial = 4
batch = 2
confirm = 8

[variables.spike_base]
bounds = [50e-6, 400e-6]

[variables.spike_height]
bounds = [50e-6, 400e-6]

[[objectives]]
kind = "speed"
substrate = "paper"
freq_hz = 10
"""


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return env


@pytest.mark.slow
def test_run_status_plot(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = tmp_path / "d.toml"
    cfg.write_text(TOML.format(budget=120))
    out = tmp_path / "d.nc"
    assert main(["design", "run", str(cfg), "--workers", "0", "--out", str(out), "--no-progress", "--plot"]) == 0
    text = capsys.readouterr().out
    assert "recommended design" in text and "fresh robots" in text
    tr = open_design(out)
    assert tr.attrs["simulations"] <= 120 and tr.attrs["recommended"] >= 0
    for name in ("design_front.png", "design_variables.png"):
        assert (tmp_path / "d_plots" / name).stat().st_size > 10_000
    assert main(["design", "status", str(out)]) == 0
    assert "recommended design" in capsys.readouterr().out
    # plain xarray reads every group
    with xr.open_dataset(out, group="designs") as ds:
        assert ds.sizes["design"] == tr["designs"].sizes["design"]
    # a second run finds the result complete and simulates nothing; another problem is refused
    before = out.stat().st_mtime_ns
    assert main(["design", "run", str(cfg), "--workers", "0", "--out", str(out)]) == 0
    assert "is complete; nothing to do" in capsys.readouterr().err and out.stat().st_mtime_ns == before
    cfg.write_text(TOML.format(budget=121))
    assert main(["design", "run", str(cfg), "--workers", "0", "--out", str(out)]) == 2
    assert "another design problem" in capsys.readouterr().err


@pytest.mark.slow
def test_kill_9_and_resume_gives_the_uninterrupted_result(tmp_path: Path) -> None:
    cfg = tmp_path / "d.toml"
    cfg.write_text(TOML.format(budget=200))
    cmd = [sys.executable, "-m", "tumblemc", "design", "run", str(cfg), "--workers", "0", "--no-progress"]
    subprocess.run([*cmd, "--out", str(tmp_path / "a.nc")], check=True, env=_env(), capture_output=True)
    parts = tmp_path / "b.nc.parts"
    p = subprocess.Popen([*cmd, "--out", str(tmp_path / "b.nc")], env=_env(), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    t0 = time.time()
    while time.time() - t0 < 120 and len(list(parts.glob("*.npz"))) < 10:
        time.sleep(0.05)
    p.send_signal(signal.SIGKILL)
    p.wait()
    assert len(list(parts.glob("*.npz"))) >= 10 and not (tmp_path / "b.nc").exists()
    subprocess.run([*cmd, "--out", str(tmp_path / "b.nc")], check=True, env=_env(), capture_output=True)
    a, b = open_design(tmp_path / "a.nc"), open_design(tmp_path / "b.nc")
    for g in ("designs", "confirm", "runs"):
        xr.testing.assert_identical(a[g].to_dataset(), b[g].to_dataset())
    assert not parts.exists()


@pytest.mark.slow
def test_dask_gives_the_serial_result(tmp_path: Path) -> None:
    cfg = tmp_path / "d.toml"
    cfg.write_text(TOML.format(budget=80))
    assert main(["design", "run", str(cfg), "--workers", "0", "--out", str(tmp_path / "s.nc"), "--no-progress"]) == 0
    assert main(["design", "run", str(cfg), "--workers", "2", "--out", str(tmp_path / "d.nc"), "--no-progress"]) == 0
    a, b = open_design(tmp_path / "s.nc"), open_design(tmp_path / "d.nc")
    for g in ("designs", "confirm", "runs"):
        xr.testing.assert_identical(a[g].to_dataset(), b[g].to_dataset())


@pytest.mark.slow
def test_sweep(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["design", "sweep", "--designs", "2", "--tol", "1", "--out", str(tmp_path)]) == 0
    import pandas as pd

    df = pd.read_csv(tmp_path / "authors_sweep.csv")
    assert len(df) == 4 and set(df.mass_rule) == {"fixed", "density"}
    assert np.all(df.speed_status == 0) and np.all(df.speed_mm_s > 10)
    assert np.all(df.holds_deg >= df.climbs_deg)  # net progress is a weaker requirement than half the ideal
    fixed = df[df.mass_rule == "fixed"]
    assert np.allclose(fixed.mass_ug, 69.4)  # the aluminum robot's 6.94e-8 kg whatever the spikes
    assert (tmp_path / "authors_sweep.png").stat().st_size > 10_000


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["design", "run", "nope.toml"], ["nope.toml", "no such design file"]),
        (["design", "status", "nope.nc"], ["nope.nc", "no such design result"]),
        (["design", "sweep", "--designs", "1"], ["--designs=1", "allowed"]),
    ],
)
def test_errors_are_one_line(argv: list[str], words: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0
    for w in words:
        assert w in err
