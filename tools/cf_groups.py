"""Write each group of a study file to its own netCDF file, for the CF checker.

    python tools/cf_groups.py results/smoke.nc cf_out [--cf18] [--char]
    cfchecks cf_out/smoke_runs.nc; cfchecks cf_out/smoke_maps.nc

cfchecks reads a file's root group only. Each extracted file is one group copied as it is
stored (netCDF4, no decoding: dimensions, variables, attributes, bytes), with the root's
attributes and the group's own over them: the view CF 2.7 gives a group (attributes apply
to the group where they are defined and its descendants). ``--cf18`` writes
``Conventions`` CF-1.8 (the newest version cfchecks 4.1.0 knows); ``--char`` writes the
netCDF-4 strings of files of earlier forms as char arrays (which the checker needs;
current files have none). Together they show what is left once the checker's own limits
are set aside (docs/guide/study_results.md, "The study file's metadata").
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import netCDF4
import numpy as np


def copy_group(src: Any, root_attrs: dict[str, Any], path: Path, cf18: bool, char: bool) -> None:
    """Group ``src`` (an open netCDF4 group) as the root of a new file ``path``."""
    attrs = {**root_attrs, **src.__dict__}
    if cf18:
        attrs["Conventions"] = str(attrs["Conventions"]).replace("CF-1.10", "CF-1.8")
    with netCDF4.Dataset(path, "w") as dst:
        dst.setncatts(attrs)
        for name, dim in src.dimensions.items():
            dst.createDimension(name, None if dim.isunlimited() else len(dim))
        for name, var in src.variables.items():
            var.set_auto_maskandscale(False)
            var.set_auto_chartostring(False)
            vattrs = var.__dict__
            data = var[...]
            dims = var.dimensions
            if var.dtype is str and char:  # a netCDF-4 string: char array, UTF-8
                raw = np.asarray(data, dtype=object).astype(str)
                width = max(1, max((len(s.encode()) for s in raw.ravel()), default=1))
                dst.createDimension(f"{name}_strlen", width)
                dims = (*dims, f"{name}_strlen")
                data = netCDF4.stringtochar(np.char.encode(raw, "utf-8").astype(f"S{width}"))
                vattrs = {**vattrs, "_Encoding": "utf-8"}
            fill = vattrs.get("_FillValue")
            out = dst.createVariable(name, "S1" if len(dims) > len(var.dimensions) else var.dtype, dims, fill_value=fill)
            out.set_auto_maskandscale(False)
            out.set_auto_chartostring(False)
            out.setncatts({k: v for k, v in vattrs.items() if k != "_FillValue"})
            out[...] = data


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("study", type=Path, help="a study file (tumblemc study run), or any tumblemc netCDF file")
    ap.add_argument("out", type=Path, help="folder for <name>_runs.nc and <name>_maps.nc")
    ap.add_argument("--cf18", action="store_true", help="write Conventions CF-1.8")
    ap.add_argument("--char", action="store_true", help="write netCDF-4 strings as char arrays")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    with netCDF4.Dataset(args.study) as nc:
        groups: dict[str, Any] = dict(nc.groups) or {"root": nc}  # a file without groups (a run, a calibration): its root
        for g, group in groups.items():
            path = args.out / f"{args.study.stem}_{g}.nc"
            copy_group(group, nc.__dict__, path, args.cf18, args.char)
            print(f"wrote {path}")


if __name__ == "__main__":
    main()
