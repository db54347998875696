"""``tumblemc design run | status | plot | sweep``: design search from the command line.

``design run`` searches a design problem (:mod:`tumblemc.design.config`) with a progress
bar (simulations of the budget), resumes an interrupted search, and ends with the
recommended design and its estimate on fresh robots (or the Pareto set).
``design sweep`` repeats the authors' diagonal sweep of the spiked-ends robot
(:mod:`tumblemc.design.sweep`).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

from tumblemc.cli.common import warm_kernels_saying


def register(sub: Any) -> None:
    """Add ``design`` and its actions to the ``tumblemc`` parser."""
    what = "robust design search: which robot dimensions to build"
    st = sub.add_parser("design", help=what, description=what + ".")
    ss = st.add_subparsers(dest="design_command", metavar="ACTION")
    ss.required = True
    r = ss.add_parser("run", help="run a design search (or resume it)", description="Run a design TOML; rerunning resumes.")
    r.add_argument("config", help="design TOML, e.g. studies/design_spiked_ends.toml")
    r.add_argument("--out", default=None, help="result netCDF (default: results/<name>.nc)")
    r.add_argument(
        "--workers", type=int, default=None, help="worker processes of the local cluster (default: all cores; 0: in this process)"
    )
    r.add_argument("--scheduler", default=None, help="address of an existing dask scheduler (instead of the local cluster)")
    r.add_argument("--fresh", action="store_true", help="discard an interrupted search of this output instead of resuming")
    r.add_argument("--no-progress", action="store_true", help="no progress bar")
    r.add_argument("--plot", action="store_true", help="also write the figures next to the result")
    s = ss.add_parser("status", help="summarise a design result", description="The designs, the recommendation and the Pareto set.")
    s.add_argument("result", help="result netCDF")
    p = ss.add_parser("plot", help="plot a design result", description="Pareto front with interval bars; objectives against each variable.")
    p.add_argument("result", help="result netCDF")
    p.add_argument("--out", default=None, help="output directory (default: <result>_plots)")
    w = ss.add_parser("sweep", help="the authors' spiked-ends sweep", description="The authors' 20-design diagonal sweep, both mass rules.")
    w.add_argument("--out", default="results/authors_sweep", help="output folder (CSV, markdown table, figure)")
    w.add_argument("--designs", type=int, default=20, help="designs along the diagonal (default 20)")
    w.add_argument("--tol", type=float, default=0.125, help="critical-incline resolution, degree (default 0.125, the authors' step)")
    for q in (r, s, p, w):
        q.set_defaults(run=_dispatch)


def _dispatch(args: Any) -> int:
    return {"run": _run, "status": _status, "plot": _plot, "sweep": _sweep}[args.design_command](args)


def _run(args: Any) -> int:
    from tumblemc.design.config import load_design
    from tumblemc.design.search import search

    cfg = load_design(args.config)
    out = Path(args.out or f"results/{cfg.name}.nc")
    n = len(cfg.variables)
    print(
        f"design search {cfg.name}: family {cfg.family} ({n} variable{'s' * (n != 1)}: {', '.join(v.name for v in cfg.variables)}), "
        f"{len(cfg.objectives)} objective(s), {len(cfg.constraints)} constraint(s), strategy {cfg.strategy}, "
        f"budget {cfg.budget} simulations",
        file=sys.stderr,
    )
    from tumblemc.study.cluster import command_client

    if not args.scheduler:  # a remote cluster's workers compile their own
        warm_kernels_saying(not args.no_progress)
    try:
        with command_client(args.scheduler, args.workers) as client:
            search(cfg, out, client, fresh=args.fresh, progress=not args.no_progress)
    except KeyboardInterrupt:
        print(f"\ninterrupted: finished chunks are kept in {out}.parts; run the same command again to resume", file=sys.stderr)
        return 130
    _summary(out)
    if args.plot:
        _plot_to(out, None)
    return 0


def _summary(path: Path) -> None:
    from tumblemc.design.result import open_design

    tree = open_design(path)
    ds = tree["designs"].to_dataset()
    objs = [o for o in f"{tree.attrs['objectives']},{tree.attrs['constraints']}".split(",") if o]
    variables = [str(v) for v in ds.data_vars if ds[v].attrs.get("long_name", "").startswith("design variable")]
    rec = int(tree.attrs["recommended"])
    stopped = int(ds["stopped_early"].sum())
    print(
        f"{path}: {ds.sizes['design']} designs ({stopped} stopped early), {tree.attrs['simulations']} simulations of {tree.attrs['budget']}"
    )
    nfeas = int(ds["feasible"].sum())
    if tree.attrs["constraints"]:
        print(f"{nfeas} of {ds.sizes['design']} designs meet the constraints ({tree.attrs['constraints']}) on their search robots")
    if rec < 0 and not ds["pareto"].any():
        print("no design meets the constraints: nothing to recommend (widen the bounds or relax a constraint)")
        return
    rows = []
    show = [rec] if rec >= 0 else [int(i) for i in ds["design"].values[ds["pareto"].values]]
    for i in show:
        d = ds.isel(design=i)
        row = [str(i)] + [_fmt_var(d, v) for v in variables]
        for o in objs:
            row.append(f"{float(d[o]):.3g} [{float(d[o + '_lo']):.3g}, {float(d[o + '_hi']):.3g}]")
        rows.append(row)
    head = ["design", *variables, *(f"{o} (search robots)" for o in objs)]
    if rec >= 0:
        c = tree["confirm"].to_dataset()
        for o in objs:
            v = c.sel(objective=o)
            head.append(f"{o} on {int(v['robots'])} fresh robots")
            rows[0].append(f"{float(v['value']):.3g} [{float(v['lo']):.3g}, {float(v['hi']):.3g}]")
        print("recommended design (the model's best, re-estimated on fresh robots):")
    else:
        print("Pareto set (estimates on the search robots, 95% intervals):")
    print(_table(head, rows))


def _table(head: list[str], rows: list[list[str]]) -> str:
    """An aligned text table."""
    w = [max(len(h), *(len(r[i]) for r in rows)) if rows else len(h) for i, h in enumerate(head)]
    return "\n".join("  ".join(c.ljust(k) for c, k in zip(r, w, strict=True)) for r in [head, *rows])


def _fmt_var(d: Any, v: str) -> str:
    x = float(d[v])
    return f"{x * 1e6:.1f} um" if d[v].attrs.get("units") == "m" else f"{x:.3g}"


def _status(args: Any) -> int:
    path = Path(args.result)
    if not path.is_file():
        raise ValueError(f"{path}: no such design result (a running or interrupted search keeps its parts in {path}.parts)")
    _summary(path)
    return 0


def _plot_to(path: Path, out: str | None) -> None:
    from tumblemc.design.result import open_design
    from tumblemc.viz.design import plot_design

    folder = Path(out) if out else path.with_name(path.stem + "_plots")
    for p in plot_design(open_design(path), folder):
        print(f"wrote {p}")


def _plot(args: Any) -> int:
    path = Path(args.result)
    if not path.is_file():
        raise ValueError(f"{path}: no such design result")
    _plot_to(path, args.out)
    return 0


def _sweep(args: Any) -> int:
    from tumblemc.design.sweep import authors_sweep, sweep_table
    from tumblemc.viz.design import sweep_figure

    if not (2 <= args.designs <= 1000):
        raise ValueError(f"--designs={args.designs} is out of range (allowed: 2 to 1000)")
    if not (math.isfinite(args.tol) and 1e-3 <= args.tol <= 5):
        raise ValueError(f"--tol={args.tol} is out of range (allowed: 0.001 to 5 degree)")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    df = authors_sweep(args.designs, args.tol, progress=True)
    df.to_csv(out / "authors_sweep.csv", index=False)
    (out / "authors_sweep.md").write_text(sweep_table(df))
    sweep_figure(df, out / "authors_sweep.png")
    print(sweep_table(df))
    print(f"wrote {out / 'authors_sweep.csv'}, {out / 'authors_sweep.md'}, {out / 'authors_sweep.png'}")
    return 0
