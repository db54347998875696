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
mode                 ``"grid"`` (default: every run is one incline of the grid) or
                     ``"critical_incline"`` (every run is one parameter sample; the
                     engine bisects on the incline for the steepest one it climbs)
incline_range        critical_incline only: ``{min, max}`` degrees (default 0, 60)
incline_tol          critical_incline only: bisection tolerance, degrees (default 0.5)
shapes*              list of shape names (:data:`tumblemc.shapes.SHAPES`)
presets*             list of substrate presets (:data:`tumblemc.params.PRESETS`); the
                     run-table coordinate is ``substrate``
incline_deg*         list of numbers, or ``{start, stop, step}`` (stop inclusive);
                     each in [-89, 89] degrees
field_mT*            number or list, mT, in (0, 10000]
freq_hz*             number or list, Hz, in (0, 10000]
periods              simulated field periods, >= 2 (default 2)
transient_periods    periods discarded before measuring (default 1); at least one period
                     must remain (``transient_periods <= periods - 1``)
dt                   time step, s (default: the simulator's ``DEFAULT_DT``)
torque               ``"start"`` (default) or ``"end"``
success_ratio        progress ratio at or above which a run "climbed" (default 0.5)
samples*             runs per cell, integer >= 1
sampler              ``"mc"`` (default), ``"sobol"`` or ``"lhs"`` (see Notes)
seed*                root seed, integer >= 0
ci                   ``"wilson"`` (default) or ``"clopper-pearson"``
ci_level             confidence level of the intervals (default 0.95)
[check]              numerical-error subset re-simulated at ``dt / dt_factor``:
                     ``fraction`` (0.02), ``min_runs`` (20), ``dt_factor`` (4)
[execution]          how to run, not what: ``batch_size`` (8), ``max_in_flight``,
                     ``workers``; excluded from :func:`config_hash`
[uncertain.<param>]  one table per uncertain parameter (below)
===================  ===================================================================

``<param>`` is any numeric field of :class:`~tumblemc.params.Params` (``mass``,
``F_elect``, ``mu``, ``offset_deg``, ``V_m``, ``magnetization``, ``adhesion_C``,
``line_contact_fraction``, ``e_t``, ``e_o``, ``e_r``, ``g``) or ``field_mT``. Values are
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

    [uncertain.adhesion_C]
    dist = "lognormal"
    cv = 0.3

Every problem is one :class:`ConfigError` naming the key path (``uncertain.mu.rel_sd``),
the value and what is allowed; unknown keys are errors with a did-you-mean.

Notes
-----
*Physical bounds.* Each parameter has a physical range (``mu >= 0``, ``mass > 0``,
``0 <= line_contact_fraction <= 1``, ``|offset_deg| <= 180``, ...; :data:`PHYSICAL_RANGE`,
the same as :class:`~tumblemc.params.Params` enforces). Samples never leave it and are
never clipped onto it (no probability atom at a bound): ``normal`` and ``lognormal`` are
accepted only if they put at most :data:`NEGLIGIBLE_MASS` (1e-6) of probability outside
the range for every preset (and field) of the study, and are then sampled truncated to
the range, which changes them by less than that; wider ones are a ConfigError that
suggests ``truncnormal``. ``truncnormal`` cuts at ``lower``/``upper`` (inside the range)
and must keep at least :data:`MIN_KEPT_MASS` of the normal. ``uniform`` and
``triangular`` must lie inside the range.

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

import dataclasses
import difflib
import hashlib
import json
import math
import re
import tomllib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from scipy import stats
from scipy.stats import qmc

from . import shapes as _shapes
from .analysis import CI_METHODS, COORD_ATTRS
from .params import PRESETS
from .simulate import TORQUE_OPTIONS

#: version of the seed derivation and sampler mapping; part of every config hash
SAMPLING_SCHEME = 1
MODES = ("grid", "critical_incline")
SAMPLERS = ("mc", "sobol", "lhs")
TORQUES = TORQUE_OPTIONS  # the simulator's torque options
DISTS = ("normal", "truncnormal", "lognormal", "uniform", "triangular")
#: most probability a ``normal``/``lognormal`` may put outside the physical range
NEGLIGIBLE_MASS = 1e-6
#: least probability a ``truncnormal`` must keep between its bounds
MIN_KEPT_MASS = 0.01
MAX_SAMPLES = 1_000_000
MAX_GRID_VALUES = 10_001
_U_EPS = 2.0**-53  # uniforms are kept in [eps, 1 - eps] so every ppf is finite


class ConfigError(ValueError):
    """One problem in a study config; ``key`` is its dotted path (``uncertain.mu.rel_sd``)."""

    def __init__(self, key: str, message: str) -> None:
        super().__init__(message)
        self.key = key


@dataclass(frozen=True)
class PhysicalRange:
    """Allowed values of an uncertain parameter (``lo_open``: ``lo`` itself excluded)."""

    lo: float
    hi: float
    lo_open: bool
    hi_open: bool
    units: str
    long_name: str

    def describe(self) -> str:
        return _interval(self.lo, self.hi, self.lo_open, self.hi_open)

    def contains(self, x: float) -> bool:
        above = x > self.lo if self.lo_open else x >= self.lo
        below = x < self.hi if self.hi_open else x <= self.hi
        return above and below


_INF = math.inf
#: physical range, units and description of each parameter that may be uncertain; the
#: order is part of the ``mc`` sampler's scheme (append only)
PHYSICAL_RANGE: dict[str, PhysicalRange] = {
    "mass": PhysicalRange(0.0, _INF, True, True, "kg", "robot mass"),
    "F_elect": PhysicalRange(0.0, _INF, False, True, "N", "electrostatic force"),
    "mu": PhysicalRange(0.0, _INF, False, True, "1", "friction coefficient"),
    "offset_deg": PhysicalRange(-180.0, 180.0, False, False, "degree", "magnetisation offset angle"),
    "V_m": PhysicalRange(0.0, _INF, False, True, "m^3", "magnetic volume"),
    "magnetization": PhysicalRange(0.0, _INF, False, True, "A/m", "magnetisation"),
    "adhesion_C": PhysicalRange(0.0, _INF, False, True, "N/m^2", "adhesion per contact area"),
    "line_contact_fraction": PhysicalRange(0.0, 1.0, False, False, "1", "adhering fraction in point/line contact"),
    "e_t": PhysicalRange(0.0, _INF, True, True, "1", "friction ellipsoid e_t"),
    "e_o": PhysicalRange(0.0, _INF, True, True, "1", "friction ellipsoid e_o"),
    "e_r": PhysicalRange(0.0, _INF, True, True, "m", "friction ellipsoid e_r"),
    "g": PhysicalRange(0.0, _INF, True, True, "m/s^2", "gravity"),
    "field_mT": PhysicalRange(0.0, 10_000.0, True, False, "mT", "rotating field magnitude"),
}
UNCERTAIN_PARAMS: tuple[str, ...] = tuple(PHYSICAL_RANGE)

#: the uncertainty assumed when a config has no ``[uncertain]`` table
DEFAULT_UNCERTAIN: dict[str, dict[str, Any]] = {
    "mu": {"dist": "truncnormal", "rel_sd": 0.15},
    "adhesion_C": {"dist": "lognormal", "cv": 0.3},
    "offset_deg": {"dist": "normal", "sd": 5.0},
    "magnetization": {"dist": "normal", "rel_sd": 0.1},
}

# dist -> alternative parameter sets: (required keys, optional keys); one set must match
_DIST_FORMS: dict[str, tuple[tuple[tuple[str, ...], tuple[str, ...]], ...]] = {
    "normal": ((("sd",), ("mean",)), (("rel_sd",), ("mean",))),
    "truncnormal": ((("sd",), ("mean", "lower", "upper")), (("rel_sd",), ("mean", "lower", "upper"))),
    "lognormal": ((("sd",), ("mean",)), (("cv",), ("mean",))),
    "uniform": ((("low", "high"), ()), (("rel_low", "rel_high"), ())),
    "triangular": ((("low", "high"), ("mode",)), (("rel_low", "rel_high"), ("rel_mode",))),
}


# --------------------------------------------------------------------------- config types


@dataclass(frozen=True)
class Uncertain:
    """One uncertain parameter: its distribution and parameters as written (floats).

    ``args`` is a sorted tuple of ``(name, value)`` pairs, e.g.
    ``(("rel_sd", 0.15),)``; :meth:`resolve` turns it into a distribution for a nominal.
    """

    param: str
    dist: str
    args: tuple[tuple[str, float], ...]

    def to_dict(self) -> dict[str, Any]:
        return {"dist": self.dist, **dict(self.args)}

    def resolve(self, nominal: float, where: str = "") -> ParamDistribution:
        """The distribution of this parameter around ``nominal`` (units of the parameter).

        Raises
        ------
        ConfigError
            If the spec is not usable with this nominal value (zero scale, support
            outside the physical range, ...); ``where`` names the preset or field in
            the message.
        """
        return _resolve(self, float(nominal), where)


@dataclass(frozen=True)
class ParamDistribution:
    """A distribution resolved for one nominal value, restricted to the physical range.

    ``ppf(u)`` maps uniforms to values by ``dist.ppf(c_lo + u (c_hi - c_lo))``: the
    quantile function of ``dist`` restricted to its cdf range ``[c_lo, c_hi]``.
    """

    param: str
    dist: Any  # a frozen scipy.stats distribution
    c_lo: float
    c_hi: float

    def ppf(self, u: np.ndarray) -> np.ndarray:
        """Values (units of the parameter) for uniforms ``u`` in (0, 1), any shape."""
        u = np.clip(np.asarray(u, dtype=float), _U_EPS, 1.0 - _U_EPS)
        x = np.asarray(self.dist.ppf(self.c_lo + u * (self.c_hi - self.c_lo)), dtype=float)
        # rounding guard only: the restricted distribution lies inside the range
        r = PHYSICAL_RANGE[self.param]
        x = np.clip(x, r.lo, r.hi)
        if r.lo_open:
            x = np.where(x <= r.lo, np.nextafter(r.lo, _INF), x)
        if r.hi_open and math.isfinite(r.hi):
            x = np.where(x >= r.hi, np.nextafter(r.hi, -_INF), x)
        return x

    def mean(self) -> float:
        """Mean of ``dist`` (restrictions of normal/lognormal are below NEGLIGIBLE_MASS)."""
        return float(self.dist.mean())

    def std(self) -> float:
        """Standard deviation of ``dist`` (same caveat as :meth:`mean`)."""
        return float(self.dist.std())


@dataclass(frozen=True)
class CheckConfig:
    """Numerical-error check: ``max(min_runs, ceil(fraction * runs))`` runs (at most all)
    are re-simulated at ``dt / dt_factor``."""

    fraction: float = 0.02
    min_runs: int = 20
    dt_factor: int = 4


@dataclass(frozen=True)
class ExecutionConfig:
    """How a study is run (not part of its identity): runs per dask task, tasks in
    flight and workers (``None``: the engine decides)."""

    batch_size: int = 8
    max_in_flight: int | None = None
    workers: int | None = None


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
    description: str = ""
    incline_range: tuple[float, float] = (0.0, 60.0)
    incline_tol: float = 0.5
    mode: str = "grid"
    periods: float = 2.0
    transient_periods: float = 1.0
    dt: float | None = None
    torque: str = "start"
    success_ratio: float = 0.5
    sampler: str = "mc"
    ci: str = "wilson"
    ci_level: float = 0.95
    check: CheckConfig = field(default_factory=CheckConfig)
    execution: ExecutionConfig = field(default_factory=ExecutionConfig)
    uncertain: tuple[Uncertain, ...] = ()

    @property
    def cell_dims(self) -> tuple[str, ...]:
        """Names of the coordinates that identify a cell in this mode."""
        return _MODES[self.mode].dims

    @property
    def uncertain_names(self) -> tuple[str, ...]:
        return tuple(u.param for u in self.uncertain)

    @property
    def n_runs(self) -> int:
        return len(cells(self)) * self.samples

    def duration_s(self, freq_hz: float) -> float:
        """Simulated time of a run at ``freq_hz``, s."""
        return self.periods / freq_hz


# ------------------------------------------------------------------------ value checkers


def _interval(lo: float, hi: float, lo_open: bool = False, hi_open: bool = False) -> str:
    if math.isinf(lo) and math.isinf(hi):
        return "a finite number"
    if math.isinf(hi):
        return f"a number {'>' if lo_open else '>='} {lo:g}"
    if math.isinf(lo):
        return f"a number {'<' if hi_open else '<='} {hi:g}"
    return f"a number in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"


def _bad(key: str, value: Any, problem: str, allowed: str) -> ConfigError:
    return ConfigError(key, f"{key}={value!r} {problem} (allowed: {allowed})")


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))


