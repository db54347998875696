"""A design problem (``tumblemc design run design.toml``): its schema and validation.

Example (``studies/design_spiked_ends.toml``)::

    name = "spiked_ends_climb"
    family = "spiked_ends"         # tumblemc.design.families.FAMILIES
    mass_rule = "density"          # density | ends | fixed (families module docstring)
    seed = 1
    strategy = "gp"                # gp | tpe | sobol (tumblemc.design.strategies)
    budget = 3200                  # simulations in all, confirmation included
    samples = 200                  # the most robots a design is evaluated on
    stage = 25                     # robots per stage; early stopping decides between stages
    initial = 8                    # designs of the initial space-filling set
    batch = 4                      # designs proposed per round
    confirm = 200                  # fresh robots that re-estimate the recommended design

    [variables.spike_base]         # a dimension of the family, m (degree for *_deg)
    bounds = [50e-6, 400e-6]
    tolerance = 0.0                # manufacturing sd, same unit (sampled per robot)

    [fixed]                        # other dimensions (defaults: the paper's shape)
    length = 800e-6

    [[objectives]]
    kind = "climb"                 # climb | speed | incline_quantile | critical_field
    substrate = "aluminum"
    incline_deg = 30
    field_mT = 20
    freq_hz = 1

    [[constraints]]                # same keys as an objective, plus min or max
    kind = "climb"
    substrate = "paper"
    incline_deg = 20
    min = 0.8

    [uncertain]                    # as in a study (defaults when absent; a posterior too)

Objective kinds and their estimates (value per robot -> design value):

- ``climb``: climbed (0/1) at ``incline_deg``; P(climb) with a Wilson interval. Maximised.
- ``speed``: mean uphill speed (mm/s) after the transient; the mean with a t interval.
  Maximised.
- ``incline_quantile``: each robot's critical incline on ``incline_grid`` (a threshold
  search); the incline that a fraction ``q`` of robots climb (order statistic with its
  binomial interval). Maximised.
- ``critical_field``: each robot's smallest climbing field on ``field_grid``; its ``q``
  quantile. Minimised.
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tumblemc.design.families import MASS_RULES, build, get_family
from tumblemc.model.params import PRESETS, RANGES
from tumblemc.study.checks import (
    ConfigError,
    check_choice,
    check_int,
    check_no_unknown,
    check_num,
    check_num_list,
    check_range_table,
    check_required,
    check_str,
    check_table,
    config_error,
    read_config_text,
)
from tumblemc.study.distributions import DEFAULT_UNCERTAIN, Uncertain, parse_uncertain
from tumblemc.study.posterior import Posterior, split_posterior

KINDS = ("climb", "speed", "incline_quantile", "critical_field")
GOALS = {"climb": "max", "speed": "max", "incline_quantile": "max", "critical_field": "min"}
UNITS = {"climb": "1", "speed": "mm/s", "incline_quantile": "degree", "critical_field": "mT"}
STRATEGIES = ("gp", "tpe", "sobol")
#: the incline range of objectives and constraints, degrees (a study's default incline_range)
INCLINE_RANGE = (0.0, 60.0)
_DERIVED = ("mass", "V_m")  # follow from the design: not uncertain


@dataclass(frozen=True)
class Variable:
    """A design variable: a dimension of the family, its bounds and manufacturing sd (m, or degree)."""

    name: str
    lo: float
    hi: float
    tolerance: float = 0.0


@dataclass(frozen=True)
class Objective:
    """An objective or a constraint (``bound``/``sense`` set): what is measured, where, and its goal."""

    name: str
    kind: str
    substrate: str
    incline_deg: float = 0.0
    field_mT: float = 20.0
    freq_hz: float = 1.0
    q: float = 0.9
    grid: tuple[float, ...] = ()
    goal: str = "max"
    bound: float | None = None  # constraints: the bound the estimate must meet
    sense: str = ""  # "min" (estimate >= bound) or "max" (estimate <= bound)

    @property
    def unit(self) -> str:
        """Unit of the estimate."""
        return UNITS[self.kind]

    @property
    def label(self) -> str:
        """What the estimate is, in words (figures, tables)."""
        at = f"{self.substrate}, {self.field_mT:g} mT, {self.freq_hz:g} Hz"
        if self.kind == "climb":
            return f"P(climb {self.incline_deg:g} deg, {at})"
        if self.kind == "speed":
            return f"speed at {self.incline_deg:g} deg ({at}), mm/s"
        if self.kind == "incline_quantile":
            return f"incline {self.q:.0%} of robots climb ({at}), deg"
        return f"field {self.q:.0%} of robots climb at ({self.substrate}, {self.incline_deg:g} deg, {self.freq_hz:g} Hz), mT"

    @property
    def binary(self) -> bool:
        """Whether each robot's value is 0/1 (the anytime-valid early stop applies)."""
        return self.kind == "climb"


