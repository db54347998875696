"""Sensitivity analysis and scenario discovery: which uncertain parameters decide success.

Three steps, kept apart as in SALib (sampling, running, analysis):

1. **Sampling** (no simulation): :func:`saltelli_design` draws the Saltelli matrices
   ``A``, ``B`` and ``AB_i`` on the unit hypercube from one scrambled Sobol sequence;
   :func:`sobol_rows` maps them through a study config's distributions into
   ``tumblemc.simulate`` keyword rows for one cell (:func:`map_unit_samples` does the
   mapping alone).
2. **Running**: the caller's (``simulate(**row)`` per row, or the engine).
3. **Analysis**: :func:`split_saltelli` and :func:`sobol_indices` (variance-based
   first-order and total indices with bootstrap intervals); and for any existing Monte
   Carlo study, whatever its sampler: :func:`rank_correlation` (Spearman),
   :func:`logistic_summary` (per-cell logistic regression of ``climbed``) and
   :func:`prim_box` / :func:`failure_region` (PRIM boxes where failures concentrate).

Per-cell analyses return an :class:`xarray.Dataset` with the cell coordinates as dims
plus ``parameter``; every variable has ``units`` and ``long_name``. Only valid runs
(``status == 0``) are used.

The analytic problems that check these estimators live in :mod:`tumblemc.testing`.

References
----------
Archer, G. E. B., Saltelli, A. & Sobol', I. M. (1997). Sensitivity measures, ANOVA-like
techniques and the use of bootstrap. J. Statist. Comput. Simul. 58, 99-120.
Friedman, J. H. & Fisher, N. I. (1999). Bump hunting in high-dimensional data.
Statistics and Computing 9, 123-143.
Jansen, M. J. W. (1999). Analysis of variance designs for model output. Computer Physics
Communications 117, 35-43.
Saltelli, A. (2002). Making best use of model evaluations to compute sensitivity
indices. Computer Physics Communications 145, 280-297.
Saltelli, A., Annoni, P., Azzini, I., Campolongo, F., Ratto, M. & Tarantola, S. (2010).
Variance based sensitivity analysis of model output. Design and estimator for the total
sensitivity index. Computer Physics Communications 181, 259-270.
Fieller, E. C., Hartley, H. O. & Pearson, E. S. (1957). Tests for rank correlation
coefficients. I. Biometrika 44, 470-481.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike
from scipy import optimize, stats
from scipy.special import expit, ndtri
from scipy.stats import qmc

from .analysis import COORD_ATTRS, SWEEP_DIMS, cell_groups
from .params import PRESETS
from .sampling import PHYSICAL_RANGE, StudyConfig, batch_row, nominal_value, run_kwargs, sampled_name

#: default cell coordinates of the per-cell analyses (swept field settings are added)
CELL_BY = ("shape", "substrate", "incline_deg")
#: default prior precision of the logistic coefficients (on standardized parameters)
RIDGE = 1e-2
_BOOT_ELEMENTS = 1 << 22  # bootstrap chunk size (float64 elements per array), ~32 MB

_COORD_ATTRS: dict[str, dict[str, str]] = {**COORD_ATTRS, "parameter": {"long_name": "uncertain parameter"}}


# ------------------------------------------------------------------------------ sampling


class SaltelliDesign(NamedTuple):
    """Saltelli matrices on the unit hypercube.

    ``A``, ``B``: (n, d); ``AB``: (d, n, d), ``AB[i]`` is ``A`` with column ``i`` taken
    from ``B`` (Saltelli 2010, section 3).
    """

    A: np.ndarray
    B: np.ndarray
    AB: np.ndarray

    @property
    def n(self) -> int:
        return int(self.A.shape[0])

    @property
    def d(self) -> int:
        return int(self.A.shape[1])

    def stack(self) -> np.ndarray:
        """All ``n (d + 2)`` points as one matrix in the SALib layout.

        Row block ``j`` (``d + 2`` rows) is ``A[j], AB[0][j], ..., AB[d-1][j], B[j]``;
        :func:`split_saltelli` takes the outputs of these rows apart again.
        """
        n, d = self.A.shape
        out = np.empty((n, d + 2, d))
        out[:, 0] = self.A
        out[:, 1 : d + 1] = np.swapaxes(self.AB, 0, 1)
        out[:, d + 1] = self.B
        return out.reshape(n * (d + 2), d)


def _pow2(n: int, what: str = "n") -> int:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise ValueError(f"{what} must be an integer >= 2, got {n!r}")
    m = int(n).bit_length() - 1
    if 1 << m != n:
        raise ValueError(f"{what} must be a power of 2 (Sobol points are balanced only then), got {n}; use {1 << m} or {1 << (m + 1)}")
    return m


def saltelli_design(n: int, d: int, seed: int) -> SaltelliDesign:
    """Saltelli design for first-order and total Sobol indices on the unit hypercube.

    Parameters
    ----------
    n : int
        Base sample size, a power of 2 (>= 2); the design has ``n (d + 2)`` points.
    d : int
        Number of inputs, >= 1.
    seed : int
        Seed of the scrambling (same seed, same design).

    Returns
    -------
    SaltelliDesign
        ``A`` and ``B`` (n, d) are the two halves of one ``2 d``-dimensional scrambled
        Sobol sequence; ``AB`` (d, n, d) the radial matrices. Values in [0, 1).

    Notes
    -----
    Saltelli (2002) and Saltelli et al. (2010, section 3): taking ``A`` and ``B`` from the
    first and last ``d`` coordinates of one quasi-random sequence of dimension ``2 d``
    keeps them independent of each other. ``n`` must be a power of two because only
    then does a scrambled Sobol sequence keep its balance (``random_base2``); no
    rounding is done silently. Second-order indices are not offered.
    """
    m = _pow2(n)
    if isinstance(d, bool) or not isinstance(d, (int, np.integer)) or d < 1:
        raise ValueError(f"d must be an integer >= 1, got {d!r}")
    base = qmc.Sobol(2 * int(d), scramble=True, rng=np.random.default_rng(seed)).random_base2(m)
    A = np.ascontiguousarray(base[:, :d])
    B = np.ascontiguousarray(base[:, d:])
    AB = np.repeat(A[None, :, :], d, axis=0)
    for i in range(d):
        AB[i, :, i] = B[:, i]
    return SaltelliDesign(A, B, AB)


def split_saltelli(y: ArrayLike, d: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Outputs of :meth:`SaltelliDesign.stack` rows taken apart.

    Parameters
    ----------
    y : (n (d + 2),) float array, outputs in the row order of the stacked matrix.
    d : number of inputs.

    Returns
    -------
    yA, yB : (n,) float64 arrays
    yAB : (d, n) float64 array, ``yAB[i]`` the outputs at ``AB[i]``.
    """
    v = np.asarray(y, dtype=np.float64).ravel()
    if d < 1 or v.size % (d + 2):
        raise ValueError(f"y has {v.size} values, not a multiple of d + 2 = {d + 2}")
    blocks = v.reshape(-1, d + 2)
    return blocks[:, 0].copy(), blocks[:, d + 1].copy(), np.ascontiguousarray(blocks[:, 1 : d + 1].T)


