"""Uncertain parameters of a study.

The ``[uncertain.<param>]`` tables parsed into :class:`Uncertain`, resolved around a
preset's nominal value into a :class:`ParamDistribution` restricted to the parameter's
physical range (:data:`tumblemc.model.params.RANGES`). The TOML forms are documented in
:mod:`tumblemc.study.config`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import stats

from tumblemc.model.params import NUMERIC_FIELDS, PRESETS, RANGES, describe_interval
from tumblemc.study.checks import ConfigError, check_choice, check_no_unknown, check_num, check_required, check_table, config_error

_INF = math.inf

DISTS = ("normal", "truncnormal", "lognormal", "uniform", "triangular")


#: most probability a ``normal``/``lognormal`` may put outside the physical range
NEGLIGIBLE_MASS = 1e-6


#: least probability a ``truncnormal`` must keep between its bounds
MIN_KEPT_MASS = 0.01


U_EPS = 2.0**-53  # uniforms are kept in [eps, 1 - eps] so every ppf is finite


#: the parameters that may be uncertain (each has a row in RANGES), in the order of the
#: ``mc`` sampler's slots: part of the sampling scheme, append only (the Params fields
#: added after field_mT go after it, so that every earlier parameter keeps its slot)
_ADDED_AFTER_FIELD = ("line_contact_width", "peel_length")
#: the mc stream's slot of a calibration posterior's row (study/posterior.py), taken when
#: UNCERTAIN_PARAMS had this many entries; parameters added since sit after it
POSTERIOR_SLOT = 15
UNCERTAIN_PARAMS: tuple[str, ...] = (
    *(f for f in NUMERIC_FIELDS if f not in _ADDED_AFTER_FIELD),
    "field_mT",
    *_ADDED_AFTER_FIELD,
    "axis_yaw_deg",  # the field axis's pointing error (study/fieldcfg.py), slots after the posterior's
    "axis_pitch_deg",
)


def mc_slot(param: str) -> int:
    """The ``mc`` stream slot of an uncertain parameter (its index, skipping the posterior's slot)."""
    i = UNCERTAIN_PARAMS.index(param)
    return i if i < POSTERIOR_SLOT else i + 1


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
        """The TOML table of this parameter: ``{"dist": ..., <args>}``."""
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
        u = np.clip(np.asarray(u, dtype=float), U_EPS, 1.0 - U_EPS)
        x = np.asarray(self.dist.ppf(self.c_lo + u * (self.c_hi - self.c_lo)), dtype=float)
        # rounding guard only: the restricted distribution lies inside the range
        r = RANGES[self.param]
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


def parse_uncertain(value: Any) -> tuple[Uncertain, ...]:
    """Parse the ``[uncertain]`` table into :class:`Uncertain` entries, sorted by parameter name.

    Raises
    ------
    ConfigError
        For an unknown parameter or distribution, or a parameter set that matches none of
        the distribution's forms.
    """
    table = check_table("uncertain", value)
    check_no_unknown(table, UNCERTAIN_PARAMS, "uncertain", "uncertain parameter")
    out = []
    for param in sorted(table):
        key = f"uncertain.{param}"
        spec = check_table(key, table[param])
        dist = check_choice(f"{key}.dist", check_required(spec, "dist", key, "one of " + ", ".join(DISTS)), DISTS)
        forms = _DIST_FORMS[dist]
        all_keys = tuple(dict.fromkeys(k for req, opt in forms for k in (*req, *opt)))
        for k in spec:
            owners = [o for o, fs in _DIST_FORMS.items() if any(k in (*req, *opt) for req, opt in fs)]
            if k != "dist" and k not in all_keys and owners:
                raise ConfigError(
                    f"{key}.{k}",
                    f"{key}.{k} is a parameter of dist={' or '.join(map(repr, owners))}, not of dist={dist!r} "
                    f"(allowed: {', '.join(all_keys)})",
                )
        check_no_unknown(spec, ("dist", *all_keys), key, f"parameter of dist={dist!r}")
        args = {k: check_num(f"{key}.{k}", v) for k, v in spec.items() if k != "dist"}
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
    r = RANGES[param]
    for k in ("sd", "rel_sd", "cv"):
        if k in a and not a[k] > 0:
            raise config_error(f"{key}.{k}", a[k], "is out of range", "a number > 0")
    if "mean" in a and not r.contains(a["mean"]):
        raise config_error(f"{key}.mean", a["mean"], f"is outside the physical range of {param}", r.describe())
    if dist == "lognormal" and "mean" in a and not a["mean"] > 0:
        raise config_error(f"{key}.mean", a["mean"], "is out of range", "a number > 0 (lognormal)")
    for k in ("lower", "upper", "low", "high", "mode"):
        if k in a and not (r.lo <= a[k] <= r.hi):
            raise config_error(f"{key}.{k}", a[k], f"is outside the physical range of {param}", describe_interval(r.lo, r.hi))
    lo, hi = a.get("lower", r.lo), a.get("upper", r.hi)
    if ("lower" in a or "upper" in a) and not lo < hi:
        k = "upper" if "upper" in a else "lower"
        raise config_error(f"{key}.{k}", a[k], "leaves an empty interval", f"lower < upper (now {lo:g} and {hi:g})")
    if "low" in a and not a["low"] < a["high"]:
        raise config_error(f"{key}.high", a["high"], "is not above low", f"a number > low = {a['low']:g}")
    if "rel_low" in a and not a["rel_low"] < a["rel_high"]:
        raise config_error(f"{key}.rel_high", a["rel_high"], "is not above rel_low", f"a number > rel_low = {a['rel_low']:g}")


def _resolve(u: Uncertain, nominal: float, where: str) -> ParamDistribution:
    """:func:`_restricted`, refused if it can draw a non-finite value or puts more than NEGLIGIBLE_MASS outside the plausible range.

    The plausible range is :data:`RANGES`' (a run with a value outside it is refused and
    recorded as failed), so at most a NEGLIGIBLE_MASS share of a study's runs can fail so.
    """
    r, key = RANGES[u.param], f"uncertain.{u.param}"
    with np.errstate(all="ignore"):
        pd = _restricted(u, nominal, where)
        ends = pd.ppf(np.array([0.0, NEGLIGIBLE_MASS, 1.0 - NEGLIGIBLE_MASS, 1.0]))  # 0, 1: the extreme draws (U_EPS)
    if not (np.isfinite(ends).all() and r.plausible(ends[1:3]).all()):
        spec = ", ".join(f"{k} = {v:g}" for k, v in u.args)
        raise ConfigError(
            key,
            f"{key} (dist={u.dist!r}, {spec}){f' for {where}' if where else ''} draws from {ends[0]:.4g} to {ends[3]:.4g} "
            f"{r.units}, its {NEGLIGIBLE_MASS:g} and {1 - NEGLIGIBLE_MASS:g} quantiles {ends[1]:.4g} and {ends[2]:.4g} (allowed: "
            f"finite draws, at most {NEGLIGIBLE_MASS:g} of them outside {r.describe_plausible()}, {r.why}; a smaller spread)",
        )
    return pd


def _restricted(u: Uncertain, nominal: float, where: str) -> ParamDistribution:  # noqa: C901
    r = RANGES[u.param]
    a = dict(u.args)
    key = f"uncertain.{u.param}"
    at = f" for {where}" if where else ""
    if u.dist in ("normal", "truncnormal"):
        mean = a.get("mean", nominal)
        sd = a["sd"] if "sd" in a else a["rel_sd"] * abs(nominal)
        if not sd > 0:
            raise config_error(
                f"{key}.rel_sd", a["rel_sd"], f"gives sd = 0 around the nominal {nominal:g}{at}", "an absolute 'sd' > 0 instead"
            )
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
        s2 = math.log1p(min(cv * cv, 1e300))  # a cv beyond 1e150 is refused by its draws (_resolve)
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
            raise config_error(
                f"{key}.rel_low",
                a["rel_low"],
                f"is relative to the nominal {nominal:g}{at}",
                "relative bounds need a nominal > 0; use low/high",
            )
        low, high, mode = a["rel_low"] * nominal, a["rel_high"] * nominal, a.get("rel_mode", 1.0) * nominal
        mode_key = f"{key}.rel_mode"
        if low < r.lo:
            raise config_error(f"{key}.rel_low", a["rel_low"], f"gives low = {low:g}{at}, below the physical range", r.describe())
        if high > r.hi:
            raise config_error(f"{key}.rel_high", a["rel_high"], f"gives high = {high:g}{at}, above the physical range", r.describe())
    if u.dist == "uniform":
        return ParamDistribution(u.param, stats.uniform(loc=low, scale=high - low), 0.0, 1.0)
    if not low <= mode <= high:
        allowed = f"a mode in [low, high] = [{low:g}, {high:g}]"
        given = mode_key.rsplit(".", 1)[1]
        if given in a:
            raise config_error(mode_key, a[given], f"gives mode = {mode:g}{at}", allowed)
        raise ConfigError(
            mode_key, f"{mode_key} is not given and its default, the nominal {mode:g}{at}, is outside [low, high] (allowed: {allowed})"
        )
    return ParamDistribution(u.param, stats.triang((mode - low) / (high - low), loc=low, scale=high - low), 0.0, 1.0)


def nominal_value(param: str, substrate: str, field_mT: float) -> float:
    """Nominal value of an uncertain parameter in a cell (the preset's, or the cell field)."""
    if param == "field_mT":
        return float(field_mT)
    if param in ("axis_yaw_deg", "axis_pitch_deg"):
        return 0.0
    return float(getattr(PRESETS[substrate], param))
