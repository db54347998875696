"""End-to-end Sobol sensitivity of the robot.

Saltelli rows through the simulator (:func:`sobol_rows`, :func:`robot_sobol`). The
estimators themselves, which never simulate, are in :mod:`tumblemc.analysis.sobol`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from tumblemc.analysis.sobol import saltelli_design, sobol_indices, split_saltelli
from tumblemc.model.params import PRESETS
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
    from tumblemc.model.rows import simulate_rows
    from tumblemc.study.design import grid_of

    if outcome not in ("progress_ratio", "mean_speed"):
        raise ValueError(f"outcome={outcome!r} is not allowed (allowed: progress_ratio, mean_speed)")
    _, cells = _design_cells(config, n, seed, shape, substrate, incline_deg, None, None)
    res = simulate_rows(shape, [batch_row(config, c) for c in cells], grid_of(config))
    y = np.where(res["status"] == 0, res[outcome], np.nan)
    yA, yB, yAB = split_saltelli(y, len(config.uncertain))
    out = sobol_indices(yA, yB, yAB, names=list(config.uncertain_names), n_boot=n_boot, level=level, seed=seed)
    out.attrs.update({"shape": shape, "substrate": substrate, "incline_deg": float(incline_deg), "outcome": outcome, "n_base": n})
    return out
