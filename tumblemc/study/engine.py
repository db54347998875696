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
import os
import sys
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import xarray as xr

from tumblemc.analysis.critical import expand_to_grid
from tumblemc.analysis.maps import maps as make_maps
from tumblemc.io import (
    ShardStore,
    StudyStateError,
    open_result,
    parts_dir,
    read_study_json,
    remove_stale_temps,
    result_attrs,
    write_result,
)
from tumblemc.study.adaptive import AdaptiveResult, adaptive_attrs, restrict, run_adaptive, schedule, threshold_verdicts
from tumblemc.study.assemble import assemble_critical, assemble_runs, provenance
from tumblemc.study.cluster import local_client, n_workers, warm_kernels  # noqa: F401  (re-exported)
from tumblemc.study.config import StudyConfig, load_config
from tumblemc.study.design import check_inclines, check_mask, check_subset, design, grid_of, n_check_runs
from tumblemc.study.faults import StudyAbortedError, finish, kept_words, lost_task, tidy_finished
from tumblemc.study.identity import config_hash, config_to_json
from tumblemc.study.lock import ReadOnlyOutputError, StudyLock
from tumblemc.study.progress import Progress
from tumblemc.study.status import default_output, study_status  # noqa: F401  (study_status re-exported)
from tumblemc.study.tasks import Task, design_rows, execute_task, one_run_tasks  # noqa: F401  (re-exported)
from tumblemc.study.threshold import difficulty_order, direct_passes, pilot_priors, sample_rows
from tumblemc.study.threshold_file import assemble_threshold, threshold_maps
from tumblemc.study.twins import TWIN_KINDS, outside_tol, twin_row, with_twins


class StudyResult(NamedTuple):
    """What :func:`run_study` returns: the two groups of the file and its path."""

    runs: xr.Dataset
    maps: xr.Dataset
    path: Path


def plan(
    cfg: StudyConfig,
    des: xr.Dataset,
    kind: str,
    todo: np.ndarray,
    batch_size: int,
    chash: str,
    priors: dict[str, tuple[float, ...]] | None = None,
) -> list[Task]:
    """Batches of the runs ``todo``: runs of one cell (one shape and time grid) together.

    ``kind``: "main", "check" (at the finer dt) or one of :data:`TWIN_KINDS` (grid mode:
    the magnetisation changed, simulated to the end). ``priors``: threshold mode, the
    prior of each cell's searches (by cell key; absent: plain bisection).
    """
    grid = grid_of(cfg, fine=(kind == "check" and cfg.mode == "grid"))
    fine = grid_of(cfg, fine=True)
    inclines = check_inclines(cfg)
    shapes = des["shape"].values
    cellkey = des["cell_key"].values
    checked = des["check_flag"].values.astype(bool)  # adaptive: the full design's subset (see assemble_runs)
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
        base = Task(kind, key, str(shapes[idx[0]]), tuple(int(i) for i in idx), (), grid)  # what every mode's task has
        if cfg.mode == "threshold":  # a batch is one cell: one prior
            arows = tuple(sample_rows(cfg, des, idx))
            prior = (priors or {}).get(str(cellkey[idx[0]]), ())
            tasks.append(dataclasses.replace(base, mode=cfg.mode, fine=fine, axis_rows=arows, prior=prior, cfg=cfg))
        else:
            rows = tuple(design_rows(cfg, des, idx))
            if kind in TWIN_KINDS:
                rows = tuple(twin_row(r, TWIN_KINDS[kind], cfg.check.twin_rel) for r in rows)
            if cfg.mode == "grid":
                full = tuple(bool(f) or kind in TWIN_KINDS for f in checked[idx]) if grid.early_decision else ()
                tasks.append(dataclasses.replace(base, rows=rows, full=full))
            else:
                lo, hi = cfg.incline_range
                tasks.append(
                    dataclasses.replace(base, rows=rows, mode=cfg.mode, lo=lo, hi=hi, tol=cfg.incline_tol, inclines=inclines, fine=fine)
                )
        start = stop
    return tasks


#: the last ``TAIL_PER_WORKER x workers`` tasks of a batch of work go run by run (see :func:`balance`)
TAIL_PER_WORKER = 2


