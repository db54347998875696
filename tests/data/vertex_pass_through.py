"""Save the vertex impact of ``tests/kernels/test_hard_steps.py`` (``tests/data/vertex_pass_through.npz``).

Robot 8 of cell 1's 100 (docs/notes/step_size.md; ``experiments/step_size.py ensemble
--cells paper_200Hz``: the paper cuboid on the flat, 20 mT at 200 Hz, its sampled friction,
adhesion, offset and magnetisation below) at 4x finer than the near-step-out default,
7.8125e-8 s, integrated with the default options up to the step before t = 0.242120 s. The
step before put a corner on the plane (converged, 150 weights of normal force) without
stopping it: it moves into the plane at 15.8 (scaled; 0.49 m/s) while the robot turns at
1.2 (scaled) about the normal. No attempt of the ladder solves the impact at any depth.
The impulse rule used to keep, as loose, attempts with 1.7 weights of normal force whose
corner ended one step's travel (3.9e-4 scaled, 39 nm) below the plane; the two steps after
it went 7.7e-4 and 1.16e-3 deep, and the last failed at every depth after 3.9 million
Newton iterations (38 s). Now such an attempt is refused (``contact.IMPULSE_PASS_DEPTH``)
and the rescue pass solves the impact at dt. docs/notes/solver_gaps.md, section 13.

Run from the repository root: ``python tests/data/vertex_pass_through.py`` (about 10 s).
"""

from __future__ import annotations

import sys
from pathlib import Path

from tumblemc.model.fields import Rotating

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fast_landings import write_before_step  # noqa: E402

OUT = Path(__file__).resolve().parent / "vertex_pass_through.npz"
RUN = {
    "shape": "cuboid",
    "preset": "paper",
    "field": Rotating(20.0, 200.0),
    "duration_s": 0.5,
    "dt": 3.125e-7 / 4,
    "record_every": 64,
    "mu": 0.32486643904653656,
    "adhesion_C": 2.77627332552387,
    "offset_deg": 25.145530468446225,
    "magnetization": 12277.95726247537,
}
STEPS = 3_099_129  # steps taken before the step


def main() -> None:
    write_before_step(OUT, RUN, STEPS)


if __name__ == "__main__":
    main()
