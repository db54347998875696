"""The default time step (tumblemc.model.step_size) and the ledger's field work (issue 45)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import tumblemc
from tumblemc.model.fields import Rotating, Sequence, Static
from tumblemc.model.frames import quat_to_matrix
from tumblemc.model.params import get_preset, magnetisation_dir
from tumblemc.model.rows import TimeGrid, simulate_rows
from tumblemc.model.run import run_inputs
from tumblemc.model.shapes.library import get_shape
from tumblemc.model.step_size import (
    CEILING_S,
    NEAR_FRACTION,
    STEPS_PER_PERIOD,
    STEPS_PER_PERIOD_NEAR,
    TURN_PER_STEP,
    default_step,
    natural_frequency,
)
from tumblemc.study.config import load_config
from tumblemc.study.design import batch_row, design, design_values, grid_of, run_kwargs
from tumblemc.study.stepcfg import study_dt


@pytest.mark.parametrize("preset", ["paper", "aluminum"])
@pytest.mark.parametrize("shape", ["cuboid", "spiked", "spiked_ends", "curved"])
@pytest.mark.parametrize("freq", [1.0, 10.0])
def test_the_paper_points_keep_the_papers_step(shape: str, preset: str, freq: float) -> None:
    ri = run_inputs(shape, preset, field_mT=20.0, freq_hz=freq)
    assert ri.dt == CEILING_S and ri.dt_rule.startswith("ceiling")


def test_each_rate_sets_the_step_it_needs() -> None:
    # the field's period: 1000 steps per turn at 100 Hz
    ri = run_inputs("cuboid", "paper", field=Rotating(20.0, 100.0), duration_s=0.01)
    assert ri.dt == pytest.approx(1.0 / (STEPS_PER_PERIOD * 100.0)) and ri.dt_rule.startswith("field period")
    # the natural frequency: aluminum at 100 mT, sqrt(|m||B| / I_min) against an independent eigenvalue
    p = get_preset("aluminum")
    inertia = get_shape("cuboid").inertia(p.mass)
    wn = math.sqrt(p.V_m * p.magnetization * 0.1 / min(np.linalg.eigvalsh(inertia)))
    assert natural_frequency(inertia, p.V_m * p.magnetization, 100.0) == pytest.approx(wn, rel=1e-12)
    ri = run_inputs("cuboid", "aluminum", field_mT=100.0, duration_s=0.01)
    k = math.ceil(CEILING_S * wn / TURN_PER_STEP)
    assert ri.dt == pytest.approx(CEILING_S / k) and ri.dt * wn <= TURN_PER_STEP and ri.dt_rule.startswith("natural")
    # the initial spin
    ri = run_inputs("cuboid", "paper", omega0=(0.0, 0.0, 31000.0), duration_s=0.01)
    assert ri.dt * 31000.0 <= TURN_PER_STEP < 2 * ri.dt * 31000.0 and ri.dt_rule.startswith("initial spin")
    # a whole divisor of the ceiling, the given step wins
    assert (CEILING_S / ri.dt) == pytest.approx(round(CEILING_S / ri.dt), abs=1e-9)
    given = run_inputs("cuboid", "paper", field=Rotating(20.0, 200.0), duration_s=0.01, dt=2e-5)
    assert given.dt == 2e-5 and given.dt_rule == "given"
    # a static field has no period; a field program's fastest segment counts
    assert default_step(inertia, 0.0, 0.0, [0.0]).dt == CEILING_S


def test_a_field_near_the_magnets_natural_frequency_gets_finer_steps() -> None:
    # the paper cuboid at 20 mT: natural frequency sqrt(|m||B| / I_min) / 2 pi, about 311 Hz
    p = get_preset("paper")
    inertia = get_shape("cuboid").inertia(p.mass)
    f_nat = math.sqrt(p.V_m * p.magnetization * 0.02 / min(np.linalg.eigvalsh(inertia))) / (2 * math.pi)
    assert 300.0 < f_nat < 320.0
    below = run_inputs("cuboid", "paper", field=Rotating(20.0, 0.99 * NEAR_FRACTION * f_nat), duration_s=0.01)
    above = run_inputs("cuboid", "paper", field=Rotating(20.0, 1.01 * NEAR_FRACTION * f_nat), duration_s=0.01)
    assert below.dt_rule.startswith(f"field period ({STEPS_PER_PERIOD} steps")
    assert above.dt_rule.startswith(f"field period ({STEPS_PER_PERIOD_NEAR} steps") and "natural frequency 311.1 Hz" in above.dt_rule
    assert above.dt <= 1.0 / (STEPS_PER_PERIOD_NEAR * 1.01 * NEAR_FRACTION * f_nat) < below.dt / 10
    # at 200 Hz: 16000 steps per turn, the step at which the ensemble's P(success) settles
    assert run_inputs("cuboid", "paper", field=Rotating(20.0, 200.0), duration_s=0.01).dt == 5e-5 / 160
    # a field program: each segment against the natural frequency at its own field
    fast_strong, slow_weak = Rotating(100.0, 200.0), Rotating(5.0, 80.0)  # 0.29 and 0.51 of their natural frequencies
    assert run_inputs("cuboid", "paper", field=fast_strong, duration_s=0.01).dt == 5e-6
    prog = run_inputs("cuboid", "paper", field=Sequence((0.005, fast_strong), (0.005, slow_weak)), duration_s=0.01)
    assert prog.dt == pytest.approx(1.0 / (STEPS_PER_PERIOD_NEAR * 80.0), rel=0.1) and "at 80 Hz" in prog.dt_rule
    with pytest.raises(ValueError, match="segment_mT"):
        default_step(inertia, 1.0, 20.0, [1.0, 2.0], segment_mT=[20.0])


def test_the_run_reports_its_step_rule() -> None:
    ds = tumblemc.simulate(field=Rotating(20.0, 100.0), duration_s=0.002)
    assert ds.attrs["dt"] == pytest.approx(1e-5) and "1000 steps per turn at 100 Hz" in ds.attrs["dt_rule"]


def test_each_cell_of_a_study_runs_at_its_own_step() -> None:
    cfg = load_config("studies/smoke.toml")
    assert study_dt(cfg) == CEILING_S
    assert set(design(cfg)["dt"].values) == {CEILING_S}
    fast = load_config({**_smoke_dict(), "freq_hz": [1.0, 200.0], "field_mT": [20.0, 100.0]})
    des = design(fast)
    # each cell its own default: the field period at 200 Hz, the magnet at 100 mT, the ceiling at 20 mT, 1 Hz
    for i in range(des.sizes["run"]):
        r = des.isel(run=i)
        kw = run_kwargs(fast, r)
        alone = run_inputs("cuboid", "aluminum", field_mT=float(r["field_mT"]), freq_hz=float(r["freq_hz"]), duration_s=0.01)
        assert float(r["dt"]) == kw["dt"] == alone.dt
    assert len(set(des["dt"].values)) == 3 and study_dt(fast) == min(des["dt"].values)
    # the rows the engine simulates carry that step; the check's grid divides it
    rows = [batch_row(fast, row) for row in design_values(fast, des, range(des.sizes["run"]))]
    assert [r["dt"] for r in rows] == list(des["dt"].values)
    assert grid_of(fast).refine == 1 and grid_of(fast, fine=True).refine == fast.check.dt_factor
    given = load_config({**_smoke_dict(), "freq_hz": [200.0], "dt": 2e-5})
    assert study_dt(given) == 2e-5 and set(design(given)["dt"].values) == {2e-5}
    # a threshold study searching the field: one step per robot, the strongest field's
    thr = load_config({**_smoke_dict(), "mode": "threshold", "threshold_axis": "field_mT", "field_mT": [20.0, 100.0]})
    assert set(design(thr)["dt"].values) == {study_dt(thr)} and study_dt(thr) < CEILING_S


def test_the_fine_grid_divides_each_rows_step() -> None:
    rows = [{"preset": "paper", "freq_hz": 200.0, "dt": 1e-5}, {"preset": "paper", "freq_hz": 200.0, "dt": 2e-5}]
    coarse = simulate_rows("cuboid", rows, TimeGrid(periods=0.2, transient_periods=0.1))
    fine = simulate_rows("cuboid", [{**r, "dt": r["dt"] / 4} for r in rows], TimeGrid(periods=0.2, transient_periods=0.1))
    refined = simulate_rows("cuboid", rows, TimeGrid(periods=0.2, transient_periods=0.1, refine=4))
    assert not np.array_equal(coarse["progress_ratio"], refined["progress_ratio"])
    for k in ("progress_ratio", "status", "newton_iterations"):
        np.testing.assert_array_equal(fine[k], refined[k])
    # a refined grid without a step: the row is recorded as not run, with the reason
    assert "needs a step" in simulate_rows("cuboid", [{"preset": "paper"}], TimeGrid(refine=2))["error"][0]


def _smoke_dict() -> dict:
    return {
        "name": "s",
        "shapes": ["cuboid"],
        "presets": ["aluminum"],
        "incline_deg": [0.0],
        "field_mT": 20.0,
        "freq_hz": 1.0,
        "samples": 2,
        "seed": 1,
    }


# ---- the ledger's field work, against an independent account ------------------------------

FREE_FLIGHT = {
    "preset": "aluminum",
    "field": Rotating(100.0, 200.0, axis=(1.0, 1.0, 1.0)),
    "lift_m": 0.05,
    "omega0": (3000.0, -2000.0, 1000.0),
    "duration_s": 0.02,
}


def _independent_excess(ds) -> np.ndarray:  # type: ignore[no-untyped-def]
    """E(t) - E(0) + integral m . dB from the records alone.

    The field interpolated linearly and the magnet's direction by slerp, 16 points per record interval.
    """
    eb = magnetisation_dir(float(ds.attrs["offset_deg"]), (1.0, 0.0, 0.0))
    q, B, U = ds["quaternion"].values, ds["field"].values, ds["magnetic_energy"].values
    m = quat_to_matrix(q) @ eb
    k = float(np.dot(U, -np.einsum("ij,ij->i", m, B)) / np.dot(np.einsum("ij,ij->i", m, B), np.einsum("ij,ij->i", m, B)))
    wf = np.zeros(len(q))
    s = np.linspace(0.0, 1.0, 17)
    for r in range(1, len(q)):
        q0, q1 = q[r - 1], q[r] if np.dot(q[r - 1], q[r]) >= 0 else -q[r]
        th = math.acos(min(1.0, float(np.dot(q0, q1))))
        qs = (
            np.outer(1 - s, q0) + np.outer(s, q1)
            if th < 1e-12
            else (np.outer(np.sin((1 - s) * th), q0) + np.outer(np.sin(s * th), q1)) / math.sin(th)
        )
        ms = quat_to_matrix(qs / np.linalg.norm(qs, axis=1)[:, None]) @ eb
        Bs = B[r - 1] + np.outer(s, B[r] - B[r - 1])
        wf[r] = wf[r - 1] - k * np.einsum("ij,ij->", 0.5 * (ms[1:] + ms[:-1]), np.diff(Bs, axis=0))
    e = ds["kinetic_energy"].values + U + ds["potential_energy"].values
    return e - e[0] - wf


def test_the_energy_excess_is_the_energy_above_what_the_field_supplied() -> None:
    """Free flight in a fast rotating field (no contact, no friction).

    The ledger's excess is the mechanical energy above its start minus -integral m . dB, computed independently.
    """
    ds = tumblemc.simulate(dt=5e-5 / 4, **FREE_FLIGHT)  # type: ignore[arg-type]
    mb = float(np.abs(ds["magnetic_energy"]).max())
    ind = _independent_excess(ds)
    led = ds["energy_excess"].values
    assert np.abs(led - ind).max() <= 0.02 * np.abs(ind).max() + 1e-3 * mb
    assert ds.attrs["energy_excess_J"] == pytest.approx(led.max(), rel=1e-9)
    assert float(np.abs(ds["work_field"]).max()) > 0.01 * mb  # the field did work


def test_the_excess_is_flagged_at_the_papers_step_and_not_at_a_converging_one() -> None:
    """The two reproducers of issue 45: flagged at 5e-5 s given explicitly, ok at 5e-5 / 16."""
    spin = {
        "preset": "aluminum",
        "field": Static(100.0, (0.0, 0.0, -1.0)),
        "lift_m": 0.04,
        "omega0": (6000.0, 3000.0, 1000.0),
        "duration_s": 0.08,
    }
    for kw in ({**FREE_FLIGHT, "duration_s": 0.1}, spin):
        coarse = tumblemc.simulate(dt=5e-5, **kw)  # type: ignore[arg-type]
        fine = tumblemc.simulate(dt=5e-5 / 16, record_every=16, **kw)  # type: ignore[arg-type]
        assert coarse.attrs["status"] == 4 and coarse.attrs["energy_excess_ratio"] > 0.05
        assert fine.attrs["status"] == 0 and fine.attrs["energy_excess_ratio"] < 0.01
        assert coarse.attrs["contact_gain_ratio"] < 1e-6  # no contact: the old account saw nothing


def test_a_study_whose_cells_step_differently_hashes_it_and_says_so() -> None:
    from tumblemc.study.identity import config_hash, identity_json
    from tumblemc.study.stepcfg import step_attrs

    # every shipped study: one step for all cells, the hash of before the per-cell step
    for toml in sorted(Path("studies").glob("*.toml")):
        if "design" in toml.name:
            continue
        cfg = load_config(str(toml))
        assert "dt_rule" not in identity_json(cfg) and "dt_rule" not in step_attrs(cfg), toml
    mixed = load_config({**_smoke_dict(), "freq_hz": [1.0, 200.0]})
    alike = load_config({**_smoke_dict(), "freq_hz": [1.0, 2.0]})
    assert '"dt_rule":"per cell"' in identity_json(mixed) and "dt_rule" in step_attrs(mixed)
    assert "dt_rule" not in identity_json(alike)
    given = load_config({**_smoke_dict(), "freq_hz": [1.0, 200.0], "dt": 5e-6})
    assert "dt_rule" not in identity_json(given) and config_hash(given) != config_hash(mixed)


def test_the_budget_counts_a_searched_frequencys_step() -> None:
    # a threshold study searching the frequency runs every robot at its fastest frequency's step
    base = {**_smoke_dict(), "mode": "threshold", "threshold_axis": "freq_hz", "freq_hz": [0.5, 160.0], "incline_deg": [0.0]}
    cfg = load_config(base)
    steps = round(cfg.periods / 0.5 / study_dt(cfg))  # the slow frequency at the fast one's step
    with pytest.raises(ValueError, match="steps"):
        load_config({**base, "execution": {"max_steps_per_run": steps - 1}})
    load_config({**base, "execution": {"max_steps_per_run": steps * cfg.check.dt_factor}})
