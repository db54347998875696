"""Study storage: crash-safe shards while a study runs, one netCDF file when it is done.

While a study runs, every finished batch is written at once to its own shard file in
``<result>.parts/`` (written to a temporary name, flushed and renamed, so a shard is either
complete or absent after ``kill -9`` or power loss). The folder also holds ``study.json``:
the config (canonical JSON) and its hash. Rerunning the same study reads the shards and
runs only what is missing; a different config is refused unless the caller starts afresh.
When every run is done the shards are assembled into one netCDF file (netCDF4 engine, zlib)
with two groups, ``runs`` and ``maps``, and the folder is removed.

Every shard carries a checksum: the first 16 hex digits of the SHA-256 of its bytes end its
name. A shard that fails its checksum, cannot be read, or whose columns differ from the
other shards', and every shard holding a run that another shard records with different
values, is set aside in ``<result>.parts/damaged/`` (named in a warning) and its runs are
simulated again: results depend only on the config, so the recomputed file is the same.
"""

from __future__ import annotations

import errno
import hashlib
import io
import json
import os
import shutil
import uuid
import zipfile
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from tumblemc.ncformat import from_labels, write_dataset, write_groups

SHARD_SUFFIX = ".npz"
DIGEST_CHARS = 16  # hex digits of the shard's SHA-256 in its name
LEGACY_TAG_CHARS = 8  # the random tag that ended a shard's name in earlier versions: no checksum to verify


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


def _atomic_write_bytes(path: Path, data: bytes, kept: str) -> None:
    """Write ``data`` to ``path`` through a temporary and a rename; ``kept``: what a full disk leaves (for its message)."""
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")
    try:
        with open(tmp, "xb") as fh:  # O_EXCL: never through a file or link already there
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except OSError as e:
        tmp.unlink(missing_ok=True)
        if e.errno == errno.ENOSPC:
            raise no_space(path.parent, f"to write {path.name}", kept) from None
        raise


def no_space(folder: Path, doing: str, kept: str, free: int | None = None) -> ResultWriteError:
    """The one-line error of a full disk: where, how much is free, what is kept, what to do."""
    free = shutil.disk_usage(folder).free if free is None else free
    return ResultWriteError(
        errno.ENOSPC,
        f"no space left on the disk of {folder} ({_size(free)} free) {doing}; {kept}: free space and run the same command again",
    )


def _size(nbytes: float) -> str:
    """``nbytes`` in B, KiB, MiB or GiB."""
    for unit in ("B", "KiB", "MiB"):
        if nbytes < 1024:
            return f"{nbytes:.0f} {unit}"
        nbytes /= 1024
    return f"{nbytes:.1f} GiB"


