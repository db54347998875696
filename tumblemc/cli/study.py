"""``tumblemc study run | status | plot | compare``: the command line of the study engine.

``study run`` prints a header (runs, cells, check runs, workers, output) at once, says
when the kernels compile, shows a progress bar, and ends with a table of P(success) per
shape and substrate (:func:`success_table`).
"""

from __future__ import annotations

import argparse
import math
import signal
import sys
import threading
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from tumblemc.cli.common import UsageError, format_table, warm_kernels_saying

#: wall time of one simulated second of one run on one core, s (measured on this project's
#: 2-core machine: the default study, 20,800 runs of 2 s and 416 check runs at dt/4, in
#: 2,417 s of simulation on 2 workers with the chord start: 0.108); only the
#: header's first estimate, the bar's ETA measures the real rate
WALL_PER_SIM_S = 0.11


def register(sub: Any) -> None:
    """Add ``study`` and its actions to the ``tumblemc`` parser."""
    what = "Monte Carlo robustness studies: run, status, plot"
    st = sub.add_parser("study", help=what, description=what + ".")
    ss = st.add_subparsers(dest="study_command", metavar="ACTION")
    ss.required = True
    r = ss.add_parser("run", help="run a study (or resume it)", description="Run a study TOML; rerunning resumes an interrupted study.")
    r.add_argument("config", help="study TOML, e.g. studies/smoke.toml")
    r.add_argument("--out", default=None, help="result netCDF (default: results/<study name>.nc)")
    r.add_argument(
        "--workers",
        type=int,
        default=None,
        help="worker processes of the embedded local cluster (default: all cores; 0: run in this process without dask)",
    )
    r.add_argument(
        "--scheduler", default=None, help="address of an existing dask scheduler, e.g. tcp://host:8786 (instead of the local cluster)"
    )
    r.add_argument(
        "--dashboard",
        action="store_true",
        help="serve the dask dashboard of the local cluster (port 8787 or a free one) and print its link",
    )
    r.add_argument("--batch-size", type=int, default=None, help="runs per task (default: the config's [execution].batch_size)")
    r.add_argument(
        "--fresh", action="store_true", help="discard earlier results of this output instead of resuming (needed after a config change)"
    )
    r.add_argument("--no-progress", action="store_true", help="no progress bar")
    r.add_argument("--plot", action="store_true", help="also write the study plots next to the result")
    t = ss.add_parser(
        "status",
        help="how far a study got",
        description="How far a study got (from its TOML or its result path, also of an interrupted study), with the runs done per cell.",
    )
    t.add_argument("study", help="study TOML or result netCDF (an interrupted study's too: its shards are in <result>.parts)")
    t.add_argument("--out", default=None, help="result netCDF of a TOML given (default: results/<study name>.nc)")
    pl = ss.add_parser(
        "plot", help="plot a study result", description="Success-probability heatmap, curves with CI bands, progress-ratio distributions."
    )
    pl.add_argument("result", help="result netCDF; of an interrupted grid study, the runs done so far are plotted, marked partial")
    pl.add_argument("--out", default=None, help="output directory (default: next to the result, <name>_plots, or <name>_partial_plots)")
    cmp = ss.add_parser(
        "compare",
        help="critical-incline curve vs a grid map",
        description="Compare a critical-incline study with a direct incline-grid study at the grid inclines.",
    )
    cmp.add_argument("critical", help="result netCDF of a mode = critical_incline study")
    cmp.add_argument("grid", help="result netCDF of a grid study of the same shapes and substrates")
    cmp.add_argument("--out", default=None, help="write the comparison table as CSV")
    st.set_defaults(run=run)


