"""Screening of a Monte Carlo study: which uncertain parameters matter, per cell (analysis layer).

Works on the ``runs`` table of any study, whatever its sampler, one cell (shape,
substrate, incline and any swept field setting) at a time:

- :func:`rank_correlation`: Spearman correlation of each parameter with an outcome, with
  Fisher-z intervals;
- :func:`logistic_summary`: penalized logistic regression of a binary outcome
  (``climbed``) on the standardized parameters, with separation flagged.

It also holds the helpers the other per-cell analyses share: the uncertain parameters of
a study (:func:`uncertain_parameters`), its valid runs (:func:`valid_mask`) and the runs
of one cell (:func:`cell_mask`). Results are :class:`xarray.Dataset` objects over the cell
coordinates and ``parameter``, with ``units`` and ``long_name`` on every variable. Nothing
here runs the simulator.

References
----------
Albert, A. & Anderson, J. A. (1984). On the existence of maximum likelihood estimates in
logistic regression models. Biometrika 71, 1-10.
Fieller, E. C., Hartley, H. O. & Pearson, E. S. (1957). Tests for rank correlation
coefficients. I. Biometrika 44, 470-481.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np
import xarray as xr
from scipy import optimize, stats
from scipy.special import expit, ndtri

from tumblemc.analysis.maps import cell_groups, decided_early_mask
from tumblemc.model.outcome import is_valid
from tumblemc.model.params import RANGES
from tumblemc.schema import SENSITIVITY_COORD_ATTRS, SWEEP_DIMS, sampled_name

#: default cell coordinates of the per-cell analyses (swept field settings are added)
CELL_BY = ("shape", "substrate", "incline_deg")


#: default prior precision of the logistic coefficients (on standardized parameters)
RIDGE = 1e-2


def uncertain_parameters(runs: xr.Dataset, parameters: Sequence[str] | None) -> list[tuple[str, str]]:
    """Pair each uncertain parameter with its variable in the run table.

    Parameters
    ----------
    runs : Dataset
        Study runs (dim ``run``).
    parameters : sequence of str or None
        Parameter names; None takes those named in ``runs.attrs["uncertain"]``.

    Returns
    -------
    list of (str, str)
        ``(parameter, variable)`` pairs; the variable differs from the parameter for a
        parameter that is also a cell coordinate (``field_mT`` -> ``field_mT_sampled``).

    Raises
    ------
    ValueError
        If no parameter is named, or one has no per-run variable.
    """
    if parameters is None:
        names = [s.strip() for s in str(runs.attrs.get("uncertain", "")).split(",") if s.strip()]
        if not names:
            raise ValueError("runs.attrs['uncertain'] names no parameter; pass parameters=")
    else:
        names = [str(p) for p in parameters]
    out = []
    for p in names:
        var = sampled_name(p)
        if var not in runs.variables or runs[var].dims != ("run",):
            raise ValueError(f"runs has no per-run variable {var!r} for uncertain parameter {p!r}")
        out.append((p, var))
    return out


def _by(runs: xr.Dataset, by: Sequence[str] | None) -> list[str]:
    if by is None:
        dims = list(CELL_BY)
        dims += [d for d in SWEEP_DIMS if d in runs.variables and np.unique(runs[d].values).size > 1]
    else:
        dims = [str(b) for b in by]
    missing = [d for d in dims if d not in runs.variables]
    if missing:
        raise ValueError(f"runs has no cell coordinate(s) {missing}")
    return dims


def _groups(runs: xr.Dataset, dims: Sequence[str]) -> tuple[dict[str, np.ndarray], tuple[int, ...], list[np.ndarray]]:
    """Sorted unique values per dim, the grid shape, and the run indices of each cell.

    Cells are in C order over the grid (:func:`tumblemc.analysis.maps.cell_groups`).
    """
    values, shape, _, groups = cell_groups(runs, dims)
    return values, shape, groups


def valid_mask(runs: xr.Dataset) -> np.ndarray:
    """Boolean mask over ``run`` of the valid runs (``status == 0``).

    Parameters
    ----------
    runs : Dataset
        Study runs with a ``status`` variable.

    Returns
    -------
    (n_run,) bool array
    """
    if "status" not in runs.variables:
        raise ValueError("runs has no 'status' variable (0 = valid run)")
    return is_valid(runs["status"].values)


def _coords(runs: xr.Dataset, dims: Sequence[str], values: Mapping[str, np.ndarray], params: Sequence[tuple[str, str]]) -> dict[str, Any]:
    coords: dict[str, Any] = {}
    for d in dims:
        attrs = dict(SENSITIVITY_COORD_ATTRS.get(d, {}))
        attrs.update({k: v for k, v in runs[d].attrs.items() if k in ("units", "long_name")})
        coords[d] = (d, values[d], attrs)
    coords["parameter"] = ("parameter", np.asarray([p for p, _ in params], dtype=str), SENSITIVITY_COORD_ATTRS["parameter"])
    units = [str(runs[v].attrs.get("units", RANGES[p].units if p in RANGES else "")) for p, v in params]
    coords["parameter_units"] = ("parameter", np.asarray(units, dtype=str), {"long_name": "units of the parameter"})
    return coords


#: per-run outcomes that an early decision censors (kept up to the decision)
CENSORED_OUTCOMES = ("progress_ratio", "mean_speed", "progress", "newton_iterations", "lateral_drift", "heading_change_deg")


def censored_outcome(runs: xr.Dataset, outcome: str) -> None:
    """Raise if ``outcome`` is censored in some valid run (stopped by an early decision)."""
    if outcome in CENSORED_OUTCOMES:
        k = int(np.count_nonzero(decided_early_mask(runs) & valid_mask(runs)))
        if k:
            raise ValueError(
                f"{k} valid runs were stopped by an early decision, so their {outcome} is censored (known only up to the "
                f"decision): rank them by outcome='climbed', or run the study with early_decision = false"
            )


def rank_correlation(
    runs: xr.Dataset,
    by: Sequence[str] | None = None,
    outcome: str = "progress_ratio",
    *,
    parameters: Sequence[str] | None = None,
    level: float = 0.95,
) -> xr.Dataset:
    """Spearman rank correlation of each uncertain parameter with an outcome, per cell.

    Parameters
    ----------
    runs : Dataset
        Study results (dim ``run``; ``status``, the outcome and the uncertain parameters
        named in ``attrs["uncertain"]``).
    by : sequence of str, optional
        Cell coordinates; default ``("shape", "substrate", "incline_deg")`` plus
        ``field_mT``/``freq_hz`` when the study sweeps them.
    outcome : str
        Per-run variable, e.g. ``"progress_ratio"`` or ``"climbed"``.
    parameters : sequence of str, optional
        Parameter names (default: ``runs.attrs["uncertain"]``).
    level : float
        Confidence level of ``rho_lower``/``rho_upper``, in (0, 1).

    Returns
    -------
    Dataset
        Dims ``(*by, parameter)``: ``rho``, ``rho_lower``, ``rho_upper``, ``p_value``;
        dims ``by``: ``n_valid``, ``no_variation``. Values are NaN where the cell has
        fewer than 4 usable runs or the parameter or outcome is constant in it.

    Notes
    -----
    Uses the valid runs (``status == 0``) with a finite outcome and finite parameters.
    ``rho`` and the two-sided ``p_value`` are :func:`scipy.stats.spearmanr`'s (t
    approximation, no multiplicity correction). The interval is Fisher's
    ``atanh`` transform with the variance ``1.06 / (n - 3)`` of Fieller et al. (1957).
    """
    params = uncertain_parameters(runs, parameters)
    dims = _by(runs, by)
    if outcome not in runs.variables:
        raise ValueError(f"runs has no outcome variable {outcome!r}")
    if not (0.0 < float(level) < 1.0):
        raise ValueError(f"level must be in (0, 1), got {level!r}")
    censored_outcome(runs, outcome)
    values, shape, groups = _groups(runs, dims)
    valid = valid_mask(runs)
    y_all = np.asarray(runs[outcome].values, dtype=np.float64)
    x_all = np.column_stack([np.asarray(runs[v].values, dtype=np.float64) for _, v in params])
    d = len(params)
    ncell = len(groups)
    rho = np.full((ncell, d), np.nan)
    pval = np.full((ncell, d), np.nan)
    lo = np.full((ncell, d), np.nan)
    hi = np.full((ncell, d), np.nan)
    n_valid = np.zeros(ncell, dtype=np.int64)
    flat = np.zeros(ncell, dtype=bool)
    z = float(ndtri(0.5 + 0.5 * float(level)))
    for c, rows in enumerate(groups):
        rows = rows[valid[rows]]
        y = y_all[rows]
        x = x_all[rows]
        ok = np.isfinite(y) & np.all(np.isfinite(x), axis=1)
        y, x = y[ok], x[ok]
        n = y.size
        n_valid[c] = n
        flat[c] = n == 0 or bool(np.all(y == y[0]))
        if n < 4 or flat[c]:
            continue
        for j in range(d):
            if np.all(x[:, j] == x[0, j]):
                continue
            res = stats.spearmanr(x[:, j], y)
            r = float(res.statistic)
            rho[c, j], pval[c, j] = r, float(res.pvalue)
            half = z * math.sqrt(1.06 / (n - 3))
            zr = math.atanh(min(max(r, -1.0 + 1e-15), 1.0 - 1e-15))
            lo[c, j], hi[c, j] = math.tanh(zr - half), math.tanh(zr + half)

    pdims = [*dims, "parameter"]
    pct = f"{100 * float(level):g}%"

    def grid(a: np.ndarray) -> np.ndarray:
        return a.reshape(shape + a.shape[1:])

    ds = xr.Dataset(
        {
            "rho": (pdims, grid(rho), {"units": "1", "long_name": f"Spearman rank correlation of the parameter with {outcome}"}),
            "rho_lower": (pdims, grid(lo), {"units": "1", "long_name": f"lower bound of the {pct} Fisher-z interval of rho"}),
            "rho_upper": (pdims, grid(hi), {"units": "1", "long_name": f"upper bound of the {pct} Fisher-z interval of rho"}),
            "p_value": (pdims, grid(pval), {"units": "1", "long_name": "two-sided p-value of rho = 0 (scipy.stats.spearmanr)"}),
            "n_valid": (dims, grid(n_valid), {"units": "1", "long_name": f"valid runs with a finite {outcome} and parameters"}),
            "no_variation": (dims, grid(flat), {"units": "1", "long_name": f"{outcome} is the same in every valid run of the cell"}),
        },
        coords=_coords(runs, dims, values, params),
        attrs={"title": f"rank correlation of uncertain parameters with {outcome}", "outcome": outcome, "confidence_level": float(level)},
    )
    return ds


class _LogitFit(NamedTuple):
    beta: np.ndarray  # (1 + d,), intercept first
    se: np.ndarray
    converged: bool


def _fit_logit(Z: np.ndarray, y: np.ndarray, ridge: float) -> _LogitFit:
    """Penalized logistic regression ``min sum(log(1 + e^eta) - y eta) + ridge |beta|^2 / 2``."""
    n, d = Z.shape
    X = np.column_stack([np.ones(n), Z])
    eye = np.eye(d + 1)

    def fun(beta: np.ndarray) -> tuple[float, np.ndarray]:
        eta = X @ beta
        nll = float(np.sum(np.logaddexp(0.0, eta) - y * eta) + 0.5 * ridge * beta @ beta)
        return nll, X.T @ (expit(eta) - y) + ridge * beta

    def hess(beta: np.ndarray) -> np.ndarray:
        p = expit(X @ beta)
        return (X.T * (p * (1.0 - p))) @ X + ridge * eye

    res = optimize.minimize(fun, np.zeros(d + 1), jac=True, hess=hess, method="trust-exact", options={"gtol": 1e-6})
    beta = np.asarray(res.x, dtype=np.float64)
    # trust-exact may stop on rounding a hair above gtol; the gradient says whether it got there
    converged = bool(res.success) or float(np.max(np.abs(fun(beta)[1]))) <= 1e-6 * max(1, n)
    H = hess(beta)
    se = np.full(d + 1, np.nan)
    if np.all(np.isfinite(H)):
        try:
            cov = np.linalg.inv(H)
        except np.linalg.LinAlgError:
            cov = None
        if cov is not None:
            diag = np.diag(cov)
            ok = np.isfinite(diag) & (diag > 0.0)
            se[ok] = np.sqrt(diag[ok])
    return _LogitFit(beta, se, converged)


def _separable(Z: np.ndarray, y: np.ndarray) -> bool:
    """Whether a hyperplane separates the classes completely (Albert & Anderson 1984).

    That is, whether the linear program ``(2 y - 1)(b + Z w) >= 1`` is feasible.
    """
    n, d = Z.shape
    X = np.column_stack([np.ones(n), Z])
    A_ub = -(2.0 * y - 1.0)[:, None] * X
    res = optimize.linprog(np.zeros(d + 1), A_ub=A_ub, b_ub=-np.ones(n), bounds=[(None, None)] * (d + 1), method="highs")
    return bool(res.status == 0)


def logistic_summary(
    runs: xr.Dataset,
    by: Sequence[str] | None = None,
    outcome: str = "climbed",
    *,
    parameters: Sequence[str] | None = None,
    ridge: float = RIDGE,
    level: float = 0.95,
) -> xr.Dataset:
    """Per-cell logistic regression of a binary outcome on the standardized parameters.

    Parameters
    ----------
    runs : Dataset
        Study results (see :func:`rank_correlation`).
    by : sequence of str, optional
        Cell coordinates (default as :func:`rank_correlation`).
    outcome : str
        Per-run 0/1 variable (``climbed``).
    parameters : sequence of str, optional
        Parameter names (default: ``runs.attrs["uncertain"]``).
    ridge : float
        Precision of the Gaussian prior ``N(0, 1 / ridge)`` on the intercept and each
        standardized coefficient (a ridge penalty ``ridge |beta|^2 / 2``), > 0. The
        default 0.01 (prior SD of 10 log-odds per SD) barely moves coefficients that the
        data determine and keeps them finite under separation.
    level : float
        Confidence level of the Wald intervals ``coef +- z se``, in (0, 1).

    Returns
    -------
    Dataset
        Dims ``(*by, parameter)``: ``coef`` (change in log-odds per standard deviation of
        the parameter in the cell), ``coef_se``, ``coef_lower``, ``coef_upper``,
        ``param_mean``, ``param_sd``; dims ``by``: ``intercept``, ``intercept_se``,
        ``n_valid``, ``n_success``, ``p_success``, ``no_variation``, ``separated``,
        ``converged``. Coordinate ``parameter_units`` gives each parameter's units.

    Notes
    -----
    Valid runs (``status == 0``) with finite parameters are used; each parameter is
    standardized with its mean and SD in the cell, so coefficients compare across
    parameters. Standard errors are the square roots of the diagonal of the inverse
    Hessian of the penalized negative log-likelihood (the Laplace approximation of the
    posterior), NaN where that is not finite. Cells are flagged rather than fitted
    where the outcome does not vary (``no_variation``: all 0, all 1 or no valid run;
    coefficients NaN). ``separated`` flags cells where a hyperplane in parameter space
    separates the classes completely (a linear program, Albert & Anderson 1984): the
    maximum-likelihood coefficients are then infinite and the reported ones are set by
    the ridge prior, so only their signs and order mean something. A parameter constant
    in a cell gets a NaN coefficient there.

    Albert, A. & Anderson, J. A. (1984). On the existence of maximum likelihood
    estimates in logistic regression models. Biometrika 71, 1-10.
    """
    params = uncertain_parameters(runs, parameters)
    dims = _by(runs, by)
    if outcome not in runs.variables:
        raise ValueError(f"runs has no outcome variable {outcome!r}")
    if not (isinstance(ridge, (int, float)) and ridge > 0 and math.isfinite(ridge)):
        raise ValueError(f"ridge must be a positive number, got {ridge!r}")
    if not (0.0 < float(level) < 1.0):
        raise ValueError(f"level must be in (0, 1), got {level!r}")
    values, shape, groups = _groups(runs, dims)
    valid = valid_mask(runs)
    y_all = np.asarray(runs[outcome].values, dtype=np.float64)
    x_all = np.column_stack([np.asarray(runs[v].values, dtype=np.float64) for _, v in params])
    d, ncell = len(params), len(groups)
    coef = np.full((ncell, d), np.nan)
    coef_se = np.full((ncell, d), np.nan)
    mean = np.full((ncell, d), np.nan)
    sd = np.full((ncell, d), np.nan)
    icpt = np.full(ncell, np.nan)
    icpt_se = np.full(ncell, np.nan)
    n_valid = np.zeros(ncell, dtype=np.int64)
    n_succ = np.zeros(ncell, dtype=np.int64)
    flat = np.ones(ncell, dtype=bool)
    separated = np.zeros(ncell, dtype=bool)
    converged = np.zeros(ncell, dtype=bool)
    for c, rows in enumerate(groups):
        rows = rows[valid[rows]]
        y, x = y_all[rows], x_all[rows]
        ok = np.isfinite(y) & np.all(np.isfinite(x), axis=1)
        y, x = y[ok], x[ok]
        if np.any((y != 0) & (y != 1)):
            raise ValueError(f"outcome {outcome!r} must be 0 or 1 in valid runs, found {np.unique(y[(y != 0) & (y != 1)])[:5]}")
        n = y.size
        n_valid[c], n_succ[c] = n, int(np.count_nonzero(y))
        if n == 0:
            continue
        mean[c] = x.mean(axis=0)
        sd[c] = x.std(axis=0)
        flat[c] = n_succ[c] in (0, n)
        if flat[c]:
            continue
        varies = sd[c] > 0.0
        Z = np.zeros_like(x)
        Z[:, varies] = (x[:, varies] - mean[c, varies]) / sd[c, varies]
        fit = _fit_logit(Z[:, varies], y, float(ridge))
        coef[c, varies], coef_se[c, varies] = fit.beta[1:], fit.se[1:]
        icpt[c], icpt_se[c] = fit.beta[0], fit.se[0]
        converged[c] = fit.converged
        separated[c] = _separable(Z[:, varies], y)

    z = float(ndtri(0.5 + 0.5 * float(level)))
    pct = f"{100 * float(level):g}%"
    pdims = [*dims, "parameter"]
    with np.errstate(invalid="ignore"):
        p_succ = np.where(n_valid > 0, n_succ / np.maximum(n_valid, 1), np.nan)

    def grid(a: np.ndarray) -> np.ndarray:
        return a.reshape(shape + a.shape[1:])

    per_sd = f"change in log-odds of {outcome} = 1 per standard deviation of the parameter"
    par_units = "units of the parameter (see parameter_units)"
    ds = xr.Dataset(
        {
            "coef": (pdims, grid(coef), {"units": "1", "long_name": f"standardized logistic coefficient: {per_sd}"}),
            "coef_se": (pdims, grid(coef_se), {"units": "1", "long_name": "standard error of coef (inverse penalized Hessian)"}),
            "coef_lower": (pdims, grid(coef - z * coef_se), {"units": "1", "long_name": f"lower bound of the {pct} Wald interval of coef"}),
            "coef_upper": (pdims, grid(coef + z * coef_se), {"units": "1", "long_name": f"upper bound of the {pct} Wald interval of coef"}),
            "param_mean": (pdims, grid(mean), {"units": par_units, "long_name": "mean of the parameter over the cell's valid runs"}),
            "param_sd": (pdims, grid(sd), {"units": par_units, "long_name": "standard deviation of the parameter (standardization scale)"}),
            "intercept": (dims, grid(icpt), {"units": "1", "long_name": f"log-odds of {outcome} = 1 at the mean parameters"}),
            "intercept_se": (dims, grid(icpt_se), {"units": "1", "long_name": "standard error of the intercept"}),
            "n_valid": (dims, grid(n_valid), {"units": "1", "long_name": "valid runs with finite parameters"}),
            "n_success": (dims, grid(n_succ), {"units": "1", "long_name": f"valid runs with {outcome} = 1"}),
            "p_success": (dims, grid(p_succ), {"units": "1", "long_name": f"fraction of valid runs with {outcome} = 1"}),
            "no_variation": (dims, grid(flat), {"units": "1", "long_name": f"{outcome} is all 0, all 1 or absent: not fitted"}),
            "separated": (
                dims,
                grid(separated),
                {"units": "1", "long_name": "classes completely separated: coefficients set by the ridge prior"},
            ),
            "converged": (dims, grid(converged), {"units": "1", "long_name": "the optimizer reported convergence"}),
        },
        coords=_coords(runs, dims, values, params),
        attrs={
            "title": f"logistic regression of {outcome} on standardized uncertain parameters",
            "outcome": outcome,
            "ridge": float(ridge),
            "confidence_level": float(level),
            "method": "penalized maximum likelihood (scipy.optimize.minimize, trust-exact)",
        },
    )
    return ds


def cell_mask(
    runs: xr.Dataset,
    shape: str,
    substrate: str,
    incline_deg: float | None = None,
    *,
    field_mT: float | None = None,
    freq_hz: float | None = None,
) -> np.ndarray:
    """Boolean mask over ``run`` of the runs of one cell.

    Parameters
    ----------
    runs : Dataset
        Study runs (dim ``run``) with the cell coordinates.
    shape, substrate : str
        The cell's shape and substrate.
    incline_deg : float, optional
        The cell's incline, degree; None takes every incline.
    field_mT, freq_hz : float, optional
        The field setting (mT, Hz). A study that sweeps the field or the frequency needs
        them: runs of different field settings are never pooled.

    Returns
    -------
    (n_run,) bool array

    Raises
    ------
    ValueError
        If no run matches, or the runs matched span several field settings.
    """
    mask = (np.asarray(runs["shape"].values).astype(str) == shape) & (np.asarray(runs["substrate"].values).astype(str) == substrate)
    for name, v in (("incline_deg", incline_deg), ("field_mT", field_mT), ("freq_hz", freq_hz)):
        if v is not None:
            mask &= np.asarray(runs[name].values, dtype=np.float64) == float(v)
    if not np.any(mask):
        raise ValueError(
            f"no run with shape={shape!r}, substrate={substrate!r}, incline_deg={incline_deg!r}, field_mT={field_mT!r}, freq_hz={freq_hz!r}"
        )
    for name in ("field_mT", "freq_hz"):
        if name in runs.variables and np.unique(np.asarray(runs[name].values)[mask]).size > 1:
            raise ValueError(f"the cell has several {name} values; pass {name}=")
    return mask
