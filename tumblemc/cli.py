"""Command line: ``tumblemc simulate | validate | stress | study | shapes | animate | bench``.

Also available as ``python -m tumblemc``.

Examples::

    tumblemc simulate --incline-deg 20 --set mu=0.4 --out run.nc --plot
    tumblemc study run studies/smoke.toml --workers 2
    tumblemc study status studies/smoke.toml
    tumblemc study plot results/smoke.nc
    tumblemc shapes --out shapes.png
    tumblemc animate run.nc --out run.gif
    tumblemc validate --quick --out validation
    tumblemc bench --quick --repeats 3

Invalid inputs (a ValueError from the API) print ``error: <message>`` on stderr and exit
with status 2, like argparse's own usage errors.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from tumblemc.cli_lab import (
    PRESET_CHOICES,
    PRESET_HELP,
    SHAPE_CHOICES,
    SHAPE_HELP,
    add_calibrate_parser,
    add_lab_parser,
    cmd_calibrate,
    cmd_lab,
)
from tumblemc.cli_study import add_study_parser, cmd_study
from tumblemc.io import write_run
from tumblemc.model.params import Params
from tumblemc.model.run import ROTATION_OPTIONS, TORQUE_OPTIONS
from tumblemc.version import __version__

EXIT_OK = 0
EXIT_RUN_FAILED = 1
EXIT_USAGE = 2


class _UsageError(Exception):
    """Bad command-line input detected by the CLI itself (exit status 2)."""


# --------------------------------------------------------------------------- parsing


def parse_value(text: str) -> Any:
    """Parse a ``--set`` value.

    ``true``/``false`` -> bool, a number -> float, ``a,b,c`` -> tuple of floats (e.g.
    ``offset_axis=1,0,0``); anything else stays a string (the API rejects it with a message
    naming the parameter).
    """
    low = text.strip().lower()
    if low in ("true", "yes", "on"):
        return True
    if low in ("false", "no", "off"):
        return False
    try:
        return float(text)
    except ValueError:
        pass
    if "," in text:
        try:
            return tuple(float(part) for part in text.split(","))
        except ValueError:
            pass
    return text


def parse_overrides(items: Sequence[str] | None) -> dict[str, Any]:
    """``["mu=0.4", "offset_deg=10"]`` -> ``{"mu": 0.4, "offset_deg": 10.0}``."""
    out: dict[str, Any] = {}
    for item in items or ():
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or not name or not value.strip():
            raise _UsageError(f"--set {item!r} is not NAME=VALUE (allowed: e.g. --set mu=0.4)")
        if name in out:
            raise _UsageError(f"--set {name} given twice (allowed: once per parameter)")
        if name not in Params.field_names():
            raise _UsageError(
                f"--set {name}: unknown parameter (allowed: {', '.join(Params.field_names())}; options such as --dt have their own flags)"
            )
        out[name] = parse_value(value)
    return out


#: units of the run summary (:func:`tumblemc.summarize`) as the CLI prints it; names not
#: listed are counts or ratios
SUMMARY_UNITS = {
    "mean_speed": "m/s",
    "ideal_speed": "m/s",
    "max_penetration": "m",
    "mean_slip_speed": "m/s",
    "energy_gain_J": "J",
    "field_work_bound_J": "J",
    "lateral_drift": "m",
    "heading_change_deg": "deg",
    "duration": "s",
    "progress": "m",
}


def format_table(d: dict[str, Any], units: dict[str, str] | None = None) -> str:
    """Aligned ``name  value [unit]`` lines."""
    if not d:
        return ""
    width = max(len(k) for k in d)
    lines = []
    for k, v in d.items():
        if isinstance(v, float) and not isinstance(v, bool):
            text = f"{v:.6g}" if math.isfinite(v) else str(v)
        else:
            text = str(v)
        unit = (units or {}).get(k)
        lines.append(f"{k:<{width}}  {text}" + (f" {unit}" if unit else ""))
    return "\n".join(lines)


def build_parser() -> argparse.ArgumentParser:
    """Build the ``tumblemc`` argument parser with its subcommands."""
    p = argparse.ArgumentParser(prog="tumblemc", description="Simulate tumbling magnetic microrobots (non-point contact).")
    p.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    what = "run one simulation and write a netCDF file"
    s = sub.add_parser("simulate", help=what, description=what[0].upper() + what[1:] + ".")
    s.add_argument("--shape", default="cuboid", choices=SHAPE_CHOICES, help=SHAPE_HELP)
    s.add_argument("--preset", default="paper", choices=PRESET_CHOICES, help=PRESET_HELP)
    s.add_argument("--incline-deg", type=float, default=0.0, help="substrate incline, degrees (default: 0)")
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
    s.add_argument("--out", default="run.nc", help="output netCDF path (default: run.nc)")
    s.add_argument("--plot", action="store_true", help="also write a PNG figure next to the netCDF file")

    def add_set(q: argparse.ArgumentParser) -> None:
        q.add_argument(
            "--set", action="append", default=[], metavar="NAME=VALUE", dest="overrides", help="override a parameter (repeatable)"
        )

    add_lab_parser(sub, add_set)
    add_calibrate_parser(sub, add_set)

    what = "run the validation suite and write its report"
    v = sub.add_parser("validate", help=what, description=what[0].upper() + what[1:] + ".")
    v.add_argument("--out", default="validation", help="output directory (default: validation)")
    v.add_argument("--quick", action="store_true", help="reduced, faster suite")

    what = "run the stress campaign (a wide-range study and 3-D runs) and write its report"
    sp = sub.add_parser("stress", help=what, description=what[0].upper() + what[1:] + " (issue 13; docs/stress.md).")
    sp.add_argument("--quick", action="store_true", help="the CI size: studies/stress_quick.toml and 8 3-D runs")
    sp.add_argument("--config", default=None, help="study TOML (default: studies/stress.toml, or stress_quick.toml with --quick)")
    sp.add_argument("--result", default=None, help="study result netCDF (default: results/<study name>.nc; resumed if present)")
    sp.add_argument("--out", default="docs", help="report folder for stress.md and stress.png (default: docs)")
    sp.add_argument("--n3d", type=int, default=None, help="3-D runs (default: 100, or 8 with --quick)")
    sp.add_argument("--workers", type=int, default=None, help="local worker processes (default: all cores; 0: no dask)")

    add_study_parser(sub)

    what = "animate a saved run (side view GIF or MP4)"
    an = sub.add_parser(
        "animate",
        help=what,
        description="Animate a run written by `tumblemc simulate --out run.nc`: body outline, field arrow, contact point, adhesion.",
    )
    an.add_argument("run", help="netCDF of one run (tumblemc simulate --out)")
    an.add_argument("--out", default=None, help="GIF or MP4 path (default: the run's name with .gif)")
    an.add_argument("--fps", type=float, default=25.0, help="frames per second (default: 25)")
    an.add_argument("--max-frames", type=int, default=300, help="frames at most (default: 300)")
    an.add_argument("--speed", type=float, default=None, help="simulated seconds per wall second (default: fit max-frames)")

    what = "draw every shape's profile, hull faces and adhesion areas"
    sh = sub.add_parser("shapes", help=what, description=what[0].upper() + what[1:] + ".")
    sh.add_argument("--out", default="shapes.png", help="PNG path (default: shapes.png)")

    sub.add_parser(
        "bench",
        help="run the benchmarks (arguments are passed on, e.g. --quick --repeats 3)",
        description="Run the benchmarks; all further arguments go to tumblemc.stepcost.",
        add_help=False,
        prefix_chars="\0",  # parse nothing: every argument is passed through
    )
    return p


# --------------------------------------------------------------------------- commands


def _cmd_simulate(args: argparse.Namespace) -> int:
    from tumblemc.model.outcome import summarize
    from tumblemc.model.run import simulate

    overrides = parse_overrides(args.overrides)
    out = Path(args.out)
    ds = simulate(
        shape=args.shape,
        preset=args.preset,
        incline_deg=args.incline_deg,
        field_mT=args.field_mT,
        freq_hz=args.freq_hz,
        duration_s=args.duration_s,
        dt=args.dt,
        torque=args.torque,
        rotation=args.rotation,
        record_every=args.record_every,
        **overrides,
    )
    out.parent.mkdir(parents=True, exist_ok=True)
    write_run(ds, out)
    print(f"wrote {out}")
    if args.plot:
        from tumblemc.viz.run import plot_run

        png = out.with_suffix(".png")
        plot_run(ds, png)
        print(f"wrote {png}")
    try:
        summary = summarize(ds)
    except ValueError as exc:
        t = ds["time"].values
        summary = {"duration": float(t[-1] - t[0]), "progress": float(ds["progress"].values[-1]), "status": int(ds.attrs.get("status", 0))}
        print(f"(no steady-state summary: {exc})")
    print(format_table(summary, SUMMARY_UNITS))
    status = int(ds.attrs.get("status", 0))
    if status != 0:
        meaning = {
            1: "a step did not converge",
            2: "the state became non-finite",
            4: f"the energy ledger's numerical gain is {ds.attrs.get('energy_gain_ratio', float('nan')):.3g} of the run's energy scale",
        }.get(status, "see status_meanings")
        print(f"warning: the run is not valid (status {status}: {meaning}; failed steps {ds.attrs.get('failed_steps')})", file=sys.stderr)
        return EXIT_RUN_FAILED
    return EXIT_OK


def _cmd_stress(args: argparse.Namespace) -> int:
    from tumblemc.stress import run_campaign

    config = Path(args.config or ("studies/stress_quick.toml" if args.quick else "studies/stress.toml"))
    if not config.exists():
        raise _UsageError(f"--config {config} does not exist (run from the repository root, or give --config)")
    result = Path(args.result or f"results/{config.stem}.nc")
    n3d = args.n3d if args.n3d is not None else (8 if args.quick else 100)
    if n3d < 1:
        raise _UsageError(f"--n3d={n3d} is not allowed (allowed: an integer >= 1)")
    path = run_campaign(config, result, args.out, n3d, args.workers, quick=args.quick)
    print(f"wrote {path}")
    return EXIT_OK


def _cmd_validate(args: argparse.Namespace) -> int:
    from tumblemc.claims import run_validation

    return int(run_validation(out_dir=args.out, quick=args.quick))


def _cmd_animate(args: argparse.Namespace) -> int:
    from tumblemc.viz.animation import animate_result

    if args.max_frames < 2:
        raise _UsageError(f"--max-frames {args.max_frames} is not allowed (allowed: >= 2)")
    if not args.fps > 0:
        raise _UsageError(f"--fps {args.fps} is not allowed (allowed: > 0)")
    out = Path(args.out) if args.out else Path(args.run).with_suffix(".gif")
    path = animate_result(args.run, out, fps=args.fps, max_frames=args.max_frames, speed=args.speed)
    print(f"wrote {path}")
    return EXIT_OK


def _cmd_shapes(args: argparse.Namespace) -> int:
    from tumblemc.viz.run import plot_shapes

    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    plot_shapes(path=out)
    print(f"wrote {out}")
    return EXIT_OK


def _cmd_bench(rest: list[str]) -> int:
    from tumblemc.stepcost import main as bench_main

    rc = bench_main(rest)
    return int(rc or 0)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``tumblemc`` command; returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    try:
        args, rest = parser.parse_known_args(argv)
        if rest and args.command != "bench":
            parser.error(f"unrecognized arguments: {' '.join(rest)}")
    except SystemExit as exc:  # --help, --version and usage errors
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else EXIT_USAGE)
    try:
        if args.command == "simulate":
            return _cmd_simulate(args)
        if args.command == "validate":
            return _cmd_validate(args)
        if args.command == "stress":
            return _cmd_stress(args)
        if args.command == "bench":
            return _cmd_bench(rest)
        if args.command == "study":
            return cmd_study(args, format_table, _UsageError)
        if args.command == "shapes":
            return _cmd_shapes(args)
        if args.command == "animate":
            return _cmd_animate(args)
        if args.command == "calibrate":
            return cmd_calibrate(args, parse_overrides(args.overrides))
        if args.command == "lab":
            return cmd_lab(args, parse_overrides(args.overrides))
    except (ValueError, _UsageError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as exc:  # an output path that cannot be written
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    parser.print_usage(sys.stderr)  # pragma: no cover - argparse requires a command
    return EXIT_USAGE


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
