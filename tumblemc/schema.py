"""The one schema of tumblemc outputs.

Every variable, coordinate and flag, with units, long_name, CF ``standard_name`` where
one exists, and flag values and meanings.

Declared here once and carried into Datasets by :func:`annotate` (or ``attrs.update``):
a run's time series (:data:`RUN_VARIABLES`), a study's coordinates
(:data:`COORD_ATTRS`), run outcomes (:data:`OUTCOMES`, :data:`OUTCOME_ATTRS`), maps
(:data:`MAP_VARIABLES`), the critical-incline outcomes and the numerical checks
(:data:`GRID_CHECK_VARIABLES`, :data:`CRITICAL_CHECK_VARIABLES`), and the status flags
(:data:`STATUS_FLAGS`, :data:`CONTACT_MODE_FLAGS`). A study file's root attributes are
:data:`STUDY_FILE_ATTRS` plus those :func:`tumblemc.study.assemble.provenance` builds; its
groups hold only their own (:data:`MAPS_FROM_RUNS_ATTRS`).

CF standard names exist for few of these quantities: the table (geoscience) has no
magnetic flux density, rotation frequency, friction coefficient, incline of a bench plane
(``ground_slope_angle`` is the Earth's surface) or success probability, and its ``time``
is a time coordinate, whose units CF wants with a reference date (``s since ...``, CF
4.4): a run's time since its own start has none, so no variable carries a standard name.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from tumblemc.kernels import batch as KB

CONTACT_MODE_FLAGS = {"flag_values": np.array([0, 1, 2], dtype=np.int8), "flag_meanings": "none point_or_line face"}


RUN_VARIABLES: dict[str, dict[str, Any]] = {
    "time": {"units": "s", "long_name": "time since the start of the run"},
    "xyz": {"long_name": "world axis (label)"},
    "quat": {"long_name": "quaternion component, scalar first (label)"},
    "progress": {"units": "m", "long_name": "uphill progress of the centre of mass along the plane"},
    "position": {"units": "m", "long_name": "centre-of-mass position (world frame)"},
    "quaternion": {"units": "1", "long_name": "orientation quaternion, scalar first (body to world)"},
    "velocity": {"units": "m s-1", "long_name": "centre-of-mass velocity (world frame)"},
    "omega": {"units": "rad s-1", "long_name": "angular velocity (world frame)"},
    "normal_force": {"units": "N", "long_name": "normal contact force (sum over pieces)"},
    "adhesion_force": {"units": "N", "long_name": "adhesion force C*A from this step's contact mode (applied in the next step)"},
    "contact_area": {"units": "m2", "long_name": "adhering contact area"},
    "contact_mode": {"units": "1", "long_name": "contact mode", **CONTACT_MODE_FLAGS},
    "slip_speed": {"units": "m s-1", "long_name": "tangential slip speed at the equivalent contact point"},
    "ecp": {"units": "m", "long_name": "equivalent contact point on the robot (world frame; NaN in flight)"},
    "newton_iterations": {"units": "1", "long_name": "Newton iterations in the step (free-flight prediction included)"},
    "residual": {"units": "1", "long_name": "final max-norm of the scaled residual in the step"},
    "fallbacks": {
        "units": "1",
        "long_name": "damped (Levenberg-Marquardt) or gradient Newton steps plus extra solve strategies in the step",
    },
    "substeps": {"units": "1", "long_name": "extra sub-steps (halvings of dt) in the step"},
    "penetration": {"units": "m", "long_name": "depth of the robot below the plane at the end of the step"},
    "failed": {"units": "1", "long_name": "steps whose solve did not converge at the smallest sub-step"},
    "loose": {
        "units": "1",
        "long_name": "steps with a (sub-)step kept unsolved: without halving at a residual between the solver's tol and accept_tol, "
        "or at the smallest sub-step balancing momentum to impulse_accept_tol",
    },
    "impulse_kept": {
        "units": "1",
        "long_name": "steps with a (sub-)step kept unsolved at the smallest sub-step because it balances momentum to impulse_accept_tol "
        "(also counted in loose)",
    },
    "field": {"units": "T", "long_name": "magnetic flux density B (world frame)"},
    "work_magnetic": {"units": "J", "long_name": "work of the magnetic torque since the start (h T_m . w+ per step)"},
    "work_gravity": {"units": "J", "long_name": "work of gravity since the start"},
    "work_electrostatic": {"units": "J", "long_name": "work of the electrostatic force since the start"},
    "work_adhesion": {"units": "J", "long_name": "work of the adhesion force since the start"},
    "work_normal": {"units": "J", "long_name": "work of the normal contact impulses since the start (positive: numerical)"},
    "work_friction": {"units": "J", "long_name": "work of friction (tangential and torsional) since the start"},
    "numerical_dissipation": {"units": "J", "long_name": "backward Euler's dissipation 1/2 dV . M dV since the start (impacts included)"},
    "energy_balance": {
        "units": "J",
        "long_name": "kinetic energy gained beyond the work of all forces and the dissipation, since the start",
    },
    "energy_gain": {
        "units": "J",
        "long_name": "numerical energy gain since the start: per step max(balance + max(normal work, 0), 0)",
    },
    "kinetic_energy": {"units": "J", "long_name": "kinetic energy"},
    "potential_energy_released": {"units": "J", "long_name": "most work gravity and the electrostatic force have done since the start"},
    "work_field": {"units": "J", "long_name": "work of the field: the magnetic energy's change due to the field's own time variation"},
    "energy_excess": {
        "units": "J",
        "long_name": "mechanical energy above its start beyond the field's work and every non-conservative force's (numerical)",
    },
    "energy_excess_max": {"units": "J", "long_name": "the most the energy excess has reached since the start"},
    "magnetic_exchange": {"units": "J", "long_name": "magnetic energy the body's rotation released (what the torque's work approximates)"},
    "magnetic_energy_released": {"units": "J", "long_name": "most magnetic energy the magnet has handed to the body since the start"},
    "potential_energy": {"units": "J", "long_name": "potential energy of gravity and of the electrostatic force, relative to the start"},
    "magnetic_energy": {"units": "J", "long_name": "magnetic energy -V_m (R E_b) . B"},
}


def sampled_name(param: str) -> str:
    """Run-table variable of a sampled parameter.

    ``field_mT`` is a cell coordinate, so its sampled value is ``field_mT_sampled``.
    """
    return "field_mT_sampled" if param == "field_mT" else param


def annotate(ds: xr.Dataset, schema: dict[str, dict[str, Any]] | None = None) -> xr.Dataset:
    """Attach the attributes of ``schema`` to every variable of ``ds`` it names (in place).

    ``schema`` defaults to a run's, :data:`RUN_VARIABLES`. Returns ``ds``.
    """
    for name, attrs in (RUN_VARIABLES if schema is None else schema).items():
        if name in ds.variables:
            ds[name].attrs.update(attrs)
    return ds


CI_METHODS = ("wilson", "clopper-pearson", "confidence-sequence", "confidence-sequence-ends")


CELL_DIMS = ("shape", "incline_deg", "substrate")


SWEEP_DIMS = ("field_mT", "freq_hz")  # dims of the maps only when the study sweeps them


COORD_ATTRS: dict[str, dict[str, str]] = {
    "shape": {"long_name": "robot shape"},
    "substrate": {"long_name": "substrate preset"},
    "incline_deg": {"units": "degree", "long_name": "incline angle of the plane"},
    "field_mT": {"units": "mT", "long_name": "magnitude of the rotating magnetic field"},
    "freq_hz": {"units": "Hz", "long_name": "rotation frequency of the magnetic field"},
    "quantile": {"units": "1", "long_name": "quantile level"},
}


MAP_VARIABLES: dict[str, dict[str, str]] = {
    "p_success": {
        "units": "1",
        "long_name": "fraction of valid runs that climbed (n_success / n_valid)",
        "ancillary_variables": "p_success_lower p_success_upper n_valid n_failed",
    },
    "p_success_lower": {"units": "1", "long_name": "lower bound of the confidence interval of p_success"},
    "p_success_upper": {"units": "1", "long_name": "upper bound of the confidence interval of p_success"},
    "n_success": {"units": "1", "long_name": "number of valid runs that climbed"},
    "n_valid": {"units": "1", "long_name": "number of valid runs (status ok)"},
    "n_failed": {"units": "1", "long_name": "number of runs that are not valid (status not ok)"},
    "p_success_invalid_as_failure": {
        "units": "1",
        "long_name": "fraction of all runs that climbed, counting invalid runs as failures (n_success / n_runs)",
    },
    "p_success_invalid_as_success": {
        "units": "1",
        "long_name": "fraction of all runs, counting invalid runs as successes ((n_success + n_failed) / n_runs)",
    },
    "n_runs": {"units": "1", "long_name": "number of runs"},
    "progress_ratio_mean": {"units": "1", "long_name": "mean progress ratio over valid runs (NaN where a run was decided early)"},
    "progress_ratio_quantile": {
        "units": "1",
        "long_name": (
            "quantiles of the progress ratio over valid runs; where runs were decided early (final ratio below the success"
            " threshold), exact at or above the threshold and NaN below"
        ),
    },
    "mean_speed_mean": {"units": "m s-1", "long_name": "mean uphill speed over valid runs (NaN where a run was decided early)"},
    "check_within_tol_share": {
        "units": "1",
        "long_name": "share of the cell's dt-check runs whose progress ratios at dt and dt / check_dt_factor agree within tolerance",
        "ancillary_variables": "n_check_compared",
    },
    "n_check_compared": {"units": "1", "long_name": "dt-check runs of the cell valid at both time steps"},
    "n_check_dt_limited": {
        "units": "1",
        "long_name": "dt-check runs of the cell outside the ratio tolerance whose sensitivity twins stay within it (limited by dt)",
    },
    "n_check_sensitive": {
        "units": "1",
        "long_name": "dt-check runs of the cell whose sensitivity twins move the ratio beyond the tolerance (not determined by the model)",
    },
    "n_decided_early": {
        "units": "1",
        "long_name": "runs stopped by an early decision (failures whose final ratio is only known to be below the success threshold)",
    },
}


#: outcome columns of :func:`simulate_rows`, with their dtypes
OUTCOMES: dict[str, type] = {
    "progress_ratio": np.float64,
    "mean_speed": np.float64,
    "progress": np.float64,
    "climbed": np.int8,
    "status": np.int8,
    "newton_iterations": np.float64,
    "substeps": np.int64,
    "fallbacks": np.int64,
    "failed_steps": np.int64,
    "loose_steps": np.int64,
    "impulse_steps": np.int64,
    "max_penetration": np.float64,
    "energy_gain": np.float64,
    "energy_gain_ratio": np.float64,
    "field_work_bound": np.float64,
    "lateral_drift": np.float64,
    "heading_change_deg": np.float64,
    "decided_time": np.float64,
    "decided_early": np.int8,
}


#: the outcome status of a run, the one table: ``(code, name, meaning)``. The flags of every
#: status variable, a run's ``status_meanings`` attribute and the reports' words derive from it
STATUS_TABLE: tuple[tuple[int, str, str], ...] = (
    (KB.BATCH_OK, "ok", "finished, every step converged, the energy ledger within its tolerance"),
    (KB.BATCH_FAILED_STEPS, "failed_steps", "a (sub-)step no solve strategy converged at the smallest sub-step: the best attempt was kept"),
    (KB.BATCH_NONFINITE, "nonfinite", "the state became non-finite"),
    (KB.BATCH_ERROR, "error", "the inputs were rejected"),
    (KB.BATCH_ENERGY_GAIN, "energy_gain", "converged steps, but the energy ledger's numerical gain exceeds the tolerance"),
)
#: status code -> name, and code -> meaning
STATUS_NAMES: dict[int, str] = {code: name for code, name, _ in STATUS_TABLE}
STATUS_MEANINGS: dict[int, str] = {code: meaning for code, _, meaning in STATUS_TABLE}
#: a single run's ``status_meanings`` attribute (a run on its own is never "error": its inputs raise)
RUN_STATUS_MEANINGS = ", ".join(f"{code} {name}" for code, name, _ in STATUS_TABLE if code != KB.BATCH_ERROR)

STATUS_FLAGS = {
    "flag_values": np.array([code for code, _, _ in STATUS_TABLE], dtype=np.int8),
    "flag_meanings": " ".join(name for _, name, _ in STATUS_TABLE),
}


OUTCOME_ATTRS: dict[str, dict[str, Any]] = {
    "progress_ratio": {"units": "1", "long_name": "mean uphill speed after the transient over the no-slip speed (hull perimeter x f)"},
    "mean_speed": {"units": "m s-1", "long_name": "mean uphill speed after the transient"},
    "progress": {"units": "m", "long_name": "uphill progress after the transient"},
    "climbed": {
        "units": "1",
        "long_name": "run succeeded: status ok and progress_ratio >= success_ratio",
        "flag_values": np.array([0, 1], dtype=np.int8),
        "flag_meanings": "no yes",
    },
    "status": {"units": "1", "long_name": "run status", **STATUS_FLAGS},
    "newton_iterations": {"units": "1", "long_name": "mean Newton iterations per time step"},
    "substeps": {"units": "1", "long_name": "extra sub-steps (halvings of dt), total"},
    "fallbacks": {"units": "1", "long_name": "damped or gradient Newton steps and extra solve strategies, total"},
    "failed_steps": {"units": "1", "long_name": "time steps that did not converge at the smallest sub-step"},
    "loose_steps": {"units": "1", "long_name": "time steps kept unsolved but within accept_tol or impulse_accept_tol"},
    "impulse_steps": {
        "units": "1",
        "long_name": "of the loose steps, those kept at the smallest sub-step by impulse_accept_tol "
        "(momentum balanced, residual above accept_tol)",
    },
    "max_penetration": {"units": "m", "long_name": "largest depth of the robot below the plane"},
    "energy_gain": {
        "units": "J",
        "long_name": (
            "numerical energy gain of the energy ledger, of the account with the larger ratio: the contact gain (kinetic"
            " energy no force supplied plus positive normal work, summed per step) or the energy excess (the most the"
            " energy exceeded the field's work)"
        ),
    },
    "energy_gain_ratio": {
        "units": "1",
        "long_name": (
            "the larger of: contact gain over (field work bound + initial kinetic energy + potential energy released"
            " + m g x 1e-4 m), energy excess over the energy the run received; status energy_gain above 0.01"
        ),
    },
    "field_work_bound": {"units": "J", "long_name": "most work the rotating field can do on the magnet in the run: |m||B| (2 + 2 pi f T)"},
    "lateral_drift": {"units": "m", "long_name": "displacement of the centre of mass along the plane tangent t (world x) over the run"},
    "heading_change_deg": {
        "units": "degree",
        "long_name": "turn of the body x (tumbling) axis about the plane normal over the run, folded to (-90, 90]",
    },
    "decided_time": {
        "units": "s",
        "long_name": (
            "time from the start at which the energy bound (tumblemc.kernels.decide) decided failure: progress so far plus the most"
            " the run could still climb fell short of success; NaN if it never did"
        ),
    },
    "decided_early": {
        "units": "1",
        "long_name": (
            "run stopped at decided_time (early_decision): verdict failure; progress_ratio, progress, mean_speed and the"
            " counters are those up to the decision (censored)"
        ),
        "flag_values": np.array([0, 1], dtype=np.int8),
        "flag_meanings": "no yes",
    },
    "error": {"long_name": "why the run could not start (empty when it ran)"},
}


#: columns of a critical study's check task: dtype, width ("grid": one per check incline,
#: "pair": the two inclines around the first failure) and the fill of a run that raised
CHECK_COLUMNS: dict[str, tuple[type, str, float]] = {
    "grid_climbed": (np.int8, "grid", 0),
    "grid_status": (np.int8, "grid", 3),
    "pair_incline": (np.float64, "pair", np.nan),
    "pair_climbed": (np.int8, "pair", 0),
    "pair_status": (np.int8, "pair", 3),
    "pair_climbed_fine": (np.int8, "pair", 0),
    "pair_status_fine": (np.int8, "pair", 3),
}


TIMESTAMP_ATTRS = ("history", "date_created")


#: root attributes (ACDD-1.3) every study file shares; the license is pyproject.toml's
STUDY_FILE_ATTRS: dict[str, str] = {
    "keywords": (
        "tumbling microrobot, magnetic microrobot, rotating magnetic field, non-point contact, adhesion, friction, "
        "inclined plane, complementarity time-stepping, Monte Carlo, robustness, uncertainty quantification"
    ),
    "license": "MIT",
    "creator_name": "tumblemc developers",
    "creator_type": "group",
    "naming_authority": "tumblemc",
    "references": (
        "Xie, J., Bi, C., Cappelleri, D. J. and Chakraborty, N. (2019): Towards Dynamic Simulation Guided Optimal Design "
        "of Tumbling Microrobots, Proceedings of the ASME 2019 International Design Engineering Technical Conferences and "
        "Computers and Information in Engineering Conference (IDETC/CIE 2019), Anaheim, CA, USA, paper DETC2019-97306"
    ),
}


#: attributes the ``maps`` group keeps from the ``runs`` group: the definitions its
#: variables refer to (success threshold, dt check) and the study's config hash
MAPS_FROM_RUNS_ATTRS = ("config_hash", "success_ratio", "check_dt_factor", "check_ratio_abs_tol", "check_ratio_rel_tol")


#: the design's ``check_flag`` in a study file (int8 like the other flags; a bool mask in memory)
CHECK_FLAG_ATTRS: dict[str, Any] = {"units": "1", "flag_values": np.array([0, 1], dtype=np.int8), "flag_meanings": "no yes"}


#: outcome columns of :func:`bisect_rows`
CRITICAL_OUTCOMES: dict[str, type] = {
    "critical_incline_deg": np.float64,
    "fails_at_deg": np.float64,
    "censored": np.int8,
    "n_simulations": np.int64,
    "status": np.int8,
    "newton_iterations": np.float64,
    "substeps": np.int64,
    "failed_steps": np.int64,
    "loose_steps": np.int64,
    "impulse_steps": np.int64,
}


CRITICAL_ATTRS: dict[str, dict[str, Any]] = {
    "critical_incline_deg": {
        "units": "degree",
        "long_name": "steepest incline the sample was seen to climb (lower end of the final bracket); NaN if it fails at incline_range.min",
    },
    "fails_at_deg": {
        "units": "degree",
        "long_name": "gentlest incline the sample was seen to fail (upper end of the final bracket); NaN if it climbs incline_range.max",
    },
    "censored": {
        "units": "1",
        "long_name": "critical incline outside incline_range (meaningful where status is ok)",
        "flag_values": np.array([-1, 0, 1], dtype=np.int8),
        "flag_meanings": "fails_at_min bracketed climbs_at_max",
    },
    "n_simulations": {"units": "1", "long_name": "simulations used by the bisection"},
    "status": {"units": "1", "long_name": "worst status of the run's simulations", **STATUS_FLAGS},
    "newton_iterations": {"units": "1", "long_name": "mean Newton iterations per time step over the run's simulations"},
    "substeps": {"units": "1", "long_name": "extra sub-steps (halvings of dt), total over the run's simulations"},
    "failed_steps": {"units": "1", "long_name": "time steps that did not converge at the smallest sub-step, total"},
    "loose_steps": {"units": "1", "long_name": "time steps kept unsolved but within accept_tol or impulse_accept_tol, total"},
    "impulse_steps": {"units": "1", "long_name": "of the loose steps, those kept by impulse_accept_tol, total"},
}


SENSITIVITY_COORD_ATTRS: dict[str, dict[str, str]] = {**COORD_ATTRS, "parameter": {"long_name": "uncertain parameter"}}


#: variables and coordinates of the numerical dt check of a grid study (``runs`` group)
GRID_CHECK_VARIABLES: dict[str, dict[str, Any]] = {
    "check_run": {"units": "1", "long_name": "index (along run) of a run re-simulated at dt / check_dt_factor"},
    "check_progress_ratio_fine": {"units": "1", "long_name": "progress ratio of the re-simulation at the finer dt"},
    "check_climbed_fine": {
        "units": "1",
        "long_name": "verdict of the re-simulation at the finer dt",
        "flag_values": np.array([0, 1], dtype=np.int8),
        "flag_meanings": "no yes",
    },
    "check_status_fine": {"units": "1", "long_name": "status of the re-simulation at the finer dt", **STATUS_FLAGS},
    "check_agree": {
        "units": "1",
        "long_name": "verdict at the study dt equals the verdict at the finer dt (compared only where both runs are valid)",
        "flag_values": np.array([-1, 0, 1], dtype=np.int8),
        "flag_meanings": "not_compared no yes",
    },
    "check_ratio_diff": {"units": "1", "long_name": "progress ratio at dt / check_dt_factor minus progress ratio at dt"},
    "check_ratio_within_tol": {
        "units": "1",
        "long_name": (
            "|check_ratio_diff| <= check_ratio_abs_tol + check_ratio_rel_tol * |fine ratio| (attributes of the group;"
            " compared only where both runs are valid)"
        ),
        "flag_values": np.array([-1, 0, 1], dtype=np.int8),
        "flag_meanings": "not_compared no yes",
    },
    "check_twin_spread": {
        "units": "1",
        "long_name": (
            "largest move of the progress ratio at dt when the magnetisation is changed by +- check_twin_rel"
            " (only for check runs outside the ratio tolerance; NaN elsewhere)"
        ),
    },
    "check_twin_ratio_up": {
        "units": "1",
        "long_name": "progress ratio at dt with the magnetisation x (1 + check_twin_rel) (NaN where not simulated or not valid)",
    },
    "check_twin_ratio_down": {
        "units": "1",
        "long_name": "progress ratio at dt with the magnetisation x (1 - check_twin_rel) (NaN where not simulated or not valid)",
    },
    "check_sensitive": {
        "units": "1",
        "long_name": (
            "a check run outside the ratio tolerance whose twins moved its ratio beyond that tolerance"
            " (sensitive: the model does not determine its ratio to the tolerance) or not (limited by dt)"
        ),
        "flag_values": np.array([-1, 0, 1], dtype=np.int8),
        "flag_meanings": "not_classified dt_limited sensitive",
    },
    "check": {"units": "1", "long_name": "index of a numerical-check run"},
    "run": {"units": "1", "long_name": "run index (the design's order: cell by cell, sample fastest)"},
}

#: variables and coordinates of the monotonicity and dt checks of a critical-incline study (``runs`` group)
CRITICAL_CHECK_VARIABLES: dict[str, dict[str, Any]] = {
    "run": {"units": "1", "long_name": "run index (one parameter sample each)"},
    "check": {"units": "1", "long_name": "index of a check run"},
    "check_incline_deg": {"units": "degree", "long_name": "grid incline of the monotonicity check"},
    "check_run": {"units": "1", "long_name": "index (along run) of a checked sample"},
    "check_grid_climbed": {
        "units": "1",
        "long_name": "verdict of a direct simulation at the grid incline",
        "flag_values": np.array([0, 1], dtype=np.int8),
        "flag_meanings": "no yes",
    },
    "check_grid_status": {"units": "1", "long_name": "status of the direct simulation at the grid incline", **STATUS_FLAGS},
    "check_disagree": {
        "units": "1",
        "long_name": "direct verdict differs from incline <= critical_incline_deg",
        "flag_values": np.array([0, 1], dtype=np.int8),
        "flag_meanings": "agree disagree",
    },
    "check_nonmonotone": {
        "units": "1",
        "long_name": "sample climbs a grid incline steeper than one it fails",
        "flag_values": np.array([0, 1], dtype=np.int8),
        "flag_meanings": "monotone nonmonotone",
    },
    "check_agree": {
        "units": "1",
        "long_name": (
            "verdicts at the two grid inclines around the first failure equal those at dt / check_dt_factor"
            " (compared only where all four runs are valid)"
        ),
        "flag_values": np.array([-1, 0, 1], dtype=np.int8),
        "flag_meanings": "not_compared no yes",
    },
    "check_climbed_fine": {"units": "1", "long_name": "verdicts at dt / check_dt_factor at the inclines check_pair_incline_deg"},
    "check_pair_incline_deg": {"units": "degree", "long_name": "last climbing and first failing grid incline of the direct simulation"},
}
