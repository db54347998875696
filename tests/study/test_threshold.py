"""Threshold studies: the search on grid indices against an oracle, the config, and small real studies."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import tumblemc.study.threshold as TH
from tests.study.test_cf import plain_reader_checks
from tumblemc.io import open_result
from tumblemc.model.rows import TimeGrid
from tumblemc.study.config import ConfigError, load_config
from tumblemc.study.design import grid_of
from tumblemc.study.engine import run_study
from tumblemc.study.identity import config_hash, config_to_json

ROOT = Path(__file__).resolve().parents[2]
SMOKE = ROOT / "studies" / "smoke.toml"


def oracle(monkeypatch: pytest.MonkeyPatch, verdict: Any, invalid: set[tuple[int, int]] = frozenset()) -> list[tuple[int, int]]:
    """Replace the simulator: row ``{"i": i, "k": k}`` climbs when ``verdict(i, k)``; ``invalid`` pairs fail their step."""
    calls: list[tuple[int, int]] = []

    def fake(shape: str, rows: list[dict[str, int]], grid: TimeGrid, full: Any = None) -> dict[str, np.ndarray]:
        n = len(rows)
        out = {
            k: np.zeros(n, np.int64)
            for k in ("status", "climbed", "decided_early", "substeps", "failed_steps", "loose_steps", "impulse_steps")
        }
        out["newton_iterations"] = np.ones(n)
        out["error"] = np.full(n, "", dtype=object)
        for j, r in enumerate(rows):
            calls.append((r["i"], r["k"]))
            if (r["i"], r["k"]) in invalid:
                out["status"][j] = 1
            else:
                out["climbed"][j] = int(verdict(r["i"], r["k"]))
        return out

    monkeypatch.setattr(TH, "simulate_rows", fake)
    return calls


def rows_for(n: int, m: int) -> list[list[dict[str, int]]]:
    return [[{"i": i, "k": k} for k in range(m)] for i in range(n)]


def search(rows: list[list[dict[str, int]]], prior: Any) -> dict[str, np.ndarray]:
    """search_rows one sample at a time (a task holds one cell, so one prior)."""
    outs = [TH.search_rows("cuboid", [r], TimeGrid(), prior) for r in rows]
    return {k: np.concatenate([o[k] for o in outs]) for k in outs[0]}


@pytest.mark.parametrize("m", [1, 2, 5, 13])
def test_every_threshold_under_every_prior_is_found_exactly(monkeypatch: pytest.MonkeyPatch, m: int) -> None:
    """Monotone verdicts: the search returns the exact count of grid values passed, whatever its prior."""
    bisect_bound = int(np.ceil(np.log2(m + 1)))
    for g in [None, *range(m + 1)]:  # plain bisection, then a pilot that saw one sample at g
        prior = None if g is None else TH.pilot_prior(np.array([g]), m)
        calls = oracle(monkeypatch, lambda i, k: k < i)  # sample i passes i grid values
        out = search(rows_for(m + 1, m), prior)
        assert out["n_pass"].tolist() == list(range(m + 1))
        assert np.all(out["fail_rank"] - out["pass_rank"] == 1)
        assert out["censored"].tolist() == ([-1] + [0] * (m - 1) + [1] if m > 1 else [-1, 1])
        assert len(calls) == out["n_simulations"].sum()
        per: dict[int, list[int]] = {}
        for i, k in calls:  # never a grid value twice for a sample, never outside the grid
            assert 0 <= k < m
            per.setdefault(i, []).append(k)
        assert all(len(v) == len(set(v)) for v in per.values())
        if g is None:
            assert out["n_simulations"].max() <= bisect_bound
        else:
            assert out["n_simulations"][g] <= 2  # the pilot was right: the values next to it
            assert out["n_simulations"].max() <= max(bisect_bound, 7)  # the floor bounds a wrong pilot


def test_a_uniform_prior_is_plain_bisection() -> None:
    for m in range(1, 20):
        uniform = np.full(m + 1, 1.0)
        for lo in range(-1, m - 1):
            for hi in range(lo + 2, m + 1):
                assert TH.next_probe(lo, hi, uniform) == TH.next_probe(lo, hi, None) == (lo + hi) // 2


def test_an_invalid_probe_stops_the_search_and_keeps_what_is_known(monkeypatch: pytest.MonkeyPatch) -> None:
    m = 13  # true J = 8; plain bisection probes 6 (pass), then 9 (fail), then 7: invalid there
    oracle(monkeypatch, lambda i, k: k < 8, invalid={(0, 7)})
    out = TH.search_rows("cuboid", rows_for(1, m), TimeGrid())
    assert out["status"][0] == 1 and out["n_pass"][0] == -1
    assert (out["pass_rank"][0], out["fail_rank"][0]) == (6, 9)
    v = TH.implied_verdicts(out["pass_rank"], out["fail_rank"], np.arange(m))[0]
    assert v.tolist() == [1] * 7 + [-1, -1] + [0] * 4


def test_a_nonmonotone_sample_still_ends_on_a_pass_next_to_a_failure(monkeypatch: pytest.MonkeyPatch) -> None:
    """Verdicts 1 1 0 1 1 0 ...: the search reports one crossing, which the audit can contradict."""
    pattern = [1, 1, 0, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0]
    oracle(monkeypatch, lambda i, k: pattern[k])
    out = TH.search_rows("cuboid", rows_for(1, 13), TimeGrid())
    lo, hi = int(out["pass_rank"][0]), int(out["fail_rank"][0])
    assert hi == lo + 1 and pattern[lo] == 1 and pattern[hi] == 0


def test_direct_passes_and_axis_order() -> None:
    climbed = np.array([[1, 1, 0, 0], [1, 1, 1, 1], [0, 1, 1, 1], [1, 0, 0, 0]], np.int8)
    status = np.zeros_like(climbed)
    status[3, 1] = 1  # an invalid run before the first failure: unknown
    assert TH.direct_passes(climbed, status).tolist() == [2, 4, 0, -1]
    assert TH.implied_verdicts(np.array([1]), np.array([2]), np.array([3, 2, 1, 0]))[0].tolist() == [0, 0, 1, 1]


def tiny_threshold(**changes: Any) -> dict[str, Any]:
    d = tomllib.loads(SMOKE.read_text())
    d.update(
        {
            "name": "tth",
            "mode": "threshold",
            "presets": ["aluminum"],
            "incline_deg": [0, 20, 40, 60],
            "freq_hz": 10,
            "samples": 4,
            "check": {"fraction": 1.0, "min_runs": 1, "dt_factor": 2},
        }
    )
    d.update(changes)
    return d


def test_config_threshold_mode() -> None:
    cfg = load_config(tiny_threshold(incline_deg=[40, 0, 20, 60]))
    assert cfg.cell_dims == ("shape", "substrate", "field_mT", "freq_hz")
    assert cfg.axis_values == (0.0, 20.0, 40.0, 60.0)  # sorted
    assert grid_of(cfg).early_decision
    assert config_to_json(load_config(json.loads(config_to_json(cfg)))) == config_to_json(load_config(tiny_threshold()))
    f = load_config(tiny_threshold(threshold_axis="field_mT", field_mT=[5, 20, 10]))
    assert f.axis_values == (5.0, 10.0, 20.0) and TH.difficulty_order(f).tolist() == [2, 1, 0]
    assert config_hash(f) != config_hash(
        load_config(tiny_threshold(threshold_axis="field_mT", field_mT=[5, 20, 10], threshold_start="bisect"))
    )


@pytest.mark.parametrize(
    ("changes", "words"),
    [
        ({"threshold_axis": "shape"}, "has no order to search"),
        ({"threshold_axis": "mu"}, "threshold_axis"),
        ({"incline_deg": [30]}, "at least 2 distinct values"),
        ({"incline_deg": [30, 30, 40]}, "has duplicates"),
        ({"threshold_start": "median"}, "threshold_start"),
        (
            {"threshold_axis": "field_mT", "field_mT": [5, 20], "uncertain": {"field_mT": {"dist": "normal", "rel_sd": 0.05}}},
            "uncertain.field_mT",
        ),
        ({"incline_range": {"min": 0, "max": 30}}, "incline_range"),
    ],
)
def test_config_refuses(changes: dict[str, Any], words: str) -> None:
    with pytest.raises(ConfigError, match=words.replace(".", r"\.")):
        load_config(tiny_threshold(**changes))


def test_grid_config_hash_is_unchanged_by_the_threshold_keys() -> None:
    """A grid study's identity text holds no threshold key, and its hash is what 157fb29 (before threshold studies) gave."""
    grid = load_config(tomllib.loads(SMOKE.read_text()))
    assert "threshold" not in config_to_json(grid)
    assert config_hash(grid) == "3e37a8c516c2fa6c0db6fcd904bbf919701882089ce165afd2d678e914eb9b42"


