"""Early decisions (tumblemc.kernels.decide).

The bound is checked against a Python twin written from the derivation in the module's
docstring, against the runs themselves (at every recorded instant of the window the climb
still to come stays below it), and the early stop against the same run simulated to the end
(the same arithmetic up to the decision, a failure verdict after it).
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import tumblemc
from tumblemc.kernels import layout as L
from tumblemc.kernels.decide import climb_bound
from tumblemc.kernels.field import field_work_between, field_work_bound
from tumblemc.model.energy import ENERGY_GAIN_TOL
from tumblemc.model.fields import Rotating, Sequence
from tumblemc.model.rows import TimeGrid, simulate_rows
from tumblemc.model.run import prepare, run_inputs
from tumblemc.study.checks import ConfigError
from tumblemc.study.config import load_config
from tumblemc.study.identity import config_hash, config_to_json, identity_json

# a cuboid on aluminum at 40 deg from the default study that slides down (ratio about -380)
SLIDER = {"preset": "aluminum", "incline_deg": 40.0, "field_mT": 20.0, "freq_hz": 1.0, "adhesion_C": 34.857,
          "magnetization": 41761.6, "mu": 0.42, "offset_deg": 1.868}  # fmt: skip
# the paper robot climbing the paper incline at 45 deg (ratio about 0.93)
CLIMBER = {"preset": "paper", "incline_deg": 45.0}


def _twin_bound(ds: xr.Dataset, k: int) -> float:
    """climb_bound in SI from a run's record at index ``k``: the derivation, written again."""
    a = ds.attrs
    th = math.radians(a["incline_deg"])
    m, g = a["mass"], a["g"]
    mb = a["V_m"] * a["magnetization"] * a["field_mT"] * 1e-3
    t, t_end = float(ds.time[k]), float(ds.time[-1])
    n = np.array([0.0, math.sin(th), math.cos(th)])
    zc = float(n @ ds.position.values[k])
    eref0 = float(ds.kinetic_energy[0]) + m * g * 1e-4 + mb * (2 + 2 * math.pi * a["freq_hz"] * t_end)
    tol_left = max(ENERGY_GAIN_TOL * (eref0 + float(ds.potential_energy_released[k])) - float(ds.energy_gain[k]), 0.0)
    e = float(ds.kinetic_energy[k]) + mb * (2 + 2 * math.pi * a["freq_hz"] * (t_end - t)) + (m * g * math.cos(th) + a["F_elect"]) * zc
    return (e + tol_left) / (m * g * math.sin(th))


def _kernel_bound(ds: xr.Dataset, k: int, **kw: object) -> float:
    """The kernel's climb_bound on the same record (scaled in, SI out)."""
    spec = prepare(run_inputs("cuboid", duration_s=float(ds.time[-1]), **kw))  # type: ignore[arg-type]
    u = spec.units
    led = np.zeros(L.N_LED)
    led[L.L_KE] = float(ds.kinetic_energy[k]) / u.energy
    led[L.L_GAIN] = float(ds.energy_gain[k]) / u.energy
    led[L.L_POTMAX] = float(ds.potential_energy_released[k]) / u.energy
    t_end = float(ds.time[-1]) / u.time
    eref0 = float(ds.kinetic_energy[0]) / u.energy + 1.0 + field_work_bound(spec.prm, t_end)
    x = ds.position.values[k] / u.length
    return float(climb_bound(spec.prm, x, led, float(ds.time[k]) / u.time, t_end, eref0)) * u.length


@pytest.mark.parametrize("kw", [SLIDER, CLIMBER], ids=["slider", "climber"])
def test_climb_bound_matches_its_twin_and_bounds_the_climb_to_come(kw: dict[str, float]) -> None:
    ds = tumblemc.simulate(shape="cuboid", duration_s=2.0, record_every=100, **kw)  # type: ignore[arg-type]
    assert ds.attrs["status"] == 0
    prog = ds.progress.values
    window = np.flatnonzero(ds.time.values >= 1.0)[:-1]  # the kernel never asks at the run's end
    for k in window[::4]:
        twin = _twin_bound(ds, int(k))
        assert _kernel_bound(ds, int(k), **kw) == pytest.approx(twin, rel=1e-9)
        assert prog[-1] - prog[k] <= twin  # the climb still to come
    assert 0.0 < _twin_bound(ds, int(window[0])) < math.inf


