"""``tumblemc simulate``: one run, its netCDF file, its figure and its summary."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from tumblemc.analysis.words import incline_words, verdict_name
from tumblemc.cli.common import (
    EXIT_OK,
    EXIT_RUN_FAILED,
    PRESET_CHOICES,
    PRESET_HELP,
    SHAPE_CHOICES,
    SHAPE_HELP,
    SUMMARY_UNITS,
    format_table,
    parse_overrides,
)
from tumblemc.io import write_run
from tumblemc.kernels.batch import BATCH_ENERGY_GAIN
from tumblemc.model.cost import DEFAULT_MAX_WALL_S
from tumblemc.model.solver_options import ROTATION_OPTIONS, TORQUE_OPTIONS
from tumblemc.schema import STATUS_MEANINGS


def register(sub: Any) -> None:
    """Add this subcommand to the ``tumblemc`` parser."""
    what = "run one simulation and write a netCDF file"
    s = sub.add_parser("simulate", help=what, description=what[0].upper() + what[1:] + ".")
    s.add_argument("--shape", default="cuboid", choices=SHAPE_CHOICES, help=SHAPE_HELP)
    s.add_argument("--preset", default="paper", choices=PRESET_CHOICES, help=PRESET_HELP)
    s.add_argument("--incline-deg", type=float, default=0.0, help="substrate incline, degrees; negative: downhill (default: 0)")
    s.add_argument("--field-mT", type=float, default=20.0, dest="field_mT", help="rotating field magnitude, mT (default: 20)")
    s.add_argument("--freq-hz", type=float, default=1.0, help="field frequency, Hz (default: 1)")
    s.add_argument("--duration-s", type=float, default=2.0, help="simulated time, s (default: 2)")
    s.add_argument("--dt", type=float, default=None, help="time step, s (default: the package default)")
    s.add_argument("--torque", choices=TORQUE_OPTIONS, default="start", help="magnetic torque at the step start (default) or end")
    s.add_argument(
        "--rotation",
        choices=ROTATION_OPTIONS,
        default="momentum",
        help="rotational row: the momentum form (default) or the paper's explicit form",
    )
    s.add_argument("--record-every", type=int, default=1, help="record every k-th step (default: 1)")
    s.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        dest="overrides",
        help="override a parameter, e.g. --set mu=0.4 or --set offset_axis=1,0,0 (repeatable)",
    )
    s.add_argument(
        "--max-wall-s",
        type=float,
        default=DEFAULT_MAX_WALL_S,
        help="wall-time budget, s: a long run is refused if its first steps project more (default: 600; inf: no limit)",
    )
    s.add_argument(
        "--check",
        action="store_true",
        help="also run the step check: the run again at dt / 4 and as 4 twins (magnetisation changed by 1e-6), "
        "and say whether the step sets the answer (within tolerance, limited by dt, sensitive); about 8 times the run's cost",
    )
    s.add_argument("--check-factor", type=int, default=4, help="the step check's finer step is dt / this (2 to 64; default: 4)")
    s.add_argument("--check-twins", type=int, default=4, help="the step check's twins at dt (0 to 64; default: 4)")
    s.add_argument("--out", default="run.nc", help="output netCDF path (default: run.nc)")
    s.add_argument(
        "--plot",
        action="store_true",
        help="also write a PNG figure next to the netCDF file (with --check, the check's too: <out>_check.png)",
    )
    s.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Run one simulation, write it (and its figure), print its summary; returns the exit status (1: the run is not valid)."""
    from tumblemc.model.outcome import summarize
    from tumblemc.model.plausible import run_notes
    from tumblemc.model.run import run_inputs, simulate

    overrides = parse_overrides(args.overrides)
    out = Path(args.out)
    kw = {k: getattr(args, k) for k in ("shape", "preset", "incline_deg", "field_mT", "freq_hz", "duration_s", "dt")}
    kw.update(torque=args.torque, rotation=args.rotation, record_every=args.record_every, **overrides)
    for note in run_notes(run_inputs(**kw)):  # valid, but maybe not what was meant
        print(f"note: {note}", file=sys.stderr)
    check = None
    if args.check:
        from tumblemc.model.step_check import check_step

        check = check_step(**kw, max_wall_s=args.max_wall_s, factor=args.check_factor, twins=args.check_twins, progress=True)
        ds = check.run
    else:
        ds = simulate(**kw, max_wall_s=args.max_wall_s)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_run(ds, out)
    print(f"wrote {out}")
    if args.plot:
        from tumblemc.viz.run import plot_run

        png = out.with_suffix(".png")
        plot_run(ds, png)
        print(f"wrote {png}")
        if check is not None:
            from tumblemc.viz.run import plot_step_check

            png = out.with_name(out.stem + "_check.png")
            plot_step_check(check, png)
            print(f"wrote {png}")
    try:
        summary = summarize(ds)
    except ValueError as exc:
        t = ds["time"].values
        summary = {"duration": float(t[-1] - t[0]), "progress": float(ds["progress"].values[-1]), "status": int(ds.attrs.get("status", 0))}
        print(f"(no steady-state summary: {exc})")
    said = incline_words(args.incline_deg)
    if said:  # negative: downhill, and the verdict is named for it
        print(said)
        summary = {(verdict_name(args.incline_deg) if k == "climbed" else k): v for k, v in summary.items()}
    print(format_table(summary, SUMMARY_UNITS))
    if check is not None:
        print(check.words())
    status = int(ds.attrs.get("status", 0))
    if status != 0:
        meaning = STATUS_MEANINGS.get(status, "see status_meanings")
        if status == BATCH_ENERGY_GAIN:
            meaning += f" ({ds.attrs.get('energy_gain_ratio', float('nan')):.3g} of the run's energy scale)"
        print(f"warning: the run is not valid (status {status}: {meaning}; failed steps {ds.attrs.get('failed_steps')})", file=sys.stderr)
        return EXIT_RUN_FAILED
    return EXIT_OK
