"""Calibration from bench data (tumblemc.lab.calibrate)."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from tumblemc import lab
from tumblemc.cli import main
from tumblemc.lab import calibrate as C

TRUTH = {"F_elect": 2.5e-6, "offset_deg": 22.0}
FIELDS = np.arange(3.0, 15.5, 1.0)


def _synthetic(path, noise=0.3, seed=1):
    y = np.array([lab.cuboid_tilt_balance(b, "paper", **TRUTH) for b in FIELDS])
    y = y + np.random.default_rng(seed).normal(0.0, noise, y.size)
    C.write_bench(path, "field_mT", "tilt_deg", FIELDS, y)
    return y


def test_fit_recovers_the_truth_and_names_the_undetermined(tmp_path) -> None:
    _synthetic(tmp_path / "tilt.csv")
    post = C.calibrate(tmp_path / "tilt.csv", ["F_elect", "offset_deg", "adhesion_C"], model="closed-form")
    for nm, v in TRUTH.items():
        lo, hi = np.quantile(post[nm].values, [0.005, 0.995])
        assert lo < v < hi, (nm, lo, hi)
        assert post[nm].attrs["units"] in ("N", "degree")
    # the tilt branch sees C only through the line adhesion C w W, far below F_elect
    assert post.attrs["undetermined"] == "adhesion_C"
    assert post.sizes["sample"] == C.N_POSTERIOR
    lower, upper = np.asarray(post.attrs["bounds_lower"]), np.asarray(post.attrs["bounds_upper"])
    draws = np.stack([post[n].values for n in ("F_elect", "offset_deg", "adhesion_C")], 1)
    assert np.all((draws >= lower) & (draws <= upper))
    assert np.corrcoef(draws[:, 0], draws[:, 1])[0, 1] < -0.5  # more load (F_elect) and a smaller offset (more torque) trade off


def test_simulated_and_closed_form_models_agree(tmp_path) -> None:
    data = C.BenchData("static_tilt", "field_mT", "tilt_deg", "degree", np.array([5.0, 9.0, 14.0]), np.zeros(3), "x")
    p = {"F_elect": 2.5e-6, "offset_deg": 22.0}
    sim = C.forward_model(data, model="simulate")(p)
    cf = C.forward_model(data, model="closed-form")(p)
    np.testing.assert_allclose(sim, cf, atol=0.05)


@pytest.mark.slow
def test_coverage_of_the_posterior() -> None:
    # 60 replicates: a 95% interval must hold the truth in at least 85% (P(fewer) about
    # 0.2% at a true 95%); docs/notes/calibration_coverage.md reports 400
    cov = C.coverage(60, seed=7)
    assert np.all(cov["coverage"].values >= 0.85), cov["coverage"].values
    assert np.all(cov["coverage"].values <= 1.0)


@pytest.mark.parametrize(
    "text, match",
    [
        ("", "empty"),
        ("a,b\n1,2\n", "header 'a,b' is not a bench test"),
        ("field_mT,tilt_deg\n1,x\n2,3\n", "line 2: '1,x' is not two numbers"),
        ("field_mT,tilt_deg\n1,2\n", "1 data row"),
        ("field_mT,tilt_deg\n1,nan\n2,3\n", "line 2: '1,nan' is not finite"),
    ],
)
def test_bad_bench_files_name_file_and_line(tmp_path, text, match) -> None:
    f = tmp_path / "bad.csv"
    f.write_text(text)
    with pytest.raises(ValueError, match=match):
        C.read_bench(f)


def test_bad_free_parameters(tmp_path) -> None:
    _synthetic(tmp_path / "t.csv")
    with pytest.raises(ValueError, match="'mass_kg' is not a numeric Params field"):
        C.calibrate(tmp_path / "t.csv", ["mass_kg"], model="closed-form")
    with pytest.raises(ValueError, match="bounds of mu"):
        C.calibrate(tmp_path / "t.csv", ["mu"], {"mu": (1.0, 0.5)}, model="closed-form")
    with pytest.raises(ValueError, match=r"bounds of F_elect = \(-1e-06, 1e-05\) leave the physical range"):
        C.calibrate(tmp_path / "t.csv", ["F_elect"], {"F_elect": (-1e-6, 1e-5)}, model="closed-form")
    with pytest.raises(ValueError, match="critical-incline test is read but not fitted"):
        C.forward_model(C.BenchData("critical_incline", "incline_deg", "climbed", "1", np.zeros(2), np.zeros(2), "f"))


def test_cli_calibrate(tmp_path, capsys) -> None:
    _synthetic(tmp_path / "tilt.csv")
    out = tmp_path / "calib.nc"
    argv = ["calibrate", "static-tilt", str(tmp_path / "tilt.csv"), "--free", "F_elect,offset_deg", "--model", "closed-form"]
    assert main([*argv, "--samples", "500", "--out", str(out), "--plot"]) == 0
    text = capsys.readouterr().out
    assert "F_elect = " in text and "offset_deg = " in text
    with xr.open_dataset(out) as ds:
        assert ds.sizes["sample"] == 500 and "F_elect" in ds and ds.attrs["test"] == "static_tilt"
    assert (tmp_path / "calib.png").exists()
    assert main(["calibrate", "speed", str(tmp_path / "tilt.csv"), "--free", "mu"]) == 2
    assert "its header is a static_tilt test, not speed" in capsys.readouterr().err


@pytest.mark.slow
def test_speed_calibration_with_the_simulator(tmp_path) -> None:
    # speed against frequency on a 20 deg incline: slip above ~10 Hz makes it depend on mu
    f = np.array([5.0, 15.0, 25.0, 35.0])
    y = lab.step_out(f, mu=0.3, incline_deg=20.0, periods=4.0)["speed"].values
    y = y + np.random.default_rng(0).normal(0.0, 0.3, f.size)
    C.write_bench(tmp_path / "speed.csv", "freq_hz", "speed_mm_s", f, y)
    post = C.calibrate(tmp_path / "speed.csv", ["mu"], {"mu": (0.15, 0.6)}, incline_deg=20.0, n_posterior=500)
    lo, hi = np.quantile(post["mu"].values, [0.005, 0.995])
    assert lo < 0.3 < hi
    assert post.attrs["test"] == "speed" and post["fit"].attrs["units"] == "mm s-1"
    assert len(post.attrs["jacobian_step_ratio"]) == 1


@pytest.mark.slow
def test_coverage_campaign_small_version() -> None:
    # the issue-14 protocol (tools/calibration_coverage.py, docs/notes/calibration_coverage.md) at
    # 20 replicates: simulated tilts at known parameters, 1 deg noise, 15 fields, 3 free;
    # at least 80% (P(fewer) < 0.5% at a true 95%)
    truth = {"F_elect": 2.5e-6, "offset_deg": 22.0, "adhesion_C": 5.0}
    fields = np.linspace(3.0, 15.0, 15)
    clean = lab.static_tilt(fields, **truth)["tilt_deg"].values
    cov = C.coverage(20, truth, fields, noise_deg=1.0, seed=3, clean=clean)
    assert np.all(cov["coverage"].values >= 0.8), cov["coverage"].values


def test_auto_model_fits_the_closed_form_and_checks_it_with_the_simulator(tmp_path) -> None:
    _synthetic(tmp_path / "t.csv")
    post = C.calibrate(tmp_path / "t.csv", ["F_elect", "offset_deg"], n_posterior=200)
    assert post.attrs["model"] == "auto" and post.attrs["fit_model"] == "closed-form"
    assert 0.0 <= post.attrs["simulator_check_rms"] < 0.05  # degrees: the two models agree
    with pytest.raises(ValueError, match="model='exact' is not allowed"):
        C.calibrate(tmp_path / "t.csv", ["F_elect"], model="exact")
