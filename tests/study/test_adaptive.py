"""Adaptive sampling per cell: the confidence sequence, its coverage, the engine's rounds."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.study.test_engine import _to_toml, assert_same_result, tiny
from tumblemc.analysis.confseq import MIXTURES, cs_interval, first_possible_stop, half_width, stop_count
from tumblemc.analysis.coverage import interval_table, simulate_coverage
from tumblemc.analysis.maps import proportion_ci
from tumblemc.io import StudyStateError, open_result, parts_dir
from tumblemc.model.outcome import is_valid
from tumblemc.study import engine
from tumblemc.study.adaptive import run_adaptive, schedule
from tumblemc.study.checks import ConfigError
from tumblemc.study.config import cells, load_config
from tumblemc.study.engine import run_study, study_status
from tumblemc.study.identity import config_hash, identity_json
from tumblemc.study.partial import partial_result


def _slow_marginal(k: int, n: int, mixture: str) -> float:
    """The prior's integral of ``q^k (1 - q)^(n - k)``, by quadrature on the prior's density (not betaln)."""
    from scipy.integrate import quad

    total = 0.0
    for w, a, b in MIXTURES[mixture]:
        # quad's algebraic weight carries the ends' singularities q^(a-1) (1-q)^(b-1)
        val, _ = quad(
            lambda q: q**k * (1 - q) ** (n - k), 0.0, 1.0, weight="alg", wvar=(a - 1.0, b - 1.0), epsabs=0.0, epsrel=1e-12, limit=200
        )
        total += w * val * math.gamma(a + b) / (math.gamma(a) * math.gamma(b))
    return total


def _slow_cs(k: int, n: int, level: float, mixture: str) -> tuple[float, float]:
    """The mixture's interval by brute force: every p on a grid of 1e-5 where M_n(p) < 1/alpha."""
    p = np.linspace(1e-9, 1 - 1e-9, 100_001)
    log_m = math.log(_slow_marginal(k, n, mixture)) - k * np.log(p) - (n - k) * np.log1p(-p)
    inside = p[log_m < math.log(1 / (1 - level))]
    return float(inside.min()), float(inside.max())


@pytest.mark.parametrize("mixture", ["ends", "uniform"])
@pytest.mark.parametrize(("k", "n"), [(0, 1), (1, 1), (3, 10), (0, 40), (17, 40), (40, 40), (100, 200), (7, 200)])
def test_cs_interval_against_brute_force(k: int, n: int, mixture: str) -> None:
    lo, hi = cs_interval(k, n, 0.95, mixture)
    slo, shi = _slow_cs(k, n, 0.95, mixture)
    assert lo == pytest.approx(slo if k > 0 else 0.0, abs=2e-5)
    assert hi == pytest.approx(shi if k < n else 1.0, abs=2e-5)


def test_cs_closed_form_all_success_and_symmetry() -> None:
    n = np.arange(1, 300)
    lo, hi = cs_interval(n, n, 0.9, "uniform")
    np.testing.assert_allclose(lo, (0.1 / (n + 1)) ** (1 / n), rtol=1e-12)
    assert np.all(hi == 1.0)
    for m in (5, 21, 60):  # the default prior: lower = (alpha I_n)^(1/n), I_n its integral of q^n
        lo_m, hi_m = cs_interval(m, m, 0.9, "ends")
        assert lo_m == pytest.approx((0.1 * _slow_marginal(m, m, "ends")) ** (1 / m), rel=1e-9) and hi_m == 1.0
    for mixture in MIXTURES:
        k = np.arange(0, 51)
        lo, hi = cs_interval(k, 50, mixture=mixture)
        lo2, hi2 = cs_interval(50 - k, 50, mixture=mixture)
        np.testing.assert_allclose(lo, 1 - hi2, atol=1e-13)
        assert cs_interval(0, 0, mixture=mixture) == (0.0, 1.0)
    with pytest.raises(ValueError, match="mixture must be one of"):
        cs_interval(1, 2, mixture="jeffreys")