def test_field_work_between_is_the_run_bound_on_the_whole_run_and_splits() -> None:
    spec = prepare(run_inputs("cuboid", preset="paper", duration_s=2.0))
    prm = spec.prm
    T = 2.0 / spec.units.time
    assert field_work_between(prm, 0.0, T) == field_work_bound(prm, T)
    # two halves: each carries the energy range 2|m||B| once
    halves = field_work_between(prm, 0.0, T / 2) + field_work_between(prm, T / 2, T)
    assert halves == pytest.approx(field_work_bound(prm, T) + 2 * prm[L.P_TORQ], rel=1e-12)
    assert field_work_between(prm, T, T) == 2 * prm[L.P_TORQ]  # the energy range alone
    # a program of two segments (a step in frequency at 0.5 s): over [0, T] it equals the run's bound
    prog = Sequence((0.5, Rotating(20.0, 1.0)), (1.5, Rotating(10.0, 3.0)))
    sp = prepare(run_inputs("cuboid", preset="paper", duration_s=2.0, field=prog))
    Tp = 2.0 / sp.units.time
    assert field_work_between(sp.prm, 0.0, Tp) == pytest.approx(field_work_bound(sp.prm, Tp), rel=1e-12)
    # the second segment alone: 2 |m| |B2| + |m| |B2| 2 pi f2 (T - 0.5 s)
    t1 = 1.0 / sp.units.time
    amp2 = sp.prm[L.N_PRM + L.FSEG + L.FS_AMP]
    f2 = sp.prm[L.N_PRM + L.FSEG + L.FS_FREQ]
    assert field_work_between(sp.prm, t1, Tp) == pytest.approx(2 * amp2 + amp2 * 2 * math.pi * f2 * (Tp - t1), rel=1e-12)


def test_flat_plane_and_contact_only_electrostatics_are_never_decided() -> None:
    spec = prepare(run_inputs("cuboid", preset="paper", incline_deg=0.0, duration_s=2.0))
    assert math.isinf(climb_bound(spec.prm, np.zeros(3), np.zeros(L.N_LED), 0.0, 1.0, 1.0))
    # in contact only, the electrostatic force is no potential (a hop gains F_e x its height)
    on = prepare(run_inputs("cuboid", preset="paper", incline_deg=45.0, duration_s=2.0))
    off = prepare(run_inputs("cuboid", preset="paper", incline_deg=45.0, duration_s=2.0, electrostatic_in_flight=False))
    assert math.isfinite(climb_bound(on.prm, np.zeros(3), np.zeros(L.N_LED), 0.0, 1.0, 1.0))
    assert math.isinf(climb_bound(off.prm, np.zeros(3), np.zeros(L.N_LED), 0.0, 1.0, 1.0))


def test_only_grid_studies_decide_early() -> None:
    from tumblemc.study.design import grid_of

    base = {"name": "e", "shapes": ["cuboid"], "presets": ["paper"], "incline_deg": [30, 45], "field_mT": 20, "freq_hz": 1,
            "samples": 2, "seed": 1}  # fmt: skip
    assert grid_of(load_config(base)).early_decision
    assert not grid_of(load_config(base), fine=True).early_decision  # the dt check runs to the end
    assert not grid_of(load_config({**base, "early_decision": False})).early_decision
    # critical-incline studies have no audit: every run to the end
    assert not grid_of(load_config({**base, "mode": "critical_incline", "incline_range": {"min": 0, "max": 60}})).early_decision


@pytest.fixture(scope="module")
def slider_rows() -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    rows = [SLIDER, CLIMBER]
    grid = TimeGrid(max_failed_steps=1)
    full = simulate_rows("cuboid", rows, grid)  # type: ignore[arg-type]
    early = simulate_rows("cuboid", rows, dataclasses.replace(grid, early_decision=True))  # type: ignore[arg-type]
    return full, early


def test_early_stop_is_the_full_run_up_to_the_decision(slider_rows: tuple[dict[str, np.ndarray], dict[str, np.ndarray]]) -> None:
    full, early = slider_rows
    # the slider: the bound decides it before the end, the full run fails, the early one stops there
    td = full["decided_time"][0]
    assert 1.0 < td < 2.0 and full["climbed"][0] == 0 and full["decided_early"][0] == 0
    assert early["decided_early"][0] == 1 and early["climbed"][0] == 0 and early["status"][0] == 0
    assert early["decided_time"][0] == td
    # its censored progress is the full run's progress at the decision (record every step)
    ds = tumblemc.simulate(shape="cuboid", duration_s=2.0, **SLIDER)  # type: ignore[arg-type]
    p = ds.progress.sel(time=td, method="nearest") - ds.progress.sel(time=1.0, method="nearest")
    assert early["progress"][0] == pytest.approx(float(p), rel=1e-9, abs=1e-12)
    assert early["progress_ratio"][0] == pytest.approx(float(p) / (td - 1.0) / ds.attrs["ideal_speed"], rel=1e-9)
    # the climber is never decided and is the same run in both modes, bit for bit
    assert np.isnan(full["decided_time"][1]) and early["decided_early"][1] == 0
    for k in ("progress_ratio", "newton_iterations", "energy_gain", "climbed"):
        assert early[k][1] == full[k][1]


