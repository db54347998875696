"""Tests of the Monte Carlo engine.

Batch kernel against simulate, determinism across schedulers and batch sizes, crash-safe
resume, refusal of a changed config, the file's metadata.
"""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr

import tumblemc
from tests.tooling import load_tool
from tumblemc.io import StudyStateError, open_result, parts_dir, result_attrs
from tumblemc.model.rows import TimeGrid, simulate_rows
from tumblemc.schema import TIMESTAMP_ATTRS
from tumblemc.study import engine as eng
from tumblemc.study.checks import ConfigError
from tumblemc.study.config import load_config
from tumblemc.study.engine import run_study, study_status
from tumblemc.study.identity import config_hash, config_to_json, identity_json

ROOT = Path(__file__).resolve().parents[2]
SMOKE = ROOT / "studies" / "smoke.toml"


def tiny(**changes: Any) -> dict[str, Any]:
    """The smoke study made small: 10 Hz (0.2 s runs), 2 inclines, 3 samples per cell."""
    d = tomllib.loads(SMOKE.read_text())
    d.update({"name": "tiny", "incline_deg": [0, 60], "freq_hz": 10, "samples": 3})
    d["check"] = {"fraction": 0.02, "min_runs": 2, "dt_factor": 2}
    d.update(changes)
    return d


def strip_time(ds: xr.Dataset) -> xr.Dataset:
    out = ds.copy()
    for k in TIMESTAMP_ATTRS:
        out.attrs.pop(k, None)
    return out


def assert_same_result(a: Path, b: Path) -> None:
    ra, ma = open_result(a)
    rb, mb = open_result(b)
    xr.testing.assert_identical(strip_time(ra), strip_time(rb))
    xr.testing.assert_identical(strip_time(ma), strip_time(mb))


def test_batch_rows_equal_simulate_and_summarize() -> None:
    rows = [
        {"preset": "aluminum", "incline_deg": 0.0, "field_mT": 20.0, "freq_hz": 10.0, "mu": 0.5},
        {"preset": "paper", "incline_deg": 30.0, "field_mT": 18.0, "freq_hz": 10.0, "offset_deg": 20.0},
        {"preset": "paper", "incline_deg": 10.0, "field_mT": 20.0, "freq_hz": 5.0},
    ]
    grid = TimeGrid(periods=2.0, transient_periods=1.0)
    res = simulate_rows("cuboid", rows, grid)
    for i, row in enumerate(rows):
        s = tumblemc.summarize(tumblemc.simulate(duration_s=2.0 / row["freq_hz"], **row))
        assert res["status"][i] == s["status"] == 0
        # same kernel and trajectory; the window's progress is summed in another order
        assert res["progress_ratio"][i] == pytest.approx(s["progress_ratio"], rel=1e-12, abs=1e-12)
        assert res["mean_speed"][i] == pytest.approx(s["mean_speed"], rel=1e-12, abs=1e-15)
        assert bool(res["climbed"][i]) == s["climbed"]
        assert res["substeps"][i] == s["substeps"]
        assert res["failed_steps"][i] == s["failed_steps"]
        assert res["loose_steps"][i] == s["loose_steps"]
        assert res["max_penetration"][i] == s["max_penetration"]
        assert res["newton_iterations"][i] == pytest.approx(s["mean_newton_iterations"], rel=1e-12)


def test_batch_and_simulate_count_the_same_loose_steps() -> None:
    """The batch kernel and simulate/summarize count the same loose steps.

    The curved robot sliding down 35 deg aluminum at 0.5 Hz, low friction and adhesion (a run of
    studies/stress.toml), has loose steps (SolverOptions.accept_tol).
    """
    row = {
        "preset": "aluminum",
        "incline_deg": 35.0,
        "field_mT": 16.1843,
        "freq_hz": 0.5,
        "mu": 0.4739,
        "adhesion_C": 8.0537,
        "offset_deg": 23.8541,
    }
    res = simulate_rows("curved", [row], TimeGrid(periods=2.0, transient_periods=1.0))
    s = tumblemc.summarize(tumblemc.simulate(shape="curved", periods=2.0, **row))
    assert res["status"][0] == s["status"] == 0
    assert res["failed_steps"][0] == s["failed_steps"] == 0
    assert res["loose_steps"][0] == s["loose_steps"] > 0


