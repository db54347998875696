"""``tumblemc calibrate``: fit parameters to bench data and write a posterior."""

from __future__ import annotations

import argparse
from typing import Any

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
    p.add_argument(
        "--bounds",
        action="append",
        default=[],
        metavar="NAME=LO:HI",
        help="bounds of a free field (default: its physical range; a scale parameter such as adhesion_C x 1e-3 to x 1e3 the preset's, log)",
    )
    p.add_argument("--direction", default="0,0,-1", help="static field direction, world frame (default: 0,0,-1)")
    p.add_argument(
        "--model",
        choices=("auto", "simulate", "closed-form"),
        default="auto",
        help="forward model: auto (default: the cuboid's closed form where it applies, checked by the simulator), simulate, closed-form",
    )
    p.add_argument(
        "--posterior",
        choices=("auto", "mcmc", "laplace"),
        default="auto",
        help="auto (default: MCMC with the closed form, Laplace with the simulator), mcmc (closed form only), laplace",
    )
    p.add_argument(
        "--noise-sd",
        type=float,
        default=None,
        help="the data's noise sd, when the instrument's is known (data units; MCMC only; default: unknown, marginalised)",
    )
    p.add_argument("--samples", type=int, default=2000, help="posterior draws (default: 2000)")
    p.add_argument("--seed", type=int, default=0, help="seed of the global search and the sampler (default: 0)")
    add_robot_and_output(p, "calib.nc")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Run a calibration, write the posterior file (and figure), print the estimate."""
    from tumblemc.lab.calibrate import calibrate, read_bench, report

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
        data,
        free,
        bounds,
        args.shape,
        args.preset,
        parse_vector("--direction", args.direction),
        args.model,
        args.samples,
        seed=args.seed,
        posterior=args.posterior,
        noise_sd=args.noise_sd,
        **overrides,
    )
    print("\n".join(report(res)))
    return write_dataset(res, args)
