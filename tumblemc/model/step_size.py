"""The default time step of a run, chosen from what the run must resolve.

The paper's step, 5e-5 s (:data:`CEILING_S`, the largest step of the convergence study
whose verdicts match the finest step at the paper's operating points), is the ceiling.
Below it the step shrinks, as a whole divisor ``5e-5 / k`` (so that a study's check at
``dt / 4`` and a user's ladder stay on the same grid), until it resolves three rates:

- **the field's period**: at least :data:`STEPS_PER_PERIOD` steps per turn of the field.
  A robot that follows a rotating field turns with it; backward Euler's lag accumulates
  every period, and the progress ratio drifts with the step until the period is resolved
  (paper cuboid at 200 Hz: 0.612 at 5e-5, 0.499 at 5e-5/4, 0.465 at 5e-5/16); and
  :data:`STEPS_PER_PERIOD_NEAR` where the field turns faster than :data:`NEAR_FRACTION` of
  the magnet's natural frequency (below), which brings the robot near step-out: there the
  ensemble's P(success) moved from 0.39 at 1000 steps per turn to 0.63 and 0.66 at 16000
  and 64000 (paper cuboid, 20 mT, 200 Hz: 0.64 of its 311 Hz), while at 150 Hz (0.48 of
  it) 1000 and 16000 steps agreed (mean ratio +0.016 +- 0.010);
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
#: steps per field period where the field turns faster than NEAR_FRACTION of the natural frequency
STEPS_PER_PERIOD_NEAR = 16000
#: the share of the magnet's natural frequency (in Hz, ``sqrt(|m||B| / I_min) / 2 pi``) above
#: which a field's period needs STEPS_PER_PERIOD_NEAR steps
NEAR_FRACTION = 0.5
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
    segment_mT: Iterable[float] | None = None,
) -> StepChoice:
    """The default step of a run (see the module docstring).

    ``freq_hz`` may be several frequencies (a field program's segments, ``segment_mT`` their
    field magnitudes, default ``field_mT`` for each): the most demanding counts.
    """
    freqs = [abs(float(f)) for f in (freq_hz if isinstance(freq_hz, Iterable) else [freq_hz])]
    seg = [float(b) for b in segment_mT] if segment_mT is not None else [float(field_mT)] * len(freqs)
    if len(seg) != len(freqs):
        raise ValueError(f"segment_mT has {len(seg)} values for {len(freqs)} frequencies (allowed: one per frequency)")
    wn = natural_frequency(inertia, moment_Am2, field_mT)
    w0 = float(np.linalg.norm(np.asarray(list(omega0), dtype=float)))
    period, f, steps, f_nat = math.inf, 0.0, STEPS_PER_PERIOD, 0.0
    for fi, bi in zip(freqs, seg, strict=True):
        fn = natural_frequency(inertia, moment_Am2, bi) / (2.0 * math.pi)
        ni = STEPS_PER_PERIOD_NEAR if fn > 0 and fi > NEAR_FRACTION * fn else STEPS_PER_PERIOD
        if fi > 0 and 1.0 / (ni * fi) < period:
            period, f, steps, f_nat = 1.0 / (ni * fi), fi, ni, fn
    near = f", above {NEAR_FRACTION:g} of the magnet's natural frequency {f_nat:.4g} Hz" if steps != STEPS_PER_PERIOD else ""
    limits = {
        "ceiling (the paper's step)": CEILING_S,
        f"field period ({steps} steps per turn at {f:g} Hz{near})": period,
        f"natural frequency ({TURN_PER_STEP} rad per step at {wn:.4g} rad/s)": TURN_PER_STEP / wn if wn > 0 else math.inf,
        f"initial spin ({TURN_PER_STEP} rad per step at {w0:.4g} rad/s)": TURN_PER_STEP / w0 if w0 > 0 else math.inf,
    }
    rule = min(limits, key=lambda k: limits[k])
    need = max(1, math.ceil(min(CEILING_S / limits[rule], 1e18) - 1e-9))
    k = min(need, MAX_DIVISOR)
    return StepChoice(dt=CEILING_S / k, divisor=k, rule=rule, needed=need)


__all__ = [
    "CEILING_S",
    "MAX_DIVISOR",
    "NEAR_FRACTION",
    "STEPS_PER_PERIOD",
    "STEPS_PER_PERIOD_NEAR",
    "TURN_PER_STEP",
    "StepChoice",
    "default_step",
    "natural_frequency",
]
