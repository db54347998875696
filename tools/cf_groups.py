"""Write each group of a study file to its own netCDF file, for the CF checker.

    python tools/cf_groups.py results/smoke.nc cf_out [--cf18] [--char]
    cfchecks cf_out/smoke_runs.nc; cfchecks cf_out/smoke_maps.nc

cfchecks reads a file, not a group. Each extracted file has the root's attributes with the
group's own over them: the view CF 2.7 gives a group (attributes apply to the group where
they are defined and its descendants). ``--cf18`` (``Conventions`` CF-1.8, the newest
version cfchecks 4.1.0 knows) and ``--char`` (netCDF-4 strings as char arrays, which it
cannot read) show what is left once the checker's own limits are set aside
(docs/guide/study_results.md, "The study file's metadata").
"""

from __future__ import annotations

import argparse
from pathlib import Path

import xarray as xr


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("study", type=Path, help="a study file (tumblemc study run)")
    ap.add_argument("out", type=Path, help="folder for <name>_runs.nc and <name>_maps.nc")
    ap.add_argument("--cf18", action="store_true", help="write Conventions CF-1.8")
    ap.add_argument("--char", action="store_true", help="write strings as char arrays")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    with xr.open_dataset(args.study, engine="netcdf4") as root:
        rattrs = dict(root.attrs)
    for g in ("runs", "maps"):
        with xr.open_dataset(args.study, group=g, engine="netcdf4", decode_cf=False) as ds:
            ds = ds.load()
        ds.attrs = {**rattrs, **ds.attrs}
        if args.cf18:
            ds.attrs["Conventions"] = str(ds.attrs["Conventions"]).replace("CF-1.10", "CF-1.8")
        enc = {v: {"dtype": "S1"} for v in ds.variables if ds[v].dtype.kind in "OU"} if args.char else {}
        path = args.out / f"{args.study.stem}_{g}.nc"
        ds.to_netcdf(path, engine="netcdf4", encoding=enc)
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
