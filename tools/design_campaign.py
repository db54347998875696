"""The design-search acceptance campaign (docs/notes/design_search.md).

    python tools/design_campaign.py grid  --out /tmp/dc       # the 8x8 reference grid, 200 robots per design
    python tools/design_campaign.py search --out /tmp/dc      # G1: 5 seeds per strategy, re-estimated on 1,000 fresh robots
    python tools/design_campaign.py front --out /tmp/dc       # G2: two objectives, hypervolume against the grid front
    python tools/design_campaign.py report --out /tmp/dc      # the tables of docs/notes/design_search.md
    ... --quick                                               # a small version (CI): 3x3 grid, 8 robots

The problem (G1, G2): the spiked-ends robot's spike base (width) and spike height (length)
in [50, 400] um, geometry-derived mass (``mass_rule = "density"``), the default
uncertainties; objectives P(climb 30 deg, aluminum, 20 mT, 1 Hz) and the mean speed on flat
paper at 20 mT, 10 Hz. Every chunk of work is saved as it finishes (``<out>/grid/*.npz``):
an interrupted campaign resumes.
"""

from __future__ import annotations

import argparse
import itertools
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

import numpy as np

from tumblemc.design.config import DesignConfig, parse_design
from tumblemc.design.evaluate import FRESH, Chunk, execute

UM = 1e-6


OBJECTIVES = (
    {"kind": "climb", "substrate": "aluminum", "incline_deg": 30, "field_mT": 20, "freq_hz": 1},
    {"kind": "speed", "substrate": "paper", "incline_deg": 0, "field_mT": 20, "freq_hz": 10},
)


def problem(quick: bool, **over: Any) -> DesignConfig:
    """The campaign's design problem (module docstring); ``over``: top-level keys replaced."""
    d: dict[str, Any] = {
        "name": "spiked_ends_g1",
        "family": "spiked_ends",
        "seed": 20190818,
        "variables": {"spike_base": {"bounds": [50 * UM, 400 * UM]}, "spike_height": {"bounds": [50 * UM, 400 * UM]}},
        "objectives": list(OBJECTIVES),
        "samples": 8 if quick else 200,
        "stage": 8 if quick else 25,
    }
    d.update(over)
    return parse_design(d)


def grid_axes(quick: bool) -> np.ndarray:
    return np.linspace(50 * UM, 400 * UM, 3 if quick else 8)


def _pool(workers: int) -> ProcessPoolExecutor:
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")
    return ProcessPoolExecutor(workers)


def run_chunks(chunks: list[Chunk], folder: Path, workers: int) -> dict[str, dict[str, np.ndarray]]:
    """Every chunk's result, simulated unless ``folder`` holds it (saved as each one finishes)."""
    folder.mkdir(parents=True, exist_ok=True)
    out: dict[str, dict[str, np.ndarray]] = {}
    todo = []
    for c in chunks:
        f = folder / f"{c.key}.npz"
        if f.exists():
            with np.load(f, allow_pickle=True) as z:
                out[c.key] = {k: z[k] for k in z.files}
        else:
            todo.append(c)
    t0, n = time.time(), 0
    with _pool(workers) as ex:
        futs = {ex.submit(execute, c): c for c in todo}
        for fut in as_completed(futs):
            c = futs[fut]
            r = fut.result()
            tmp = folder / f"{c.key}.tmp.npz"
            arrays: dict[str, Any] = {k: (v.astype(str) if v.dtype == object else v) for k, v in r.items()}
            np.savez(tmp, **arrays)
            tmp.replace(folder / f"{c.key}.npz")
            out[c.key] = r
            n += 1
            if n % 20 == 0 or n == len(todo):
                print(f"  {n}/{len(todo)} chunks, {time.time() - t0:.0f} s", file=sys.stderr, flush=True)
    return out


