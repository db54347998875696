"""Evaluating a design: the robots it is tested on (common random numbers) and the estimates.

*Common random numbers.* Robot ``s`` of a design problem has the uniforms
``SeedSequence([seed, stream, s])`` (``stream`` 0 for the search, 1 for the fresh robots
that re-estimate the recommendation), one slot per uncertain parameter (the study's
slots, :func:`tumblemc.study.distributions.mc_slot`), one for the posterior draw and one
per design variable (its manufacturing noise). The draws depend on neither the design nor
the objective: every design meets the same robots, so differences between designs are
paired, and robot ``s`` is the same robot in every objective (its parameters follow each
substrate's nominal values through the same uniforms).

:func:`execute` runs one :class:`Chunk` (one design, one objective, some robots) and
returns each robot's value; :func:`estimate` turns values into the design's estimate and
interval.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, cast

import numpy as np
from scipy import stats

from tumblemc.design.config import DesignConfig, Objective
from tumblemc.design.families import Design, build
from tumblemc.model.rows import RunRow, TimeGrid, simulate_rows
from tumblemc.study.distributions import POSTERIOR_SLOT, UNCERTAIN_PARAMS, mc_slot, nominal_value
from tumblemc.study.threshold import search_rows

SEARCH, FRESH = 0, 1  # the two streams of robots
_WIDTH = len(UNCERTAIN_PARAMS) + 1  # the study's slots and the posterior's; the variables' follow


def uniforms(cfg: DesignConfig, samples: Sequence[int], stream: int) -> np.ndarray:
    """(len(samples), _WIDTH + n_variables) uniforms in (0, 1) of robots ``samples``."""
    width = _WIDTH + len(cfg.variables)
    out = np.empty((len(samples), width))
    for i, s in enumerate(samples):
        state = np.random.SeedSequence([cfg.seed, 20261205, stream, int(s)]).generate_state(width, np.uint64)
        out[i] = ((state >> np.uint64(11)).astype(float) + 0.5) * 2.0**-53
    return out


def robot_params(cfg: DesignConfig, obj: Objective, u: np.ndarray) -> list[dict[str, float]]:
    """Each robot's parameter overrides on ``obj``'s substrate (the study's distributions)."""
    rows: list[dict[str, float]] = [{} for _ in range(len(u))]
    for unc in cfg.uncertain:
        dist = unc.resolve(nominal_value(unc.param, obj.substrate, obj.field_mT))
        vals = dist.ppf(u[:, mc_slot(unc.param)])
        name = "field_mT" if unc.param == "field_mT" else unc.param
        for r, v in zip(rows, vals, strict=True):
            r[name] = float(v)
    if cfg.posterior is not None:
        draws = cfg.posterior.rows(u[:, POSTERIOR_SLOT])
        for r, d in zip(rows, draws, strict=True):
            r.update({p: float(v) for p, v in zip(cfg.posterior.params, d, strict=True)})
    return rows


def robot_dims(cfg: DesignConfig, x: Mapping[str, float], u: np.ndarray) -> list[dict[str, float]]:
    """Each robot's dimensions: ``x`` plus its manufacturing noise (normal, sd ``tolerance``, kept in the bounds)."""
    out = []
    for row in u:
        d = dict(x)
        for j, v in enumerate(cfg.variables):
            if v.tolerance > 0:
                d[v.name] = float(np.clip(x[v.name] + v.tolerance * stats.norm.ppf(row[_WIDTH + j]), v.lo, v.hi))
        out.append(cfg.dims(d))
    return out


@dataclass(frozen=True)
class Chunk:
    """One unit of work: design ``design`` at ``x``, objective ``task`` (index into ``cfg.tasks``), robots ``samples``."""

    design: int
    x: tuple[tuple[str, float], ...]
    task: int
    samples: tuple[int, ...]
    stream: int
    cfg: DesignConfig

    @property
    def key(self) -> str:
        """Stable name of the chunk (its file in the parts folder)."""
        return f"d{self.design:05d}-t{self.task:02d}-s{self.stream}-{self.samples[0]:07d}"


def time_grid(cfg: DesignConfig, obj: Objective) -> TimeGrid:
    """The time grid of ``obj``'s runs: a speed is measured to the end, verdicts may stop early."""
    return TimeGrid(
        periods=cfg.periods,
        transient_periods=cfg.transient_periods,
        dt=cfg.dt,
        success_ratio=cfg.success_ratio,
        max_failed_steps=1,
        early_decision=obj.kind != "speed",
    )


def _row(obj: Objective, des: Design, params: Mapping[str, float], **at: float) -> RunRow:
    row: dict[str, Any] = {"preset": obj.substrate, "incline_deg": obj.incline_deg, "field_mT": obj.field_mT, "freq_hz": obj.freq_hz}
    row.update(params)
    row.update(des.overrides())
    row.update(at)
    return cast(RunRow, row)


def execute(chunk: Chunk) -> dict[str, np.ndarray]:
    """Simulate ``chunk``: per robot ``value`` (NaN where invalid), ``status``, ``n_sim`` and ``error``.

    A design that cannot be built (a robot whose manufacturing noise leaves the buildable
    set) gets status 3 and the reason; nothing raises.
    """
    cfg = chunk.cfg
    obj = cfg.tasks[chunk.task]
    u = uniforms(cfg, chunk.samples, chunk.stream)
    params = robot_params(cfg, obj, u)
    dims = robot_dims(cfg, dict(chunk.x), u)
    n = len(chunk.samples)
    out = {"value": np.full(n, np.nan), "status": np.full(n, 3, np.int8), "n_sim": np.zeros(n, np.int32), "error": np.full(n, "", object)}
    groups: dict[tuple[float, ...], list[int]] = {}
    for i, d in enumerate(dims):
        groups.setdefault(tuple(d.values()), []).append(i)
    grid = time_grid(cfg, obj)
    for idx in groups.values():
        try:
            des = build(cfg.family, dims[idx[0]], obj.substrate, cfg.mass_rule)
        except ValueError as e:
            out["error"][idx] = str(e)
            continue
        _simulate(obj, des, [params[i] for i in idx], grid, out, np.asarray(idx))
    return out


def _simulate(
    obj: Objective, des: Design, params: list[dict[str, float]], grid: TimeGrid, out: dict[str, np.ndarray], idx: np.ndarray
) -> None:
    if obj.kind in ("climb", "speed"):
        res = simulate_rows(des.shape, [_row(obj, des, p) for p in params], grid)
        ok = res["status"] == 0  # a valid run (a verdict decided early included)
        v = res["climbed"].astype(float) if obj.kind == "climb" else res["mean_speed"] * 1e3
        out["value"][idx] = np.where(ok, v, np.nan)
        out["status"][idx] = res["status"]
        out["n_sim"][idx] = 1
        out["error"][idx] = res["error"]
        return
    axis = "incline_deg" if obj.kind == "incline_quantile" else "field_mT"
    order = list(obj.grid) if axis == "incline_deg" else list(obj.grid)[::-1]  # difficulty order: easiest first
    rows = [[_row(obj, des, p, **{axis: float(g)}) for g in order] for p in params]
    res = search_rows(cast(Any, des.shape), rows, grid)
    npass = res["n_pass"]
    below = -math.inf if axis == "incline_deg" else math.inf  # climbs none of the grid
    thr = np.array([order[k - 1] if k > 0 else below for k in npass], dtype=float)
    out["value"][idx] = np.where(npass >= 0, thr, np.nan)
    out["status"][idx] = res["status"]
    out["n_sim"][idx] = res["n_simulations"]
    out["error"][idx] = res["error"]


@dataclass(frozen=True)
class Estimate:
    """A design's estimate on one objective: value, interval, valid robots, and the noise variance a model is told."""

    value: float
    lo: float
    hi: float
    n: int
    var: float


def estimate(obj: Objective, values: np.ndarray, level: float = 0.95) -> Estimate:
    """The design's value on ``obj`` from its robots' values (NaN: invalid, left out)."""
    v = np.asarray(values, dtype=float)
    v = v[~np.isnan(v)]
    n = len(v)
    if n == 0:
        return Estimate(math.nan, math.nan, math.nan, 0, math.inf)
    z = float(stats.norm.ppf(0.5 + level / 2))
    if obj.kind == "climb":
        k = float(v.sum())
        p = k / n
        den = 1 + z * z / n
        c = (p + z * z / (2 * n)) / den
        h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
        ps = (k + 1) / (n + 2)  # smoothed: a design at 0 or 1 is not noise-free
        return Estimate(p, max(0.0, c - h), min(1.0, c + h), n, ps * (1 - ps) / n)
    if obj.kind == "speed":
        m = float(v.mean())
        sd = float(v.std(ddof=1)) if n > 1 else math.inf
        h = float(stats.t.ppf(0.5 + level / 2, max(n - 1, 1))) * sd / math.sqrt(n)
        return Estimate(m, m - h, m + h, n, sd * sd / n)
    return _quantile(obj, np.sort(v), level)


def _quantile(obj: Objective, v: np.ndarray, level: float) -> Estimate:
    """Order statistic and its distribution-free (binomial) interval."""
    n = len(v)
    p0 = 1.0 - obj.q if obj.kind == "incline_quantile" else obj.q  # the quantile of the per-robot values
    # incline: the largest v_(j) with #(v >= v_(j)) >= q n; field: the smallest with #(v <= v_(j)) >= q n
    j = math.floor(n + 1 - obj.q * n + 1e-9) if obj.kind == "incline_quantile" else math.ceil(obj.q * n - 1e-9)
    j = min(max(j, 1), n)
    a = (1 - level) / 2
    lo_i = int(stats.binom.ppf(a, n, p0))
    hi_i = int(stats.binom.ppf(1 - a, n, p0)) + 1
    lo = float(v[lo_i - 1]) if lo_i >= 1 else -math.inf
    hi = float(v[hi_i - 1]) if hi_i <= n else math.inf
    val = float(v[j - 1])
    finite = v[np.isfinite(v)]
    spread = float(np.ptp(finite)) if len(finite) > 1 else 1.0
    width = (hi - lo) if math.isfinite(hi - lo) else spread
    return Estimate(val, lo, hi, n, (width / (2 * 1.96)) ** 2 + 1e-12)


__all__ = ["FRESH", "SEARCH", "Chunk", "Estimate", "estimate", "execute", "robot_dims", "robot_params", "time_grid", "uniforms"]
