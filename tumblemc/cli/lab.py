"""``tumblemc lab ...``: the bench-test protocols of :mod:`tumblemc.lab` from the command line.

tumblemc lab static-tilt --field-mT 3:15:1 --direction 0,0,-1 --out tilt.nc --plot
tumblemc lab critical-field --freq-hz 1 --incline-deg 0
tumblemc lab step-out --freq-hz 1,5,10,20,30,40 --out stepout.nc --plot
tumblemc lab steer --preset aluminum --plot
"""

from __future__ import annotations

import argparse
import math
from typing import Any

from tumblemc.analysis.words import incline_words
from tumblemc.cli.common import (
    add_robot_and_output,
    labelled_table,
    parse_overrides,
    parse_values,
    parse_vector,
    write_dataset,
)


def register(sub: Any) -> None:
    """Add this subcommand to the ``tumblemc`` parser."""
    what = "bench tests in simulation: static tilt, critical field, step-out, steering"
    lab = sub.add_parser("lab", help=what, description=what[0].upper() + what[1:] + " (docs/guide/lab.md).")
    ls = lab.add_subparsers(dest="lab_command", metavar="PROTOCOL")
    ls.required = True

    p = ls.add_parser("static-tilt", help="equilibrium tilt under a static field", description="Equilibrium tilt under a static field.")
    p.add_argument(
        "--field-mT", default="3:15:1", dest="field_mT", help="field magnitudes, mT: START:STOP:STEP or a list (default: 3:15:1)"
    )
    p.add_argument("--direction", default="0,0,-1", help="field direction, world frame (default: 0,0,-1, straight down)")
    p.add_argument("--incline-deg", type=float, default=0.0, help="substrate incline, degrees; negative: downhill (default: 0)")
    p.add_argument("--duration-s", type=float, default=0.6, help="simulated time per field, s (default: 0.6)")
    p.add_argument("--dt", type=float, default=1.25e-5, help="time step, s (default: 1.25e-5)")
    add_robot_and_output(p, "static_tilt.nc")

    p = ls.add_parser("critical-field", help="smallest field that tumbles (bisection)", description="Smallest field that tumbles.")
    p.add_argument("--freq-hz", type=float, default=1.0, help="field frequency, Hz (default: 1)")
    p.add_argument("--incline-deg", type=float, default=0.0, help="substrate incline, degrees; negative: downhill (default: 0)")
    p.add_argument("--lo-mT", type=float, default=0.5, help="bracket low end, mT (default: 0.5)")
    p.add_argument("--hi-mT", type=float, default=40.0, help="bracket high end, mT (default: 40)")
    p.add_argument("--tol-mT", type=float, default=0.1, help="bracket width to stop at, mT (default: 0.1)")
    p.add_argument("--posterior", default=None, help="a calibration file: one bisection per posterior draw")
    p.add_argument("--samples", type=int, default=20, help="posterior draws to use with --posterior (default: 20)")
    add_robot_and_output(p, "critical_field.nc")

    p = ls.add_parser("step-out", help="speed and phase lag against frequency", description="Speed and phase lag against frequency.")
    p.add_argument("--freq-hz", default="1,2,5,10,15,20,25,30,40", help="frequencies, Hz: START:STOP:STEP or a list")
    p.add_argument("--field-mT", type=float, default=20.0, dest="field_mT", help="field magnitude, mT (default: 20)")
    p.add_argument("--incline-deg", type=float, default=0.0, help="substrate incline, degrees; negative: downhill (default: 0)")
    add_robot_and_output(p, "step_out.nc")

    p = ls.add_parser("steer", help="roll about x, then about y: the heading turn", description="Roll about x, then y: the turn.")
    p.add_argument("--freq-hz", type=float, default=1.75, help="field frequency, Hz (default: 1.75: no field jump with 1 s legs)")
    p.add_argument("--field-mT", type=float, default=20.0, dest="field_mT", help="field magnitude, mT (default: 20)")
    p.add_argument("--leg-s", type=float, default=1.0, help="duration of each leg, s (default: 1)")
    add_robot_and_output(p, "steering.nc")
    lab.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Run one protocol, write its Dataset (and figure), print its headline numbers."""
    from tumblemc import lab

    overrides = parse_overrides(args.overrides)
    c = args.lab_command
    kw = dict(shape=args.shape, preset=args.preset, **overrides)
    said = incline_words(getattr(args, "incline_deg", 0.0))
    if said:
        print(said)
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
        print(labelled_table(ds, cols))
        if not ds["tilt_closed_form_deg"].notnull().all():
            print("(-: no value; the closed form covers the cuboid under a field pointing down only)")
    elif c == "critical-field":
        bis = dict(lo_mT=args.lo_mT, hi_mT=args.hi_mT, tol_mT=args.tol_mT, **kw)
        if args.posterior:
            draws = lab.posterior_samples(args.posterior, args.samples, args.shape, args.preset)
            ds = lab.critical_field_samples(draws, args.freq_hz, args.incline_deg, **bis)
            print(posterior_critical_words(ds, args.lo_mT, args.hi_mT))
        else:
            ds = lab.critical_field(args.freq_hz, args.incline_deg, **bis)
            print(critical_field_words(ds, args.lo_mT, args.hi_mT))
    elif c == "step-out":
        ds = lab.step_out(parse_values("--freq-hz", args.freq_hz), args.field_mT, args.incline_deg, progress=True, **kw)
        print(labelled_table(ds, ["speed", "progress_ratio", "phase_lag_deg", "following_share", "status"]))
        print(step_out_words(ds))
    else:
        ds = lab.steering(field_mT=args.field_mT, freq_hz=args.freq_hz, leg_s=args.leg_s, **kw)
        print(
            f"turn {float(ds['turn_deg']):.2f} deg (legs {ds['heading_deg'].values.round(2).tolist()} deg), field jump "
            f"{float(ds['field_jump_deg']):.1f} deg, failed steps {int(ds['failed_steps'])}, status {int(ds['status'])}"
        )
    return write_dataset(ds, args)


def step_out_words(ds: Any) -> str:
    """The step-out frequency of a :func:`tumblemc.lab.step_out` sweep in a sentence (no NaN: where there is none, why)."""
    f = ds["freq_hz"].values
    lo, hi = float(f.min()), float(f.max())
    so, last = float(ds["step_out_hz"]), float(ds["last_following_hz"])
    if math.isfinite(so):
        band = f" (it follows again at {last:g} Hz: an intermittent band above it)" if math.isfinite(last) and last > so else ""
        return f"step-out frequency: {so:g} Hz{band}"
    if not math.isfinite(last):
        return (
            f"no frequency followed from {lo:g} to {hi:g} Hz: the step-out lies below {lo:g} Hz, "
            f"or {float(ds.attrs['field_mT']):g} mT does not turn the magnet"
        )
    if last >= hi:
        return f"no step-out up to {hi:g} Hz: the robot follows the field at {hi:g} Hz (sweep higher to find it)"
    return f"no step-out found: the robot follows up to {last:g} Hz but no bisection bracket held a crossing"


def critical_field_words(ds: Any, lo_mT: float, hi_mT: float) -> str:
    """The result of :func:`tumblemc.lab.critical_field` in a sentence; outside the bracket, which end and what to change."""
    crit = float(ds["critical_mT"])
    if math.isfinite(crit):
        bracket = ds["bracket_mT"].values.round(4).tolist()
        return f"critical field {crit:.3g} mT (bracket {bracket} mT, {int(ds['n_runs'])} runs)"
    if bool(ds["tumbles_at_lo"]):
        return f"no critical field in [{lo_mT:g}, {hi_mT:g}] mT: the robot already tumbles at {lo_mT:g} mT (lower --lo-mT)"
    return f"no critical field in [{lo_mT:g}, {hi_mT:g}] mT: the robot does not tumble at {hi_mT:g} mT (raise --hi-mT)"


def posterior_critical_words(ds: Any, lo_mT: float, hi_mT: float) -> str:
    """The critical field over posterior draws in a sentence; draws without a crossing in the bracket are counted."""
    crit = ds["critical_mT"].values
    n, k = crit.size, int(math.fsum(1 for c in crit if math.isfinite(c)))
    if k == 0:
        return f"no critical field in [{lo_mT:g}, {hi_mT:g}] mT for any of {n} posterior draws (widen --lo-mT/--hi-mT)"
    lo, hi = ds["critical_mT_5_95"].values
    med = float(ds["critical_mT_median"])
    miss = f" ({n - k} of {n} draws have no crossing in [{lo_mT:g}, {hi_mT:g}] mT and are left out)" if k < n else ""
    return f"critical field over {n} posterior draws: median {med:.3g} mT, 5-95% {lo:.3g}-{hi:.3g} mT{miss}"
