"""Save the stalled smoothing step of ``tests/kernels/test_hard_steps.py`` (``tests/data/stall_step.npz``).

The curved robot sliding down aluminum at 35 deg (``tumblemc.simulate(shape="curved",
preset="aluminum", incline_deg=35, duration_s=2)``, the default options with
``stall_window = 0``) integrated up to the step before t = 0.82665 s. That step is refined
down to dt / 64; 119 of its smoothing attempts run to their 300-iteration limit without
converging (42,244 Newton iterations in one step, 35,700 of them in those attempts), and
the step is kept loose from a plain attempt (residual 2.2e-7, within ``accept_tol``).
docs/notes/kernel_experiments.md, "A stall window for the smoothing continuation".

The state, the warm start and the contact before the step are saved, so the test runs one
step. Run from the repository root: ``python tests/data/stall_step.py``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from tumblemc.model.run import prepare, run_inputs
from tumblemc.model.solver_options import SolverOptions

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fast_landings import before_step  # noqa: E402

OUT = Path(__file__).resolve().parent / "stall_step.npz"
RUN = {"shape": "curved", "preset": "aluminum", "incline_deg": 35.0, "duration_s": 2.0}
STEPS = 16532  # steps taken before the stalled step


def main() -> None:
    sp = prepare(run_inputs(**RUN, solver=SolverOptions(stall_window=0)))  # type: ignore[arg-type]
    d = before_step(sp, STEPS)
    np.savez(OUT, allow_pickle=False, **d)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