def map_unit_samples(config: StudyConfig, U: ArrayLike, substrate: str, field_mT: float) -> dict[str, np.ndarray]:
    """Map unit-hypercube points through a study's uncertain-parameter distributions.

    Parameters
    ----------
    config : StudyConfig
        Its ``uncertain`` entries give the distributions (column ``j`` of ``U`` is
        ``config.uncertain[j]``).
    U : (m, d) float array in (0, 1), ``d = len(config.uncertain)``.
    substrate : preset whose nominal values the distributions are centred on.
    field_mT : the cell's nominal field, mT (the nominal of an uncertain ``field_mT``).

    Returns
    -------
    dict
        ``{sampled_name(param): (m,) values}`` in the units of each parameter, the names
        of the run table (:func:`tumblemc.sampling.sampled_name`).
    """
    u = np.asarray(U, dtype=np.float64)
    d = len(config.uncertain)
    if u.ndim != 2 or u.shape[1] != d:
        raise ValueError(f"U must have shape (m, {d}) (one column per uncertain parameter), got {u.shape}")
    if substrate not in PRESETS:
        raise ValueError(f"substrate {substrate!r} is not a preset; choose from {sorted(PRESETS)}")
    out: dict[str, np.ndarray] = {}
    for j, unc in enumerate(config.uncertain):
        dist = unc.resolve(nominal_value(unc.param, substrate, field_mT), where=f"preset {substrate}")
        out[sampled_name(unc.param)] = dist.ppf(u[:, j])
    return out


def _one(values: Sequence[float], given: float | None, name: str) -> float:
    if given is not None:
        return float(given)
    if len(values) != 1:
        raise ValueError(f"the config has several {name} values {list(values)}; pass {name}=")
    return float(values[0])