@dataclass(frozen=True)
class DesignConfig:
    """A validated design problem (module docstring)."""

    name: str
    family: str
    variables: tuple[Variable, ...]
    objectives: tuple[Objective, ...]
    seed: int
    fixed: Mapping[str, float] = field(default_factory=dict)
    constraints: tuple[Objective, ...] = ()
    mass_rule: str = "density"
    strategy: str = "gp"
    budget: int = 3200
    samples: int = 200
    stage: int = 25
    initial: int = 8
    batch: int = 4
    confirm: int = 200
    early_stop: bool = True
    level: float = 0.95
    periods: float = 2.0
    transient_periods: float = 1.0
    dt: float | None = None
    success_ratio: float = 0.5
    uncertain: tuple[Uncertain, ...] = ()
    posterior: Posterior | None = None
    description: str = ""
    source: str = ""  # the TOML text (stored in the result)

    @property
    def tasks(self) -> tuple[Objective, ...]:
        """Objectives then constraints: everything each design is evaluated on."""
        return self.objectives + self.constraints

    def dims(self, x: Mapping[str, float]) -> dict[str, float]:
        """The family's dimensions of design ``x`` (variables) with the fixed ones."""
        return {**self.fixed, **{k: float(v) for k, v in x.items()}}


_TOP = (
    "name description family mass_rule seed strategy budget samples stage initial batch confirm early_stop level "
    "periods transient_periods dt success_ratio variables fixed objectives constraints uncertain"
).split()
_OBJ = ("name", "kind", "substrate", "incline_deg", "field_mT", "freq_hz", "q", "incline_grid", "field_grid", "goal")


def _grid(key: str, v: Any, lo: float, hi: float) -> tuple[float, ...]:
    g = check_range_table(key, v, lo, hi) if isinstance(v, Mapping) else check_num_list(key, v, lo, hi)
    if len(g) < 2:
        raise config_error(key, v, "has fewer than 2 values", "at least 2 values to search")
    return tuple(sorted(g))


def _objective(key: str, t: Any, constraint: bool) -> Objective:
    t = check_table(key, t)
    check_no_unknown(t, (*_OBJ, *(("min", "max") if constraint else ())), key)
    kind = check_choice(f"{key}.kind", check_required(t, "kind", key, ", ".join(KINDS)), KINDS)
    sub = check_choice(f"{key}.substrate", check_required(t, "substrate", key, ", ".join(PRESETS)), sorted(PRESETS))
    lo, hi = INCLINE_RANGE
    inc = check_num(f"{key}.incline_deg", t.get("incline_deg", 0.0), lo, hi)
    mT = check_num(f"{key}.field_mT", t.get("field_mT", 20.0), 0.0, RANGES["field_mT"].hi, lo_open=True)
    hz = check_num(f"{key}.freq_hz", t.get("freq_hz", 1.0 if kind != "speed" else 10.0), 0.0, RANGES["freq_hz"].hi, lo_open=True)
    q = check_num(f"{key}.q", t.get("q", 0.9 if kind == "incline_quantile" else 0.5), 0.0, 1.0, lo_open=True, hi_open=True)
    grid: tuple[float, ...] = ()
    if kind == "incline_quantile":
        grid = _grid(f"{key}.incline_grid", t.get("incline_grid", {"start": 0, "stop": 60, "step": 2.5}), lo, hi)
    elif kind == "critical_field":
        grid = _grid(f"{key}.field_grid", t.get("field_grid", {"start": 1, "stop": 30, "step": 1}), 1e-6, RANGES["field_mT"].hi)
    for other in ("incline_grid", "field_grid"):
        if other in t and not (
            other == "incline_grid" and kind == "incline_quantile" or other == "field_grid" and kind == "critical_field"
        ):
            raise ConfigError(f"{key}.{other}", f"{key}.{other} does not apply to kind={kind!r}")
    goal = check_choice(f"{key}.goal", t.get("goal", GOALS[kind]), ("max", "min"))
    default = {"climb": f"climb{inc:g}_{sub}", "speed": f"speed{hz:g}Hz_{sub}", "incline_quantile": f"incline_q{q:g}_{sub}"}
    name = check_str(f"{key}.name", t.get("name") or default.get(kind, f"critical_field_q{q:g}_{sub}"))
    bound, sense = None, ""
    if constraint:
        if ("min" in t) == ("max" in t):
            raise ConfigError(key, f"{key} needs exactly one of min or max (the bound the design's estimate must meet)")
        sense = "min" if "min" in t else "max"
        bound = check_num(f"{key}.{sense}", t[sense])
    return Objective(name, kind, sub, inc, mT, hz, q, grid, goal, bound, sense)


