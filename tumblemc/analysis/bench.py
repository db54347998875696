"""Measurements on bench-test runs (:mod:`tumblemc.lab`): tilt, equilibria, phase lag, turns followed, and the closed form.

Pure functions of run Datasets and parameters (nothing here simulates); ``docs/lab.md``
derives the closed-form edge balance and explains the detection.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np
import xarray as xr

from tumblemc.model.frames import plane_frame, quat_to_matrix
from tumblemc.model.params import get_preset
from tumblemc.model.shapes.library import get_shape

TILT_SKIP_S = 0.1  # the first lift-off is left out of the detection
LIFT_DEG = 0.5  # a robot that never tilts more than this stayed flat (held by adhesion)


def tilt_deg(ds: xr.Dataset) -> np.ndarray:
    """Tilt (degrees) of the body's bottom face: the angle between body z and ``-n`` (MODEL.md frames)."""
    n = plane_frame(float(ds.attrs["incline_deg"]))["n"]
    bz = quat_to_matrix(ds["quaternion"].values)[:, :, 2]
    return np.degrees(np.arccos(np.clip(-(bz @ n), -1.0, 1.0)))


def equilibrium_tilts(ds: xr.Dataset, skip_s: float = TILT_SKIP_S) -> np.ndarray:
    """Tilts (deg) at which the tilt's acceleration changes sign during a smooth pivot.

    Interpolated linearly between the two records around each sign change; only records
    in line contact with line contact at both neighbours (no impact, no flight), after
    ``skip_s`` and above :data:`LIFT_DEG`, count.
    """
    t = ds["time"].values
    th = tilt_deg(ds)
    acc = np.gradient(np.gradient(th, t), t)
    line = ds["contact_mode"].values == 1
    smooth = line.copy()
    smooth[1:] &= line[:-1]
    smooth[:-1] &= line[1:]
    ok = smooth[:-1] & smooth[1:] & (t[:-1] > skip_s) & (th[:-1] > LIFT_DEG)
    i = np.nonzero(ok & (np.sign(acc[:-1]) != np.sign(acc[1:])) & (acc[:-1] != acc[1:]))[0]
    return th[i] + (th[i + 1] - th[i]) * acc[i] / (acc[i] - acc[i + 1])


@functools.cache
def _cuboid_lwh() -> tuple[float, float, float]:
    """Length, width, height (m) of the library's cuboid (x W, y L, z H), built once: the balance is called per data point."""
    w, l_, h = np.ptp(get_shape("cuboid").pieces[0].support_points, axis=0)
    return float(l_), float(w), float(h)


def cuboid_tilt_balance(field_mT: float, preset: str = "paper", **overrides: Any) -> float:
    """Closed-form equilibrium tilt (deg) of the paper's cuboid under a field straight down (``-n``).

    Flat until ``V_m|E||B| cos(phi) = (m g + F_elect + C L W) L / 2`` (face adhesion); then
    the root in ``(0, 90 deg - phi)`` of
    ``V_m|E||B| cos(theta + phi) = (m g + F_elect + lambda_line) (L/2 cos theta - H/2 sin theta)``
    with ``lambda_line = C w W`` (strip rule) or ``line_contact_fraction x W H`` (the authors'
    rule); docs/lab.md derives it. ``phi`` is the offset about the width axis. Where the
    torque still wins when the centre of mass is above the edge (``theta = atan(L/H)``),
    the robot topples and that tilt is returned.
    """
    from scipy.optimize import brentq

    p = get_preset(preset).replace(**overrides) if overrides else get_preset(preset)
    L, W, H = _cuboid_lwh()
    phi = math.radians(p.offset_deg)
    torque = p.V_m * p.magnetization * field_mT * 1e-3
    load = p.mass * p.g + p.F_elect
    lam_line = p.adhesion_C * (p.line_contact_width * W if p.line_adhesion == "strip" else p.line_contact_fraction * W * H)
    if torque * math.cos(phi) <= (load + p.adhesion_C * L * W) * L / 2:
        return 0.0

    def net(th: float) -> float:
        return torque * math.cos(th + phi) - (load + lam_line) * (L / 2 * math.cos(th) - H / 2 * math.sin(th))

    # the edge balance holds up to the tilt where the centre of mass passes over the edge
    # (atan(L/H)); a field strong enough to hold the robot there topples it: that tilt
    top = min(math.pi / 2 - phi, math.atan2(L, H))
    if net(top) > 0.0:
        return math.degrees(top)
    return math.degrees(brentq(net, 0.0, top, xtol=1e-12))


def _plane_angles(ds: xr.Dataset, t0: float) -> tuple[np.ndarray, np.ndarray]:
    """Unwrapped angles (rad) of the magnetisation and of the field in the world y-z plane after ``t0``."""
    from tumblemc.model.params import magnetisation_dir

    e_b = magnetisation_dir(float(ds.attrs["offset_deg"]), ds.attrs.get("offset_axis", (1.0, 0.0, 0.0)))
    m = quat_to_matrix(ds["quaternion"].values) @ e_b
    b = ds["field"].values
    keep = ds["time"].values >= t0
    return np.unwrap(np.arctan2(m[keep, 2], m[keep, 1])), np.unwrap(np.arctan2(b[keep, 2], b[keep, 1]))


def phase_lag_deg(ds: xr.Dataset, t0: float) -> float:
    """Mean angle (deg, in (-180, 180]) by which the magnetisation trails the field in the rotation plane, after ``t0``.

    The paper's field rotates about world x; both vectors are projected onto the y-z plane.
    """
    ang_m, ang_b = _plane_angles(ds, t0)
    lag = float(np.degrees(np.mean(ang_b - ang_m)))
    return (lag + 180.0) % 360.0 - 180.0


def following_share(ds: xr.Dataset, t0: float) -> float:
    """The share of the field's turns the magnetisation made after ``t0`` (1: it follows; 0: it stopped).

    Angles in the plane normal to world x (the paper's field), unwrapped; a robot that
    follows lags by a bounded angle, one that stepped out loses whole turns.
    """
    turn_m, turn_b = _plane_angles(ds, t0)
    field_turn = turn_b[-1] - turn_b[0]
    return float((turn_m[-1] - turn_m[0]) / field_turn) if field_turn else math.nan


__all__ = ["LIFT_DEG", "TILT_SKIP_S", "cuboid_tilt_balance", "equilibrium_tilts", "following_share", "phase_lag_deg", "tilt_deg"]