def test_ends_prior_is_narrow_at_the_ends_and_a_little_wider_in_between() -> None:
    """What the default prior buys and what it costs, against Robbins' uniform prior."""
    n = np.arange(5, 1001)
    assert np.all(half_width(n, n, mixture="ends") < half_width(n, n, mixture="uniform"))  # every cell at p = 1 (or 0) stops sooner
    assert np.all(half_width(n // 2, n, mixture="ends") > half_width(n // 2, n, mixture="uniform"))  # p = 1/2: wider
    assert np.all(half_width(n // 2, n, mixture="ends") < 1.06 * half_width(n // 2, n, mixture="uniform"))  # by at most 6%


def test_cs_is_wider_than_wilson_and_shrinks_with_n() -> None:
    """The price of validity at every n: wider than the fixed-n interval, never wider with more data at the same share."""
    for n in (20, 100, 400):
        wl, wh = proportion_ci(n // 2, n, 0.95, "wilson")
        assert half_width(n // 2, n) > 0.5 * (wh - wl)
    hw = half_width(np.arange(10, 1000, 10) // 2, np.arange(10, 1000, 10))
    assert np.all(np.diff(hw) < 0)


def test_first_possible_stop_and_schedule() -> None:
    assert first_possible_stop(0.1, mixture="ends") == 21
    assert half_width(21, 21, mixture="ends") <= 0.1 < half_width(20, 20, mixture="ends")
    assert half_width(0, 21, mixture="ends") <= 0.1 < half_width(0, 20, mixture="ends")
    assert first_possible_stop(0.05, mixture="ends") == 45
    assert half_width(45, 45, mixture="ends") <= 0.05 < half_width(44, 44, mixture="ends")
    assert first_possible_stop(0.1) == 29  # the functions' default: the uniform prior
    assert first_possible_stop(0.1, mixture="uniform") == 29  # (1 - (0.05/30)^(1/29)) / 2 = 0.099 <= 0.1 < the value at 28
    assert half_width(29, 29, mixture="uniform") <= 0.1 < half_width(28, 28, mixture="uniform")
    assert first_possible_stop(0.05, mixture="uniform") == 69
    cfg = load_config(tiny(samples=200, precision=0.1, ci="confidence-sequence-ends"))
    assert schedule(cfg) == [21, 32, 48, 72, 108, 162, 200]
    cfg = load_config(tiny(samples=200, precision=0.1, ci="confidence-sequence"))
    assert schedule(cfg) == [29, 44, 66, 99, 149, 200]


def test_stop_count_is_the_first_prefix_and_skips_invalid_runs() -> None:
    ok = np.ones(40, bool)
    assert stop_count(ok, ok, 0.1, mixture="ends") == 21
    assert stop_count(ok[:20], ok[:20], 0.1, mixture="ends") is None
    assert stop_count(ok, ok, 0.1, mixture="uniform") == 29
    valid = ok.copy()
    valid[[3, 10]] = False  # two invalid runs: 23 runs hold 21 valid ones
    assert stop_count(valid, valid, 0.1, mixture="ends") == 23
    mixed = np.arange(40) % 2 == 0
    assert stop_count(ok, mixed, 0.1, mixture="ends") is None


@pytest.mark.parametrize("method", ["confidence-sequence-ends", "confidence-sequence"])
@pytest.mark.parametrize("p", [0.0, 0.02, 0.1, 0.5, 0.9, 1.0])
def test_coverage_at_the_stop_is_at_least_nominal(p: float, method: str) -> None:
    """Small version of tools/adaptive_coverage.py (docs/guide/adaptive.md): 4000 cells per p."""
    table = interval_table(200, 0.95, method)
    res = simulate_coverage(p, 0.1, 200, reps=4000, seed=7, table=table)
    assert res["coverage"] >= 0.95
    if p in (0.0, 1.0):
        assert res["mean_runs"] == (21.0 if method == "confidence-sequence-ends" else 29.0)
    if p == 0.5:
        assert res["share_capped"] == 1.0  # 0.120 (0.115 uniform) at n = 200: the cap binds


def test_config_rules() -> None:
    d = tiny(precision=0.1, samples=29)
    del d["ci"]
    cfg = load_config(d)
    assert cfg.ci == "confidence-sequence-ends" and cfg.precision == 0.1
    # the uniform prior kept its name: a study of the rule before keeps its hash, and one that
    # left ci out (the uniform rule then) now hashes with the new default, so its shards are refused
    old = load_config(tiny(precision=0.1, samples=29, ci="confidence-sequence"))
    assert old.ci == "confidence-sequence" and config_hash(old) != config_hash(cfg)
    assert config_hash(load_config(tiny())) != config_hash(cfg)
    assert '"precision"' not in identity_json(load_config(tiny()))  # older studies keep their hash
    with pytest.raises(ConfigError, match=r"precision=0\.5 .*allowed"):
        load_config(tiny(samples=29, precision=0.5, ci="confidence-sequence-ends"))
    with pytest.raises(ConfigError, match="sampler='lhs' with precision"):
        load_config(tiny(samples=29, precision=0.1, sampler="lhs", ci="confidence-sequence-ends"))
    with pytest.raises(ConfigError, match="ci='wilson' with precision"):
        load_config(tiny(samples=29, precision=0.1, ci="wilson"))
    with pytest.raises(ConfigError, match="mode = 'grid'"):
        load_config(tiny(samples=29, precision=0.1, mode="critical_incline", incline_deg=[0, 10, 20], ci="confidence-sequence-ends"))
    with pytest.raises(ConfigError, match=r"samples=20 with precision=0\.1.*allowed: samples >= 21"):
        load_config(tiny(precision=0.1, samples=20, ci="confidence-sequence-ends"))
    load_config(tiny(precision=0.1, samples=21, ci="confidence-sequence-ends"))
    with pytest.raises(ConfigError, match=r"samples=28 with precision=0\.1.*allowed: samples >= 29"):
        load_config(tiny(precision=0.1, samples=28, ci="confidence-sequence"))
    load_config(tiny(precision=0.1, samples=29, ci="confidence-sequence"))
    with pytest.raises(ValueError, match="finite"):
        cs_interval(float("nan"), 10)


# inclines where the smoke cuboid at 10 Hz has p = 1, about 0.75, about 0.35 and 0
MIXED: dict[str, Any] = {"incline_deg": [0, 10, 15, 60], "samples": 16}
ADAPT: dict[str, Any] = {**MIXED, "precision": 0.3, "ci": "confidence-sequence-ends"}


@pytest.fixture(scope="module")
def fixed_and_adaptive(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    d = tmp_path_factory.mktemp("adaptive")
    run_study(tiny(**MIXED), out=d / "fixed.nc", progress=False)
    run_study(tiny(**ADAPT), out=d / "adaptive.nc", progress=False)
    return d / "fixed.nc", d / "adaptive.nc"


def test_adaptive_keeps_the_prefix_the_rule_picks_from_the_fixed_study(fixed_and_adaptive: tuple[Path, Path]) -> None:
    fixed, _ = open_result(fixed_and_adaptive[0])
    runs, maps = open_result(fixed_and_adaptive[1])
    kept = []
    for inc in MIXED["incline_deg"]:
        f = fixed.isel(run=np.flatnonzero(fixed["incline_deg"].values == inc))
        a = runs.isel(run=np.flatnonzero(runs["incline_deg"].values == inc))
        valid = is_valid(f["status"].values)
        j = stop_count(valid, valid & (f["climbed"].values == 1), 0.3, mixture="ends") or 16
        kept.append(j)
        np.testing.assert_array_equal(a["sample"].values, np.arange(j))
        for v in ("run_key", "progress_ratio", "status", "climbed", "mu", "energy_gain"):
            np.testing.assert_array_equal(a[v].values, f[v].values[:j])
        cell = maps.sel(shape="cuboid", substrate="aluminum", incline_deg=float(inc))
        assert int(cell["n_runs"]) == j
        lo, hi = cs_interval(int(cell["n_success"]), int(cell["n_valid"]), mixture="ends")
        assert float(cell["p_success_lower"]) == lo and float(cell["p_success_upper"]) == hi
    assert kept[0] == kept[-1] == first_possible_stop(0.3, mixture="ends") == 5  # p = 0 and p = 1: the first possible stop at precision 0.3
    assert max(kept[1:3]) > 6  # the mixed cells need more
    assert runs.attrs["runs_kept"] == sum(kept) and runs.attrs["runs_simulated"] >= sum(kept)
    assert maps["p_success_lower"].attrs["ci_method"] == "confidence-sequence-ends"
    assert np.all(runs["run_key"].values[runs["check_run"].values] == runs["run_key"].values[runs["check_flag"].values == 1])


@pytest.mark.parametrize("batch_size", [1, 5])
def test_adaptive_result_does_not_depend_on_batch_size(fixed_and_adaptive: tuple[Path, Path], tmp_path: Path, batch_size: int) -> None:
    out = tmp_path / "a.nc"
    run_study(tiny(**ADAPT), out=out, progress=False, batch_size=batch_size)
    assert_same_result(fixed_and_adaptive[1], out)


def test_interrupted_adaptive_study_resumes_to_the_same_file(
    fixed_and_adaptive: tuple[Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "a.nc"
    calls = {"n": 0, "runs": 0}
    real = engine.execute_task

    def flaky(task: engine.Task) -> Any:
        calls["n"] += 1
        if calls["n"] > 9:  # round 1 is 8 tasks (4 cells x 5 runs, batches of 4 in each cell): stop inside round 2
            raise KeyboardInterrupt
        calls["runs"] += len(task.run)
        return real(task)

    monkeypatch.setattr(engine, "execute_task", flaky)
    with pytest.raises(KeyboardInterrupt):
        run_study(tiny(**ADAPT), out=out, progress=False, batch_size=4)
    monkeypatch.setattr(engine, "execute_task", real)
    assert not out.exists() and len(list(parts_dir(out).glob("main-*.npz"))) == 9
    toml = tmp_path / "a.toml"
    toml.write_text(_to_toml(tiny(**ADAPT)))
    st = study_status(toml, out)
    assert st["state"] == "partial" and st["done"] == calls["runs"] > 20 and st["total"] == 64 and st["total_is_cap"]
    assert study_status(out) == st and "(of up to 16 each;" in st["cells"]  # from the result path: the config in the shards
    runs, maps, note = partial_result(out)  # what `study plot` draws: the runs done, in their cells
    assert int(maps["n_runs"].sum()) == runs.sizes["run"] == st["done"] and note.startswith(f"partial: {st['done']} of up to 64 runs")
    run_study(tiny(**ADAPT), out=out, progress=False, batch_size=3)
    assert_same_result(fixed_and_adaptive[1], out)


@pytest.mark.slow
def test_coverage_campaign_script_writes_its_report(tmp_path: Path) -> None:
    """The small version of the campaign behind docs/notes/adaptive_coverage.md."""
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[2]
    out = tmp_path / "cov.md"
    subprocess.run([sys.executable, str(root / "tools" / "adaptive_coverage.py"), "--reps", "400", "--out", str(out)], check=True, cwd=root)
    text = out.read_text()
    assert "| 0.1 | 200 | 0.5 |" in text and (tmp_path / "cov.png").stat().st_size > 10_000
    low = float(text.split("Lowest coverage of the confidence sequence: **")[1].split("**")[0])
    assert low >= 0.95


def test_plots_say_how_many_runs_each_cell_kept(fixed_and_adaptive: tuple[Path, Path], tmp_path: Path) -> None:
    import matplotlib.pyplot as plt

    from tumblemc.viz.study import plot_study, plot_success_heatmap

    runs, maps = open_result(fixed_and_adaptive[1])
    fig = plot_success_heatmap(maps)
    texts = [t.get_text() for ax in fig.axes for t in ax.texts]
    assert any("n=5" in t for t in texts) and "runs kept (n)" in fig._suptitle.get_text()  # type: ignore[union-attr]
    assert "confidence-sequence (ends prior) interval" in fig._suptitle.get_text()  # type: ignore[union-attr]
    plt.close(fig)
    fixed_maps = open_result(fixed_and_adaptive[0])[1]
    fig = plot_success_heatmap(fixed_maps)  # every cell 16 runs: no n
    assert not any("n=" in t.get_text() for ax in fig.axes for t in ax.texts)
    plt.close(fig)
    paths = plot_study(runs, maps, tmp_path)
    assert all(p.stat().st_size > 10_000 for p in paths)
    # a cell with invalid runs keeps two detail lines (n and the invalid count on one), so the
    # panel keeps every cell's interval instead of falling back to probabilities alone
    bad = maps.copy(deep=True)
    bad["n_failed"][...] = 0
    bad["n_failed"].loc[{"incline_deg": 10.0}] = 1
    fig = plot_success_heatmap(bad)
    texts = [t.get_text() for ax in fig.axes for t in ax.texts]
    assert any(t.endswith(", 1 inv") and "n=" in t for t in texts)
    assert sum("\u2013" in t for t in texts) == bad["p_success"].size and not any(t.endswith("*") for t in texts)
    plt.close(fig)


def _fake_store(lose: int) -> tuple[Any, Any, dict[str, int]]:
    """read_main/simulate over a dict; the first ``lose`` simulate calls lose their last run (a shard set aside)."""
    done: dict[int, int] = {}
    calls = {"n": 0}

    def read() -> dict[str, np.ndarray]:
        r = np.array(sorted(done), dtype=np.int64)
        return {"run": r, "status": np.zeros(r.size, np.int64), "climbed": np.array([done[i] for i in r], dtype=np.int64)}

    def sim(idx: np.ndarray) -> None:
        calls["n"] += 1
        for i in idx[:-1] if calls["n"] <= lose else idx:
            done[int(i)] = 1

    return read, sim, calls


def test_a_run_lost_inside_a_round_is_simulated_again_or_stops_with_one_line() -> None:
    cfg = load_config(tiny(samples=40, precision=0.1, ci="confidence-sequence-ends"))
    n = 40 * len(cells(cfg))
    read, sim, calls = _fake_store(lose=1)
    redone: list[int] = []
    res = run_adaptive(cfg, n, read, sim, redo=redone.append)
    assert calls["n"] == 2 and np.all(res.kept == 21)  # every cell all one verdict: the first possible stop
    assert redone == [1]  # its shard was written (counted) and set aside: simulated again, counted off once
    # resumed with runs 0..4 done; run 4's shard is set aside after the first round's simulate
    done = {i: 1 for i in range(5)}
    ncall = {"n": 0}

    def read2() -> dict[str, np.ndarray]:
        r = np.array(sorted(done), dtype=np.int64)
        return {"run": r, "status": np.zeros(r.size, np.int64), "climbed": np.ones(r.size, np.int64)}

    def sim2(idx: np.ndarray) -> None:
        ncall["n"] += 1
        done.update({int(i): 1 for i in idx})
        if ncall["n"] == 1:
            del done[4]

    redone = []
    run_adaptive(cfg, n, read2, sim2, redo=redone.append)
    assert redone == [1]  # counted once at the start, simulated again: a progress bar takes it off
    read, sim, _ = _fake_store(lose=10**6)
    with pytest.raises(StudyStateError, match="runs still missing"):
        run_adaptive(cfg, n, read, sim)


@pytest.mark.slow
def test_adaptive_study_on_two_workers_equals_the_serial_one(
    fixed_and_adaptive: tuple[Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Rounds on a 2-worker cluster give the serial study's file.

    There the rounds go dearest cell first with the tail run by run (``engine.balance``).
    """
    calls: list[tuple[int, int, int]] = []
    real = engine.balance

    def spy(tasks: list[engine.Task], workers: int, cost: Any = None) -> list[engine.Task]:
        out = real(tasks, workers, cost)
        calls.append((workers, len(tasks), sum(len(t.run) == 1 for t in out)))
        return out

    monkeypatch.setattr(engine, "balance", spy)
    client = engine.local_client(2)
    try:
        out = tmp_path / "w2.nc"
        run_study(tiny(**ADAPT), client, out=out, progress=False, batch_size=3)
    finally:
        cluster = client.cluster
        client.close()
        cluster.close()
    assert_same_result(fixed_and_adaptive[1], out)
    assert calls and all(w == 2 for w, _, _ in calls)
    assert any(single > 0 for _, _, single in calls)  # a round's tail went run by run


def test_adaptive_twins_match_the_fixed_studys_run_by_run(tmp_path: Path) -> None:
    """An adaptive study's sensitivity twins are the fixed study's, run key by run key.

    Its twins are simulated by design index and renumbered with the runs kept.
    """
    strict = {"fraction": 0.02, "min_runs": 4, "dt_factor": 2, "ratio_abs_tol": 0.0, "ratio_rel_tol": 0.0}
    run_study(tiny(**MIXED, check=strict), out=tmp_path / "f.nc", progress=False)
    run_study(tiny(**ADAPT, check=strict), out=tmp_path / "a.nc", progress=False)
    (f, _), (a, _) = open_result(tmp_path / "f.nc"), open_result(tmp_path / "a.nc")
    fkey = {int(k): i for i, k in enumerate(f["run_key"].values[f["check_run"].values])}
    both = [(i, fkey[int(k)]) for i, k in enumerate(a["run_key"].values[a["check_run"].values]) if int(k) in fkey]
    assert both and (a["check_ratio_within_tol"].values == 0).any()
    for i, j in both:
        for v in ("check_twin_spread", "check_sensitive", "check_ratio_diff"):
            np.testing.assert_array_equal(a[v].values[i], f[v].values[j])