def sobol_rows(
    config: StudyConfig,
    n: int,
    seed: int,
    shape: str,
    substrate: str,
    incline_deg: float,
    *,
    field_mT: float | None = None,
    freq_hz: float | None = None,
) -> tuple[np.ndarray, list[dict[str, Any]]]:
    """The runs of a Sobol sensitivity study of one cell of a robustness study.

    Parameters
    ----------
    config : StudyConfig
        Distributions (``uncertain``), duration, time step and torque of the runs.
    n : int
        Base sample size, a power of 2; ``n (d + 2)`` runs with ``d`` uncertain
        parameters.
    seed : int
        Seed of the Saltelli design.
    shape, substrate : cell shape and preset.
    incline_deg : cell incline, degree.
    field_mT, freq_hz : cell field (mT) and frequency (Hz); needed only when the config
        has several.

    Returns
    -------
    unit_matrix : (n (d + 2), d) float64 array
        :meth:`SaltelliDesign.stack` of :func:`saltelli_design` ``(n, d, seed)``.
    rows : list of dict
        One ``tumblemc.simulate`` keyword dict per row of ``unit_matrix``
        (:func:`tumblemc.sampling.run_kwargs`), the parameters mapped through the
        config's distributions. Run them, then ``split_saltelli(y, d)`` and
        :func:`sobol_indices` with ``names=config.uncertain_names``.
    """
    U, cells = _design_cells(config, n, seed, shape, substrate, incline_deg, field_mT, freq_hz)
    return U, [run_kwargs(config, c) for c in cells]


def _design_cells(
    config: StudyConfig, n: int, seed: int, shape: str, substrate: str, incline_deg: float, field_mT: float | None, freq_hz: float | None
) -> tuple[np.ndarray, list[dict[str, Any]]]:
    """The stacked Saltelli design and one run-table row (cell coordinates and sampled
    parameters) per design row."""
    d = len(config.uncertain)
    if d == 0:
        raise ValueError("the config has no uncertain parameter: nothing to analyse")
    b = _one(config.field_mT, field_mT, "field_mT")
    f = _one(config.freq_hz, freq_hz, "freq_hz")
    U = saltelli_design(n, d, seed).stack()
    values = map_unit_samples(config, U, substrate, b)
    cell = {"shape": shape, "substrate": substrate, "incline_deg": float(incline_deg), "field_mT": b, "freq_hz": f}
    return U, [{**cell, **{k: float(v[i]) for k, v in values.items()}} for i in range(U.shape[0])]


def robot_sobol(
    config: StudyConfig,
    shape: str,
    substrate: str,
    incline_deg: float,
    *,
    n: int = 64,
    seed: int = 0,
    outcome: str = "progress_ratio",
    n_boot: int = 1000,
    level: float = 0.95,
) -> xr.Dataset:
    """Sobol indices of a robot's ``outcome`` in one cell, end to end (in-process).

    Builds :func:`sobol_rows`, simulates every row through the batch kernel with the
    study's time grid (:func:`tumblemc.engine.grid_of`), and returns
    :func:`sobol_indices` of ``outcome`` (``progress_ratio`` or ``mean_speed``). Cost:
    ``n (d + 2)`` simulations (d uncertain parameters); runs that fail are dropped and
    counted (``attrs["n_dropped"]``).
    """
    from .batch import simulate_rows
    from .engine import grid_of

    if outcome not in ("progress_ratio", "mean_speed"):
        raise ValueError(f"outcome={outcome!r} is not allowed (allowed: progress_ratio, mean_speed)")
    _, cells = _design_cells(config, n, seed, shape, substrate, incline_deg, None, None)
    res = simulate_rows(shape, [batch_row(config, c) for c in cells], grid_of(config))
    y = np.where(res["status"] == 0, res[outcome], np.nan)
    yA, yB, yAB = split_saltelli(y, len(config.uncertain))
    out = sobol_indices(yA, yB, yAB, names=list(config.uncertain_names), n_boot=n_boot, level=level, seed=seed)
    out.attrs.update({"shape": shape, "substrate": substrate, "incline_deg": float(incline_deg), "outcome": outcome, "n_base": n})
    return out


# ------------------------------------------------------------------------- Sobol indices


