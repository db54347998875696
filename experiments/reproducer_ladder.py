"""Issue 13's reproducer 1 (the snap hop) over a ladder of step sizes (docs/notes/energy_ledger.md).

Prints a markdown table: dt, progress ratio, failed steps, and the progress at the first
landing (t = 0.40 s) and after its slide (t = 0.50 s), where the runs part.
``python experiments/reproducer_ladder.py`` runs the documented ladder (about 4 minutes);
``--dt`` (repeatable) picks step sizes, each dividing the 4 s run.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence

import numpy as np

import tumblemc
from tumblemc.testing import SNAP_HOP

LADDER = (1e-4, 8e-5, 5e-5, 4e-5, 2.5e-5, 2e-5, 1.25e-5, 1e-5, 6.25e-6, 5e-6, 3.125e-6)
DURATION_S = 4.0


def ladder(dts: Sequence[float]) -> list[dict[str, float]]:
    """One row per step size: ratio, failed steps, progress (mm) at 0.40 and 0.50 s."""
    rows = []
    for dt in dts:
        ds = tumblemc.simulate(shape="cuboid", dt=dt, duration_s=DURATION_S, **SNAP_HOP)  # type: ignore[arg-type]
        s = tumblemc.summarize(ds)
        t = ds["time"].values
        p = ds["progress"].values
        at = [float(p[int(np.argmin(np.abs(t - x)))]) * 1e3 for x in (0.40, 0.50)]
        rows.append(
            {
                "dt": dt,
                "progress_ratio": float(s["progress_ratio"]),
                "failed_steps": int(s["failed_steps"]),
                "progress_0.40_mm": at[0],
                "progress_0.50_mm": at[1],
            }
        )
    return rows


def table(rows: list[dict[str, float]]) -> str:
    out = ["| dt (s) | progress ratio | failed steps | progress at 0.40 s (mm) | at 0.50 s (mm) |", "|---|---|---|---|---|"]
    for r in rows:
        cells = (f"{r['dt']:g}", f"{r['progress_ratio']:.2f}", f"{r['failed_steps']:.0f}", f"{r['progress_0.40_mm']:.2f}")
        out.append(f"| {' | '.join(cells)} | {r['progress_0.50_mm']:.2f} |")
    return "\n".join(out)


def main(argv: Sequence[str] | None = None) -> str:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dt", type=float, action="append", help="step size in s (repeatable; default: the documented ladder)")
    args = ap.parse_args(argv)
    for dt in args.dt or []:
        n = DURATION_S / dt
        if not dt > 0 or abs(n - round(n)) > 1e-9 * n:
            ap.error(f"--dt={dt!r} does not divide the {DURATION_S:g} s run (allowed: 4 s / an integer)")
    text = table(ladder(args.dt or LADDER))
    print(text)
    return text


if __name__ == "__main__":
    main()
