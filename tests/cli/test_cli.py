"""Command line (``tumblemc.cli``) and run figures (``tumblemc.plotting``)."""

from __future__ import annotations

import argparse
import os
import sys
import types
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from matplotlib.figure import Figure

import tumblemc
from tumblemc.cli import SUMMARY_UNITS, format_table, main, parse_overrides, parse_value
from tumblemc.io import netcdf_ready
from tumblemc.model.shapes.library import get_shape
from tumblemc.viz.run import plot_run, side_view_outline, strip_offsets

SHORT = "0.05"


@pytest.fixture(scope="module")
def short_run() -> xr.Dataset:
    return tumblemc.simulate(duration_s=float(SHORT))


def test_simulate_writes_netcdf_and_png(tmp_path, capsys):
    out = tmp_path / "run.nc"
    sets = ["--set", "mu=0.35", "--set", "electrostatic_in_flight=false"]
    rc = main(["simulate", "--duration-s", SHORT, "--out", str(out), "--plot", *sets])
    captured = capsys.readouterr()
    assert rc == 0, captured.err
    assert "wrote" in captured.out and "status" in captured.out
    with xr.open_dataset(out, engine="netcdf4") as ds:
        assert ds.sizes["time"] == round(float(SHORT) / float(ds.attrs["dt"])) + 1
        for name in ds.data_vars:
            assert ds[name].attrs.get("units"), name
            assert ds[name].attrs.get("long_name"), name
        assert float(ds.attrs["mu"]) == pytest.approx(0.35)
        assert int(ds.attrs["electrostatic_in_flight"]) == 0
        assert np.asarray(ds.attrs["offset_axis"]).shape == (3,)
        assert ds.attrs["torque"] == "start"
        # labels along a dimension: xarray selects by them; on disk char arrays named in `coordinates`
        assert ds["position"].sel(xyz="z").dims == ("time",) and ds["quaternion"].sel(quat="w").dims == ("time",)
        assert "xyz" in ds["position"].encoding["coordinates"].split() and ds["xyz"].encoding["dtype"] == "S1"
        # CF 4.4: standard_name time needs units with a reference date, which a run's time has not
        assert "standard_name" not in ds["time"].attrs and ds["time"].attrs["units"] == "s"
        assert ds["xyz"].attrs["long_name"] and ds["quat"].attrs["long_name"]
    png = out.with_suffix(".png")
    assert png.stat().st_size > 10_000
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_simulate_with_the_step_check_says_its_class_and_keeps_it(tmp_path, capsys):
    out = tmp_path / "run.nc"
    rc = main(["simulate", "--freq-hz", "2", "--duration-s", "1.5", "--check", "--check-twins", "2", "--out", str(out)])
    captured = capsys.readouterr()
    assert rc == 0, captured.err
    assert "step check: within tolerance. Progress ratio" in captured.out
    assert captured.err.count("step check: ") == 4  # the run, dt / 4 and two twins, as each finishes
    with xr.open_dataset(out, engine="netcdf4") as ds:
        assert ds.attrs["step_check_class"] == "within tolerance"
        assert float(ds.attrs["step_check_fine_dt"]) == pytest.approx(float(ds.attrs["dt"]) / 4)
        assert np.asarray(ds.attrs["step_check_twin_ratios"]).shape == (2,)
    assert main(["simulate", "--check", "--check-factor", "1", "--out", str(tmp_path / "bad.nc")]) == 2
    assert "factor=1" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("argv", "field"),
    [
        (["--set", "mu=-1"], "mu"),
        (["--set", "foo=1"], "foo"),
        (["--preset", "nope"], "preset"),
        (["--set", "mu"], "mu"),
        (["--set", "offset_deg=abc"], "offset_deg"),
        (["--duration-s", "0"], "duration_s"),
    ],
)
def test_simulate_bad_value_exits_2(tmp_path, capsys, argv, field):
    out = tmp_path / "bad.nc"
    rc = main(["simulate", "--duration-s", SHORT, *argv, "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2
    # argparse's own message for a choice lists the choices
    assert err.startswith("error: ") or "error: argument --preset: invalid choice: 'nope' (choose from 'paper', 'aluminum')" in err
    assert field in err
    assert "Traceback" not in err
    assert not out.exists()


def test_usage_errors_and_version(capsys):
    assert main(["simulate", "--torque", "middle"]) == 2
    assert "--torque" in capsys.readouterr().err
    assert main([]) == 2
    capsys.readouterr()
    assert main(["--version"]) == 0
    assert tumblemc.__version__ in capsys.readouterr().out


def test_validate_delegates_and_every_subcommand_registers_itself(monkeypatch, tmp_path):
    calls: list[tuple] = []
    val = types.ModuleType("tumblemc.reports.claims")
    val.run_validation = lambda out_dir, quick: calls.append(("validate", out_dir, quick)) or 3  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "tumblemc.reports.claims", val)
    assert main(["validate", "--quick", "--out", str(tmp_path)]) == 3
    assert main(["validate"]) == 3
    assert calls == [("validate", str(tmp_path), True), ("validate", "validation", False)]
    from tumblemc.cli import SUBCOMMANDS, build_parser

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    assert list(sub.choices) == list(SUBCOMMANDS)
    assert main(["bench"]) == 2  # the per-step benchmark lives in benchmarks/step_cost.py, outside the wheel


def test_parse_helpers():
    assert parse_value("true") is True and parse_value("False") is False
    assert parse_value("0.4") == 0.4 and parse_value("1e-3") == 1e-3
    assert parse_value("1,0,0") == (1.0, 0.0, 0.0)
    assert parse_value("abc") == "abc"
    assert parse_overrides(["mu=0.4", "offset_deg = 10"]) == {"mu": 0.4, "offset_deg": 10.0}
    table = format_table({"a": 1.0, "long_name": True})
    assert table.splitlines() == ["a          1", "long_name  True"]
    assert format_table({"mean_speed": 0.5, "climbed": True}, SUMMARY_UNITS).splitlines() == ["mean_speed  0.5 m/s", "climbed     True"]


def test_shape_and_preset_list_their_choices(capsys):
    assert main(["simulate", "--help"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "{cuboid,spiked,spiked_ends,curved}" in out and "{paper,aluminum}" in out


def test_netcdf_ready_does_not_touch_input(short_run):
    ds = short_run.copy()
    ds.attrs["flag"] = True
    ds.attrs["vec"] = [1.0, 2.0]
    safe = netcdf_ready(ds)
    assert safe.attrs["flag"] == 1 and isinstance(safe.attrs["vec"], np.ndarray)
    assert ds.attrs["flag"] is True and isinstance(ds.attrs["vec"], list)


def test_side_view_outline_at_rest(short_run):
    shape = get_shape("cuboid")
    s, h = side_view_outline(short_run, shape, 0)
    half_len = np.ptp(shape.outline[:, 0]) / 2
    height = np.ptp(shape.outline[:, 1])
    assert np.allclose(np.sort(np.unique(np.round(s, 12))), [-half_len, half_len])
    assert h.min() == pytest.approx(0.0, abs=1e-12) and h.max() == pytest.approx(height)
    s_end, h_end = side_view_outline(short_run, None, -1)
    assert s_end.shape == s.shape and h_end.min() > -1e-9


def test_strip_layouts():
    box = (np.array([-4e-4, 4e-4, 4e-4, -4e-4]), np.zeros(4))
    moved = [(box[0] + k * 5e-5, box[1]) for k in range(4)]  # slow: spread uphill
    off, layout, extra = strip_offsets(moved, 8e-4)
    assert layout == "spread" and extra > 0 and np.all(np.diff(off) > 0)
    far = [(box[0] + k * 1e-3, box[1]) for k in range(4)]  # already apart
    assert strip_offsets(far, 8e-4)[1] == "true"
    slide = [(box[0] - k * 1e-2, box[1]) for k in range(4)]  # fast slide downhill
    assert strip_offsets(slide, 8e-4)[1] == "slots"


def test_plot_run_returns_figure(short_run, tmp_path):
    fig = plot_run(short_run, tmp_path / "fig.png", snapshots=5)
    assert isinstance(fig, Figure)
    assert len(fig.axes) >= 4  # progress, contact, adhesion twin, strip (+ colorbar)
    assert (tmp_path / "fig.png").stat().st_size > 0


def test_set_only_takes_physical_parameters(tmp_path, capsys):  # type: ignore[no-untyped-def]
    rc = main(["simulate", "--duration-s", SHORT, "--out", str(tmp_path / "r.nc"), "--set", "shape=sphere"])
    assert rc == 2
    assert "shape" in capsys.readouterr().err


def test_unwritable_output_is_a_clear_error(tmp_path, capsys):  # type: ignore[no-untyped-def]
    rc = main(["simulate", "--duration-s", SHORT, "--out", str(tmp_path)])
    assert rc == 2
    assert "error:" in capsys.readouterr().err


def test_study_run_refuses_a_changed_config_before_compiling(tmp_path, capsys, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """Shards of another config: one line, before the header and before any kernel is compiled or worker started."""
    import json

    from tumblemc.io import parts_dir

    out = tmp_path / "s.nc"
    parts = parts_dir(out)
    parts.mkdir()
    (parts / "study.json").write_text(json.dumps({"config_hash": "0" * 64, "config": {}}))
    import tumblemc.study.cluster as cluster

    def no(*a: object, **k: object) -> None:
        raise AssertionError("compiled or started workers before refusing")

    monkeypatch.setattr(cluster, "warm_kernels", no)  # what the command's kernel step calls (cli.common.warm_kernels_saying)
    monkeypatch.setattr(cluster, "local_client", no)
    assert main(["study", "run", "studies/smoke.toml", "--out", str(out), "--workers", "0"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error:") and err.count("\n") == 1  # no header, no "compiling": one line
    assert "different config" in err and "--fresh" in err
    assert json.loads((parts / "study.json").read_text())["config_hash"] == "0" * 64  # nothing overwritten


@pytest.mark.parametrize("cached", [True, False])
def test_the_kernel_step_says_whether_it_loads_or_compiles_and_ticks(
    cached: bool, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import time

    from tumblemc.cli.common import warm_kernels_saying
    from tumblemc.study import cluster

    monkeypatch.setattr(cluster, "kernels_cached", lambda: cached)
    monkeypatch.setattr(cluster, "warm_kernels", lambda: time.sleep(0.35) or 0.35)
    assert warm_kernels_saying(True, tick_s=0.1) == 0.35
    err = capsys.readouterr().err.splitlines()
    assert err[0].startswith("loading the compiled kernels from the cache" if cached else "compiling the kernels (")
    ticks = [line for line in err if line.startswith("  still")]
    assert len(ticks) >= 2 and all(("loading" if cached else "compiling") in t for t in ticks)
    assert err[-1].startswith("kernels ready in")
    assert warm_kernels_saying(False) == 0.35 and capsys.readouterr().err == ""


def test_kernels_cached_reads_numbas_index(tmp_path: Path) -> None:
    import subprocess

    from tumblemc.study.cluster import kernels_cached, warm_kernels

    warm_kernels()
    assert kernels_cached() is True
    # a process whose Numba cache folder is empty has nothing to load
    code = "from tumblemc.study.cluster import kernels_cached; print(kernels_cached())"
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "empty")}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True, timeout=120)
    assert out.stdout.strip() == "False"
