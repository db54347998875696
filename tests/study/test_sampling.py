"""Study design: config validation, seeds keyed by run id, distributions, run table.

Statistical checks use fixed seeds (so they are deterministic regressions of a draw that
passed) with tolerances stated in standard errors of the estimate.
"""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy import stats

from tumblemc.model.params import PRESETS, RANGES, Params
from tumblemc.model.run import run_inputs
from tumblemc.study.checks import ConfigError
from tumblemc.study.config import StudyConfig, cells, load_config
from tumblemc.study.design import design, params_for_run, run_kwargs
from tumblemc.study.distributions import DEFAULT_UNCERTAIN, NEGLIGIBLE_MASS, UNCERTAIN_PARAMS
from tumblemc.study.identity import config_hash, config_to_json

STUDIES = Path(__file__).resolve().parents[2] / "studies"
N_SE = 4.0  # tolerance of the statistical checks, in standard errors of the estimate
KS_P_MIN = 1e-3  # smallest Kolmogorov-Smirnov p-value accepted (fixed seed)

BASE: dict[str, Any] = {
    "name": "t",
    "shapes": ["cuboid"],
    "presets": ["aluminum"],
    "incline_deg": [0, 30],
    "field_mT": 20,
    "freq_hz": 1,
    "samples": 8,
    "seed": 7,
}


def cfg(**changes: Any) -> StudyConfig:
    d = copy.deepcopy(BASE)
    for k, v in changes.items():
        if v is None:
            d.pop(k, None)
        else:
            d[k] = v
    return load_config(d)


def by_key(ds: Any, var: str) -> dict[int, float]:
    return dict(zip(ds["run_key"].values.tolist(), ds[var].values.tolist(), strict=True))


# ------------------------------------------------------------------------------ errors


def _set(path: str, value: Any) -> dict[str, Any]:
    """BASE with ``value`` at dotted ``path`` (``None``: key removed)."""
    d = copy.deepcopy(BASE)
    *head, last = path.split(".")
    t = d
    for k in head:
        t = t.setdefault(k, {})
    if value is None:
        t.pop(last, None)
    else:
        t[last] = value
    return d


def _unc(**spec: Any) -> dict[str, Any]:
    return {**copy.deepcopy(BASE), "uncertain": {"mu": spec}}