def grid(args: argparse.Namespace) -> None:
    """The reference: every design of the grid on the same ``samples`` robots, both objectives."""
    cfg = problem(args.quick)
    ax = grid_axes(args.quick)
    chunks = []
    d = 0
    for b in ax:
        for h in ax:
            x = (("spike_base", float(b)), ("spike_height", float(h)))
            for t in range(len(cfg.tasks)):
                for s0 in range(0, cfg.samples, cfg.stage):
                    chunks.append(Chunk(d, x, t, tuple(range(s0, s0 + cfg.stage)), 0, cfg))
            d += 1
    t0 = time.time()
    res = run_chunks(chunks, args.out / "grid", args.workers)
    n = len(ax)
    vals = np.full((n, n, len(cfg.tasks), cfg.samples), np.nan)
    nsim = np.zeros((n, n, len(cfg.tasks)), np.int64)
    for c in chunks:
        i, j = divmod(c.design, n)
        r = res[c.key]
        vals[i, j, c.task, list(c.samples)] = r["value"]
        nsim[i, j, c.task] += int(r["n_sim"].sum())
    np.savez(args.out / "grid.npz", values=vals, n_sim=nsim, axis=ax)
    print(f"grid: {n}x{n} designs, {int(nsim.sum())} simulations, {time.time() - t0:.0f} s")


def fresh_values(cfg: DesignConfig, x: dict[str, float], task: int, n: int, folder: Path, workers: int, design_id: int) -> np.ndarray:
    """Design ``x`` on ``n`` fresh robots (stream FRESH, from robot 100000 on: never the search's own confirmation robots)."""
    xs = tuple(sorted(x.items()))
    chunks = [Chunk(design_id, xs, task, tuple(range(100_000 + s, 100_000 + min(s + 100, n))), FRESH, cfg) for s in range(0, n, 100)]
    res = run_chunks(chunks, folder, workers)
    return np.concatenate([res[c.key]["value"] for c in chunks])


def _nearest(ax: np.ndarray, x: float) -> int:
    return int(np.argmin(np.abs(ax - x)))


def emulator(vals: np.ndarray, ax: np.ndarray, tasks: list[int]) -> Any:
    """A runner that answers from the grid: a design is snapped to the nearest grid design (the search over 64 designs)."""

    def run(chunks: list[Chunk]) -> Any:
        for c in chunks:
            x = dict(c.x)
            i, j = _nearest(ax, x["spike_base"]), _nearest(ax, x["spike_height"])
            if c.stream != 0:
                raise RuntimeError("the emulator has no fresh robots")
            v = vals[i, j, tasks[c.task], list(c.samples)]
            n = len(v)
            yield c, {"value": v, "status": np.zeros(n, np.int8), "n_sim": np.ones(n, np.int32), "error": np.full(n, "", object)}

    return run


