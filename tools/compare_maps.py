"""Compare the success maps of two studies of the same cells, statistically.

    python tools/compare_maps.py REFERENCE.nc NEW.nc [REFERENCE2.nc ...] [--out report.md]

For studies whose samples differ (a threshold study against the grid study of the same
seed, or a grid study against itself reseeded), bit equality means nothing; what should
hold is that the estimates agree as independent samples of the same probabilities.
Reported per pair (REFERENCE against NEW, and every further file against NEW):

- cells compared (both have valid runs), and how many of NEW's ``p_success`` lie outside
  REFERENCE's interval (the ``p_success_lower``/``p_success_upper`` of the file: Wilson at
  95% for the default study). Two independent estimates with 200 samples each put a few
  percent of the cells outside by chance: compare with a reseeded REFERENCE;
- mean and largest ``|delta P|`` over the cells;
- the steepest incline with ``P >= 0.5`` per shape and substrate in each (the verdict
  line of ``study run``), and how many of those differ.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import xarray as xr

from tumblemc.io import open_result

DIMS = ("shape", "substrate", "incline_deg")


def _p(maps: xr.Dataset) -> xr.Dataset:
    keep = maps[["p_success", "p_success_lower", "p_success_upper", "n_valid"]]
    extra = [d for d in keep.dims if d not in DIMS]
    if extra:
        raise SystemExit(f"maps with the sweep dimensions {extra} are not compared by this tool (allowed: one field and frequency)")
    return keep.transpose(*DIMS)


def climbs_to(p: xr.DataArray, level: float = 0.5) -> dict[tuple[str, str], float]:
    """Steepest grid incline with P >= level before the first below it, per shape and substrate (NaN: none)."""
    out = {}
    for s in p["shape"].values:
        for b in p["substrate"].values:
            row = p.sel(shape=s, substrate=b).values
            th = p["incline_deg"].values
            ok = np.flatnonzero(~(row >= level))
            k = int(ok[0]) if len(ok) else len(th)
            out[(str(s), str(b))] = float(th[k - 1]) if k > 0 else float("nan")
    return out


def compare(ref: xr.Dataset, new: xr.Dataset) -> dict[str, object]:
    a, b = _p(ref), _p(new)
    a, b = xr.align(a, b, join="inner")
    both = (a["n_valid"] > 0) & (b["n_valid"] > 0)
    pa, pb = a["p_success"].where(both), b["p_success"].where(both)
    outside = both & ((pb < a["p_success_lower"] - 1e-12) | (pb > a["p_success_upper"] + 1e-12))
    d = np.abs(pa - pb)
    ca, cb = climbs_to(a["p_success"]), climbs_to(b["p_success"])
    diff = {k: (ca[k], cb[k]) for k in ca if not (ca[k] == cb[k] or (np.isnan(ca[k]) and np.isnan(cb[k])))}
    flat = outside.stack(c=DIMS)
    cells = flat.where(flat, drop=True)
    where = []
    for s, sub, t in zip(*(cells[k].values for k in DIMS), strict=True):
        at = {"shape": s, "substrate": sub, "incline_deg": t}
        where.append(f"{s} {sub} {t:g} deg: {float(pa.sel(at)):.3f} vs {float(pb.sel(at)):.3f}")
    return {
        "cells": int(both.sum()),
        "outside": int(outside.sum()),
        "outside_cells": where,
        "mean_abs_dp": float(d.mean()),
        "max_abs_dp": float(d.max()),
        "climbs_to_differ": diff,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("reference", nargs="+", help="result files to compare NEW against (the first is the reference)")
    ap.add_argument("new", help="result file under test")
    ap.add_argument("--out", default=None, help="also write the report (Markdown) here")
    args = ap.parse_args(argv)
    _, new = open_result(args.new)
    lines = [f"# {Path(args.new).name} against {', '.join(Path(r).name for r in args.reference)}", ""]
    pairs = [(r, args.new, new) for r in args.reference]
    if len(args.reference) > 1:  # the references against each other: what reseeding alone gives
        pairs.append((args.reference[0], args.reference[1], open_result(args.reference[1])[1]))
    for ref_path, new_path, nm in pairs:
        _, rm = open_result(ref_path)
        c = compare(rm, nm)
        lines += [
            f"## {Path(new_path).name} in the intervals of {Path(ref_path).name}",
            "",
            f"- cells compared: {c['cells']}; outside the reference's interval: {c['outside']}",
            f"- mean |delta P| {c['mean_abs_dp']:.4f}, largest {c['max_abs_dp']:.3f}",
            f"- steepest incline with P >= 0.5 differs for: {c['climbs_to_differ'] or 'none'}",
            *(f"  - outside: {w}" for w in c["outside_cells"]),  # type: ignore[attr-defined]
            "",
        ]
    text = "\n".join(lines)
    print(text)
    if args.out:
        Path(args.out).write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
