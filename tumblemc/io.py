"""Study storage: crash-safe shards while a study runs, one netCDF file when it is done.

While a study runs, every finished batch is written at once to its own shard file in
``<result>.parts/`` (written to a temporary name, flushed and renamed, so a shard is either
complete or absent after ``kill -9`` or power loss). The folder also holds ``study.json``:
the config (canonical JSON) and its hash. Rerunning the same study reads the shards and
runs only what is missing; a different config is refused unless the caller starts afresh.
When every run is done the shards are assembled into one netCDF file (netCDF4 engine, zlib)
with two groups, ``runs`` and ``maps``, and the folder is removed.
"""

from __future__ import annotations

import io
import json
import os
import shutil
import uuid
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

SHARD_SUFFIX = ".npz"


class StudyStateError(ValueError):
    """The stored state of a study does not belong to the config being run."""


def parts_dir(result: Path) -> Path:
    """The shard folder of a result file."""
    return result.with_name(result.name + ".parts")


def _fsync_dir(folder: Path) -> None:
    """Make a rename in ``folder`` durable (POSIX; a no-op where directories cannot be opened)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:  # pragma: no cover - e.g. Windows
        return
    try:
        os.fsync(fd)
    except OSError:  # pragma: no cover
        pass
    finally:
        os.close(fd)


def _atomic_write_bytes(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")
    with open(tmp, "wb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


class ShardStore:
    """The ``<result>.parts/`` folder of one study.

    Parameters
    ----------
    result : Path
        The final netCDF file; shards live next to it.
    config_json, config_hash : str
        Identity of the study; :meth:`open` refuses a folder written by another config.
    """

    def __init__(self, result: Path, config_json: str, config_hash: str) -> None:
        self.result = Path(result)
        self.dir = parts_dir(self.result)
        self.config_json = config_json
        self.config_hash = config_hash

    def open(self, fresh: bool = False) -> None:
        """Create the folder, or check that an existing one belongs to this config."""
        meta = self.dir / "study.json"
        if fresh and self.dir.exists():
            shutil.rmtree(self.dir)
        if meta.exists():
            stored = json.loads(meta.read_text())
            if stored.get("config_hash") != self.config_hash:
                raise StudyStateError(
                    f"{self.dir} holds runs of a different config (hash {stored.get('config_hash', '?')[:12]}, "
                    f"this config {self.config_hash[:12]}); rerun with --fresh (fresh=True) to discard them, "
                    f"or give another --out"
                )
            return
        self.dir.mkdir(parents=True, exist_ok=True)
        _atomic_write_bytes(meta, json.dumps({"config_hash": self.config_hash, "config": json.loads(self.config_json)}, indent=1).encode())

    def write(self, kind: str, run: np.ndarray, outcome: dict[str, np.ndarray]) -> Path:
        """Write one finished batch: ``run`` indices and outcome columns (same length)."""
        name = f"{kind}-{int(run[0]):09d}-{len(run)}-{uuid.uuid4().hex[:8]}{SHARD_SUFFIX}"
        arrays: dict[str, Any] = {"run": np.asarray(run, dtype=np.int64)}
        for k, v in outcome.items():
            arrays[k] = np.asarray(v).astype(str) if np.asarray(v).dtype == object else np.asarray(v)
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        path = self.dir / name
        _atomic_write_bytes(path, buf.getvalue())
        return path

    def read(self, kind: str) -> dict[str, np.ndarray]:
        """All finished runs of ``kind``.

        Concatenated columns sorted by run index, each run once (a shard written twice,
        e.g. by a task that was retried, counts once).
        """
        cols: dict[str, list[np.ndarray]] = {}
        if not self.dir.exists():
            return {}
        for path in sorted(self.dir.glob(f"{kind}-*{SHARD_SUFFIX}")):
            try:
                with np.load(path, allow_pickle=False) as z:
                    data = {k: z[k] for k in z.files}
            except (OSError, ValueError, EOFError):  # pragma: no cover - a torn file cannot be renamed into place
                continue
            for k, v in data.items():
                cols.setdefault(k, []).append(v)
        if not cols:
            return {}
        out = {k: np.concatenate(v) for k, v in cols.items()}
        _, first = np.unique(out["run"], return_index=True)
        return {k: v[first] for k, v in out.items()}

    def done(self, kind: str) -> np.ndarray:
        """Run indices of ``kind`` already finished."""
        return self.read(kind).get("run", np.zeros(0, np.int64))

    def remove(self) -> None:
        """Delete the shard directory and everything in it."""
        shutil.rmtree(self.dir, ignore_errors=True)


def write_result(path: Path, runs: xr.Dataset, maps: xr.Dataset, root_attrs: dict[str, Any]) -> None:
    """Write ``runs`` and ``maps`` as groups of one netCDF4 file (zlib), atomically."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")
    xr.Dataset(attrs=root_attrs).to_netcdf(tmp, mode="w", engine="netcdf4")
    for group, ds in (("runs", runs), ("maps", maps)):
        enc = {v: {"zlib": True, "complevel": 4} for v in ds.data_vars if ds[v].dtype.kind in "fiub"}
        ds.to_netcdf(tmp, mode="a", group=group, engine="netcdf4", encoding=enc)
    with open(tmp, "rb") as fh:  # on disk before the shards it replaces are removed
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    _fsync_dir(path.parent)


def open_result(path: str | Path) -> tuple[xr.Dataset, xr.Dataset]:
    """Open a study file: ``(runs, maps)`` datasets, loaded into memory."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path} does not exist (a study result written by `tumblemc study run`)")
    with xr.open_dataset(path, group="runs", engine="netcdf4") as r, xr.open_dataset(path, group="maps", engine="netcdf4") as m:
        return r.load(), m.load()


def result_attrs(path: str | Path) -> dict[str, Any]:
    """The root attributes of a study file."""
    with xr.open_dataset(path, engine="netcdf4") as ds:
        return dict(ds.attrs)


def _netcdf_safe(value: Any) -> Any:
    """An attribute value netCDF4 can store: bools -> int, sequences -> numpy arrays."""
    if isinstance(value, (bool, np.bool_)):
        return int(value)
    if value is None:
        return ""
    if isinstance(value, (list, tuple)):
        arr = np.asarray([_netcdf_safe(v) for v in value])
        return arr.astype(str) if arr.dtype == object else arr
    if isinstance(value, np.ndarray):
        return value.astype(np.int8) if value.dtype == bool else value
    if isinstance(value, dict):
        return repr(value)
    return value


def netcdf_ready(ds: Any) -> Any:
    """A shallow copy of ``ds`` whose global and variable attrs are netCDF-safe."""
    out = ds.copy(deep=False)
    out.attrs = {k: _netcdf_safe(v) for k, v in ds.attrs.items()}
    for name in out.variables:
        out[name].attrs = {k: _netcdf_safe(v) for k, v in ds[name].attrs.items()}
    return out


def write_run(ds: xr.Dataset, path: str | Path) -> None:
    """Write one run's Dataset (:func:`tumblemc.simulate`) to netCDF, compressed.

    Its attributes are made netCDF-safe first (:func:`netcdf_ready`).
    """
    safe = netcdf_ready(ds)
    safe.to_netcdf(path, engine="netcdf4", encoding={name: {"zlib": True, "complevel": 4} for name in safe.data_vars})


__all__ = ["ShardStore", "netcdf_ready", "StudyStateError", "open_result", "parts_dir", "result_attrs", "write_result", "write_run"]