def shard_digest(config_hash: str, data: bytes) -> str:
    """The digits that end a shard's name: SHA-256 of the study's config hash and the shard's bytes.

    A shard proves both that it is intact and that it belongs to this study: one copied
    from another study (valid columns, other runs) fails the check like a damaged one.
    """
    return hashlib.sha256(f"tumblemc-shard {config_hash}\n".encode() + data).hexdigest()[:DIGEST_CHARS]


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
        self.n_runs: int | None = None  # runs in the design, once known: a shard with others is set aside

    def open(self, fresh: bool = False) -> int:
        """Create the folder, or check that an existing one belongs to this config (:func:`check_parts_belong`).

        A missing ``study.json`` is written from the config once every shard has proved
        it belongs; returns how many shards did (0 when ``study.json`` was there or the
        folder new).
        """
        meta = self.dir / "study.json"
        if fresh and self.dir.exists():
            shutil.rmtree(self.dir)
        if meta.exists():
            check_parts_belong(self.dir, self.config_hash)
            return 0
        proved = check_parts_belong(self.dir, self.config_hash)
        kept = f"the {proved} finished shards are kept in {self.dir}" if proved else "nothing was run yet"
        try:
            self.dir.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            if e.errno == errno.ENOSPC:
                raise no_space(self.dir.parent, f"to create {self.dir.name}", kept) from None
            raise
        _atomic_write_bytes(
            meta, json.dumps({"config_hash": self.config_hash, "config": json.loads(self.config_json)}, indent=1).encode(), kept
        )
        return proved

    def write(self, kind: str, run: np.ndarray, outcome: dict[str, np.ndarray]) -> Path:
        """Write one finished batch: ``run`` indices and outcome columns (same length).

        The name ends with the checksum of the bytes, so a retried batch (same values)
        replaces its own shard.
        """
        arrays: dict[str, Any] = {"run": np.asarray(run, dtype=np.int64)}
        for k, v in outcome.items():
            arrays[k] = np.asarray(v).astype(str) if np.asarray(v).dtype == object else np.asarray(v)
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        data = buf.getvalue()
        name = f"{kind}-{int(run[0]):09d}-{len(run)}-{shard_digest(self.config_hash, data)}{SHARD_SUFFIX}"
        path = self.dir / name
        _atomic_write_bytes(path, data, f"the runs finished before are kept in {self.dir}")
        return path

    def read(self, kind: str, set_aside: bool = True) -> dict[str, np.ndarray]:
        """All finished runs of ``kind``.

        Concatenated columns sorted by run index, each run once (a shard written twice,
        e.g. by a task that was retried, counts once). Damaged and conflicting shards
        (module docstring) are left out; with ``set_aside`` they are moved to
        ``damaged/``, and :attr:`damaged` lists ``(file, reason)`` either way.
        """
        self.damaged: list[tuple[Path, str]] = []
        if not self.dir.exists():
            return {}
        shards: dict[Path, dict[str, np.ndarray]] = {}
        for path in sorted(self.dir.glob(f"{kind}-*{SHARD_SUFFIX}")):
            data, why = _load_shard(path, self.config_hash)
            if data is not None and self.n_runs is not None and (data["run"].min() < 0 or data["run"].max() >= self.n_runs):
                data, why = None, f"records runs outside the study's design (0 to {self.n_runs - 1})"
            if data is None:
                self.damaged.append((path, why))
            else:
                shards[path] = data
        if shards:  # every shard of a kind has the same columns: the most common set
            common = Counter(frozenset(d) for d in shards.values()).most_common(1)[0][0]
            for path, d in list(shards.items()):
                if frozenset(d) != common:
                    missing, extra = sorted(common - frozenset(d)), sorted(frozenset(d) - common)
                    self.damaged.append((path, f"columns differ from the other shards (missing {missing}, extra {extra})"))
                    del shards[path]
        for path in _conflicting(shards):
            self.damaged.append((path, "records a run that another shard records with different values"))
            del shards[path]
        if set_aside:
            for path, _ in self.damaged:
                (self.dir / "damaged").mkdir(exist_ok=True)
                os.replace(path, self.dir / "damaged" / path.name)
        if not shards:
            return {}
        out = {k: np.concatenate([d[k] for d in shards.values()]) for k in next(iter(shards.values()))}
        _, first = np.unique(out["run"], return_index=True)
        return {k: v[first] for k, v in out.items()}

    def done(self, kind: str) -> np.ndarray:
        """Run indices of ``kind`` already finished (damaged shards set aside)."""
        return self.read(kind).get("run", np.zeros(0, np.int64))

    def require(self, pairs: list[tuple[np.ndarray, dict[str, np.ndarray]]]) -> None:
        """Raise :class:`StudyStateError` if a shard was damaged or a ``(runs wanted, runs read)`` pair misses a run."""
        if self.damaged or any(np.setdiff1d(want, got.get("run", ())).size for want, got in pairs):
            raise StudyStateError(f"{self.dir} does not hold every run after simulating the missing ones; run the same command again")

    def remove(self) -> None:
        """Delete the shard directory and everything in it."""
        shutil.rmtree(self.dir, ignore_errors=True)