BAD: list[tuple[str, dict[str, Any], str, list[str]]] = [
    # (id, config, key path in the error, fragments of the message)
    ("unknown top key", _set("sampels", 8), "sampels", ["did you mean 'samples'"]),
    ("unknown check key", _set("check.fractoin", 0.1), "check.fractoin", ["did you mean 'fraction'"]),
    ("unknown execution key", _set("execution.batchsize", 4), "execution.batchsize", ["batch_size"]),
    ("unknown uncertain param", _set("uncertain.muu", {"dist": "normal", "sd": 0.01}), "uncertain.muu", ["did you mean 'mu'"]),
    ("unknown dist key", _unc(dist="truncnormal", rel_sdd=0.1), "uncertain.mu.rel_sdd", ["did you mean 'rel_sd'"]),
    ("param of another dist", _unc(dist="normal", cv=0.1), "uncertain.mu.cv", ["dist='lognormal'", "not of dist='normal'", "rel_sd"]),
    ("missing name", _set("name", None), "name", ["missing"]),
    ("missing seed", _set("seed", None), "seed", ["missing"]),
    ("missing samples", _set("samples", None), "samples", ["missing"]),
    ("missing shapes", _set("shapes", None), "shapes", ["missing"]),
    ("missing incline", _set("incline_deg", None), "incline_deg", ["missing"]),
    ("missing dist", _unc(rel_sd=0.1), "uncertain.mu.dist", ["missing", "truncnormal"]),
    ("samples str", _set("samples", "16"), "samples", ["'16'", "not an integer"]),
    ("samples float", _set("samples", 2.5), "samples", ["2.5", "not an integer"]),
    ("seed bool", _set("seed", True), "seed", ["True", "not an integer"]),
    ("shapes str", _set("shapes", "cuboid"), "shapes", ["'cuboid'", "list"]),
    ("name not str", _set("name", 5), "name", ["5", "string"]),
    ("incline str", _set("incline_deg", "30"), "incline_deg", ["'30'"]),
    ("check not table", _set("check", 3), "check", ["3", "table"]),
    ("uncertain spec not table", _set("uncertain.mu", 0.1), "uncertain.mu", ["0.1", "table"]),
    ("incline out of range", _set("incline_deg", [0, 90]), "incline_deg[1]", ["90", "[-89, 89]"]),
    ("incline duplicate", _set("incline_deg", [0, 0.0]), "incline_deg", ["duplicates"]),
    ("incline nan", _set("incline_deg", [math.nan]), "incline_deg[0]", ["nan", "out of range"]),
    ("incline step 0", _set("incline_deg", {"start": 0, "stop": 60, "step": 0}), "incline_deg.step", ["0", "> 0"]),
    ("incline stop < start", _set("incline_deg", {"start": 10, "stop": 0, "step": 5}), "incline_deg.stop", ["start"]),
    ("incline table key", _set("incline_deg", {"start": 0, "end": 60, "step": 5}), "incline_deg.end", ["allowed: start, stop, step"]),
    ("field zero", _set("field_mT", 0), "field_mT", ["0", "(0, 1000]"]),
    ("freq negative", _set("freq_hz", [1, -1]), "freq_hz[1]", ["-1"]),
    ("periods < 2", _set("periods", 1.5), "periods", ["1.5", "[2, "]),
    ("transient too long", _set("transient_periods", 1.5), "transient_periods", ["1.5", "periods - 1"]),
    ("samples zero", _set("samples", 0), "samples", ["0", "[1, "]),
    ("seed negative", _set("seed", -1), "seed", ["-1"]),
    ("ci_level", _set("ci_level", 1.5), "ci_level", ["1.5"]),
    ("success_ratio", _set("success_ratio", 0), "success_ratio", ["0", "(0, 1]"]),
    ("check fraction", _set("check.fraction", 2.0), "check.fraction", ["2.0", "[0, 1]"]),
    ("dt_factor", _set("check.dt_factor", 1), "check.dt_factor", ["1", "[2, 64]"]),
    ("batch_size", _set("execution.batch_size", 0), "execution.batch_size", ["0"]),
    ("dt", _set("dt", 1.0), "dt", ["1.0"]),
    ("bad name", _set("name", "my study"), "name", ["'my study'", "letters"]),
    ("bad sampler", _set("sampler", "halton"), "sampler", ["'halton'", "'sobol'"]),
    ("sampler typo", _set("sampler", "sobl"), "sampler", ["did you mean 'sobol'"]),
    ("bad ci", _set("ci", "wald"), "ci", ["'wald'", "'wilson'"]),
    ("bad mode", _set("mode", "critical"), "mode", ["'critical'", "'grid'", "'critical_incline'"]),
    ("bad torque", _set("torque", "middle"), "torque", ["'middle'", "'start'"]),
    ("unknown shape", _set("shapes", ["cuboid", "sphere"]), "shapes[1]", ["'sphere'", "cuboid"]),
    ("unknown preset", _set("presets", ["glass"]), "presets[0]", ["'glass'", "paper"]),
    ("bad dist", _unc(dist="gamma", sd=0.1), "uncertain.mu.dist", ["'gamma'", "truncnormal"]),
    ("no scale", _unc(dist="normal"), "uncertain.mu", ["{none}", "rel_sd"]),
    ("abs and rel", _unc(dist="truncnormal", sd=0.1, rel_sd=0.1), "uncertain.mu", ["do not mix"]),
    ("negative rel_sd", _unc(dist="truncnormal", rel_sd=-0.1), "uncertain.mu.rel_sd", ["-0.1", "> 0"]),
    ("rel_sd not number", _unc(dist="truncnormal", rel_sd="10%"), "uncertain.mu.rel_sd", ["'10%'", "not a number"]),
    ("wide normal", _unc(dist="normal", rel_sd=0.5), "uncertain.mu.dist", ["truncnormal", "outside the physical range"]),
    ("truncnormal lower < 0", _unc(dist="truncnormal", rel_sd=0.1, lower=-0.1), "uncertain.mu.lower", ["-0.1", "physical"]),
    ("truncnormal empty", _unc(dist="truncnormal", rel_sd=0.1, lower=0.6, upper=0.5), "uncertain.mu.upper", ["lower < upper"]),
    ("truncnormal far", _unc(dist="truncnormal", rel_sd=0.01, lower=1.0), "uncertain.mu", ["keeps only"]),
    ("bounds on normal", _unc(dist="normal", rel_sd=0.1, lower=0.0), "uncertain.mu.lower", ["dist='truncnormal'"]),
    ("uniform low > high", _unc(dist="uniform", low=0.6, high=0.5), "uncertain.mu.high", ["0.5", "low"]),
    ("uniform below 0", _unc(dist="uniform", low=-0.1, high=0.5), "uncertain.mu.low", ["-0.1", "physical"]),
    ("uniform one bound", _unc(dist="uniform", low=0.1), "uncertain.mu", ["high"]),
    (
        "triangular mode out",
        _unc(dist="triangular", rel_low=0.9, rel_high=1.1, rel_mode=1.5),
        "uncertain.mu.rel_mode",
        ["1.5", "mode = 0.81", "a mode in [low, high]"],
    ),
    (
        "triangular nominal out",
        _unc(dist="triangular", low=0.1, high=0.2),
        "uncertain.mu.mode",
        ["default, the nominal 0.54", "[0.1, 0.2]"],
    ),
    ("lognormal zero sd", _unc(dist="lognormal", cv=0.0), "uncertain.mu.cv", ["0.0", "> 0"]),
    (
        "lognormal zero nominal",
        _set("uncertain.F_elect", {"dist": "lognormal", "cv": 0.1}),
        "uncertain.F_elect.dist",
        ["'aluminum'", "mean > 0"],
    ),
    (
        "rel_sd of zero nominal",
        _set("uncertain.offset_deg", {"dist": "normal", "rel_sd": 0.1}),
        "uncertain.offset_deg.rel_sd",
        ["'aluminum'", "'sd'"],
    ),
    (
        "lognormal above upper bound",
        _set("uncertain.line_contact_fraction", {"dist": "lognormal", "cv": 2.0}),
        "uncertain.line_contact_fraction.dist",
        ["above the physical bound 1"],
    ),
    ("field uncertain too wide", _set("uncertain.field_mT", {"dist": "normal", "rel_sd": 0.5}), "uncertain.field_mT.dist", ["field_mT=20"]),
]