def _num(key: str, value: Any, lo: float = -_INF, hi: float = _INF, lo_open: bool = False, hi_open: bool = False) -> float:
    allowed = _interval(lo, hi, lo_open, hi_open)
    if not _is_number(value):
        raise _bad(key, value, "is not a number", allowed)
    x = float(value)
    ok = math.isfinite(x) and (x > lo if lo_open else x >= lo) and (x < hi if hi_open else x <= hi)
    if not ok:
        raise _bad(key, value, "is out of range", allowed)
    return x + 0.0  # -0.0 -> 0.0: one canonical zero for hashes


def _int(key: str, value: Any, lo: int, hi: int) -> int:
    allowed = f"an integer in [{lo}, {hi}]"
    if not isinstance(value, (int, np.integer)) or isinstance(value, (bool, np.bool_)):
        raise _bad(key, value, "is not an integer", allowed)
    if not lo <= int(value) <= hi:
        raise _bad(key, value, "is out of range", allowed)
    return int(value)


def _str(key: str, value: Any, allowed: str = "a string") -> str:
    if not isinstance(value, str):
        raise _bad(key, value, "is not a string", allowed)
    return value


def _choice(key: str, value: Any, choices: Sequence[str]) -> str:
    allowed = "one of " + ", ".join(repr(c) for c in choices)
    if not isinstance(value, str):
        raise _bad(key, value, "is not a string", allowed)
    if value not in choices:
        close = difflib.get_close_matches(value, choices, n=1)
        hint = f" - did you mean {close[0]!r}?" if close else ""
        raise _bad(key, value, f"is not allowed{hint}", allowed)
    return value


