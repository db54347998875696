"""The study file's CF/ACDD metadata and provenance.

ACDD global attributes at the root, groups that hold only their own attributes, int8 flags
with flag attributes, and the git commit and dirty flag of the code that wrote the file:
read from the checkout, or recorded when the package was built.
"""

from __future__ import annotations

import re
import subprocess
import sys
import tomllib
import types
from pathlib import Path

import netCDF4
import numpy as np
import pytest
import xarray as xr

from tests.tooling import load_tool
from tumblemc import version
from tumblemc.io import open_result, result_attrs, write_result
from tumblemc.schema import MAPS_FROM_RUNS_ATTRS, STUDY_FILE_ATTRS
from tumblemc.study.engine import run_study

ROOT = Path(__file__).resolve().parents[2]
SHA = re.compile(r"[0-9a-f]{40}")

#: ACDD-1.3 highly recommended and the recommended ones a study can fill in truthfully
ACDD = (
    "Conventions",
    "title",
    "summary",
    "keywords",
    "id",
    "naming_authority",
    "history",
    "source",
    "license",
    "date_created",
    "creator_name",
    "creator_type",
    "references",
)

#: root attributes a group may repeat: the config hash that ties it to its study, and
#: (runs) the definitions of its columns that analysis reads from the group
SHARED = {"config_hash", "success_ratio", "uncertain", "mode"}


