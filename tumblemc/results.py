"""The one schema of tumblemc outputs: dimensions, units and descriptions.

Every variable a run writes is declared here once; :func:`annotate` carries the
declarations into a Dataset so that files written anywhere have the same metadata.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

CONTACT_MODE_FLAGS = {"flag_values": np.array([0, 1, 2], dtype=np.int8), "flag_meanings": "none point_or_line face"}

RUN_VARIABLES: dict[str, dict[str, Any]] = {
    "time": {"units": "s", "long_name": "time since the start of the run"},
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
        "long_name": "steps with a (sub-)step kept, without halving, at a residual between the solver's tol and accept_tol",
    },
    "field": {"units": "T", "long_name": "magnetic flux density B (world frame)"},
}


def annotate(ds: xr.Dataset, schema: dict[str, dict[str, Any]] | None = None) -> xr.Dataset:
    """Attach the attributes of ``schema`` (default: a run's, :data:`RUN_VARIABLES`) to
    every variable of ``ds`` it names (in place)."""
    for name, attrs in (RUN_VARIABLES if schema is None else schema).items():
        if name in ds.variables:
            ds[name].attrs.update(attrs)
    return ds