@pytest.mark.parametrize(("config", "key", "fragments"), [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_each_bad_config_is_one_clear_error(config: dict[str, Any], key: str, fragments: list[str]) -> None:
    with pytest.raises(ConfigError) as err:
        load_config(config)
    assert err.value.key == key, str(err.value)
    assert isinstance(err.value, ValueError)
    for frag in fragments:
        assert frag in str(err.value), str(err.value)


def test_file_errors_name_the_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\nsamples = [1,\n')
    with pytest.raises(ConfigError, match="bad.toml: not valid TOML"):
        load_config(bad)
    bad.write_text((STUDIES / "smoke.toml").read_text().replace("samples = 16", "samples = -16"))
    with pytest.raises(ConfigError, match=r"bad.toml: samples=-16 is out of range") as err:
        load_config(str(bad))
    assert err.value.key == "samples"


# ---------------------------------------------------------------------------- defaults


def test_defaults() -> None:
    c = cfg()
    assert (c.mode, c.periods, c.transient_periods, c.dt, c.torque) == ("grid", 2.0, 1.0, None, "start")
    assert (c.success_ratio, c.sampler, c.ci, c.ci_level) == (0.5, "mc", "wilson", 0.95)
    assert (c.check.fraction, c.check.min_runs, c.check.dt_factor) == (0.02, 20, 4)
    assert c.execution.batch_size == 8
    assert {u.param: u.to_dict() for u in c.uncertain} == DEFAULT_UNCERTAIN
    assert cfg(uncertain={}).uncertain == ()
    assert design(cfg(uncertain={})).data_vars.keys() == {"check_flag", "dt"}


def test_incline_range_is_inclusive_and_canonical() -> None:
    c = cfg(incline_deg={"start": 0, "stop": 60, "step": 5})
    assert c.incline_deg == tuple(float(x) for x in range(0, 61, 5))
    assert cfg(incline_deg={"start": 0, "stop": 0.3, "step": 0.1}).incline_deg == (0.0, 0.1, 0.2, 0.3)
    # the same cells whether listed or ranged, so the same hash and draws
    assert config_hash(c) == config_hash(cfg(incline_deg=list(range(0, 61, 5))))


def test_physical_ranges_match_params_validation() -> None:
    """RANGES mirrors Params.__post_init__: bounds allowed or refused alike."""
    numeric = [f for f in Params.field_names() if f not in ("offset_axis", "electrostatic_in_flight", "line_adhesion", "adhesion_release")]
    assert set(UNCERTAIN_PARAMS) == {*numeric, "field_mT", "axis_yaw_deg", "axis_pitch_deg"}
    base = PRESETS["paper"]
    for name in numeric:
        r = RANGES[name]
        for bound, is_open in ((r.lo, r.lo_open), (r.hi, r.hi_open)):
            if not math.isfinite(bound):
                continue
            if is_open:
                with pytest.raises(ValueError):
                    base.replace(**{name: bound})
            else:
                base.replace(**{name: bound})
            outside = bound - 1e-9 if bound == r.lo else bound + 1e-9
            with pytest.raises(ValueError):
                base.replace(**{name: outside})


# --------------------------------------------------------------------------- run table


def test_design_layout() -> None:
    c = cfg(shapes=["cuboid"], presets=["paper", "aluminum"], incline_deg=[0, 30], freq_hz=[1, 2], samples=3)
    ds = design(c)
    assert ds.sizes["run"] == 2 * 2 * 2 * 3 == c.n_runs
    assert len(cells(c)) == 8
    # cell by cell, sample fastest
    assert ds["sample"].values.tolist() == [0, 1, 2] * 8
    assert ds["substrate"].values[:12].tolist() == ["paper"] * 12
    assert ds["freq_hz"].values[:6].tolist() == [1.0] * 3 + [2.0] * 3
    assert len(set(ds["run_key"].values.tolist())) == ds.sizes["run"]
    assert len(set(ds["cell_key"].values.tolist())) == 8
    assert ds["run_key"].dtype == np.int64
    for v in ("mu", "adhesion_C", "offset_deg", "magnetization"):
        assert ds[v].attrs["units"] and ds[v].attrs["long_name"]
    assert ds["mu"].attrs["units"] == "1" and ds["adhesion_C"].attrs["units"] == "N/m^2"
    assert ds.attrs["config_hash"] == config_hash(c)
    # each run's overrides build valid Params and a complete simulate() call
    for i in range(ds.sizes["run"]):
        row = ds.isel(run=i)
        PRESETS[str(row["substrate"].item())].replace(**params_for_run(c, row))
        kw = run_kwargs(c, row)
        assert kw["periods"] == c.periods and kw["field_mT"] == 20.0
        assert run_inputs(**kw).duration_s == c.periods / kw["freq_hz"]
        assert kw["preset"] == str(row["substrate"].item()) and kw["mu"] == float(row["mu"])


def test_check_subset() -> None:
    ds = design(cfg(samples=100, check={"fraction": 0.05, "min_runs": 3}))
    assert int(ds["check_flag"].sum()) == 10  # ceil(0.05 * 200)
    assert int(design(cfg(samples=4, check={"fraction": 0.05, "min_runs": 3}))["check_flag"].sum()) == 3
    assert int(design(cfg(samples=1, check={"min_runs": 20}))["check_flag"].sum()) == 2  # at most all


def test_uncertain_field() -> None:
    c = cfg(uncertain={"field_mT": {"dist": "uniform", "rel_low": 0.9, "rel_high": 1.1}}, field_mT=[10, 20])
    ds = design(c)
    x, b = ds["field_mT_sampled"].values, ds["field_mT"].values
    assert np.all((x >= 0.9 * b) & (x <= 1.1 * b))
    assert params_for_run(c, ds.isel(run=0)) == {}
    assert run_kwargs(c, ds.isel(run=0))["field_mT"] == x[0]


# ------------------------------------------------------------------------------- seeds


@pytest.mark.parametrize("sampler", ["mc", "sobol"])
def test_draws_keyed_by_run_identity_not_position(sampler: str) -> None:
    a = design(cfg(sampler=sampler, shapes=["cuboid"], presets=["paper", "aluminum"], incline_deg=[0, 30, 60], samples=8))
    # other order, a subset of cells, more samples, another batch size
    b = design(
        cfg(
            sampler=sampler,
            presets=["aluminum", "paper"],
            incline_deg=[60, 30],
            samples=16,
            execution={"batch_size": 3},
        )
    )
    for v in ("mu", "adhesion_C", "offset_deg", "magnetization"):
        ka, kb = by_key(a, v), by_key(b, v)
        common = ka.keys() & kb.keys()
        assert len(common) == 2 * 2 * 8
        assert all(ka[k] == kb[k] for k in common), v
    # N not a power of two: the first N of the same sequence (and no balance warning)
    c = by_key(design(cfg(sampler=sampler, presets=["paper"], incline_deg=[30], samples=5)), "mu")
    assert len(c) == 5 and all(c[k] == by_key(b, "mu")[k] for k in c)


def test_mc_draw_of_a_parameter_ignores_the_other_parameters() -> None:
    both = design(cfg(uncertain={"mu": {"dist": "truncnormal", "rel_sd": 0.15}, "mass": {"dist": "normal", "rel_sd": 0.05}}))
    alone = design(cfg(uncertain={"mu": {"dist": "truncnormal", "rel_sd": 0.15}}))
    np.testing.assert_array_equal(both["mu"].values, alone["mu"].values)


@pytest.mark.parametrize("sampler", ["mc", "sobol", "lhs"])
def test_draws_differ_between_cells_and_seeds(sampler: str) -> None:
    ds = design(cfg(sampler=sampler, incline_deg=[0, 30]))
    mu = ds["mu"].values.reshape(2, -1)
    assert not np.any(mu[0] == mu[1])
    other = design(cfg(sampler=sampler, seed=8, incline_deg=[0, 30]))["mu"].values.reshape(2, -1)
    assert not np.any(mu == other)
    again = design(cfg(sampler=sampler, incline_deg=[0, 30]))["mu"].values.reshape(2, -1)
    np.testing.assert_array_equal(mu, again)


def test_lhs_is_per_cell_but_not_prefix_stable() -> None:
    a = by_key(design(cfg(sampler="lhs", incline_deg=[0, 30])), "mu")
    b = by_key(design(cfg(sampler="lhs", incline_deg=[30])), "mu")
    assert all(a[k] == b[k] for k in b)
    # a Latin hypercube of 16 is not a Latin hypercube of 8 plus 8 more (documented)
    c = by_key(design(cfg(sampler="lhs", incline_deg=[30], samples=16)), "mu")
    assert any(c[k] != b[k] for k in b)


def test_sobol_cell_is_a_balanced_net() -> None:
    """With N a power of two, every 1-D stratum of width 1/N holds exactly one point."""
    c = cfg(sampler="sobol", samples=64, incline_deg=[0], uncertain={"mu": {"dist": "uniform", "low": 0.0, "high": 1.0}})
    x = design(c)["mu"].values
    assert sorted(np.floor(x * 64).astype(int).tolist()) == list(range(64))


# ----------------------------------------------------------------------- distributions


STAT_UNCERTAIN = {
    "mu": {"dist": "truncnormal", "rel_sd": 0.15},
    "adhesion_C": {"dist": "lognormal", "cv": 0.3},
    "offset_deg": {"dist": "normal", "sd": 5.0},
    "magnetization": {"dist": "normal", "rel_sd": 0.1},
    "V_m": {"dist": "uniform", "rel_low": 0.8, "rel_high": 1.2},
    "mass": {"dist": "triangular", "rel_low": 0.8, "rel_high": 1.3},
    "line_contact_fraction": {"dist": "truncnormal", "mean": 0.05, "sd": 0.2, "upper": 0.5},
}


@pytest.mark.parametrize("sampler", ["mc", "sobol", "lhs"])
def test_sampled_moments_and_shapes(sampler: str) -> None:
    """Sample mean and sd within N_SE standard errors; K-S p-value above KS_P_MIN.

    Fixed seed: a deterministic check of a draw of 4096.
    """
    n = 4096
    c = cfg(sampler=sampler, samples=n, incline_deg=[0], uncertain=STAT_UNCERTAIN)
    ds = design(c)
    for u in c.uncertain:
        nominal = getattr(PRESETS["aluminum"], u.param)
        dist = u.resolve(nominal)
        x = ds[u.param].values
        m, s = dist.mean(), dist.std()
        kurt = float(dist.dist.stats(moments="k"))  # excess kurtosis: SE of the sd
        assert abs(x.mean() - m) < N_SE * s / math.sqrt(n), u.param
        assert abs(x.std(ddof=1) - s) < N_SE * s * math.sqrt((kurt + 2.0) / (4.0 * n)), u.param
        assert stats.kstest(x, lambda v, d=dist: d.dist.cdf(v)).pvalue > KS_P_MIN, u.param


def test_distributions_are_what_the_docs_say() -> None:
    """The resolved distributions against closed forms (a regression, exact)."""
    c = cfg(uncertain=STAT_UNCERTAIN)
    al = PRESETS["aluminum"]
    d = {u.param: u.resolve(getattr(al, u.param)) for u in c.uncertain}
    assert d["adhesion_C"].mean() == pytest.approx(al.adhesion_C, rel=1e-12)
    assert d["adhesion_C"].std() == pytest.approx(0.3 * al.adhesion_C, rel=1e-12)
    assert d["magnetization"].mean() == pytest.approx(al.magnetization, rel=1e-12)
    assert d["magnetization"].std() == pytest.approx(0.1 * al.magnetization, rel=1e-12)
    assert d["mu"].std() == pytest.approx(0.15 * al.mu, rel=1e-9)  # cut at 6.7 sd: negligible
    assert d["offset_deg"].std() == pytest.approx(5.0, rel=1e-12)
    assert d["V_m"].ppf(np.array([0.0, 1.0])) == pytest.approx([0.8 * al.V_m, 1.2 * al.V_m], rel=1e-9)
    assert d["mass"].dist.mean() == pytest.approx((0.8 + 1.0 + 1.3) / 3 * al.mass, rel=1e-12)


def test_bounds_hold_for_many_samples() -> None:
    """Distributions pressed against their physical bounds never cross them."""
    wide = {
        "mu": {"dist": "truncnormal", "mean": 0.02, "sd": 0.5},
        "mass": {"dist": "uniform", "rel_low": 0.001, "rel_high": 2.0},  # from 0: beyond a 1e-6 share implausible (below 1e-12 kg)
        "line_contact_fraction": {"dist": "truncnormal", "mean": 0.9, "sd": 0.5},
        "adhesion_C": {"dist": "lognormal", "cv": 3.0},
        "e_r": {"dist": "triangular", "low": 0.0, "mode": 0.0, "high": 0.2},
        "magnetization": {"dist": "normal", "rel_sd": 0.2},  # 5 sd from 0: allowed
        "offset_deg": {"dist": "truncnormal", "mean": 170.0, "sd": 30.0},
    }
    for sampler in ("mc", "sobol"):
        ds = design(cfg(sampler=sampler, samples=2048, presets=["paper", "aluminum"], incline_deg=[0], uncertain=wide))
        for p in wide:
            r, x = RANGES[p], ds[p].values
            assert np.all(np.isfinite(x)) and all(r.contains(v) for v in x), p
        for i in range(0, ds.sizes["run"], 97):
            PRESETS[str(ds["substrate"].values[i])].replace(**{p: float(ds[p].values[i]) for p in wide})


def test_normal_truncation_rule_threshold() -> None:
    """``normal`` is allowed exactly when at most NEGLIGIBLE_MASS lies outside the range."""
    z = -stats.norm.ppf(NEGLIGIBLE_MASS)  # the bound this many sd from the mean
    mu = PRESETS["aluminum"].mu
    cfg(uncertain={"mu": {"dist": "normal", "sd": mu / z * 0.99}})
    with pytest.raises(ConfigError, match="truncnormal"):
        cfg(uncertain={"mu": {"dist": "normal", "sd": mu / z * 1.01}})


# ---------------------------------------------------------------------------- hashing


def test_config_hash_is_stable_and_ignores_execution() -> None:
    c = cfg()
    assert config_hash(c) == config_hash(cfg())
    assert config_hash(c) == config_hash(cfg(execution={"batch_size": 1, "workers": 4, "max_in_flight": 8}))
    assert config_hash(c) == config_hash(cfg(samples=8, seed=7, field_mT=20.0, incline_deg=[0.0, 30.0]))
    assert config_hash(c) != config_hash(cfg(seed=8))
    assert config_hash(c) != config_hash(cfg(uncertain={}))
    assert len(config_hash(c)) == 64
    assert "execution" not in json.loads(config_to_json(c))


def test_config_json_round_trips() -> None:
    c = load_config(STUDIES / "smoke.toml")
    back = load_config(json.loads(config_to_json(c)))
    assert back == c.__class__(**{**c.__dict__, "execution": back.execution})
    assert config_hash(back) == config_hash(c)


# ----------------------------------------------------------------------- study files


def test_smoke_toml() -> None:
    c = load_config(STUDIES / "smoke.toml")
    assert (c.shapes, c.presets, c.incline_deg, c.field_mT, c.freq_hz) == (("cuboid",), ("aluminum",), (0.0, 30.0, 60.0), (20.0,), (1.0,))
    assert (c.periods, c.samples) == (2.0, 16)
    assert {u.param: u.to_dict() for u in c.uncertain} == DEFAULT_UNCERTAIN
    assert design(c).sizes["run"] == 48


def test_default_toml() -> None:
    """The main job is a threshold study; default_grid.toml is the same study on every incline."""
    c = load_config(STUDIES / "default.toml")
    assert c.shapes == ("cuboid", "spiked", "spiked_ends", "curved") and c.presets == ("paper", "aluminum")
    assert c.incline_deg == tuple(float(x) for x in range(0, 61, 5))
    assert c.mode == "threshold" and c.threshold_axis == "incline_deg"
    assert c.samples == 200 and c.n_runs == 4 * 2 * 200
    assert {u.param: u.to_dict() for u in c.uncertain} == DEFAULT_UNCERTAIN
    assert len(cells(c)) == 4 * 2
    g = load_config(STUDIES / "default_grid.toml")
    assert g.mode == "grid" and g.n_runs == 4 * 2 * 13 * 200 and len(cells(g)) == 4 * 2 * 13
    same = ("shapes", "presets", "incline_deg", "field_mT", "freq_hz", "samples", "seed", "uncertain", "check", "periods", "dt")
    assert all(getattr(c, k) == getattr(g, k) for k in same)


def test_sampler_slots_are_append_only() -> None:
    """A parameter's mc slot never moves: the first 13 are those of every earlier study."""
    first = (
        "mass",
        "F_elect",
        "mu",
        "offset_deg",
        "V_m",
        "magnetization",
        "adhesion_C",
        "line_contact_fraction",
        "e_t",
        "e_o",
        "e_r",
        "g",
        "field_mT",
    )
    assert UNCERTAIN_PARAMS[: len(first)] == first