@pytest.mark.slow
def test_threshold_study_audits_itself(tmp_path: Path) -> None:
    """Every sample checked: the searched thresholds equal the direct sweeps', the maps follow from them."""
    res = run_study(tiny_threshold(), out=tmp_path / "t.nc", progress=False)
    runs, maps = open_result(res.path)
    plain_reader_checks(res.path)  # xarray alone selects by label
    assert list(runs["pair"].values) == ["last_pass", "first_fail"]
    a = runs.attrs
    assert a["audit_checked_samples"] == 4 and a["audit_thresholds_compared"] == 4
    assert a["audit_threshold_mismatches"] == 0 and a["audit_disagreements"] == 0
    assert a["audit_early_stopped_climbed"] == 0
    assert runs["n_simulations"].sum() < 4 * 4
    ok = runs["status"].values == 0
    for th in runs["incline_deg"].values:
        share = float((runs["threshold"].values[ok] >= th).mean())
        assert maps["p_success"].sel(incline_deg=th).item() == pytest.approx(share)
    p = maps["p_success"].squeeze().values
    assert np.all(np.diff(p) <= 0)  # monotone by construction
    for ds in (runs, maps):
        for name, var in ds.variables.items():
            assert "long_name" in var.attrs, name
    from tumblemc.analysis.words import threshold_words
    from tumblemc.study.status import study_status

    words = study_status(res.path)["threshold_search"]
    assert "0 non-monotone, thresholds identical in 4 of 4, 0 of 16 verdicts differ" in words and " (in " not in words
    bad = runs.copy(deep=True)
    bad["check_nonmonotone"].values[1] = 1
    bad.attrs["audit_nonmonotone_samples"] = 1
    said = str(threshold_words(bad))
    assert "(in cuboid on aluminum: maps.audit_nonmonotone" in said and "WARNING: 1 of 4 audited samples" in said
    assert "WARNING" not in words
    from tumblemc.viz.study import plot_study

    pngs = plot_study(runs, maps, tmp_path / "plots")
    assert [p.name for p in pngs] == ["success_heatmap.png", "success_curves.png", "threshold_distribution.png"]
    # a rerun resumes nothing and gives the same file content
    again = run_study(tiny_threshold(), out=tmp_path / "t2.nc", progress=False, batch_size=1)
    r2, m2 = open_result(again.path)
    np.testing.assert_array_equal(r2["threshold"].values, runs["threshold"].values)
    np.testing.assert_array_equal(m2["p_success"].values, maps["p_success"].values)


