"""Public API: validation errors, presets, Dataset schema, summarize."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import xarray as xr

import tumblemc
from tumblemc.model.params import PRESETS, Params


@pytest.mark.parametrize(
    ("kwargs", "names"),
    [
        ({"mass": -1.0}, ["mass", "-1.0"]),
        ({"mu": -0.1}, ["mu", "-0.1"]),
        ({"mu": math.nan}, ["mu", "nan"]),
        ({"adhesion_C": "lots"}, ["adhesion_C", "lots"]),
        ({"line_contact_fraction": 2.0}, ["line_contact_fraction", "[0, 1]"]),
        ({"offset_axis": (0, 0, 0)}, ["offset_axis"]),
        ({"frobnicate": 1.0}, ["frobnicate", "allowed"]),
        ({"incline_deg": 95.0}, ["incline_deg", "95.0", "[-89, 89]"]),
        ({"freq_hz": -1.0}, ["freq_hz", "-1.0", "[0, 10000]"]),
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
    assert (p.mass, p.F_elect, p.mu, p.offset_deg, p.V_m, p.magnetization, p.adhesion_C) == (
        1.6071e-7,
        3.2022e-6,
        0.3,
        27.0,
        2.9e-11,
        15000.0,
        3.7148,
    )
    assert (a.mass, a.F_elect, a.mu, a.offset_deg, a.V_m, a.magnetization, a.adhesion_C) == (
        6.94e-8,
        0.0,
        0.54,
        0.0,
        3.2e-11,
        51835.0,
        26.1771,
    )
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.mu = 1.0  # type: ignore[misc]


def test_magnetisation_direction_follows_model() -> None:
    e = PRESETS["paper"].magnetisation_dir()
    phi = math.radians(27.0)
    np.testing.assert_allclose(e, [0.0, math.cos(phi), math.sin(phi)], atol=1e-15)
    e2 = Params(**{**PRESETS["paper"].as_attrs(), "offset_axis": (0.0, 0.0, 1.0), "electrostatic_in_flight": True}).magnetisation_dir()
    np.testing.assert_allclose(e2, [-math.sin(phi), math.cos(phi), 0.0], atol=1e-15)


def test_dataset_schema_and_attrs() -> None:
    ds = tumblemc.simulate(duration_s=0.01, mu=0.35)
    for name in [
        "progress",
        "position",
        "quaternion",
        "velocity",
        "omega",
        "normal_force",
        "adhesion_force",
        "contact_area",
        "contact_mode",
        "slip_speed",
        "newton_iterations",
        "residual",
    ]:
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


@pytest.mark.parametrize(
    ("kwargs", "names"),
    [
        ({"record_every": 2.5}, ["record_every", "integer"]),
        ({"v0": "abc"}, ["v0"]),
        ({"shape": ["cuboid"]}, ["shape"]),
        ({"duration_s": 1e4, "dt": 1e-9}, ["duration_s", "record_every", "GiB"]),
        ({"mass": True}, ["mass"]),
    ],
)
def test_more_bad_input(kwargs: dict, names: list[str]) -> None:
    with pytest.raises(ValueError) as err:
        tumblemc.simulate(**{"duration_s": 0.001, **kwargs})
    for n in names:
        assert n in str(err.value)


def test_solver_options_need_integers() -> None:
    with pytest.raises(ValueError, match="max_iter"):
        tumblemc.SolverOptions(max_iter=2.5)  # type: ignore[arg-type]


@pytest.mark.parametrize("value", [-1e-6, math.nan, 2.0, 1e-12])
def test_solver_options_reject_bad_accept_tol(value: float) -> None:
    with pytest.raises(ValueError, match="accept_tol"):
        tumblemc.SolverOptions(accept_tol=value)


def test_summarize_rejects_bad_arguments() -> None:
    ds = tumblemc.simulate(duration_s=2.0, dt=5e-4)
    for kw in ({"transient_periods": math.nan}, {"transient_periods": -1.0}, {"min_window_periods": -1.0}, {"threshold": math.inf}):
        with pytest.raises(ValueError, match=next(iter(kw))):
            tumblemc.summarize(ds, **kw)


def _synthetic(speed: float, freq: float = 2.0, dt: float = 1e-3, duration: float = 2.0) -> xr.Dataset:
    import xarray as xr

    t = np.arange(round(duration / dt) + 1) * dt
    prog = np.where(t < 0.3, -1e-4, -1e-4 + speed * (t - 0.3))  # a transient, then steady
    n = len(t)
    ds = xr.Dataset(
        {
            "progress": ("time", prog),
            "penetration": ("time", np.zeros(n)),
            "failed": ("time", np.zeros(n, np.int32)),
            "newton_iterations": ("time", np.r_[0, np.full(n - 1, 2)]),
            "slip_speed": ("time", np.full(n, 3e-5)),
            "substeps": ("time", np.zeros(n, np.int32)),
            "fallbacks": ("time", np.zeros(n, np.int32)),
        },
        coords={"time": t},
    )
    ds.attrs.update(freq_hz=freq, ideal_speed=1.8e-3 * freq, n_steps=n - 1, status=0, failed_steps=0, dt=dt)
    return ds


def test_summarize_arithmetic_on_a_known_series() -> None:
    speed = 2.7e-3
    s = tumblemc.summarize(_synthetic(speed), transient_periods=1.0)  # window starts at 0.5 s
    assert s["mean_speed"] == pytest.approx(speed, rel=1e-12)
    assert s["ideal_speed"] == pytest.approx(3.6e-3)
    assert s["progress_ratio"] == pytest.approx(0.75, rel=1e-12)
    assert s["climbed"] is True
    assert tumblemc.summarize(_synthetic(speed), threshold=0.8)["climbed"] is False
    assert s["mean_newton_iterations"] == pytest.approx(2.0)
    # a window that includes the transient sees a lower speed
    assert tumblemc.summarize(_synthetic(speed), transient_periods=0.0)["mean_speed"] < speed


def test_failed_run_has_no_verdict() -> None:
    ds = _synthetic(2.7e-3)
    ds.attrs["kernel_status"] = 3  # the time loop stopped on a non-finite state (ST_NAN)
    s = tumblemc.summarize(ds)
    assert math.isnan(s["progress_ratio"]) and s["climbed"] is False and s["status"] == 2  # nonfinite


def test_last_step_is_always_recorded() -> None:
    ds = tumblemc.simulate(duration_s=0.0101, dt=1e-4, record_every=4)
    assert ds["time"].values[-1] == pytest.approx(0.0101, abs=1e-15)
    full = tumblemc.simulate(duration_s=0.0101, dt=1e-4)
    assert int(ds["newton_iterations"].sum()) == int(full["newton_iterations"].sum())
    assert float(ds["penetration"].max()) == float(full["penetration"].max())
    np.testing.assert_array_equal(ds["position"].values[-1], full["position"].values[-1])


def test_field_direction_convention() -> None:
    from tumblemc.kernels import layout as L
    from tumblemc.kernels.field import field_dir
    from tumblemc.model.frames import plane_frame
    from tumblemc.model.run import prepare, run_inputs

    spec = prepare(run_inputs(incline_deg=30.0, freq_hz=2.0, duration_s=0.001))
    fr = plane_frame(30.0)
    out = np.zeros(3)
    field_dir(spec.prm, 0.0, out)
    np.testing.assert_allclose(out, fr["u"], atol=1e-15)  # along the uphill direction at t=0
    quarter = 0.25 / spec.prm[L.P_FREQ]
    field_dir(spec.prm, quarter, out)
    np.testing.assert_allclose(out, -fr["n"], atol=1e-12)  # toward -n a quarter period later


def test_positive_offset_first_tips_backwards_then_climbs() -> None:
    ds = tumblemc.simulate(preset="paper", duration_s=2.0, dt=1e-4)
    assert ds["omega"].values[1:20, 0].max() < 0.0  # rotation against the tumbling sense
    assert ds["progress"].values[50] < 0.0
    assert tumblemc.summarize(ds)["climbed"]


def test_torque_at_end_of_step_runs_and_tracks_no_slip() -> None:
    s = tumblemc.summarize(tumblemc.simulate(preset="paper", duration_s=2.0, dt=1e-4, torque="end"))
    assert s["failed_steps"] == 0
    assert s["progress_ratio"] == pytest.approx(1.0, abs=0.02)


def test_contact_state_classification() -> None:
    from tumblemc.kernels.contact import contact_state
    from tumblemc.kernels.geometry import N_CG, N_QS
    from tumblemc.kernels.layout import N_SC
    from tumblemc.kernels.runtypes import Scratch
    from tumblemc.model.run import prepare, run_inputs
    from tumblemc.model.shapes.library import cuboid

    spec = prepare(run_inputs(duration_s=0.001, line_contact_fraction=0.1, line_adhesion="face_fraction"))
    geo, prm = spec.geo, spec.prm
    shp = cuboid()
    areas = np.array([c.area for c in shp.pieces[0].constraints]) / 1e-8  # scaled
    z = np.zeros(24)
    z[23] = 1.0  # lam_n > 0
    state = np.zeros(13)  # at the origin, at rest
    scr = Scratch(
        sc=np.zeros(N_SC), R=np.zeros(9), tmp=np.zeros(3), tmp2=np.zeros(3), tmp3=np.zeros(3),
        cg=np.zeros(N_CG), qs=np.zeros(N_QS), iters=np.zeros(3, np.int64), prob=None, prob6=None, hts=np.zeros(8),
    )  # fmt: skip
    z[16 + 4] = 1.0  # +z face alone: face contact with its area
    mode, area, *_ = contact_state(z, state, prm, geo, scr)
    assert mode == 2 and area == pytest.approx(areas[4])
    z[16 + 2] = 0.7  # +y end too: an edge, line contact with fraction x smaller area
    mode, area, *_ = contact_state(z, state, prm, geo, scr)
    assert mode == 1 and area == pytest.approx(0.1 * min(areas[4], areas[2]))
    # the strip rule (default): 5 um x the 400 um edge the two faces share, scaled by 1e-8 m^2
    strip = prepare(run_inputs(duration_s=0.001))
    mode, area, *_ = contact_state(z, state, strip.prm, strip.geo, scr)
    assert mode == 1 and area == pytest.approx(5e-6 * 400e-6 / 1e-8, rel=1e-12)
    z[16 + 0] = 0.5  # +x side too: a vertex, w^2
    mode, area, *_ = contact_state(z, state, strip.prm, strip.geo, scr)
    assert mode == 1 and area == pytest.approx((5e-6) ** 2 / 1e-8, rel=1e-12)
    z[16 + 0] = 0.0
    z[23] = 0.0  # no normal force: no contact
    mode, area, *_ = contact_state(z, state, prm, geo, scr)
    assert mode == 0 and area == 0.0


def test_public_api() -> None:
    """The package's public names: one run, studies, shapes and presets."""
    import tumblemc

    for name in ("simulate", "summarize", "run_study", "load_config", "open_result", "shapes", "PRESETS", "SHAPES", "Params"):
        assert name in tumblemc.__all__ and getattr(tumblemc, name) is not None
    assert callable(tumblemc.shapes.extruded)


def test_documented_submodules_are_attributes_imported_on_first_use() -> None:
    """``tumblemc.lab``, ``tumblemc.fields``, ... after ``import tumblemc`` alone, without matplotlib or dask loaded."""
    import subprocess
    import sys

    code = (
        "import sys, tumblemc\n"
        "heavy = [m for m in ('matplotlib', 'dask', 'distributed') if m in sys.modules]\n"
        "assert not heavy, heavy\n"
        "for name, mod in tumblemc.SUBMODULES.items():\n"
        "    assert getattr(tumblemc, name) is sys.modules[mod], name\n"
        "    assert name in dir(tumblemc)\n"
        "assert tumblemc.fields.Rotating is tumblemc.model.fields.Rotating\n"
        "assert callable(tumblemc.lab.static_tilt)\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
