"""Newton's rounding floor at small steps: a fast spin in free flight (docs/notes/step_size.md).

The paper cuboid 1 mm above the plane, 20 mT rotating at 212.5 Hz, 0.3 ms, spinning about x
at 1000-4000 rad/s, at the default step of 212.5 Hz (2.94e-7 s) and 4 and 16 times finer:
Newton iterations per step, strategy fallbacks, loose steps and the largest residual, with
the default tolerance and with it loosened to 1e-8. Run it on a checkout before
``kernels.newton.rounding_floor`` for the "before" column.

    python experiments/rounding_floor.py
"""

from __future__ import annotations

import time

import tumblemc as tm
from tumblemc.model.solver_options import SolverOptions


def main() -> None:
    print("| spin (rad/s) | step (s) | tol | Newton iterations per step | fallbacks | loose steps | largest residual | wall (s) |")
    print("|---|---|---|---|---|---|---|---|")
    for w in (1000.0, 2000.0, 3000.0, 4000.0):
        for dt in (2.941e-7, 2.941e-7 / 4, 2.941e-7 / 16):
            for tol in (1e-9, 1e-8):
                t0 = time.perf_counter()
                ds = tm.simulate(
                    "cuboid", "paper", 0.0, 20.0, 212.5, duration_s=3e-4, dt=dt, lift_m=1e-3, omega0=(w, 0.0, 0.0),
                    max_wall_s=None, solver=SolverOptions(tol=tol),
                )  # fmt: skip
                n = ds.sizes["time"] - 1
                print(
                    f"| {w:.0f} | {dt:.3g} | {tol:.0e} | {float(ds['newton_iterations'].sum()) / n:.2f} | {int(ds['fallbacks'].sum())} "
                    f"| {int(ds['loose'].sum())} | {float(ds['residual'].max()):.1e} | {time.perf_counter() - t0:.1f} |",
                    flush=True,
                )


if __name__ == "__main__":
    main()