def balance(tasks: list[Task], workers: int, cost: Callable[[Task], float] | None = None) -> list[Task]:
    """The order in which to hand ``tasks`` to ``workers``: dearest first, the tail run by run.

    Work that is waited for as a whole (an adaptive round, a study's last tasks) ends when
    its slowest worker ends. Longest-processing-time-first order (Graham 1969) puts the
    tasks expected to cost most (``cost``; stable, so equal costs keep the design order)
    first, and the last ``TAIL_PER_WORKER x workers`` tasks are split into one-run tasks, so
    the workers finish within about one run of each other instead of one batch. Results do
    not depend on it: every run's arithmetic is its own (run-keyed draws, no batch-mates).
    One worker (or none: this process) keeps the tasks as planned.
    """
    if workers <= 1:
        return tasks
    if cost is not None:
        tasks = sorted(tasks, key=cost, reverse=True)
    cut = max(len(tasks) - TAIL_PER_WORKER * workers, 0)
    tail = []
    for t in tasks[cut:]:
        tail += one_run_tasks(t) if len(t.run) > 1 else [t]
    return tasks[:cut] + tail


def cell_cost(main: dict[str, np.ndarray], samples: int) -> Callable[[Task], float]:
    """A task's expected cost from the finished runs of its cell (adaptive rounds).

    Runs x the cell's mean Newton iterations per step over its finished runs (a batch never
    spans two cells, :func:`plan`): 1.8 for the paper cuboid at 45 deg, 5.0 for the curved
    robot sliding on aluminum at 35 deg, whose steps also cost more. Cells with no finished
    run cost 0 (design order among themselves, after the known ones).
    """
    runs = np.asarray(main.get("run", np.zeros(0, np.int64)), dtype=np.int64)
    its = np.asarray(main.get("newton_iterations", np.zeros(0)), dtype=np.float64)
    ok = np.isfinite(its)
    cells = runs[ok] // samples
    tot = np.bincount(cells, weights=its[ok]) if cells.size else np.zeros(0)
    cnt = np.bincount(cells) if cells.size else np.zeros(0, np.int64)
    mean = np.divide(tot, cnt, out=np.zeros(tot.shape), where=cnt > 0)

    def cost(task: Task) -> float:
        c = task.run[0] // samples
        return float(len(task.run) * mean[c]) if c < mean.size else 0.0

    return cost


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
            try:
                result = fut.result()
            except Exception as e:  # the cluster lost the task (its workers died, say): said in words by run_study
                raise lost_task(next(t for t in tasks if t.key == fut.key), e) from e
            on_result(*result)
            fut.release()
            nxt = next(it, None)
            if nxt is not None:
                f2 = client.submit(execute_task, nxt, key=nxt.key, retries=3, pure=False)
                submitted.append(f2)
                ac.add(f2)
    except BaseException:
        client.cancel([f for f in submitted if not f.done()])
        raise


