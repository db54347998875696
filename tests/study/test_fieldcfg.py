"""A study's [field] table and the field axis's pointing error."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tumblemc.model.fields import Rotating
from tumblemc.study.checks import ConfigError
from tumblemc.study.config import load_config
from tumblemc.study.design import batch_row, design
from tumblemc.study.distributions import POSTERIOR_SLOT, UNCERTAIN_PARAMS, mc_slot
from tumblemc.study.engine import run_study
from tumblemc.study.fieldcfg import turned_axis
from tumblemc.study.identity import config_to_json, identity_json

BASE = {
    "name": "f",
    "shapes": ["cuboid"],
    "presets": ["paper"],
    "incline_deg": [0.0, 30.0],
    "field_mT": [20.0],
    "freq_hz": [10.0],
    "samples": 4,
    "seed": 5,
    "check": {"fraction": 0.02, "min_runs": 1, "dt_factor": 2},
    "uncertain": {"mu": {"dist": "truncnormal", "rel_sd": 0.15}},
}
ERRORS = {"axis_yaw_deg": {"dist": "normal", "sd": 5.0}, "axis_pitch_deg": {"dist": "normal", "sd": 3.0}}


def test_default_field_keeps_every_earlier_config_identity() -> None:
    assert '"field"' not in identity_json(load_config(BASE))
    cfg = load_config({**BASE, "field": {"kind": "rotating", "axis": [0, 1, 0]}})
    assert '"field"' in identity_json(cfg)
    assert load_config(__import__("json").loads(config_to_json(cfg))).field == cfg.field  # JSON round trip


@pytest.mark.parametrize(
    "table, match",
    [
        ({"kind": "static"}, "field.kind='static'"),
        ({"kind": "rotating", "axis": [1, 0]}, "field.axis=\\[1, 0\\] is not allowed"),
        ({"kind": "rotating", "axis": [0, 0, 0]}, "nonzero direction"),
        ({"axis": [0, 1, 0]}, "needs field.kind = 'rotating'"),
        ({"kind": "rotating", "axis": [0, 1, 0], "start": [0, 2, 0]}, "parallel to axis"),
        ({"kind": "rotating", "cone": 3}, "field"),
    ],
)
def test_bad_field_tables(table, match) -> None:
    with pytest.raises(ConfigError, match=match):
        load_config({**BASE, "field": table})


def test_turned_axis() -> None:
    np.testing.assert_allclose(turned_axis((1, 0, 0), 90.0, 0.0), (0, 1, 0), atol=1e-15)
    a = turned_axis((1, 0, 0), 0.0, 10.0)  # tilted about x cross z = -y: x rises toward +z
    np.testing.assert_allclose(a, (math.cos(math.radians(10)), 0.0, math.sin(math.radians(10))), atol=1e-15)
    assert turned_axis((0, 0, 1), 30.0, 20.0) == pytest.approx((0.0, 0.0, 1.0))


def test_axis_errors_are_run_keyed_and_leave_other_draws_alone() -> None:
    plain = design(load_config(BASE))
    cfg = load_config({**BASE, "field": {"kind": "rotating"}, "uncertain": {**BASE["uncertain"], **ERRORS}})
    des = design(cfg)
    np.testing.assert_array_equal(plain["mu"].values, des["mu"].values)
    assert des["axis_yaw_deg"].std() > 1.0 and des["axis_pitch_deg"].std() > 0.5
    row = batch_row(cfg, des.isel(run=3))
    prog = row["field"]
    assert isinstance(prog, Rotating) and "field_mT" not in row
    want = turned_axis((1, 0, 0), float(des["axis_yaw_deg"][3]), float(des["axis_pitch_deg"][3]))
    np.testing.assert_allclose(prog.axis, want, atol=1e-12)
    # the new parameters' slots skip the posterior's, which stays where it was
    assert POSTERIOR_SLOT == 15 and mc_slot("peel_length") == 14 and mc_slot("axis_yaw_deg") == 16
    assert len({mc_slot(p) for p in UNCERTAIN_PARAMS} | {POSTERIOR_SLOT}) == len(UNCERTAIN_PARAMS) + 1


def test_rotating_program_study_matches_the_paper_field(tmp_path) -> None:
    # the paper's field written as a program (start = uphill) gives the same verdicts
    base = {**BASE, "incline_deg": [0.0]}
    a = run_study(base, out=tmp_path / "a.nc", progress=False)
    b = run_study({**base, "field": {"kind": "rotating", "start": [0.0, -1.0, 0.0]}}, out=tmp_path / "b.nc", progress=False)
    np.testing.assert_array_equal(a.runs["climbed"].values, b.runs["climbed"].values)
    np.testing.assert_allclose(a.runs["progress_ratio"].values, b.runs["progress_ratio"].values, rtol=1e-6)
