"""Many runs: a study's design executed in batches, in-process or on a dask cluster.

:func:`run_study` turns a study config (:mod:`tumblemc.study.config`) into runs, groups them
into batches (one dask task each, a second or so of work), streams every finished batch
to a crash-safe shard (:mod:`tumblemc.io`), and assembles the ``runs`` and ``maps`` groups
of one netCDF file. ``client=None`` runs the batches in this process; a
``dask.distributed.Client`` runs them on its cluster (local processes or a job queue).

Guarantees
----------
- Results depend only on the config: a run's parameters come from the root seed and the
  run's identity, each run is simulated alone, and outcomes are stored by run index, so
  worker count, batch size and completion order change nothing (tests check bit-identity).
- Nothing finished is lost: an interrupted study (Ctrl-C, ``kill -9``, a lost worker)
  keeps its shards; the same call again runs only the missing runs. A changed config is
  refused unless ``fresh=True``.
- A run that fails (invalid sampled parameters, non-converged steps, a non-finite state)
  is recorded with its ``status``; it never stops the study.
- Numerical error is measured: a deterministic subset of runs (``[check]``: 2%, at least
  20) is re-simulated at ``dt / dt_factor`` and the agreement is stored in the file.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import json
import math
import os
import signal
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple, cast

import numpy as np
import xarray as xr

from tumblemc.analysis.critical import expand_to_grid
from tumblemc.analysis.maps import check_words
from tumblemc.analysis.maps import maps as make_maps
from tumblemc.io import ShardStore, StudyStateError, open_result, parts_dir, result_attrs, write_result
from tumblemc.model.rows import RunRow, TimeGrid, simulate_rows
from tumblemc.schema import CHECK_COLUMNS, CRITICAL_OUTCOMES, OUTCOMES, sampled_name
from tumblemc.study.assemble import assemble_critical, assemble_runs, provenance
from tumblemc.study.config import StudyConfig, config_hash, config_to_json, load_config
from tumblemc.study.critical import bisect_rows, monotonicity_rows
from tumblemc.study.design import batch_row, check_inclines, check_subset, design, grid_of


class StudyResult(NamedTuple):
    """What :func:`run_study` returns: the two groups of the file and its path."""

    runs: xr.Dataset
    maps: xr.Dataset
    path: Path


@dataclass(frozen=True)
class Task:
    """One batch: runs of one shape on one time grid (a dask task)."""

    kind: str  # "main" or "check"
    key: str
    shape: str
    run: tuple[int, ...]
    rows: tuple[RunRow, ...]
    grid: TimeGrid
    mode: str = "grid"
    # critical_incline mode: incline range and tolerance, check grid, fine time grid
    lo: float = 0.0
    hi: float = 0.0
    tol: float = 0.0
    inclines: tuple[float, ...] = ()
    fine: TimeGrid | None = None


def execute_task(task: Task) -> tuple[str, np.ndarray, dict[str, np.ndarray]]:
    """Run one batch (the function every dask task calls).

    A batch that raises is rerun row by row; a row that still raises is recorded with status
    ``error`` and the message, so one bad run never stops a study.
    """
    try:
        return _execute_task(task)
    except Exception:  # noqa: BLE001 - any failure of a run is data, not a crash
        if len(task.run) == 1:
            return _error_result(task)
        parts = [execute_task(dataclasses.replace(task, run=(r,), rows=(row,))) for r, row in zip(task.run, task.rows, strict=True)]
        return task.kind, np.asarray(task.run, dtype=np.int64), {k: np.concatenate([p[2][k] for p in parts]) for k in parts[0][2]}


def _error_result(task: Task) -> tuple[str, np.ndarray, dict[str, np.ndarray]]:
    import traceback

    msg = traceback.format_exc(limit=2).strip().splitlines()[-1]
    cols = CRITICAL_OUTCOMES if (task.mode != "grid" and task.kind == "main") else OUTCOMES
    out: dict[str, np.ndarray] = {}
    for k, dt in cols.items():
        out[k] = np.full(1, np.nan) if np.dtype(dt).kind == "f" else np.zeros(1, dt)
    out["status"][:] = 3
    out["error"] = np.array([f"internal error: {msg}"], dtype=object)
    if task.mode != "grid" and task.kind == "check":  # the check columns of a critical study
        out = {
            k: np.full((1, len(task.inclines) if width == "grid" else 2), fill, dtype) for k, (dtype, width, fill) in CHECK_COLUMNS.items()
        }
    return task.kind, np.asarray(task.run, dtype=np.int64), out


def _execute_task(task: Task) -> tuple[str, np.ndarray, dict[str, np.ndarray]]:
    run = np.asarray(task.run, dtype=np.int64)
    if task.mode == "grid":
        return task.kind, run, simulate_rows(task.shape, task.rows, task.grid)
    if task.kind == "main":
        return task.kind, run, bisect_rows(task.shape, task.rows, task.grid, task.lo, task.hi, task.tol)
    return task.kind, run, _critical_check(task)


def _critical_check(task: Task) -> dict[str, np.ndarray]:
    """Check runs of a critical-incline study.

    Verdicts at every grid incline (the monotonicity check) and, at the two grid inclines
    around the first failure, the verdicts at the finer dt (the numerical check).
    """
    th = np.asarray(task.inclines, dtype=float)
    mono = monotonicity_rows(task.shape, task.rows, task.grid, th)
    n = len(task.rows)
    # th is sorted (plan): the pair is the last climbing and the first failing grid incline
    ij = np.zeros((n, 2), np.int64)
    for i in range(n):
        fails = np.flatnonzero(mono["climbed"][i] == 0)
        k = int(fails[0]) if len(fails) else len(th) - 1
        ij[i] = (max(k - 1, 0), k)
    pair = th[ij]
    assert task.fine is not None
    fine = simulate_rows(
        task.shape, [cast(RunRow, dict(r, incline_deg=float(t))) for r, p in zip(task.rows, pair, strict=True) for t in p], task.fine
    )
    rows_i = np.arange(n)[:, None]
    return {
        "grid_climbed": mono["climbed"],
        "grid_status": mono["status"],
        "pair_incline": pair,
        "pair_climbed": mono["climbed"][rows_i, ij].astype(np.int8),
        "pair_status": mono["status"][rows_i, ij].astype(np.int8),
        "pair_climbed_fine": fine["climbed"].reshape(n, 2),
        "pair_status_fine": fine["status"].reshape(n, 2),
    }


def design_rows(cfg: StudyConfig, des: xr.Dataset, idx: Sequence[int] | np.ndarray) -> list[RunRow]:
    """:func:`tumblemc.study.design.batch_row` of runs ``idx`` (columns read once, not per run)."""
    names = ["substrate", "incline_deg", "field_mT", "freq_hz", *(sampled_name(k) for k in cfg.uncertain_names)]
    cols = {k: des[k].values for k in names if k in des.variables}
    return [batch_row(cfg, {k: v[i] for k, v in cols.items()}) for i in idx]


def plan(cfg: StudyConfig, des: xr.Dataset, kind: str, todo: np.ndarray, batch_size: int, chash: str) -> list[Task]:
    """Batches of the runs ``todo``: runs of one cell (one shape and time grid) together."""
    grid = grid_of(cfg, fine=(kind == "check" and cfg.mode == "grid"))
    fine = grid_of(cfg, fine=True)
    inclines = check_inclines(cfg)
    shapes = des["shape"].values
    cellkey = des["cell_key"].values
    tasks = []
    todo = np.sort(np.asarray(todo, dtype=np.int64))
    start = 0
    while start < len(todo):
        # a batch never spans two cells (different shapes or time grids)
        stop = start + 1
        while stop < len(todo) and stop - start < batch_size and cellkey[todo[stop]] == cellkey[todo[start]]:
            stop += 1
        idx = todo[start:stop]
        key = f"tumblemc-{kind}-{chash[:10]}-{int(idx[0]):09d}-{len(idx)}"
        rows = tuple(design_rows(cfg, des, idx))
        if cfg.mode == "grid":
            tasks.append(Task(kind, key, str(shapes[idx[0]]), tuple(int(i) for i in idx), rows, grid))
        else:
            lo, hi = cfg.incline_range
            tasks.append(
                Task(
                    kind,
                    key,
                    str(shapes[idx[0]]),
                    tuple(int(i) for i in idx),
                    rows,
                    grid,
                    cfg.mode,
                    lo,
                    hi,
                    cfg.incline_tol,
                    inclines,
                    fine,
                )
            )
        start = stop
    return tasks


class Progress:
    """A text progress bar on stderr: runs done, runs/s and ETA (no dependency)."""

    def __init__(self, total: int, done: int = 0, enabled: bool = True, stream: Any = None) -> None:
        self.total, self.done, self.enabled = total, done, enabled
        self.start_done = done
        self.stream = stream or sys.stderr
        self.t0 = time.perf_counter()
        self.last = 0.0
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())

    def update(self, n: int) -> None:
        """Count ``n`` more runs done and redraw (at most every 0.2 s on a terminal, 10 s otherwise)."""
        self.done += n
        now = time.perf_counter()
        if self.enabled and (now - self.last > (0.2 if self.tty else 10.0) or self.done >= self.total):
            self.last = now
            rate = (self.done - self.start_done) / max(now - self.t0, 1e-9)
            eta = (self.total - self.done) / rate if rate > 0 else math.inf
            width = 30
            fill = int(width * self.done / max(self.total, 1))
            eta_s = "--" if not math.isfinite(eta) else str(_dt.timedelta(seconds=round(eta)))
            line = f"[{'#' * fill}{'.' * (width - fill)}] {self.done}/{self.total} runs  {rate:.2f} runs/s  ETA {eta_s}"
            print(("\r" if self.tty else "") + line, end="" if self.tty else "\n", file=self.stream, flush=True)

    def close(self) -> None:
        """End the bar's line on a terminal."""
        if self.enabled and self.tty:
            print(file=self.stream, flush=True)