def _table(key: str, value: Any) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise _bad(key, value, "is not a table", "a TOML table / mapping")
    for k in value:
        if not isinstance(k, str):
            raise _bad(f"{key}.{k}", k, "is not a string key", "string keys")
    return value


def _join(prefix: str, key: str) -> str:
    return f"{prefix}.{key}" if prefix else key


def _no_unknown(table: Mapping[str, Any], allowed: Sequence[str], prefix: str, what: str = "key") -> None:
    for k in table:
        if k not in allowed:
            close = difflib.get_close_matches(k, allowed, n=1)
            hint = f"did you mean {close[0]!r}? " if close else ""
            key = _join(prefix, k)
            raise ConfigError(key, f"{key} is not a known {what} ({hint}allowed: {', '.join(allowed)})")


def _required(table: Mapping[str, Any], key: str, prefix: str, allowed: str) -> Any:
    if table.get(key) is None:
        path = _join(prefix, key)
        raise ConfigError(path, f"{path} is missing (required: {allowed})")
    return table[key]


def _str_list(key: str, value: Any, choices: Sequence[str], what: str) -> tuple[str, ...]:
    allowed = f"a non-empty list of distinct {what} names ({', '.join(sorted(choices))})"
    if not isinstance(value, (list, tuple)) or not value:
        raise _bad(key, value, "is not a non-empty list", allowed)
    out = tuple(_choice(f"{key}[{i}]", v, sorted(choices)) for i, v in enumerate(value))
    if len(set(out)) != len(out):
        raise _bad(key, value, "has duplicates", allowed)
    return out


