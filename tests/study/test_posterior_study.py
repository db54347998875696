"""A calibration posterior as a study's joint uncertainty ([uncertain] posterior = "calib.nc")."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from tumblemc.study.checks import ConfigError
from tumblemc.study.config import load_config
from tumblemc.study.design import design
from tumblemc.study.distributions import POSTERIOR_SLOT, UNCERTAIN_PARAMS, mc_slot
from tumblemc.study.engine import run_study
from tumblemc.study.identity import config_hash


def _posterior(path: Path, n: int = 50, seed: int = 0) -> Path:
    rng = np.random.default_rng(seed)
    f = 3.2e-6 + 1e-7 * rng.standard_normal(n)
    off = 27.0 - 2.0 * (f - 3.2e-6) / 1e-7 + 0.1 * rng.standard_normal(n)  # strongly correlated
    xr.Dataset({"F_elect": ("sample", f), "offset_deg": ("sample", off)}).to_netcdf(path)
    return path


def _config(tmp: Path, **changes):
    d = {
        "name": "post",
        "shapes": ["cuboid"],
        "presets": ["paper"],
        "incline_deg": [0.0, 60.0],
        "field_mT": [20.0],
        "freq_hz": [10.0],
        "samples": 5,
        "seed": 2,
        "check": {"fraction": 0.02, "min_runs": 1, "dt_factor": 2},
        "uncertain": {"posterior": str(tmp / "calib.nc"), "mu": {"dist": "truncnormal", "rel_sd": 0.15}},
    }
    d.update(changes)
    return d


def test_each_run_takes_a_whole_draw_keyed_by_the_run(tmp_path: Path) -> None:
    _posterior(tmp_path / "calib.nc")
    cfg = load_config(_config(tmp_path))
    assert cfg.uncertain_names == ("F_elect", "mu", "offset_deg")
    des = design(cfg)
    rows = {tuple(r) for r in np.stack([cfg.posterior.draws[:, 0], cfg.posterior.draws[:, 1]], 1)}
    assert all((a, b) in rows for a, b in zip(des["F_elect"].values, des["offset_deg"].values, strict=True))
    # run-keyed: more samples keep the earlier runs' draws; dropping mu changes no posterior draw
    more = design(load_config(_config(tmp_path, samples=9)))
    np.testing.assert_array_equal(more["F_elect"].values.reshape(2, 9)[:, :5].ravel(), des["F_elect"].values)
    no_mu = design(load_config(_config(tmp_path, uncertain={"posterior": str(tmp_path / "calib.nc")})))
    np.testing.assert_array_equal(no_mu["offset_deg"].values, des["offset_deg"].values)
    assert POSTERIOR_SLOT == 15 and POSTERIOR_SLOT not in {mc_slot(q) for q in UNCERTAIN_PARAMS}


def test_the_posterior_is_part_of_the_identity(tmp_path: Path) -> None:
    _posterior(tmp_path / "calib.nc")
    h = config_hash(load_config(_config(tmp_path)))
    (tmp_path / "moved").mkdir()
    shutil.copy(tmp_path / "calib.nc", tmp_path / "moved" / "calib.nc")
    moved = _config(tmp_path)
    moved["uncertain"]["posterior"] = str(tmp_path / "moved" / "calib.nc")
    assert config_hash(load_config(moved)) == h  # the same content elsewhere: the same study
    _posterior(tmp_path / "calib.nc", seed=1)
    assert config_hash(load_config(_config(tmp_path))) != h


def test_relative_path_from_the_toml_folder(tmp_path: Path) -> None:
    _posterior(tmp_path / "calib.nc")
    toml = tmp_path / "s.toml"
    toml.write_text(
        'name = "p"\nshapes = ["cuboid"]\npresets = ["paper"]\nincline_deg = [0]\nfield_mT = [20]\nfreq_hz = [1]\n'
        'samples = 2\nseed = 0\n[uncertain]\nposterior = "calib.nc"\n'
    )
    assert load_config(toml).posterior.params == ("F_elect", "offset_deg")


@pytest.mark.parametrize(
    "change, match",
    [
        ({"uncertain": {"posterior": "nowhere.nc"}}, "cannot read"),
        ({"uncertain": {"posterior": 3}}, "uncertain.posterior=3 is not a path"),
        ({"sampler": "sobol"}, "does not sample a posterior"),
        ({"uncertain": {"posterior": "@", "offset_deg": {"dist": "normal", "sd": 1.0}}}, "also in the posterior"),
    ],
)
def test_bad_posterior_configs(tmp_path: Path, change, match) -> None:
    _posterior(tmp_path / "calib.nc")
    d = _config(tmp_path, **change)
    if d["uncertain"].get("posterior") == "@":
        d["uncertain"]["posterior"] = str(tmp_path / "calib.nc")
    with pytest.raises(ConfigError, match=match):
        load_config(d)


def test_study_runs_from_a_posterior(tmp_path: Path) -> None:
    _posterior(tmp_path / "calib.nc")
    res = run_study(_config(tmp_path), out=tmp_path / "post.nc", progress=False)
    with xr.open_dataset(res.path, group="runs") as runs:
        assert "F_elect" in runs and "offset_deg" in runs and runs.sizes["run"] == 10
        assert np.all(runs["status"].values == 0)


def test_posterior_of_another_robot_is_refused(tmp_path: Path) -> None:
    path = _posterior(tmp_path / "calib.nc")
    ds = xr.load_dataset(path)
    ds.attrs.update(shape="cuboid", preset="aluminum")
    ds.to_netcdf(tmp_path / "al.nc")
    d = _config(tmp_path)
    d["uncertain"]["posterior"] = str(tmp_path / "al.nc")
    with pytest.raises(ConfigError, match="calibrated for preset 'aluminum'; the study has presets \\['paper'\\]"):
        load_config(d)
    from tumblemc import lab

    with pytest.raises(ValueError, match="calibrated for preset 'aluminum', not 'paper'"):
        lab.posterior_samples(str(tmp_path / "al.nc"), 3, "cuboid", "paper")