def test_bad_row_is_recorded_not_raised() -> None:
    res = simulate_rows("cuboid", [{"preset": "paper", "mu": -1.0, "freq_hz": 10.0}, {"preset": "paper", "freq_hz": 10.0}], TimeGrid())
    assert res["status"].tolist() == [3, 0]
    assert "mu" in res["error"][0] and res["error"][1] == ""
    assert np.isnan(res["progress_ratio"][0]) and res["climbed"][0] == 0


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("ref") / "tiny.nc"
    run_study(tiny(), out=out, progress=False)
    return out


def test_file_schema(reference: Path) -> None:
    runs, maps = open_result(reference)
    assert runs.sizes["run"] == 6 and runs.sizes["check"] == 2
    for ds in (runs, maps):
        for name, var in ds.variables.items():
            assert "long_name" in var.attrs, name
            if var.dtype.kind in "fiu" and name not in ("quantile",):
                assert "units" in var.attrs, name
        assert "config_hash" in ds.attrs  # ties a group read alone to its study (tests/study/test_cf.py: the rest is at the root)
    root = result_attrs(reference)
    for key in (
        "Conventions",
        "history",
        "source",
        "date_created",
        "tumblemc_version",
        "git_sha",
        "git_dirty",
        "config_json",
        "config_hash",
        "seed",
    ):
        assert key in root, key
    assert runs["status"].attrs["flag_meanings"] == "ok failed_steps nonfinite error energy_gain"
    assert maps["p_success"].attrs["ancillary_variables"].startswith("p_success_lower")
    # the whole file opens as a tree too
    tree = xr.open_datatree(reference, engine="netcdf4")
    assert set(tree.children) == {"runs", "maps"}
    tree.close()
    # intervals at 0/N and N/N are never of zero width
    lo, hi, p = (maps[k].values.ravel() for k in ("p_success_lower", "p_success_upper", "p_success"))
    ok = np.isfinite(p)
    assert np.all(hi[ok] > lo[ok])
    st = study_status(reference)
    assert st["state"] == "complete" and st["done"] == 6 and "check_agreement_rate" in st


@pytest.mark.parametrize("batch_size", [1, 4])
def test_batch_size_changes_nothing(reference: Path, tmp_path: Path, batch_size: int) -> None:
    out = tmp_path / "tiny.nc"
    run_study(tiny(), out=out, progress=False, batch_size=batch_size)
    assert_same_result(reference, out)


def test_config_change_refused_then_fresh(reference: Path, tmp_path: Path) -> None:
    out = tmp_path / "tiny.nc"
    out.write_bytes(reference.read_bytes())
    again = run_study(tiny(), out=out, progress=False)  # complete: nothing to do
    assert again.runs.sizes["run"] == 6
    with pytest.raises(StudyStateError, match="different config"):
        run_study(tiny(seed=1), out=out, progress=False)
    # a partial study of another config is refused as well
    part = tmp_path / "part.nc"
    parts_dir(part).mkdir()
    from tumblemc.io import ShardStore
    from tumblemc.study.identity import config_hash, config_to_json

    c = load_config(tiny())
    ShardStore(part, config_to_json(c), config_hash(c)).open()
    with pytest.raises(StudyStateError, match="fresh"):
        run_study(tiny(samples=4), out=part, progress=False)
    res = run_study(tiny(samples=4), out=part, progress=False, fresh=True)
    assert res.runs.sizes["run"] == 8


