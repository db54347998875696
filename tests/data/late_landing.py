"""Save the late landings of ``tests/kernels/test_hard_steps.py`` (``tests/data/late_landing.npz``).

Run 109 of the stress study's violent class (``studies/stress.toml`` restricted to
aluminum, 70 deg and 0.5 Hz, seed 88001: the spiked robot sliding at 20 m/s), integrated
with the default options up to the step before t = 3.45160 s. That step does not converge
at dt and is halved; its second half is a landing whose normal impulse did 1.3e-6 J of
positive work, 99.99% of the run's energy gain (``energy_gain_ratio`` 0.044, status
``energy_gain``), because the landing refinement (``SolverOptions.landing_work``) checked
only a step's first sub-step. docs/notes/solver_gaps.md, section 9.

Run 386 of the same class (the curved robot sliding at 17 m/s), integrated with the
default options up to the step before t = 3.83800 s: a landing whose normal impulse does
2.0e-6 J of positive work at dt, and whose refinement's first half-step does not converge.
With ``SolverOptions(refine_halvings=0)`` the refinement is refused and the step kept at dt
with that work; by default the half-step is halved again (docs/notes/solver_gaps.md, section 10).

The state, the warm start and the contact before each step are saved (the second case with
keys prefixed ``halve_``), so the test runs one step. Run from the repository root: ``python tests/data/late_landing.py``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from tumblemc.model.run import prepare, run_inputs

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fast_landings import before_step  # noqa: E402

OUT = Path(__file__).resolve().parent / "late_landing.npz"
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
    "dt": 5e-5,  # the step it was found at (the default at this field is now 2.5e-5 s)
}
STEPS = 69031  # steps taken before the landing
RUN_HALVE = {
    "shape": "curved",
    "preset": "aluminum",
    "incline_deg": 70.0,
    "field_mT": 30.731046403282114,
    "freq_hz": 0.5,
    "adhesion_C": 52.15060398025141,
    "mu": 0.5866561928138672,
    "offset_deg": 9.213948934233612,
    "periods": 2.0,
    "dt": 5e-5,  # the step it was found at (the default at this field is now 2.5e-5 s)
}
STEPS_HALVE = 76759
# each saved case: its keys' prefix -> (the run, steps taken before the landing)
CASES = {"": (RUN, STEPS), "halve_": (RUN_HALVE, STEPS_HALVE)}


def main() -> None:
    d = {}
    for prefix, (run, steps) in CASES.items():
        saved = before_step(prepare(run_inputs(**run)), steps)  # type: ignore[arg-type]
        d.update({f"{prefix}{k}": v for k, v in saved.items()})
    np.savez(OUT, allow_pickle=False, **d)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
