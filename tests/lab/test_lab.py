"""Bench-test protocols (tumblemc.lab): the static tilt against its closed form, steering, sweeps."""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr

from tumblemc import lab
from tumblemc.cli import main
from tumblemc.model.params import get_preset
from tumblemc.model.shapes.types import ALUMINUM_ROBOT_LWH_M


def test_closed_form_balance_by_hand() -> None:
    # lift-off where V_m|E||B| cos(phi) = (m g + F_elect + C L W) L/2, about 6.2 mT
    p = get_preset("paper")
    L, W, H = ALUMINUM_ROBOT_LWH_M  # the paper's cuboid (MODEL.md), independent of the shape library
    phi = math.radians(p.offset_deg)
    b_lift = (p.mass * p.g + p.F_elect + p.adhesion_C * L * W) * L / 2 / (p.V_m * p.magnetization * math.cos(phi)) * 1e3
    assert 6.1 < b_lift < 6.25
    assert lab.cuboid_tilt_balance(b_lift * 0.999) == 0.0
    assert lab.cuboid_tilt_balance(b_lift * 1.001) > 20.0  # it snaps to the edge balance
    # the root balances the torques about the edge (strip rule: lambda_line = C w W)
    th = math.radians(lab.cuboid_tilt_balance(10.0))
    load = p.mass * p.g + p.F_elect + p.adhesion_C * p.line_contact_width * W
    mag = p.V_m * p.magnetization * 10e-3 * math.cos(th + phi)
    assert mag == pytest.approx(load * (L / 2 * math.cos(th) - H / 2 * math.sin(th)), rel=1e-9)


def test_static_tilt_matches_the_closed_form_from_3_to_15_mT() -> None:
    ds = lab.static_tilt(np.arange(3.0, 15.5, 1.0))
    err = np.abs(ds["tilt_deg"] - ds["tilt_closed_form_deg"]).values
    assert np.all(err <= 0.5), err
    assert np.all(ds["status"].values == 0)
    lifted = ds["field_mT"].values > 6.2
    assert np.all(ds["tilt_deg"].values[~lifted] == 0.0)
    assert np.all(ds["n_equilibria"].values[lifted] >= 20)
    assert ds["tilt_deg"].attrs["units"] == "degree" and ds["field_mT"].attrs["units"] == "mT"


def test_equilibrium_detection_on_a_pendulum() -> None:
    # a synthetic rocking about 30 deg: the acceleration changes sign at the centre
    t = np.linspace(0.0, 1.0, 20001)
    th = 30.0 + 20.0 * np.sin(2 * np.pi * 7.0 * t)
    q = np.zeros((len(t), 4))
    half = np.radians(th) / 2  # rotation about world x: body z tilts away from -n
    q[:, 0], q[:, 1] = np.cos(half), np.sin(half)
    # body z starts along -z (MODEL.md): compose with a half turn about x
    q = np.stack([-q[:, 1], q[:, 0], np.zeros_like(t), np.zeros_like(t)], -1)
    ds = xr.Dataset(
        {"quaternion": (("time", "quat"), q), "contact_mode": ("time", np.ones(len(t), np.int8))},
        coords={"time": t},
        attrs={"incline_deg": 0.0},
    )
    np.testing.assert_allclose(lab.tilt_deg(ds), th, atol=1e-9)
    eq = lab.equilibrium_tilts(ds)
    assert eq.size >= 12
    np.testing.assert_allclose(eq, 30.0, atol=0.01)


@pytest.mark.parametrize("preset", ["paper", "aluminum"])
def test_steering_turns_the_heading_by_90_deg(preset: str) -> None:
    ds = lab.steering(preset)
    assert int(ds["failed_steps"]) == 0 and int(ds["status"]) == 0
    assert float(ds["field_jump_deg"]) < 1e-6
    assert abs(abs(float(ds["turn_deg"])) - 90.0) <= 3.0, float(ds["turn_deg"])
    assert float(ds["max_height"]) < 1e-3  # no hop: the field turns without a jump


