"""A study's identity: the canonical JSON of its config and the hash that names its results.

Split from :mod:`tumblemc.study.config`, which re-exports :func:`config_to_json`,
:func:`config_hash` and :data:`ADDED_KEYS`.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from typing import TYPE_CHECKING, Any

from tumblemc.study.fieldcfg import FieldConfig

if TYPE_CHECKING:
    from tumblemc.study.config import StudyConfig

#: keys added to the schema after studies were written, with the value every earlier study
#: implied: left out of the hashed text (identity_json) at that value, so that an earlier study
#: keeps its config hash. ``rotation`` then became "momentum" by default: a config that omits it hashes
#: with it written out, so an earlier paper-form run's shards are refused, not mixed in; the
#: same for ``early_decision`` (true by default) and ``check.twin_rel`` (the
#: sensitivity twins of the dt check, 1e-6 by default)
#: A study without ``dt`` whose cells need different default steps also hashes a marker
#: ``dt_rule = "per cell"`` (each cell at its own step; earlier versions ran every cell at the
#: most demanding cell's): a study whose cells share one step keeps its hash.
ADDED_KEYS: dict[str, object] = {
    "rotation": "paper",
    "check.ratio_abs_tol": 0.05,
    "check.ratio_rel_tol": 0.1,
    "check.twin_rel": 0.0,
    "field": dataclasses.asdict(FieldConfig()),
    "precision": None,
    "early_decision": False,
}


def config_to_json(config: StudyConfig) -> str:
    """Canonical JSON of a config: sorted keys, defaults filled in, ``incline_deg`` expanded, ``[execution]`` left out.

    ``load_config(json.loads(...))`` gives the config back (with the default execution table):
    every key is written, also those of :data:`ADDED_KEYS` (which :func:`identity_json`, the
    text the hash is taken of, leaves out at the value earlier studies implied).
    """
    d = _canonical(config)
    if d["field"]["kind"] == "paper":  # the paper's field takes no other key (study/fieldcfg.py)
        d["field"] = {"kind": "paper"}
    return json.dumps(d, sort_keys=True, separators=(",", ":"), allow_nan=False)


def identity_json(config: StudyConfig) -> str:
    """The text :func:`config_hash` is taken of.

    :func:`config_to_json` without the keys of :data:`ADDED_KEYS` that hold the value every
    earlier study implied (so that an earlier study keeps its hash).
    """
    d = _canonical(config)
    for key, default in ADDED_KEYS.items():  # keys added later: only when not at their default
        *parents, leaf = key.split(".")
        table = d
        for p in parents:
            table = table[p]
        if leaf in table and table[leaf] == default:
            del table[leaf]
    if config.dt is None and _steps_differ(config):  # cells at different steps: studies run before
        d["dt_rule"] = "per cell"  # ran every cell at the finest one, so their shards are refused, not mixed in
    return json.dumps(d, sort_keys=True, separators=(",", ":"), allow_nan=False)


def _steps_differ(config: StudyConfig) -> bool:
    """Whether the cells of a study without ``dt`` run at different default steps (:mod:`tumblemc.study.stepcfg`)."""
    from tumblemc.study.stepcfg import step_attrs

    return "dt_rule" in step_attrs(config)


def _canonical(config: StudyConfig) -> dict[str, Any]:
    d = dataclasses.asdict(config)
    del d["execution"]
    for k in ("shapes", "presets", "incline_deg", "field_mT", "freq_hz"):
        d[k] = list(d[k])
    d["uncertain"] = {u.param: u.to_dict() for u in config.uncertain}
    if d.pop("posterior") is not None:  # the file (where) and its sha256 (what)
        d["uncertain"]["posterior"] = config.posterior.to_dict() if config.posterior else None
    d["incline_range"] = {"min": config.incline_range[0], "max": config.incline_range[1]}
    if config.mode != "critical_incline":  # keys only the critical-incline mode takes
        del d["incline_range"], d["incline_tol"]
    if config.mode != "threshold":  # and the threshold mode
        del d["threshold_axis"], d["threshold_start"]
    if config.mode != "grid":  # the sensitivity twins are the grid mode's (study/twins.py)
        del d["check"]["twin_rel"]
    return d


def config_hash(config: StudyConfig) -> str:
    """sha256 (hex) of the sampling scheme and :func:`identity_json`.

    The identity of a study's results; insensitive to ``[execution]``.
    """
    text = identity_json(config)
    if config.posterior is not None:  # the posterior's identity is its content, not where it lies
        text = text.replace(json.dumps(config.posterior.file), '""', 1)
    return hashlib.sha256(f"tumblemc-sampling-{_scheme()}\n{text}".encode()).hexdigest()


def _scheme() -> int:
    from tumblemc.study.config import SAMPLING_SCHEME

    return SAMPLING_SCHEME


__all__ = ["ADDED_KEYS", "config_hash", "config_to_json", "identity_json"]
