"""The dt-convergence table behind the default time step (``tumblemc validate``).

Every row is a plain run of :func:`tumblemc.simulate` at one time step and one torque
option; :func:`default_dt` picks the largest dt whose verdicts and progress ratios agree
with the finest one. Also :func:`timed_run`, the run-and-summarise step of the claims.
"""

from __future__ import annotations

import time
from typing import Any

from tumblemc.model.outcome import summarize
from tumblemc.model.run import simulate

#: time steps of the dt-convergence table, s
CONVERGENCE_DTS = (5e-4, 2.5e-4, 1e-4, 5e-5, 2.5e-5, 1.25e-5)

#: scenarios of the dt-convergence table: (name, keyword arguments of simulate)
CONVERGENCE_CASES: tuple[tuple[str, dict[str, Any]], ...] = (
    ("flat paper 1 Hz", dict(preset="paper", incline_deg=0.0, freq_hz=1.0)),
    ("flat paper 10 Hz", dict(preset="paper", incline_deg=0.0, freq_hz=10.0)),
    ("paper 45 deg", dict(preset="paper", incline_deg=45.0, freq_hz=1.0)),
    ("aluminum 20 deg", dict(preset="aluminum", incline_deg=20.0, freq_hz=1.0)),
    ("aluminum 30 deg", dict(preset="aluminum", incline_deg=30.0, freq_hz=1.0)),
)


def timed_run(periods: float = 2.0, **kw: Any) -> tuple[Any, dict[str, Any], float]:
    """Simulate ``periods`` field periods with ``kw`` and summarise: ``(ds, summary, wall_s)``."""
    t0 = time.perf_counter()
    ds = simulate(duration_s=periods / kw.get("freq_hz", 1.0), **kw)
    s = summarize(ds)
    return ds, s, time.perf_counter() - t0


def convergence(quick: bool = False) -> list[dict[str, Any]]:
    """Progress ratio and verdict against dt for both torque options (issue acceptance)."""
    dts = CONVERGENCE_DTS[:3] if quick else CONVERGENCE_DTS
    out = []
    for name, kw in CONVERGENCE_CASES:
        for torque in ("start", "end"):
            for dt in dts:
                _, s, wall = timed_run(dt=dt, torque=torque, **kw)
                out.append(
                    {
                        "case": name,
                        "torque": torque,
                        "dt": dt,
                        "progress_ratio": s["progress_ratio"],
                        "climbed": s["climbed"],
                        "failed_steps": s["failed_steps"],
                        "loose_steps": s["loose_steps"],
                        "substeps": s["substeps"],
                        "wall_s": wall,
                    }
                )
    return out


def default_dt(table: list[dict[str, Any]], torque: str = "start", rel: float = 0.02) -> tuple[float | None, dict[str, float]]:
    """Largest dt whose verdicts match the finest dt and whose ratios are within ``rel``.

    The ratio criterion applies to cases that climb at the finest dt: there the progress
    ratio measures the accuracy of the gait. A robot that fails slides or tumbles down
    chaotically and its ratio does not converge (the verdict does), so for those cases
    only the verdict must match. Returns the dt and, per case, the largest qualifying dt
    (qualifying dts must be contiguous from the finest).
    """
    cases = sorted({r["case"] for r in table})
    per_case: dict[str, float] = {}
    for c in cases:
        rows = sorted((r for r in table if r["case"] == c and r["torque"] == torque), key=lambda r: r["dt"])
        ref = rows[0]
        best = ref["dt"]
        for r in rows:
            ok = r["climbed"] == ref["climbed"]
            if ref["climbed"]:
                ok = ok and abs(r["progress_ratio"] - ref["progress_ratio"]) <= rel * abs(ref["progress_ratio"])
            if not ok:
                break
            best = r["dt"]
        per_case[c] = best
    return (min(per_case.values()) if per_case else None), per_case
