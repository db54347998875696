"""A run's energy ledger in SI units, and the energy check of its outcome status.

The kernels keep the ledger (:mod:`tumblemc.kernels.ledger`, docs/guide/model.md "Energy
ledger"): per committed step the work of every force over the step actually taken,
backward Euler's dissipation, the field's own work and two numerical accounts:

- the *contact gain* (``energy_gain`` column): per step, kinetic energy that no force
  supplied plus any positive work of the normal impulse, which a rigid contact cannot do
  (counted step by step, so that dissipation elsewhere cannot hide it);
- the *energy excess* (``energy_excess``, its running maximum ``energy_excess_max``): the
  mechanical energy (kinetic, magnetic, potential) above its start beyond what the field
  supplied (the magnetic energy's change due to the field's own time variation,
  ``work_field``) and what every non-conservative force did. The torque's work
  ``h T . w+`` is an exchange inside the system; its time discretisation, which the first
  account books as field work, shows up here.

Each account has its tolerance (:data:`ENERGY_GAIN_TOL`, 1%) relative to its own scale.
The contact gain's scale is the one measured on the stress campaign: the field's work
bound ``|m||B| (2 + 2 pi f T)``, the potential energy gravity and the electrostatic force
released, the initial kinetic energy and ``m g x 1e-4 m`` (so that a run without field has
a scale). The energy excess's scale is the energy the run actually received: the same
initial kinetic energy, weight and potential energy released, plus the most magnetic
energy the magnet handed to the body and the magnetic energy's range ``2 |m| max|B|`` (what
a turning magnet exchanges within a turn), not a bound that grows with the frequency. A run
whose larger ratio exceeds 1% gets the outcome status ``energy_gain``: the numbers it
reports rest on energy the model cannot make. Measured in ``docs/notes/energy_ledger.md``.
"""

from __future__ import annotations

import numpy as np

from tumblemc.kernels import layout as L
from tumblemc.kernels.field import field_energy_range
from tumblemc.kernels.field import field_work_bound as kernel_work_bound
from tumblemc.model.frames import quat_to_matrix
from tumblemc.model.units import Units

#: relative tolerance of the numerical energy gain (see the module docstring)
ENERGY_GAIN_TOL = L.ENERGY_GAIN_TOL

LEDGER_COLUMNS = {
    "work_magnetic": L.L_WMAG,
    "work_gravity": L.L_WGRAV,
    "work_electrostatic": L.L_WELECT,
    "work_adhesion": L.L_WADH,
    "work_normal": L.L_WN,
    "work_friction": L.L_WFRIC,
    "numerical_dissipation": L.L_DISS,
    "energy_balance": L.L_BAL,
    "energy_gain": L.L_GAIN,
    "kinetic_energy": L.L_KE,
    "potential_energy_released": L.L_POTMAX,
    "work_field": L.L_WFIELD,
    "energy_excess": L.L_EXCESS,
    "energy_excess_max": L.L_XGAIN,
    "magnetic_exchange": L.L_WMAGX,
    "magnetic_energy_released": L.L_MAGMAX,
}


def field_work_bound(prm: np.ndarray, duration: float) -> float:
    """The most work the field can do on the magnet in ``duration`` (kernel units).

    ``|m||B| (2 + 2 pi f T)`` for the paper's field, summed over the segments of a field
    program (:func:`tumblemc.kernels.field.field_work_bound`, which the batch kernel calls).
    """
    return float(kernel_work_bound(prm, float(duration)))


def energy_reference(prm: np.ndarray, duration: float, ke0: float, released: float) -> float:
    """The energy scale of the contact gain (kernel units).

    The initial kinetic energy + the weight times the length unit + the potential energy
    released (``released``: the most work gravity and the electrostatic force have done
    since the start) + the field work bound.
    """
    return (ke0 + prm[L.P_MASS] * prm[L.P_G] + released) + field_work_bound(prm, duration)  # the batch kernel's order