def _num_list(key: str, value: Any, lo: float, hi: float, lo_open: bool = False) -> tuple[float, ...]:
    allowed = f"a number or a non-empty list of distinct numbers, each {_interval(lo, hi, lo_open)}"
    if _is_number(value):
        return (_num(key, value, lo, hi, lo_open),)
    if not isinstance(value, (list, tuple)) or not value:
        raise _bad(key, value, "is not a number or a non-empty list", allowed)
    if len(value) > MAX_GRID_VALUES:
        raise _bad(key, f"<{len(value)} values>", "is too long", f"at most {MAX_GRID_VALUES} values")
    out = tuple(_num(f"{key}[{i}]", v, lo, hi, lo_open) for i, v in enumerate(value))
    if len(set(out)) != len(out):
        raise _bad(key, value, "has duplicates", allowed)
    return out


def _range_table(key: str, value: Mapping[str, Any], lo: float, hi: float) -> tuple[float, ...]:
    _no_unknown(value, ("start", "stop", "step"), key)
    start = _num(f"{key}.start", _required(value, "start", key, _interval(lo, hi)), lo, hi)
    stop = _num(f"{key}.stop", _required(value, "stop", key, _interval(lo, hi)), lo, hi)
    step = _num(f"{key}.step", _required(value, "step", key, "a number > 0"), 0.0, _INF, lo_open=True)
    if stop < start:
        raise _bad(f"{key}.stop", value["stop"], "is below start", f"a number >= start = {start:g}")
    n = math.floor((stop - start) / step + 1e-9) + 1
    if n > MAX_GRID_VALUES:
        raise _bad(f"{key}.step", value["step"], f"gives {n} values", f"at most {MAX_GRID_VALUES} values")
    # rounding makes 0.1-steps land on 0.3, not 0.30000000000000004 (cell ids use repr)
    return tuple(round(start + i * step, 10) + 0.0 for i in range(n))


# --------------------------------------------------------------------- uncertain params


def _parse_uncertain(value: Any) -> tuple[Uncertain, ...]:
    table = _table("uncertain", value)
    _no_unknown(table, UNCERTAIN_PARAMS, "uncertain", "uncertain parameter")
    out = []
    for param in sorted(table):
        key = f"uncertain.{param}"
        spec = _table(key, table[param])
        dist = _choice(f"{key}.dist", _required(spec, "dist", key, "one of " + ", ".join(DISTS)), DISTS)
        forms = _DIST_FORMS[dist]
        all_keys = tuple(dict.fromkeys(k for req, opt in forms for k in (*req, *opt)))
        for k in spec:
            owners = [o for o, fs in _DIST_FORMS.items() if any(k in (*req, *opt) for req, opt in fs)]
            if k != "dist" and k not in all_keys and owners:
                raise ConfigError(
                    f"{key}.{k}",
                    f"{key}.{k} is a parameter of dist={' or '.join(map(repr, owners))}, not of dist={dist!r} (allowed: {', '.join(all_keys)})",
                )
        _no_unknown(spec, ("dist", *all_keys), key, f"parameter of dist={dist!r}")
        args = {k: _num(f"{key}.{k}", v) for k, v in spec.items() if k != "dist"}
        form = next((f for f in forms if set(f[0]) <= set(args) and set(args) <= {*f[0], *f[1]}), None)
        if form is None:
            options = " or ".join("{" + ", ".join([*req, *(f"[{o}]" for o in opt)]) + "}" for req, opt in forms)
            shown = ", ".join(sorted(args)) or "none"
            raise ConfigError(
                key, f"{key} (dist={dist!r}) has parameters {{{shown}}} (allowed: {options}; absolute and relative parameters do not mix)"
            )
        _check_args_alone(key, param, dist, args)
        out.append(Uncertain(param, dist, tuple(sorted(args.items()))))
    return tuple(out)


