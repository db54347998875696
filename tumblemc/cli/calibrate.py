"""``tumblemc calibrate``: fit parameters to bench data and write a posterior."""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from tumblemc.cli.common import (
    add_robot_and_output,
    parse_overrides,
    parse_vector,
    write_dataset,
)


def register(sub: Any) -> None:
    """Add this subcommand to the ``tumblemc`` parser."""
    what = "fit parameters to bench data and write a posterior"
    p = sub.add_parser("calibrate", help=what, description=what[0].upper() + what[1:] + " (docs/guide/calibration.md).")
    p.add_argument("test", choices=("static-tilt", "speed"), help="the bench test the data come from")
    p.add_argument("data", help="CSV with a header: field_mT,tilt_deg (static-tilt) or freq_hz,speed_mm_s (speed)")
    p.add_argument("--free", required=True, help="Params fields to fit, comma-separated, e.g. F_elect,offset_deg,adhesion_C")
    p.add_argument("--bounds", action="append", default=[], metavar="NAME=LO:HI", help="bounds of a free field (default 0.25x-4x nominal)")
    p.add_argument("--direction", default="0,0,-1", help="static field direction, world frame (default: 0,0,-1)")
    p.add_argument(
        "--model",
        choices=("auto", "simulate", "closed-form"),
        default="auto",
        help="forward model: auto (default: the cuboid's closed form where it applies, checked by the simulator), simulate, closed-form",
    )
    p.add_argument("--samples", type=int, default=2000, help="posterior draws (default: 2000)")
    add_robot_and_output(p, "calib.nc")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Run a calibration, write the posterior file (and figure), print the estimate."""
    from tumblemc.lab.calibrate import calibrate, read_bench

    overrides = parse_overrides(args.overrides)
    data = read_bench(args.data)
    want = {"static-tilt": "static_tilt", "speed": "speed"}[args.test]
    if data.test != want:
        raise ValueError(f"{args.data}: its header is a {data.test} test, not {args.test} (allowed: the test the header names)")
    bounds = {}
    for item in args.bounds:
        name, _, rng = item.partition("=")
        lo, _, hi = rng.partition(":")
        try:
            bounds[name.strip()] = (float(lo), float(hi))
        except ValueError:
            raise ValueError(f"--bounds {item!r} is not NAME=LO:HI (allowed: e.g. --bounds F_elect=0:1e-5)") from None
    free = [f.strip() for f in args.free.split(",") if f.strip()]
    res = calibrate(
        data, free, bounds, args.shape, args.preset, parse_vector("--direction", args.direction), args.model, args.samples, **overrides
    )
    for nm in free:
        est, sd = float(res[f"estimate_{nm}"]), float(res[nm].std())
        lo, hi = np.quantile(res[nm].values, [0.025, 0.975])
        print(f"{nm:>14s} = {est:.6g} (posterior sd {sd:.3g}, 95% {lo:.6g} .. {hi:.6g}) {res[nm].attrs['units']}")
    a = res.attrs
    print(f"rms residual {a['rms_residual']:.4g}, {a['n_evaluations']} {a['fit_model']} evaluations, condition {a['condition_number']:.3g}")
    if np.isfinite(a["simulator_check_rms"]):
        print(f"the simulator at the estimate differs from the closed form by {a['simulator_check_rms']:.3g} (rms, data units)")
    if res.attrs["undetermined"]:
        print(f"warning: the data do not determine {res.attrs['undetermined']} (its posterior keeps most of its bounds)")
    return write_dataset(res, args)
