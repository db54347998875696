"""Early decisions: the most a run can still climb, from its energy.

A run climbs when its uphill progress over the measurement window reaches ``need`` (the
success ratio x the no-slip speed x the window). At a time ``t`` in the window, the rest of
the run can add at most :func:`climb_bound` to the progress; once

    progress(t) + climb_bound(t) < need

the verdict is failure whatever the rest of the run does, and the run may stop
(:func:`tumblemc.kernels.stepper.run` with ``opts[O_DECIDE] == 2``).

The bound, from the energy ledger's balance over ``[t, T]`` (MODEL.md, "Energy ledger";
``kernels/ledger.py``), for a run that ends valid:

- kinetic energy at ``T`` is at least 0 and at ``t`` is ``KE(t)``;
- gravity's work is exactly ``-m g`` times the rise of the centre of mass (the position
  update is ``x+ = x + h v+``): ``-m g sin(theta) dp - m g cos(theta) dz``, ``dp`` along
  the uphill direction ``u`` and ``dz`` along the normal ``n``. The height ``z`` along
  ``n`` cannot fall below 0 (the centre of mass is inside the robot, the robot above the
  plane), so ``-m g cos(theta) dz <= m g cos(theta) z(t)``; the same holds for the
  electrostatic force (constant, along ``-n``): ``F_e z(t)``;
- the field does at most ``field_work_between(t, T)`` on the magnet in the continuous
  model (the magnetic energy's range plus the work of the field's turning; the ledger's
  bound). The ledger's discrete work ``h T_m . w+`` with the start-of-step torque exceeds
  it by about ``1/2 h |m||B|`` times the integral of ``|w|^2`` for a magnet that rattles
  fast (an order-one share at 1500 rad/s), and backward Euler's dissipation of the same
  oscillation removes it again: what the bound uses is that the discrete work *minus*
  the dissipation stays within the field's bound (assumed; on a planar rotor at 1500
  rad/s it reached 0.2 of it);
- friction and the normal impulse do no positive work that the ledger does not count as
  numerical gain (``L_GAIN`` takes every step's positive normal work; friction opposes the
  slip at a converged step, while a loose step may leave it a round-off of positive
  work), and a valid run gains at most ``ENERGY_GAIN_TOL`` x its energy scale. The scale
  is taken with the potential energy released up to ``t``: a robot that first slides
  further down and then climbs back would have 1% of that extra release as more
  tolerance, which the bound leaves out (metres of descent and return to matter);
- the electrostatic force is a potential only when it also acts in flight (the default);
  in contact only, nothing is decided;
- adhesion is assumed to do no net positive work over ``[t, T]``. It is an attractive
  force in contact only (MODEL.md), so it does negative work when the robot lifts and
  positive work only while the centre of mass descends in contact.

Adhesion and the discrete magnetic work are what the bound assumes rather than proves;
every grid study audits it on its check runs, which run to the end (``decided_time``
against their verdicts; docs/early_decisions.md).

So ``m g sin(theta) (p(T) - p(t)) <= KE(t) + W_field(t, T) + (m g cos(theta) + F_e) z(t)
+ tolerance left``. The bound is loose (the field's work reaches at most 0.84 of its
bound over any stretch of 80 audited runs; docs/kernel_experiments.md): it decides
sliders, never a success (nothing bounds how fast a robot falls), and never on a flat plane.
"""

from __future__ import annotations

import math

from ._jit import jit
from .field import field_work_between
from .layout import (
    ENERGY_GAIN_TOL,
    L_GAIN,
    L_KE,
    L_POTMAX,
    P_ELECT_FLIGHT,
    P_FELECT,
    P_G,
    P_MASS,
    P_N,
    P_U,
)

DECIDE_EVERY = 20  # steps between two evaluations of the bound (1 ms at the default dt)


@jit
def climb_bound(prm, x, led, t, t_end, eref0):  # type: ignore[no-untyped-def]
    """The most uphill progress (scaled length, along ``u``) the centre of mass at ``x``
    can still make between ``t`` and ``t_end``, with the ledger ``led`` at ``t`` and
    ``eref0`` = initial kinetic energy + ``m g`` x length unit + the field's work bound over
    the run (the energy scale without the potential energy released). ``inf`` on a plane
    that does not rise along ``u``."""
    wg = prm[P_MASS] * prm[P_G] * prm[P_U + 2]  # m g sin(theta)
    if wg <= 0.0:
        return math.inf
    if prm[P_FELECT] > 0.0 and prm[P_ELECT_FLIGHT] < 0.5:
        # the electrostatic force in contact only is no potential: a hop that rises free and
        # comes down in contact gains F_e x its height each time (no bound here)
        return math.inf
    zc = prm[P_N] * x[0] + prm[P_N + 1] * x[1] + prm[P_N + 2] * x[2]
    fn = prm[P_MASS] * prm[P_G] * prm[P_N + 2] + prm[P_FELECT]  # m g cos(theta) + F_e
    tol_left = max(ENERGY_GAIN_TOL * (eref0 + led[L_POTMAX]) - led[L_GAIN], 0.0)
    e = led[L_KE] + field_work_between(prm, t, t_end) + fn * max(zc, 0.0) + tol_left
    return e / wg


__all__ = ["DECIDE_EVERY", "climb_bound"]