def _check_args_alone(key: str, param: str, dist: str, a: dict[str, float]) -> None:
    """Checks that do not depend on the nominal value."""
    r = PHYSICAL_RANGE[param]
    for k in ("sd", "rel_sd", "cv"):
        if k in a and not a[k] > 0:
            raise _bad(f"{key}.{k}", a[k], "is out of range", "a number > 0")
    if "mean" in a and not r.contains(a["mean"]):
        raise _bad(f"{key}.mean", a["mean"], f"is outside the physical range of {param}", r.describe())
    if dist == "lognormal" and "mean" in a and not a["mean"] > 0:
        raise _bad(f"{key}.mean", a["mean"], "is out of range", "a number > 0 (lognormal)")
    for k in ("lower", "upper", "low", "high", "mode"):
        if k in a and not (r.lo <= a[k] <= r.hi):
            raise _bad(f"{key}.{k}", a[k], f"is outside the physical range of {param}", _interval(r.lo, r.hi))
    lo, hi = a.get("lower", r.lo), a.get("upper", r.hi)
    if ("lower" in a or "upper" in a) and not lo < hi:
        k = "upper" if "upper" in a else "lower"
        raise _bad(f"{key}.{k}", a[k], "leaves an empty interval", f"lower < upper (now {lo:g} and {hi:g})")
    if "low" in a and not a["low"] < a["high"]:
        raise _bad(f"{key}.high", a["high"], "is not above low", f"a number > low = {a['low']:g}")
    if "rel_low" in a and not a["rel_low"] < a["rel_high"]:
        raise _bad(f"{key}.rel_high", a["rel_high"], "is not above rel_low", f"a number > rel_low = {a['rel_low']:g}")


def _resolve(u: Uncertain, nominal: float, where: str) -> ParamDistribution:
    r = PHYSICAL_RANGE[u.param]
    a = dict(u.args)
    key = f"uncertain.{u.param}"
    at = f" for {where}" if where else ""
    if u.dist in ("normal", "truncnormal"):
        mean = a.get("mean", nominal)
        sd = a["sd"] if "sd" in a else a["rel_sd"] * abs(nominal)
        if not sd > 0:
            raise _bad(f"{key}.rel_sd", a["rel_sd"], f"gives sd = 0 around the nominal {nominal:g}{at}", "an absolute 'sd' > 0 instead")
        lo, hi = a.get("lower", r.lo), a.get("upper", r.hi)
        za, zb = (lo - mean) / sd, (hi - mean) / sd
        if u.dist == "normal":
            outside = float(stats.norm.cdf(za) + stats.norm.sf(zb))
            if outside > NEGLIGIBLE_MASS:
                raise ConfigError(
                    f"{key}.dist",
                    f"{key}.dist='normal' (mean {mean:g}, sd {sd:g}){at} puts {outside:.3g} of its probability outside the physical "
                    f"range of {u.param}, {r.describe()} (allowed: at most {NEGLIGIBLE_MASS:g}; use dist='truncnormal', "
                    f"which cuts at lower/upper, by default the physical bounds, or a smaller sd)",
                )
        else:
            kept = float(stats.norm.cdf(zb) - stats.norm.cdf(za))
            if kept < MIN_KEPT_MASS:
                raise ConfigError(
                    key,
                    f"{key}: truncnormal (mean {mean:g}, sd {sd:g}) keeps only {kept:.3g} of its probability in [{lo:g}, {hi:g}]{at} "
                    f"(allowed: at least {MIN_KEPT_MASS:g}; move mean or widen the bounds)",
                )
        return ParamDistribution(u.param, stats.truncnorm(za, zb, loc=mean, scale=sd), 0.0, 1.0)
    if u.dist == "lognormal":
        mean = a.get("mean", nominal)
        if not mean > 0:
            raise ConfigError(
                f"{key}.dist",
                f"{key}.dist='lognormal' needs a mean > 0 but the nominal {u.param} is {nominal:g}{at} (allowed: an absolute 'mean' > 0)",
            )
        cv = a["sd"] / mean if "sd" in a else a["cv"]
        s2 = math.log1p(cv * cv)
        dist = stats.lognorm(math.sqrt(s2), scale=mean / math.sqrt(1.0 + cv * cv))
        c_hi = 1.0
        if math.isfinite(r.hi):
            outside = float(dist.sf(r.hi))
            if outside > NEGLIGIBLE_MASS:
                raise ConfigError(
                    f"{key}.dist",
                    f"{key}.dist='lognormal' (mean {mean:g}, cv {cv:g}){at} puts {outside:.3g} of its probability above the physical "
                    f"bound {r.hi:g} of {u.param} (allowed: at most {NEGLIGIBLE_MASS:g}; use dist='truncnormal' or a smaller spread)",
                )
            c_hi = float(dist.cdf(r.hi))
        return ParamDistribution(u.param, dist, 0.0, c_hi)
    # uniform, triangular
    if "low" in a:
        low, high, mode = a["low"], a["high"], a.get("mode", nominal)
        mode_key = f"{key}.mode"
    else:
        if not nominal > 0:
            raise _bad(
                f"{key}.rel_low",
                a["rel_low"],
                f"is relative to the nominal {nominal:g}{at}",
                "relative bounds need a nominal > 0; use low/high",
            )
        low, high, mode = a["rel_low"] * nominal, a["rel_high"] * nominal, a.get("rel_mode", 1.0) * nominal
        mode_key = f"{key}.rel_mode"
        if low < r.lo:
            raise _bad(f"{key}.rel_low", a["rel_low"], f"gives low = {low:g}{at}, below the physical range", r.describe())
        if high > r.hi:
            raise _bad(f"{key}.rel_high", a["rel_high"], f"gives high = {high:g}{at}, above the physical range", r.describe())
    if u.dist == "uniform":
        return ParamDistribution(u.param, stats.uniform(loc=low, scale=high - low), 0.0, 1.0)
    if not low <= mode <= high:
        allowed = f"a mode in [low, high] = [{low:g}, {high:g}]"
        given = mode_key.rsplit(".", 1)[1]
        if given in a:
            raise _bad(mode_key, a[given], f"gives mode = {mode:g}{at}", allowed)
        raise ConfigError(
            mode_key, f"{mode_key} is not given and its default, the nominal {mode:g}{at}, is outside [low, high] (allowed: {allowed})"
        )
    return ParamDistribution(u.param, stats.triang((mode - low) / (high - low), loc=low, scale=high - low), 0.0, 1.0)


