"""Bench tests in simulation and calibration from bench data.

:mod:`.protocols`: the bench-test protocols (static tilt, critical field, step-out,
steering), each a set of runs summarised as a Dataset; their names are re-exported here
(``tumblemc.lab.static_tilt``). :mod:`.calibrate`: fits of the model's parameters to bench
data (``tumblemc calibrate``) and their posteriors. Their measurements are in
:mod:`tumblemc.analysis.bench`, their figures in :mod:`tumblemc.viz.lab` and
:mod:`tumblemc.viz.calibrate`, the command line in :mod:`tumblemc.cli`.
"""

from tumblemc.lab.protocols import (
    critical_field,
    critical_field_samples,
    cuboid_tilt_balance,
    equilibrium_tilts,
    following_share,
    phase_lag_deg,
    posterior_samples,
    static_tilt,
    steering,
    step_out,
    step_out_bisect,
    tilt_deg,
)

__all__ = [
    "critical_field",
    "critical_field_samples",
    "cuboid_tilt_balance",
    "equilibrium_tilts",
    "following_share",
    "phase_lag_deg",
    "posterior_samples",
    "static_tilt",
    "steering",
    "step_out",
    "step_out_bisect",
    "tilt_deg",
]
