"""Save the landing at a tiny step of ``tests/kernels/test_hard_steps.py`` (``tests/data/tiny_step_landing.npz``).

The paper cuboid on the flat, 20 mT rotating at 239.84375 Hz (a probe of the step-out
bisection at 16 times the default step, ``experiments/step_size.py stepout``), at dt =
1.6276e-8 s (256,000 steps per field turn), integrated with the default options up to the
step before t = 24.134 ms. In that step the hopping robot's long edge, level and already
at the plane, comes down at 0.33 m/s while it slides at 9 mm/s: the impact reverses the
slip, and its forces are the impulse over the step, ``lam_n`` = 5.7e5 weights. One unit in
the last place of the friction cone's row ``(mu lam_n)^2 - (lam_o / e_o)^2`` is then 6e-6,
so no iterate reaches ``tol`` = 1e-9: every strategy and every halving failed (42 s and 3.8
million Newton iterations), until Newton accepted a stall within the rows' rounding
(``tumblemc.kernels.rounding``; docs/notes/step_size.md, "A residual floor at small steps").

Run from the repository root: ``python tests/data/tiny_step_landing.py``. The committed
file was written with the code before that stop (8e6c9ed). With it, earlier steps of the
run also end within rounding, and the state the tool writes now differs by 1e-2 (scaled);
the landing is the same step, but there its best iterate reaches 9.9e-7, within
``SolverOptions.accept_tol`` (1e-6), so the old rule would keep it as loose rather than fail.
The tests keep the committed file, on which the old rule fails.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fast_landings import write_before_step  # noqa: E402

OUT = Path(__file__).resolve().parent / "tiny_step_landing.npz"
RUN = {
    "shape": "cuboid",
    "preset": "paper",
    "incline_deg": 0.0,
    "field_mT": 20.0,
    "freq_hz": 239.84375,
    "periods": 5.8,
    "dt": 1.6276041666666667e-08,
}
STEPS = 1_482_839  # steps taken before the landing


def main() -> None:
    write_before_step(OUT, RUN, STEPS)


if __name__ == "__main__":
    main()
