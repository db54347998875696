"""A design search's result file: designs x objectives with intervals, the Pareto set, the runs behind them.

netCDF4 with groups (``xr.open_datatree(path)``, or ``xr.open_dataset(path, group=...)``):

- ``designs`` (dim ``design``): each design variable (its unit), ``round``,
  ``robots`` (evaluated on), ``stopped_early``, per objective ``<name>`` with
  ``<name>_lo``/``<name>_hi`` (the interval at ``level``), ``feasible`` (constraints met),
  ``pareto`` (not dominated by another design's estimates), ``model_mean`` (the model's
  posterior mean of the objective; one objective only) and ``recommended``.
- ``confirm`` (dim ``objective``): the recommended design re-estimated on fresh robots:
  ``value``, ``lo``, ``hi``, ``robots``.
- ``runs`` (dim ``run``): every robot's ``value`` per design, objective (``task``) and
  stream (0 search, 1 fresh), with ``status``, ``n_sim`` and ``sample``.

Root attributes: the problem (``config_json``, ``config_hash``, ``family``, ``mass_rule``,
``strategy``), ``simulations``, ``recommended`` (design index, -1 if none).
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr

from tumblemc.design.config import DesignConfig
from tumblemc.design.evaluate import FRESH, SEARCH
from tumblemc.ncformat import write_groups
from tumblemc.version import __version__

if TYPE_CHECKING:
    from tumblemc.design.search import Search


def pareto_mask(Y: np.ndarray) -> np.ndarray:
    """Rows of ``Y`` (larger is better in every column) that no other row dominates; NaN rows are never in the set."""
    ok = np.all(np.isfinite(Y), axis=1)
    out = np.zeros(len(Y), dtype=bool)
    for i in np.flatnonzero(ok):
        dom = np.all(Y[ok] >= Y[i], axis=1) & np.any(Y[ok] > Y[i], axis=1)
        out[i] = not dom.any()
    return out


def hypervolume(Y: np.ndarray, ref: np.ndarray) -> float:
    """Hypervolume dominated by the rows of ``Y`` (2 objectives, larger is better) above ``ref``."""
    P = Y[pareto_mask(Y)]
    P = P[np.all(P > ref, axis=1)]
    if not len(P):
        return 0.0
    P = P[np.argsort(-P[:, 0])]
    hv, y_prev = 0.0, float(ref[1])
    for a, b in P:
        if b > y_prev:
            hv += (a - ref[0]) * (b - y_prev)
            y_prev = b
    return hv


def _units(cfg: DesignConfig, var: str) -> str:
    from tumblemc.design.families import get_family

    return get_family(cfg.family).unit(var)


def build_dataset(s: Search, rec: int | None, means: np.ndarray | None = None) -> xr.DataTree:
    """The result tree of search ``s`` (module docstring); ``means``: the model's posterior means (larger is better; one objective)."""
    from tumblemc.design.search import config_dict, config_hash

    cfg = s.cfg
    nd = len(s.designs)
    des: dict[str, Any] = {}
    for v in cfg.variables:
        des[v.name] = (
            "design",
            np.array([d["x"][v.name] for d in s.designs]),
            {"units": _units(cfg, v.name), "long_name": f"design variable {v.name}"},
        )
    des["round"] = ("design", np.array([d["round"] for d in s.designs], np.int32), {"long_name": "round the design was proposed in"})
    robots = np.array([len(s.values.get((i, 0, SEARCH), [])) for i in range(nd)], np.int32)
    des["robots"] = ("design", robots, {"long_name": "robots the design was evaluated on (search stream)"})
    des["stopped_early"] = (
        "design",
        np.array([i in s.stopped for i in range(nd)]),
        {"long_name": "stopped: decisively worse than the best"},
    )
    for t, o in enumerate(cfg.tasks):
        e = [s.est(i, t) for i in range(nd)]
        what = "constraint" if o.bound is not None else "objective"
        des[o.name] = (
            "design",
            np.array([x.value for x in e]),
            {"units": o.unit, "long_name": f"{what} {o.name} ({o.kind}, goal {o.goal})", "label": o.label},
        )
        des[o.name + "_lo"] = (
            "design",
            np.array([x.lo for x in e]),
            {"units": o.unit, "long_name": f"{o.name}: lower end, level {cfg.level}"},
        )
        des[o.name + "_hi"] = (
            "design",
            np.array([x.hi for x in e]),
            {"units": o.unit, "long_name": f"{o.name}: upper end, level {cfg.level}"},
        )
    X, Y, V = s.matrix()
    feas = s.feasible()
    des["feasible"] = ("design", feas, {"long_name": "estimates meet every constraint"})
    des["pareto"] = ("design", pareto_mask(np.where(feas[:, None], Y, np.nan)), {"long_name": "feasible and not dominated (estimates)"})
    if means is not None:
        sign = 1.0 if cfg.objectives[0].goal == "max" else -1.0
        des["model_mean"] = (
            "design",
            sign * np.where(np.isfinite(means), means, np.nan),
            {"units": cfg.objectives[0].unit, "long_name": "model posterior mean"},
        )
    des["recommended"] = ("design", np.arange(nd) == (rec if rec is not None else -1), {"long_name": "the recommended design"})
    designs = xr.Dataset(des, coords={"design": np.arange(nd)})

    names = [o.name for o in cfg.tasks]
    conf: dict[str, list[float]] = {"value": [], "lo": [], "hi": [], "robots": []}
    for t in range(len(cfg.tasks)):
        est = s.est(rec, t, FRESH) if rec is not None else None
        conf["value"].append(est.value if est else math.nan)
        conf["lo"].append(est.lo if est else math.nan)
        conf["hi"].append(est.hi if est else math.nan)
        conf["robots"].append(est.n if est else 0)
    confirm = xr.Dataset({k: ("objective", np.array(v)) for k, v in conf.items()}, coords={"objective": np.array(names, dtype=object)})
    confirm.attrs["long_name"] = "the recommended design on fresh robots"

    cols: dict[str, list[Any]] = {k: [] for k in ("design", "task", "stream", "sample", "value", "status", "n_sim")}
    for c, r in sorted(s.chunks.values(), key=lambda cr: cr[0].key):
        n = len(c.samples)
        cols["design"] += [c.design] * n
        cols["task"] += [c.task] * n
        cols["stream"] += [c.stream] * n
        cols["sample"] += list(c.samples)
        cols["value"] += list(r["value"])
        cols["status"] += list(r["status"])
        cols["n_sim"] += list(r["n_sim"])
    runs = xr.Dataset(
        {
            "design": ("run", np.array(cols["design"], np.int32)),
            "task": (
                "run",
                np.array(cols["task"], np.int16),
                {"long_name": "objective index: " + ", ".join(f"{i} {n}" for i, n in enumerate(names))},
            ),
            "stream": ("run", np.array(cols["stream"], np.int8), {"long_name": "0 search robots, 1 fresh robots"}),
            "sample": ("run", np.array(cols["sample"], np.int64), {"long_name": "robot index (common to every design)"}),
            "value": ("run", np.array(cols["value"], float), {"long_name": "the robot's value on the objective (NaN: invalid run)"}),
            "status": ("run", np.array(cols["status"], np.int8), {"long_name": "run status (0 ok)"}),
            "n_sim": ("run", np.array(cols["n_sim"], np.int32), {"long_name": "simulations behind the value"}),
        }
    )
    attrs = {
        "title": f"tumblemc design search {cfg.name}",
        "family": cfg.family,
        "mass_rule": cfg.mass_rule,
        "strategy": cfg.strategy,
        "objectives": ",".join(o.name for o in cfg.objectives),
        "constraints": ",".join(o.name for o in cfg.constraints),
        "simulations": int(s.nsim),
        "budget": int(cfg.budget),
        "recommended": int(rec if rec is not None else -1),
        "config_json": json.dumps(config_dict(cfg), default=str),
        "config_hash": config_hash(cfg),
        "tumblemc_version": __version__,
    }
    return xr.DataTree.from_dict({"/": xr.Dataset(attrs=attrs), "designs": designs, "confirm": confirm, "runs": runs})


def write_result(path: Path, s: Search, rec: int | None, means: np.ndarray | None = None) -> None:
    """Write the result atomically (a temporary file renamed over ``path``)."""
    tree = build_dataset(s, rec, means)
    tmp = path.with_name(path.name + ".tmp")
    write_groups(tmp, tree.attrs, {name: node.to_dataset() for name, node in tree.children.items()})
    os.replace(tmp, path)


def open_design(path: str | Path) -> xr.DataTree:
    """A design search result (loaded into memory, the file closed)."""
    with xr.open_datatree(path, engine="netcdf4") as t:
        return t.load()


__all__ = ["build_dataset", "hypervolume", "open_design", "pareto_mask", "write_result"]