def test_full_rows_are_audited_not_stopped() -> None:
    grid = TimeGrid(max_failed_steps=1, early_decision=True)
    out = simulate_rows("cuboid", [SLIDER, SLIDER], grid, full=[True, False])  # type: ignore[list-item]
    assert out["decided_early"].tolist() == [0, 1]
    assert out["decided_time"][0] == out["decided_time"][1]
    assert out["climbed"].tolist() == [0, 0]


def test_early_decision_config_key() -> None:
    base = {"name": "e", "shapes": ["cuboid"], "presets": ["paper"], "incline_deg": [30], "field_mT": 20, "freq_hz": 1,
            "samples": 2, "seed": 1}  # fmt: skip
    assert load_config(base).early_decision is True
    assert load_config({**base, "early_decision": False}).early_decision is False
    with pytest.raises(ConfigError, match="early_decision"):
        load_config({**base, "early_decision": "yes"})
    # a study written before the key (early_decision false, implied) keeps its hash; the default does not
    assert "early_decision" not in identity_json(load_config({**base, "early_decision": False}))
    off = load_config({**base, "early_decision": False})
    assert load_config(json.loads(config_to_json(off))) == off  # the stored JSON keeps the key
    assert config_hash(load_config({**base, "early_decision": False})) != config_hash(load_config(base))


@pytest.mark.slow
def test_study_stops_sliders_audits_the_check_runs_and_keeps_every_verdict(tmp_path: Path) -> None:
    """A small study with and without early decisions: the same verdicts run by run.

    The cuboid on paper at 60 deg slides; half the runs are check runs, which run to the end
    and audit the bound.
    """
    from tumblemc.analysis.words import early_words
    from tumblemc.study.engine import run_study
    from tumblemc.viz.ratio import plot_ratio_distribution

    cfg = {"name": "ed", "shapes": ["cuboid"], "presets": ["paper"], "incline_deg": [45, 60], "field_mT": 20, "freq_hz": 1,
           "samples": 4, "seed": 3, "check": {"fraction": 0.5, "min_runs": 2, "dt_factor": 2}}  # fmt: skip
    res = run_study(cfg, out=tmp_path / "on.nc", progress=False)
    on = res.runs
    off = run_study({**cfg, "early_decision": False}, out=tmp_path / "off.nc", progress=False).runs
    early = on["decided_early"].values == 1
    checked = on["check_flag"].values == 1
    assert early.any() and not early[checked].any()
    assert off["decided_early"].values.sum() == 0 and on.attrs["decided_early_runs"] == early.sum()
    # every verdict and status the same; the runs not stopped identical in every outcome
    assert np.array_equal(on["climbed"].values, off["climbed"].values)
    assert np.array_equal(on["status"].values, off["status"].values)
    assert np.array_equal(on["decided_time"].values, off["decided_time"].values, equal_nan=True)
    for k in ("progress_ratio", "newton_iterations", "energy_gain"):
        assert np.array_equal(on[k].values[~early], off[k].values[~early], equal_nan=True)
    # the audit: check runs decided by the bound (at dt and at dt/2) never climbed
    assert on.attrs["early_decision_audit_dt_climbed"] == 0 and on.attrs["early_decision_audit_fine_climbed"] == 0
    assert on.attrs["early_decision_audit_dt_runs"] == checked.sum()
    # a censored outcome is not ranked as if it were final
    from tumblemc.analysis.screening import rank_correlation

    with pytest.raises(ValueError, match="early decision"):
        rank_correlation(on, outcome="progress_ratio")
    assert "rho" in rank_correlation(on, outcome="climbed")
    assert "rho" in rank_correlation(off, outcome="progress_ratio")
    words = early_words(on)
    assert words is not None and f"{early.sum()} of 8 runs" in words
    assert early_words(off) is None
    plot_ratio_distribution(on, path=tmp_path / "ratio.png")
    # the maps count them; a censored final ratio is only known to be below the threshold:
    # the cell's mean is unknown, a quantile exact at or above the threshold, unknown below
    assert int(res.maps["n_decided_early"].sum()) == early.sum()
    offm = run_study({**cfg, "early_decision": False}, out=tmp_path / "off.nc", progress=False).maps
    for inc in (45.0, 60.0):
        m_on, m_off = res.maps.sel(incline_deg=inc).squeeze(), offm.sel(incline_deg=inc).squeeze()
        if int(m_on["n_decided_early"]) == 0:
            assert float(m_on["progress_ratio_mean"]) == float(m_off["progress_ratio_mean"])
            continue
        assert np.isnan(float(m_on["progress_ratio_mean"]))
        q_on, q_off = m_on["progress_ratio_quantile"].values, m_off["progress_ratio_quantile"].values
        known = np.isfinite(q_on)
        assert np.array_equal(q_on[known], q_off[known]) and np.all(q_on[known] >= 0.5)
        assert np.all(q_off[~known] < 0.5)
