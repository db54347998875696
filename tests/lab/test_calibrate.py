"""Calibration from bench data (tumblemc.lab.calibrate)."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from tests.tooling import load_tool
from tumblemc import lab
from tumblemc.cli import main
from tumblemc.lab import bounds
from tumblemc.lab import calibrate as C
from tumblemc.lab import mcmc as mc
from tumblemc.lab.coverage import coverage

TRUTH = {"F_elect": 2.5e-6, "offset_deg": 22.0}
FIELDS = np.arange(3.0, 15.5, 1.0)


def _synthetic(path, noise=0.3, seed=1):
    y = np.array([lab.cuboid_tilt_balance(b, "paper", **TRUTH) for b in FIELDS])
    y = y + np.random.default_rng(seed).normal(0.0, noise, y.size)
    C.write_bench(path, "field_mT", "tilt_deg", FIELDS, y)
    return y


def test_fit_recovers_the_truth_and_sees_the_lift_off(tmp_path) -> None:
    _synthetic(tmp_path / "tilt.csv")
    post = C.calibrate(tmp_path / "tilt.csv", ["F_elect", "offset_deg", "adhesion_C"], model="closed-form")
    for nm, v in {**TRUTH, "adhesion_C": 3.7148}.items():
        lo, hi = np.quantile(post[nm].values, [0.005, 0.995])
        assert lo < v < hi, (nm, lo, hi)
    assert post["adhesion_C"].attrs["units"] == "N/m^2"
    # the tilt branch sees C only through the line adhesion C w W, but the lift-off between
    # 6 and 7 mT brackets it: the sampled posterior uses that step, a Laplace one cannot
    assert post.attrs["undetermined"] == ""
    assert post.attrs["posterior"].startswith("MCMC (emcee") and post.attrs["posterior_method"] == "mcmc"
    assert post.sizes["sample"] == C.N_POSTERIOR
    assert post.attrs["sampling_scale"] == "log,linear,log"
    assert all(0 < t < 100 for t in post.attrs["autocorr_steps"])
    lower, upper = np.asarray(post.attrs["bounds_lower"]), np.asarray(post.attrs["bounds_upper"])
    draws = np.stack([post[n].values for n in ("F_elect", "offset_deg", "adhesion_C")], 1)
    assert np.all((draws >= lower) & (draws <= upper))
    assert np.corrcoef(draws[:, 0], draws[:, 1])[0, 1] < -0.5  # more load (F_elect) and a smaller offset (more torque) trade off
    assert post.attrs["predictive_share"] >= 0.8 and post.attrs["liftoff_share"] >= 0.99
    assert post.sizes["x_grid"] == C.GRID_POINTS
    wide, narrow = post["grid_predictive_hi"] - post["grid_predictive_lo"], post["grid_band_hi"] - post["grid_band_lo"]
    assert float(wide.mean()) > float(narrow.mean())  # new data carry the noise too


def test_the_batch_closed_form_is_the_scalar_one() -> None:
    rng = np.random.default_rng(0)
    f, off, c = 10 ** rng.uniform(-9, -4, 60), rng.uniform(-90, 90, 60), 10 ** rng.uniform(-3, 3, 60)
    fields = np.linspace(1.0, 30.0, 12)
    for fixed in ({}, {"line_adhesion": "face_fraction"}):
        batch = mc.tilt_balance_batch(fields, "paper", fixed, F_elect=f[:, None], offset_deg=off[:, None], adhesion_C=c[:, None])
        scalar = [
            [lab.cuboid_tilt_balance(b, "paper", **fixed, F_elect=f[i], offset_deg=off[i], adhesion_C=c[i]) for b in fields]
            for i in range(60)
        ]
        np.testing.assert_allclose(batch, scalar, rtol=0, atol=1e-9)
        assert 0.2 < np.mean(batch > 0) < 0.8  # both branches (flat, lifted) are exercised


def test_the_sampler_recovers_known_posteriors() -> None:
    # a straight line with unknown noise: under a flat prior the marginal posterior
    # SSR^(-n/2) of (a, b) is a bivariate t with n - 2 degrees of freedom
    rng = np.random.default_rng(3)
    x = np.linspace(0.0, 1.0, 12)
    y = 1.0 + 2.0 * x + rng.normal(0.0, 0.3, x.size)
    X = np.stack([np.ones_like(x), x], 1)
    beta, ssr = np.linalg.lstsq(X, y, rcond=None)[:2]
    nu = x.size - 2
    sd_t = np.sqrt(np.diag(float(ssr[0]) / nu * np.linalg.inv(X.T @ X)) * nu / (nu - 2))
    lo, hi = beta - 12 * sd_t, beta + 12 * sd_t  # a box that truncates nothing that matters

    def log_post(z: np.ndarray) -> np.ndarray:
        ab = lo + z * (hi - lo)
        r = np.sum((ab[:, :1] + ab[:, 1:] * x - y) ** 2, axis=1)
        return np.where(np.all((z >= 0) & (z <= 1), axis=1), -0.5 * x.size * np.log(r), -np.inf)

    ch = mc.sample_posterior(log_post, (beta - lo) / (hi - lo), 4000, seed=1)
    ab = lo + ch.z * (hi - lo)
    np.testing.assert_allclose(ab.mean(0), beta, atol=0.1 * sd_t.max())
    np.testing.assert_allclose(ab.std(0), sd_t, rtol=0.1)
    # a cliff in one dimension (a step model, as the lift-off makes), against the posterior
    # integrated on a grid
    xs = np.linspace(0.0, 1.0, 10)
    ys = np.where(xs > 0.45, 1.0, 0.0) + np.random.default_rng(4).normal(0.0, 0.2, xs.size)

    def lp1(z: np.ndarray) -> np.ndarray:
        r = np.sum((np.where(xs[None, :] > z, 1.0, 0.0) - ys) ** 2, axis=1)
        return np.where((z[:, 0] >= 0) & (z[:, 0] <= 1), -0.5 * xs.size * np.log(r), -np.inf)

    grid = np.linspace(0.0, 1.0, 20001)
    dens = np.exp(lp1(grid[:, None]) - lp1(grid[:, None]).max())
    cdf = np.cumsum(dens) / dens.sum()
    draws = mc.sample_posterior(lp1, np.array([0.45]), 4000, seed=2).z[:, 0]
    np.testing.assert_array_equal(mc.sample_posterior(lp1, np.array([0.45]), 4000, seed=2).z[:, 0], draws)  # a seed, the same draws
    for q in (0.1, 0.5, 0.9):
        assert abs(np.mean(draws <= grid[np.searchsorted(cdf, q)]) - q) < 0.04


def test_the_importance_correction_restores_what_the_chain_missed() -> None:
    # a curved ridge on the unit box (its far end pressing on the bound z1 = 1, as a low
    # F_elect against a high adhesion does), and a "chain" that stayed in its near half: the
    # corrected draws have the grid posterior's quantiles, the chain's do not
    def log_post(z: np.ndarray) -> np.ndarray:
        ok = np.all((z >= 0) & (z <= 1), axis=1)
        return np.where(ok, -0.5 * ((z[:, 1] - (0.2 + 0.9 * z[:, 0] ** 2)) / 0.05) ** 2, -np.inf)

    g = (np.arange(800) + 0.5) / 800
    zz = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    dens = np.exp(log_post(zz)).reshape(800, 800)
    cdf0 = np.cumsum(dens.sum(1)) / dens.sum()
    rng = np.random.default_rng(7)
    pts = rng.uniform(0.0, 1.0, (400000, 2))
    keep = (pts[:, 0] < 0.5) & (rng.uniform(size=len(pts)) < np.exp(log_post(pts)))
    chain = pts[keep]
    draws, ess, calls = mc.importance_correct(log_post, chain, 4000, np.random.default_rng(8))
    assert ess > 4000 and calls > 0
    for q in (0.025, 0.5, 0.975):
        exact = g[np.searchsorted(cdf0, q)]
        assert abs(np.quantile(draws[:, 0], q) - exact) < 0.03, q  # Monte Carlo: about 0.01 sd
    assert np.quantile(chain[:, 0], 0.975) < g[np.searchsorted(cdf0, 0.975)] - 0.2  # the chain alone is far off


@pytest.fixture(scope="module")
def cliff() -> tuple[C.BenchData, xr.Dataset]:
    # lift-off needs an adhesion coefficient 1/50 of the preset's: the data tilt 25 deg at
    # 4.7 mT, where the preset's adhesion would hold the robot flat up to 7 mT
    truth = {"F_elect": 2.5e-6, "offset_deg": 22.0, "adhesion_C": 3.7148 / 50}
    x = np.linspace(3.0, 15.0, 15)
    y = mc.tilt_balance_batch(x, "paper", **truth) + np.random.default_rng(0).normal(0.0, 1.0, x.size)
    data = C.BenchData("static_tilt", "field_mT", "tilt_deg", "degree", x, y, "cliff")
    return data, C.calibrate(data, list(truth), model="closed-form")


def test_cliff_draws_reproduce_the_lift_off(cliff) -> None:
    data, post = cliff
    assert post.attrs["liftoff_share"] >= 0.95
    lifted = data.y > 3.0
    pred = mc.tilt_balance_batch(data.x[lifted], "paper", **{n: post[n].values[:, None] for n in ("F_elect", "offset_deg", "adhesion_C")})
    assert np.mean(np.all(pred > 0, axis=1)) >= 0.95
    # the Laplace posterior at the same optimum puts many draws where the model stays flat
    lap = C.calibrate(data, ["F_elect", "offset_deg", "adhesion_C"], model="closed-form", posterior="laplace")
    assert lap.attrs["liftoff_share"] < 0.8
    assert "Laplace" in lap.attrs["posterior"] and "requested" in lap.attrs["posterior"]


def test_a_study_reads_the_sampled_posterior(cliff, tmp_path) -> None:
    from tumblemc.study.posterior import load_posterior

    _, post = cliff
    post.to_netcdf(tmp_path / "calib.nc")
    got = load_posterior(str(tmp_path / "calib.nc"))
    assert set(got.params) == {"F_elect", "offset_deg", "adhesion_C"}  # not noise_sd: not a Params field
    np.testing.assert_array_equal(got.draws[:, got.params.index("adhesion_C")], post["adhesion_C"].values)
    assert lab.posterior_samples(str(tmp_path / "calib.nc"), 3)[0].keys() == set(got.params)


def test_the_report_says_what_the_data_rule_out(cliff) -> None:
    _, post = cliff
    text = "\n".join(C.report(post))
    hi = np.quantile(post["adhesion_C"].values, 0.995)
    assert hi < 3.7148
    assert "the data rule out the preset's adhesion_C = 3.715 N/m^2: the 99% interval is" in text
    assert "predictive check:" in text and "inside their 95% posterior predictive band" in text
    assert "autocorrelation time" in text
    # the data bound C only from above: its draws run down to the default lower bound
    assert "adhesion_C presses on its lower bound 0.003715 N/m^2" in text and "--bounds adhesion_C=0.0003715:3715" in text
    assert "offset_deg presses" not in text and "F_elect presses" not in text


def test_a_fit_against_a_bound_names_it_and_how_to_widen_it(cliff) -> None:
    data, _ = cliff
    # the old default bounds (0.25x to 4x the preset): the posterior runs into the lower one
    post = C.calibrate(
        data, ["F_elect", "offset_deg", "adhesion_C"], {"adhesion_C": (0.9287, 14.859)}, model="closed-form", posterior="laplace"
    )
    w = post.attrs["bound_warnings"]
    assert "adhesion_C presses on its lower bound 0.9287 N/m^2 (" in w and "--bounds adhesion_C=0.09287:14.86" in w
    assert "upper bound" not in w


def test_laplace_is_the_labelled_fallback_for_the_simulator(tmp_path) -> None:
    _synthetic(tmp_path / "t.csv")
    with pytest.raises(ValueError, match="posterior='mcmc' needs the closed-form forward model"):
        C.calibrate(tmp_path / "t.csv", ["F_elect"], model="simulate", posterior="mcmc")
    with pytest.raises(ValueError, match="posterior='gibbs' is not allowed"):
        C.calibrate(tmp_path / "t.csv", ["F_elect"], posterior="gibbs")


def test_default_bounds_are_physical() -> None:
    assert bounds.default_bounds("adhesion_C") == pytest.approx((3.7148e-3, 3714.8, True))
    assert bounds.default_bounds("offset_deg") == (-90.0, 90.0, False)
    assert bounds.default_bounds("line_contact_fraction") == (0.0, 1.0, False)
    with pytest.raises(ValueError, match="F_elect = 0 in preset 'aluminum' sets no scale"):
        bounds.default_bounds("F_elect", "aluminum")
    sc = bounds.check_free(["F_elect", "adhesion_C"], {"F_elect": (0.0, 1e-5)}, "paper")
    assert sc.log.tolist() == [False, True]  # a log scale has no 0
    np.testing.assert_allclose(sc.to_values(sc.to_z([2e-6, 0.5])), [2e-6, 0.5])


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
    cov = coverage(60, seed=7)
    assert np.all(cov["coverage"].values >= 0.85), cov["coverage"].values
    assert np.all(cov["coverage"].values <= 1.0)


def test_one_free_parameter_against_its_bound_is_sampled() -> None:
    # one free parameter whose posterior presses on its upper bound: emcee's snooker move is
    # degenerate in one dimension (NaN proposals, "At least one parameter value was NaN")
    x = np.linspace(3.0, 15.0, 15)
    y = [-0.458, -1.901, -1.29, -1.842, -0.235, 22.265, 29.288, 33.119, 35.724, 35.671, 39.454, 41.408, 42.78, 42.152, 44.068]
    data = C.BenchData("static_tilt", "field_mT", "tilt_deg", "degree", x, np.array(y), "offset 34.89 deg, 1 deg noise")
    post = C.calibrate(data, ["offset_deg"], model="closed-form", bounds={"offset_deg": (10.0, 35.0)}, seed=1)
    lo, hi = np.quantile(post["offset_deg"].values, [0.025, 0.975])
    assert 34.0 < lo < 34.89 < hi <= 35.0, (lo, hi)


def test_a_known_noise_sd_replaces_the_marginalised_one() -> None:
    x = np.linspace(3.0, 15.0, 15)
    y = [-0.458, -1.901, -1.29, -1.842, -0.235, 22.265, 29.288, 33.119, 35.724, 35.671, 39.454, 41.408, 42.78, 42.152, 44.068]
    data = C.BenchData("static_tilt", "field_mT", "tilt_deg", "degree", x, np.array(y), "offset 34.89 deg, 1 deg noise")
    known = C.calibrate(data, ["offset_deg"], model="closed-form", bounds={"offset_deg": (10.0, 35.0)}, seed=1, noise_sd=3.0)
    assert known.attrs["noise_model"] == "known sd 3" and np.all(known["noise_sd"].values == 3.0)
    assert "noise: known sd 3" in "\n".join(C.report(known))
    unknown = C.calibrate(data, ["offset_deg"], model="closed-form", bounds={"offset_deg": (10.0, 35.0)}, seed=1)
    assert float(known["offset_deg"].std()) > 1.5 * float(unknown["offset_deg"].std())  # 3 deg against the residuals' 1
    for bad, kw in ((-1.0, {}), (float("nan"), {}), (1.0, {"posterior": "laplace"})):
        with pytest.raises(ValueError, match="noise_sd=.* is not allowed"):
            C.calibrate(data, ["offset_deg"], model="closed-form", noise_sd=bad, **kw)


def test_coverage_draws_each_truth_from_the_prior() -> None:
    prior = {"F_elect": (1e-6, 1e-5), "offset_deg": (10.0, 35.0)}
    cov = coverage(2, dict.fromkeys(prior, 0.0), noise_deg=1.0, seed=5, prior=prior, n_posterior=200)
    v = cov["truth_value"].values
    assert v.shape == (2, 2) and v[0, 0] != v[1, 0] and v[0, 1] != v[1, 1]
    assert np.all((v >= [1e-6, 10.0]) & (v <= [1e-5, 35.0])), v
    assert np.all((cov["rank"].values >= 0.0) & (cov["rank"].values <= 1.0))
    with pytest.raises(ValueError, match="prior= draws each truth"):
        coverage(1, dict.fromkeys(prior, 0.0), prior=prior, shift_mT=1.0)


@pytest.mark.slow
def test_the_posterior_is_calibrated_over_its_prior() -> None:
    # simulation-based calibration: truths drawn from the prior the posterior assumes, so an
    # exact posterior's 95% intervals hold them 95% of the time, averaged over the prior
    # (docs/notes/calibration_coverage.md measures 0.92-0.94 over 400), and ranks them
    # uniformly: at least 25 of 30 (P(fewer) about 0.3% at a true 95%; the chain's draws
    # alone, before the importance correction, needed 24) and KS p > 0.001; a posterior too
    # narrow (noise underrated, a stuck sampler) or shifted fails both
    from scipy import stats

    prior = {"F_elect": (1e-6, 1e-5), "offset_deg": (10.0, 35.0), "adhesion_C": (0.03, 30.0)}
    cov = coverage(30, dict.fromkeys(prior, 0.0), tuple(np.linspace(3.0, 15.0, 15)), noise_deg=1.0, seed=3, prior=prior)
    assert np.all(cov["covered"].values.sum(axis=0) >= 25), cov["coverage"].values
    for j in range(3):
        assert stats.kstest(cov["rank"].values[:, j], "uniform").pvalue > 1e-3, cov["rank"].values[:, j]


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
    assert "posterior: MCMC (emcee" in text and "predictive check:" in text
    with xr.open_dataset(out) as ds:
        assert ds.sizes["sample"] == 500 and "F_elect" in ds and ds.attrs["test"] == "static_tilt"
        assert "param" not in ds.sel(param="F_elect").dims  # xarray selects a parameter by name
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
    # the simulator's speeds are rough in mu (a fit through them is a Laplace fallback, its
    # interval linearised and not calibrated: "linearised" in the report); at the default
    # step (2.5e-5 s at 25 and 35 Hz, issue 45) the 99% interval ends at 0.2996, just short
    # of the truth, at 5e-5 s it held it: the recovery is what is tested, to 5%
    lo, hi = np.quantile(post["mu"].values, [0.005, 0.995])
    assert abs(float(np.median(post["mu"].values)) - 0.3) < 0.015 and lo < hi < 0.32 and lo > 0.27
    assert post.attrs["test"] == "speed" and post["fit"].attrs["units"] == "mm s-1"
    assert post.attrs["posterior"].endswith("(fallback: simulator forward model)") and post.attrs["posterior_method"] == "laplace"
    assert "linearised" in "\n".join(C.report(post))
    assert len(post.attrs["jacobian_step_ratio"]) == 1


@pytest.mark.slow
def test_coverage_campaign_small_version() -> None:
    # the issue-14 protocol (tools/calibration_coverage.py, docs/notes/calibration_coverage.md) at
    # 20 replicates: simulated tilts at known parameters, 1 deg noise, 15 fields, 3 free;
    # F_elect and offset_deg at least 80% (P(fewer) < 0.5% at a true 95%). adhesion_C is
    # determined only by the lift-off, between the last flat field (5.57 mT) and the first
    # lifted one (6.43 mT); its posterior is flat between them and the truth's lift-off
    # (5.63 mT) sits near one end, so its coverage at this fixed grid is below nominal
    # (0.80 at 50 replicates, docs/notes/calibration_coverage.md); with the grid shifted
    # per replicate it is nominal (the campaign's shifted case)
    truth = {"F_elect": 2.5e-6, "offset_deg": 22.0, "adhesion_C": 5.0}
    fields = np.linspace(3.0, 15.0, 15)
    clean = lab.static_tilt(fields, **truth)["tilt_deg"].values
    cov = coverage(20, truth, fields, noise_deg=1.0, seed=3, clean=clean)
    assert np.all(cov["coverage"].values[:2] >= 0.8), cov["coverage"].values
    assert cov["coverage"].values[2] >= 0.5, cov["coverage"].values
    assert np.nanmin(cov["liftoff_share"].values) >= 0.9 and float(cov["heldout_share"].mean()) >= 0.85


def test_auto_model_fits_the_closed_form_and_checks_it_with_the_simulator(tmp_path) -> None:
    _synthetic(tmp_path / "t.csv")
    post = C.calibrate(tmp_path / "t.csv", ["F_elect", "offset_deg"], n_posterior=200, posterior="laplace")  # laplace: quicker
    assert post.attrs["model"] == "auto" and post.attrs["fit_model"] == "closed-form"
    assert 0.0 <= post.attrs["simulator_check_rms"] < 0.05  # degrees: the two models agree
    with pytest.raises(ValueError, match="model='exact' is not allowed"):
        C.calibrate(tmp_path / "t.csv", ["F_elect"], model="exact")


@pytest.mark.slow
def test_the_quick_coverage_campaign(tmp_path) -> None:
    # tools/calibration_coverage.py --quick: the 1/50-adhesion case, 5 replicates (about 15 s)
    mod = load_tool("calibration_coverage")
    mod.main(["--quick", "--out", str(tmp_path / "cov.md")])
    text = (tmp_path / "cov.md").read_text()
    rows = {
        r.split("|")[1].strip(): [float(v) for v in r.split("|")[2:5]]
        for r in text.splitlines()
        if r.startswith("| share") or r.startswith("| fit")
    }
    assert rows["share of draws reproducing the lift-off the data show"][1] >= 0.9  # the worst replicate
    assert rows["share of held-out points in the 95% predictive band"][0] >= 0.85
    assert rows["fit time (s, one core)"][2] < 60.0
