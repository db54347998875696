"""A calibration's diagnostics in words, with units and what each means for the user.

:func:`tumblemc.lab.calibrate.report` prints these lines. Each number carries its unit (the
data's, for residuals) and a verdict against a named threshold:

- the rms residual, in data units, beside the residual sd (the noise the fit infers);
- the condition number of ``J^T J`` in the sampling scale ``z`` (the fit's Jacobian): how
  much worse the worst-determined combination of free parameters is known than the best.
  Above :data:`CONDITION_POOR` (the worst combination 100 times less precise) the line
  names it (the eigenvector of the smallest eigenvalue); pairs whose posterior correlation
  reaches :data:`CORRELATION_POOR` are named as poorly separated whatever the number;
- the simulator's check of a closed-form fit: the rms difference between the simulator and
  the closed form at the estimate matters when it reaches :data:`SIM_CHECK_MATTERS` of the
  residual sd (the model error is then a visible share of the data's scatter).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import xarray as xr

#: condition number of J^T J (z scale) above which the worst direction is named: its
#: precision is then 100 times (sqrt) below the best one's
CONDITION_POOR = 1e4
#: |posterior correlation| at which two parameters count as poorly separated
CORRELATION_POOR = 0.9
#: share of the residual sd at which the simulator's difference from the closed form matters
SIM_CHECK_MATTERS = 0.5
#: unit attributes as printed
UNIT_WORDS = {"degree": "deg", "mm s-1": "mm/s", "1": ""}


def weakest_direction(jac: np.ndarray, names: Sequence[str]) -> str:
    """The combination of free parameters the data determine worst (z scale): ``"0.71 F_elect - 0.70 adhesion_C"``.

    The eigenvector of ``J^T J`` with the smallest eigenvalue, its components above 0.2 in
    size, largest first, signed so that the largest is positive.
    """
    w, v = np.linalg.eigh(np.asarray(jac, float).T @ np.asarray(jac, float))
    vec = v[:, int(np.argmin(w))]
    vec = vec * (1.0 if vec[int(np.argmax(np.abs(vec)))] >= 0 else -1.0)
    parts = [(c, nm) for c, nm in sorted(zip(vec, names, strict=True), key=lambda t: -abs(t[0])) if abs(c) >= 0.2]
    text = " ".join(f"{'-' if c < 0 else '+'} {abs(c):.2f} {nm}" for c, nm in parts)
    return text[2:] if text.startswith("+ ") else text


def poorly_separated(cov: np.ndarray, names: Sequence[str]) -> list[tuple[str, str, float]]:
    """Pairs of free parameters whose posterior correlation reaches :data:`CORRELATION_POOR` in size."""
    c = np.atleast_2d(np.asarray(cov, float))
    sd = np.sqrt(np.clip(np.diag(c), 0.0, None))
    out = []
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            if sd[i] > 0 and sd[j] > 0:
                r = float(c[i, j] / (sd[i] * sd[j]))
                if abs(r) >= CORRELATION_POOR:
                    out.append((names[i], names[j], r))
    return out


def diagnostic_lines(ds: xr.Dataset) -> list[str]:
    """The fit's residual, conditioning and simulator check in words (module docstring)."""
    a = ds.attrs
    unit = UNIT_WORDS.get(str(ds["y"].attrs.get("units", "")), str(ds["y"].attrs.get("units", "")))
    u = f" {unit}" if unit else ""
    lines = [
        f"rms residual {a['rms_residual']:.4g}{u} (data minus the fit at the estimate; the noise sd the fit infers, "
        f"with n - p degrees of freedom, is {a['residual_sd']:.4g}{u}); {a['n_evaluations']} {a['fit_model']} evaluations in the fit"
    ]
    names = str(a["free"]).split(",")
    cond = float(a["condition_number"])
    pairs = poorly_separated(ds["covariance"].values, names)
    if len(names) == 1:
        what = "one free parameter: nothing to separate"
    elif cond > CONDITION_POOR or not math.isfinite(cond):
        weak = a.get("weakest_direction", "")
        what = (
            f"above {CONDITION_POOR:.0e}: the data determine the combination {weak} (sampling scale) "
            f"{math.sqrt(cond) if math.isfinite(cond) else math.inf:.3g} times less precisely than the best one; "
            "read the joint draws, not each interval alone"
        )
    else:
        what = f"at most {CONDITION_POOR:.0e}: the data separate the free parameters"
    lines.append(f"condition number {cond:.3g} (of J^T J, the fit's Jacobian in the sampling scale; dimensionless): {what}")
    for x, y, r in pairs:
        lines.append(
            f"poorly separated: {x} and {y} (posterior correlation {r:+.2f}, |r| >= {CORRELATION_POOR}): the data trade one for the other"
        )
    sim = float(a.get("simulator_check_rms", math.nan))
    if math.isfinite(sim):
        sd = float(a["residual_sd"])
        share = sim / sd if sd > 0 else math.inf
        verdict = (
            f"it matters (at least {SIM_CHECK_MATTERS:g} of it): the closed form's estimate may not hold for the simulator; "
            "refit with --model simulate"
            if share >= SIM_CHECK_MATTERS
            else f"it does not matter (below {SIM_CHECK_MATTERS:g} of it)"
        )
        lines.append(
            f"the simulator at the estimate differs from the closed form by {sim:.3g}{u} rms, {share:.2g} of the noise sd "
            f"{sd:.3g}{u}: {verdict}"
        )
    return lines


__all__ = ["CONDITION_POOR", "CORRELATION_POOR", "SIM_CHECK_MATTERS", "diagnostic_lines", "poorly_separated", "weakest_direction"]