def _cli(args: list[str], **kw: Any) -> subprocess.Popen[str]:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.Popen(
        [sys.executable, "-m", "tumblemc", *args], env=env, text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, **kw
    )


@pytest.mark.slow
def test_sigkill_then_resume_gives_the_same_file(tmp_path: Path) -> None:
    cfg = tiny(freq_hz=1, samples=4, incline_deg=[0, 30])  # 8 runs of 2 s: long enough to kill
    toml = tmp_path / "kill.toml"
    toml.write_text(_to_toml(cfg))
    ref = tmp_path / "ref.nc"
    run_study(cfg, out=ref, progress=False)
    out = tmp_path / "killed.nc"
    proc = _cli(["study", "run", str(toml), "--workers", "0", "--batch-size", "1", "--out", str(out), "--no-progress"])
    parts = parts_dir(out)
    deadline = time.time() + 120
    while time.time() < deadline and len(list(parts.glob("main-*.npz"))) < 2:
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.communicate()
    n_done = len(list(parts.glob("main-*.npz")))
    assert 2 <= n_done < 8, "the study was not interrupted mid-run"
    assert not out.exists()
    st = study_status(toml, out)
    assert st["state"] == "partial" and st["done"] >= 2
    proc = _cli(["study", "run", str(toml), "--workers", "0", "--out", str(out)])
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    assert f"{st['done']} of 8 runs already done" in err
    assert_same_result(ref, out)
    assert not parts.exists()


def test_cli_bad_config_is_one_clear_error(tmp_path: Path) -> None:
    toml = tmp_path / "bad.toml"
    toml.write_text(_to_toml(tiny(samplez=3)))
    proc = _cli(["study", "run", str(toml), "--workers", "0", "--out", str(tmp_path / "x.nc")])
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 2
    assert "samplez" in err and "samples" in err and "Traceback" not in err


def _to_toml(d: dict[str, Any]) -> str:
    """A minimal TOML writer for the flat configs of these tests."""

    def val(v: Any) -> str:
        if isinstance(v, str):
            return f'"{v}"'
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(val(x) for x in v) + "]"
        return repr(v)

    lines = [f"{k} = {val(v)}" for k, v in d.items() if not isinstance(v, dict)]
    for k, v in d.items():
        if isinstance(v, dict):
            if all(isinstance(x, dict) for x in v.values()) and v:
                for sub, tab in v.items():
                    lines.append(f"[{k}.{sub}]")
                    lines += [f"{a} = {val(b)}" for a, b in tab.items()]
            else:
                lines.append(f"[{k}]")
                lines += [f"{a} = {val(b)}" for a, b in v.items()]
    return "\n".join(lines) + "\n"


@pytest.mark.slow
def test_local_cluster_1_and_2_workers_identical_to_serial(reference: Path, tmp_path: Path) -> None:
    from tumblemc.study.engine import local_client

    for workers in (1, 2):
        client = local_client(workers)
        try:
            out = tmp_path / f"w{workers}.nc"
            run_study(tiny(), client, out=out, progress=False, batch_size=2)
        finally:
            cluster = client.cluster
            client.close()
            cluster.close()
        assert_same_result(reference, out)


@pytest.mark.slow
def test_worker_killed_mid_study_loses_and_duplicates_nothing(tmp_path: Path) -> None:
    from tumblemc.study.engine import local_client

    cfg = tiny(freq_hz=1, samples=6, incline_deg=[0, 30])  # 12 runs of 2 s
    ref = tmp_path / "ref.nc"
    run_study(cfg, out=ref, progress=False)
    client = local_client(2)
    try:
        pids = client.run(os.getpid)
        out = tmp_path / "killed.nc"
        import threading

        shards_at_kill: list[int] = []

        def killer() -> None:
            parts = parts_dir(out)
            deadline = time.time() + 120
            while time.time() < deadline and not list(parts.glob("main-*.npz")):
                time.sleep(0.05)
            shards_at_kill.append(len(list(parts.glob("main-*.npz"))))
            os.kill(next(iter(pids.values())), signal.SIGKILL)

        th = threading.Thread(target=killer)
        th.start()
        res = run_study(cfg, client, out=out, progress=False, batch_size=1)
        th.join()
    finally:
        cluster = client.cluster
        client.close()
        cluster.close()
    assert res.runs.sizes["run"] == 12
    assert shards_at_kill and shards_at_kill[0] < 12, "the worker was not killed mid-study"
    assert_same_result(ref, out)


