"""Coverage of the calibration posterior on synthetic static-tilt data (docs/calibration.md).

    python tools/calibration_coverage.py [N_REP]

Draws N_REP (default 1000) data sets from the closed-form edge balance of the paper's
cuboid at F_elect = 2.5e-6 N, offset_deg = 22 (3 to 15 mT, noise 0.5 deg), calibrates each
(free: F_elect, offset_deg; closed-form model) and prints, per parameter, the share of 95%
posterior intervals that hold the truth. CI runs 120 replicates (tests/test_calibrate.py).
"""

from __future__ import annotations

import sys
import time

from tumblemc.calibrate import coverage


def main() -> None:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 1000
    t = time.perf_counter()
    cov = coverage(n, progress=True)
    se = (0.95 * 0.05 / n) ** 0.5
    print(f"{n} replicates, {time.perf_counter() - t:.0f} s; binomial standard error at 95%: {se:.3f}")
    for p in cov["param"].values:
        print(f"{p:>12s}: coverage {float(cov['coverage'].sel(param=p)):.3f}, mean 95% width {float(cov['mean_width'].sel(param=p)):.4g}")


if __name__ == "__main__":
    main()