@pytest.fixture(scope="module")
def study(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tomllib.loads((ROOT / "studies" / "smoke.toml").read_text())
    d.update(
        {"name": "cf", "incline_deg": [0, 60], "freq_hz": 10, "samples": 2, "check": {"fraction": 0.02, "min_runs": 2, "dt_factor": 2}}
    )
    out = tmp_path_factory.mktemp("cf") / "cf.nc"
    run_study(d, out=out, progress=False)
    return out


def test_root_has_the_acdd_attributes(study: Path) -> None:
    root = result_attrs(study)
    for key in ACDD:
        assert str(root.get(key, "")).strip(), key
    assert root["Conventions"].split() == ["CF-1.10", "ACDD-1.3"]  # blank-separated (CF 2.6.1)
    assert root["license"] == "MIT"
    assert "Towards Dynamic Simulation Guided Optimal Design of Tumbling Microrobots" in root["references"]
    assert {k: root[k] for k in STUDY_FILE_ATTRS} == STUDY_FILE_ATTRS
    assert root["config_hash"][:16] in root["id"]


def test_groups_do_not_repeat_the_root(study: Path) -> None:
    root = result_attrs(study)
    runs, maps = open_result(study)
    for ds in (runs, maps):
        assert set(ds.attrs) & set(root) <= SHARED | {"title"}, sorted(set(ds.attrs) & set(root))
        assert ds.attrs["config_hash"] == root["config_hash"]
        assert ds.attrs["title"] != root["title"]
        # CF 2.7: Conventions only at the root
        assert "Conventions" not in ds.attrs and "history" not in ds.attrs
    # what analysis reads from the groups is still there
    assert runs.attrs["uncertain"] == root["uncertain"] and runs.attrs["success_ratio"] == root["success_ratio"]
    assert "check_dt_factor" in runs.attrs and "dt" in runs.attrs
    assert set(maps.attrs) >= {"ci_method", "confidence_level", "success_definition", *MAPS_FROM_RUNS_ATTRS}


def test_check_flag_is_int8_with_flag_attributes(study: Path) -> None:
    runs, _ = open_result(study)
    flag = runs["check_flag"]
    assert flag.dtype == np.int8
    np.testing.assert_array_equal(flag.attrs["flag_values"], [0, 1])
    assert flag.attrs["flag_meanings"] == "no yes" and flag.attrs["units"] == "1"
    np.testing.assert_array_equal(np.flatnonzero(flag.values), runs["check_run"].values)
    for name, var in runs.variables.items():  # every flag variable: int8, flag_values of its type
        if "flag_values" in var.attrs:
            assert var.dtype == np.int8 and np.asarray(var.attrs["flag_values"]).dtype == np.int8, name
            assert len(var.attrs["flag_values"]) == len(var.attrs["flag_meanings"].split()), name


def test_study_file_has_no_standard_name(study: Path) -> None:
    # no quantity of it has a CF standard name (tumblemc.schema)
    with xr.open_datatree(study, engine="netcdf4") as tree:
        names = {v.attrs.get("standard_name") for node in tree.subtree for v in node.dataset.variables.values()}
    assert names == {None}


def test_provenance_has_a_commit_and_a_dirty_flag(study: Path) -> None:
    root = result_attrs(study)
    assert SHA.fullmatch(root["git_sha"]), root["git_sha"]
    assert root["git_dirty"] in (0, 1)
    assert root["git_sha_source"] in ("checkout", "build")
    info = version.build_info()
    assert info["git_sha"] == root["git_sha"] and info["git_sha_source"] == root["git_sha_source"]


def _git(*args: str, cwd: Path) -> None:
    subprocess.run(["git", "-c", "user.name=t", "-c", "user.email=t@t", *args], cwd=cwd, check=True, capture_output=True)


def test_checkout_commit_follows_the_tree_and_ignores_untracked_copies(tmp_path: Path) -> None:
    """A tracked file reports its checkout's commit and dirty flag.

    An untracked one (an installed package inside a clone's ignored .venv) reports none.
    """
    _git("init", "-q", cwd=tmp_path)
    (tmp_path / "mod.py").write_text("x = 1\n")
    _git("add", "mod.py", cwd=tmp_path)
    _git("commit", "-q", "-m", "first", cwd=tmp_path)
    sha = subprocess.run(["git", "rev-parse", "HEAD"], cwd=tmp_path, capture_output=True, text=True, check=True).stdout.strip()
    assert version._checkout(tmp_path / "mod.py") == (sha, False)
    (tmp_path / "mod.py").write_text("x = 2\n")
    assert version._checkout(tmp_path / "mod.py") == (sha, True)
    (tmp_path / "site").mkdir()
    (tmp_path / "site" / "mod.py").write_text("x = 1\n")
    assert version._checkout(tmp_path / "site" / "mod.py") is None


def test_an_installed_package_reports_the_commit_it_was_built_from(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(version, "_checkout", lambda path=None: None)
    assert version.build_info() == {"git_sha": "unknown", "git_dirty": -1, "git_sha_source": "none"}
    built = types.ModuleType("tumblemc._build_info")
    built.node, built.dirty = "g" + "ab" * 20, False  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "tumblemc._build_info", built)
    assert version.build_info() == {"git_sha": "ab" * 20, "git_dirty": 0, "git_sha_source": "build"}


def _raw_variables(path: Path) -> dict[str, netCDF4.Variable]:
    """Every variable of a netCDF file, as netCDF4 sees it, by group path ("maps/shape")."""
    out: dict[str, netCDF4.Variable] = {}
    with netCDF4.Dataset(path) as nc:
        nc.set_auto_chartostring(False)
        for g in [nc, *nc.groups.values()]:
            for name, var in g.variables.items():
                out[f"{g.name.strip('/')}/{name}".lstrip("/")] = var
        # read what the checks below need while the file is open
        return {k: types.SimpleNamespace(dtype=v.dtype, dimensions=v.dimensions, attrs=v.__dict__) for k, v in out.items()}


def plain_reader_checks(path: Path) -> None:
    """What a user of plain xarray, or of any netCDF-4 reader, meets in a study file."""
    with xr.open_datatree(path, engine="netcdf4") as tree:
        cell = tree["maps"].sel(shape="cuboid", substrate="aluminum")
        assert "p_success" in cell and "shape" not in cell.dims and "substrate" not in cell.dims
        assert set(tree.children) == {"runs", "maps"}
    with xr.open_dataset(path, group="maps", engine="netcdf4") as maps:
        assert float(maps["p_success"].sel(shape="cuboid", substrate="aluminum").isel(incline_deg=0)) >= 0.0
        assert {"shape", "substrate"} <= set(maps.indexes)
    with xr.open_dataset(path, engine="netcdf4") as root:  # the root says where the data are
        assert not root.variables
        assert root.attrs["data_groups"] == "runs maps"
        assert 'group="maps"' in root.attrs["comment"] and "open_datatree" in root.attrs["comment"]
    raw = _raw_variables(path)
    for name, var in raw.items():
        assert var.dtype is not str, f"{name} is a netCDF-4 string (vlen): char arrays only"
        group, _, short = name.rpartition("/")
        if short in var.dimensions:  # a variable named like its dimension: numeric, or a char label
            assert var.dtype.kind in "iuf" or (var.dimensions == (short, f"{short}_strlen") and var.dtype == "S1"), name
    for label in ("shape", "substrate"):
        assert raw[f"maps/{label}"].dimensions == (label, f"{label}_strlen")
        assert label in raw["maps/p_success"].attrs["coordinates"].split()  # a CF auxiliary coordinate (label)


def test_plain_xarray_reads_the_study_file(study: Path) -> None:
    """Plain xarray selects by label; open_result gives the same values, strings as str."""
    plain_reader_checks(study)
    runs, maps = open_result(study)
    assert maps["p_success"].sel(shape="cuboid", substrate="aluminum").dims == ("incline_deg",)
    assert maps["shape"].dtype.kind == "U" and runs["shape"].dtype.kind == "U" and runs["error"].dtype.kind == "U"
    with xr.open_dataset(study, group="maps", engine="netcdf4") as plain:
        for name in maps.variables:
            np.testing.assert_array_equal(plain[name].values.astype(maps[name].dtype), maps[name].values)
            assert plain[name].attrs == maps[name].attrs, name


@pytest.mark.parametrize("name", ["example.nc", "example_critical.nc"])
def test_plain_xarray_reads_the_shipped_studies(name: str) -> None:
    plain_reader_checks(ROOT / "data" / name)


def _tiny_maps() -> tuple[xr.Dataset, xr.Dataset]:
    maps = xr.Dataset(
        {"p_success": (("shape", "incline_deg", "substrate"), np.arange(4.0).reshape(2, 2, 1), {"units": "1", "long_name": "P"})},
        coords={"shape": ["cuboid", "spiked_ends"], "incline_deg": [0.0, 30.0], "substrate": ["aluminum"], "field_mT": 20.0},
        attrs={"title": "maps"},
    )
    runs = xr.Dataset(
        {"climbed": ("run", np.array([1, 0], np.int8)), "error": ("run", ["", "solver failed at t = 0.1 s"])},
        coords={"run": [0, 1], "shape": ("run", ["cuboid", "spiked_ends"])},
        attrs={"title": "runs"},
    )
    return runs, maps


@pytest.mark.parametrize("form", ["label", "string"])
def test_files_of_earlier_forms_still_open(tmp_path: Path, form: str) -> None:
    """Labels as <dim>_label (before issue 46) or as netCDF-4 string coordinates (before that)."""
    runs, maps = _tiny_maps()
    path = tmp_path / f"{form}.nc"
    xr.Dataset(attrs={"Conventions": "CF-1.10"}).to_netcdf(path, engine="netcdf4")
    for group, ds in (("runs", runs), ("maps", maps)):
        old = ds.rename_vars({d: f"{d}_label" for d in ("shape", "substrate") if d in ds.dims}) if form == "label" else ds
        old.to_netcdf(path, mode="a", group=group, engine="netcdf4")
    got_runs, got_maps = open_result(path)
    xr.testing.assert_identical(got_maps, maps)
    xr.testing.assert_identical(got_runs, runs)
    assert float(got_maps["p_success"].sel(shape="spiked_ends", substrate="aluminum", incline_deg=30.0)) == 3.0
    # tools/upgrade_result.py rewrites it in the current form, values unchanged
    load_tool("upgrade_result").main([str(path), "--out", str(tmp_path / "new.nc")])
    with xr.open_datatree(tmp_path / "new.nc", engine="netcdf4") as tree:
        assert float(tree["maps"]["p_success"].sel(shape="spiked_ends", substrate="aluminum", incline_deg=30.0)) == 3.0
        assert tree.attrs["Conventions"] == "CF-1.10" and "upgrade_result.py" in tree.attrs["history"]
    new_runs, new_maps = open_result(tmp_path / "new.nc")
    xr.testing.assert_identical(new_maps, maps)
    xr.testing.assert_identical(new_runs, runs)


def test_written_files_round_trip_through_open_result(tmp_path: Path) -> None:
    runs, maps = _tiny_maps()
    write_result(tmp_path / "new.nc", runs, maps, {"Conventions": "CF-1.10", "title": "t"})
    got_runs, got_maps = open_result(tmp_path / "new.nc")
    xr.testing.assert_identical(got_maps, maps)
    xr.testing.assert_identical(got_runs, runs)
    assert result_attrs(tmp_path / "new.nc")["data_groups"] == "runs maps"
    raw = _raw_variables(tmp_path / "new.nc")
    assert raw["runs/error"].dimensions == ("run", "error_strlen") and raw["runs/error"].dtype == "S1"
    assert raw["runs/climbed"].attrs["coordinates"] == "shape"
    assert set(raw["maps/p_success"].attrs["coordinates"].split()) == {"field_mT", "shape", "substrate"}
    # tools/cf_groups.py: each group a file of its own for the CF checker, stored bytes unchanged
    load_tool("cf_groups").main([str(tmp_path / "new.nc"), str(tmp_path / "cf"), "--cf18"])
    with netCDF4.Dataset(tmp_path / "cf" / "new_maps.nc") as nc:
        assert nc.variables["shape"].dimensions == ("shape", "shape_strlen") and nc.Conventions == "CF-1.8"
        assert nc.title == "maps" and list(nc.variables["shape"][:]) == ["cuboid", "spiked_ends"]