def test_critical_incline_mode_brackets_and_checks(tmp_path: Path) -> None:
    cfg = {
        "name": "crit",
        "mode": "critical_incline",
        "shapes": ["cuboid"],
        "presets": ["paper"],
        "incline_deg": [0, 20, 40, 60],
        "incline_range": {"min": 0, "max": 60},
        "incline_tol": 4.0,
        "field_mT": 20,
        "freq_hz": 10,
        "samples": 4,
        "seed": 5,
        "check": {"min_runs": 2, "dt_factor": 2},
    }
    res = run_study(cfg, out=tmp_path / "crit.nc", progress=False)
    runs, maps = open_result(res.path)
    crit, fail, cens = (runs[k].values for k in ("critical_incline_deg", "fails_at_deg", "censored"))
    rows = [
        {"preset": "paper", "field_mT": 20.0, "freq_hz": 10.0, **{k: float(runs[k].values[i]) for k in runs.attrs["uncertain"].split(",")}}
        for i in range(4)
    ]
    grid = TimeGrid(dt=None)
    for i in range(4):
        assert runs["status"].values[i] == 0
        if cens[i] == 0:  # bracketed: climbs at the lower end, fails at the upper, within tol
            assert 0 < fail[i] - crit[i] <= 4.0
            v = simulate_rows("cuboid", [dict(rows[i], incline_deg=float(crit[i])), dict(rows[i], incline_deg=float(fail[i]))], grid)
            assert v["climbed"].tolist() == [1, 0]
    # P(climb theta) is non-increasing in theta and lies in its interval
    p = maps["p_success"].squeeze().values
    assert np.all(np.diff(p) <= 1e-12)
    assert runs.attrs["monotonicity_checked_samples"] == 2
    assert 0.0 <= runs.attrs["monotonicity_disagreement_rate"] <= 1.0
    assert runs["check_grid_climbed"].shape == (2, 4)
    assert runs.attrs["simulations_total"] == int(runs["n_simulations"].sum())
    from tumblemc.viz.study import plot_study

    pngs = plot_study(runs, maps, tmp_path / "plots")
    assert [p.name for p in pngs] == ["success_curves.png", "critical_incline_distribution.png"]
    assert all(p.stat().st_size > 0 for p in pngs)
    st = study_status(res.path)
    assert st["state"] == "complete" and st["done"] == 4


def test_interrupted_fresh_run_resumes_over_an_old_result(reference: Path, tmp_path: Path) -> None:
    """Running B again (without --fresh) continues B instead of refusing.

    The setting: an old result of config A and the shards of an interrupted --fresh run
    of config B.
    """
    from tumblemc.io import ShardStore
    from tumblemc.study.identity import config_hash, config_to_json

    out = tmp_path / "tiny.nc"
    out.write_bytes(reference.read_bytes())
    b = load_config(tiny(seed=1))
    ShardStore(out, config_to_json(b), config_hash(b)).open()
    res = run_study(tiny(seed=1), out=out, progress=False)
    assert res.runs.attrs["config_hash"] == config_hash(b)