def _variables(d: Mapping[str, Any], family: str) -> tuple[Variable, ...]:
    fam = get_family(family)
    vt = check_table("variables", check_required(d, "variables", "", "a [variables.<dimension>] table per design variable"))
    if not vt:
        raise ConfigError("variables", f"variables is empty (allowed: dimensions of {family}: {', '.join(fam.defaults)})")
    out = []
    for name, spec in vt.items():
        key = f"variables.{name}"
        check_no_unknown({name: 0}, tuple(fam.defaults), "variables", what=f"dimension of the {family} family")
        spec = check_table(key, spec)
        check_no_unknown(spec, ("bounds", "tolerance"), key)
        b = check_required(spec, "bounds", key, "[low, high]")
        if not isinstance(b, (list, tuple)) or len(b) != 2:
            raise config_error(f"{key}.bounds", b, "is not a pair", "[low, high]")
        hi_allowed = 89.9 if fam.unit(name) == "degree" else 0.1
        lo_v = check_num(f"{key}.bounds[0]", b[0], 0.0, hi_allowed, lo_open=True)
        hi_v = check_num(f"{key}.bounds[1]", b[1], 0.0, hi_allowed, lo_open=True)
        if not hi_v > lo_v:
            raise config_error(f"{key}.bounds", list(b), "is not increasing", "[low, high] with high > low")
        tol = check_num(f"{key}.tolerance", spec.get("tolerance", 0.0), 0.0, (hi_v - lo_v))
        out.append(Variable(name, lo_v, hi_v, tol))
    return tuple(out)


def _check_buildable(family: str, variables: tuple[Variable, ...], fixed: Mapping[str, float], rule: str) -> None:
    """Refuse bounds with a corner that cannot be built (every corner of the box is tried)."""
    import itertools

    for corner in itertools.product(*((v.lo, v.hi) for v in variables)):
        x = {v.name: c for v, c in zip(variables, corner, strict=True)}
        try:
            build(family, {**fixed, **x}, "aluminum", rule)
        except ValueError as e:
            raise ConfigError("variables", f"variables: the bounds reach designs that cannot be built: {e}") from None


