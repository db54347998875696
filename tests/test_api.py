"""Public API: validation errors, presets, Dataset schema, summarize."""

from __future__ import annotations

import math

import numpy as np
import pytest

import tumblemc
from tumblemc.params import PRESETS, Params


@pytest.mark.parametrize(
    ("kwargs", "names"),
    [
        ({"mass": -1.0}, ["mass", "-1.0"]),
        ({"mu": -0.1}, ["mu", "-0.1"]),
        ({"mu": math.nan}, ["mu", "nan"]),
        ({"adhesion_C": "lots"}, ["adhesion_C", "lots"]),
        ({"line_contact_fraction": 2.0}, ["line_contact_fraction", "[0.0, 1.0]"]),
        ({"offset_axis": (0, 0, 0)}, ["offset_axis"]),
        ({"frobnicate": 1.0}, ["frobnicate", "allowed"]),
        ({"incline_deg": 95.0}, ["incline_deg", "95.0"]),
        ({"torque": "middle"}, ["torque", "start", "end"]),
        ({"preset": "glass"}, ["preset", "glass", "paper"]),
        ({"shape": "sphere"}, ["shape", "sphere", "cuboid"]),
        ({"dt": 0.0}, ["dt"]),
    ],
)
def test_bad_input_is_a_clear_error(kwargs: dict, names: list[str]) -> None:
    with pytest.raises(ValueError) as err:
        tumblemc.simulate(duration_s=0.001, **kwargs)
    for n in names:
        assert n in str(err.value)


def test_presets_are_the_paper_tables() -> None:
    p, a = PRESETS["paper"], PRESETS["aluminum"]
    assert (p.mass, p.F_elect, p.mu, p.offset_deg, p.V_m, p.magnetization, p.adhesion_C) == (1.6071e-7, 3.2022e-6, 0.3, 27.0, 2.9e-11, 15000.0, 3.7148)
    assert (a.mass, a.F_elect, a.mu, a.offset_deg, a.V_m, a.magnetization, a.adhesion_C) == (6.94e-8, 0.0, 0.54, 0.0, 3.2e-11, 51835.0, 26.1771)
    with pytest.raises(Exception):
        p.mu = 1.0  # type: ignore[misc]


def test_magnetisation_direction_follows_model() -> None:
    e = PRESETS["paper"].magnetisation_dir()
    phi = math.radians(27.0)
    np.testing.assert_allclose(e, [0.0, math.cos(phi), math.sin(phi)], atol=1e-15)
    e2 = Params(**{**PRESETS["paper"].as_attrs(), "offset_axis": (0.0, 0.0, 1.0), "electrostatic_in_flight": True}).magnetisation_dir()
    np.testing.assert_allclose(e2, [-math.sin(phi), math.cos(phi), 0.0], atol=1e-15)


def test_dataset_schema_and_attrs() -> None:
    ds = tumblemc.simulate(duration_s=0.01, mu=0.35)
    for name in ["progress", "position", "quaternion", "velocity", "omega", "normal_force", "adhesion_force", "contact_area", "contact_mode", "slip_speed", "newton_iterations", "residual"]:
        assert name in ds, name
    for name, var in ds.data_vars.items():
        assert "units" in var.attrs and "long_name" in var.attrs, name
    assert ds["contact_mode"].dtype == np.int8
    assert ds["contact_mode"].attrs["flag_meanings"] == "none point_or_line face"
    assert ds.attrs["mu"] == 0.35 and ds.attrs["mass"] == PRESETS["paper"].mass
    assert ds.attrs["tumblemc_version"] == tumblemc.__version__
    assert ds.sizes["time"] == round(0.01 / ds.attrs["dt"]) + 1


def test_summarize_needs_a_full_window() -> None:
    ds = tumblemc.simulate(duration_s=0.5)
    with pytest.raises(ValueError, match="too short"):
        tumblemc.summarize(ds)