def test_a_batch_that_raises_is_recorded_row_by_row(monkeypatch: pytest.MonkeyPatch) -> None:
    import tumblemc.study.engine as eng
    import tumblemc.study.tasks as tasks_mod

    real = tasks_mod.simulate_rows

    def flaky(shape: str, rows: Any, grid: TimeGrid, full: Any = None) -> Any:
        if any(r.get("mu") == 0.123 for r in rows):
            raise RuntimeError("boom")
        return real(shape, rows, grid, full)

    monkeypatch.setattr(tasks_mod, "simulate_rows", flaky)
    rows = ({"preset": "paper", "freq_hz": 10.0, "mu": 0.3}, {"preset": "paper", "freq_hz": 10.0, "mu": 0.123})
    task = eng.Task("main", "k", "cuboid", (0, 1), rows, TimeGrid())
    _, run, out = eng.execute_task(task)
    assert run.tolist() == [0, 1] and out["status"].tolist() == [0, 3]
    assert "boom" in out["error"][1] and np.isnan(out["progress_ratio"][1])


def test_critical_mode_needs_two_check_inclines_in_range() -> None:
    from tumblemc.study.checks import ConfigError

    cfg = {"name": "c", "mode": "critical_incline", "shapes": ["cuboid"], "presets": ["paper"], "incline_deg": [30, 45],
           "incline_range": {"min": 0, "max": 20}, "field_mT": 20, "freq_hz": 1, "samples": 2, "seed": 1}  # fmt: skip
    with pytest.raises(ConfigError, match="incline_deg"):
        load_config(cfg)


def test_a_critical_check_task_that_raises_keeps_every_column(monkeypatch: pytest.MonkeyPatch) -> None:
    """The error row of a critical study's check task has the same columns as a normal one.

    The shards of a task are concatenated column by column.
    """
    import tumblemc.study.engine as eng
    import tumblemc.study.tasks as tasks_mod

    def boom(*args: Any, **kw: Any) -> Any:
        raise RuntimeError("boom")

    monkeypatch.setattr(tasks_mod, "monotonicity_rows", boom)
    rows = ({"preset": "paper", "freq_hz": 10.0}, {"preset": "paper", "freq_hz": 10.0})
    task = eng.Task("check", "k", "cuboid", (3, 4), rows, TimeGrid(), "critical_incline", 0.0, 40.0, 5.0, (0.0, 20.0, 40.0), TimeGrid())
    _, run, out = eng.execute_task(task)
    assert run.tolist() == [3, 4] and set(out) == set(tasks_mod.CHECK_COLUMNS)
    assert out["grid_status"].shape == (2, 3) and np.all(out["grid_status"] == 3)
    assert out["pair_status"].shape == (2, 2) and np.all(out["pair_status"] == 3)


def test_batch_row_with_lift_equals_simulate() -> None:
    row = {"preset": "paper", "incline_deg": 0.0, "freq_hz": 10.0, "lift_m": 20e-6}
    res = simulate_rows("cuboid", [row], TimeGrid())
    s = tumblemc.summarize(tumblemc.simulate(duration_s=0.2, **row))
    assert res["status"][0] == s["status"] == 0
    assert res["progress_ratio"][0] == pytest.approx(s["progress_ratio"], rel=1e-12, abs=1e-12)


