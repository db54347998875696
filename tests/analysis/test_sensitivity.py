"""Sensitivity analysis and scenario discovery against analytic benchmarks.

Tolerances say what kind of check each test is:

- REGRESSION (exact arithmetic, rounding only): design layout, closed-form indices.
- STATISTICAL: estimates from finite samples against the closed form. Seeds are fixed,
  so the tests are deterministic, but the tolerance is sized from the estimator's
  sampling error (a few bootstrap or binomial standard errors), not from rounding; a new
  seed may move an estimate within it.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr

from tumblemc.analysis.prim import failure_region, prim_box
from tumblemc.analysis.screening import logistic_summary, rank_correlation
from tumblemc.analysis.sobol import saltelli_design, sobol_indices, split_saltelli
from tumblemc.model.params import RANGES
from tumblemc.study.config import load_config
from tumblemc.study.distributions import nominal_value
from tumblemc.study.sobol import salib_problem, salib_rows, sobol_rows
from tumblemc.testing import (
    BOX_FAILURE_BOX,
    ISHIGAMI_BOUNDS,
    SYNTHETIC_ALL_SUCCESS,
    SYNTHETIC_SEPARATED,
    box_failure,
    box_failure_indices,
    ishigami,
    ishigami_indices,
    linear_additive,
    linear_indices,
    synthetic_runs,
)
from tumblemc.viz.sensitivity import plot_prim, plot_sobol, plot_success_vs_parameter

# REGRESSION: literature values of the Ishigami indices (a = 7, b = 0.1) to 4 decimals
ISHIGAMI_LITERATURE = {"S1": (0.3139, 0.4424, 0.0), "ST": (0.5576, 0.4424, 0.2437)}
LITERATURE_ATOL = 5e-5
# STATISTICAL: Ishigami at n = 2**12 base rows; every index within 3 of its own
# bootstrap standard errors (measured: at most 0.7 SE)
ISHIGAMI_N = 2**12
ISHIGAMI_N_SE = 3.0
# REGRESSION (fixed seed): linear additive model at n = 2**10; measured errors 1.4e-4 (S1)
# and 3e-8 (ST: Jansen's estimator is exact for an additive model up to the sampling of
# (A_i - B_i)^2)
LINEAR_S1_ATOL = 1e-3
LINEAR_ST_ATOL = 1e-6
# STATISTICAL: SALib's estimates on tumblemc's design, N = 2**10, inside tumblemc's 95%
# bootstrap intervals (same estimators; SALib centres on the mean of every output, tumblemc
# on that of yA and yB: measured difference 1e-6, interval half-widths ~0.05)
SALIB_N = 2**10
# REGRESSION: the physical export scaled by SALib against tumblemc's quantile functions;
# a lognormal is exported without tumblemc's cut at <= 1e-6 of its mass
PHYSICAL_RTOL = 1e-6
# STATISTICAL: ~390 valid runs per cell; SE of Spearman rho under independence is
# 1 / sqrt(n - 1) ~ 0.05, so |rho| < 0.2 is 4 SE; logistic coefficients within 4 SE.
RHO_NULL_ATOL = 0.2
N_SE = 4.0
# STATISTICAL: PRIM boundary on 4000 uniform points; one peel moves a bound by
# alpha x (box width) <= 0.05, plus the gap between neighbouring points.
PRIM_BOUND_ATOL = 0.05


def _unit_to(bounds: tuple[tuple[float, float], ...], U: np.ndarray) -> np.ndarray:
    lo = np.array([b[0] for b in bounds])
    hi = np.array([b[1] for b in bounds])
    return lo + (hi - lo) * U


# ------------------------------------------------------------------------------ design


def test_saltelli_design_layout() -> None:
    n, d = 16, 3
    des = saltelli_design(n, d, seed=5)
    assert des.A.shape == (n, d) and des.B.shape == (n, d) and des.AB.shape == (d, n, d)
    for i in range(d):
        others = [j for j in range(d) if j != i]
        np.testing.assert_array_equal(des.AB[i][:, i], des.B[:, i])
        np.testing.assert_array_equal(des.AB[i][:, others], des.A[:, others])
    stacked = des.stack()
    assert stacked.shape == (n * (d + 2), d)
    assert np.all((stacked >= 0.0) & (stacked < 1.0))
    # SALib row order, and split_saltelli is its inverse
    np.testing.assert_array_equal(stacked[0], des.A[0])
    np.testing.assert_array_equal(stacked[1], des.AB[0][0])
    np.testing.assert_array_equal(stacked[d + 1], des.B[0])
    code = stacked @ np.array([1.0, 10.0, 100.0])
    yA, yB, yAB = split_saltelli(code, d)
    np.testing.assert_array_equal(yA, des.A @ [1.0, 10.0, 100.0])
    np.testing.assert_array_equal(yB, des.B @ [1.0, 10.0, 100.0])
    np.testing.assert_array_equal(yAB, des.AB @ [1.0, 10.0, 100.0])
    np.testing.assert_array_equal(saltelli_design(n, d, seed=5).stack(), stacked)
    assert not np.array_equal(saltelli_design(n, d, seed=6).A, des.A)


def test_saltelli_design_rejects_non_power_of_two() -> None:
    with pytest.raises(ValueError, match="power of 2.*use 64 or 128"):
        saltelli_design(100, 2, seed=0)
    with pytest.raises(ValueError, match="d must be"):
        saltelli_design(8, 0, seed=0)


def test_sobol_rows_map_config_distributions() -> None:
    config = load_config(
        {
            "name": "sens",
            "shapes": ["cuboid"],
            "presets": ["paper", "aluminum"],
            "incline_deg": [0, 30],
            "field_mT": 20,
            "freq_hz": 1,
            "samples": 4,
            "seed": 1,
        }
    )
    n = 8
    d = len(config.uncertain)
    U, rows = sobol_rows(config, n, 3, "cuboid", "aluminum", 30.0)
    assert U.shape == (n * (d + 2), d) and len(rows) == U.shape[0]
    np.testing.assert_array_equal(U, saltelli_design(n, d, 3).stack())
    for j, unc in enumerate(config.uncertain):
        col = np.array([r[unc.param] for r in rows])
        # the config's distribution at the preset's nominal value, applied to the unit column
        expect = unc.resolve(nominal_value(unc.param, "aluminum", 20.0)).ppf(U[:, j])
        np.testing.assert_array_equal(col, expect)
        r = RANGES[unc.param]
        assert np.all([r.contains(v) for v in col])
        # a monotone map: the unit column and the values are in the same order
        assert np.all(np.diff(col[np.argsort(U[:, j])]) >= 0.0)
    row = rows[0]
    assert (row["shape"], row["preset"], row["incline_deg"], row["field_mT"], row["freq_hz"]) == ("cuboid", "aluminum", 30.0, 20.0, 1.0)
    assert row["periods"] == config.periods


# ----------------------------------------------------------------------- Sobol indices


def test_ishigami_closed_form_matches_literature() -> None:
    ref = ishigami_indices()
    for key, lit in ISHIGAMI_LITERATURE.items():
        np.testing.assert_allclose(ref[key], lit, atol=LITERATURE_ATOL)


def test_sobol_indices_ishigami() -> None:
    des = saltelli_design(ISHIGAMI_N, 3, seed=1)
    y = ishigami(_unit_to(ISHIGAMI_BOUNDS, des.stack()))
    ind = sobol_indices(*split_saltelli(y, 3), names=["x1", "x2", "x3"], n_boot=1000, seed=0)
    ref = ishigami_indices()
    assert ind.attrs["n_used"] == ISHIGAMI_N and ind.attrs["n_dropped"] == 0
    for key in ("S1", "ST"):
        est, lo, hi = ind[key].values, ind[f"{key}_lower"].values, ind[f"{key}_upper"].values
        assert np.all((lo <= ref[key]) & (ref[key] <= hi)), (key, est, lo, hi, ref[key])
        assert np.all(np.abs(est - ref[key]) < ISHIGAMI_N_SE * ind[f"{key}_se"].values), (key, est, ref[key])
    for name, v in ind.data_vars.items():
        assert v.attrs["units"] == "1" and v.attrs["long_name"], name


def test_sobol_indices_linear_additive() -> None:
    c = [1.0, 2.0, 0.5, 0.0]
    des = saltelli_design(2**10, 4, seed=2)
    ind = sobol_indices(*split_saltelli(linear_additive(des.stack(), c), 4), n_boot=200)
    ref = linear_indices(c)
    np.testing.assert_allclose(ind["S1"].values, ref["S1"], atol=LINEAR_S1_ATOL)
    np.testing.assert_allclose(ind["ST"].values, ref["ST"], atol=LINEAR_ST_ATOL)
    # REGRESSION: an input with no effect has ST exactly 0 (yA == yAB_i row by row)
    assert ind["ST"].values[3] == 0.0


def test_sobol_indices_drop_non_finite_rows() -> None:
    des = saltelli_design(2**8, 3, seed=3)
    yA, yB, yAB = split_saltelli(ishigami(_unit_to(ISHIGAMI_BOUNDS, des.stack())), 3)
    bad = np.zeros(yA.size, dtype=bool)
    bad[[3, 50, 51]] = True
    yA2, yAB2 = yA.copy(), yAB.copy()
    yA2[3] = np.nan
    yAB2[1, 50] = np.inf
    yAB2[2, 51] = np.nan
    got = sobol_indices(yA2, yB, yAB2, n_boot=50)
    want = sobol_indices(yA[~bad], yB[~bad], yAB[:, ~bad], n_boot=50)
    assert got.attrs["n_dropped"] == 3 and got.attrs["n_used"] == yA.size - 3
    np.testing.assert_array_equal(got["S1"].values, want["S1"].values)
    np.testing.assert_array_equal(got["ST"].values, want["ST"].values)
    with pytest.raises(ValueError, match="constant"):
        sobol_indices(np.ones(8), np.ones(8), np.ones((2, 8)))


def test_sobol_indices_binary_box_failure() -> None:
    # a 0/1 output, as tumblemc's verdicts: indices of the box indicator in closed form
    des = saltelli_design(ISHIGAMI_N, 3, seed=7)
    ind = sobol_indices(*split_saltelli(box_failure(des.stack()), 3), n_boot=500, seed=1)
    ref = box_failure_indices()
    for key in ("S1", "ST"):
        est = ind[key].values
        assert np.all(np.abs(est - ref[key]) <= ISHIGAMI_N_SE * ind[f"{key}_se"].values + 1e-12), (key, est, ref[key])
    # REGRESSION: x3 has no effect, so every AB_3 row equals its A row
    assert ind["ST"].values[2] == 0.0 and ind["S1"].values[2] == 0.0


# ---------------------------------------------------------------------- SALib interop

SENS_CONFIG = {
    "name": "sens",
    "shapes": ["cuboid"],
    "presets": ["paper", "aluminum"],
    "incline_deg": [0, 30],
    "field_mT": 20,
    "freq_hz": 1,
    "samples": 4,
    "seed": 1,
    # every distribution kind, absolute and relative
    "uncertain": {
        "mu": {"dist": "truncnormal", "rel_sd": 0.15},
        "adhesion_C": {"dist": "lognormal", "cv": 0.3},
        "offset_deg": {"dist": "normal", "sd": 5.0},
        "magnetization": {"dist": "uniform", "rel_low": 0.9, "rel_high": 1.1},
        "e_r": {"dist": "triangular", "rel_low": 0.8, "rel_high": 1.2},
    },
}


def test_salib_problem_round_trip() -> None:
    config = load_config(SENS_CONFIG)
    d = len(config.uncertain)
    U, rows = sobol_rows(config, 8, 3, "cuboid", "aluminum", 30.0)
    unit = salib_problem(config, "aluminum")
    assert unit == {"num_vars": d, "names": list(config.uncertain_names), "bounds": [[0.0, 1.0]] * d, "dists": ["unif"] * d}
    assert salib_rows(config, unit, U, "cuboid", "aluminum", 30.0) == rows
    # columns in another order, named by the problem
    perm = np.arange(d)[::-1]
    shuffled = {**unit, "names": [unit["names"][j] for j in perm]}
    assert salib_rows(config, shuffled, U[:, perm], "cuboid", "aluminum", 30.0) == rows
    # physical space: the values themselves
    phys = salib_problem(config, "aluminum", space="physical")
    assert phys["names"] == unit["names"] and set(phys["dists"]) == {"truncnorm", "lognorm", "unif", "triang"}
    X = np.array([[r[p] for p in phys["names"]] for r in rows])
    assert salib_rows(config, phys, X, "cuboid", "aluminum", 30.0) == rows
    with pytest.raises(ValueError, match="not the config's uncertain parameters"):
        salib_rows(config, {**unit, "names": ["mu", *unit["names"][1:]]}, U, "cuboid", "aluminum", 30.0)
    with pytest.raises(ValueError, match="neither a unit-space problem"):
        salib_rows(config, phys, X, "cuboid", "paper", 30.0)  # paper's nominals differ
    with pytest.raises(ValueError, match="outside its physical range"):
        salib_rows(config, phys, np.where(np.arange(d) == phys["names"].index("mu"), -1.0, X[:1]), "cuboid", "aluminum", 30.0)


def test_salib_physical_export_matches_tumblemc_quantiles() -> None:
    util = pytest.importorskip("SALib.util")
    config = load_config(SENS_CONFIG)
    U, rows = sobol_rows(config, 16, 4, "curved", "paper", 0.0)
    phys = salib_problem(config, "paper", space="physical")
    got = util.scale_samples(U.copy(), phys)
    want = np.array([[r[p] for p in phys["names"]] for r in rows])
    np.testing.assert_allclose(got, want, rtol=PHYSICAL_RTOL)


def test_salib_sobol_agrees_within_bootstrap_intervals() -> None:
    pytest.importorskip("SALib")
    from SALib.analyze import sobol as salib_sobol
    from SALib.sample import sobol as salib_sample

    problem = {"num_vars": 3, "names": ["x1", "x2", "x3"], "bounds": [list(b) for b in ISHIGAMI_BOUNDS]}
    des = saltelli_design(SALIB_N, 3, seed=2)
    # REGRESSION: SALib's sampler with a Generator seed is tumblemc's design, scaled
    X = salib_sample.sample(problem, SALIB_N, calc_second_order=False, seed=np.random.default_rng(2))
    np.testing.assert_allclose(X, _unit_to(ISHIGAMI_BOUNDS, des.stack()), rtol=1e-12, atol=1e-12)
    y = ishigami(X)
    ours = sobol_indices(*split_saltelli(y, 3), n_boot=1000, seed=0)
    theirs = salib_sobol.analyze(problem, y, calc_second_order=False, num_resamples=100, seed=1)
    for key in ("S1", "ST"):
        lo, hi = ours[f"{key}_lower"].values, ours[f"{key}_upper"].values
        assert np.all((lo <= theirs[key]) & (theirs[key] <= hi)), (key, lo, theirs[key], hi)


# ------------------------------------------------------------------- per-cell analyses


def _cell(ds: xr.Dataset, spec: Mapping[str, Any]) -> xr.Dataset:
    return ds.sel(shape=spec["shape"], substrate=spec["substrate"], incline_deg=spec["incline_deg"])


def _ordinary_cells(ds: xr.Dataset) -> list[xr.Dataset]:
    out = []
    for shape in ds["shape"].values:
        for sub in ds["substrate"].values:
            for inc in ds["incline_deg"].values:
                spec = {"shape": shape, "substrate": sub, "incline_deg": inc}
                if spec not in (SYNTHETIC_ALL_SUCCESS, SYNTHETIC_SEPARATED):
                    out.append(_cell(ds, spec))
    return out


def test_rank_correlation_recovers_mu() -> None:
    runs = synthetic_runs()
    rc = rank_correlation(runs)
    assert rc["rho"].dims == ("shape", "substrate", "incline_deg", "parameter")
    others = [p for p in rc["parameter"].values if p != "mu"]
    for cell in [*_ordinary_cells(rc), _cell(rc, SYNTHETIC_ALL_SUCCESS)]:
        assert cell["rho"].sel(parameter="mu") > 0.8
        assert cell["rho_lower"].sel(parameter="mu") > 0.7
        assert cell["p_value"].sel(parameter="mu") < 1e-10
        assert np.all(np.abs(cell["rho"].sel(parameter=others).values) < RHO_NULL_ATOL)
    assert np.all(rc["n_valid"].values > 350)
    for name, v in rc.data_vars.items():
        assert "units" in v.attrs and v.attrs["long_name"], name


def test_rank_correlation_binary_outcome_and_flat_cell() -> None:
    rc = rank_correlation(synthetic_runs(), outcome="climbed")
    flat = _cell(rc, SYNTHETIC_ALL_SUCCESS)
    assert bool(flat["no_variation"]) and np.all(np.isnan(flat["rho"].values))
    assert int(rc["no_variation"].sum()) == 1
    for cell in _ordinary_cells(rc):
        assert cell["rho"].sel(parameter="mu") > 0.5


def test_logistic_summary_recovers_mu() -> None:
    slope = 3.0
    runs = synthetic_runs(slope=slope)
    lg = logistic_summary(runs)
    assert lg["coef"].dims == ("shape", "substrate", "incline_deg", "parameter")
    others = [p for p in lg["parameter"].values if p != "mu"]
    for cell in _ordinary_cells(lg):
        mu = cell.sel(parameter="mu")
        assert bool(cell["converged"]) and not bool(cell["separated"]) and not bool(cell["no_variation"])
        assert abs(float(mu["coef"]) - slope) < N_SE * float(mu["coef_se"])
        rest = cell.sel(parameter=others)
        assert np.all(np.abs(rest["coef"].values) < N_SE * rest["coef_se"].values)
        assert float(mu["coef"]) > 3.0 * np.max(np.abs(rest["coef"].values))
    flat = _cell(lg, SYNTHETIC_ALL_SUCCESS)
    assert bool(flat["no_variation"]) and float(flat["p_success"]) == 1.0
    assert np.all(np.isnan(flat["coef"].values))
    sep = _cell(lg, SYNTHETIC_SEPARATED)
    assert bool(sep["separated"]) and not bool(sep["no_variation"])
    coef = sep["coef"]
    assert np.all(np.isfinite(coef.values)) and float(coef.sel(parameter="mu")) > 3.0 * np.max(np.abs(coef.sel(parameter=others).values))
    assert int(lg["separated"].sum()) == 1
    for name, v in lg.data_vars.items():
        assert "units" in v.attrs and v.attrs["long_name"], name
    assert list(lg["parameter_units"].values) == ["N/m^2", "A/m", "1", "degree"]


# --------------------------------------------------------------------------------- PRIM


def test_prim_recovers_known_box() -> None:
    rng = np.random.default_rng(11)
    X = rng.uniform(size=(4000, 4))
    res = prim_box(X, box_failure(X), ["x1", "x2", "x3", "x4"], alpha=0.05, min_support=0.05)
    assert set(res.box) == {"x1", "x2"}
    (lo1, hi1), (lo2, hi2) = res.box["x1"], res.box["x2"]
    assert abs(lo1 - BOX_FAILURE_BOX[0][0]) < PRIM_BOUND_ATOL and hi1 == np.inf
    assert abs(hi2 - BOX_FAILURE_BOX[1][1]) < PRIM_BOUND_ATOL and lo2 == -np.inf
    assert res.density >= 0.99 and res.coverage > 0.85
    traj = res.trajectory
    assert traj.attrs["chosen_step"] == res.step
    assert np.all(np.diff(traj["support"].values) < 0) and traj["support"].values[-1] >= 0.05
    np.testing.assert_array_equal(res.contains(X).sum(), traj["n_in_box"].values[res.step])


def test_failure_region_of_a_study_cell() -> None:
    runs = synthetic_runs()
    sep = failure_region(runs, **SYNTHETIC_SEPARATED)
    assert set(sep.box) == {"mu"} and sep.density == 1.0 and sep.coverage > 0.95
    # climbs iff mu > 0.3: a box of density 1 cannot reach past 0.3
    assert sep.box["mu"][0] == -np.inf and 0.3 - 0.01 < sep.box["mu"][1] <= 0.3
    with pytest.raises(ValueError, match="nothing to find"):
        failure_region(runs, **SYNTHETIC_ALL_SUCCESS)


# -------------------------------------------------------------------------------- plots


def test_sensitivity_plots_write_png(tmp_path: Path) -> None:
    des = saltelli_design(2**8, 3, seed=4)
    ind = sobol_indices(*split_saltelli(ishigami(_unit_to(ISHIGAMI_BOUNDS, des.stack())), 3), n_boot=100)
    runs = synthetic_runs(per_cell=60)
    res = failure_region(runs, "curved", "paper", 0.0)
    paths = [tmp_path / f"{k}.png" for k in ("sobol", "vs_cell", "vs_all", "prim")]
    plot_sobol(ind, paths[0])
    plot_success_vs_parameter(runs, "curved", "paper", 0.0, paths[1])
    plot_success_vs_parameter(runs, "cuboid", "paper", path=paths[2])  # every incline, one all-success
    fig = plot_prim(res.trajectory, paths[3])
    assert fig.axes
    for p in paths:
        assert p.stat().st_size > 1000, p


def test_robot_sobol_end_to_end_small() -> None:
    """The robot path runs and returns indices for every uncertain parameter.

    A smoke test of the plumbing: n = 4 is far too small for meaningful values.
    """
    from tumblemc.study.config import load_config
    from tumblemc.study.sobol import robot_sobol

    cfg = load_config(
        {
            "name": "s",
            "shapes": ["cuboid"],
            "presets": ["paper"],
            "incline_deg": [10],
            "field_mT": 20,
            "freq_hz": 10,
            "samples": 1,
            "seed": 1,
        }
    )
    idx = robot_sobol(cfg, "cuboid", "paper", 10.0, n=4, n_boot=50)
    assert list(idx["parameter"].values) == list(cfg.uncertain_names)
    # every run of the design ran and gave a finite progress ratio
    assert idx.attrs["n_used"] == 4 and idx.attrs["n_dropped"] == 0
    assert np.all(np.isfinite(idx["ST"].values)) and np.all(np.isfinite(idx["S1"].values))


@pytest.mark.slow
def test_the_salib_morris_example_in_the_docs_runs(monkeypatch: pytest.MonkeyPatch) -> None:
    """docs/guide/libraries.md's Morris example, as written (100 runs of the default study's cell)."""
    import re

    pytest.importorskip("SALib")
    root = Path(__file__).resolve().parents[2]
    code = re.findall(r"```python\n(.*?)```", (root / "docs" / "guide" / "libraries.md").read_text(), re.S)
    assert len(code) == 1
    monkeypatch.chdir(root)
    ns: dict[str, Any] = {}
    exec(code[0], ns)  # noqa: S102 - the documentation's own example
    Si = ns["Si"]
    assert list(Si["names"]) == ["adhesion_C", "magnetization", "mu", "offset_deg"]
    assert np.all(np.isfinite(Si["mu_star"])) and np.all(np.asarray(Si["mu_star"]) >= 0)
