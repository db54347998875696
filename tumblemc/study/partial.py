"""An interrupted study as it stands: its config from its shard folder, the runs done per cell, partial maps.

``study status <out>.nc`` and ``study plot <out>.nc`` read an interrupted study from
``<out>.nc.parts/`` (:mod:`tumblemc.io`) without its TOML: ``study.json`` there holds the
config. Nothing here writes to the folder (damaged shards are left where they are and
named by ``study status``), so a study may be read while ``study run`` is still adding to it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from tumblemc.analysis.maps import maps as make_maps
from tumblemc.io import ShardStore, StudyStateError, parts_dir, read_study_json
from tumblemc.study.adaptive import restrict
from tumblemc.study.assemble import assemble_runs
from tumblemc.study.config import StudyConfig, cells, load_config
from tumblemc.study.design import check_subset, design
from tumblemc.study.identity import config_hash, config_to_json

#: cell axes a map may spread along its columns, in order of preference
_COLUMN_AXES = ("incline_deg", "field_mT", "freq_hz")
_AXIS_WORDS = {"incline_deg": ("incline", "deg"), "field_mT": ("field", "mT"), "freq_hz": ("frequency", "Hz")}


def has_parts(result: str | Path) -> bool:
    """Whether ``result`` has a shard folder with its ``study.json`` (a study begun and not assembled)."""
    return (parts_dir(Path(result)) / "study.json").exists()


def config_of_parts(result: str | Path) -> StudyConfig:
    """The config of the study whose shards are in ``<result>.parts/``, from its ``study.json``.

    Raises :class:`tumblemc.io.StudyStateError` naming the file when it cannot be read or
    when the config it holds no longer hashes to the hash stored with it (an earlier version
    of tumblemc wrote it: its runs are not this version's).
    """
    meta = parts_dir(Path(result)) / "study.json"
    stored = read_study_json(meta)
    try:
        cfg = load_config(stored["config"])
    except (KeyError, TypeError, ValueError) as e:
        raise StudyStateError(f"{meta}: its config cannot be read ({e}); give the study's TOML instead") from None
    if config_hash(cfg) != stored.get("config_hash"):
        raise StudyStateError(
            f"{meta} was written by another version of tumblemc (its config hashes differently here); "
            "give the study's TOML, or rerun it with --fresh"
        )
    return cfg


def cell_map(cfg: StudyConfig, done: np.ndarray) -> str:
    """Runs done per cell as a text table (``done/total``), one row per shape and substrate.

    ``done`` holds the finished run indices (:func:`tumblemc.study.design.design` order:
    cell by cell, sample fastest). The columns are the incline grid (or the field or the
    frequency when the incline is not a swept cell axis); other swept axes name their value
    in the row.
    """
    cl = cells(cfg)
    n = cfg.samples
    counts = np.bincount(np.asarray(done, dtype=np.int64) // n, minlength=len(cl))
    dims = list(cl[0])
    swept = [d for d in dims if len({c[d] for c in cl}) > 1]
    col = next((d for d in _COLUMN_AXES if d in swept), None)
    row_dims = [d for d in dims if d in ("shape", "substrate") or (d in swept and d != col)]
    col_vals = sorted({c[col] for c in cl}) if col else [None]
    table: dict[tuple[Any, ...], dict[Any, int]] = {}
    for c, k in zip(cl, counts.tolist(), strict=True):
        table.setdefault(tuple(c[d] for d in row_dims), {})[c[col] if col else None] = k
    labels = [_row_label(row_dims, key) for key in table]
    lw = max(len(x) for x in labels)
    heads = [f"{v:g}" for v in col_vals] if col else ["runs"]
    cw = max(len(f"{n}/{n}"), *(len(h) for h in heads))
    cap = "up to " if cfg.precision is not None else ""
    what = f"; columns: {_AXIS_WORDS[col][0]}, {_AXIS_WORDS[col][1]}" if col else ""
    lines = [f"runs done per cell (of {cap}{n} each{what})", " " * lw + "  " + "  ".join(h.rjust(cw) for h in heads)]
    for label, row in zip(labels, table.values(), strict=True):
        lines.append(label.ljust(lw) + "  " + "  ".join(f"{row[v]}/{n}".rjust(cw) for v in col_vals))
    return "\n".join(lines)


def _row_label(dims: list[str], key: tuple[Any, ...]) -> str:
    parts = []
    for d, v in zip(dims, key, strict=True):
        parts.append(str(v) if d in ("shape", "substrate") else f"{_AXIS_WORDS[d][0]} {v:g} {_AXIS_WORDS[d][1]}")
    return "  ".join(parts)


def partial_result(result: str | Path) -> tuple[xr.Dataset, xr.Dataset, str]:
    """``(runs, maps, note)`` of the runs an interrupted grid study has finished, as :func:`tumblemc.io.open_result` would give.

    The maps count only the finished runs (a cell's interval is as wide as its count
    makes it; a cell with none is absent or NaN); the dt check covers the check runs
    finished with their run. The note says how much is done and how to finish. A
    threshold or critical-incline study is refused with that sentence: its maps need
    every search of a cell.
    """
    result = Path(result)
    cfg = config_of_parts(result)
    finish = f"finish it with `tumblemc study run <its TOML> --out {result}` (it resumes)"
    if cfg.mode != "grid":
        raise StudyStateError(f"{result} is not finished and a {cfg.mode} study has no partial maps; {finish}")
    store = ShardStore(result, config_to_json(cfg), config_hash(cfg))
    des = design(cfg)
    n = des.sizes["run"]
    store.n_runs = n
    main = store.read("main", set_aside=False)
    check = store.read("check", set_aside=False)
    used = np.asarray(main.get("run", np.zeros(0, np.int64)), dtype=np.int64)
    if not used.size:
        raise StudyStateError(f"{result} is not finished and no run of it is done yet; {finish}")
    check_idx = np.intersect1d(np.intersect1d(check_subset(des), check.get("run", ())), used).astype(np.int64)
    des_u, main_u, check_u, local = restrict(des, main, check, used, check_idx)
    runs = assemble_runs(cfg, des_u, main_u, local, check_u)
    maps = make_maps(runs, level=cfg.ci_level, method=cfg.ci)
    for ds in (runs, maps):
        ds.attrs.update({"partial": 1, "partial_runs_done": int(used.size), "partial_runs_total": int(n)})
    done_cells = int(np.count_nonzero(np.bincount(used // cfg.samples, minlength=n // cfg.samples) == cfg.samples))
    note = (
        f"partial: {used.size:,} of {'up to ' if cfg.precision is not None else ''}{n:,} runs done "
        f"({done_cells} of {n // cfg.samples} cells complete); the maps count only these; {finish}"
    )
    return runs, maps, note


__all__ = ["cell_map", "config_of_parts", "has_parts", "partial_result"]
