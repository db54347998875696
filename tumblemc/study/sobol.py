"""End-to-end Sobol sensitivity of the robot, and SALib interop.

Saltelli rows through the simulator (:func:`sobol_rows`, :func:`robot_sobol`). The
estimators themselves, which never simulate, are in :mod:`tumblemc.analysis.sobol`.

Any SALib method (Morris, FAST, delta, ...) can drive the robot: :func:`salib_problem`
exports a cell's uncertain parameters as a SALib ``problem`` dict, :func:`salib_rows`
turns a sample matrix ``X`` of that problem into ``tumblemc.simulate`` keywords, and
:func:`salib_outputs` runs them (docs/libraries.md). SALib is not needed for either:
a ``problem`` is a plain dict.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from tumblemc.analysis.sobol import saltelli_design, sobol_indices, split_saltelli
from tumblemc.model.params import PRESETS, RANGES
from tumblemc.schema import sampled_name
from tumblemc.study.config import StudyConfig
from tumblemc.study.design import batch_row, run_kwargs
from tumblemc.study.distributions import nominal_value


def _independent(config: StudyConfig) -> None:
    if config.posterior is not None:
        raise ValueError("Sobol indices need independent inputs: a posterior's draws are correlated (allowed: [uncertain] distributions)")


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
        of the run table (:func:`tumblemc.study.design.sampled_name`).
    """
    u = np.asarray(U, dtype=np.float64)
    _independent(config)
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
        (:func:`tumblemc.study.design.run_kwargs`), the parameters mapped through the
        config's distributions. Run them, then ``split_saltelli(y, d)`` and
        :func:`sobol_indices` with ``names=config.uncertain_names``.
    """
    U, cells = _design_cells(config, n, seed, shape, substrate, incline_deg, field_mT, freq_hz)
    return U, [run_kwargs(config, c) for c in cells]


def _design_cells(
    config: StudyConfig, n: int, seed: int, shape: str, substrate: str, incline_deg: float, field_mT: float | None, freq_hz: float | None
) -> tuple[np.ndarray, list[dict[str, Any]]]:
    """The stacked Saltelli design and one run-table row per design row.

    A row holds the cell coordinates and the sampled parameters.
    """
    _independent(config)
    d = len(config.uncertain)
    if d == 0:
        raise ValueError("the config has no uncertain parameter: nothing to analyse")
    U = saltelli_design(n, d, seed).stack()
    b = _one(config.field_mT, field_mT, "field_mT")
    return U, _cells(config, map_unit_samples(config, U, substrate, b), shape, substrate, incline_deg, b, freq_hz)


def _cells(
    config: StudyConfig,
    values: dict[str, np.ndarray],
    shape: str,
    substrate: str,
    incline_deg: float,
    field_mT: float,
    freq_hz: float | None,
) -> list[dict[str, Any]]:
    f = _one(config.freq_hz, freq_hz, "freq_hz")
    cell = {"shape": shape, "substrate": substrate, "incline_deg": float(incline_deg), "field_mT": field_mT, "freq_hz": f}
    m = len(next(iter(values.values())))
    return [{**cell, **{k: float(v[i]) for k, v in values.items()}} for i in range(m)]


def _simulate(config: StudyConfig, shape: str, cells: list[dict[str, Any]], outcome: str) -> np.ndarray:
    """``outcome`` of every run-table row, NaN where the run failed (in-process)."""
    from tumblemc.model.rows import simulate_rows
    from tumblemc.study.design import grid_of

    if outcome not in ("progress_ratio", "mean_speed"):
        raise ValueError(f"outcome={outcome!r} is not allowed (allowed: progress_ratio, mean_speed)")
    # every run to the end: Sobol indices need every run's ratio, not a censored one
    res = simulate_rows(shape, [batch_row(config, c) for c in cells], dataclasses.replace(grid_of(config), early_decision=False))
    return np.where(res["status"] == 0, res[outcome], np.nan)


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
    _, cells = _design_cells(config, n, seed, shape, substrate, incline_deg, None, None)
    y = _simulate(config, shape, cells, outcome)
    yA, yB, yAB = split_saltelli(y, len(config.uncertain))
    out = sobol_indices(yA, yB, yAB, names=list(config.uncertain_names), n_boot=n_boot, level=level, seed=seed)
    out.attrs.update({"shape": shape, "substrate": substrate, "incline_deg": float(incline_deg), "outcome": outcome, "n_base": n})
    return out


# ------------------------------------------------------------------------ SALib interop


def _physical(dist: Any, param: str) -> tuple[str, list[float]]:
    """SALib ``dists`` entry and ``bounds`` row of a resolved scipy distribution."""
    name, args, kw = dist.dist.name, dist.args, dist.kwds
    loc, scale = float(kw.get("loc", 0.0)), float(kw.get("scale", 1.0))
    if name == "uniform":
        return "unif", [loc, loc + scale]
    if name == "triang" and float(args[0]) < 1.0:  # SALib wants the peak fraction < 1
        return "triang", [loc, loc + scale, float(args[0])]
    if name == "truncnorm":  # normal and truncnormal (cut at the physical range)
        return "truncnorm", [loc + float(args[0]) * scale, loc + float(args[1]) * scale, loc, scale]
    if name == "lognorm":
        return "lognorm", [math.log(scale), float(args[0])]
    raise ValueError(f"{param}: a {name} distribution with these parameters has no SALib equivalent; use space='unit'")


def salib_problem(config: StudyConfig, substrate: str, *, field_mT: float | None = None, space: str = "unit") -> dict[str, Any]:
    """A SALib ``problem`` dict of a study cell's uncertain parameters.

    Parameters
    ----------
    config : StudyConfig
        Its ``uncertain`` distributions (independent: no posterior).
    substrate : str
        Preset whose nominal values the distributions are centred on.
    field_mT : float, optional
        The cell's field, mT; needed only when the config has several.
    space : {"unit", "physical"}
        ``"unit"``: every input uniform on [0, 1], the space tumblemc samples; a row of
        ``X`` is mapped through the config's quantile functions (:func:`map_unit_samples`)
        exactly as tumblemc's own runs are. ``"physical"``: the distributions in the
        parameters' units, as SALib ``dists`` (``unif``, ``triang``, ``truncnorm``,
        ``lognorm``), for methods that read values (e.g. plots of ``X``).

    Returns
    -------
    dict
        ``num_vars``, ``names`` (``config.uncertain_names``), ``bounds``, ``dists``.

    Notes
    -----
    ``normal`` and ``truncnormal`` are both exported as SALib ``truncnorm`` cut at the
    bounds tumblemc cuts them at (for ``normal``, the physical range), so the physical
    export is exact for them and for ``uniform`` and ``triangular``; a ``lognormal`` that
    tumblemc restricts below a finite physical upper bound (at most 1e-6 of its mass)
    is exported unrestricted. A triangular with its mode at ``high`` has no SALib form.
    """
    _independent(config)
    if space not in ("unit", "physical"):
        raise ValueError(f"space={space!r} is not allowed (allowed: unit, physical)")
    if substrate not in PRESETS:
        raise ValueError(f"substrate {substrate!r} is not a preset; choose from {sorted(PRESETS)}")
    d = len(config.uncertain)
    if d == 0:
        raise ValueError("the config has no uncertain parameter: nothing to analyse")
    names = [u.param for u in config.uncertain]
    if space == "unit":
        return {"num_vars": d, "names": names, "bounds": [[0.0, 1.0] for _ in names], "dists": ["unif"] * d}
    b = _one(config.field_mT, field_mT, "field_mT")
    pairs = [
        _physical(u.resolve(nominal_value(u.param, substrate, b), where=f"preset {substrate}").dist, u.param) for u in config.uncertain
    ]
    return {"num_vars": d, "names": names, "bounds": [p[1] for p in pairs], "dists": [p[0] for p in pairs]}


def _is_physical_export(config: StudyConfig, problem: Mapping[str, Any], names: list[str], substrate: str, field_mT: float) -> bool:
    """Whether ``problem`` is :func:`salib_problem` ``(space="physical")`` of the cell, up to column order.

    Checked before :func:`_is_unit`: a physical export whose inputs are all uniform
    inside [0, 1] would otherwise be read as unit coordinates.
    """
    try:
        want = salib_problem(config, substrate, field_mT=field_mT, space="physical")
    except ValueError:
        return False
    dists = list(problem.get("dists") or ["unif"] * len(names))
    for p, dist, bound in zip(want["names"], want["dists"], want["bounds"], strict=True):
        i = names.index(p)
        row = np.asarray(problem["bounds"][i], dtype=np.float64)
        if dists[i] != dist or row.shape != (len(bound),) or not np.allclose(row, bound, rtol=1e-12, atol=0.0):
            return False
    return True


def _is_unit(problem: Mapping[str, Any]) -> bool:
    dists = problem.get("dists") or ["unif"] * len(problem["names"])
    rows = [np.asarray(b, dtype=np.float64) for b in problem["bounds"]]
    return all(d == "unif" for d in dists) and all(r.shape == (2,) and 0.0 <= r[0] < r[1] <= 1.0 for r in rows)


def salib_rows(
    config: StudyConfig,
    problem: Mapping[str, Any],
    X: ArrayLike,
    shape: str,
    substrate: str,
    incline_deg: float,
    *,
    field_mT: float | None = None,
    freq_hz: float | None = None,
) -> list[dict[str, Any]]:
    """``tumblemc.simulate`` keywords of each row of a SALib sample matrix.

    Parameters
    ----------
    config : StudyConfig
        Distributions, duration, time step and torque of the runs.
    problem : dict
        A SALib problem whose ``names`` are ``config``'s uncertain parameters (any order):
        a unit-space problem (every input ``unif`` with bounds inside [0, 1], e.g.
        :func:`salib_problem` ``(space="unit")`` or a trimmed ``[0.01, 0.99]`` for
        Morris), whose ``X`` is mapped through the config's distributions, or the
        ``space="physical"`` export of the same cell, whose ``X`` holds values.
    X : (m, num_vars) float array
        The sample (columns in ``problem["names"]`` order), e.g. from
        ``SALib.sample.morris.sample(problem, ...)``.
    shape, substrate, incline_deg : the cell (incline in degree).
    field_mT, freq_hz : the cell's field (mT) and frequency (Hz) if the config has several.

    Returns
    -------
    list of dict
        One :func:`tumblemc.study.design.run_kwargs` dict per row of ``X``.

    Raises
    ------
    ValueError
        If the names differ from the config's, ``X`` has the wrong shape, a physical
        problem is not this cell's export, or a value is outside its physical range.
    """
    cells = _salib_cells(config, problem, X, shape, substrate, incline_deg, field_mT, freq_hz)
    return [run_kwargs(config, c) for c in cells]


def _salib_cells(
    config: StudyConfig,
    problem: Mapping[str, Any],
    X: ArrayLike,
    shape: str,
    substrate: str,
    incline_deg: float,
    field_mT: float | None,
    freq_hz: float | None,
) -> list[dict[str, Any]]:
    _independent(config)
    own = [u.param for u in config.uncertain]
    names = [str(n) for n in problem["names"]]
    if sorted(names) != own:
        raise ValueError(f"problem names {names} are not the config's uncertain parameters {own}")
    x = np.asarray(X, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != len(names):
        raise ValueError(f"X must have shape (m, {len(names)}) (one column per problem name), got {x.shape}")
    cols = x[:, [names.index(p) for p in own]]
    b = _one(config.field_mT, field_mT, "field_mT")
    if _is_physical_export(config, problem, names, substrate, b):
        for j, p in enumerate(own):
            bad = [v for v in cols[:, j] if not RANGES[p].contains(float(v))]
            if bad:
                raise ValueError(f"X has {p} = {bad[0]:g} outside its physical range ({RANGES[p].describe()})")
        values = {sampled_name(p): cols[:, j].copy() for j, p in enumerate(own)}
    elif _is_unit(problem):
        values = map_unit_samples(config, cols, substrate, b)
    else:
        raise ValueError(
            f"problem is neither a unit-space problem (every input unif, bounds inside [0, 1]) nor the physical export "
            f"of preset {substrate!r} (salib_problem(config, {substrate!r}, space='physical'))"
        )
    return _cells(config, values, shape, substrate, incline_deg, b, freq_hz)


def salib_outputs(
    config: StudyConfig,
    problem: Mapping[str, Any],
    X: ArrayLike,
    shape: str,
    substrate: str,
    incline_deg: float,
    *,
    outcome: str = "progress_ratio",
    field_mT: float | None = None,
    freq_hz: float | None = None,
) -> np.ndarray:
    """Simulate every row of a SALib sample (in-process) and return ``outcome``, ``(m,)``.

    The rows are :func:`salib_rows`'; the study's time grid is used. A failed run gives
    NaN: SALib's analysers do not drop it (``sobol.analyze`` then returns zeros), so
    drop or impute it first, or use :func:`tumblemc.analysis.sobol.sobol_indices`.
    """
    return _simulate(config, shape, _salib_cells(config, problem, X, shape, substrate, incline_deg, field_mT, freq_hz), outcome)
