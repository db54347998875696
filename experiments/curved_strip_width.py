"""The curved robot on aluminum: its critical incline against the strip width (issue 45, item 5).

The validation's C7 rows (20 mT, 1 Hz, 2 field periods, the default dt; strip rule of
line adhesion) have the curved robot climbing 30 deg of aluminum, which the paper says it
fails. This script measures what that verdict rests on:

- the critical incline (the largest incline climbed, progress ratio >= 0.5) of the curved
  robot for several ``line_contact_width`` (0, half the default, the default, 2x, 5x), by
  bisection between 20 and 40 deg to 0.1 deg (``tumblemc.reports.climbers.critical_incline``,
  which the validation's C7c and S4 rows use), and a scan at 1 deg from 20 to 40 deg, which
  shows whether the verdict is monotone in the incline (the bisection assumes it), and a
  scan at 0.02 deg 0.3 deg either side of the bisection's bracket (the highest incline
  climbed and the lowest failed there: how sharp the threshold is);
- the same at the default width for the cuboid, spiked and spiked-ends robots, and for the
  curved robot at dt/2;
- the curved robot's progress ratio at 30 deg at dt, dt/2 and dt/4;
- where it touches at 30 deg (default width): the share of steps rolling on the interior of
  its outer arc, pivoting on the outer or inner edges of its radial end faces, on the
  inner chord (line contacts, each with the strip's adhesion), lying on an end face, and
  in flight;
- the static limit, the steepest incline on which friction can hold the robot in line
  contact with the strip's adhesion pressing it on: ``m g sin(theta) = mu (m g cos(theta)
  + F_elect + C w l)`` with ``l`` the robot's thickness (the length of its contact line),
  from the model's force law (docs/guide/model.md, "Forces";
  ``tumblemc.reports.climbers.line_static_limit_deg``).

    python experiments/curved_strip_width.py [--quick]

Prints markdown tables (copied into docs/notes/curved_strip_width.md). About 4 minutes of
one core after compilation.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

import tumblemc
from tumblemc.model.params import PRESETS
from tumblemc.model.run import DEFAULT_DT
from tumblemc.model.shapes.library import get_shape
from tumblemc.reports.climbers import critical_incline, line_static_limit_deg

#: the C7 rows' settings (tumblemc/reports/claims.py, shape_claims; timed_run's 2 periods)
C7 = {"preset": "aluminum", "field_mT": 20.0, "freq_hz": 1.0, "duration_s": 2.0}
DEFAULT_W = PRESETS["aluminum"].line_contact_width  # 5e-6 m
WIDTHS = (0.0, 2.5e-6, 5e-6, 10e-6, 25e-6)


def ratio(shape: str, incline: float, **kw: Any) -> float:
    """Progress ratio of one C7 run."""
    return float(tumblemc.summarize(tumblemc.simulate(shape=shape, incline_deg=float(incline), **C7, **kw))["progress_ratio"])


def scan(shape: str, lo: int = 20, hi: int = 40, **kw: Any) -> dict[int, float]:
    """Progress ratios on a 1-deg scan of ``lo..hi``."""
    return {th: ratio(shape, th, **kw) for th in range(lo, hi + 1)}


def fine(shape: str, lo: float, hi: float, **kw: Any) -> tuple[float, float]:
    """Highest incline climbed and lowest failed on a 0.02-deg scan 0.3 deg either side of ``[lo, hi]``."""
    ths = np.round(np.arange(lo - 0.3, hi + 0.3001, 0.02), 3)
    r = np.array([ratio(shape, th, **kw) for th in ths])
    up, down = ths[r >= 0.5], ths[r < 0.5]
    return (float(up.max()) if up.size else np.nan), (float(down.min()) if down.size else np.nan)


def monotone(sc: dict[int, float]) -> bool:
    """Whether the scan climbs up to some incline and fails above it."""
    v = [r >= 0.5 for r in sc.values()]
    return v == sorted(v, reverse=True)


def contact_shares(ds: Any) -> dict[str, float]:
    """Share of steps by where the curved robot touches (body-frame ECP against the hull)."""
    shp = get_shape("curved")
    zc = -shp.cm_shift[1]  # centre of curvature, body z
    r_out, r_in, half = 1250e-6, 1100e-6, 25.0
    q = ds["quaternion"].values[1:]
    pos = ds["position"].values[1:]
    ecp = ds["ecp"].values[1:]
    mode = ds["contact_mode"].values[1:]
    w, x, y, z = q.T
    # rows of R (body to world); body = R^T (ecp - pos)
    R = np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        1,
    )
    rb = np.einsum("nji,nj->ni", R, ecp - pos)
    d = np.hypot(rb[:, 1], rb[:, 2] - zc)
    ang = np.degrees(np.arctan2(rb[:, 1], rb[:, 2] - zc))
    n = len(mode)
    area = ds["contact_area"].values[1:]
    strip = DEFAULT_W * 400e-6  # C w l / C: one contact line of the default strip
    line = mode == 1
    edge = np.abs(ang) >= half - 0.05
    outer = line & (np.abs(d - r_out) < 2e-7)
    inner = line & (np.abs(d - r_in) < 2e-7) & edge
    return {
        "outer arc, interior (rolling)": (outer & ~edge).sum() / n,
        "outer edges of the end faces (pivoting)": (outer & edge).sum() / n,
        "inner edges of the end faces (pivoting)": inner.sum() / n,
        "inner chord (both inner edges)": (line & ~outer & ~inner & (np.abs(area - 2 * strip) < 1e-3 * strip)).sum() / n,
        "other line or point contact": (line & ~outer & ~inner & (np.abs(area - 2 * strip) >= 1e-3 * strip)).sum() / n,
        "end face (face contact)": (mode == 2).sum() / n,
        "flight": (mode == 0).sum() / n,
        "line contact with the strip's adhesion (C w l or 2 C w l)": (line & (area > 0.5 * strip)).sum() / n,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="only the default width and 0")
    args = ap.parse_args()
    t0 = time.perf_counter()
    widths = (0.0, DEFAULT_W) if args.quick else WIDTHS

    def row(shape: str, **kw: Any) -> str:
        lo, hi = critical_incline(shape, **kw)
        sc = scan(shape, **kw)
        lim = line_static_limit_deg(shape, **{k: v for k, v in kw.items() if k == "line_contact_width"})
        top, bottom = fine(shape, lo, hi, **kw)
        tail = "<!-- scan: " + ", ".join(f"{th}: {r:.3g}" for th, r in sc.items()) + " -->"
        return f"{lo:.2f}-{hi:.2f} | {top:.2f} / {bottom:.2f} | {lim:.2f} | {'yes' if monotone(sc) else 'no'} | {sc[30]:.3f} |\n{tail}"

    print("## Critical incline of the curved robot against line_contact_width (C7 settings)\n")
    print(
        "| line_contact_width | critical incline (deg) | highest climbed / lowest failed at 0.02 deg "
        "| static limit (deg) | monotone on the 1-deg scan | ratio at 30 deg |"
    )
    print("|---|---|---|---|---|---|")
    for wdt in widths:
        print(f"| {wdt * 1e6:g} um | " + row("curved", line_contact_width=wdt), flush=True)

    print("\n## dt at 30 deg (curved, default width)\n")
    print("| dt | progress ratio |")
    print("|---|---|")
    for k in (1, 2, 4):
        print(f"| dt/{k} ({DEFAULT_DT / k:g} s) | {ratio('curved', 30.0, dt=DEFAULT_DT / k):.4f} |", flush=True)
    lo, hi = critical_incline("curved", dt=DEFAULT_DT / 2)
    print(f"\ncritical incline at dt/2: {lo:.2f}-{hi:.2f} deg\n", flush=True)

    print("## Contact of the curved robot at 30 deg (default width, every step)\n")
    ds = tumblemc.simulate(shape="curved", incline_deg=30.0, **C7)
    print("| where | share of steps |")
    print("|---|---|")
    for k, v in contact_shares(ds).items():
        print(f"| {k} | {100 * v:.1f}% |")

    print("\n## Critical incline of the four shapes at the default width\n")
    print(
        "| shape | critical incline (deg) | highest climbed / lowest failed at 0.02 deg "
        "| static limit in line contact (deg) | monotone on the 1-deg scan | ratio at 30 deg |"
    )
    print("|---|---|---|---|---|---|")
    for shape in ("cuboid", "spiked", "spiked_ends", "curved"):
        print(f"| {shape} | " + row(shape), flush=True)
    print(f"\n({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