def test_dt_check_compares_ratios_against_the_tolerance(reference: Path, tmp_path: Path) -> None:
    """The dt check compares numbers.

    Per check run the ratio difference and a within-tolerance flag, the share in the maps,
    and the words of study status; the tolerance is a config key.
    """
    runs, maps = open_result(reference)
    diff = runs["check_ratio_diff"].values
    sel = runs["check_run"].values
    np.testing.assert_array_equal(diff, runs["check_progress_ratio_fine"].values - runs["progress_ratio"].values[sel])
    flag = runs["check_ratio_within_tol"].values
    tol = 0.05 + 0.1 * np.abs(runs["check_progress_ratio_fine"].values)
    valid = (runs["status"].values[sel] == 0) & (runs["check_status_fine"].values == 0)
    np.testing.assert_array_equal(flag, np.where(valid, np.abs(diff) <= tol, -1))
    share = maps["check_within_tol_share"].values
    assert np.nansum(maps["n_check_compared"].values) == np.count_nonzero(flag >= 0)
    assert np.nanmin(share) >= 0.0 and np.nanmax(share) <= 1.0
    assert study_status(reference)["dt_check"].startswith("dt converged in ")
    # a zero tolerance flags every checked run whose ratios differ at all, and says so
    strict = tmp_path / "strict.nc"
    run_study(
        tiny(check={"fraction": 0.02, "min_runs": 2, "dt_factor": 2, "ratio_abs_tol": 0.0, "ratio_rel_tol": 0.0}),
        out=strict,
        progress=False,
    )
    r2, _ = open_result(strict)
    differ = np.abs(r2["check_ratio_diff"].values) > 0
    np.testing.assert_array_equal(r2["check_ratio_within_tol"].values == 0, differ & (r2["check_ratio_within_tol"].values >= 0))
    if differ.any():
        assert "runs differ" in study_status(strict)["dt_check"]
    assert r2.attrs["config_hash"] != runs.attrs["config_hash"]  # the tolerance is part of the study


def test_config_hash_leaves_out_added_keys_at_their_default() -> None:
    """Keys added after studies were written keep older hashes.

    The check tolerances at their defaults and rotation = "paper" (the value older studies
    implied) are left out.
    """
    base = load_config(tiny(rotation="paper"))
    same = load_config(tiny(rotation="paper", check={"fraction": 0.02, "min_runs": 2, "dt_factor": 2, "ratio_abs_tol": 0.05}))
    assert config_hash(base) == config_hash(same)
    assert '"rotation"' not in identity_json(base) and "ratio_abs_tol" not in identity_json(base)
    assert '"rotation":"momentum"' in identity_json(load_config(tiny()))  # the new default is written out
    # the stored JSON keeps every key: it gives the config back, also at the values earlier studies implied
    assert '"rotation":"paper"' in config_to_json(base)
    back = load_config(json.loads(config_to_json(base)))
    assert back == dataclasses.replace(base, execution=back.execution)  # [execution] is not part of the JSON
    with pytest.raises(ConfigError, match="check.ratio_rel_tol"):
        load_config(tiny(check={"ratio_rel_tol": -1.0}))


def test_balance_orders_dearest_first_and_splits_the_tail() -> None:
    """``balance`` with one worker keeps the plan.

    With more it puts the dearest tasks first (stable) and splits the last 2 x workers
    tasks run by run: every run once, its row and flag with it, keys unique.
    """
    rows = tuple({"preset": "paper", "incline_deg": float(i)} for i in range(40))
    flags = (True, False, False, True)
    tasks = [
        eng.Task("main", f"tumblemc-main-abc-{i:09d}-4", "cuboid", tuple(range(i, i + 4)), rows[i : i + 4], TimeGrid(), full=flags)  # type: ignore[arg-type]
        for i in range(0, 40, 4)
    ]
    assert eng.balance(tasks, 1, lambda t: -t.run[0]) == tasks
    cost = {0: 1.0, 4: 5.0, 8: 5.0, 12: 2.0}  # the rest 0
    out = eng.balance(tasks, 2, lambda t: cost.get(t.run[0], 0.0))
    assert [t.run[0] for t in out[:6]] == [4, 8, 12, 0, 16, 20]  # dearest first, ties in plan order
    assert all(len(t.run) == 1 for t in out[6:]) and len(out) == 6 + 16  # the last 4 tasks, one run each
    assert sorted(r for t in out for r in t.run) == list(range(40))
    for t in out:
        for k, r in enumerate(t.run):
            assert t.rows[k] == rows[r]
            assert t.full[k] == (r % 4 in (0, 3))
    assert len({t.key for t in out}) == len(out)
    assert out[-1].key == "tumblemc-main-abc-000000039-1"