def _execute(
    tasks: Sequence[Task], client: Any, on_result: Callable[[str, np.ndarray, dict[str, np.ndarray]], None], max_in_flight: int
) -> None:
    if client is None:
        for t in tasks:
            on_result(*execute_task(t))
        return
    from distributed import as_completed

    it: Iterator[Task] = iter(tasks)
    ac = as_completed()
    submitted = []
    try:
        for t in it:
            fut = client.submit(execute_task, t, key=t.key, retries=3, pure=False)
            submitted.append(fut)
            ac.add(fut)
            if ac.count() >= max_in_flight:
                break
        for fut in ac:
            on_result(*fut.result())
            fut.release()
            nxt = next(it, None)
            if nxt is not None:
                f2 = client.submit(execute_task, nxt, key=nxt.key, retries=3, pure=False)
                submitted.append(f2)
                ac.add(f2)
    except BaseException:
        client.cancel([f for f in submitted if not f.done()])
        raise


def default_output(cfg: StudyConfig) -> Path:
    """Default result path of a study: ``results/<name>.nc``."""
    return Path("results") / f"{cfg.name}.nc"


def run_study(
    config: str | os.PathLike[str] | StudyConfig | dict[str, Any],
    client: Any = None,
    *,
    out: str | os.PathLike[str] | None = None,
    fresh: bool = False,
    progress: bool = True,
    batch_size: int | None = None,
    max_in_flight: int | None = None,
) -> StudyResult:
    """Run a study (or its missing runs) and write its netCDF file.

    Parameters
    ----------
    config : path, dict or StudyConfig
        The study (:func:`tumblemc.study.config.load_config`).
    client : dask.distributed.Client, optional
        Where to run the batches; ``None`` runs them in this process.
    out : path, optional
        Result file; default ``results/<study name>.nc``.
    fresh : bool
        Discard the shards (and result) of an earlier run instead of resuming; required
        when the config changed.
    progress : bool
        Show a progress bar on stderr.
    batch_size, max_in_flight : int, optional
        Runs per task and tasks submitted at once (default: the config's ``[execution]``).

    Returns
    -------
    StudyResult
        ``runs`` and ``maps`` datasets (as in the file) and the file's path.
    """
    cfg = config if isinstance(config, StudyConfig) else load_config(config)
    path = Path(out) if out is not None else default_output(cfg)
    cjson, chash = config_to_json(cfg), config_hash(cfg)
    if path.exists() and not fresh:
        stored = result_attrs(path).get("config_hash")
        if stored == chash:
            runs, maps = open_result(path)
            if progress:
                print(f"{path} is complete ({runs.sizes['run']} runs); nothing to do", file=sys.stderr)
            return StudyResult(runs, maps, path)
        if _parts_hash(path) != chash:  # an interrupted run of this config may replace it
            raise StudyStateError(
                f"{path} holds a study with a different config (hash {str(stored)[:12]}, this config {chash[:12]}); "
                "use --fresh (fresh=True) to replace it, or another --out"
            )
    path.parent.mkdir(parents=True, exist_ok=True)
    store = ShardStore(path, cjson, chash)
    store.open(fresh=fresh)

    des = design(cfg)
    n = des.sizes["run"]
    check_idx = check_subset(des)
    bs = int(batch_size or cfg.execution.batch_size)
    if client is not None and not (max_in_flight or cfg.execution.max_in_flight):
        client.wait_for_workers(1)  # a cluster that is still starting has no workers yet
    mif = int(max_in_flight or cfg.execution.max_in_flight or (4 * _n_workers(client) if client is not None else 1))
    todo_main = np.setdiff1d(np.arange(n), store.done("main"))
    todo_check = np.setdiff1d(check_idx, store.done("check"))
    tasks = plan(cfg, des, "main", todo_main, bs, chash) + plan(cfg, des, "check", todo_check, bs, chash)
    total = n + len(check_idx)
    bar = Progress(total, total - len(todo_main) - len(todo_check), enabled=progress)
    if progress and len(todo_main) < n:
        print(f"resuming {cfg.name}: {n - len(todo_main)} of {n} runs already done", file=sys.stderr)

    def on_result(kind: str, run: np.ndarray, outcome: dict[str, np.ndarray]) -> None:
        store.write(kind, run, outcome)
        bar.update(len(run))

    try:
        _execute(tasks, client, on_result, mif)
    finally:
        bar.close()
    if cfg.mode == "grid":
        runs = assemble_runs(cfg, des, store.read("main"), check_idx, store.read("check"))
        maps = make_maps(runs, level=cfg.ci_level, method=cfg.ci)
    else:
        runs = assemble_critical(cfg, des, store.read("main"), check_idx, store.read("check"))
        lo, hi = cfg.incline_range
        curve = np.round(np.arange(lo, hi + 0.5 * cfg.incline_tol, cfg.incline_tol), 10)
        maps = make_maps(expand_to_grid(runs, curve), level=cfg.ci_level, method=cfg.ci)
        maps.attrs["p_success_definition"] = "fraction of valid samples whose critical incline is at least incline_deg"
    attrs = provenance(cfg, cjson, chash)
    maps.attrs.update(attrs)
    runs.attrs.update(attrs)
    write_result(path, runs, maps, attrs)
    store.remove()
    return StudyResult(runs, maps, path)


