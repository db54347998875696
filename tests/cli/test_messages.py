"""What the commands say.

A downhill incline named as such, sentences where a number is missing, units, interrupted
studies read from their result path, report folders outside the project's docs.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from tests.study.test_faults import interrupted
from tests.study.test_threshold import tiny_threshold
from tumblemc.cli import build_parser, main
from tumblemc.cli.lab import critical_field_words, posterior_critical_words, step_out_words
from tumblemc.cli.study import success_table
from tumblemc.io import ShardStore, parts_dir
from tumblemc.study.config import load_config
from tumblemc.study.identity import config_hash, config_to_json

RUN = ["simulate", "--freq-hz", "10", "--duration-s", "0.2"]  # two periods: the summary's shortest


@pytest.mark.parametrize(("incline", "verdict", "other"), [("-10", "descended", "climbed"), ("10", "climbed", "descended")])
def test_a_negative_incline_is_reported_as_downhill(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], incline: str, verdict: str, other: str
) -> None:
    assert main([*RUN, "--incline-deg", incline, "--out", str(tmp_path / "r.nc")]) == 0
    out = capsys.readouterr().out
    assert verdict in out and other not in out
    assert ("downhill slope of 10 deg" in out) == incline.startswith("-")
    assert "progress_ratio" in out and "x ideal_speed" in out  # a ratio says what it is a ratio of


def _maps(inclines: list[float], p: list[float]) -> xr.Dataset:
    shape = (1, len(inclines), 1)
    return xr.Dataset(
        {"p_success": (("shape", "incline_deg", "substrate"), np.reshape(p, shape))},
        coords={"shape": ["cuboid"], "incline_deg": inclines, "substrate": ["aluminum"]},
    )


def test_the_success_table_names_downhill_inclines() -> None:
    down = success_table(_maps([-20.0, -10.0], [1.0, 0.9]))
    assert "negative inclines are downhill" in down and "none uphill; descends 10 deg" in down
    assert "-10 deg" not in down
    mixed = success_table(_maps([-10.0, 0.0, 30.0], [1.0, 1.0, 0.8]))
    assert mixed.splitlines()[-1].endswith("   30 deg")
    up = success_table(_maps([0.0, 30.0], [1.0, 0.2]))
    assert "downhill" not in up and up.splitlines()[-1].endswith("   0 deg")


def test_a_step_out_sweep_that_follows_throughout_says_so(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # the paper robot at 20 mT follows to about 238 Hz (docs/guide/lab.md)
    assert main(["lab", "step-out", "--freq-hz", "20,40", "--out", str(tmp_path / "so.nc")]) == 0
    out = capsys.readouterr().out
    assert "no step-out up to 40 Hz" in out and "nan" not in out.lower()
    assert "speed (mm/s)" in out and "phase_lag_deg" in out


def _sweep(freqs: list[float], so: float, last: float) -> xr.Dataset:
    return xr.Dataset({"step_out_hz": ((), so), "last_following_hz": ((), last)}, coords={"freq_hz": freqs}, attrs={"field_mT": 20.0})


def test_step_out_words_cover_every_case() -> None:
    assert step_out_words(_sweep([1.0, 10.0, 20.0], 12.5, 10.0)) == "step-out frequency: 12.5 Hz"
    assert "intermittent band" in step_out_words(_sweep([1.0, 10.0, 20.0, 30.0], 12.5, 30.0))
    none = step_out_words(_sweep([1.0, 10.0], math.nan, math.nan))
    assert none.startswith("no frequency followed from 1 to 10 Hz") and "20 mT" in none
    assert step_out_words(_sweep([1.0, 10.0], math.nan, 10.0)).startswith("no step-out up to 10 Hz")
    assert "nan" not in step_out_words(_sweep([1.0, 10.0], math.nan, 1.0)).lower()


def test_a_critical_field_outside_the_bracket_is_a_sentence(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["lab", "critical-field", "--freq-hz", "10", "--lo-mT", "15", "--hi-mT", "20", "--out", str(tmp_path / "c.nc")]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "no critical field in [15, 20] mT: the robot already tumbles at 15 mT (lower --lo-mT)" in out and "nan" not in out
    fails = xr.Dataset({"critical_mT": ((), math.nan), "tumbles_at_lo": ((), False), "tumbles_at_hi": ((), False)})
    assert critical_field_words(fails, 0.5, 1.0).endswith("does not tumble at 1 mT (raise --hi-mT)")
    draws = xr.Dataset(
        {
            "critical_mT": ("sample", [5.0, math.nan, 7.0]),
            "critical_mT_median": ((), 6.0),
            "critical_mT_5_95": ("q", [5.1, 6.9]),
        }
    )
    said = posterior_critical_words(draws, 0.5, 40.0)
    assert "median 6 mT" in said and "1 of 3 draws have no crossing" in said
    nothing = draws.assign(critical_mT=("sample", [math.nan] * 3), critical_mT_median=((), math.nan))
    assert "nan" not in posterior_critical_words(nothing, 0.5, 40.0).lower()


def test_an_interrupted_study_is_read_from_its_result_path(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "tiny.nc"
    shards = interrupted(out, monkeypatch)  # 2 inclines x 3 samples, every shard, no file
    for s in shards:
        if s.name.startswith(("main-000000004-", "main-000000005-")):  # two runs of the second cell undone
            s.unlink()
    assert main(["study", "status", str(out)]) == 0
    said = capsys.readouterr().out
    assert "state        partial" in said and "done         4" in said and "total        6" in said
    table = said.split("runs done per cell (of 3 each; columns: incline, deg)\n", 1)[1].splitlines()
    assert table[0].split() == ["0", "60"] and table[1].split() == ["cuboid", "aluminum", "3/3", "1/3"]

    assert main(["study", "plot", str(out)]) == 0
    said = capsys.readouterr().out
    assert said.startswith("partial: 4 of 6 runs done (1 of 2 cells complete)") and "study run <its TOML> --out" in said
    plots = tmp_path / "tiny_partial_plots"
    assert (plots / "success_heatmap.png").stat().st_size > 10_000
    assert not (tmp_path / "tiny_plots").exists() and not out.exists()
    assert sorted(p.name for p in shards if p.exists()) == sorted(p.name for p in parts_dir(out).glob("main-*.npz"))  # untouched


def test_interrupted_studies_that_cannot_be_read_say_why(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["study", "status", str(tmp_path / "none.nc")]) == 2
    assert "nor its shard folder" in capsys.readouterr().err
    cfg = load_config(tiny_threshold())
    out = tmp_path / "tth.nc"
    ShardStore(out, config_to_json(cfg), config_hash(cfg)).open()
    assert main(["study", "plot", str(out)]) == 2
    err = capsys.readouterr().err
    assert "a threshold study has no partial maps" in err and f"--out {out}" in err
    assert main(["study", "status", str(out)]) == 0 and "state        partial" in capsys.readouterr().out
    meta = parts_dir(out) / "study.json"
    meta.write_text(json.dumps({"config_hash": "0" * 64, "config": json.loads(config_to_json(cfg))}))
    assert main(["study", "status", str(out)]) == 2
    assert "written by another version of tumblemc" in capsys.readouterr().err


def _outs(parser: argparse.ArgumentParser, path: str = "tumblemc") -> dict[str, object]:
    found = {}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                found.update(_outs(sub, f"{path} {name}"))
        elif "--out" in action.option_strings or "--report" in action.option_strings:
            found[path] = action.default
    return found


def test_no_command_writes_into_the_project_docs_by_default() -> None:
    outs = _outs(build_parser())
    assert "tumblemc stress" in outs and "tumblemc validate" in outs
    inside = {cmd: d for cmd, d in outs.items() if isinstance(d, str) and Path(d).parts[:1] == ("docs",)}
    assert not inside