def nominal_value(param: str, substrate: str, field_mT: float) -> float:
    """Nominal value of an uncertain parameter in a cell (the preset's, or the cell field)."""
    if param == "field_mT":
        return float(field_mT)
    return float(getattr(PRESETS[substrate], param))


# ------------------------------------------------------------------------------ modes


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


def _critical_cells(c: StudyConfig) -> list[dict[str, Any]]:
    return [
        {"shape": s, "substrate": p, "field_mT": b, "freq_hz": f}
        for s in c.shapes
        for p in c.presets
        for b in c.field_mT
        for f in c.freq_hz
    ]


_MODES: dict[str, _Mode] = {
    "grid": _Mode(("shape", "substrate", "incline_deg", "field_mT", "freq_hz"), ("incline_deg",), _grid_cells),
    # one run = one parameter sample; the engine bisects on the incline within
    # incline_range to incline_tol; incline_deg is the grid of the monotonicity check
    "critical_incline": _Mode(
        ("shape", "substrate", "field_mT", "freq_hz"), ("incline_deg", "incline_range", "incline_tol"), _critical_cells
    ),
}

_COMMON_KEYS = (
    "name",
    "description",
    "mode",
    "shapes",
    "presets",
    "field_mT",
    "freq_hz",
    "periods",
    "transient_periods",
    "dt",
    "torque",
    "success_ratio",
    "samples",
    "sampler",
    "seed",
    "ci",
    "ci_level",
    "check",
    "execution",
    "uncertain",
)


# ----------------------------------------------------------------------------- loading


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
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as e:
        raise ConfigError("", f"{path}: not valid TOML: {e}") from None
    try:
        return _parse(data)
    except ConfigError as e:
        raise ConfigError(e.key, f"{path}: {e}") from None


