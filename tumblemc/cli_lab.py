"""``tumblemc lab ...``: the bench-test protocols of :mod:`tumblemc.lab` from the command line.

tumblemc lab static-tilt --field-mT 3:15:1 --direction 0,0,-1 --out tilt.nc --plot
tumblemc lab critical-field --freq-hz 1 --incline-deg 0
tumblemc lab step-out --freq-hz 1,5,10,20,30,40 --out stepout.nc --plot
tumblemc lab steer --preset aluminum --plot
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from tumblemc.model.params import PRESETS
from tumblemc.model.shapes.library import SHAPES

SHAPE_CHOICES = tuple(SHAPES)
PRESET_CHOICES = tuple(PRESETS)
SHAPE_HELP = f"robot shape: {', '.join(SHAPE_CHOICES)} (default: cuboid)"
PRESET_HELP = f"parameter preset: {', '.join(PRESET_CHOICES)} (default: paper)"


def parse_values(name: str, text: str) -> list[float]:
    """``a:b:step`` (inclusive) or a comma list of numbers."""
    try:
        if ":" in text:
            a, b, s = (float(v) for v in text.split(":"))
            if not s > 0 or b < a:
                raise ValueError
            return list(np.round(np.arange(a, b + s / 2, s), 12))
        return [float(v) for v in text.split(",")]
    except ValueError:
        raise ValueError(f"{name}={text!r} is not allowed (allowed: START:STOP:STEP or a comma list, e.g. 3:15:1 or 1,5,10)") from None


def parse_vector(name: str, text: str) -> tuple[float, float, float]:
    """Three comma-separated numbers."""
    try:
        vals = tuple(float(v) for v in text.split(","))
    except ValueError:
        vals = ()
    if len(vals) != 3:
        raise ValueError(f"{name}={text!r} is not allowed (allowed: three comma-separated numbers, e.g. 0,0,-1)")
    return (vals[0], vals[1], vals[2])


def add_lab_parser(sub: Any, common: Any) -> None:
    """Add ``lab`` and its protocol subcommands to the ``tumblemc`` parser (``common`` adds --set)."""
    what = "bench tests in simulation: static tilt, critical field, step-out, steering"
    lab = sub.add_parser("lab", help=what, description=what[0].upper() + what[1:] + " (docs/lab.md).")
    ls = lab.add_subparsers(dest="lab_command", metavar="PROTOCOL")
    ls.required = True

    def base(p: argparse.ArgumentParser, out: str) -> None:
        p.add_argument("--shape", default="cuboid", choices=SHAPE_CHOICES, help=SHAPE_HELP)
        p.add_argument("--preset", default="paper", choices=PRESET_CHOICES, help=PRESET_HELP)
        common(p)
        p.add_argument("--out", default=out, help=f"output netCDF path (default: {out})")
        p.add_argument("--plot", action="store_true", help="also write a PNG figure next to the netCDF file")

    p = ls.add_parser("static-tilt", help="equilibrium tilt under a static field", description="Equilibrium tilt under a static field.")
    p.add_argument(
        "--field-mT", default="3:15:1", dest="field_mT", help="field magnitudes, mT: START:STOP:STEP or a list (default: 3:15:1)"
    )
    p.add_argument("--direction", default="0,0,-1", help="field direction, world frame (default: 0,0,-1, straight down)")
    p.add_argument("--incline-deg", type=float, default=0.0, help="substrate incline, degrees (default: 0)")
    p.add_argument("--duration-s", type=float, default=0.6, help="simulated time per field, s (default: 0.6)")
    p.add_argument("--dt", type=float, default=1.25e-5, help="time step, s (default: 1.25e-5)")
    base(p, "static_tilt.nc")

    p = ls.add_parser("critical-field", help="smallest field that tumbles (bisection)", description="Smallest field that tumbles.")
    p.add_argument("--freq-hz", type=float, default=1.0, help="field frequency, Hz (default: 1)")
    p.add_argument("--incline-deg", type=float, default=0.0, help="substrate incline, degrees (default: 0)")
    p.add_argument("--lo-mT", type=float, default=0.5, help="bracket low end, mT (default: 0.5)")
    p.add_argument("--hi-mT", type=float, default=40.0, help="bracket high end, mT (default: 40)")
    p.add_argument("--tol-mT", type=float, default=0.1, help="bracket width to stop at, mT (default: 0.1)")
    p.add_argument("--posterior", default=None, help="a calibration file: one bisection per posterior draw")
    p.add_argument("--samples", type=int, default=20, help="posterior draws to use with --posterior (default: 20)")
    base(p, "critical_field.nc")

    p = ls.add_parser("step-out", help="speed and phase lag against frequency", description="Speed and phase lag against frequency.")
    p.add_argument("--freq-hz", default="1,2,5,10,15,20,25,30,40", help="frequencies, Hz: START:STOP:STEP or a list")
    p.add_argument("--field-mT", type=float, default=20.0, dest="field_mT", help="field magnitude, mT (default: 20)")
    p.add_argument("--incline-deg", type=float, default=0.0, help="substrate incline, degrees (default: 0)")
    base(p, "step_out.nc")

    p = ls.add_parser("steer", help="roll about x, then about y: the heading turn", description="Roll about x, then y: the turn.")
    p.add_argument("--freq-hz", type=float, default=1.75, help="field frequency, Hz (default: 1.75: no field jump with 1 s legs)")
    p.add_argument("--field-mT", type=float, default=20.0, dest="field_mT", help="field magnitude, mT (default: 20)")
    p.add_argument("--leg-s", type=float, default=1.0, help="duration of each leg, s (default: 1)")
    base(p, "steering.nc")


def add_calibrate_parser(sub: Any, common: Any) -> None:
    """Add ``calibrate TEST DATA.csv`` to the ``tumblemc`` parser."""
    what = "fit parameters to bench data and write a posterior"
    p = sub.add_parser("calibrate", help=what, description=what[0].upper() + what[1:] + " (docs/calibration.md).")
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
    p.add_argument("--shape", default="cuboid", choices=SHAPE_CHOICES, help=SHAPE_HELP)
    p.add_argument("--preset", default="paper", choices=PRESET_CHOICES, help=PRESET_HELP)
    common(p)
    p.add_argument("--out", default="calib.nc", help="output netCDF path (default: calib.nc)")
    p.add_argument("--plot", action="store_true", help="also write a PNG figure next to the netCDF file")


def cmd_calibrate(args: argparse.Namespace, overrides: dict[str, Any]) -> int:
    """Run a calibration, write the posterior file (and figure), print the estimate."""
    from tumblemc.calibrate import calibrate, read_bench

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
    return _write(res, args)


def cmd_lab(args: argparse.Namespace, overrides: dict[str, Any]) -> int:
    """Run one protocol, write its Dataset (and figure), print its headline numbers."""
    from tumblemc import lab

    c = args.lab_command
    kw = dict(shape=args.shape, preset=args.preset, **overrides)
    if c == "static-tilt":
        ds = lab.static_tilt(
            parse_values("--field-mT", args.field_mT),
            parse_vector("--direction", args.direction),
            incline_deg=args.incline_deg,
            duration_s=args.duration_s,
            dt=args.dt,
            progress=True,
            **kw,
        )
        cols = ["tilt_deg", "tilt_spread_deg", "tilt_closed_form_deg", "tilt_min_deg", "tilt_max_deg", "status"]
        print(ds[cols].to_dataframe().round(3).to_string())
    elif c == "critical-field":
        bis = dict(lo_mT=args.lo_mT, hi_mT=args.hi_mT, tol_mT=args.tol_mT, **kw)
        if args.posterior:
            draws = lab.posterior_samples(args.posterior, args.samples, args.shape, args.preset)
            ds = lab.critical_field_samples(draws, args.freq_hz, args.incline_deg, **bis)
            lo, hi = ds["critical_mT_5_95"].values
            med = float(ds["critical_mT_median"])
            print(f"critical field over {ds.sizes['sample']} posterior draws: median {med:.3g} mT, 5-95% {lo:.3g}-{hi:.3g} mT")
        else:
            ds = lab.critical_field(args.freq_hz, args.incline_deg, **bis)
            bracket = ds["bracket_mT"].values.round(4).tolist()
            print(f"critical field {float(ds['critical_mT']):.3g} mT (bracket {bracket} mT, {int(ds['n_runs'])} runs)")
    elif c == "step-out":
        ds = lab.step_out(parse_values("--freq-hz", args.freq_hz), args.field_mT, args.incline_deg, progress=True, **kw)
        print(ds[["speed", "progress_ratio", "phase_lag_deg", "status"]].to_dataframe().round(3).to_string())
        print(f"step-out frequency: {float(ds['step_out_hz']):g} Hz")
    else:
        ds = lab.steering(field_mT=args.field_mT, freq_hz=args.freq_hz, leg_s=args.leg_s, **kw)
        print(
            f"turn {float(ds['turn_deg']):.2f} deg (legs {ds['heading_deg'].values.round(2).tolist()} deg), field jump "
            f"{float(ds['field_jump_deg']):.1f} deg, failed steps {int(ds['failed_steps'])}, status {int(ds['status'])}"
        )
    return _write(ds, args)


def _write(ds: Any, args: argparse.Namespace) -> int:
    """Write a protocol's or a calibration's Dataset to ``--out`` and, with ``--plot``, its figure next to it."""
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    ds.to_netcdf(out)
    print(f"wrote {out}")
    if args.plot:
        from tumblemc.viz.calibrate import plot_calibration
        from tumblemc.viz.lab import plot_lab

        png = out.with_suffix(".png")
        if (plot_calibration(ds, png) if "test" in ds.attrs else plot_lab(ds, png)) is not None:
            print(f"wrote {png}")
    return 0


__all__ = [
    "PRESET_CHOICES",
    "SHAPE_CHOICES",
    "add_calibrate_parser",
    "add_lab_parser",
    "cmd_calibrate",
    "cmd_lab",
    "parse_values",
    "parse_vector",
]