def parse_design(d: Mapping[str, Any], base: Path | None = None, source: str = "") -> DesignConfig:
    """A :class:`DesignConfig` from a parsed TOML table; every problem is one :class:`ConfigError` naming the key."""
    d = check_table("<config>", d)
    check_no_unknown(d, _TOP, "")
    name = check_str("name", check_required(d, "name", "", "a name of letters, digits, '_' and '-'"))
    if not re.fullmatch(r"[A-Za-z0-9_-]+", name):
        raise config_error("name", name, "is not allowed", "letters, digits, '_' and '-' only")
    family = check_str("family", check_required(d, "family", "", "a family name"))
    try:
        fam = get_family(family)
    except ValueError as e:
        raise ConfigError("family", str(e)) from None
    rule = check_choice("mass_rule", d.get("mass_rule", "density"), MASS_RULES)
    variables = _variables(d, family)
    ft = check_table("fixed", d.get("fixed", {}))
    check_no_unknown(ft, tuple(fam.defaults), "fixed", what=f"dimension of the {family} family")
    fixed = {k: check_num(f"fixed.{k}", v, 0.0, 89.9 if fam.unit(k) == "degree" else 0.1, lo_open=True) for k, v in ft.items()}
    both = sorted(set(fixed) & {v.name for v in variables})
    if both:
        raise ConfigError(f"fixed.{both[0]}", f"fixed.{both[0]} is also a design variable (allowed: one or the other)")
    _check_buildable(family, variables, fixed, rule)

    objs = d.get("objectives")
    if not isinstance(objs, list) or not objs:
        raise ConfigError("objectives", "objectives is missing (required: one or more [[objectives]] tables)")
    objectives = tuple(_objective(f"objectives[{i}]", t, False) for i, t in enumerate(objs))
    cons_t = d.get("constraints", [])
    if not isinstance(cons_t, list):
        raise config_error("constraints", cons_t, "is not a list of tables", "[[constraints]] tables")
    constraints = tuple(_objective(f"constraints[{i}]", t, True) for i, t in enumerate(cons_t))
    names = [o.name for o in (*objectives, *constraints)]
    if len(set(names)) != len(names):
        raise ConfigError("objectives", f"objective and constraint names repeat: {names} (allowed: distinct names; set name = ...)")

    samples = check_int("samples", d.get("samples", 200), 2, 100_000)
    stage = check_int("stage", d.get("stage", min(25, samples)), 1, samples)
    if samples % stage:
        raise config_error("stage", stage, f"does not divide samples = {samples}", "a divisor of samples")
    unc_table, posterior = split_posterior(d.get("uncertain", DEFAULT_UNCERTAIN), base)
    uncertain = parse_uncertain(unc_table)
    for u in uncertain:
        if u.param in _DERIVED:
            raise ConfigError(f"uncertain.{u.param}", f"uncertain.{u.param} follows from the design (mass_rule) and cannot be uncertain")
        for o in (*objectives, *constraints):  # every nominal the search will meet
            from tumblemc.study.distributions import nominal_value

            u.resolve(nominal_value(u.param, o.substrate, o.field_mT), f"substrate {o.substrate}")
    budget = check_int("budget", d.get("budget", 3200), 1, 10**9)
    confirm = check_int("confirm", d.get("confirm", 200), 0, 1_000_000)
    least = (samples + (confirm if len(objectives) == 1 else 0)) * (len(objectives) + len(constraints))
    if budget < least:
        raise config_error("budget", budget, "does not pay for one design and the confirmation", f"at least {least} simulations")
    early = d.get("early_stop", True)
    if not isinstance(early, bool):
        raise config_error("early_stop", early, "is not a boolean", "true or false")
    periods = check_num("periods", d.get("periods", 2.0), 2.0, 1e4)
    transient = check_num("transient_periods", d.get("transient_periods", 1.0), 0.0, periods - 1.0)
    return DesignConfig(
        name=name,
        family=family,
        variables=variables,
        objectives=objectives,
        seed=check_int("seed", check_required(d, "seed", "", "an integer >= 0"), 0, 2**63 - 1),
        fixed=fixed,
        constraints=constraints,
        mass_rule=rule,
        strategy=check_choice("strategy", d.get("strategy", "gp"), STRATEGIES),
        budget=budget,
        samples=samples,
        stage=stage,
        initial=check_int("initial", d.get("initial", 8), 1, 10_000),
        batch=check_int("batch", d.get("batch", 4), 1, 1000),
        confirm=confirm,
        early_stop=early,
        level=check_num("level", d.get("level", 0.95), 0.5, 1.0, hi_open=True),
        periods=periods,
        transient_periods=transient,
        dt=None if d.get("dt") is None else check_num("dt", d["dt"], RANGES["dt"].lo, RANGES["dt"].hi),
        success_ratio=check_num("success_ratio", d.get("success_ratio", 0.5), 0.0, 1.0, lo_open=True),
        uncertain=uncertain,
        posterior=posterior,
        description=check_str("description", d.get("description") or ""),
        source=source,
    )


def load_design(source: str | Path | Mapping[str, Any]) -> DesignConfig:
    """A design problem from a TOML file or a mapping; problems name the file and the key."""
    if isinstance(source, Mapping):
        return parse_design(source)
    path = Path(source)
    if not path.is_file():
        raise ConfigError("", f"{path}: no such design file")
    text = read_config_text(path)
    try:
        table = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ConfigError("", f"{path}: not valid TOML: {e}") from None
    try:
        return parse_design(table, path.parent, text)
    except ConfigError as e:
        raise ConfigError(e.key, f"{path}: {e}") from None


__all__ = ["GOALS", "INCLINE_RANGE", "KINDS", "STRATEGIES", "DesignConfig", "Objective", "Variable", "load_design", "parse_design"]