def _parse(d: Mapping[str, Any]) -> StudyConfig:
    d = _table("<config>", d)
    mode = _choice("mode", d["mode"], MODES) if d.get("mode") is not None else "grid"
    m = _MODES[mode]
    _no_unknown(d, (*_COMMON_KEYS, *m.keys), "")

    def req(key: str, allowed: str) -> Any:
        return _required(d, key, "", allowed)

    name = _str("name", req("name", "a name of letters, digits, '_' and '-'"))
    if not re.fullmatch(r"[A-Za-z0-9_-]+", name):
        raise _bad("name", name, "is not allowed", "letters, digits, '_' and '-' only")
    description = _str("description", d.get("description") or "")
    shapes = _str_list("shapes", req("shapes", "a list of shape names"), tuple(_shapes.SHAPES), "shape")
    presets = _str_list("presets", req("presets", "a list of preset names"), tuple(PRESETS), "preset")

    inc = req("incline_deg", "a list of numbers or a {start, stop, step} table")
    incline = _range_table("incline_deg", inc, -89.0, 89.0) if isinstance(inc, Mapping) else _num_list("incline_deg", inc, -89.0, 89.0)
    field_mT = _num_list("field_mT", req("field_mT", "a number or list, mT"), 0.0, 10_000.0, lo_open=True)
    freq_hz = _num_list("freq_hz", req("freq_hz", "a number or list, Hz"), 0.0, 10_000.0, lo_open=True)

    rng_t = _table("incline_range", d.get("incline_range", {"min": 0.0, "max": 60.0}))
    _no_unknown(rng_t, ("min", "max"), "incline_range")
    inc_min = _num("incline_range.min", rng_t.get("min", 0.0), -89.0, 89.0)
    inc_max = _num("incline_range.max", rng_t.get("max", 60.0), -89.0, 89.0)
    if not inc_max > inc_min:
        raise _bad("incline_range.max", inc_max, "is not above incline_range.min", f"a number > {inc_min:g}")
    inc_tol = _num("incline_tol", d.get("incline_tol", 0.5), 1e-3, 90.0)
    if mode == "critical_incline":
        inside = [t for t in incline if inc_min <= t <= inc_max]
        if len(inside) < 2:
            raise _bad(
                "incline_deg",
                list(incline),
                f"has {len(inside)} incline(s) inside incline_range [{inc_min:g}, {inc_max:g}]",
                "at least 2 there: they are the grid of the monotonicity check",
            )

    periods = _num("periods", d.get("periods", 2.0), 2.0, 1e6)
    transient = _num("transient_periods", d.get("transient_periods", 1.0), 0.0, 1e6)
    if transient > periods - 1.0:
        raise _bad(
            "transient_periods",
            d.get("transient_periods", 1.0),
            "leaves less than one measured period",
            f"a number in [0, periods - 1 = {periods - 1:g}]",
        )
    dt = None if d.get("dt") is None else _num("dt", d["dt"], 1e-9, 0.1)
    torque = _choice("torque", d.get("torque", "start"), TORQUES)
    success_ratio = _num("success_ratio", d.get("success_ratio", 0.5), 0.0, 1.0, lo_open=True)
    samples = _int("samples", req("samples", f"an integer in [1, {MAX_SAMPLES}]"), 1, MAX_SAMPLES)
    sampler = _choice("sampler", d.get("sampler", "mc"), SAMPLERS)
    seed = _int("seed", req("seed", "an integer >= 0"), 0, 2**63 - 1)
    ci = _choice("ci", d.get("ci", "wilson"), CI_METHODS)
    ci_level = _num("ci_level", d.get("ci_level", 0.95), 0.5, 1.0, hi_open=True)

    ct = _table("check", d.get("check", {}))
    _no_unknown(ct, ("fraction", "min_runs", "dt_factor"), "check")
    check = CheckConfig(
        fraction=_num("check.fraction", ct.get("fraction", 0.02), 0.0, 1.0),
        min_runs=_int("check.min_runs", ct.get("min_runs", 20), 0, 10**9),
        dt_factor=_int("check.dt_factor", ct.get("dt_factor", 4), 2, 64),
    )
    et = _table("execution", d.get("execution", {}))
    _no_unknown(et, ("batch_size", "max_in_flight", "workers"), "execution")
    execution = ExecutionConfig(
        batch_size=_int("execution.batch_size", et.get("batch_size", 8), 1, 10**6),
        max_in_flight=None if et.get("max_in_flight") is None else _int("execution.max_in_flight", et["max_in_flight"], 1, 10**6),
        workers=None if et.get("workers") is None else _int("execution.workers", et["workers"], 1, 10**5),
    )
    uncertain = _parse_uncertain(d.get("uncertain", DEFAULT_UNCERTAIN))

    cfg = StudyConfig(
        name=name,
        shapes=shapes,
        presets=presets,
        incline_deg=incline,
        field_mT=field_mT,
        freq_hz=freq_hz,
        samples=samples,
        seed=seed,
        description=description,
        incline_range=(inc_min, inc_max),
        incline_tol=inc_tol,
        mode=mode,
        periods=periods,
        transient_periods=transient,
        dt=dt,
        torque=torque,
        success_ratio=success_ratio,
        sampler=sampler,
        ci=ci,
        ci_level=ci_level,
        check=check,
        execution=execution,
        uncertain=uncertain,
    )
    for u in uncertain:  # every nominal the study will meet
        for p in presets:
            for b in field_mT if u.param == "field_mT" else field_mT[:1]:
                nom = nominal_value(u.param, p, b)
                where = f"field_mT={b:g}" if u.param == "field_mT" else f"preset {p!r} (nominal {u.param} = {nom:g})"
                u.resolve(nom, where)
    return cfg


# ------------------------------------------------------------------ identity and hashing


def cells(config: StudyConfig) -> list[dict[str, Any]]:
    """Cell coordinates in run-table order (shape outermost, then substrate, incline,
    field, frequency), one dict per cell keyed by ``config.cell_dims``."""
    return _MODES[config.mode].cells(config)


def _canonical_cell(cell: Mapping[str, Any]) -> str:
    canon = {k: (float(v) + 0.0 if _is_number(v) else str(v)) for k, v in cell.items()}  # 30 and 30.0: one cell
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


def config_to_json(config: StudyConfig) -> str:
    """Canonical JSON of a config: sorted keys, defaults filled in, ``incline_deg``
    expanded, ``[execution]`` left out. ``load_config(json.loads(...))`` gives the config
    back (with the default execution table)."""
    d = dataclasses.asdict(config)
    del d["execution"]
    for k in ("shapes", "presets", "incline_deg", "field_mT", "freq_hz"):
        d[k] = list(d[k])
    d["uncertain"] = {u.param: u.to_dict() for u in config.uncertain}
    d["incline_range"] = {"min": config.incline_range[0], "max": config.incline_range[1]}
    if config.mode == "grid":  # keys only the critical-incline mode takes
        del d["incline_range"], d["incline_tol"]
    return json.dumps(d, sort_keys=True, separators=(",", ":"), allow_nan=False)


def config_hash(config: StudyConfig) -> str:
    """sha256 (hex) of the sampling scheme and :func:`config_to_json`: the identity of a
    study's results; insensitive to ``[execution]``."""
    return hashlib.sha256(f"tumblemc-sampling-{SAMPLING_SCHEME}\n{config_to_json(config)}".encode()).hexdigest()


# ---------------------------------------------------------------------------- sampling


