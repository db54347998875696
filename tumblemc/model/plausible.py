"""Plausibility of a run's inputs beyond the one range table (:data:`~tumblemc.model.params.RANGES`).

The range table bounds every parameter and magnitude one by one. A run adds what only the
run knows: the initial motion (``v0``, ``omega0``, vectors), the solver options' type, and
whether the default time step can resolve the run at all (a strong magnet on a light body,
or a fast initial spin, may need a step below the finest default). Each refusal is one
``ValueError`` line naming the input, the value, what is allowed and why.

:func:`run_notes` words the runs that are valid but do nothing a user may have meant: a
field switched off, a field that does not turn, a robot without a magnetic moment. The
CLI prints them; they change no result.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from tumblemc.model.params import check_vector
from tumblemc.model.solver_options import SolverOptions
from tumblemc.model.step_size import CEILING_S, MAX_DIVISOR, StepChoice

#: the largest initial angular speed, rad/s: above the fastest field in range (10 kHz =
#: 6.3e4 rad/s), and the default step resolves it (0.3 rad per step) at a divisor of 17
MAX_SPIN_RAD_S = 1e5
#: the largest initial speed, m/s: a 0.1 mm robot then crosses its own size in 0.1 ms, two
#: of the paper's steps
MAX_SPEED_M_S = 1.0
_MOTION = {
    "omega0": (MAX_SPIN_RAD_S, "rad/s", "above the fastest field in range (10 kHz = 6.3e4 rad/s) no field drives such a spin"),
    "v0": (MAX_SPEED_M_S, "m/s", "at 1 m/s a 0.1 mm robot crosses its own size every two default steps"),
}


def check_motion(name: str, vec: Any) -> tuple[float, float, float]:
    """``v0`` or ``omega0`` as a finite 3-tuple of plausible magnitude (:data:`MAX_SPEED_M_S`, :data:`MAX_SPIN_RAD_S`)."""
    v = check_vector(name, vec)
    limit, units, why = _MOTION[name]
    size = float(np.linalg.norm(v))
    if size > limit:
        raise ValueError(f"{name}={vec!r} is implausible: |{name}| = {size:.3g} {units} (allowed: |{name}| <= {limit:g} {units}; {why})")
    return v


def check_solver(solver: Any) -> SolverOptions:
    """``solver`` if it is a :class:`SolverOptions` (``None``: the defaults), else a ValueError."""
    if solver is None:
        return SolverOptions()
    if not isinstance(solver, SolverOptions):
        raise ValueError(f"solver={solver!r} is not allowed (allowed: None or a tumblemc.model.solver_options.SolverOptions)")
    return solver


def check_resolved(choice: StepChoice) -> tuple[float, str]:
    """The default step and its rule; a ValueError if the rule needs a step below the finest default.

    Such a run would turn its magnet (or its initial spin) by more than the default's
    0.3 rad per step at the finest default, ``CEILING_S / MAX_DIVISOR`` (5 ns), and cost
    at least ``MAX_DIVISOR`` times the steps of the paper's run.
    """
    if choice.needed > MAX_DIVISOR:
        raise ValueError(
            f"dt=None: the default time step cannot resolve this run: its {choice.rule} needs dt <= {CEILING_S / choice.needed:.3g} s, "
            f"below the finest default {CEILING_S / MAX_DIVISOR:.3g} s (allowed: a weaker magnet, a heavier body or a slower spin; "
            "or give dt to run it anyway)"
        )
    return choice.dt, choice.rule


def run_notes(inputs: Any) -> list[str]:
    """What a valid run will not do that a user may expect (a :class:`~tumblemc.model.run.RunInputs`), one line each."""
    p = inputs.params
    notes = []
    if inputs.field_mT == 0.0:
        notes.append("the field is off (field_mT = 0): only gravity, contact and the initial motion move the robot")
    elif inputs.program is None and inputs.freq_hz == 0.0:
        notes.append("freq_hz = 0: the field does not turn (a static field along the uphill direction); the robot tilts once at most")
    if p.V_m * p.magnetization == 0.0:
        notes.append(
            f"the magnetic moment is zero (V_m = {p.V_m:g} m^3, magnetization = {p.magnetization:g} A/m): the field exerts no torque"
        )
    return notes


__all__ = ["MAX_SPEED_M_S", "MAX_SPIN_RAD_S", "check_motion", "check_resolved", "check_solver", "run_notes"]
