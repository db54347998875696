"""The default time step of a run, chosen from what the run must resolve.

The paper's step, 5e-5 s (:data:`CEILING_S`, the largest step of the convergence study
whose verdicts match the finest step at the paper's operating points), is the ceiling.
Below it the step shrinks, as a whole divisor ``5e-5 / k`` (so that a study's check at
``dt / 4`` and a user's ladder stay on the same grid), until it resolves three rates:

- **the field's period**: at least :data:`STEPS_PER_PERIOD` steps per turn of the field.
  A robot that follows a rotating field turns with it; backward Euler's lag accumulates
  every period, and the progress ratio drifts with the step until the period is resolved
  (paper cuboid at 200 Hz: 0.612 at 5e-5, 0.499 at 5e-5/4, 0.465 at 5e-5/16);
- **the magnet's natural frequency** ``sqrt(|m||B| / I)`` (``I`` the smallest principal
  moment): at most :data:`TURN_PER_STEP` radians per step. At the paper's operating points
  (aluminum, 20 mT) this is 0.29 rad at 5e-5 s; at 100 mT the magnet snaps 2.2 times as
  fast;
- **the initial spin** ``|omega0|``: at most :data:`TURN_PER_STEP` radians per step.

A user's explicit ``dt`` always wins. The rule and the rate that set the step are in the
run's attributes (``dt_rule``). Measured in ``docs/notes/step_size.md``
(``experiments/step_size.py``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

#: the paper's step, s: the ceiling of the default
CEILING_S = 5e-5
#: steps per field period the default resolves at least
STEPS_PER_PERIOD = 1000
#: radians per step the default allows at the magnet's natural frequency and the initial spin
TURN_PER_STEP = 0.3
#: the finest default step, as a divisor of the ceiling (5e-5 / 10000 = 5 ns)
MAX_DIVISOR = 10000


@dataclass(frozen=True)
class StepChoice:
    """A default step and why: ``dt`` (s), ``divisor`` (``CEILING_S / dt``) and ``rule``."""

    dt: float
    divisor: int
    rule: str
    needed: int = 1  # the divisor the rule asked for, before the cap MAX_DIVISOR


def natural_frequency(inertia: np.ndarray, moment_Am2: float, field_mT: float) -> float:
    """The magnet's natural angular frequency, rad/s: ``sqrt(|m||B| / I_min)``.

    ``inertia`` the body-frame inertia (kg m^2), ``moment_Am2`` the magnetic moment
    ``V_m |E|`` (A m^2), ``field_mT`` the field's peak magnitude.
    """
    i_min = float(np.linalg.eigvalsh(np.asarray(inertia, dtype=float)).min())
    torque = abs(moment_Am2) * abs(field_mT) * 1e-3
    return math.sqrt(torque / i_min) if i_min > 0.0 and torque > 0.0 else 0.0


def default_step(
    inertia: np.ndarray,
    moment_Am2: float,
    field_mT: float,
    freq_hz: float | Iterable[float],
    omega0: Iterable[float] = (0.0, 0.0, 0.0),
) -> StepChoice:
    """The default step of a run (see the module docstring).

    ``freq_hz`` may be several frequencies (a field program's segments): the fastest counts.
    """
    freqs = [abs(float(f)) for f in (freq_hz if isinstance(freq_hz, Iterable) else [freq_hz])]
    f = max(freqs, default=0.0)
    wn = natural_frequency(inertia, moment_Am2, field_mT)
    w0 = float(np.linalg.norm(np.asarray(list(omega0), dtype=float)))
    limits = {
        "ceiling (the paper's step)": CEILING_S,
        f"field period ({STEPS_PER_PERIOD} steps per turn at {f:g} Hz)": 1.0 / (STEPS_PER_PERIOD * f) if f > 0 else math.inf,
        f"natural frequency ({TURN_PER_STEP} rad per step at {wn:.4g} rad/s)": TURN_PER_STEP / wn if wn > 0 else math.inf,
        f"initial spin ({TURN_PER_STEP} rad per step at {w0:.4g} rad/s)": TURN_PER_STEP / w0 if w0 > 0 else math.inf,
    }
    rule = min(limits, key=lambda k: limits[k])
    need = max(1, math.ceil(min(CEILING_S / limits[rule], 1e18) - 1e-9))
    k = min(need, MAX_DIVISOR)
    return StepChoice(dt=CEILING_S / k, divisor=k, rule=rule, needed=need)


__all__ = ["CEILING_S", "MAX_DIVISOR", "STEPS_PER_PERIOD", "TURN_PER_STEP", "StepChoice", "default_step", "natural_frequency"]