def _mc_uniforms(seed: int, words: list[int], n: int, slots: list[int]) -> np.ndarray:
    """(n, len(slots)) uniforms, one SeedSequence per run, one slot per parameter."""
    out = np.empty((n, len(slots)))
    width = len(UNCERTAIN_PARAMS)
    for s in range(n):
        state = np.random.SeedSequence([seed, *words, s]).generate_state(width, np.uint64)
        out[s] = ((state[slots] >> np.uint64(11)).astype(float) + 0.5) * 2.0**-53
    return out


def _cell_uniforms(config: StudyConfig, cell: Mapping[str, Any]) -> np.ndarray:
    """Uniforms in (0, 1) for one cell: shape (samples, n_uncertain), columns in
    ``config.uncertain`` order."""
    n, d = config.samples, len(config.uncertain)
    if d == 0:
        return np.empty((n, 0))
    words = _cell_words(cell)
    if config.sampler == "mc":
        return _mc_uniforms(config.seed, words, n, [UNCERTAIN_PARAMS.index(u.param) for u in config.uncertain])
    rng = np.random.default_rng(np.random.SeedSequence([config.seed, *words]))
    if config.sampler == "sobol":
        u = qmc.Sobol(d, scramble=True, rng=rng).random_base2(max(0, math.ceil(math.log2(n))))[:n]
    else:
        u = qmc.LatinHypercube(d, rng=rng).random(n)
    return np.clip(u, _U_EPS, 1.0 - _U_EPS)


def _check_mask(config: StudyConfig, keys: np.ndarray) -> np.ndarray:
    """The numerical-check subset: the runs with the smallest seeded hash scores."""
    n = len(keys)
    k = min(n, max(config.check.min_runs, math.ceil(config.check.fraction * n)))
    score = np.array([int.from_bytes(_digest(f"check#{config.seed}#{int(rk)}")[:8], "little") for rk in keys], dtype=np.uint64)
    mask = np.zeros(n, dtype=bool)
    mask[np.lexsort((keys, score))[:k]] = True
    return mask


def sampled_name(param: str) -> str:
    """Run-table variable of a sampled parameter (``field_mT`` is a cell coordinate, so
    its sampled value is ``field_mT_sampled``)."""
    return "field_mT_sampled" if param == "field_mT" else param


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
    for c, cell in enumerate(cl):
        sl = slice(c * n, (c + 1) * n)
        u = _cell_uniforms(config, cell)
        for j, unc in enumerate(config.uncertain):
            nom = nominal_value(unc.param, cell["substrate"], cell["field_mT"])
            dist = cache.get((unc.param, nom))
            if dist is None:
                dist = cache[(unc.param, nom)] = unc.resolve(nom)
            values[j, sl] = dist.ppf(u[:, j])
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
        r = PHYSICAL_RANGE[unc.param]
        long = f"sampled {r.long_name} ({unc.dist})"
        data[sampled_name(unc.param)] = (run, values[j], {"units": r.units, "long_name": long})
    data["check_flag"] = (
        run,
        _check_mask(config, keys),
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


# ------------------------------------------------------------------------- run inputs


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
    return {u.param: float(_scalar(row, u.param)) for u in config.uncertain if u.param != "field_mT"}


def batch_row(config: StudyConfig, row: Mapping[str, Any] | xr.Dataset) -> dict[str, Any]:
    """The keywords of one run that differ from run to run (a row of
    :func:`tumblemc.batch.simulate_rows`): preset, incline, field (the sampled one if
    ``field_mT`` is uncertain), frequency and :func:`params_for_run`."""
    field_name = sampled_name("field_mT") if "field_mT" in config.uncertain_names else "field_mT"
    out: dict[str, Any] = {"preset": str(_scalar(row, "substrate"))}
    if "incline_deg" in row:  # a critical-incline run has none: the engine sets it
        out["incline_deg"] = float(_scalar(row, "incline_deg"))
    out["field_mT"] = float(_scalar(row, field_name))
    out["freq_hz"] = float(_scalar(row, "freq_hz"))
    return {**out, **params_for_run(config, row)}


def run_kwargs(config: StudyConfig, row: Mapping[str, Any] | xr.Dataset) -> dict[str, Any]:
    """Every keyword of ``tumblemc.simulate`` for one run: :func:`batch_row` plus the
    shape and the time grid (duration, dt, torque)."""
    b = batch_row(config, row)
    return {
        "shape": str(_scalar(row, "shape")),
        **b,
        "duration_s": config.duration_s(b["freq_hz"]),
        "dt": config.dt,
        "torque": config.torque,
    }


__all__ = [
    "CI_METHODS",
    "DEFAULT_UNCERTAIN",
    "DISTS",
    "MIN_KEPT_MASS",
    "MODES",
    "NEGLIGIBLE_MASS",
    "PHYSICAL_RANGE",
    "SAMPLERS",
    "SAMPLING_SCHEME",
    "UNCERTAIN_PARAMS",
    "CheckConfig",
    "ConfigError",
    "ExecutionConfig",
    "ParamDistribution",
    "PhysicalRange",
    "StudyConfig",
    "Uncertain",
    "batch_row",
    "cell_key",
    "cells",
    "config_hash",
    "config_to_json",
    "design",
    "load_config",
    "nominal_value",
    "params_for_run",
    "run_key",
    "run_kwargs",
    "sampled_name",
]