def test_a_threshold_task_that_raises_keeps_every_column(monkeypatch: pytest.MonkeyPatch) -> None:
    import tumblemc.study.tasks as tasks_mod
    from tumblemc.study.design import design
    from tumblemc.study.engine import plan

    cfg = load_config(tiny_threshold())
    des = design(cfg)

    def boom(*a: Any, **k: Any) -> Any:
        raise RuntimeError("boom")

    monkeypatch.setattr(tasks_mod, "search_rows", boom)
    monkeypatch.setattr(tasks_mod, "sweep_rows", boom)
    for kind, cols in (("main", {*TH.THRESHOLD_OUTCOMES, "error"}), ("check", set(TH.THRESHOLD_CHECK_COLUMNS))):
        (task,) = plan(cfg, des, kind, np.arange(2), 8, "0" * 64)
        _, run, out = tasks_mod.execute_task(task)
        assert run.tolist() == [0, 1] and set(out) == cols
        assert all(len(v) == 2 for v in out.values())
        if kind == "main":
            assert out["status"].tolist() == [3, 3] and "boom" in out["error"][0]


@pytest.mark.slow
def test_critical_field_study_brackets_equal_the_lab_protocol(tmp_path: Path) -> None:
    """The field axis: each sample's bracket is the one lab.critical_field's bisection ends with (its midpoints are grid values)."""
    from tumblemc.lab import critical_field

    d = {
        "name": "cf",
        "mode": "threshold",
        "threshold_axis": "field_mT",
        "threshold_start": "bisect",
        "shapes": ["cuboid"],
        "presets": ["paper"],
        "incline_deg": 0,
        "field_mT": np.arange(3.0, 11.01, 0.5).tolist(),
        "freq_hz": 1,
        "samples": 2,
        "seed": 7,
        "check": {"fraction": 0.0, "min_runs": 0},
    }
    runs, _ = open_result(run_study(d, out=tmp_path / "cf.nc", progress=False).path)
    names = str(runs.attrs["uncertain"]).split(",")
    for i in range(2):
        lab = critical_field(
            1.0, 0.0, "cuboid", "paper", lo_mT=3.0, hi_mT=11.0, tol_mT=0.5, periods=2.0, **{p: float(runs[p].values[i]) for p in names}
        )
        assert bool(lab["tumbles_at_hi"]) and not bool(lab["tumbles_at_lo"])  # bracketed: the comparison means something
        assert lab["bracket_mT"].values.tolist() == [runs["threshold_fail"].values[i], runs["threshold"].values[i]]
        assert runs["n_simulations"].values[i] < int(lab["n_runs"])