def study_header(cfg: Any, path: Path, where: str) -> str:
    """What ``study run`` is about to do: runs, cells, check runs, where, output, a first time estimate."""
    from tumblemc.analysis.confseq import CS_METHODS, first_possible_stop
    from tumblemc.study.config import cells
    from tumblemc.study.design import n_check_runs

    n_cells = len(cells(cfg))
    n = cfg.n_runs
    n_check = n_check_runs(cfg, n)
    sim_s = sum(cfg.periods / f for f in cfg.freq_hz) / len(cfg.freq_hz)
    work = (n + n_check * cfg.check.dt_factor) * sim_s * WALL_PER_SIM_S
    axes = [("shape", cfg.shapes), ("substrate", cfg.presets), ("field", cfg.field_mT), ("frequency", cfg.freq_hz)]
    if cfg.mode == "grid":
        axes.insert(2, ("incline", cfg.incline_deg))
    if cfg.mode == "threshold":
        m = len(cfg.axis_values)
        axes = [a for a in axes if a[0] != {"field_mT": "field", "freq_hz": "frequency"}.get(cfg.threshold_axis)]
        # a search takes log2(m + 1) runs by bisection, about 0.7 of that from a pilot's prior (2.58 of
        # 3.84 on the main job); an audit sample m, plus 2 at dt / dt_factor
        per = math.log2(m + 1) * (0.7 if cfg.threshold_start == "pilot" else 1.0)
        work = (n * per + n_check * (m + 2 * cfg.check.dt_factor)) * sim_s * WALL_PER_SIM_S
    dims = " x ".join(f"{len(v)} {_plural(k, len(v))}" for k, v in axes if len(v) > 1 or k in ("shape", "substrate"))
    upto = "up to " if cfg.precision is not None else ""
    if cfg.mode == "threshold":
        grid = ", ".join(f"{v:g}" for v in cfg.axis_values)
        start = "they give each cell its search start" if cfg.threshold_start == "pilot" else "the searches bisect"
        return "\n".join(
            [
                f"study {cfg.name}: {n:,} sampled robots = {n_cells} {_plural('cell', n_cells)} ({dims}) x {cfg.samples} "
                f"{_plural('sample', cfg.samples)}, each asked for its threshold on the {cfg.threshold_axis} grid "
                f"[{grid}] ({m} values) by a search of about 2-4 runs, not {m}",
                f"  audit first: {n_check} of the samples simulated at every grid value to the end (and around their first "
                f"failure at dt/{cfg.check.dt_factor}); {start}",
                f"  on {where}; output {path}",
                f"  rough estimate {_duration(work)} of single-core time (the progress bar counts samples; its ETA measures the real rate)",
            ]
        )
    lines = [
        f"study {cfg.name}: {upto}{n:,} runs = {n_cells} {_plural('cell', n_cells)} ({dims}) x {upto}{cfg.samples} "
        f"{_plural('sample', cfg.samples)}"
        + (
            f", plus {upto}{n_check:,} dt-check runs at dt/{cfg.check.dt_factor} ({upto}{n + n_check:,} in the progress bar)"
            if n_check
            else ""
        ),
        *(
            [
                f"  adaptive: each cell stops once its {cfg.ci_level:.0%} confidence sequence has a half-width of at most {cfg.precision:g}"
                " (cells at p = 0 or 1 after about "
                f"{first_possible_stop(cfg.precision, cfg.ci_level, cfg.samples, CS_METHODS[cfg.ci])} runs); "
                "the progress bar's total shrinks as cells close"
            ]
            if cfg.precision is not None
            else []
        ),
        f"  on {where}; output {path}",
        f"  rough estimate {_duration(work)} of single-core time (the progress bar's ETA measures the real rate)",
    ]
    return "\n".join(lines)


def _plural(word: str, n: int) -> str:
    if n == 1:
        return word
    return word[:-1] + "ies" if word.endswith("y") else word + "s"


def _duration(seconds: float) -> str:
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


def success_table(maps: xr.Dataset, threshold: float = 0.5) -> str:
    """P(success) per shape and substrate at each incline (one line each), and the steepest incline with P >= ``threshold``.

    Sweep dimensions (field, frequency) of size > 1 get one block per value.
    """
    if "p_success" not in maps or "incline_deg" not in maps.dims:
        return ""
    p = maps["p_success"]
    extra = [d for d in p.dims if d not in ("shape", "substrate", "incline_deg")]
    blocks = []
    for key in np.ndindex(*(p.sizes[d] for d in extra)):
        sel = {d: i for d, i in zip(extra, key, strict=True)}
        q = p.isel(sel)
        head = ", ".join(f"{d} = {p[d].values[i]:g}" for d, i in sel.items() if p.sizes[d] > 1)
        inc = q["incline_deg"].values
        lines = [f"P(success){' at ' + head if head else ''} by incline (deg); last column: steepest incline with P >= {threshold:g}"]
        if (inc < 0).any():  # downhill slopes: success there is descending, not climbing
            lines[0] += " (negative inclines are downhill: the robot tumbles down them)"
        lines.append(f"{'shape':<12} {'substrate':<9} " + " ".join(f"{t:>4g}" for t in inc) + "   climbs to")
        for s in q["shape"].values:
            for sub in q["substrate"].values:
                v = q.sel(shape=s, substrate=sub).transpose("incline_deg").values
                ok = inc[np.nan_to_num(v, nan=-1.0) >= threshold]
                cells = " ".join(f"{x:4.2f}" if np.isfinite(x) else "   -" for x in v)
                lines.append(f"{s!s:<12} {sub!s:<9} {cells}   {_climbs_to(ok)}")
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks)


