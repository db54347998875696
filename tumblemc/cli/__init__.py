"""Command line: ``tumblemc simulate | lab | calibrate | validate | stress | study | animate | shapes``.

Also available as ``python -m tumblemc``. One module per subcommand (:data:`SUBCOMMANDS`),
each with ``register(sub)``, which adds its parser and sets ``run`` (its handler) as the
parser's default; :func:`main` parses and calls ``args.run(args)``. What they share (exit
codes, value parsers, tables, ``--set``) is in :mod:`.common`.

Examples::

    tumblemc simulate --incline-deg 20 --set mu=0.4 --out run.nc --plot
    tumblemc study run studies/smoke.toml --workers 2
    tumblemc study status studies/smoke.toml
    tumblemc study plot results/smoke.nc
    tumblemc lab static-tilt --field-mT 3:15:1 --plot
    tumblemc shapes --out shapes.png
    tumblemc animate run.nc --out run.gif
    tumblemc validate --quick --out validation

Invalid inputs (a ValueError from the API) print ``error: <message>`` on stderr and exit
with status 2, like argparse's own usage errors.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from tumblemc.cli.common import EXIT_USAGE, SUMMARY_UNITS, UsageError, format_table, parse_overrides, parse_value
from tumblemc.version import __version__

#: the subcommands, in the order ``tumblemc --help`` lists them: ``tumblemc.cli.<name>``
SUBCOMMANDS = ("simulate", "lab", "calibrate", "validate", "stress", "study", "design", "animate", "shapes")


def build_parser() -> argparse.ArgumentParser:
    """Build the ``tumblemc`` argument parser: each subcommand module registers its own."""
    p = argparse.ArgumentParser(prog="tumblemc", description="Simulate tumbling magnetic microrobots (non-point contact).")
    p.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in SUBCOMMANDS:
        importlib.import_module(f"tumblemc.cli.{name}").register(sub)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``tumblemc`` command; returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version and usage errors
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else EXIT_USAGE)
    try:
        return int(args.run(args))
    except (ValueError, UsageError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as exc:  # an output path that cannot be written
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_USAGE


__all__ = ["SUBCOMMANDS", "SUMMARY_UNITS", "build_parser", "format_table", "main", "parse_overrides", "parse_value"]
