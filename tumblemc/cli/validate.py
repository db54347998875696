"""``tumblemc validate``: the paper's claims, the shape comparison and the dt-convergence table."""

from __future__ import annotations

import argparse
from typing import Any


def register(sub: Any) -> None:
    """Add this subcommand to the ``tumblemc`` parser."""
    what = "run the validation suite and write its report"
    v = sub.add_parser("validate", help=what, description=what[0].upper() + what[1:] + ".")
    v.add_argument("--out", default="validation", help="output directory (default: validation)")
    v.add_argument("--quick", action="store_true", help="reduced, faster suite")
    v.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Run the validation suite and write its report; returns the exit status."""
    from tumblemc.reports.claims import run_validation

    return int(run_validation(out_dir=args.out, quick=args.quick))
