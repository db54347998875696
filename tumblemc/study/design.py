"""A study's design.

Run keys, seeded uniforms per run (``mc``, ``sobol``, ``lhs``), the run table
(:func:`design`), the keyword rows handed to the batch path, the time grid and the
numerical-check subset. Randomness is data: a run's draw depends only on the root seed
and the run's identity.

*Samplers.* Uniforms in (0, 1) are mapped through each distribution's ppf.

- ``mc`` (default): one stream per run, ``SeedSequence([seed, *cell_hash, sample])``,
  one slot of it per possible uncertain parameter (:data:`UNCERTAIN_PARAMS` order), so a
  run's draw does not depend on the other runs, on ``samples``, or on which other
  parameters are uncertain. Per-cell success counts are exactly binomial, which is what
  the Wilson and Clopper-Pearson intervals assume: the reported intervals are honest.
- ``sobol``: scrambled Sobol points (:class:`scipy.stats.qmc.Sobol`) seeded by
  ``SeedSequence([seed, *cell_hash])``; ``2**ceil(log2 N)`` points are drawn and the first
  N kept, so growing ``samples`` keeps the earlier runs (balance is best when N is a
  power of two). Estimates usually have lower variance than ``mc``, but the runs of a
  cell are not independent, so binomial intervals are only approximate for it.
- ``lhs``: Latin hypercube (:class:`scipy.stats.qmc.LatinHypercube`) seeded by the cell.
  Independent of other cells and of run order, but *not* prefix-stable: changing
  ``samples`` redraws every run of the cell.

Changing :data:`SAMPLING_SCHEME` (any change to how draws are derived) changes every
:func:`config_hash`.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Mapping
from typing import Any, cast

import numpy as np
import xarray as xr
from scipy.stats import qmc

from tumblemc.model.params import RANGES
from tumblemc.model.rows import RunRow, TimeGrid
from tumblemc.schema import COORD_ATTRS, sampled_name
from tumblemc.study.checks import is_number
from tumblemc.study.config import SAMPLING_SCHEME, StudyConfig, cells
from tumblemc.study.distributions import POSTERIOR_SLOT, U_EPS, UNCERTAIN_PARAMS, ParamDistribution, mc_slot, nominal_value
from tumblemc.study.fieldcfg import AXIS_ERRORS, program
from tumblemc.study.identity import config_hash, config_to_json
from tumblemc.study.stepcfg import row_dt


def _canonical_cell(cell: Mapping[str, Any]) -> str:
    canon = {k: (float(v) + 0.0 if is_number(v) else str(v)) for k, v in cell.items()}  # 30 and 30.0: one cell
    return json.dumps(canon, sort_keys=True, separators=(",", ":"))


def _digest(text: str) -> bytes:
    return hashlib.sha256(text.encode("utf-8")).digest()


def cell_key(cell: Mapping[str, Any]) -> str:
    """Stable id of a cell: 16 hex digits of sha256 of its canonical JSON."""
    return _digest(_canonical_cell(cell)).hex()[:16]


def run_key(cell: Mapping[str, Any], sample: int) -> int:
    """Stable int64 id (>= 0) of a run: sha256 of its cell and sample index."""
    return _run_key(_canonical_cell(cell), sample)


def _run_key(canon: str, sample: int) -> int:
    return int.from_bytes(_digest(f"{canon}#{int(sample)}")[:8], "little") & (2**63 - 1)


def _cell_words(cell: Mapping[str, Any]) -> list[int]:
    d = _digest(_canonical_cell(cell))
    return [int.from_bytes(d[4 * i : 4 * i + 4], "little") for i in range(4)]


def _mc_uniforms(seed: int, words: list[int], n: int, slots: list[int]) -> np.ndarray:
    """(n, len(slots)) uniforms, one SeedSequence per run, one slot per parameter."""
    out = np.empty((n, len(slots)))
    width = len(UNCERTAIN_PARAMS) + 1  # every slot and the posterior's; generate_state is prefix-stable
    for s in range(n):
        state = np.random.SeedSequence([seed, *words, s]).generate_state(width, np.uint64)
        out[s] = ((state[slots] >> np.uint64(11)).astype(float) + 0.5) * 2.0**-53
    return out


def _cell_uniforms(config: StudyConfig, cell: Mapping[str, Any]) -> np.ndarray:
    """Uniforms in (0, 1) for one cell.

    Shape (samples, n_uncertain), columns in ``config.uncertain`` order.
    """
    n, d = config.samples, len(config.uncertain)
    if d == 0:
        return np.empty((n, 0))
    words = _cell_words(cell)
    if config.sampler == "mc":
        return _mc_uniforms(config.seed, words, n, [mc_slot(u.param) for u in config.uncertain])
    rng = np.random.default_rng(np.random.SeedSequence([config.seed, *words]))
    if config.sampler == "sobol":
        u = qmc.Sobol(d, scramble=True, rng=rng).random_base2(max(0, math.ceil(math.log2(n))))[:n]
    else:
        u = qmc.LatinHypercube(d, rng=rng).random(n)
    return np.clip(u, U_EPS, 1.0 - U_EPS)


def n_check_runs(config: StudyConfig, n: int) -> int:
    """How many of ``n`` runs the numerical check re-simulates: ``max(min_runs, ceil(fraction n))``, at most ``n``."""
    return min(n, max(config.check.min_runs, math.ceil(config.check.fraction * n)))


def check_mask(config: StudyConfig, keys: np.ndarray) -> np.ndarray:
    """The numerical-check subset: the runs with the smallest seeded hash scores."""
    n = len(keys)
    k = n_check_runs(config, n)
    score = np.array([int.from_bytes(_digest(f"check#{config.seed}#{int(rk)}")[:8], "little") for rk in keys], dtype=np.uint64)
    mask = np.zeros(n, dtype=bool)
    mask[np.lexsort((keys, score))[:k]] = True
    return mask


def design(config: StudyConfig) -> xr.Dataset:
    """The run table of a study.

    Parameters
    ----------
    config : StudyConfig

    Returns
    -------
    xarray.Dataset
        Dimension ``run`` (cell by cell in :func:`cells` order, sample fastest).
        Coordinates along ``run``: ``shape``, ``substrate`` (str), ``incline_deg``
        (degree), ``field_mT`` (nominal, mT), ``freq_hz`` (Hz), ``sample`` (int64),
        ``cell_key`` (str, :func:`cell_key`), ``run_key`` (int64, unique,
        :func:`run_key`). Data variables: one float64 per uncertain parameter
        (:func:`sampled_name`; units of the parameter, with ``units`` and ``long_name``
        attrs) and ``check`` (bool: re-simulated at ``dt / dt_factor``). Attributes:
        ``config_json``, ``config_hash``, ``sampling_scheme``, ``uncertain``.
    """
    cl = cells(config)
    n, ncell = config.samples, len(cl)
    total = n * ncell
    values = np.empty((len(config.uncertain), total))
    keys = np.empty(total, dtype=np.int64)
    ckeys = []
    cache: dict[tuple[str, float], ParamDistribution] = {}
    post = config.posterior
    pvals = np.empty((len(post.params) if post else 0, total))
    for c, cell in enumerate(cl):
        sl = slice(c * n, (c + 1) * n)
        u = _cell_uniforms(config, cell)
        for j, unc in enumerate(config.uncertain):
            nom = nominal_value(
                unc.param, cell["substrate"], cell.get("field_mT", config.field_mT[0])
            )  # threshold_axis field_mT: no field_mT uncertainty
            dist = cache.get((unc.param, nom))
            if dist is None:
                dist = cache[(unc.param, nom)] = unc.resolve(nom)
            values[j, sl] = dist.ppf(u[:, j])
        if post is not None:  # one whole draw per run, chosen by the run's own slot
            pvals[:, sl] = post.rows(_mc_uniforms(config.seed, _cell_words(cell), n, [POSTERIOR_SLOT])[:, 0]).T
        canon = _canonical_cell(cell)  # once per cell, not per sample
        keys[sl] = [_run_key(canon, s) for s in range(n)]
        ckeys.append(cell_key(cell))
    if len(np.unique(keys)) != total:  # 2**-63 per pair; checked, not assumed
        raise RuntimeError("run_key collision: change SAMPLING_SCHEME's hashing")

    run = ("run",)
    coords: dict[str, Any] = {"run": np.arange(total)}
    for d in config.cell_dims:  # the critical-incline mode has no incline per run
        col = np.repeat(np.asarray([cell[d] for cell in cl]), n)
        cattrs = dict(COORD_ATTRS[d])
        if d == "field_mT":
            cattrs["long_name"] = "nominal " + cattrs["long_name"]
        coords[d] = (run, col.astype(str if d in ("shape", "substrate") else float), cattrs)
    coords.update(
        {
            "sample": (run, np.tile(np.arange(n, dtype=np.int64), ncell), {"units": "1", "long_name": "sample index within the cell"}),
            "cell_key": (run, np.repeat(np.asarray(ckeys, dtype=str), n), {"long_name": "stable cell id (sha256 of the cell coordinates)"}),
            "run_key": (run, keys, {"units": "1", "long_name": "stable run id (sha256 of the cell and sample)"}),
        }
    )
    data: dict[str, Any] = {}
    for j, unc in enumerate(config.uncertain):
        r = RANGES[unc.param]
        long = f"sampled {r.long_name} ({unc.dist})"
        data[sampled_name(unc.param)] = (run, values[j], {"units": r.units, "long_name": long})
    if post is not None:
        for j, name in enumerate(post.params):
            r = RANGES[name]
            long = f"sampled {r.long_name} (posterior {post.sha256[:12]})"
            data[sampled_name(name)] = (run, pvals[j], {"units": r.units, "long_name": long})
    dts = [row_dt(config, c) for c in cl]
    data["dt"] = (run, np.repeat(np.asarray(dts, dtype=float), n), {"units": "s", "long_name": "time step of the run (its cell's)"})
    data["check_flag"] = (
        run,
        check_mask(config, keys),
        {"long_name": f"re-simulated at dt / {config.check.dt_factor} (numerical-error check)"},
    )
    attrs = {
        "study": config.name,
        "config_json": config_to_json(config),
        "config_hash": config_hash(config),
        "sampling_scheme": SAMPLING_SCHEME,
        "sampler": config.sampler,
        "uncertain": ",".join(config.uncertain_names),
    }
    return xr.Dataset(data, coords=coords, attrs=attrs)


def _scalar(row: Mapping[str, Any] | xr.Dataset, name: str) -> Any:
    v = row[name]
    if isinstance(v, (xr.DataArray, np.ndarray, np.generic)):
        v = np.asarray(v).item()
    return v


def params_for_run(config: StudyConfig, row: Mapping[str, Any] | xr.Dataset) -> dict[str, float]:
    """:class:`~tumblemc.params.Params` overrides of one run (``field_mT`` excluded).

    Parameters
    ----------
    config : StudyConfig
    row : Dataset or mapping
        One run of :func:`design` (``ds.isel(run=i)``) or a mapping with the same names.

    Returns
    -------
    dict
        ``{param: value}`` in the units of :class:`~tumblemc.params.Params`, for
        ``simulate(**overrides)`` or ``PRESETS[substrate].replace(**overrides)``.
    """
    return {p: float(_scalar(row, p)) for p in config.uncertain_names if p != "field_mT" and p not in AXIS_ERRORS}


def batch_row(config: StudyConfig, row: Mapping[str, Any] | xr.Dataset) -> RunRow:
    """The keywords of one run that differ from run to run (a row of :func:`tumblemc.model.rows.simulate_rows`).

    Preset, incline, field (the sampled one if ``field_mT`` is uncertain), frequency and
    :func:`params_for_run`, and the cell's time step (:func:`tumblemc.study.stepcfg.row_dt`).
    """
    field_name = sampled_name("field_mT") if "field_mT" in config.uncertain_names else "field_mT"
    out: dict[str, Any] = {"preset": str(_scalar(row, "substrate"))}
    if "incline_deg" in row:  # a critical-incline run has none: the engine sets it
        out["incline_deg"] = float(_scalar(row, "incline_deg"))
    mT, hz = float(_scalar(row, field_name)), float(_scalar(row, "freq_hz"))
    names = config.uncertain_names
    errs = [float(_scalar(row, e)) if e in names else None for e in AXIS_ERRORS]
    prog = program(config.field, mT, hz, errs[0], errs[1])
    if prog is None:  # the paper's field: the shorthand (records as before programs)
        out["field_mT"], out["freq_hz"] = mT, hz
    else:
        out["field"] = prog
    out["dt"] = row_dt(config, row)
    return cast(RunRow, {**out, **params_for_run(config, row)})


def design_values(config: StudyConfig, des: xr.Dataset, idx: Any, **fixed: float) -> list[dict[str, Any]]:
    """The run-table values :func:`batch_row` reads, for runs ``idx`` (columns read once, not per run).

    ``fixed``: values set in every row (a threshold study's axis value, which its run table
    does not hold).
    """
    names = ["shape", "substrate", "incline_deg", "field_mT", "freq_hz", *(sampled_name(k) for k in config.uncertain_names)]
    cols = {k: des[k].values for k in names if k in des.variables}
    return [{**{k: v[i] for k, v in cols.items()}, **fixed} for i in idx]


def run_kwargs(config: StudyConfig, row: Mapping[str, Any] | xr.Dataset) -> dict[str, Any]:
    """Every keyword of ``tumblemc.simulate`` for one run.

    :func:`batch_row` (with the cell's dt) plus the shape and the time grid (duration in
    field periods, torque, rotation): the duration in seconds is computed once, by
    ``run_inputs``.
    """
    b = batch_row(config, row)
    return {
        "shape": str(_scalar(row, "shape")),
        **b,
        "periods": config.periods,
        "torque": config.torque,
        "rotation": config.rotation,
    }


def grid_of(cfg: StudyConfig, fine: bool = False) -> TimeGrid:
    """The study's time grid of every run (``fine``: at ``dt / [check].dt_factor``, for the numerical check).

    Each run's step is its cell's (:func:`batch_row` puts it in the row); the fine grid
    divides it by ``dt_factor``.

    A run stops at its first failed step (``max_failed_steps=1``), and once its verdict
    can only be failure when ``cfg.early_decision`` (grid and threshold modes, where the
    check runs audit the bound; not at the finer dt).
    """
    # a run with a failed step is invalid in a study (status failed_steps): stop it there
    # instead of finishing it at the smallest sub-step
    return TimeGrid(
        periods=cfg.periods,
        transient_periods=cfg.transient_periods,
        refine=cfg.check.dt_factor if fine else 1,
        torque=cfg.torque,
        rotation=cfg.rotation,
        success_ratio=cfg.success_ratio,
        max_failed_steps=1,
        early_decision=cfg.early_decision and cfg.mode in ("grid", "threshold") and not fine,
    )


def check_inclines(cfg: StudyConfig) -> tuple[float, ...]:
    """Grid inclines of a critical-incline study's monotonicity check, sorted.

    Those of ``incline_deg`` inside ``incline_range``.
    """
    lo, hi = cfg.incline_range
    return tuple(sorted(t for t in cfg.incline_deg if lo <= t <= hi))


def check_subset(des: xr.Dataset) -> np.ndarray:
    """Run indices re-simulated at the finer dt.

    The design's ``check`` flag: a fraction of the runs, at least ``[check].min_runs``,
    chosen by a seeded hash of each run's key.
    """
    return np.flatnonzero(des["check_flag"].values).astype(np.int64)