def test_step_out_agrees_with_an_independent_bisection() -> None:
    # paper robot, 20 mT: it follows to about 238 Hz (docs/guide/lab.md)
    so = lab.step_out([1.0, 10.0, 100.0, 200.0, 230.0, 260.0, 300.0])
    assert np.all(so["status"].values == 0)
    assert so["progress_ratio"].values[0] == pytest.approx(1.0, abs=0.05)
    assert np.all(np.abs(so["phase_lag_deg"].values) < 180.0)
    share = so["following_share"].values
    assert np.all(share[:5] > 0.5) and np.all(share[5:] < 0.5)
    alone = lab.step_out_bisect(20.0, 300.0)
    assert 230.0 < float(so["step_out_hz"]) < 260.0
    assert abs(alone - float(so["step_out_hz"])) <= 0.02 * alone


def test_critical_field() -> None:
    cf = lab.critical_field(1.0, 0.0, lo_mT=1.0, hi_mT=20.0, tol_mT=0.5)
    c = float(cf["critical_mT"])
    assert 1.0 < c < 20.0 and np.diff(cf["bracket_mT"].values)[0] <= 0.5
    # to tumble it must lift off its face: even with the field normal to the magnetisation
    # (the largest torque, |m||B|) that needs (m g + F_elect + C L W) L/2 about the edge
    p = get_preset("paper")
    L, W, _ = ALUMINUM_ROBOT_LWH_M
    bound = (p.mass * p.g + p.F_elect + p.adhesion_C * L * W) * L / 2 / (p.V_m * p.magnetization) * 1e3
    assert bound < c < bound + 1.0


def test_cli_lab(tmp_path, capsys) -> None:
    out = tmp_path / "tilt.nc"
    assert main(["lab", "static-tilt", "--field-mT", "5,8", "--duration-s", "0.3", "--out", str(out), "--plot"]) == 0
    ds = xr.open_dataset(out)
    assert ds.attrs["protocol"] == "static_tilt" and ds.sizes["field_mT"] == 2
    ds.close()
    assert (tmp_path / "tilt.png").exists()
    assert main(["lab", "static-tilt", "--field-mT", "3:x:1"]) == 2
    assert "--field-mT='3:x:1' is not allowed" in capsys.readouterr().err
    assert main(["lab", "steer", "--set", "mu=-1"]) == 2


def test_critical_field_per_posterior_draw(tmp_path) -> None:
    path = tmp_path / "post.nc"
    xr.Dataset({"F_elect": ("sample", [1e-6, 6e-6, 3e-6]), "note": ("x", [0.0])}).to_netcdf(path)
    draws = lab.posterior_samples(str(path), 2)
    assert draws == [{"F_elect": 1e-6}, {"F_elect": 6e-6}]
    res = lab.critical_field_samples(draws, 1.0, 0.0, lo_mT=1.0, hi_mT=20.0, tol_mT=0.5)
    c = res["critical_mT"].values
    assert res.sizes["sample"] == 2 and np.all(np.isfinite(c))
    assert c[1] > c[0]  # a heavier electrostatic load needs a stronger field
    np.testing.assert_array_equal(res["F_elect"].values, [1e-6, 6e-6])


def test_lab_figures(tmp_path) -> None:
    from tumblemc.viz.lab import plot_lab

    cf = lab.critical_field(1.0, 0.0, lo_mT=1.0, hi_mT=20.0, tol_mT=2.0)
    assert cf.sizes["trial"] == int(cf["n_runs"]) and bool(cf["tumbled"].values[1])
    for ds, name in ((cf, "cf.png"), (lab.steering("paper", freq_hz=2.75), "steer.png")):
        assert plot_lab(ds, tmp_path / name) is not None
        assert (tmp_path / name).stat().st_size > 10_000