def test_cell_cost_is_runs_times_the_cells_mean_iterations() -> None:
    main = {"run": np.array([0, 1, 5, 9]), "newton_iterations": np.array([2.0, 4.0, 7.0, np.nan])}
    cost = eng.cell_cost(main, 5)  # cells of 5 runs: cell 0 has runs 0 and 1, cell 1 run 5, cell 1's run 9 unknown
    grid = TimeGrid()
    assert cost(eng.Task("main", "k", "cuboid", (2, 3, 4), ({}, {}, {}), grid)) == 3 * 3.0  # type: ignore[arg-type]
    assert cost(eng.Task("main", "k", "cuboid", (6,), ({},), grid)) == 7.0  # type: ignore[arg-type]
    assert cost(eng.Task("main", "k", "cuboid", (12, 13), ({}, {}), grid)) == 0.0  # type: ignore[arg-type]
    assert eng.cell_cost({}, 5)(eng.Task("main", "k", "cuboid", (0,), ({},), grid)) == 0.0  # type: ignore[arg-type]


STRICT = {"fraction": 0.02, "min_runs": 2, "dt_factor": 2, "ratio_abs_tol": 0.0, "ratio_rel_tol": 0.0}


def test_twins_classify_the_check_runs_outside_the_tolerance(tmp_path: Path) -> None:
    """Each check run outside the ratio tolerance is simulated again with the magnetisation x (1 +- twin_rel).

    The twins' ratios are those of ``simulate`` with that magnetisation (the obvious twin),
    the spread is their larger move, and the class says whether it reaches the dt
    difference. ``twin_rel = 0`` turns them off.
    """
    from tumblemc import simulate, summarize
    from tumblemc.model.params import PRESETS
    from tumblemc.study.design import design, run_kwargs

    out = tmp_path / "strict.nc"
    run_study(tiny(check=STRICT), out=out, progress=False)
    runs, _ = open_result(out)
    within = runs["check_ratio_within_tol"].values
    assert (within == 0).any()  # a zero tolerance: ratios at dt and dt / 2 differ
    cfg = load_config(tiny(check=STRICT))
    des = design(cfg)
    sel = runs["check_run"].values
    spread, sens = runs["check_twin_spread"].values, runs["check_sensitive"].values
    for k in range(sel.size):
        if within[k] != 0:
            assert np.isnan(spread[k]) and sens[k] == -1
            continue
        r = int(sel[k])
        kw = run_kwargs(cfg, des.isel(run=r))
        m = kw.get("magnetization", PRESETS[kw["preset"]].magnetization)  # the sampled one, else the preset's
        twins = [float(summarize(simulate(**{**kw, "magnetization": m * (1 + s * 1e-6)}))["progress_ratio"]) for s in (1, -1)]
        for tag, t in zip(("up", "down"), twins, strict=True):
            assert runs[f"check_twin_ratio_{tag}"].values[k] == pytest.approx(t, rel=1e-12, abs=1e-15)
        moves = [abs(t - runs["progress_ratio"].values[r]) for t in twins]
        assert spread[k] == pytest.approx(max(moves), rel=1e-12, abs=1e-15)  # the window summed in another order
        assert sens[k] == int(max(moves) > 0.0 + 0.0 * abs(runs["check_progress_ratio_fine"].values[k]))  # STRICT: zero tolerance
    assert runs.attrs["check_n_sensitive"] + runs.attrs["check_n_dt_limited"] == np.count_nonzero(within == 0)
    _, maps = open_result(out)  # the classes per cell
    for name, code in (("n_check_sensitive", 1), ("n_check_dt_limited", 0)):
        assert int(np.nansum(maps[name].values)) == np.count_nonzero(sens == code)
    # tools/dt_ladder.py rebuilds the same runs from the file alone: its dt / 1 and dt / 2 are the study's two steps
    tool = load_tool("dt_ladder")
    rows = tool.ladder(out, tool.outside_runs(out), [1, 2], "magnetization", 1e-6, workers=1)
    assert [r["run"] for r in rows] == [int(r) for r in sel[within == 0]]
    for row, k in zip(rows, np.flatnonzero(within == 0), strict=True):
        assert row["dt/1"] == pytest.approx(runs["progress_ratio"].values[sel[k]], rel=1e-12, abs=1e-15)
        assert row["dt/2"] == pytest.approx(runs["check_progress_ratio_fine"].values[k], rel=1e-12, abs=1e-15)
        assert row["twins' spread"] == pytest.approx(spread[k], rel=1e-9, abs=1e-12)
        assert row["not valid"] == "-"  # every run of the tiny study is valid at both steps
    words = study_status(out)["dt_check"]
    assert "limited by dt" in words and "sensitive" in words and "of 2 twins" not in words
    # a twin on the other side of the climb threshold is named in the words
    from tumblemc.analysis.words import check_words

    k0 = int(np.flatnonzero(within == 0)[0])
    flipped = runs.copy(deep=True)
    flipped["check_twin_ratio_up"].values[k0] = 0.0 if runs["progress_ratio"].values[sel[k0]] >= 0.5 else 1.0
    assert "1 of 2 twins" in check_words(flipped)
    off = tmp_path / "off.nc"
    run_study(tiny(check={**STRICT, "twin_rel": 0.0}), out=off, progress=False)
    r0, _ = open_result(off)
    assert "check_sensitive" not in r0.variables and "limited by dt" not in study_status(off)["dt_check"]
    for bad in (-1.0, 1e-13, 0.5):
        with pytest.raises(ConfigError, match="check.twin_rel"):
            load_config(tiny(check={"twin_rel": bad}))


