"""How tumblemc writes netCDF so that any netCDF reader, and the CF conventions, understand it.

Every string variable is a ``char`` array (``<name>(<dims>, <name>_strlen)``, UTF-8,
``_Encoding = "utf-8"``), not a netCDF-4 ``string``: the oldest readers and the CF checker
read them, and xarray decodes them back to strings. A string label along a dimension
(a study's ``shape`` and ``substrate``, a run's ``xyz``) is stored under the dimension's
own name and named in the ``coordinates`` attribute of every variable along it:

- for xarray (and netCDF-4 readers that match names), ``shape`` is the dimension's
  coordinate, so ``xr.open_dataset(path, group="maps").sel(shape="cuboid")`` works;
- for CF it is a string-valued auxiliary coordinate (a label, CF section 6.1): being 2-D in
  the file (the last dimension is the string length), it is no coordinate variable, which
  CF wants numeric (section 1.3), and the ``coordinates`` attribute ties it to the data.

A file of groups (a study's ``runs`` and ``maps``) names them in the root attributes
``data_groups`` and ``comment``, since ``xr.open_dataset(path)`` shows only the root.

Files written before used other forms, which :func:`from_labels` reads: the labels as
``<dim>_label`` on a dimension without a coordinate variable, or as netCDF-4 ``string``
coordinate variables.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import xarray as xr

#: the suffix of the label variables of files written before labels took their dimension's name
LABEL_SUFFIX = "_label"

_ZLIB = {"zlib": True, "complevel": 4}


def _is_text(var: xr.Variable) -> bool:
    return var.dtype.kind in "OUS"


def cf_strings(ds: xr.Dataset) -> tuple[xr.Dataset, dict[str, dict[str, Any]]]:
    """``ds`` ready to write (module docstring) and the ``encoding`` for ``to_netcdf``.

    Strings become compressed ``char`` arrays; numbers are compressed too; every data
    variable along a string label's dimension names the label in its ``coordinates``. The
    encodings ``ds`` carries from a file it was read from are dropped (they may name
    variables of an older form).
    """
    out = ds.copy(deep=False)
    for var in out.variables.values():
        var.encoding = {}
    labels = {str(d) for d in out.dims if d in out.coords and _is_text(out[d].variable)}
    aux = [str(c) for c in out.coords if c not in out.dims]
    for name, da in out.data_vars.items():
        along = {str(d) for d in da.dims}
        coords = sorted({c for c in aux if set(map(str, out[c].dims)) <= along} | (labels & along))
        if coords:
            out[name].encoding["coordinates"] = " ".join(coords)
    enc: dict[str, dict[str, Any]] = {}
    for name, var in out.variables.items():
        if _is_text(var):
            enc[str(name)] = {"dtype": "S1", "char_dim_name": f"{name}_strlen", **_ZLIB}
        elif var.dtype.kind in "fiub" and var.ndim and name not in out.dims:
            enc[str(name)] = dict(_ZLIB)
    return out, enc


def group_guide(groups: list[str]) -> dict[str, str]:
    """Root attributes that say where a file's data are: its groups, and how to open them."""
    names = " and ".join(groups)
    return {
        "data_groups": " ".join(groups),
        "comment": (
            f"The data are in the groups {names}; the root holds only these attributes. Open them with "
            f'xarray.open_datatree(path) or xarray.open_dataset(path, group="{groups[-1]}"), or any netCDF-4 reader.'
        ),
    }


def write_groups(path: str | Path, root_attrs: Mapping[Any, Any], groups: Mapping[str, xr.Dataset]) -> None:
    """Write a netCDF-4 file: the root with ``root_attrs`` (and :func:`group_guide`), and ``groups``.

    Each group as :func:`cf_strings` makes it. ``path`` is overwritten.
    """
    attrs = {**group_guide(list(groups)), **root_attrs}
    xr.Dataset(attrs=attrs).to_netcdf(path, mode="w", engine="netcdf4")
    for name, ds in groups.items():
        out, enc = cf_strings(ds)
        out.to_netcdf(path, mode="a", group=name, engine="netcdf4", encoding=enc)


def write_dataset(ds: xr.Dataset, path: str | Path) -> None:
    """Write one Dataset (no groups) to a netCDF-4 file as :func:`cf_strings` makes it."""
    out, enc = cf_strings(ds)
    out.to_netcdf(path, engine="netcdf4", encoding=enc)


def from_labels(ds: xr.Dataset) -> xr.Dataset:
    """A Dataset read from any tumblemc file with string labels indexed and stored as ``str``.

    ``<dim>_label`` (files written before labels took their dimension's name) becomes the
    indexed coordinate ``<dim>``; strings read from ``char`` arrays (``object`` dtype) become
    numpy ``str`` arrays, as those of netCDF-4 ``string`` variables load.
    """
    for d in list(ds.dims):
        lab = f"{d}{LABEL_SUFFIX}"
        if d not in ds.coords and lab in ds.coords and ds[lab].dims == (d,):
            ds = ds.rename_vars({lab: d}).set_xindex(str(d))
    text = {k: v for k, v in ds.variables.items() if v.dtype == object}
    for k, v in text.items():
        ds[k] = v.astype(str)  # an index coordinate keeps its index (rebuilt on the new values)
    return ds


__all__ = ["LABEL_SUFFIX", "cf_strings", "from_labels", "group_guide", "write_dataset", "write_groups"]