def _parts_hash(path: Path) -> str | None:
    """Config hash of the shard folder of ``path``, if there is one."""
    meta = parts_dir(path) / "study.json"
    try:
        return str(json.loads(meta.read_text())["config_hash"])
    except (OSError, ValueError, KeyError):
        return None


def _n_workers(client: Any) -> int:
    info = getattr(client, "scheduler_info", None)
    if info is None:  # pragma: no cover - a client-like object without that call
        return 1
    return max(1, len(info().get("workers", {})))


def study_status(config_or_result: str | os.PathLike[str], out: str | os.PathLike[str] | None = None) -> dict[str, Any]:
    """How far a study got, from its config (and the default or given result path) or from a result file.

    Keys: ``state`` ("not started", "partial", "complete"), ``done``, ``total``, ``failed``
    and, when complete, the check summary.
    """
    p = Path(config_or_result)
    if p.suffix == ".nc":
        runs, _ = open_result(p)
        return _complete_status(runs, p)
    cfg = load_config(p)
    path = Path(out) if out is not None else default_output(cfg)
    if path.exists():
        runs, _ = open_result(path)
        return _complete_status(runs, path)
    des = design(cfg)
    n = des.sizes["run"]
    nc = len(check_subset(des))
    store = ShardStore(path, config_to_json(cfg), config_hash(cfg))
    main = store.read("main")
    done = len(main.get("run", ()))
    failed = int(np.count_nonzero(main["status"] != 0)) if done else 0
    return {
        "state": "partial" if done or store.dir.exists() else "not started",
        "path": str(path),
        "done": done,
        "total": n,
        "check_done": len(store.done("check")),
        "check_total": nc,
        "failed": failed,
    }