def test_twin_sensitivity_classes() -> None:
    """Sensitive when the twins move the ratio beyond the run's tolerance; unclassified without valid twins or within tolerance."""
    from tumblemc.study.assemble import twin_sensitivity

    ratio = np.array([1.0, 1.0, 1.0, 1.0, 1.0, 1.0])
    twins = {
        "twin_ratio_up": np.array([1.5, 1.01, 1.5, 1.5, np.nan, 1.25]),
        "twin_ratio_down": np.array([0.9, 0.98, 0.2, 1.0, np.nan, 1.0]),
        "twin_status_up": np.array([0, 0, 1, 0, -1, 0]),
        "twin_status_down": np.array([0, 0, 0, 0, -1, 0]),
    }
    tol = np.array([0.15, 0.15, 0.15, 0.15, 0.15, 0.25])
    within = np.array([0, 0, 0, 1, 0, 0], dtype=np.int8)
    spread, sens = twin_sensitivity(ratio, twins, tol, within)
    np.testing.assert_array_equal(sens, [1, 0, -1, -1, -1, 0])  # a spread equal to the tolerance is within it, as in the dt check
    assert spread[5] == 0.25  # exactly the tolerance (binary-exact values)
    np.testing.assert_allclose(spread[[0, 1]], [0.5, 0.02])
    assert np.isnan(spread[2:5]).all()


def test_dt_ladder_names_the_steps_whose_run_is_not_valid(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """tools/dt_ladder.py marks the ladder rungs and twins whose run is not valid (their ratio is not an answer)."""
    out = tmp_path / "strict.nc"
    run_study(tiny(check=STRICT), out=out, progress=False)
    tool = load_tool("dt_ladder")
    dt0 = 5e-5
    monkeypatch.setattr(tool, "_one", lambda job: (1.0, int(job[1] < dt0 / 3 or job[2] != "")))  # dt/4 and both twins fail
    rows = tool.ladder(out, [0], [1, 2, 4], "magnetization", 1e-6, workers=1)
    assert rows[0]["not valid"] == "dt/4, magnetization +1e-06, magnetization -1e-06"