@pytest.mark.slow
def test_adaptive_threshold_study_stops_when_every_grid_value_is_known(tmp_path: Path) -> None:
    """Precision in a threshold study: a cell closes when the interval at every grid value is narrow enough."""
    from tumblemc.analysis.confseq import CS_METHODS, cs_interval

    d = tiny_threshold(
        samples=60,
        precision=0.25,
        ci="confidence-sequence-ends",
        check={"fraction": 0.05, "min_runs": 2, "dt_factor": 2},
        presets=["aluminum", "paper"],
    )
    res = run_study(d, out=tmp_path / "a.nc", progress=False)
    runs, maps = open_result(res.path)
    assert runs.attrs["runs_kept"] == runs.sizes["run"] < 2 * 60
    lo, hi = maps["p_success_lower"].values, maps["p_success_upper"].values
    assert np.nanmax((hi - lo) / 2) <= 0.25 + 1e-12
    cfg = load_config(d)
    for sub in ("aluminum", "paper"):  # one sample fewer would leave some grid value's interval too wide
        m = runs["substrate"].values == sub
        v = runs["grid_verdict"].values[m][:-1]
        widths = []
        for k in range(v.shape[1]):
            ok = v[:, k] >= 0
            a, b = cs_interval(int((v[ok, k] == 1).sum()), int(ok.sum()), cfg.ci_level, CS_METHODS[cfg.ci])
            widths.append((b - a) / 2)
        assert m.sum() == 60 or max(widths) > 0.25


@pytest.mark.slow
def test_an_interrupted_threshold_study_resumes_to_the_same_file(tmp_path: Path) -> None:
    """Main shards lost (an interruption after the audit): the rerun searches them again with the same priors."""
    import xarray as xr

    from tumblemc.io import parts_dir
    from tumblemc.study.engine import run_study as run

    d = tiny_threshold(samples=6, check={"fraction": 0.34, "min_runs": 2, "dt_factor": 2})
    ref = run(d, out=tmp_path / "ref.nc", progress=False, batch_size=2)
    out = tmp_path / "cut.nc"
    import tumblemc.study.engine as eng

    calls = {"n": 0}
    real = eng._execute

    def stop_after_audit(tasks: Any, *a: Any) -> Any:  # the audit, then two main tasks, then "Ctrl-C"
        if tasks and tasks[0].kind == "main":
            calls["n"] += 1
            real(tasks[:2], *a)
            raise KeyboardInterrupt
        return real(tasks, *a)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(eng, "_execute", stop_after_audit)
        with pytest.raises(KeyboardInterrupt):
            run(d, out=out, progress=False, batch_size=2)
    assert calls["n"] == 1 and len(list(parts_dir(out).glob("main-*"))) == 2
    again = run(d, out=out, progress=False, batch_size=3)
    ra, ma = open_result(ref.path)
    rb, mb = open_result(again.path)
    for k in ("history", "date_created"):
        for ds in (ra, rb, ma, mb):
            ds.attrs.pop(k, None)
    xr.testing.assert_identical(ra, rb)
    xr.testing.assert_identical(ma, mb)
