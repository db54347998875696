"""The design search: common random numbers, estimates, early stops, budget, resume, strategies, bad input."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr

from tumblemc.design.config import load_design, parse_design
from tumblemc.design.evaluate import SEARCH, Chunk, estimate, execute, uniforms
from tumblemc.design.result import hypervolume, open_design, pareto_mask
from tumblemc.design.search import search
from tumblemc.design.strategies import model_best, propose
from tumblemc.io import StudyStateError
from tumblemc.study.checks import ConfigError

UM = 1e-6
BOUNDS = {"spike_base": {"bounds": [50 * UM, 400 * UM]}, "spike_height": {"bounds": [50 * UM, 400 * UM]}}
OPT = np.array([0.7, 0.3])


def cfg_of(**over: Any) -> Any:
    d: dict[str, Any] = {
        "name": "t",
        "family": "spiked_ends",
        "seed": 3,
        "variables": BOUNDS,
        "objectives": [{"kind": "climb", "substrate": "aluminum", "incline_deg": 30}],
        "samples": 100,
        "stage": 20,
        "budget": 2000,
        "initial": 6,
        "batch": 3,
        "confirm": 100,
        "uncertain": {},
    }
    d.update(over)
    if d["uncertain"] is None:  # the default uncertainties
        del d["uncertain"]
    return parse_design(d)


def true_p(x: dict[str, float]) -> float:
    u = np.array([(x["spike_base"] - 50 * UM) / (350 * UM), (x["spike_height"] - 50 * UM) / (350 * UM)])
    return float(0.15 + 0.7 * np.exp(-np.sum((u - OPT) ** 2) / 0.08))


class Synthetic:
    """A runner with a known P(climb | design): robot s climbs when its own uniform is below P (common random numbers)."""

    def __init__(self, fail_after: int | None = None) -> None:
        self.calls = 0
        self.fail_after = fail_after

    def __call__(self, chunks: list[Chunk]) -> Any:
        for c in chunks:
            if self.fail_after is not None and self.calls >= self.fail_after:
                raise KeyboardInterrupt
            self.calls += 1
            u = uniforms(c.cfg, c.samples, c.stream)[:, -1]
            v = (u < true_p(dict(c.x))).astype(float)
            n = len(v)
            yield c, {"value": v, "status": np.zeros(n, np.int8), "n_sim": np.ones(n, np.int32), "error": np.full(n, "", object)}


@pytest.mark.parametrize("strategy", ["gp", "tpe", "sobol"])
def test_search_finds_a_good_design_within_budget(tmp_path: Path, strategy: str) -> None:
    cfg = cfg_of(strategy=strategy)
    out = search(cfg, tmp_path / "s.nc", progress=False, runner=Synthetic())
    tr = open_design(out)
    ds = tr["designs"].to_dataset()
    rec = int(tr.attrs["recommended"])
    assert tr.attrs["simulations"] <= cfg.budget
    assert int(ds["robots"].sum()) + 100 == tr.attrs["simulations"]  # search robots plus the confirmation's
    x = {"spike_base": float(ds["spike_base"][rec]), "spike_height": float(ds["spike_height"][rec])}
    best = 0.85
    tol = 0.12 if strategy != "sobol" else 0.3
    assert true_p(x) >= best - tol, (strategy, x, true_p(x))
    conf = tr["confirm"].to_dataset().isel(objective=0)
    assert int(conf["robots"]) == 100
    with xr.open_datatree(out, engine="netcdf4") as plain:  # xarray alone selects the objective by name
        assert int(plain["confirm"].sel(objective=str(conf["objective"].values))["robots"]) == 100
        assert plain.attrs["data_groups"] == "designs confirm runs"
    assert float(conf["lo"]) <= true_p(x) + 0.05 and true_p(x) - 0.05 <= float(conf["hi"])


def test_early_stops_only_designs_that_are_worse(tmp_path: Path) -> None:
    tr = open_design(search(cfg_of(strategy="sobol"), tmp_path / "s.nc", progress=False, runner=Synthetic()))
    ds = tr["designs"].to_dataset()
    stopped = ds["stopped_early"].values
    assert stopped.any()
    assert np.all(ds["robots"].values[stopped] < 100) and np.all(ds["robots"].values[~stopped] == 100)
    ps = np.array(
        [
            true_p({"spike_base": float(a), "spike_height": float(b)})
            for a, b in zip(ds["spike_base"].values, ds["spike_height"].values, strict=True)
        ]
    )
    assert ps[stopped].max() < ps.max() - 0.2
    # without early stopping every design gets every robot, and fewer designs fit the budget
    tr2 = open_design(search(cfg_of(strategy="sobol", early_stop=False), tmp_path / "n.nc", progress=False, runner=Synthetic()))
    assert not tr2["designs"]["stopped_early"].values.any()
    assert tr2["designs"].sizes["design"] < ds.sizes["design"]


def test_interrupted_search_resumes_to_the_same_file(tmp_path: Path) -> None:
    cfg = cfg_of(strategy="gp", budget=1200)
    whole = open_design(search(cfg, tmp_path / "a.nc", progress=False, runner=Synthetic()))
    for k in (3, 17):  # stop in the middle of a stage, then of a later round
        with pytest.raises(KeyboardInterrupt):
            search(cfg, tmp_path / "b.nc", progress=False, runner=Synthetic(fail_after=k))
        assert (tmp_path / "b.nc.parts" / "journal.json").exists() and not (tmp_path / "b.nc").exists()
    again = Synthetic()
    part = open_design(search(cfg, tmp_path / "b.nc", progress=False, runner=again))
    for g in ("designs", "confirm", "runs"):
        xr.testing.assert_identical(whole[g].to_dataset(), part[g].to_dataset())
    assert not (tmp_path / "b.nc.parts").exists()


def test_parts_of_another_problem_are_refused(tmp_path: Path) -> None:
    with pytest.raises(KeyboardInterrupt):
        search(cfg_of(), tmp_path / "b.nc", progress=False, runner=Synthetic(fail_after=2))
    with pytest.raises(StudyStateError, match="another design problem"):
        search(cfg_of(seed=4), tmp_path / "b.nc", progress=False, runner=Synthetic())
    search(cfg_of(seed=4, budget=300), tmp_path / "b.nc", fresh=True, progress=False, runner=Synthetic())


def test_common_random_numbers() -> None:
    cfg = cfg_of(uncertain=None)  # the default uncertainties
    u = uniforms(cfg, range(6), SEARCH)
    assert np.array_equal(u[2:4], uniforms(cfg, [2, 3], SEARCH))  # a robot's draws depend on nothing else
    assert not np.array_equal(u, uniforms(cfg, range(6), 1))  # the fresh robots are others
    from tumblemc.design.evaluate import robot_params

    a = robot_params(cfg, cfg.objectives[0], u)
    assert a == robot_params(cfg_of(uncertain=None, variables={"spike_base": {"bounds": [60 * UM, 300 * UM]}}), cfg.objectives[0], u)
    assert len({r["mu"] for r in a}) == 6


def test_manufacturing_tolerance_is_sampled_per_robot() -> None:
    from tumblemc.design.evaluate import robot_dims

    cfg = cfg_of(variables={"spike_base": {"bounds": [50 * UM, 400 * UM], "tolerance": 10 * UM}, "spike_height": BOUNDS["spike_height"]})
    u = uniforms(cfg, range(400), SEARCH)
    mid = np.array([d["spike_base"] for d in robot_dims(cfg, {"spike_base": 200 * UM, "spike_height": 200 * UM}, u)])
    assert abs(np.std(mid) - 10 * UM) < 1.5 * UM and abs(np.median(mid) - 200 * UM) < 1.5 * UM
    dims = robot_dims(cfg, {"spike_base": 60 * UM, "spike_height": 200 * UM}, u)
    base = np.array([d["spike_base"] for d in dims])
    assert np.all(base >= 50 * UM) and np.mean(base == 50 * UM) > 0.1  # kept in the bounds
    assert np.all([d["spike_height"] == 200 * UM for d in dims])  # no tolerance, no noise
    assert dims[5:7] == robot_dims(cfg, {"spike_base": 60 * UM, "spike_height": 200 * UM}, u[5:7])


def test_a_chunk_is_the_same_robots_however_split() -> None:
    cfg = cfg_of(uncertain=None, objectives=[{"kind": "speed", "substrate": "paper", "freq_hz": 10}], samples=4, stage=4)
    x = (("spike_base", 120 * UM), ("spike_height", 300 * UM))
    whole = execute(Chunk(0, x, 0, (0, 1, 2, 3), SEARCH, cfg))
    parts = [execute(Chunk(5, x, 0, s, SEARCH, cfg)) for s in ((0, 1), (2, 3))]
    assert np.array_equal(whole["value"], np.concatenate([p["value"] for p in parts]))
    assert np.all(whole["status"] == 0) and np.all(np.isfinite(whole["value"]))


def test_estimates() -> None:
    climb, q, field = cfg_of(
        objectives=[
            {"kind": "climb", "substrate": "aluminum"},
            {"kind": "incline_quantile", "substrate": "aluminum", "q": 0.9},
            {"kind": "critical_field", "substrate": "aluminum", "q": 0.5},
        ]
    ).objectives
    e = estimate(climb, np.array([1, 1, 0, np.nan, 1.0]))
    assert (e.value, e.n) == (0.75, 4) and 0 < e.lo < 0.75 < e.hi <= 1
    th = np.array([10.0, 20, 30, 40, 50, 60, 70, 80, 90, 100])
    e = estimate(q, th)  # the incline 90% climb: 9 of 10 have a threshold >= 20
    assert e.value == 20.0 and np.mean(th >= e.value) >= 0.9 and np.mean(th >= 30) < 0.9
    e = estimate(field, th)  # the field half of them climb at
    assert e.value == 50.0 and np.mean(th <= e.value) >= 0.5


def test_pareto_and_hypervolume_against_brute_force() -> None:
    rng = np.random.default_rng(0)
    Y = rng.random((40, 2))
    m = pareto_mask(Y)
    for i in range(40):
        dominated = any(np.all(Y[j] >= Y[i]) and np.any(Y[j] > Y[i]) for j in range(40))
        assert m[i] == (not dominated)
    g = np.linspace(0, 1, 801)[:-1] + 1 / 1600
    gy, gz = np.meshgrid(g, g, indexing="ij")
    covered = np.zeros_like(gy, dtype=bool)
    for a, b in Y:
        covered |= (gy <= a) & (gz <= b)
    assert hypervolume(Y, np.zeros(2)) == pytest.approx(covered.mean(), abs=3e-3)


def test_model_best_is_not_the_luckiest_design() -> None:
    """A design with a high raw estimate from few robots, among consistent neighbours, is not picked over a well-measured best."""
    X = np.array([[x, 0.5] for x in np.linspace(0, 1, 11)])
    y = 0.5 - 0.4 * (X[:, 0] - 0.6) ** 2
    var = np.full(11, 1e-4)
    y[2], var[2] = 0.95, 0.05  # lucky: 0.95 from a handful of robots where its neighbours say 0.44
    i, means = model_best(X, y, var, 0)
    assert i == 6 and means[2] < 0.6
    assert int(np.argmax(y)) == 2


@pytest.mark.parametrize("strategy", ["gp", "tpe", "sobol"])
def test_proposals_are_in_the_box_and_deterministic(strategy: str) -> None:
    rng = np.random.default_rng(1)
    X = rng.random((8, 2))
    Y = np.column_stack([np.sin(3 * X[:, 0]), X[:, 1]])
    V = np.full_like(Y, 0.01)
    for m in (1, 2):
        a = propose(strategy, X, Y[:, :m], V[:, :m], 3, 7, 8)
        assert a.shape == (3, 2) and np.all((a >= 0) & (a <= 1))
        assert np.array_equal(a, propose(strategy, X, Y[:, :m], V[:, :m], 3, 7, 8))


@pytest.mark.parametrize(
    ("over", "words"),
    [
        ({"variables": {"spike_base": {"bounds": [50 * UM, 500 * UM]}}}, ["cannot be built", "spike_base", "overlap"]),
        ({"variables": {"spike_lenght": {"bounds": [50 * UM, 400 * UM]}}}, ["variables.spike_lenght", "did you mean 'spike_height'"]),
        (
            {"objectives": [{"kind": "climb", "substrate": "aluminum", "incline_deg": 75}]},
            ["objectives[0].incline_deg=75", "out of range", "0"],
        ),
        (
            {"objectives": [{"kind": "incline_quantile", "substrate": "aluminum", "incline_grid": [0, 70]}]},
            ["incline_grid[1]=70", "out of range"],
        ),
        ({"objectives": [{"kind": "climb", "substrate": "glass"}]}, ["objectives[0].substrate='glass'"]),
        ({"variables": {"spike_base": {"bounds": [400 * UM, 50 * UM]}}}, ["variables.spike_base.bounds", "increasing"]),
        ({"uncertain": {"mass": {"dist": "uniform", "rel_low": 0.9, "rel_high": 1.1}}}, ["uncertain.mass", "follows from the design"]),
        ({"stage": 30}, ["stage=30", "divide"]),
        ({"strategy": "bayes"}, ["strategy='bayes'"]),
        ({"budget": 150}, ["budget=150", "at least 200"]),
        ({"fixed": {"spike_base": 1e-4}}, ["fixed.spike_base", "also a design variable"]),
    ],
)
def test_bad_input_is_one_clear_line(over: dict, words: list[str]) -> None:
    with pytest.raises(ConfigError) as e:
        cfg_of(**over)
    msg = str(e.value)
    assert "\n" not in msg
    for w in words:
        assert w in msg, msg


def test_design_files_of_the_repository_parse() -> None:
    root = Path(__file__).resolve().parents[2]
    files = sorted((root / "studies").glob("design_*.toml"))
    assert files
    for f in files:
        cfg = load_design(f)
        assert cfg.budget >= cfg.samples


def test_every_corner_is_checked() -> None:
    """Buildability is refused at any corner of the box, not only the upper one (here the lower r_inner is fine, the upper is not)."""
    with pytest.raises(ConfigError, match="r_inner"):
        parse_design(
            {
                "name": "c",
                "family": "curved",
                "seed": 1,
                "variables": {"r_inner": {"bounds": [900 * UM, 1300 * UM]}},
                "objectives": [{"kind": "speed", "substrate": "paper"}],
            }
        )


@pytest.mark.parametrize("kind", ["incline_quantile", "critical_field"])
def test_threshold_objectives_against_a_sweep(kind: str) -> None:
    """A robot's critical incline (field) from the search equals the first failure (success) of a sweep over the grid."""
    from tumblemc.design.evaluate import time_grid
    from tumblemc.design.families import build
    from tumblemc.model.rows import simulate_rows

    grid = [0.0, 10.0, 20.0, 25.0, 30.0, 40.0] if kind == "incline_quantile" else [0.5, 1.0, 1.5, 2.0, 3.0, 5.0]
    key = "incline_grid" if kind == "incline_quantile" else "field_grid"
    obj = {"kind": kind, "substrate": "aluminum", "freq_hz": 10, key: grid, "incline_deg": 0 if kind == "incline_quantile" else 20}
    cfg = cfg_of(objectives=[obj], uncertain={}, samples=2, stage=2, budget=10**4)
    x = (("spike_base", 100 * UM), ("spike_height", 125 * UM))
    res = execute(Chunk(0, x, 0, (0,), SEARCH, cfg))
    des = build("spiked_ends", cfg.dims(dict(x)), "aluminum")
    axis = "incline_deg" if kind == "incline_quantile" else "field_mT"
    o = cfg.objectives[0]
    base = {"preset": "aluminum", "incline_deg": o.incline_deg, "field_mT": o.field_mT, "freq_hz": 10.0, **des.overrides()}
    sweep = simulate_rows(des.shape, [dict(base, **{axis: g}) for g in grid], time_grid(cfg, o))
    ok = (sweep["climbed"] == 1) & (sweep["status"] == 0)
    if kind == "incline_quantile":
        assert np.all(np.diff(ok.astype(int)) <= 0)  # monotone on this grid: a sweep's answer is unambiguous
        want = max((g for g, c in zip(grid, ok, strict=True) if c), default=-math.inf)
    else:
        assert np.all(np.diff(ok.astype(int)) >= 0)
        want = min((g for g, c in zip(grid, ok, strict=True) if c), default=math.inf)
    assert math.isfinite(want) and want not in (grid[0], grid[-1])  # an interior threshold: the search had to find it
    assert res["value"][0] == want and res["status"][0] == 0
    assert 1 <= res["n_sim"][0] < len(grid)


def test_constraints_decide_what_can_be_recommended(tmp_path: Path) -> None:
    """A constraint no design meets leaves nothing to recommend; one some designs meet restricts the recommendation to them."""
    climb = {"kind": "climb", "substrate": "aluminum", "incline_deg": 30}
    # the synthetic runner answers every task with the same P: a constraint P >= 0.95 fails everywhere
    cfg = cfg_of(constraints=[dict(climb, incline_deg=20, min=0.95)], budget=1000, confirm=20)
    tr = open_design(search(cfg, tmp_path / "none.nc", progress=False, runner=Synthetic()))
    assert tr.attrs["recommended"] == -1 and not tr["designs"]["feasible"].values.any()
    assert np.isnan(tr["confirm"]["value"].values).all()
    cfg = cfg_of(constraints=[dict(climb, incline_deg=20, max=0.5)], budget=1400, confirm=20)  # only the poor designs
    tr = open_design(search(cfg, tmp_path / "some.nc", progress=False, runner=Synthetic()))
    ds = tr["designs"].to_dataset()
    rec = int(tr.attrs["recommended"])
    assert ds["feasible"].values[rec] and ds["feasible"].values.sum() < ds.sizes["design"]
    assert float(ds["climb20_aluminum"][rec]) <= 0.5
