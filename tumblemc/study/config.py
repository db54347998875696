"""Study design: configs, input distributions, samplers and seeds keyed by run id.

A *study* is a grid of *cells* (shape x substrate x incline x field x frequency), each
holding ``samples`` runs whose uncertain parameters are drawn from distributions around
the substrate preset's nominal values. This module turns a TOML file (or a dict) into a
validated :class:`StudyConfig` and the config into a run table (:func:`design`); it runs
no simulation.

Randomness is data: a run's identity is ``(shape, substrate, incline_deg, field_mT,
freq_hz, sample)`` and its parameters depend only on the root ``seed`` and that identity,
never on list positions, batch sizes or how many cells the study has.

TOML schema
-----------
Top level (``*`` required):

===================  ===================================================================
key                  meaning
===================  ===================================================================
name*                identifier, ``[A-Za-z0-9_-]+``
description          free text
mode                 ``"grid"`` (default: one run per incline of the grid), ``"threshold"``
                     or ``"critical_incline"`` (one run per sample): study/modes.py
threshold_axis       threshold only: ``"incline_deg"`` (default), ``"field_mT"`` or
                     ``"freq_hz"``: its list is the grid searched (study/threshold.py)
threshold_start      threshold only: ``"pilot"`` (default) or ``"bisect"``
incline_range        critical_incline only: ``{min, max}`` degrees (default 0, 60)
incline_tol          critical_incline only: bisection tolerance, degrees (default 0.5)
shapes*              list of shape names (:data:`tumblemc.shapes.SHAPES`)
presets*             list of substrate presets (:data:`tumblemc.model.params.PRESETS`); the
                     run-table coordinate is ``substrate``
incline_deg*         list of numbers, or ``{start, stop, step}`` (stop inclusive);
                     each in [-89, 89] degrees (negative: downhill)
field_mT*            number or list, mT, in (0, 10000]
freq_hz*             number or list, Hz, in (0, 10000]
periods              simulated field periods, >= 2 (default 2)
transient_periods    periods discarded before measuring (default 1); at least one period
                     must remain (``transient_periods <= periods - 1``)
dt                   time step, s (default: each cell's default step from its nominal field,
                     frequency and preset, model/step_size.py; 5e-5 s at the paper's)
torque               ``"start"`` (default), ``"end"`` or ``"mid"`` (their mean)
rotation             ``"momentum"`` (default), ``"paper"`` or ``"midpoint"`` (docs/guide/runs.md)
success_ratio        progress ratio at or above which a run "climbed" (default 0.5)
early_decision       ``true`` (default): stop a run once an energy bound shows that it can
                     no longer reach ``success_ratio`` (tumblemc.kernels.decide); its
                     ``decided_early`` flag is set and its ratio is censored there. The
                     dt-check runs always run to the end (they audit the bound)
samples*             runs per cell, integer >= 1 (with ``precision``: the most per cell)
precision            adaptive sampling (grid mode, ``mc``): each cell stops at the first
                     run count at which the half-width of its anytime-valid interval
                     (``ci``, a confidence sequence, analysis/confseq.py) is at most
                     this, in (0, 0.5); absent: every cell runs ``samples`` runs
sampler              ``"mc"`` (default), ``"sobol"`` or ``"lhs"`` (see Notes)
seed*                root seed, integer >= 0
ci                   ``"wilson"`` (default), ``"clopper-pearson"``,
                     ``"confidence-sequence"`` (Robbins' uniform prior; the rule of
                     adaptive studies in earlier versions) or ``"confidence-sequence-ends"``
                     (the default with ``precision``: the ``"ends"`` prior,
                     analysis/confseq.py); with ``precision`` only the last two
ci_level             confidence level of the intervals (default 0.95)
[check]              numerical-error subset re-simulated at ``dt / dt_factor``:
                     ``fraction`` (0.02), ``min_runs`` (20), ``dt_factor`` (4); the two
                     progress ratios of a checked run agree when they differ by at most
                     ``ratio_abs_tol + ratio_rel_tol * |fine ratio|`` (0.05, 0.1); a run
                     outside that is simulated twice more with the magnetisation x (1 +-
                     ``twin_rel``) (1e-6; 0: off; study/checkcfg.py, study/twins.py)
[execution]          how to run, not what: ``batch_size`` (8), ``max_in_flight``,
                     ``workers``, and the bounds ``max_runs``, ``max_steps_per_run``,
                     ``max_run_memory_gib`` (study/budget.py); excluded from :func:`config_hash`
[uncertain.<param>]  one table per uncertain parameter (below); ``posterior = "calib.nc"``
                     samples a calibration posterior jointly (study/posterior.py)
[field]              the field program: ``kind = "paper"`` (default) or ``"rotating"``
                     with ``axis``, ``start``, ``cone_deg``, ``bias_mT`` (study/fieldcfg.py);
                     ``axis_yaw_deg``/``axis_pitch_deg`` may be uncertain (pointing error)
===================  ===================================================================

``<param>`` is any numeric field of :class:`~tumblemc.model.params.Params` (``mass``,
``F_elect``, ``mu``, ``offset_deg``, ``V_m``, ``magnetization``, ``adhesion_C``,
``line_contact_width``, ``line_contact_fraction``, ``e_t``, ``e_o``, ``e_r``, ``g``,
``peel_length``) or ``field_mT`` (and, with ``[field]``, ``axis_yaw_deg`` or
``axis_pitch_deg``). Values are
in the units of that field (SI; degrees for ``offset_deg``, mT for ``field_mT``). The
*nominal* value is the preset's value (the cell's ``field_mT`` for ``field_mT``).
``dist`` picks the distribution and its parameters, either absolute or relative to the
nominal value (never both):

=============  ====================================================  ===================
dist           absolute                                              relative
=============  ====================================================  ===================
normal         ``sd`` [, ``mean``]                                    ``rel_sd``
truncnormal    ``sd`` [, ``mean``, ``lower``, ``upper``]              ``rel_sd``
lognormal      ``sd`` [, ``mean``]  (mean and sd of the value)        ``cv`` (sd / mean)
uniform        ``low``, ``high``                                      ``rel_low``,
                                                                      ``rel_high``
triangular     ``low``, ``high`` [, ``mode``]                         ``rel_low``,
                                                                      ``rel_high``
                                                                      [, ``rel_mode``]
=============  ====================================================  ===================

``mean`` (normal, truncnormal, lognormal) defaults to the nominal value, ``mode`` to the
nominal value (``rel_mode`` to 1). ``rel_sd`` and ``cv`` multiply ``|nominal|``;
``rel_low``, ``rel_mode`` and ``rel_high`` multiply a positive nominal
(``rel_low = 0.8, rel_high = 1.2`` is nominal +-20%). ``truncnormal`` is a normal with
location ``mean`` and scale ``sd`` cut to ``[lower, upper]`` (defaults: the physical
bounds), so its mean moves when the cut is near.

Without an ``[uncertain]`` table the defaults (:data:`DEFAULT_UNCERTAIN`) apply: ``mu``
truncnormal with ``rel_sd = 0.15``; ``adhesion_C`` lognormal with ``cv = 0.3``;
``offset_deg`` normal with ``sd = 5`` degrees; ``magnetization`` normal with
``rel_sd = 0.1``. ``uncertain = {}`` means no uncertain parameter.

Example::

    name = "smoke"
    shapes = ["cuboid"]
    presets = ["aluminum"]
    incline_deg = {start = 0, stop = 60, step = 30}
    field_mT = 20
    freq_hz = 1
    samples = 16
    seed = 20190818

    [uncertain.mu]
    dist = "truncnormal"
    rel_sd = 0.15

Every problem is one :class:`ConfigError` naming the key path (``uncertain.mu.rel_sd``),
the value and what is allowed; unknown keys are errors with a did-you-mean.

Notes
-----
*Physical bounds.* Each parameter has a physical range (``mu >= 0``, ``mass > 0``,
``0 <= line_contact_fraction <= 1``, ``|offset_deg| <= 180``, ...; :data:`RANGES`,
the same as :class:`~tumblemc.model.params.Params` enforces). Samples never leave it and are
never clipped onto it (no probability atom at a bound): ``normal`` and ``lognormal`` are
accepted only if they put at most :data:`NEGLIGIBLE_MASS` (1e-6) of probability outside
the range for every preset (and field) of the study, and are then sampled truncated to
the range, which changes them by less than that; wider ones are a ConfigError that
suggests ``truncnormal``. ``truncnormal`` cuts at ``lower``/``upper`` (inside the range)
and must keep at least :data:`MIN_KEPT_MASS` of the normal. ``uniform`` and
``triangular`` must lie inside the range.

*Samplers.* ``mc``, ``sobol`` and ``lhs``: see :mod:`tumblemc.study.design`.
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from dataclasses import field as dc_field
from os import PathLike
from pathlib import Path
from typing import Any

from tumblemc.model.params import PRESETS, RANGES
from tumblemc.model.shapes import SHAPES
from tumblemc.model.solver_options import ROTATION_OPTIONS, TORQUE_OPTIONS
from tumblemc.schema import CI_METHODS
from tumblemc.study.budget import MAX_RUN_MEMORY_GIB, MAX_RUNS, MAX_STEPS_PER_RUN, check_budget, count_cells
from tumblemc.study.checkcfg import CheckConfig, parse_check
from tumblemc.study.checks import (
    ConfigError,
    check_adaptive,
    check_choice,
    check_int,
    check_no_unknown,
    check_num,
    check_num_list,
    check_range_table,
    check_required,
    check_str,
    check_str_list,
    check_table,
    config_error,
    read_config_text,
)
from tumblemc.study.distributions import DEFAULT_UNCERTAIN, Uncertain, nominal_value, parse_uncertain
from tumblemc.study.fieldcfg import FieldConfig, parse_field
from tumblemc.study.modes import (  # noqa: F401  (THRESHOLD_AXES, THRESHOLD_STARTS re-exported)
    GRID_DIMS,
    MODES,
    THRESHOLD_AXES,
    THRESHOLD_STARTS,
    check_threshold_uncertain,
    parse_threshold,
)
from tumblemc.study.posterior import Posterior, split_posterior

#: version of the seed derivation and sampler mapping; part of every config hash
SAMPLING_SCHEME = 1


SAMPLERS = ("mc", "sobol", "lhs")
TORQUES = TORQUE_OPTIONS  # the simulator's torque options
ROTATIONS = ROTATION_OPTIONS  # and rotation rows
MAX_SAMPLES = 1_000_000


@dataclass(frozen=True)
class ExecutionConfig:
    """How a study is run (not part of its identity): runs per dask task, tasks in flight and workers (``None``: the engine decides)."""

    batch_size: int = 8
    max_in_flight: int | None = None
    workers: int | None = None
    max_runs: int = MAX_RUNS  # bounds of what a study may cost (study/budget.py)
    max_steps_per_run: int = MAX_STEPS_PER_RUN
    max_run_memory_gib: float = MAX_RUN_MEMORY_GIB


@dataclass(frozen=True)
class StudyConfig:
    """A validated study (see the module docstring for the meaning of each field).

    Lists are tuples; ``incline_deg`` is expanded from a ``{start, stop, step}`` table;
    ``uncertain`` is sorted by parameter name.
    """

    name: str
    shapes: tuple[str, ...]
    presets: tuple[str, ...]
    incline_deg: tuple[float, ...]
    field_mT: tuple[float, ...]
    freq_hz: tuple[float, ...]
    samples: int
    seed: int
    precision: float | None = None  # adaptive sampling: target half-width (study/adaptive.py)
    description: str = ""
    incline_range: tuple[float, float] = (0.0, 60.0)
    incline_tol: float = 0.5
    mode: str = "grid"
    threshold_axis: str = "incline_deg"  # threshold mode: the axis searched (THRESHOLD_AXES)
    threshold_start: str = "pilot"  # threshold mode: THRESHOLD_STARTS
    periods: float = 2.0
    transient_periods: float = 1.0
    dt: float | None = None
    torque: str = "start"
    rotation: str = "momentum"
    success_ratio: float = 0.5
    early_decision: bool = True
    sampler: str = "mc"
    ci: str = "wilson"
    ci_level: float = 0.95
    check: CheckConfig = dc_field(default_factory=CheckConfig)
    execution: ExecutionConfig = dc_field(default_factory=ExecutionConfig)
    uncertain: tuple[Uncertain, ...] = ()
    posterior: Posterior | None = None  # [uncertain] posterior = "calib.nc" (study/posterior.py)
    field: FieldConfig = dc_field(default_factory=FieldConfig)  # [field] (study/fieldcfg.py)

    @property
    def cell_dims(self) -> tuple[str, ...]:
        """Names of the coordinates that identify a cell in this mode."""
        if self.mode == "threshold":
            return tuple(d for d in GRID_DIMS if d != self.threshold_axis)
        return _MODES[self.mode].dims

    @property
    def axis_values(self) -> tuple[float, ...]:
        """Threshold mode: the grid of the searched axis, ascending."""
        return tuple(getattr(self, self.threshold_axis))

    @property
    def uncertain_names(self) -> tuple[str, ...]:
        """Names of the uncertain parameters (with those of the posterior), sorted."""
        return tuple(sorted({u.param for u in self.uncertain} | set(self.posterior.params if self.posterior else ())))

    @property
    def n_runs(self) -> int:
        """Number of runs: cells x samples."""
        return count_cells(self) * self.samples


@dataclass(frozen=True)
class _Mode:
    dims: tuple[str, ...]  # cell coordinates, in run-table order (outermost first)
    keys: tuple[str, ...]  # top-level keys only this mode takes
    cells: Callable[[StudyConfig], list[dict[str, Any]]]


def _grid_cells(c: StudyConfig) -> list[dict[str, Any]]:
    return [
        {"shape": s, "substrate": p, "incline_deg": i, "field_mT": b, "freq_hz": f}
        for s in c.shapes
        for p in c.presets
        for i in c.incline_deg
        for b in c.field_mT
        for f in c.freq_hz
    ]


def _cells_without(c: StudyConfig, axis: str) -> list[dict[str, Any]]:
    one: dict[str, Any] = {axis: (0.0,)}
    return [{d: v for d, v in cell.items() if d != axis} for cell in _grid_cells(replace(c, **one))]


def _critical_cells(c: StudyConfig) -> list[dict[str, Any]]:
    return _cells_without(c, "incline_deg")


def _threshold_cells(c: StudyConfig) -> list[dict[str, Any]]:
    return _cells_without(c, c.threshold_axis)


_MODES: dict[str, _Mode] = {
    "grid": _Mode(GRID_DIMS, ("incline_deg",), _grid_cells),
    # one run = one parameter sample; the engine searches the grid of threshold_axis for
    # the sample's threshold (study/threshold.py); cell_dims are the other axes
    "threshold": _Mode(GRID_DIMS, ("incline_deg", "threshold_axis", "threshold_start"), _threshold_cells),
    # one run = one parameter sample; the engine bisects on the incline within
    # incline_range to incline_tol; incline_deg is the grid of the monotonicity check
    "critical_incline": _Mode(
        ("shape", "substrate", "field_mT", "freq_hz"), ("incline_deg", "incline_range", "incline_tol"), _critical_cells
    ),
}


_COMMON_KEYS = (
    *("name", "description", "mode", "shapes", "presets", "field_mT", "freq_hz", "periods", "transient_periods", "dt"),
    *("torque", "rotation", "success_ratio", "early_decision", "samples", "precision", "sampler", "seed", "ci", "ci_level"),
    *("check", "execution", "uncertain", "field"),
)


def load_config(source: str | PathLike[str] | Mapping[str, Any] | StudyConfig) -> StudyConfig:
    """Read and validate a study config.

    Parameters
    ----------
    source : path, mapping or StudyConfig
        A TOML file (``str`` or path-like), the mapping ``tomllib`` would give, or an
        already validated config (returned unchanged).

    Returns
    -------
    StudyConfig

    Raises
    ------
    ConfigError
        For the first problem found, naming the key path, the value and what is allowed
        (for a file, prefixed with its path).
    """
    if isinstance(source, StudyConfig):
        return source
    if isinstance(source, Mapping):
        return _parse(source)
    path = Path(source)
    try:
        data = tomllib.loads(read_config_text(path))
    except tomllib.TOMLDecodeError as e:
        raise ConfigError("", f"{path}: not valid TOML: {e}") from None
    try:
        return _parse(data, path.parent)
    except ConfigError as e:
        raise ConfigError(e.key, f"{path}: {e}") from None


#: incline bounds, degrees (the one range table); a study narrows field and frequency to > 0
_INCLINE = (RANGES["incline_deg"].lo, RANGES["incline_deg"].hi)


def _parse(d: Mapping[str, Any], base: Path | None = None) -> StudyConfig:
    d = check_table("<config>", d)
    mode = check_choice("mode", d["mode"], MODES) if d.get("mode") is not None else "grid"
    m = _MODES[mode]
    check_no_unknown(d, (*_COMMON_KEYS, *m.keys), "")

    def req(key: str, allowed: str) -> Any:
        return check_required(d, key, "", allowed)

    name = check_str("name", req("name", "a name of letters, digits, '_' and '-'"))
    if not re.fullmatch(r"[A-Za-z0-9_-]+", name):
        raise config_error("name", name, "is not allowed", "letters, digits, '_' and '-' only")
    description = check_str("description", d.get("description") or "")
    shapes = check_str_list("shapes", req("shapes", "a list of shape names"), tuple(SHAPES), "shape")
    presets = check_str_list("presets", req("presets", "a list of preset names"), tuple(PRESETS), "preset")

    inc = req("incline_deg", "a list of numbers or a {start, stop, step} table")
    incline = (
        check_range_table("incline_deg", inc, *_INCLINE) if isinstance(inc, Mapping) else check_num_list("incline_deg", inc, *_INCLINE)
    )
    field_mT = check_num_list("field_mT", req("field_mT", "a number or list, mT"), 0.0, RANGES["field_mT"].plausible_hi, lo_open=True)
    freq_hz = check_num_list("freq_hz", req("freq_hz", "a number or list, Hz"), 0.0, RANGES["freq_hz"].hi, lo_open=True)

    rng_t = check_table("incline_range", d.get("incline_range", {"min": 0.0, "max": 60.0}))
    check_no_unknown(rng_t, ("min", "max"), "incline_range")
    inc_min = check_num("incline_range.min", rng_t.get("min", 0.0), *_INCLINE)
    inc_max = check_num("incline_range.max", rng_t.get("max", 60.0), *_INCLINE)
    if not inc_max > inc_min:
        raise config_error("incline_range.max", inc_max, "is not above incline_range.min", f"a number > {inc_min:g}")
    inc_tol = check_num("incline_tol", d.get("incline_tol", 0.5), 1e-3, 90.0)
    if mode == "critical_incline":
        inside = [t for t in incline if inc_min <= t <= inc_max]
        if len(inside) < 2:
            raise config_error(
                "incline_deg",
                list(incline),
                f"has {len(inside)} incline(s) inside incline_range [{inc_min:g}, {inc_max:g}]",
                "at least 2 there: they are the grid of the monotonicity check",
            )

    axis, start, (incline, field_mT, freq_hz) = parse_threshold(d, mode, (incline, field_mT, freq_hz))

    periods = check_num("periods", d.get("periods", 2.0), 2.0, RANGES["periods"].hi)
    transient = check_num("transient_periods", d.get("transient_periods", 1.0), 0.0, 1e6)
    if transient > periods - 1.0:
        raise config_error(
            "transient_periods",
            d.get("transient_periods", 1.0),
            "leaves less than one measured period",
            f"a number in [0, periods - 1 = {periods - 1:g}]",
        )
    dt = None if d.get("dt") is None else check_num("dt", d["dt"], RANGES["dt"].lo, RANGES["dt"].hi)
    torque = check_choice("torque", d.get("torque", "start"), TORQUES)
    rotation = check_choice("rotation", d.get("rotation", "momentum"), ROTATIONS)
    success_ratio = check_num("success_ratio", d.get("success_ratio", 0.5), 0.0, 1.0, lo_open=True)
    early_decision = d.get("early_decision", True)
    if not isinstance(early_decision, bool):
        raise config_error("early_decision", early_decision, "is not a boolean", "true or false")
    samples = check_int("samples", req("samples", f"an integer in [1, {MAX_SAMPLES}]"), 1, MAX_SAMPLES)
    sampler = check_choice("sampler", d.get("sampler", "mc"), SAMPLERS)
    seed = check_int("seed", req("seed", "an integer >= 0"), 0, 2**63 - 1)
    precision = None if d.get("precision") is None else check_num("precision", d["precision"], 0.0, 0.5, lo_open=True, hi_open=True)
    ci = check_choice("ci", d.get("ci", "wilson" if precision is None else "confidence-sequence-ends"), CI_METHODS)
    ci_level = check_num("ci_level", d.get("ci_level", 0.95), 0.5, 1.0, hi_open=True)
    if precision is not None:
        check_adaptive(mode, sampler, ci, precision, samples, ci_level)

    check = parse_check(d.get("check", {}))
    et = check_table("execution", d.get("execution", {}))
    check_no_unknown(et, ("batch_size", "max_in_flight", "workers", "max_runs", "max_steps_per_run", "max_run_memory_gib"), "execution")
    execution = ExecutionConfig(
        batch_size=check_int("execution.batch_size", et.get("batch_size", 8), 1, 10**6),
        max_in_flight=None if et.get("max_in_flight") is None else check_int("execution.max_in_flight", et["max_in_flight"], 1, 10**6),
        workers=None if et.get("workers") is None else check_int("execution.workers", et["workers"], 1, 10**5),
        max_runs=check_int("execution.max_runs", et.get("max_runs", MAX_RUNS), 1, 10**12),
        max_steps_per_run=check_int("execution.max_steps_per_run", et.get("max_steps_per_run", MAX_STEPS_PER_RUN), 1, 10**15),
        max_run_memory_gib=check_num(
            "execution.max_run_memory_gib", et.get("max_run_memory_gib", MAX_RUN_MEMORY_GIB), 0.0, 1e6, lo_open=True
        ),
    )
    field_cfg = parse_field(d.get("field", {}))
    unc_table, posterior = split_posterior(d.get("uncertain", DEFAULT_UNCERTAIN), base)
    uncertain = parse_uncertain(unc_table)
    if posterior is not None:
        posterior.check_matches(shapes, presets)
    if posterior is not None and sampler != "mc":
        raise ConfigError("sampler", f"sampler={sampler!r} does not sample a posterior (allowed: mc with uncertain.posterior)")

    check_threshold_uncertain(mode, axis, uncertain)
    cfg = StudyConfig(
        name=name,
        shapes=shapes,
        presets=presets,
        incline_deg=incline,
        field_mT=field_mT,
        freq_hz=freq_hz,
        samples=samples,
        seed=seed,
        precision=precision,
        description=description,
        incline_range=(inc_min, inc_max),
        incline_tol=inc_tol,
        mode=mode,
        threshold_axis=axis,
        threshold_start=start,
        periods=periods,
        transient_periods=transient,
        dt=dt,
        torque=torque,
        rotation=rotation,
        success_ratio=success_ratio,
        early_decision=bool(early_decision),
        sampler=sampler,
        ci=ci,
        ci_level=ci_level,
        check=check,
        execution=execution,
        uncertain=uncertain,
        posterior=posterior,
        field=field_cfg,
    )
    for u in uncertain:  # every nominal the study will meet
        for p in presets:
            for b in field_mT if u.param == "field_mT" else field_mT[:1]:
                nom = nominal_value(u.param, p, b)
                where = f"field_mT={b:g}" if u.param == "field_mT" else f"preset {p!r} (nominal {u.param} = {nom:g})"
                u.resolve(nom, where)
    check_budget(cfg)
    return cfg


def cells(config: StudyConfig) -> list[dict[str, Any]]:
    """Cell coordinates in run-table order (shape outermost, then substrate, incline, field, frequency).

    One dict per cell, keyed by ``config.cell_dims``.
    """
    return _MODES[config.mode].cells(config)