def _climbs_to(ok: np.ndarray) -> str:
    """The last column of :func:`success_table`: the steepest incline succeeded, in words when it is downhill."""
    if not len(ok):
        return "none"
    top = float(ok.max())
    return f"{top:g} deg" if top >= 0 else f"none uphill; descends {-top:g} deg"


def run(args: argparse.Namespace) -> int:
    """Run ``study run | status | plot | compare``; returns the exit status."""
    from tumblemc.study.engine import study_status

    if args.study_command == "status":
        st = study_status(args.study, args.out)
        where = st.pop("cells", None)
        print(format_table(st))
        if where:
            print()
            print(where)
        return 0
    if args.study_command == "plot":
        return _plot(args)
    if args.study_command == "compare":
        return _compare(args)
    if args.workers is not None and args.workers < 0:
        raise UsageError(f"--workers {args.workers} is not allowed (allowed: 0 for in-process, or >= 1)")
    if args.batch_size is not None and args.batch_size < 1:
        raise UsageError(f"--batch-size {args.batch_size} is not allowed (allowed: >= 1)")
    if args.dashboard and (args.scheduler or args.workers == 0):
        raise UsageError("--dashboard serves the local cluster's dashboard (not allowed with --scheduler or --workers 0)")
    return _run(args)


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the program is, so that it ends as Ctrl-C does (lock released, cluster closed, a message)."""


def _on_sigterm(signum: int, frame: Any) -> None:
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # a second SIGTERM ends the process at once
    raise Terminated


def _run(args: argparse.Namespace) -> int:
    """``study run``: every fault ends in one line that says what is kept and what to do (``docs/guide/faults.md``)."""
    from tumblemc.study.config import load_config
    from tumblemc.study.engine import default_output
    from tumblemc.study.faults import StudyAbortedError, kept_words
    from tumblemc.study.identity import config_hash

    cfg = load_config(args.config)
    path = Path(args.out) if args.out else default_output(cfg)
    handle = threading.current_thread() is threading.main_thread()  # signal handlers live in the main thread only
    previous = signal.signal(signal.SIGTERM, _on_sigterm) if handle else None
    try:
        res, wrote = _run_study(args, cfg, path)
    except KeyboardInterrupt as e:
        what = "terminated (SIGTERM)" if isinstance(e, Terminated) else "interrupted"
        try:  # counting the kept runs reads the shards: a second Ctrl-C there still ends in this one line
            kept = kept_words(path, config_hash(cfg))
        except KeyboardInterrupt:
            kept = "the finished runs are kept"
        print(f"\n{what}: {kept}; run the same command again to resume", file=sys.stderr)
        return 143 if isinstance(e, Terminated) else 130
    except StudyAbortedError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    finally:
        if handle:
            signal.signal(signal.SIGTERM, previous)
    print(f"{'wrote' if wrote else 'complete, read-only (nothing written):'} {res.path}")
    _report(res.path, res, args.plot)
    return 0


def _run_study(args: argparse.Namespace, cfg: Any, path: Path) -> tuple[Any, bool]:
    """Lock the output, check the config against what is there, compile, start the workers, run.

    Returns the result and whether the folder could be written (False: a complete result on read-only media).
    """
    import os

    from tumblemc.io import check_parts_belong, parts_dir
    from tumblemc.study.cluster import command_client
    from tumblemc.study.engine import complete, run_study
    from tumblemc.study.identity import config_hash
    from tumblemc.study.lock import ReadOnlyOutputError, StudyLock

    workers = args.workers if args.workers is not None else cfg.execution.workers
    n_workers = int(workers or os.cpu_count() or 1)
    procs = f"{n_workers} worker process" + ("es" if n_workers > 1 else "")
    where = args.scheduler or ("this process (no dask)" if workers == 0 else f"a local dask cluster of {procs}")
    say = not args.no_progress
    path.parent.mkdir(parents=True, exist_ok=True)
    lock = StudyLock(path)
    try:
        lock.__enter__()  # before anything is compiled or started: a second run on this output stops here
    except ReadOnlyOutputError as e:  # a finished study on read-only media is reported; anything else cannot go on
        done = None if args.fresh else complete(cfg, path, say)
        if done is None:
            raise ReadOnlyOutputError(f"{e}{_parts_words(path, config_hash(cfg))}") from None
        return done, False
    try:
        if not args.fresh:  # a changed config is refused before the header and the compilation
            check_parts_belong(parts_dir(path), config_hash(cfg))
        if say:
            print(study_header(cfg, path, where), file=sys.stderr, flush=True)
        if not args.scheduler:  # a remote cluster's workers compile their own
            warm_kernels_saying(say)  # the local cluster's workers then load them from the cache
        with command_client(args.scheduler, workers, args.dashboard) as client:
            if client is not None and args.dashboard and not args.scheduler:
                print(f"dask dashboard: {client.dashboard_link}" + _bokeh_note(), file=sys.stderr, flush=True)
            return run_study(cfg, client, out=path, fresh=args.fresh, progress=say, batch_size=args.batch_size, lock=False), True
    finally:
        lock.__exit__(None, None, None)


def _parts_words(path: Path, chash: str) -> str:
    from tumblemc.io import parts_dir
    from tumblemc.study.faults import kept_words

    return f" ({kept_words(path, chash)})" if parts_dir(path).exists() else ""


def _report(path: Path, res: Any, plot: bool) -> None:
    """The status table, P(success) per shape and substrate, and the plots if asked."""
    from tumblemc.study.engine import study_status

    print(format_table(study_status(path)))
    table = success_table(res.maps)
    if table:
        print()
        print(table)
    if plot:
        from tumblemc.viz.study import plot_study

        for p in plot_study(res.runs, res.maps, res.path.with_name(res.path.stem + "_plots")):
            print(f"wrote {p}")


def _bokeh_note() -> str:
    try:
        import bokeh  # noqa: F401
    except ImportError:
        return " (its plots need bokeh: pip install 'tumblemc[dashboard]')"
    return ""


def _plot(args: argparse.Namespace) -> int:
    from tumblemc.analysis.words import check_words, early_words
    from tumblemc.io import open_result
    from tumblemc.study.partial import has_parts, partial_result
    from tumblemc.viz.study import plot_study

    result = Path(args.result)
    suffix = "_plots"
    if not result.exists() and has_parts(result):  # interrupted: what is done, said to be partial
        runs, maps, note = partial_result(result)
        print(note)
        suffix = "_partial_plots"
    else:
        runs, maps = open_result(result)
    out_dir = Path(args.out) if args.out else result.with_name(result.stem + suffix)
    for path in plot_study(runs, maps, out_dir):
        print(f"wrote {path}")
    for words in (check_words(runs, str(result)), early_words(runs)):
        if words:
            print(words)
    return 0


def _compare(args: argparse.Namespace) -> int:
    from tumblemc.analysis.critical import compare_with_grid
    from tumblemc.io import open_result

    crit_runs, crit_maps = open_result(args.critical)
    _, grid_maps = open_result(args.grid)
    table = compare_with_grid(crit_maps, grid_maps).to_dataframe().reset_index()
    cols = [
        "shape",
        "substrate",
        "incline_deg",
        "p_success_critical",
        "p_success_lower_critical",
        "p_success_upper_critical",
        "p_success_grid",
        "p_success_lower_grid",
        "p_success_upper_grid",
        "agree",
    ]
    table = table[[c for c in cols if c in table.columns]]
    print(table.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    a = crit_runs.attrs
    if "monotonicity_disagreement_rate" in a:
        print(
            f"monotonicity check: {a['monotonicity_checked_samples']} samples "
            f"at {crit_runs.sizes.get('check_incline_deg', 0)} grid inclines; "
            f"disagreement rate {a['monotonicity_disagreement_rate']:.3f}; non-monotone samples {a['monotonicity_nonmonotone_samples']}"
        )
    sims, grid_eq = int(a.get("simulations_total", 0)), int(a.get("simulations_grid_equivalent", 0))
    if grid_eq:
        print(f"simulations: {sims} for the critical curve vs {grid_eq} for the grid it replaces (ratio {sims / grid_eq:.2f})")
    print(f"agree within the CI at {int(table['agree'].sum())} of {len(table)} grid inclines")
    if args.out:
        table.to_csv(args.out, index=False)
        print(f"wrote {args.out}")
    return 0


__all__ = ["register", "run", "study_header", "success_table"]