def check_parts_belong(folder: Path, config_hash: str) -> int:
    """Raise :class:`StudyStateError` if the shard folder ``folder`` holds runs of another config (nothing is written).

    Its ``study.json`` says which config; without one, every shard must prove by its
    checksum (:func:`shard_digest`) that it belongs to this config. Returns the number of
    shards that proved it (0 when ``study.json`` speaks for them).
    """
    meta = folder / "study.json"
    if not meta.exists():
        shards = sorted(folder.glob(f"*{SHARD_SUFFIX}"))
        alien = [p for p in shards if not _proves(p, config_hash)]
        if alien:
            raise StudyStateError(
                f"{folder} has lost its study.json (the record of the config its runs belong to) and {len(alien)} of its "
                f"{len(shards)} shards do not prove they belong to this config (e.g. {alien[0].name}: another study's, damaged "
                "or of an earlier version); nothing was changed: rerun with --fresh (fresh=True) to discard them, or give another --out"
            )
        return len(shards)
    stored = read_study_json(meta)
    if stored.get("config_hash") != config_hash:
        raise StudyStateError(
            f"{folder} holds runs of a different config (hash {str(stored.get('config_hash', '?'))[:12]}, "
            f"this config {config_hash[:12]}); rerun with --fresh (fresh=True) to discard them, "
            f"or give another --out"
        )
    return 0


def _proves(path: Path, config_hash: str) -> bool:
    """Whether the shard ``path`` carries the checksum of its bytes under ``config_hash``."""
    try:
        return path.stem.rsplit("-", 1)[-1] == shard_digest(config_hash, path.read_bytes())
    except OSError:
        return False


def read_study_json(meta: Path) -> dict[str, Any]:
    """The ``study.json`` of a shard folder; a damaged one raises :class:`StudyStateError` naming it."""
    try:
        stored = json.loads(meta.read_bytes().decode("utf-8"))
        if not isinstance(stored, dict):
            raise ValueError("not a JSON object")
    except (ValueError, UnicodeDecodeError) as e:
        raise StudyStateError(
            f"{meta} is damaged ({e}); it records which config the shards beside it belong to: "
            f"rerun with --fresh (fresh=True) to discard them"
        ) from None
    return stored


def _load_shard(path: Path, config_hash: str) -> tuple[dict[str, np.ndarray] | None, str]:
    """A shard's columns, or ``None`` and why it cannot be used (:func:`shard_digest`)."""
    try:
        raw = path.read_bytes()
    except OSError as e:
        return None, f"cannot be read ({e.strerror})"
    digest = path.stem.rsplit("-", 1)[-1]
    if len(digest) == LEGACY_TAG_CHARS:
        return None, "has the unchecked tag of an earlier version (nothing shows it is intact or of this study)"
    if len(digest) != DIGEST_CHARS or digest != shard_digest(config_hash, raw):
        if digest == hashlib.sha256(raw).hexdigest()[:DIGEST_CHARS]:
            return None, "was written by an earlier version (its checksum does not cover the study's config hash)"
        return (
            None,
            "fails its checksum (the name's SHA-256 digits over the study's config hash and the shard): damaged, or of another study",
        )
    try:
        with np.load(io.BytesIO(raw), allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, KeyError) as e:
        return None, f"cannot be decoded ({type(e).__name__}: {e})"
    run = data.get("run")
    if run is None or run.ndim != 1 or run.dtype.kind != "i":
        return None, "has no integer run column"
    bad = [k for k, v in data.items() if v.ndim == 0 or len(v) != len(run)]
    if bad:
        return None, f"columns {bad} do not match its {len(run)} runs"
    return data, ""


def _conflicting(shards: dict[Path, dict[str, np.ndarray]]) -> list[Path]:
    """Shards that record a run with values that differ from another shard's record of it."""
    first: dict[int, tuple[Path, int]] = {}
    bad: set[Path] = set()
    for path, d in shards.items():
        for j, r in enumerate(d["run"].tolist()):
            if r not in first:
                first[r] = (path, j)
                continue
            p0, j0 = first[r]
            if any(not _same(shards[p0][k][j0], d[k][j]) for k in d):
                bad.update((p0, path))
    return sorted(bad)