def energy_received(prm: np.ndarray, ke0: float, released: float, magnetic: float) -> float:
    """The energy scale of the energy excess (kernel units): the energy the run received.

    The initial kinetic energy + the weight times the length unit + the potential energy
    released + the magnetic energy released (``magnetic``: the most energy the magnet has
    handed to the body since the start, ``L_MAGMAX``) + the magnetic energy's range
    ``2 |m| max|B|`` (what a turning magnet exchanges with the body within a turn, whatever
    the field does; not the field's work bound, which grows with the frequency).
    """
    return (ke0 + prm[L.P_MASS] * prm[L.P_G] + released) + (magnetic + float(field_energy_range(prm)))  # the batch kernel's order


def ledger_variables(
    prm: np.ndarray, units: Units, rows: np.ndarray, field_T: np.ndarray, torque_per_tesla: float
) -> dict[str, tuple[str, np.ndarray]]:
    """The ledger's time series (J) for a run Dataset from its record ``rows`` (scaled).

    Also the potential energy of gravity and of the electrostatic force (constant along
    ``-n``) relative to the start, and the magnetic energy ``-V_m (R E_b) . B``
    (``torque_per_tesla``: ``V_m |E|`` in kernel torque units per tesla).
    """
    e = units.energy
    out = {name: ("time", rows[:, L.R_LED + col] * e) for name, col in LEDGER_COLUMNS.items()}
    x = rows[:, L.R_X : L.R_X + 3]
    n = prm[L.P_N : L.P_N + 3]
    pe = prm[L.P_MASS] * prm[L.P_G] * (x[:, 2] - x[0, 2]) + prm[L.P_FELECT] * ((x - x[0]) @ n)
    out["potential_energy"] = ("time", pe * e)
    m_world = quat_to_matrix(rows[:, L.R_Q : L.R_Q + 4]) @ prm[L.P_EB : L.P_EB + 3]
    bmag = np.linalg.norm(field_T, axis=-1)
    bhat = np.divide(field_T, bmag[:, None], out=np.zeros_like(field_T), where=bmag[:, None] > 0)
    if prm[L.P_FPROG] > 0:  # a field program: |B| varies, V_m |E| (R E_b) . B
        out["magnetic_energy"] = ("time", -torque_per_tesla * np.einsum("ij,ij->i", m_world, field_T) * e)
    else:
        out["magnetic_energy"] = ("time", -prm[L.P_TORQ] * np.einsum("ij,ij->i", m_world, bhat) * e)
    return out


def energy_summary(prm: np.ndarray, units: Units, rows: np.ndarray) -> dict[str, float]:
    """A run's energy summary from its record ``rows``.

    ``energy_gain_J``, ``field_work_bound_J``, ``energy_reference_J`` and
    ``energy_gain_ratio`` (gain / reference).
    """
    duration = float(rows[-1, L.R_T] - rows[0, L.R_T])
    last = rows[-1, L.R_LED :]
    ke0 = float(rows[0, L.R_LED + L.L_KE])
    released = float(last[L.L_POTMAX])
    gain, ref = float(last[L.L_GAIN]), energy_reference(prm, duration, ke0, released)
    xgain = float(last[L.L_XGAIN])
    xref = energy_received(prm, ke0, released, float(last[L.L_MAGMAX]))
    return {
        "energy_gain_J": (xgain if xgain * ref > gain * xref else gain) * units.energy,
        "contact_gain_J": gain * units.energy,
        "energy_excess_J": xgain * units.energy,
        "field_work_J": float(last[L.L_WFIELD]) * units.energy,
        "field_work_bound_J": field_work_bound(prm, duration) * units.energy,
        "energy_reference_J": ref * units.energy,
        "energy_received_J": xref * units.energy,
        "contact_gain_ratio": gain / ref,
        "energy_excess_ratio": xgain / xref,
        "energy_gain_ratio": max(gain / ref, xgain / xref),
    }


__all__ = [
    "ENERGY_GAIN_TOL",
    "LEDGER_COLUMNS",
    "energy_received",
    "energy_reference",
    "energy_summary",
    "field_work_bound",
    "ledger_variables",
]
