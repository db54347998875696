"""``tumblemc shapes``: every shape's profile, hull faces and adhesion areas."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from tumblemc.cli.common import EXIT_OK


def register(sub: Any) -> None:
    """Add this subcommand to the ``tumblemc`` parser."""
    what = "draw every shape's profile, hull faces and adhesion areas"
    sh = sub.add_parser("shapes", help=what, description=what[0].upper() + what[1:] + ".")
    sh.add_argument("--out", default="shapes.png", help="PNG path (default: shapes.png)")
    sh.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Draw the shapes into ``args.out``; returns the exit status."""
    from tumblemc.viz.run import plot_shapes

    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    plot_shapes(path=out)
    print(f"wrote {out}")
    return EXIT_OK
