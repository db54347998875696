"""Save the vertex landing of ``tests/kernels/test_hard_steps.py`` (``tests/data/vertex_rest.npz``).

One of the 100 robots of cell 1 of docs/notes/step_size.md (``experiments/step_size.py
ensemble --cells paper_200Hz``, robot 9: the paper cuboid on the flat, 20 mT at 200 Hz, its
sampled friction, adhesion, offset and magnetisation below) at the default step near
step-out, 3.125e-7 s, integrated with the default options up to the step before t =
0.148143 s. In flight, spinning at 590 rad/s (66 rad/s about the normal), a corner 7e-6
(scaled) above the plane comes down at 0.08 (scaled) and lands within the step: the
torsional friction (``e_r`` = 0.1 m) stops the turn about the normal, with a normal force
of 905 weights. Plain Newton from the zero-velocity vertex guess converges in 6
iterations; the ladder tries that guess only in a smoothing continuation, which stalls, and
every other start stalls between 1.5e-6 and 0.04: the step fails at every depth and in the
rescue pass as it was. That plain attempt is now the rescue pass's own last one
(``guesses.N_RESCUE_ONLY``), which solves the step at dt.

Run from the repository root: ``python tests/data/vertex_rest.py`` (it writes the committed
file bit for bit: the rescue-only attempt changes no step before the failing one).
"""

from __future__ import annotations

import sys
from pathlib import Path

from tumblemc.model.fields import Rotating

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fast_landings import write_before_step  # noqa: E402

OUT = Path(__file__).resolve().parent / "vertex_rest.npz"
RUN = {
    "shape": "cuboid",
    "preset": "paper",
    "field": Rotating(20.0, 200.0),
    "duration_s": 0.5,
    "mu": 0.2854624675879812,
    "adhesion_C": 3.23017738300122,
    "offset_deg": 30.821248738684492,
    "magnetization": 15686.035244465533,
}
STEPS = 474_056  # steps taken before the landing


def main() -> None:
    write_before_step(OUT, RUN, STEPS)


if __name__ == "__main__":
    main()
