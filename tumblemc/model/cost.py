"""The wall-time guard of a single run: probe its first steps, project the whole run, refuse it beyond a budget.

A plausible run can still cost an hour: a 1e-12 kg robot needs a 3.8e-7 s default step
(five million steps for 2 s), and at a coarse step its stiff contact solve takes tens of
milliseconds a step. The step count alone does not say which: the cost of a step ranges
from 1 us to 0.1 s. So before a long run, :func:`check_cost` runs its first steps (the
same inputs, a shorter clock), takes the cost of a step (CPU time of the thread, which
other processes on the machine do not inflate) from the difference between two probe
lengths (what a first call and the first steps from rest cost cancels), and projects the
whole run. Beyond ``max_wall_s`` the run is refused in one line; otherwise it runs from
its start as before, so its record is the same bit for bit.

A run starts at rest, and its later steps (tumbling, landings) can cost more than its first:
the projection takes them at :data:`LATER_STEPS_FACTOR` times the first steps' cost. It is
an estimate, not a bound: most runs take less (0.1 to 4.3 times the first steps' rate),
and a run may take more (the 1e-12 kg robot at its default step, over 12 times).

Only single runs are guarded (:func:`tumblemc.model.run.simulate`); a study's runs are
bounded by its step budget (:mod:`tumblemc.study.budget`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from time import thread_time
from typing import Any

#: the default wall-time budget of a single run, s
DEFAULT_MAX_WALL_S = 600.0
#: the dearest step measured in the plausible ranges, s (mass 1e-12 kg at dt 5e-5 s: its stiff
#: contact solve takes 35-90 ms a step): a run of at most ``max_wall_s / DEAREST_STEP_S``
#: steps fits its budget without a probe (12,000 steps at the default)
DEAREST_STEP_S = 0.05
#: runs of at most this many steps are never probed: the probe (about 1 ms at the paper's
#: point) would be a noticeable part of them
MIN_PROBED_STEPS = 1000
#: the probe's lengths, steps: the first two always run, the others while they fit in
#: PROBE_WALL_S and the projection is not clear of the budget
PROBE_STEPS = (2, 16, 128, 1024)
#: the probe's own time, s (CPU time of the calling thread, immune to other processes on the
#: machine): a longer probe is not started if it may not fit, at twice the last cost of a
#: step (a step costs more once the robot moves: 14 to 35 ms at mass 1e-12 kg, dt 5e-5 s)
PROBE_WALL_S = 3.0
#: a projection below this fraction of the budget ends the probe
CLEAR = 0.1
#: the timing noise of a probe, as a fraction of its time
NOISE = 0.05
#: the projection's factor on the first steps' cost for the later steps: a run starts at
#: rest, and once it moves (tumbling, landings) a step can cost more. Measured: 13 runs
#: (the paper's points, 200 Hz, the plausible extremes) took 0.1 to 4.3 times the first
#: steps' rate in all; the 1e-12 kg robot at its default step more than 12 times (its
#: first 1.3 million steps took over 10 minutes of CPU, 37 us a step at the start).
LATER_STEPS_FACTOR = 10.0


@dataclass(frozen=True)
class Projection:
    """A run's projected wall time (s), from ``probed`` steps at ``per_step`` s a step."""

    seconds: float
    per_step: float
    probed: int


def check_max_wall(max_wall_s: Any) -> float:
    """``max_wall_s`` as a float (``None``: no limit, ``inf``), else a ValueError."""
    if max_wall_s is None:
        return math.inf
    if isinstance(max_wall_s, bool) or not isinstance(max_wall_s, (int, float)) or not max_wall_s > 0:
        raise ValueError(f"max_wall_s={max_wall_s!r} is not allowed (allowed: a number of seconds > 0, inf or None for no limit)")
    return float(max_wall_s)


def project(n_steps: int, run_first: Callable[[int], object], budget: float = math.inf) -> Projection:
    """Run the first steps (``run_first(n)`` runs the first ``n``) and project the wall time of ``n_steps``.

    The cost of a step is the difference of the last two probes' times over their
    difference in steps (a first call's load and the first steps from rest cancel); the
    projection is the last probe's time plus :data:`LATER_STEPS_FACTOR` times that for the
    remaining steps. Probing stops when the projection is below ``CLEAR * budget`` or the
    next probe would not fit in :data:`PROBE_WALL_S`. A difference below :data:`NOISE` of
    the probe's time (a first step from rest can cost 0.5 s, the next ones 20 us) is taken
    at that: an upper bound, which a longer probe tightens.
    """
    spent, n_prev, t_prev, per_step, seconds = 0.0, 0, 0.0, 0.0, math.inf
    for i, n in enumerate(PROBE_STEPS):
        if n >= n_steps or (i >= 2 and (seconds < CLEAR * budget or spent + t_prev + 2 * per_step * (n - n_prev) > PROBE_WALL_S)):
            break
        t0 = thread_time()
        run_first(n)
        t = thread_time() - t0
        spent += t
        if n_prev:  # a difference within the timing noise bounds the cost of a step instead of measuring it
            per_step = max(t - t_prev, NOISE * t) / (n - n_prev)
            seconds = t + LATER_STEPS_FACTOR * per_step * (n_steps - n)
        n_prev, t_prev = n, t
    return Projection(seconds=seconds, per_step=per_step, probed=n_prev)


def check_cost(n_steps: int, dt: float, run_first: Callable[[int], object], max_wall_s: Any = DEFAULT_MAX_WALL_S) -> Projection | None:
    """Refuse a run of ``n_steps`` steps of ``dt`` whose projected wall time exceeds ``max_wall_s``.

    A run short enough to fit the budget at :data:`DEAREST_STEP_S` a step (or of at most
    :data:`MIN_PROBED_STEPS` steps), and any run with ``max_wall_s`` None or inf, is not
    probed (returns None); else returns the :class:`Projection` of a run that fits.

    Raises
    ------
    ValueError
        One line: the projection, the steps, the measured cost of a step and what to do.
    """
    budget = check_max_wall(max_wall_s)
    if n_steps <= max(MIN_PROBED_STEPS, budget / DEAREST_STEP_S):
        return None
    p = project(n_steps, run_first, budget)
    if p.seconds > budget:
        about = f"{p.seconds:,.0f}" if p.seconds >= 10 else f"{p.seconds:.2f}"
        raise ValueError(
            f"max_wall_s={budget:g}: this run could take {about} s of wall time ({n_steps:,} steps of dt={dt:.3g} s: its first "
            f"{p.probed} steps cost {p.per_step * 1e3:.3g} ms a step, and later steps up to {LATER_STEPS_FACTOR:g} times more once "
            "the robot moves; allowed: a run projected within max_wall_s): "
            "shorten duration_s, give a coarser dt, or raise max_wall_s (None: no limit)"
        )
    return p


__all__ = [
    "CLEAR",
    "DEAREST_STEP_S",
    "DEFAULT_MAX_WALL_S",
    "LATER_STEPS_FACTOR",
    "MIN_PROBED_STEPS",
    "NOISE",
    "PROBE_STEPS",
    "PROBE_WALL_S",
    "Projection",
    "check_cost",
    "check_max_wall",
    "project",
]