def run_study(
    config: str | os.PathLike[str] | StudyConfig | dict[str, Any],
    client: Any = None,
    *,
    out: str | os.PathLike[str] | None = None,
    fresh: bool = False,
    progress: bool = True,
    batch_size: int | None = None,
    max_in_flight: int | None = None,
    lock: bool = True,
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
    lock : bool
        Hold :class:`tumblemc.study.lock.StudyLock` on the output while running (False: the caller
        holds it, as ``tumblemc study run`` does from before it compiles anything).

    Returns
    -------
    StudyResult
        ``runs`` and ``maps`` datasets (as in the file) and the file's path.
    """
    cfg = config if isinstance(config, StudyConfig) else load_config(config)
    path = Path(out) if out is not None else default_output(cfg)
    path.parent.mkdir(parents=True, exist_ok=True)
    if not lock:  # the caller holds StudyLock(path)
        return _run_locked(cfg, client, path, fresh, progress, batch_size, max_in_flight)
    try:
        with StudyLock(path):  # a second `study run` on the same output is refused, not joined
            return _run_locked(cfg, client, path, fresh, progress, batch_size, max_in_flight)
    except ReadOnlyOutputError:
        done = None if fresh else complete(cfg, path, progress)
        if done is None:
            raise
        return done


def complete(cfg: StudyConfig, path: Path, progress: bool = True) -> StudyResult | None:
    """The result at ``path`` if it is a complete study of ``cfg`` (said on stderr), else None; writes nothing.

    This is what ``study run`` reports for a finished study, read-only media included.
    """
    if not path.exists() or result_attrs(path).get("config_hash") != config_hash(cfg):
        return None
    runs, maps = open_result(path)
    _say(progress, f"{path} is complete ({runs.sizes['run']} runs); nothing to do")
    return StudyResult(runs, maps, path)


def _run_locked(  # noqa: C901
    cfg: StudyConfig, client: Any, path: Path, fresh: bool, progress: bool, batch_size: int | None, max_in_flight: int | None
) -> StudyResult:
    cjson, chash = config_to_json(cfg), config_hash(cfg)
    for t in remove_stale_temps(path):
        _say(progress, f"removed {t.name}, left by an interrupted final write")
    if path.exists() and not fresh:
        done = complete(cfg, path, progress)
        if done is not None:
            tidy_finished(path, chash, lambda m: _say(progress, m))
            return done
        stored = result_attrs(path).get("config_hash")
        if _parts_hash(path) != chash:  # an interrupted run of this config may replace it
            raise StudyStateError(
                f"{path} holds a study with a different config (hash {str(stored)[:12]}, this config {chash[:12]}); "
                "use --fresh (fresh=True) to replace it, or another --out"
            )
    store = ShardStore(path, cjson, chash)
    if store.open(fresh=fresh):
        _say(progress, f"{store.dir}/study.json was missing: written again from the config (every shard carries its hash)")

    des = design(cfg)
    n = des.sizes["run"]
    store.n_runs = n  # a shard with runs outside the design is set aside, named
    adaptive = cfg.precision is not None
    check_idx = np.zeros(0, np.int64) if adaptive else check_subset(des)
    bs = int(batch_size or cfg.execution.batch_size)
    if client is not None and not (max_in_flight or cfg.execution.max_in_flight):
        client.wait_for_workers(1)  # a cluster that is still starting has no workers yet
    mif = int(max_in_flight or cfg.execution.max_in_flight or (4 * n_workers(client) if client is not None else 1))
    done_main, done_check = _done(store, "main", progress), _done(store, "check", progress)
    todo_main = np.setdiff1d(np.arange(n), done_main)
    todo_check = np.setdiff1d(check_idx, done_check)
    if len(done_main):
        _say(progress, f"resuming {cfg.name}: {len(done_main)} of {'up to ' if adaptive else ''}{n} runs already done")
    total = n + (n_check_runs(cfg, n) if adaptive else len(check_idx))
    bar = Progress(total, len(done_main) + len(done_check) if adaptive else total - len(todo_main) - len(todo_check), enabled=progress)

    def on_result(kind: str, run: np.ndarray, outcome: dict[str, np.ndarray]) -> None:
        store.write(kind, run, outcome)
        bar.update(len(run))

    def slots() -> int:  # asked per batch of work: a cluster may still be starting or scaling
        return n_workers(client) if client is not None else 1

    priors: dict[str, tuple[float, ...]] | None = None  # threshold mode: the searches' priors (from the audit's sweeps)

    def simulate(kind: str, idx: np.ndarray) -> None:  # an adaptive round, or its check runs: waited for as a whole
        tasks = plan(cfg, des, kind, idx, bs, chash, priors if kind == "main" else None)
        workers = slots()
        cost = cell_cost(_read(store, "main"), cfg.samples) if kind == "main" and workers > 1 else None
        _execute(balance(tasks, workers, cost), client, on_result, mif)

    used = np.arange(n)
    kept: AdaptiveResult | None = None
    try:
        if adaptive:  # rounds until every cell is known to the precision; then the dt check of the runs kept
            if cfg.mode == "threshold":  # the pilot: the audit samples among the first round's
                first = schedule(cfg)[0]
                pilot = check_subset(des)[des["sample"].values[check_subset(des)] < first]
                simulate("check", np.setdiff1d(pilot, _done(store, "check", progress)))
                priors = search_priors(cfg, des, store)
            kept = run_adaptive(
                cfg,
                n,
                lambda: _read(store, "main"),
                lambda idx: simulate("main", idx),
                lambda m: bar.expect(m + n_check_runs(cfg, m)),
                lambda again: bar.update(-again),  # runs counted once whose shards were set aside
                threshold_verdicts(difficulty_order(cfg)) if cfg.mode == "threshold" else None,
            )
            used = kept.used
            check_idx = used[check_mask(cfg, des["run_key"].values[used])]
            bar.expect(kept.simulated + len(check_idx))
            simulate("check", np.setdiff1d(check_idx, _done(store, "check", progress)))
        elif cfg.mode == "threshold":
            # the audit's sweeps first: they are the pilot that starts each cell's searches
            _execute(balance(plan(cfg, des, "check", todo_check, bs, chash), slots()), client, on_result, mif)
            priors = search_priors(cfg, des, store)
            _execute(balance(plan(cfg, des, "main", todo_main, bs, chash, priors), slots()), client, on_result, mif)
        else:
            # the check runs (at dt / dt_factor) last, as the progress bar's rate expects; their
            # last batches run by run
            tasks = plan(cfg, des, "main", todo_main, bs, chash) + plan(cfg, des, "check", todo_check, bs, chash)
            _execute(balance(tasks, slots()), client, on_result, mif)
        for _ in range(2):  # shards set aside once the new ones are in (an older schema): their runs again
            redo_main = np.setdiff1d(used, _done(store, "main", progress))
            redo_check = np.setdiff1d(check_idx, _done(store, "check", progress))
            if not (len(redo_main) or len(redo_check)):
                break
            bar.update(-(len(redo_main) + len(redo_check)))
            _execute(plan(cfg, des, "check", redo_check, bs, chash), client, on_result, mif)
            again = search_priors(cfg, des, store) if cfg.mode == "threshold" else None
            _execute(plan(cfg, des, "main", redo_main, bs, chash, again), client, on_result, mif)
        main, check = store.read("main", set_aside=False), store.read("check", set_aside=False)  # read once: twins add their own kinds
        store.require([(used, main), (check_idx, check)])
        twin_idx = outside_tol(cfg, main, check, check_idx)
        todo_twin = {k: np.setdiff1d(twin_idx, _done(store, k, progress)) for k in TWIN_KINDS}
        bar.expect(int(bar.bar.total or 0) + sum(len(t) for t in todo_twin.values()))
        _execute([t for k, idx in todo_twin.items() for t in plan(cfg, des, k, idx, bs, chash)], client, on_result, mif)
    except StudyAbortedError as e:
        raise StudyAbortedError(
            f"{e}; {kept_words(path, chash)}: run the same command again to resume (if the workers die again: fewer "
            "--workers or more memory per worker, and the workers' logs)"
        ) from e.__cause__
    finally:
        bar.close()
    twins = {k: store.read(k, set_aside=False) for k in TWIN_KINDS} if len(twin_idx) else {}
    store.require([(twin_idx, t) for t in twins.values()])
    if cfg.mode == "grid" and cfg.check.twin_rel > 0 and len(check_idx):
        check = with_twins(check, twins)
    if kept is not None:  # the runs kept, renumbered (run_key and sample keep their identity)
        des, main, check, check_idx = restrict(des, main, check, used, check_idx)
    if cfg.mode == "grid":
        runs = assemble_runs(cfg, des, main, check_idx, check)
        maps = make_maps(runs, level=cfg.ci_level, method=cfg.ci)
    elif cfg.mode == "threshold":
        runs = assemble_threshold(cfg, des, main, check_idx, check)
        maps = threshold_maps(runs, level=cfg.ci_level, method=cfg.ci)
    else:
        runs = assemble_critical(cfg, des, main, check_idx, check)
        lo, hi = cfg.incline_range
        curve = np.round(np.arange(lo, hi + 0.5 * cfg.incline_tol, cfg.incline_tol), 10)
        maps = make_maps(expand_to_grid(runs, curve), level=cfg.ci_level, method=cfg.ci)
        maps.attrs["p_success_definition"] = "fraction of valid samples whose critical incline is at least incline_deg"
    attrs = provenance(cfg, cjson, chash)
    if kept is not None:
        runs.attrs.update(adaptive_attrs(cfg, kept))
    # the root holds these (CF 2.7: a group's attributes apply to it and its descendants);
    # each group keeps its own and config_hash (assemble_runs, analysis.maps.maps)
    write_result(path, runs, maps, attrs)
    finish(store, path, lambda m: _say(True, m))
    return StudyResult(runs, maps, path)


def search_priors(cfg: StudyConfig, des: xr.Dataset, store: ShardStore) -> dict[str, tuple[float, ...]]:
    """Threshold mode: each cell's prior from its check samples' sweeps (``threshold_start = "pilot"``)."""
    if cfg.threshold_start != "pilot":
        return {}
    chk = _read(store, "check")
    if not len(chk.get("run", ())):
        return {}
    order = difficulty_order(cfg)
    j = direct_passes(chk["grid_climbed"][:, order], chk["grid_status"][:, order])
    status = np.where(j >= 0, 0, 1)
    ck = des["cell_key"].values
    return pilot_priors(j, status, ck[chk["run"]], ck, len(cfg.axis_values))


def _say(enabled: bool, msg: str) -> None:
    if enabled:
        print(msg, file=sys.stderr, flush=True)


def _done(store: ShardStore, kind: str, progress: bool) -> np.ndarray:
    """Finished runs of ``kind``; damaged shards are set aside (named on stderr) and their runs redone."""
    return _read(store, kind).get("run", np.zeros(0, np.int64))


def _read(store: ShardStore, kind: str) -> dict[str, np.ndarray]:
    """Every finished run of ``kind`` (damaged shards set aside and named, as :func:`_done`)."""
    out = store.read(kind)
    for f, why in store.damaged:
        print(f"warning: set aside {f.name} ({why}) in {f.parent / 'damaged'}; its runs will be simulated again", file=sys.stderr)
    return out


def _parts_hash(path: Path) -> str | None:
    """Config hash of the shard folder of ``path``, if there is one."""
    meta = parts_dir(path) / "study.json"
    return str(read_study_json(meta).get("config_hash")) if meta.exists() else None
