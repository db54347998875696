"""A calibration posterior as a study's joint uncertainty (``[uncertain] posterior = "calib.nc"``).

The file is what :func:`tumblemc.lab.calibrate.calibrate` writes: one variable per
:class:`~tumblemc.model.params.Params` field along ``sample``. Each run takes one whole
draw (row) of it, so the correlations the calibration found are kept. The row is chosen by
a run-keyed uniform (the ``mc`` stream's slot :data:`POSTERIOR_SLOT`), so a run gets the
same draw whatever the workers or batch sizes, and whatever the other uncertain
parameters. Parameters in the posterior cannot also have their own
``[uncertain.<param>]`` table. The file's sha256 is part of the config's identity: a study
resumed against a changed posterior refuses the old shards.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from tumblemc.model.params import NUMERIC_FIELDS, RANGES
from tumblemc.study.checks import ConfigError, check_table, config_error, read_limited
from tumblemc.study.distributions import POSTERIOR_SLOT

#: the largest posterior file read: a million draws of every Params field take 112 MB
MAX_POSTERIOR_BYTES = 256 * 2**20


@dataclass(frozen=True)
class Posterior:
    """A posterior file: its path, sha256, parameter names and draws (n_draws x n_params)."""

    file: str
    sha256: str
    params: tuple[str, ...]
    draws: np.ndarray
    shape: str = ""  # the robot and preset it was calibrated for (file attributes; "" if absent)
    preset: str = ""

    def check_matches(self, shapes: tuple[str, ...], presets: tuple[str, ...]) -> None:
        """Refuse a study of other robots than the one the posterior was calibrated for."""
        for key, mine, theirs in (("shapes", self.shape, shapes), ("presets", self.preset, presets)):
            if mine and set(theirs) != {mine}:
                msg = f"uncertain.posterior {self.file} was calibrated for {key[:-1]} {mine!r}; the study has {key} {list(theirs)}"
                raise ConfigError(key, f"{msg} (allowed: [{mine!r}])")

    def to_dict(self) -> dict[str, Any]:
        """The config JSON form: ``{"file": ..., "sha256": ...}``."""
        return {"file": self.file, "sha256": self.sha256}

    def rows(self, u: np.ndarray) -> np.ndarray:
        """The draws picked by uniforms ``u`` in (0, 1): row ``floor(u x n)``."""
        n = len(self.draws)
        return self.draws[np.minimum((np.asarray(u) * n).astype(np.int64), n - 1)]


def load_posterior(value: Any, base: Path | None = None) -> Posterior:
    """Parse ``uncertain.posterior``: a path (relative to ``base``, the TOML's folder) or ``{file, sha256}``."""
    key = "uncertain.posterior"
    want = None
    if isinstance(value, dict):
        t = check_table(key, value)
        if set(t) - {"file", "sha256"} or "file" not in t:
            raise ConfigError(key, f"{key} = {value!r} is not allowed (allowed: a path, or {{file = ..., sha256 = ...}})")
        value, want = t["file"], t.get("sha256")
    if not isinstance(value, str) or not value:
        raise config_error(key, value, "is not a path", "a calibration file written by tumblemc calibrate --out")
    path = Path(value)
    if not path.is_absolute() and base is not None:
        path = base / path
    raw = read_limited(path, MAX_POSTERIOR_BYTES, "a calibration file written by tumblemc calibrate", key, f"{key} = {value!r}: ")
    digest = hashlib.sha256(raw).hexdigest()
    if want is not None and want != digest:
        raise ConfigError(key, f"{key}: {path} has changed (sha256 {digest[:12]}..., the study was written with {str(want)[:12]}...)")
    import xarray as xr

    try:
        with xr.open_dataset(path) as ds:
            names = tuple(n for n in ds.data_vars if ds[n].dims == ("sample",) and n in NUMERIC_FIELDS)
            draws = np.stack([ds[n].values.astype(float) for n in names], 1) if names else np.empty((0, 0))
            shape, preset = str(ds.attrs.get("shape", "")), str(ds.attrs.get("preset", ""))
    except (OSError, ValueError) as e:
        raise ConfigError(key, f"{key}: {path} is not a netCDF calibration file ({e})") from None
    if not names or len(draws) == 0:
        raise ConfigError(key, f"{key}: {path} has no posterior draws (allowed: variables named after Params fields along 'sample')")
    for j, n in enumerate(names):
        r = RANGES[n]
        bad = ~r.plausible(draws[:, j])
        if bad.any():
            i = int(np.argmax(bad))
            raise ConfigError(
                key,
                f"{key}: {path}: {n} has {int(bad.sum())} of {len(draws)} draws outside {r.describe_plausible()}, the first "
                f"{float(draws[i, j])!r} (sample {i}) (allowed: every draw a value Params accepts; {r.why or 'the physical range'})",
            )
    return Posterior(str(path.resolve()), digest, names, draws, shape, preset)


def split_posterior(table: Any, base: Path | None) -> tuple[Any, Posterior | None]:
    """The ``[uncertain]`` table without its ``posterior`` key, and the posterior it names."""
    if not isinstance(table, dict) or "posterior" not in table:
        return table, None
    rest = {k: v for k, v in table.items() if k != "posterior"}
    post = load_posterior(table["posterior"], base)
    both = sorted(set(post.params) & set(rest))
    if both:
        msg = f"uncertain.{both[0]} is also in the posterior {post.file} (allowed: one source per parameter)"
        raise ConfigError(f"uncertain.{both[0]}", msg)
    return rest, post


__all__ = ["MAX_POSTERIOR_BYTES", "POSTERIOR_SLOT", "Posterior", "load_posterior", "split_posterior"]