def _complete_status(runs: xr.Dataset, path: Path) -> dict[str, Any]:
    st = runs["status"].values
    out: dict[str, Any] = {
        "state": "complete",
        "path": str(path),
        "done": int(runs.sizes["run"]),
        "total": int(runs.sizes["run"]),
        "failed": int(np.count_nonzero(st != 0)),
    }
    for k in ("check_agreement_rate", "check_not_compared", "check_median_abs_ratio_diff", "check_max_abs_ratio_diff", "check_dt_factor"):
        if k in runs.attrs:
            out[k] = runs.attrs[k]
    if "check_run" in runs:
        out["check_total"] = out["check_done"] = int(runs.sizes["check"])
    words = check_words(runs, str(path))
    if words:
        out["dt_check"] = words
    return out


def warm_kernels() -> float:
    """Compile (or load from the Numba cache) every kernel a study uses, in this process.

    Workers started afterwards load them from the cache instead of compiling each.
    """
    t0 = time.perf_counter()
    simulate_rows("cuboid", [{"preset": "paper", "freq_hz": 1000.0}], TimeGrid(periods=2.0))
    return time.perf_counter() - t0


def local_client(workers: int | None = None) -> Any:
    """A ``dask.distributed`` client on an embedded LocalCluster.

    One process per worker, one thread each (the kernels are single-threaded; processes
    avoid any GIL contention in the Python layer), Numba's cache warmed in this process
    first.
    """
    from distributed import Client, LocalCluster

    for var in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    warm_kernels()
    n = int(workers or os.cpu_count() or 1)
    # worker processes inherit an ignored SIGINT: Ctrl-C reaches only this process, which
    # keeps the finished shards and shuts the cluster down (no traceback from each worker)
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=50)
    finally:
        signal.signal(signal.SIGINT, previous)
    return Client(cluster)