def _load_grid(out: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    with np.load(out / "grid.npz") as z:
        return z["values"], z["n_sim"], z["axis"]


def _emulated(args: argparse.Namespace, strat: str, early: bool, budget: int, seed: int) -> tuple[float, int, int]:
    """One emulated search: (regret, designs evaluated, simulations)."""
    from tumblemc.design.result import open_design
    from tumblemc.design.search import search

    vals, _, ax = _load_grid(args.out)
    truth = np.nanmean(vals[:, :, 0, :], axis=-1)
    cfg = problem(args.quick, strategy=strat, seed=seed, budget=budget, confirm=0, early_stop=early, objectives=[OBJECTIVES[0]])
    path = args.out / "emulate" / f"{strat}_{int(early)}_{seed}_{budget}.nc"
    path.parent.mkdir(parents=True, exist_ok=True)
    search(cfg, path, fresh=True, progress=False, runner=emulator(vals, ax, [0]))
    tr = open_design(path)
    ds = tr["designs"].to_dataset()
    r = int(tr.attrs["recommended"])
    i, j = _nearest(ax, float(ds["spike_base"][r])), _nearest(ax, float(ds["spike_height"][r]))
    return float(truth.max() - truth[i, j]), ds.sizes["design"], int(tr.attrs["simulations"])


def emulate(args: argparse.Namespace) -> None:
    """Strategy comparison on the grid (G1's problem restricted to the 8x8 designs; no simulation)."""
    vals, nsim, ax = _load_grid(args.out)
    best = float(np.nanmean(vals[:, :, 0, :], axis=-1).max())
    total = int(nsim[:, :, 0].sum())
    rows = []
    for frac, strat, early in itertools.product((0.1, 0.25), args.strategies.split(","), (True, False)):
        budget = max(int(total * frac), vals.shape[-1])  # at least one design (the quick version)
        res = np.array([_emulated(args, strat, early, budget, seed) for seed in range(1, args.seeds + 1)])
        reg = res[:, 0]
        rows.append(
            f"| {budget} | {strat} | {'on' if early else 'off'} | {np.mean(reg <= 0.03):.2f} | {np.median(reg):.3f} | "
            f"{reg.max():.3f} | {res[:, 1].mean():.1f} | {res[:, 2].mean():.0f} |"
        )
        print(rows[-1], flush=True)
    head = (
        f"Emulated on the grid ({len(ax)}x{len(ax)} designs, {vals.shape[-1]} robots each; best grid P = {best:.3f}; "
        f"budgets 10% and 25% of the grid's {total} simulations; {args.seeds} seeds). "
        "Regret = best grid P - the grid P of the recommended design.\n\n"
        "| budget | strategy | early stop | regret <= 0.03 | median regret | worst regret | designs evaluated | simulations |\n"
        "|---|---|---|---|---|---|---|---|\n"
    )
    (args.out / "emulate.md").write_text(head + "\n".join(rows) + "\n")


SYN_OPT = np.array([0.62, 0.37])


def synthetic_p(u: np.ndarray) -> float:
    """A known P(climb) on the unit box: a global bump at SYN_OPT (0.8) and a local one at (0.15, 0.85) (0.6)."""
    g = 0.6 * np.exp(-np.sum((u - SYN_OPT) ** 2) / (2 * 0.15**2))
    loc = 0.4 * np.exp(-np.sum((u - np.array([0.15, 0.85])) ** 2) / (2 * 0.1**2))
    return float(0.2 + max(g, loc))


def synthetic_runner(cfg: DesignConfig) -> Any:
    """Robot s climbs design u when its own uniform is below P(u): common random numbers, no simulation."""
    from tumblemc.design.evaluate import uniforms

    def run(chunks: list[Chunk]) -> Any:
        for c in chunks:
            x = dict(c.x)
            u = np.array([(x[v.name] - v.lo) / (v.hi - v.lo) for v in cfg.variables])
            w = uniforms(cfg, c.samples, c.stream)[:, -1]
            v = (w < synthetic_p(u)).astype(float)
            n = len(v)
            yield c, {"value": v, "status": np.zeros(n, np.int8), "n_sim": np.ones(n, np.int32), "error": np.full(n, "", object)}

    return run


def synthetic(args: argparse.Namespace) -> None:
    """Strategy comparison on a known landscape with an interior optimum and a decoy (no simulation)."""
    from tumblemc.design.result import open_design
    from tumblemc.design.search import search

    rows = []
    for budget, strat in itertools.product((1000, 2000), args.strategies.split(",")):
        reg, nd = [], []
        for seed in range(1, args.seeds + 1):
            cfg = problem(
                False,
                strategy=strat,
                seed=seed,
                budget=budget,
                samples=100,
                stage=20,
                initial=6,
                batch=3,
                confirm=0,
                objectives=[OBJECTIVES[0]],
            )
            path = args.out / "synthetic" / f"{strat}_{seed}_{budget}.nc"
            path.parent.mkdir(parents=True, exist_ok=True)
            search(cfg, path, fresh=True, progress=False, runner=synthetic_runner(cfg))
            tr = open_design(path)
            ds = tr["designs"].to_dataset()
            r = int(tr.attrs["recommended"])
            u = np.array([(float(ds[v.name][r]) - v.lo) / (v.hi - v.lo) for v in cfg.variables])
            reg.append(0.8 - synthetic_p(u))
            nd.append(ds.sizes["design"])
        g = np.array(reg)
        rows.append(
            f"| {budget} | {strat} | {np.mean(g <= 0.03):.2f} | {np.median(g):.3f} | {np.mean(g):.3f} | {g.max():.3f} | {np.mean(nd):.1f} |"
        )
        print(rows[-1], flush=True)
    head = (
        "Synthetic landscape (known P: a bump of 0.8 at (0.62, 0.37) of the unit box, a decoy of 0.6 at (0.15, 0.85), 0.2 elsewhere; "
        f"robots climb when their own uniform is below P: common random numbers). 100 robots per design, stages of 20, "
        f"{args.seeds} seeds. Regret = 0.8 - P(recommended design).\n\n"
        "| budget | strategy | regret <= 0.03 | median regret | mean regret | worst regret | designs evaluated |\n"
        "|---|---|---|---|---|---|---|\n"
    )
    (args.out / "synthetic.md").write_text(head + "\n".join(rows) + "\n")


def _search_one(args: tuple[Path, str, int, int, bool]) -> str:
    from tumblemc.design.search import search

    out, strat, seed, budget, quick = args
    cfg = problem(quick, strategy=strat, seed=seed, budget=budget, confirm=8 if quick else 200, objectives=[OBJECTIVES[0]])
    path = out / "search" / f"{strat}_{seed}.nc"
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.exists():
        search(cfg, path, progress=False)
    return str(path)


def search_g1(args: argparse.Namespace) -> None:
    """G1: real searches (serial each, ``workers`` at once), then the recommended and the best grid design on 1,000 fresh robots."""
    from tumblemc.design.result import open_design

    vals, nsim, ax = _load_grid(args.out)
    truth = np.nanmean(vals[:, :, 0, :], axis=-1)
    bi, bj = np.unravel_index(int(np.nanargmax(truth)), truth.shape)
    budget = int(nsim[:, :, 0].sum()) // 4
    strat = args.strategies.split(",")[0]
    jobs = [(args.out, strat, seed, budget, args.quick) for seed in range(1, args.seeds + 1)]
    with _pool(args.workers) as ex:
        paths = list(ex.map(_search_one, jobs))
    nfresh = 40 if args.quick else 1000
    cfg = problem(args.quick, objectives=[OBJECTIVES[0]])
    gbest = fresh_values(
        cfg, {"spike_base": float(ax[bi]), "spike_height": float(ax[bj])}, 0, nfresh, args.out / "fresh", args.workers, 99_999
    )
    p_best = float(np.nanmean(gbest))
    rows = []
    for seed, p in enumerate(paths, 1):
        tr = open_design(p)
        ds = tr["designs"].to_dataset()
        r = int(tr.attrs["recommended"])
        x = {"spike_base": float(ds["spike_base"][r]), "spike_height": float(ds["spike_height"][r])}
        fv = fresh_values(cfg, x, 0, nfresh, args.out / "fresh", args.workers, 90_000 + seed)
        d = fv - gbest
        se = float(np.nanstd(d, ddof=1) / math.sqrt(np.sum(~np.isnan(d))))
        rows.append(
            f"| {seed} | {x['spike_base'] / UM:.0f} | {x['spike_height'] / UM:.0f} | {ds.sizes['design']} | "
            f"{int(ds['stopped_early'].sum())} | "
            f"{tr.attrs['simulations']} | {float(np.nanmean(fv)):.3f} | {float(np.nanmean(fv)) - p_best:+.3f} +- {se:.3f} | "
            f"{'yes' if float(np.nanmean(fv)) >= p_best - 0.03 else 'no'} |"
        )
        print(rows[-1], flush=True)
    head = (
        f"G1 ({strat}; budget {budget} simulations = 25% of the grid's {int(nsim[:, :, 0].sum())}, confirmation included). "
        f"Best grid design: spike base {ax[bi] / UM:.0f} um, height {ax[bj] / UM:.0f} um, P = {truth[bi, bj]:.3f} on the grid's robots, "
        f"{p_best:.3f} on {nfresh} fresh robots. Each recommendation on the same {nfresh} fresh robots (paired difference +- its SE).\n\n"
        "| seed | base (um) | height (um) | designs | stopped early | simulations | P, fresh robots "
        "| minus best grid design | within 0.03 |\n"
        "|---|---|---|---|---|---|---|---|---|\n"
    )
    (args.out / f"search_{strat}.md").write_text(head + "\n".join(rows) + "\n")


def crn(args: argparse.Namespace) -> None:
    """Paired against unpaired standard errors of the difference between neighbouring grid designs."""
    vals, _, ax = _load_grid(args.out)
    n = len(ax)
    lines = [
        "| objective | neighbouring pairs | median paired SE / unpaired SE | pairs with ratio <= 0.5 | largest ratio |",
        "|---|---|---|---|---|",
    ]
    for t, name in enumerate(("P(climb 30 deg, aluminum)", "speed, paper, 10 Hz")):
        ratios = []
        for i in range(n):
            for j in range(n):
                for di, dj in ((1, 0), (0, 1)):
                    if i + di < n and j + dj < n:
                        a, b = vals[i, j, t], vals[i + di, j + dj, t]
                        ok = ~np.isnan(a) & ~np.isnan(b)
                        a, b = a[ok], b[ok]
                        unp = math.sqrt(a.var(ddof=1) / len(a) + b.var(ddof=1) / len(b))
                        if unp > 0:
                            ratios.append(float((a - b).std(ddof=1) / math.sqrt(len(a)) / unp))
        r = np.array(ratios)
        lines.append(f"| {name} | {len(r)} | {np.median(r):.3f} | {np.mean(r <= 0.5):.2f} | {r.max():.3f} |")
    (args.out / "crn.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


def _front_one(args: tuple[Path, str, int, int, bool, int]) -> str:
    from tumblemc.design.search import search

    out, strat, seed, budget, quick, samples = args
    cfg = problem(quick, strategy=strat, seed=seed, budget=budget, confirm=0, samples=samples, stage=min(samples, 8 if quick else 25))
    path = out / "front" / f"{strat}_{seed}_{samples}.nc"
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.exists():
        search(cfg, path, progress=False)
    return str(path)


def _on_grid_robots(args: argparse.Namespace, path: str, seed: int) -> np.ndarray:
    """(Pareto designs x 2) means of a search's Pareto designs on the grid's robots (the grid's seed: every one simulated)."""
    from tumblemc.design.result import open_design

    ds = open_design(path)["designs"].to_dataset()
    cfg = problem(args.quick)  # the grid's problem: its seed, its robots
    n = cfg.samples
    chunks = {}
    for d in np.flatnonzero(ds["pareto"].values):
        x = tuple(sorted({"spike_base": float(ds["spike_base"][d]), "spike_height": float(ds["spike_height"][d])}.items()))
        for t in range(2):
            chunks[(int(d), t)] = Chunk(10_000 * seed + int(d), x, t, tuple(range(n)), 0, cfg)
    res = run_chunks(list(chunks.values()), args.out / "front_on_grid_robots", args.workers)
    designs = sorted({d for d, _ in chunks})
    return np.array([[float(np.nanmean(res[chunks[(d, t)].key]["value"])) for t in range(2)] for d in designs]).reshape(-1, 2)


def front(args: argparse.Namespace) -> None:
    """G2: two objectives; the hypervolume of the search's Pareto designs against the grid front's, on the same robots."""
    vals, nsim, ax = _load_grid(args.out)
    from tumblemc.design.result import hypervolume, open_design

    Yg = np.stack([np.nanmean(vals[:, :, 0], axis=-1).ravel(), np.nanmean(vals[:, :, 1], axis=-1).ravel()], axis=1)
    ref = Yg.min(axis=0) - np.array([0.01, 0.1])
    hv_grid = hypervolume(Yg, ref)
    budget = int(nsim.sum()) // 4
    strat = args.strategies.split(",")[0]
    samples = vals.shape[-1] // 2
    jobs = [(args.out, strat, seed, budget, args.quick, samples) for seed in range(1, args.seeds + 1)]
    with _pool(args.workers) as ex:
        paths = list(ex.map(_front_one, jobs))
    rows = []
    for seed, p in enumerate(paths, 1):
        tr = open_design(p)
        ds = tr["designs"].to_dataset()
        names = [o for o in str(tr.attrs["objectives"]).split(",") if o]
        est = hypervolume(np.stack([ds[names[0]].values, ds[names[1]].values], axis=1), ref)
        on_grid = hypervolume(_on_grid_robots(args, p, seed), ref)
        rows.append(
            f"| {seed} | {ds.sizes['design']} | {tr.attrs['simulations']} | {int(ds['pareto'].sum())} | "
            f"{on_grid / hv_grid:.3f} | {est / hv_grid:.3f} |"
        )
        print(rows[-1], flush=True)
    head = (
        f"G2 ({strat}; budget {budget} simulations = 25% of the grid's {int(nsim.sum())}; {samples} robots per design). "
        f"Hypervolume of the search's Pareto designs simulated afterwards on the grid's {vals.shape[-1]} robots (the grid's seed: "
        f"paired with the grid front), and of the search's own estimates (its own seed's robots); reference point {ref.round(3).tolist()} "
        f"(the grid's worst P and speed, less 0.01 and 0.1 mm/s); grid front hypervolume {hv_grid:.3f}.\n\n"
        "| seed | designs | simulations | Pareto designs | hypervolume / grid's (grid robots) | (own estimates) |\n"
        "|---|---|---|---|---|---|\n"
    )
    (args.out / f"front_{strat}.md").write_text(head + "\n".join(rows) + "\n")


def front_emulate(args: argparse.Namespace) -> None:
    """G2's problem restricted to the grid's designs: robots per design and strategy against the front found (no simulation)."""
    from tumblemc.design.result import hypervolume, open_design
    from tumblemc.design.search import search

    vals, nsim, ax = _load_grid(args.out)
    Yg = np.stack([np.nanmean(vals[:, :, 0], -1).ravel(), np.nanmean(vals[:, :, 1], -1).ravel()], 1)
    ref = Yg.min(0) - np.array([0.01, 0.1])
    hg = hypervolume(Yg, ref)
    n = vals.shape[-1]
    budget = int(nsim.sum()) // 4
    rows = []
    for samples, strat in ((n, "gp"), (n // 2, "gp"), (n // 4, "gp"), (n // 2, "tpe"), (n // 2, "sobol")):
        res = []
        for seed in range(1, args.seeds + 1):
            cfg = problem(args.quick, strategy=strat, seed=seed, budget=budget, confirm=0, samples=samples, stage=min(samples, 25))
            p = args.out / "front_emulate" / f"{samples}_{strat}_{seed}.nc"
            p.parent.mkdir(parents=True, exist_ok=True)
            search(cfg, p, fresh=True, progress=False, runner=emulator(vals, ax, [0, 1]))
            ds = open_design(p)["designs"].to_dataset()
            i = [_nearest(ax, float(x)) for x in ds["spike_base"].values]
            j = [_nearest(ax, float(x)) for x in ds["spike_height"].values]
            true = np.stack([np.nanmean(vals[i, j, 0], -1), np.nanmean(vals[i, j, 1], -1)], 1)
            own = np.stack([ds[o].values for o in ("climb30_aluminum", "speed10Hz_paper")], 1)
            res.append((hypervolume(true, ref) / hg, hypervolume(own, ref) / hg, ds.sizes["design"]))
        r = np.array(res)
        rows.append(
            f"| {samples} | {strat} | {r[:, 2].mean():.0f} | {np.mean(r[:, 0] >= 0.9):.2f} | {r[:, 0].min():.3f} | "
            f"{np.median(r[:, 0]):.3f} | {np.median(r[:, 1]):.3f} |"
        )
        print(rows[-1], flush=True)
    head = (
        f"G2 emulated on the grid ({len(ax)}x{len(ax)} designs; a proposal is answered by the nearest grid design's robots), budget "
        f"{budget}, {args.seeds} seeds. Hypervolume / the grid front's: of the designs found at their grid values ({n} robots), and "
        "of the search's own estimates.\n\n"
        "| robots per design | strategy | designs | HV >= 0.9 | worst HV | median HV | median HV of own estimates |\n"
        "|---|---|---|---|---|---|---|\n"
    )
    (args.out / "front_emulate.md").write_text(head + "\n".join(rows) + "\n")


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("what", choices=("grid", "emulate", "synthetic", "search", "crn", "front", "front_emulate"))
    p.add_argument("--out", type=Path, default=Path("/tmp/design_campaign"))
    p.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    p.add_argument("--quick", action="store_true")
    p.add_argument("--seeds", type=int, default=5)
    p.add_argument("--strategies", default="gp,tpe,sobol", help="comma-separated; search and front use the first")
    args = p.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    {
        "grid": grid,
        "emulate": emulate,
        "synthetic": synthetic,
        "search": search_g1,
        "crn": crn,
        "front": front,
        "front_emulate": front_emulate,
    }[args.what](args)


if __name__ == "__main__":
    main()