def _sobol_point(yA: np.ndarray, yB: np.ndarray, yAB: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """S1, ST over the last axis; leading axes broadcast (bootstrap replicates)."""
    var = np.var(np.concatenate([yA, yB], axis=-1), axis=-1)
    first = np.mean(yB[..., None, :] * (yAB - yA[..., None, :]), axis=-1)
    total = 0.5 * np.mean((yA[..., None, :] - yAB) ** 2, axis=-1)
    ok = var > 0.0
    v = np.where(ok, var, 1.0)[..., None]
    s1 = np.where(ok[..., None], first / v, np.nan)
    st = np.where(ok[..., None], total / v, np.nan)
    return s1, st, var


def sobol_indices(
    yA: ArrayLike,
    yB: ArrayLike,
    yAB: ArrayLike,
    *,
    names: Sequence[str] | None = None,
    n_boot: int = 1000,
    level: float = 0.95,
    seed: int = 0,
) -> xr.Dataset:
    """First-order and total Sobol indices with bootstrap confidence intervals.

    Parameters
    ----------
    yA, yB : (n,) float arrays
        Model outputs at the rows of ``A`` and ``B`` (:func:`saltelli_design`).
    yAB : (d, n) float array
        Outputs at ``AB[i]`` (``A`` with column ``i`` from ``B``).
    names : d parameter names (default ``x1 ... xd``).
    n_boot : bootstrap replicates (rows resampled with replacement), >= 0; 0 skips the
        intervals (they are NaN).
    level : confidence level of the percentile intervals, in (0, 1).
    seed : seed of the bootstrap resampling.

    Returns
    -------
    Dataset
        Dim ``parameter``: ``S1``, ``ST`` with ``*_lower``/``*_upper`` (percentile
        bootstrap interval) and ``*_se`` (bootstrap standard deviation). Attributes
        ``n_used`` (rows used), ``n_dropped`` (rows with a non-finite output, dropped),
        ``variance`` (output variance), ``n_boot``, ``confidence_level``.

    Notes
    -----
    With ``V`` the variance of the pooled ``yA`` and ``yB``:

    - first order (Saltelli et al. 2010, table 2 (b)):
      ``S1_i = mean(yB (yAB_i - yA)) / V``;
    - total (Jansen 1999; Saltelli et al. 2010, table 2 (f)):
      ``ST_i = mean((yA - yAB_i)^2) / (2 V)``.

    A row ``j`` (``yA[j]``, ``yB[j]`` and every ``yAB[i, j]``) is dropped when any of its
    outputs is NaN or infinite (a failed run), which keeps the estimators' pairing. The
    bootstrap resamples whole rows (Archer et al. 1997). Both estimators are unbiased
    but not bounded: small indices can come out slightly negative.
    """
    a = np.asarray(yA, dtype=np.float64).ravel()
    b = np.asarray(yB, dtype=np.float64).ravel()
    ab = np.asarray(yAB, dtype=np.float64)
    if ab.ndim == 1:
        ab = ab[None, :]
    if a.size != b.size or ab.ndim != 2 or ab.shape[1] != a.size:
        raise ValueError(f"need yA (n,), yB (n,) and yAB (d, n); got {a.shape}, {b.shape}, {ab.shape}")
    d = ab.shape[0]
    labels = [f"x{i + 1}" for i in range(d)] if names is None else [str(s) for s in names]
    if len(labels) != d:
        raise ValueError(f"names has {len(labels)} entries for d = {d} inputs")
    if not (0.0 < float(level) < 1.0):
        raise ValueError(f"level must be in (0, 1), got {level!r}")
    if isinstance(n_boot, bool) or not isinstance(n_boot, (int, np.integer)) or n_boot < 0:
        raise ValueError(f"n_boot must be an integer >= 0, got {n_boot!r}")
    keep = np.isfinite(a) & np.isfinite(b) & np.all(np.isfinite(ab), axis=0)
    n_dropped = int(a.size - np.count_nonzero(keep))
    a, b, ab = a[keep], b[keep], ab[:, keep]
    n = a.size
    if n < 2:
        raise ValueError(f"{n} complete rows after dropping {n_dropped} with non-finite outputs; need at least 2")
    s1, st, var = _sobol_point(a, b, ab)
    if not var > 0.0:
        raise ValueError("the output is constant over the design: Sobol indices are undefined")

    lo1 = hi1 = lot = hit = se1 = set_ = np.full(d, np.nan)
    n_bad = 0
    if n_boot:
        rng = np.random.default_rng(seed)
        chunk = max(1, _BOOT_ELEMENTS // (n * (d + 2)))
        boot1 = np.empty((n_boot, d))
        boott = np.empty((n_boot, d))
        for start in range(0, n_boot, chunk):
            stop = min(n_boot, start + chunk)
            idx = rng.integers(0, n, size=(stop - start, n))
            b1, bt, _ = _sobol_point(a[idx], b[idx], np.moveaxis(ab[:, idx], 0, 1))
            boot1[start:stop], boott[start:stop] = b1, bt
        good = np.all(np.isfinite(boot1), axis=1) & np.all(np.isfinite(boott), axis=1)
        n_bad = int(n_boot - np.count_nonzero(good))  # replicates with constant output
        if np.count_nonzero(good) >= 2:
            q = [0.5 * (1.0 - level), 0.5 * (1.0 + level)]
            lo1, hi1 = np.quantile(boot1[good], q, axis=0)
            lot, hit = np.quantile(boott[good], q, axis=0)
            se1 = np.std(boot1[good], axis=0, ddof=1)
            set_ = np.std(boott[good], axis=0, ddof=1)

    pct = f"{100 * float(level):g}%"
    dim = ("parameter",)

    def var_(x: np.ndarray, long: str) -> tuple[tuple[str], np.ndarray, dict[str, str]]:
        return (dim, np.asarray(x, dtype=np.float64), {"units": "1", "long_name": long})

    ds = xr.Dataset(
        {
            "S1": var_(s1, "first-order Sobol index (Saltelli et al. 2010 estimator)"),
            "S1_lower": var_(lo1, f"lower bound of the {pct} bootstrap percentile interval of S1"),
            "S1_upper": var_(hi1, f"upper bound of the {pct} bootstrap percentile interval of S1"),
            "S1_se": var_(se1, "bootstrap standard error of S1"),
            "ST": var_(st, "total Sobol index (Jansen 1999 estimator)"),
            "ST_lower": var_(lot, f"lower bound of the {pct} bootstrap percentile interval of ST"),
            "ST_upper": var_(hit, f"upper bound of the {pct} bootstrap percentile interval of ST"),
            "ST_se": var_(set_, "bootstrap standard error of ST"),
        },
        coords={"parameter": ("parameter", np.asarray(labels, dtype=str), _COORD_ATTRS["parameter"])},
        attrs={
            "title": "variance-based sensitivity indices",
            "n_used": int(n),
            "n_dropped": n_dropped,
            "variance": float(var),
            "n_boot": int(n_boot),
            "n_boot_degenerate": n_bad,
            "confidence_level": float(level),
            "bootstrap_seed": int(seed),
            "S1_estimator": "mean(yB * (yAB_i - yA)) / V (Saltelli et al. 2010)",
            "ST_estimator": "mean((yA - yAB_i)**2) / (2 V) (Jansen 1999)",
        },
    )
    return ds


# ---------------------------------------------------------------------- per-cell helpers


def _parameters(runs: xr.Dataset, parameters: Sequence[str] | None) -> list[tuple[str, str]]:
    """(parameter, run-table variable) pairs of the uncertain parameters."""
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
    """Sorted unique values per dim, the grid shape, and the run indices of each cell
    (C order over the grid): :func:`tumblemc.analysis.cell_groups`."""
    values, shape, _, groups = cell_groups(runs, dims)
    return values, shape, groups


def _valid(runs: xr.Dataset) -> np.ndarray:
    if "status" not in runs.variables:
        raise ValueError("runs has no 'status' variable (0 = valid run)")
    return np.asarray(runs["status"].values) == 0


def _coords(runs: xr.Dataset, dims: Sequence[str], values: Mapping[str, np.ndarray], params: Sequence[tuple[str, str]]) -> dict[str, Any]:
    coords: dict[str, Any] = {}
    for d in dims:
        attrs = dict(_COORD_ATTRS.get(d, {}))
        attrs.update({k: v for k, v in runs[d].attrs.items() if k in ("units", "long_name")})
        coords[d] = (d, values[d], attrs)
    coords["parameter"] = ("parameter", np.asarray([p for p, _ in params], dtype=str), _COORD_ATTRS["parameter"])
    units = [str(runs[v].attrs.get("units", PHYSICAL_RANGE[p].units if p in PHYSICAL_RANGE else "")) for p, v in params]
    coords["parameter_units"] = ("parameter", np.asarray(units, dtype=str), {"long_name": "units of the parameter"})
    return coords


# ---------------------------------------------------------------------- rank correlation


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
    by : cell coordinates; default ``("shape", "substrate", "incline_deg")`` plus
        ``field_mT``/``freq_hz`` when the study sweeps them.
    outcome : per-run variable, e.g. ``"progress_ratio"`` or ``"climbed"``.
    parameters : parameter names (default: ``runs.attrs["uncertain"]``).
    level : confidence level of ``rho_lower``/``rho_upper``.

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
    params = _parameters(runs, parameters)
    dims = _by(runs, by)
    if outcome not in runs.variables:
        raise ValueError(f"runs has no outcome variable {outcome!r}")
    if not (0.0 < float(level) < 1.0):
        raise ValueError(f"level must be in (0, 1), got {level!r}")
    values, shape, groups = _groups(runs, dims)
    valid = _valid(runs)
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


# ------------------------------------------------------------------- logistic regression


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
    """Whether a hyperplane separates the classes completely (Albert & Anderson 1984):
    the linear program ``(2 y - 1)(b + Z w) >= 1`` is feasible."""
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
    by : cell coordinates (default as :func:`rank_correlation`).
    outcome : per-run 0/1 variable (``climbed``).
    parameters : parameter names (default: ``runs.attrs["uncertain"]``).
    ridge : precision of the Gaussian prior ``N(0, 1 / ridge)`` on the intercept and
        each standardized coefficient (a ridge penalty ``ridge |beta|^2 / 2``), > 0. The
        default 0.01 (prior SD of 10 log-odds per SD) barely moves coefficients that the
        data determine and keeps them finite under separation.
    level : confidence level of the Wald intervals ``coef +- z se``.

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
    params = _parameters(runs, parameters)
    dims = _by(runs, by)
    if outcome not in runs.variables:
        raise ValueError(f"runs has no outcome variable {outcome!r}")
    if not (isinstance(ridge, (int, float)) and ridge > 0 and math.isfinite(ridge)):
        raise ValueError(f"ridge must be a positive number, got {ridge!r}")
    if not (0.0 < float(level) < 1.0):
        raise ValueError(f"level must be in (0, 1), got {level!r}")
    values, shape, groups = _groups(runs, dims)
    valid = _valid(runs)
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


# --------------------------------------------------------------------------------- PRIM


@dataclass(frozen=True)
class PrimResult:
    """Outcome of :func:`prim_box`.

    ``box`` maps each parameter the chosen box restricts to ``(lo, hi)`` (``-inf``/``inf``
    on a side never peeled); a point is inside when ``lo < x < hi`` for every entry.
    ``coverage``: fraction of all target points inside; ``density``: fraction of the
    points inside that are targets; ``support``: fraction of all points inside;
    ``step``: the chosen step of ``trajectory`` (dims ``step``, ``parameter``).
    """

    box: dict[str, tuple[float, float]]
    coverage: float
    density: float
    support: float
    step: int
    names: tuple[str, ...]
    trajectory: xr.Dataset = field(repr=False)

    def contains(self, X: ArrayLike) -> np.ndarray:
        """Boolean mask of the rows of ``X`` (columns in ``names`` order) inside the box."""
        x = np.asarray(X, dtype=np.float64)
        inside = np.ones(x.shape[0], dtype=bool)
        for name, (lo, hi) in self.box.items():
            j = self.names.index(name)
            inside &= (x[:, j] > lo) & (x[:, j] < hi)
        return inside


def _choose(density: np.ndarray, n_box: np.ndarray, threshold: float | None) -> tuple[int, str]:
    if threshold is not None:
        hit = np.flatnonzero(density >= threshold)
        if hit.size:
            return int(hit[0]), f"first box with density >= {threshold:g}"
    k = int(np.argmax(density))
    d_max = float(density[k])
    tol = math.sqrt(d_max * (1.0 - d_max) / float(n_box[k]))
    first = int(np.flatnonzero(density >= d_max - tol - 1e-12)[0])
    rule = "first box within one binomial standard error of the peak density (1-SE rule)"
    if threshold is not None:
        rule = f"no box reaches density {threshold:g}; {rule}"
    return first, rule


def prim_box(
    X: ArrayLike,
    y: ArrayLike,
    names: Sequence[str],
    *,
    alpha: float = 0.05,
    min_support: float = 0.05,
    target: float = 1,
    threshold: float | None = None,
) -> PrimResult:
    """PRIM peeling: a box in parameter space where ``y == target`` is concentrated.

    Parameters
    ----------
    X : (n, d) float array of finite inputs.
    y : (n,) outcomes; the points with ``y == target`` are the targets (e.g. failures).
    names : d parameter names.
    alpha : fraction of the box's points peeled per step, in (0, 0.5).
    min_support : peeling stops before the box holds fewer than this fraction of all
        points, in (0, 1).
    target : the outcome value sought.
    threshold : choose the first (largest) box whose density reaches this; None (or
        when none does): the first box whose density is within one binomial standard
        error of the peak density along the trajectory.

    Returns
    -------
    PrimResult
        The chosen box (only the parameters actually peeled), its coverage, density and
        support, and the whole ``trajectory`` Dataset (dim ``step``; ``coverage``,
        ``density``, ``support``, ``n_in_box``, ``peeled_parameter``, ``peeled_side``;
        ``lower``/``upper`` with dims ``(step, parameter)``; ``attrs["chosen_step"]``).

    Notes
    -----
    Friedman & Fisher (1999, section 4.1), top-down peeling without pasting: at each
    step every dimension is cut at its ``alpha`` (lower side) or ``1 - alpha`` (upper
    side) quantile among the points in the box, and the cut leaving the highest target
    density is kept (ties: the one removing fewer points, then the first dimension).
    Cuts that remove nothing (ties) or leave less than ``min_support`` are not allowed.
    Bounds lie midway between the last point removed and the first point kept, so the
    open box selects exactly the points kept.
    """
    x = np.asarray(X, dtype=np.float64)
    lab = [str(s) for s in names]
    if x.ndim != 2 or x.shape[1] != len(lab):
        raise ValueError(f"X must have shape (n, {len(lab)}) to match names, got {x.shape}")
    yv = np.asarray(y).ravel()
    if yv.size != x.shape[0]:
        raise ValueError(f"y has {yv.size} values for {x.shape[0]} rows of X")
    if not np.all(np.isfinite(x)):
        raise ValueError("X must be finite (drop invalid runs first)")
    if not (0.0 < alpha < 0.5):
        raise ValueError(f"alpha must be in (0, 0.5), got {alpha!r}")
    if not (0.0 < min_support < 1.0):
        raise ValueError(f"min_support must be in (0, 1), got {min_support!r}")
    t = yv == target
    n, d = x.shape
    n_t = int(np.count_nonzero(t))
    if n_t == 0:
        raise ValueError(f"no point has y == {target!r}: there is nothing to find")
    inbox = np.ones(n, dtype=bool)
    lo = np.full(d, -np.inf)
    hi = np.full(d, np.inf)
    steps: list[tuple[int, int, np.ndarray, np.ndarray, str, str]] = [(n, n_t, lo.copy(), hi.copy(), "", "")]
    n_min = math.ceil(min_support * n - 1e-9)
    while True:
        nb = int(np.count_nonzero(inbox))
        k = max(1, math.ceil(alpha * nb - 1e-9))
        xb, tb = x[inbox], t[inbox]
        # ((density, -removed, -j, -side), kept rows, bound) of the best peel so far
        best: tuple[tuple[float, int, int, int], np.ndarray, float] | None = None
        for j in range(d if k < nb else 0):
            s = np.sort(xb[:, j])
            for side in (0, 1):
                if side == 0:
                    cut = s[k]
                    keep = xb[:, j] >= cut
                else:
                    cut = s[nb - 1 - k]
                    keep = xb[:, j] <= cut
                kept = int(np.count_nonzero(keep))  # >= 1: the cut point itself stays
                if kept == nb or kept < n_min:  # nothing peeled (ties), or too small a box
                    continue
                # something was peeled: the bound lies midway to the nearest peeled point
                bound = 0.5 * (s[s < cut][-1] + cut) if side == 0 else 0.5 * (s[s > cut][0] + cut)
                key = (int(np.count_nonzero(tb[keep])) / kept, -(nb - kept), -j, -side)
                if best is None or key > best[0]:
                    best = (key, keep, float(bound))
        if best is None:
            break
        key, keep, bound = best
        j, side = -key[2], -key[3]
        where = np.flatnonzero(inbox)
        inbox[where[~keep]] = False
        if side == 0:
            lo[j] = bound
        else:
            hi[j] = bound
        steps.append(
            (int(np.count_nonzero(inbox)), int(np.count_nonzero(t & inbox)), lo.copy(), hi.copy(), lab[j], ("lower", "upper")[side])
        )

    n_box = np.array([s[0] for s in steps], dtype=np.int64)
    n_tb = np.array([s[1] for s in steps], dtype=np.int64)
    density = n_tb / n_box
    coverage = n_tb / n_t
    support = n_box / n
    chosen, rule = _choose(density, n_box, threshold)
    lower = np.array([s[2] for s in steps])
    upper = np.array([s[3] for s in steps])
    box = {
        lab[j]: (float(lower[chosen, j]), float(upper[chosen, j]))
        for j in range(d)
        if np.isfinite(lower[chosen, j]) or np.isfinite(upper[chosen, j])
    }
    step = ("step",)
    traj = xr.Dataset(
        {
            "coverage": (step, coverage, {"units": "1", "long_name": "fraction of all target points inside the box"}),
            "density": (step, density, {"units": "1", "long_name": "fraction of the points inside the box that are targets"}),
            "support": (step, support, {"units": "1", "long_name": "fraction of all points inside the box"}),
            "n_in_box": (step, n_box, {"units": "1", "long_name": "points inside the box"}),
            "n_target_in_box": (step, n_tb, {"units": "1", "long_name": "target points inside the box"}),
            "peeled_parameter": (step, np.asarray([s[4] for s in steps], dtype=str), {"long_name": "parameter cut at this step"}),
            "peeled_side": (step, np.asarray([s[5] for s in steps], dtype=str), {"long_name": "side of the cut (lower or upper)"}),
            "lower": (
                ("step", "parameter"),
                lower,
                {"units": "units of the parameter", "long_name": "lower bound of the box (-inf: open)"},
            ),
            "upper": (("step", "parameter"), upper, {"units": "units of the parameter", "long_name": "upper bound of the box (inf: open)"}),
        },
        coords={
            "step": ("step", np.arange(len(steps)), {"long_name": "peeling step"}),
            "parameter": ("parameter", np.asarray(lab, dtype=str)),
        },
        attrs={
            "title": "PRIM peeling trajectory (Friedman & Fisher 1999)",
            "chosen_step": int(chosen),
            "selection": rule,
            "alpha": float(alpha),
            "min_support": float(min_support),
            "target": f"y == {target!r}",
            "n_points": int(n),
            "n_target": n_t,
        },
    )
    return PrimResult(box, float(coverage[chosen]), float(density[chosen]), float(support[chosen]), int(chosen), tuple(lab), traj)


def cell_mask(
    runs: xr.Dataset,
    shape: str,
    substrate: str,
    incline_deg: float | None = None,
    *,
    field_mT: float | None = None,
    freq_hz: float | None = None,
) -> np.ndarray:
    """Boolean mask over ``run`` of the runs of one cell (``incline_deg=None``: every
    incline). A study that sweeps the field or the frequency needs ``field_mT=`` /
    ``freq_hz=``: runs of different field settings are never pooled."""
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


def failure_region(
    runs: xr.Dataset,
    shape: str,
    substrate: str,
    incline_deg: float,
    *,
    field_mT: float | None = None,
    freq_hz: float | None = None,
    parameters: Sequence[str] | None = None,
    alpha: float = 0.05,
    min_support: float = 0.05,
    threshold: float | None = None,
) -> PrimResult:
    """PRIM box of the parameter region where a study cell's valid runs fail to climb.

    Parameters
    ----------
    runs : study Dataset.
    shape, substrate, incline_deg : the cell (``incline_deg`` in degree).
    field_mT, freq_hz : needed when the study sweeps them.
    parameters : parameter names (default ``runs.attrs["uncertain"]``).
    alpha, min_support, threshold : see :func:`prim_box`.

    Returns
    -------
    PrimResult
        Targets are the valid runs (``status == 0``) with ``climbed == 0``; the box
        bounds are in the units of each parameter.
    """
    params = _parameters(runs, parameters)
    mask = cell_mask(runs, shape, substrate, incline_deg, field_mT=field_mT, freq_hz=freq_hz) & _valid(runs)
    X = np.column_stack([np.asarray(runs[v].values, dtype=np.float64)[mask] for _, v in params])
    failed = np.asarray(runs["climbed"].values)[mask] == 0
    ok = np.all(np.isfinite(X), axis=1)
    res = prim_box(X[ok], failed[ok], [p for p, _ in params], alpha=alpha, min_support=min_support, target=True, threshold=threshold)
    res.trajectory.attrs.update(
        {"target": "valid run that did not climb", "shape": shape, "substrate": substrate, "incline_deg": float(incline_deg)}
    )
    return res


__all__ = [
    "CELL_BY",
    "RIDGE",
    "PrimResult",
    "SaltelliDesign",
    "cell_mask",
    "failure_region",
    "logistic_summary",
    "map_unit_samples",
    "prim_box",
    "rank_correlation",
    "saltelli_design",
    "sobol_indices",
    "sobol_rows",
    "split_saltelli",
]
