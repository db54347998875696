"""``tumblemc stress``: the stress campaign (a wide-range study and 3-D runs) and its report."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from tumblemc.cli.common import EXIT_OK, UsageError


def register(sub: Any) -> None:
    """Add this subcommand to the ``tumblemc`` parser."""
    what = "run the stress campaign (a wide-range study and 3-D runs) and write its report"
    sp = sub.add_parser("stress", help=what, description=what[0].upper() + what[1:] + " (docs/stress.md).")
    sp.add_argument("--quick", action="store_true", help="the CI size: studies/stress_quick.toml and 8 3-D runs")
    sp.add_argument("--config", default=None, help="study TOML (default: studies/stress.toml, or stress_quick.toml with --quick)")
    sp.add_argument("--result", default=None, help="study result netCDF (default: results/<study name>.nc; resumed if present)")
    sp.add_argument(
        "--out",
        default="results",
        help="report folder for stress.md and stress.png (default: results; the project's own report is --out docs)",
    )
    sp.add_argument("--n3d", type=int, default=None, help="3-D runs (default: 100, or 8 with --quick)")
    sp.add_argument("--workers", type=int, default=None, help="local worker processes (default: all cores; 0: no dask)")
    sp.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Run the stress campaign and write its report; returns the exit status."""
    from tumblemc.reports.stress import run_campaign

    config = Path(args.config or ("studies/stress_quick.toml" if args.quick else "studies/stress.toml"))
    if not config.exists():
        raise UsageError(f"--config {config} does not exist (run from the repository root, or give --config)")
    result = Path(args.result or f"results/{config.stem}.nc")
    n3d = args.n3d if args.n3d is not None else (8 if args.quick else 100)
    if n3d < 1:
        raise UsageError(f"--n3d={n3d} is not allowed (allowed: an integer >= 1)")
    path = run_campaign(config, result, args.out, n3d, args.workers, quick=args.quick)
    print(f"wrote {path}")
    return EXIT_OK
