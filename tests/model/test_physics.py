"""Closed-form physics: rest, sliding, sticking, free fall, energy."""

from __future__ import annotations

import math

import numpy as np
import pytest

import tumblemc
from tumblemc.model.frames import plane_frame

G = 9.81
PAPER = tumblemc.PRESETS["paper"]
FACE_AREA = 0.8e-3 * 0.4e-3  # L W, the face the robot lies on
REST_DRIFT_M = 1e-9
SLIDE_REL_TOL = 0.01


def test_block_at_rest_stays_put() -> None:
    ds = tumblemc.simulate(preset="paper", field_mT=0.0, duration_s=1.0)
    drift = np.abs(ds["position"].values - ds["position"].values[0]).max()
    assert drift < REST_DRIFT_M
    assert int(ds["failed"].sum()) == 0
    assert (ds["contact_mode"].values[1:] == 2).all()
    # lying on its L x W face: adhesion C L W and the weight plus pressing forces
    np.testing.assert_allclose(ds["adhesion_force"].values[1:], PAPER.adhesion_C * FACE_AREA, rtol=1e-12)
    np.testing.assert_allclose(ds["normal_force"].values[2:], PAPER.mass * G + PAPER.F_elect + PAPER.adhesion_C * FACE_AREA, rtol=1e-9)


@pytest.mark.parametrize(
    ("incline_deg", "adhesion_C", "F_elect"),
    [(30.0, 0.0, 0.0), (80.0, PAPER.adhesion_C, PAPER.F_elect), (70.0, 2.0, 1e-6)],
)
def test_sliding_block_matches_analytic_acceleration(incline_deg: float, adhesion_C: float, F_elect: float) -> None:
    th = math.radians(incline_deg)
    m = PAPER.mass
    a = G * math.sin(th) - PAPER.mu * (G * math.cos(th) + (F_elect + adhesion_C * FACE_AREA) / m)
    assert a > 0
    ds = tumblemc.simulate(preset="paper", incline_deg=incline_deg, field_mT=0.0, duration_s=0.2, adhesion_C=adhesion_C, F_elect=F_elect)
    t = ds["time"].values
    down = -ds["progress"].values
    v = -(ds["velocity"].values @ plane_frame(incline_deg)["u"])
    # the velocity-level Euler step integrates a constant acceleration exactly in v
    fit = np.polyfit(t[10:], v[10:], 1)[0]
    assert fit == pytest.approx(a, rel=SLIDE_REL_TOL)
    assert down[-1] == pytest.approx(0.5 * a * t[-1] ** 2, rel=SLIDE_REL_TOL)
    assert int(ds["failed"].sum()) == 0
    assert float(ds["penetration"].max()) < 1e-12


@pytest.mark.parametrize("incline_deg", [10.0, 15.0])
def test_block_below_friction_angle_sticks(incline_deg: float) -> None:
    # mu = 0.3 -> friction angle 16.7 deg even without adhesion
    ds = tumblemc.simulate(preset="paper", incline_deg=incline_deg, field_mT=0.0, duration_s=0.5, adhesion_C=0.0, F_elect=0.0)
    assert np.abs(ds["progress"].values).max() < REST_DRIFT_M


def test_free_fall_matches_closed_form() -> None:
    dt = 1e-4
    lift = 1e-3
    ds = tumblemc.simulate(preset="paper", field_mT=0.0, duration_s=0.01, dt=dt, lift_m=lift, F_elect=0.0)
    z = ds["position"].values[:, 2]
    t = ds["time"].values
    k = np.arange(len(t))
    # exact solution of the discrete scheme (v first, then x += h v): -g h^2 k (k + 1) / 2
    np.testing.assert_allclose(z - z[0], -G * dt**2 * k * (k + 1) / 2, rtol=1e-9, atol=1e-15)
    # and g t^2 / 2 to first order in h
    assert np.all(np.abs((z[0] - z) - 0.5 * G * t**2) <= G * dt * t + 1e-15)
    assert (ds["contact_mode"].values == 0).all()


def _energy(ds, shape_ipm: np.ndarray) -> np.ndarray:  # type: ignore[no-untyped-def]
    from tumblemc.model.frames import quat_to_matrix

    m = float(ds.attrs["mass"])
    v = ds["velocity"].values
    w = ds["omega"].values
    R = quat_to_matrix(ds["quaternion"].values)
    Iw = np.einsum("tij,jk,tlk->til", R, m * shape_ipm, R)
    rot = 0.5 * np.einsum("ti,tij,tj->t", w, Iw, w)
    return 0.5 * m * (v**2).sum(-1) + rot + m * G * ds["position"].values[:, 2]


def test_no_energy_gain_with_field_off() -> None:
    from tumblemc.model.shapes.library import cuboid

    ds = tumblemc.simulate(
        preset="paper",
        field_mT=0.0,
        duration_s=0.1,
        lift_m=2e-4,
        v0=(0.0, 5e-3, 0.0),
        omega0=(30.0, 5.0, 10.0),
        F_elect=0.0,
        adhesion_C=0.0,
    )
    e = _energy(ds, cuboid().inertia_per_mass)
    gain = np.diff(e).max()
    assert gain <= 1e-9 * abs(e[0])
    assert e[-1] < e[0]
    assert int(ds["failed"].sum()) == 0
