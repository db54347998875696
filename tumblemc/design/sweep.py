"""The authors' design sweep of the spiked-ends robot, repeated (``tumblemc design sweep``).

Their sweep (as their code does it): spike base and spike height varied together
along the diagonal, 20 designs from 50 to 400 um, one deterministic run per design on
aluminum at 20 mT and 10 Hz (nominal parameters, no uncertainty), the incline raised in
0.125 deg steps until the robot slides, mass, inertia and magnetic volume held fixed.

Here each design is run with both mass rules (:mod:`tumblemc.design.families`):
``fixed`` (theirs) and ``density`` (geometry-derived mass, inertia and magnetic volume).
Per design: the speed on flat aluminum (mean uphill speed after one transient period) and
two critical inclines, found by raising the incline in 1 deg steps from 0 to 45 deg and
then in ``tol`` steps inside the first failing degree (the authors' raise-until-it-slides,
at their resolution, with 8x fewer runs): ``climbs`` is the last incline with tumblemc's
verdict (progress ratio at least 0.5 of the no-slip ideal), ``holds`` the last with net
uphill progress (ratio > 0: the robot does not slide back, the authors' "slides").
"""

from __future__ import annotations

import sys
from typing import Any, cast

import numpy as np
import pandas as pd

from tumblemc.design.families import build
from tumblemc.model.rows import RunRow, TimeGrid, simulate_rows

UM = 1e-6
RULES = ("fixed", "density")


def _ratios(shape: Any, base: dict[str, Any], inclines: np.ndarray, grid: TimeGrid) -> np.ndarray:
    res = simulate_rows(shape, [cast(RunRow, dict(base, incline_deg=float(t))) for t in inclines], grid)
    return np.where(res["status"] == 0, res["progress_ratio"], np.nan)


def first_failure(shape: Any, base: dict[str, Any], tol: float, grid: TimeGrid, success: float, top: float = 45.0) -> tuple[float, float]:
    """(last incline climbed, first incline failed) raising the incline: 1 deg steps, then ``tol`` steps.

    A run climbs when its progress ratio is at least ``success`` (``> 0`` for ``success = 0``:
    net uphill progress, the robot does not slide back); an invalid run counts as a failure.
    """

    def ok(r: np.ndarray) -> np.ndarray:
        return np.nan_to_num(r, nan=-np.inf) > 0 if success == 0 else np.nan_to_num(r, nan=-np.inf) >= success

    coarse = np.arange(0.0, top + 1e-9, 1.0)
    c = ok(_ratios(shape, base, coarse, grid))
    if c.all():
        return top, float("nan")
    k = int(np.argmin(c))
    if k == 0:
        return float("nan"), 0.0
    fine = np.arange(coarse[k - 1] + tol, coarse[k] + 1e-9, tol)
    f = ok(_ratios(shape, base, fine, grid))
    j = int(np.argmin(f)) if not f.all() else len(fine) - 1
    last = coarse[k - 1] if j == 0 else float(fine[j - 1])
    return float(last), float(fine[j])


def authors_sweep(n: int = 20, tol: float = 0.125, progress: bool = False, periods: float = 2.0) -> pd.DataFrame:
    """The sweep: one row per design and mass rule (module docstring)."""
    grid = TimeGrid(periods=periods, transient_periods=1.0, max_failed_steps=1)
    rows = []
    for i, s in enumerate(np.linspace(50 * UM, 400 * UM, n)):
        for rule in RULES:
            des = build("spiked_ends", {"spike_base": float(s), "spike_height": float(s)}, "aluminum", rule)
            base = {"preset": "aluminum", "field_mT": 20.0, "freq_hz": 10.0, **des.overrides()}
            sp = simulate_rows(des.shape, [cast(RunRow, dict(base, incline_deg=0.0))], grid)
            climbs, fails = first_failure(des.shape, base, tol, grid, 0.5)
            holds, slides = first_failure(des.shape, base, tol, grid, 0.0)
            rows.append(
                {
                    "design": i,
                    "spike_um": round(float(s) / UM, 3),
                    "mass_rule": rule,
                    "mass_ug": des.mass * 1e9,
                    "V_m_mm3": des.V_m * 1e9,
                    "hull_perimeter_um": des.shape.hull_perimeter / UM,
                    "speed_mm_s": float(sp["mean_speed"][0]) * 1e3,
                    "speed_status": int(sp["status"][0]),
                    "climbs_deg": climbs,
                    "fails_deg": fails,
                    "holds_deg": holds,
                    "slides_deg": slides,
                }
            )
        if progress:
            print(f"  design {i + 1}/{n}", file=sys.stderr, flush=True)
    return pd.DataFrame(rows)


def sweep_table(df: pd.DataFrame) -> str:
    """Markdown: one row per design, both mass rules side by side."""
    w = df.pivot(index=["design", "spike_um"], columns="mass_rule", values=["speed_mm_s", "climbs_deg", "holds_deg", "mass_ug", "V_m_mm3"])
    lines = [
        "| spike base = height (um) | speed, fixed (mm/s) | speed, density (mm/s) | climbs, fixed (deg) | climbs, density (deg) "
        "| holds, fixed (deg) | holds, density (deg) | mass, density (ug) | V_m, density (mm^3) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for (_, um), r in w.iterrows():
        lines.append(
            f"| {um:.1f} | {r[('speed_mm_s', 'fixed')]:.1f} | {r[('speed_mm_s', 'density')]:.1f} | {r[('climbs_deg', 'fixed')]:.3f} | "
            f"{r[('climbs_deg', 'density')]:.3f} | {r[('holds_deg', 'fixed')]:.3f} | {r[('holds_deg', 'density')]:.3f} | "
            f"{r[('mass_ug', 'density')]:.1f} | {r[('V_m_mm3', 'density')]:.4f} |"
        )
    return "\n".join(lines) + "\n"


__all__ = ["RULES", "authors_sweep", "first_failure", "sweep_table"]
