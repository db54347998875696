"""``tumblemc animate``: a saved run as a side-view GIF or MP4."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from tumblemc.cli.common import EXIT_OK, UsageError


def register(sub: Any) -> None:
    """Add this subcommand to the ``tumblemc`` parser."""
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
    an.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Write the animation of ``args.run``; returns the exit status."""
    from tumblemc.viz.animation import animate_result

    if args.max_frames < 2:
        raise UsageError(f"--max-frames {args.max_frames} is not allowed (allowed: >= 2)")
    if not args.fps > 0:
        raise UsageError(f"--fps {args.fps} is not allowed (allowed: > 0)")
    out = Path(args.out) if args.out else Path(args.run).with_suffix(".gif")
    path = animate_result(args.run, out, fps=args.fps, max_frames=args.max_frames, speed=args.speed)
    print(f"wrote {path}")
    return EXIT_OK
