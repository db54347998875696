"""Rewrite a study file of an earlier form in the current one, values unchanged.

    python tools/upgrade_result.py data/example.nc [--out NEW.nc]

Files written before the string labels took their dimension's name store them as
``shape_label``/``substrate_label`` (or, earlier, as netCDF-4 ``string`` coordinate
variables): ``tumblemc.open_result`` reads them, plain xarray cannot ``.sel(shape=...)``.
This reads the file with ``open_result`` and writes it again with
``tumblemc.io.write_result`` (tumblemc.ncformat: char strings, labels under their
dimension's name), keeping every value and attribute; the root gains ``data_groups``,
``comment`` and ``date_modified``, and ``history`` a line. Without ``--out`` the file is
replaced (atomically). Rerunning a study rewrites its file too, but with the values of the
code that reruns it.
"""

from __future__ import annotations

import argparse
import datetime as dt
from pathlib import Path

from tumblemc.io import open_result, result_attrs, write_result
from tumblemc.version import __version__


def upgrade(path: Path, out: Path | None = None) -> Path:
    """Write ``path`` in the current form to ``out`` (default: over ``path``); return where."""
    runs, maps = open_result(path)
    attrs = result_attrs(path)
    now = dt.datetime.now(dt.UTC).replace(microsecond=0).isoformat()
    line = f"{now} tumblemc {__version__} tools/upgrade_result.py: rewritten in the current netCDF form, values unchanged"
    attrs["history"] = f"{attrs['history']}\n{line}" if attrs.get("history") else line
    attrs["date_modified"] = now
    target = out or path
    write_result(target, runs, maps, attrs)
    return target


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("study", type=Path, help="a study file (tumblemc study run)")
    ap.add_argument("--out", type=Path, help="write here instead of replacing the file")
    args = ap.parse_args(argv)
    print(f"wrote {upgrade(args.study, args.out)}")


if __name__ == "__main__":
    main()