def _same(a: Any, b: Any) -> bool:
    return bool(np.array_equal(np.asarray(a), np.asarray(b), equal_nan=np.asarray(a).dtype.kind in "fc"))


class ResultWriteError(OSError):
    """The final netCDF file could not be written (full disk, say); the shards are kept."""

    def __str__(self) -> str:
        return str(self.args[-1])


def remove_stale_temps(path: Path) -> list[Path]:
    """Delete temporary files an interrupted final write left next to ``path`` (call under :class:`StudyLock`)."""
    stale = sorted(Path(path).parent.glob(f".{Path(path).name}.*.tmp"))
    for t in stale:
        t.unlink(missing_ok=True)
    return stale


def write_result(path: Path, runs: xr.Dataset, maps: xr.Dataset, root_attrs: dict[str, Any]) -> None:
    """Write ``runs`` and ``maps`` as groups of one netCDF4 file (zlib), atomically.

    Plain xarray reads it (``xr.open_dataset(path, group="maps").sel(shape="cuboid")``),
    and so does any netCDF-4 reader: :mod:`tumblemc.ncformat` says how. A failure leaves
    no temporary file behind; a full disk raises :class:`ResultWriteError` saying so
    (netCDF reports it as an ``HDF error``).
    """
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")
    try:
        write_groups(tmp, root_attrs, {"runs": runs, "maps": maps})
        with open(tmp, "rb") as fh:  # on disk before the shards it replaces are removed
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except (OSError, RuntimeError) as e:
        # the space free once the partial file is gone: netCDF may hold it open after a failed close
        # (its blocks then return only when this process ends), so count them rather than measure after the unlink
        free = shutil.disk_usage(path.parent).free + _allocated(tmp)
        tmp.unlink(missing_ok=True)
        need = runs.nbytes + maps.nbytes
        full = getattr(e, "errno", None) == errno.ENOSPC or ("HDF error" in str(e) and free < max(2 * need, 64 * 2**20))
        what = f"no space left on the disk of {path.parent} ({_size(free)} free)" if full else str(e)
        raise ResultWriteError(
            errno.ENOSPC if full else getattr(e, "errno", None) or errno.EIO,
            f"cannot write {path}: {what}. The finished runs are kept in {parts_dir(path)}; run the same command again to write the file",
        ) from e
    _fsync_dir(path.parent)


def _allocated(path: Path) -> int:
    """Bytes the file ``path`` occupies on its disk (0 if it is not there)."""
    try:
        st = os.stat(path)
    except OSError:
        return 0
    return int(getattr(st, "st_blocks", 0) * 512) or st.st_size


def open_result(path: str | Path) -> tuple[xr.Dataset, xr.Dataset]:
    """Open a study file: ``(runs, maps)`` datasets, loaded into memory.

    The same as ``xr.open_dataset(path, group=...)`` with strings as numpy ``str``; files
    written before the labels took their dimensions' names (``shape_label``) get their
    index back (:func:`tumblemc.ncformat.from_labels`).
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path} does not exist (a study result written by `tumblemc study run`)")
    with xr.open_dataset(path, group="runs", engine="netcdf4") as r, xr.open_dataset(path, group="maps", engine="netcdf4") as m:
        return from_labels(r.load()), from_labels(m.load())


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

    Its attributes are made netCDF-safe first (:func:`netcdf_ready`), its strings written as
    :mod:`tumblemc.ncformat` says.
    """
    write_dataset(netcdf_ready(ds), path)


__all__ = [
    "ResultWriteError",
    "ShardStore",
    "StudyStateError",
    "netcdf_ready",
    "open_result",
    "parts_dir",
    "check_parts_belong",
    "read_study_json",
    "remove_stale_temps",
    "result_attrs",
    "write_result",
    "write_run",
]
