"""Save the late landing of ``tests/test_late_landing.py`` (``tests/data/late_landing.npz``).

Run 109 of the stress study's violent class (``studies/stress.toml`` restricted to
aluminum, 70 deg and 0.5 Hz, seed 88001: the spiked robot sliding at 20 m/s), integrated
with the default options up to the step before t = 3.45160 s. That step does not converge
at dt and is halved; its second half is a landing whose normal impulse did 1.3e-6 J of
positive work, 99.99% of the run's energy gain (``energy_gain_ratio`` 0.044, status
``energy_gain``), because the landing refinement (``SolverOptions.landing_work``) checked
only a step's first sub-step. docs/solver_gaps.md, section 9.

The state, the warm start and the contact before the step are saved, so the test runs one
step. Run from the repository root: ``python tools/late_landing.py``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from tumblemc.model.run import prepare, run_inputs

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fast_landings import before_step  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "tests" / "data" / "late_landing.npz"
RUN = {
    "shape": "spiked",
    "preset": "aluminum",
    "incline_deg": 70.0,
    "field_mT": 23.974213225682288,
    "freq_hz": 0.5,
    "adhesion_C": 230.26778894935111,
    "mu": 0.7825397772678971,
    "offset_deg": 28.208096218362247,
    "periods": 2.0,
}
STEPS = 69031  # steps taken before the landing


def main() -> None:
    d = before_step(prepare(run_inputs(**RUN)), STEPS)  # type: ignore[arg-type]
    np.savez(OUT, allow_pickle=False, **d)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
