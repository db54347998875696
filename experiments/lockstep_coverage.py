"""How much of a study's work could run in lockstep? Issue 15, item 2, measured on the default study's runs.

    python experiments/lockstep_coverage.py [--runs 32] [--lanes 8,32] [--main-job results/default.nc]

Item 2 advances K runs of a cell together; a run that needs a fallback, a sub-step or
another contact state takes that step on the scalar path and rejoins. Whatever the
lockstep kernels gain, it applies only to the steps that stay together, and a group
advances at the pace of its slowest lane. This script measures both on real runs.

For each cell below, the first ``--runs`` runs of the default study's design
(``studies/default.toml``: the study's own parameter draws) are simulated with every step
recorded (``tumblemc.simulate``; single runs are not decided early, so sliders run to the
end). Lane ``l`` of group ``g`` is run ``g K + l``. At each step of a group:

- a lane is **plain** if its step took no sub-step and no fallback, its contact mode is
  that of its previous step, and that mode is the group's most common plain mode (the
  lanes of one lockstep system share its shape: all in flight or all in contact);
- a step's cost is modelled as ``1 + Newton iterations`` (the step's fixed work and one
  residual, Jacobian and solve per iteration; the profile's split, docs/notes/kernel_experiments.md);
- **coverage** ``c``: the plain lanes' share of the total cost;
- **efficiency** ``e``: the plain lanes' cost over ``(plain lanes) x (1 + the largest
  plain lane's iterations)``: the group runs until its slowest plain lane converges.

Then a lockstep whose kernels make a plain lane's step ``s`` times cheaper (all lanes
busy) gives at most ``1 / ((1 - c) + c / (s e))`` per run. The table prints the
break-even ``s = 1 / e`` (below it lockstep is slower than the scalar path), the ``s``
that the issue's 2.5x per run would need, the bound at ``s = 4`` (what straight-line
kernel code gained in lockstep at K = 8, ``experiments/lockstep_lu.py --block``), the bound of
perfect K-wide vectors with no lane ever idle (``s = K``, ``e = 1``), and the ceiling
``1 / (1 - c)`` of an infinitely fast lockstep. The last two columns let a group wait only
for its median plain lane, the lanes that need more finishing their step on the scalar
path (:func:`coverage` with ``leave``).

A second table weights the cells over the main job: each cell stands for a class of its
work (paper; aluminum without the curved robot; the curved robot on aluminum), each class
weighted by its share of the main job's modelled cost (``--main-job``: a main job's
netCDF; by default the shares of the run at 46d8347). It gives the main job's gain, the
study throughput against d5c7070 and the main job's minutes for:
- the LU at its best measured lockstep gain on its share of a step, the rest at the best
  kernel gain;
- ``s = 4``;
- the best measured kernel gain (6.6x), with the measured efficiency and with none idle;
- ``s = K`` with no lane idle;
- the ceiling;
- and the ``s`` that issue 15's study target (5x) needs.

Reported in docs/notes/kernel_experiments.md ("Lockstep LU") and docs/notes/speed_targets.md.
"""

from __future__ import annotations

import argparse
import functools
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

import tumblemc
from tumblemc.study.config import load_config
from tumblemc.study.design import design, run_kwargs

ROOT = Path(__file__).resolve().parents[1]
CELLS = [
    ("cuboid", "paper", 45.0),
    ("cuboid", "aluminum", 30.0),
    ("spiked", "paper", 20.0),
    ("curved", "aluminum", 35.0),
]


@functools.cache
def default_design() -> tuple[Any, Any]:
    """The default study's config and run table, built once for every cell."""
    cfg = load_config(ROOT / "studies" / "default.toml")
    return cfg, design(cfg)


def lane_records(shape: str, substrate: str, incline: float, runs: int, duration: float | None = None) -> dict[str, np.ndarray]:
    """Per-step records (run, step) of the first ``runs`` runs of one cell of the default study."""
    cfg, des = default_design()
    in_cell = (des["shape"].values == shape) & (des["substrate"].values == substrate) & (des["incline_deg"].values == incline)
    sel = np.flatnonzero(in_cell)[:runs]
    if len(sel) < runs:
        raise SystemExit(f"cell ({shape}, {substrate}, {incline:g} deg) has {len(sel)} runs, fewer than --runs {runs}")
    out: dict[str, list[np.ndarray]] = {"nit": [], "sub": [], "fb": [], "mode": []}
    for i in sel:
        kw: dict[str, Any] = run_kwargs(cfg, des.isel(run=int(i)))
        if duration is not None:
            kw.pop("periods")
            kw["duration_s"] = duration
        ds = tumblemc.simulate(**kw, record_every=1)
        out["nit"].append(ds["newton_iterations"].values[1:])
        out["sub"].append(ds["substeps"].values[1:])
        out["fb"].append(ds["fallbacks"].values[1:])
        out["mode"].append(ds["contact_mode"].values)
    rec = {k: np.array(v, dtype=float) for k, v in out.items()}
    return rec


def coverage(rec: dict[str, np.ndarray], K: int, leave: bool = False) -> tuple[float, float]:
    """Coverage and efficiency (module docstring) of lockstep groups of K lanes.

    With ``leave``, a group waits only for its median plain lane (the upper median of their
    costs): a lane that needs more finishes its step on the scalar path, and that remainder
    counts as work off the lockstep path.
    """
    nit, sub, fb, mode = rec["nit"], rec["sub"], rec["fb"], rec["mode"]
    R, S = nit.shape
    cost = 1.0 + nit
    plain_cost = 0.0
    slots = 0.0
    for g0 in range(0, R - K + 1, K):
        lanes = slice(g0, g0 + K)
        m = mode[lanes, 1:]
        ok = (sub[lanes] == 0) & (fb[lanes] == 0) & (m == mode[lanes, :-1])
        for s in range(S):
            o = ok[:, s]
            if not o.any():
                continue
            modes, counts = np.unique(m[o, s], return_counts=True)
            keep = o & (m[:, s] == modes[np.argmax(counts)])
            c = cost[lanes, s][keep]
            wait = float(np.sort(c)[len(c) // 2]) if leave else float(c.max())
            plain_cost += float(np.minimum(c, wait).sum())
            slots += float(keep.sum() * wait)
    total = float(cost[: (R // K) * K].sum())
    return plain_cost / total, plain_cost / slots if slots else float("nan")


def bound(c: float, e: float, s: float) -> float:
    """Per-run speed-up bound ``1 / ((1 - c) + c / (s e))`` (1 with nothing in lockstep, ``c = 0``)."""
    if c == 0.0:
        return 1.0
    return 1.0 / ((1.0 - c) + c / (s * e))


def s_needed(c: float, e: float, target: float) -> float:
    """The kernel gain ``s`` at which :func:`bound` reaches ``target`` (inf beyond the ceiling)."""
    room = 1.0 / target - (1.0 - c)
    return c / (e * room) if room > 0.0 else float("inf")


#: each cell stands for a class of the main job's work (paper cells, the aluminum cells of
#: the cuboid and both spiked shapes, the curved robot's aluminum cells)
CLASS_OF = {
    ("cuboid", "paper", 45.0): "paper",
    ("spiked", "paper", 20.0): "paper",
    ("cuboid", "aluminum", 30.0): "aluminum, not curved",
    ("curved", "aluminum", 35.0): "curved, aluminum",
}
#: the classes' shares of the main job's modelled cost (:func:`main_job_shares`), from its
#: run at 46d8347 (2026-11-29; ``--main-job FILE`` recomputes them from any main job's
#: netCDF)
MAIN_JOB_SHARES = {"paper": 0.440, "aluminum, not curved": 0.379, "curved, aluminum": 0.181}
#: the best per-lane gain any lockstep kernel reached (``experiments/lockstep_lu.py --block``:
#: straight-line code, flat layout, K = 8 and 16)
BEST_KERNEL_GAIN = 6.6
#: the best per-lane gain of a lockstep LU (copy, factor, solve) against today's sparse LU,
#: by K (``experiments/lockstep_lu.py``, two runs of 2026-11-29, the best form of the best
#: scenario: 1.49x at K = 8, the flat form; 2.27x at K = 32, the 2-D form); other K take
#: the nearest K below
BEST_LU_GAIN = {8: 1.49, 32: 2.27}
#: the smallest share of a step that the LU (``copy_amax``, ``lu_factor``, ``lu_solve``)
#: takes in ``benchmarks/profile.py``'s profiles (19.6% to 35.7% over four scenarios,
#: 2026-11-29): the share most favourable to lockstep
LU_SHARE = 0.196


def main_job_shares(path: Path) -> dict[str, float]:
    """The classes' shares of a main job's modelled cost.

    Read from its ``runs`` group: steps of the study's dt up to the run's end, or to
    ``decided_time`` for a run decided early, times ``1 + iterations``; each check run (at
    ``dt / check_dt_factor``, to the end) adds its run's cost to the end times the factor
    (its iterations taken as its run's).
    """
    import json

    import xarray as xr

    with xr.open_dataset(path) as root:
        cfg = json.loads(root.attrs["config_json"])
    with xr.open_dataset(path, group="runs") as ds:
        dt = float(ds.attrs["dt"])
        end = cfg["periods"] / ds["freq_hz"].values
        t = np.where(ds["decided_early"].values == 1, ds["decided_time"].values, end)
        nit = ds["newton_iterations"].values
        cost = t / dt * (1.0 + nit)
        if "check_run" in ds:
            chk = ds["check_run"].values
            cost = cost.copy()
            np.add.at(cost, chk, float(ds.attrs["check_dt_factor"]) * end[chk] / dt * (1.0 + nit[chk]))
        paper = ds["substrate"].values == "paper"
        curved = ds["shape"].values == "curved"
    cls = np.where(paper, "paper", np.where(curved, "curved, aluminum", "aluminum, not curved"))
    tot = float(np.nansum(cost))
    return {k: float(np.nansum(cost[cls == k])) / tot for k in MAIN_JOB_SHARES}


def weighted(per_cell: dict[tuple[str, str, float], tuple[float, float]], shares: dict[str, float], s: float, e_one: bool) -> float:
    """The main job's bound: each class's time fraction (the mean over its cells) weighted by its share.

    The shares are normalised to sum to 1. A class without a cell, or a cell of no class
    (``CLASS_OF``), is an error.
    """
    unknown = [cell for cell in per_cell if cell not in CLASS_OF]
    if unknown:
        raise ValueError(f"cells {unknown} stand for no class of the main job (CLASS_OF)")
    total = sum(shares.values())
    frac = 0.0
    for cls, w in shares.items():
        fs = [1.0 / bound(c, 1.0 if e_one else e, s) for cell, (c, e) in per_cell.items() if CLASS_OF[cell] == cls]
        if not fs:
            raise ValueError(f"no measured cell stands for the class {cls!r} (CLASS_OF)")
        frac += w / total * float(np.mean(fs))
    return 1.0 / frac


def s_for(per_cell: dict[tuple[str, str, float], tuple[float, float]], shares: dict[str, float], target: float, e_one: bool) -> float:
    """The kernel gain at which :func:`weighted` reaches ``target`` (inf if its ceiling is below)."""
    ceiling = weighted(per_cell, shares, 1e12, e_one)
    if math.isnan(ceiling):
        raise ValueError("the weighted bound is NaN (a cell's efficiency is undefined)")
    if ceiling < target:
        return float("inf")
    lo, hi = 0.01, 1e12
    for _ in range(100):  # the bracket's log ratio halves each step
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if weighted(per_cell, shares, mid, e_one) < target else (lo, mid)
    return hi


def main(argv: list[str] | None = None) -> str:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=32, help="runs per cell (default 32)")
    ap.add_argument("--lanes", default="8,32", help="lockstep widths K (default 8,32)")
    ap.add_argument("--duration", type=float, default=None, help="simulated seconds per run (default: the study's 2 periods)")
    ap.add_argument("--main-job", type=Path, default=None, help="a main job's netCDF for the classes' shares (default: the run at 46d8347)")
    ap.add_argument("--study-now", type=float, default=1.56, help="today's study throughput against d5c7070 (default 1.56, README)")
    ap.add_argument("--minutes-now", type=float, default=37.27, help="today's main job, minutes (default 37.27, README)")
    args = ap.parse_args(argv)
    lanes = [int(k) for k in args.lanes.split(",")]
    if any(K > args.runs for K in lanes):
        raise SystemExit(f"--lanes {args.lanes}: every K must be at most --runs {args.runs}")
    extra = f" --duration {args.duration:g}" if args.duration is not None else ""
    lines = [
        f"`python experiments/lockstep_coverage.py --runs {args.runs} --lanes {args.lanes}{extra}`:",
        "",
        "| cell | K | coverage c | efficiency e | break-even s = 1/e | s for 2.5x per run | bound at s = 4 "
        "| s = K, e = 1 | ceiling 1/(1-c) | lanes above the median leave: c, e | their bound at s = 4 |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    per_cell: dict[int, dict[tuple[str, str, float], tuple[float, float]]] = {K: {} for K in lanes}
    for shape, substrate, incline in CELLS:
        print(f"simulating {shape}, {substrate}, {incline:g} deg ...", file=sys.stderr, flush=True)
        rec = lane_records(shape, substrate, incline, args.runs, args.duration)
        for K in lanes:
            c, e = coverage(rec, K)
            per_cell[K][(shape, substrate, incline)] = (c, e)
            need = s_needed(c, e, 2.5)
            cl, el = coverage(rec, K, leave=True)
            lines.append(
                f"| {shape}, {substrate}, {incline:g} deg | {K} | {c:.3f} | {e:.3f} | {1.0 / e:.2f} "
                f"| {need:.2f} | {bound(c, e, 4.0):.2f}x | {bound(c, 1.0, float(K)):.2f}x "
                f"| {1.0 / (1.0 - c):.2f}x | {cl:.3f}, {el:.3f} | {bound(cl, el, 4.0):.2f}x |".replace("| inf |", "| out of reach |")
            )
    lines += main_job_table(per_cell, args.main_job, args.study_now, args.minutes_now)
    text = "\n".join(lines)
    print(text)
    return text


def main_job_table(
    per_cell: dict[int, dict[tuple[str, str, float], tuple[float, float]]], path: Path | None, study_now: float, minutes_now: float
) -> list[str]:
    """The bounds weighted over the main job, against issue 15's study targets."""
    shares = MAIN_JOB_SHARES if path is None else main_job_shares(path)
    src = "the main job at 46d8347" if path is None else str(path)
    need = 5.0 / study_now
    lines = [
        "",
        f"Weighted over the main job (classes' shares of its modelled cost, {src}: "
        + ", ".join(f"{k} {v:.1%}" for k, v in shares.items())
        + f"; each class at the mean of its cells' time fractions). Today: study {study_now:g}x against d5c7070, "
        f"main job {minutes_now:g} min; the study's 5x needs {need:.2f}x more, 12 min needs {minutes_now / 12.0:.2f}x:",
        "",
        "| K | kernel gain s | efficiency | main job gain | study against d5c7070 | main job, min |",
        "|---|---|---|---|---|---|",
    ]
    for K, cells in per_cell.items():
        if set(CLASS_OF) - set(cells):
            continue
        lu_gain = BEST_LU_GAIN[max([k for k in BEST_LU_GAIN if k <= K], default=min(BEST_LU_GAIN))]
        amdahl = 1.0 / (LU_SHARE / lu_gain + (1.0 - LU_SHARE) / BEST_KERNEL_GAIN)
        lu_label = f"{amdahl:.2f} (LU at {lu_gain:g}x, {LU_SHARE:.0%} of a step; the rest at {BEST_KERNEL_GAIN:g}x)"
        cases = [
            (lu_label, amdahl, False),
            (lu_label, amdahl, True),
            ("4", 4.0, False),
            (f"{BEST_KERNEL_GAIN:g} (best measured)", BEST_KERNEL_GAIN, False),
            (f"{BEST_KERNEL_GAIN:g} (best measured)", BEST_KERNEL_GAIN, True),
            (f"{K} (K-wide, ideal)", float(K), True),
            ("infinite (ceiling)", 1e12, False),
        ]
        for label, s, e_one in cases:
            g = weighted(cells, shares, s, e_one)
            eff = "1 (no idle lane)" if e_one else "measured"
            lines.append(f"| {K} | {label} | {eff} | {g:.2f}x | {study_now * g:.2f}x | {minutes_now / g:.1f} |")
        for e_one in (False, True):
            s5 = s_for(cells, shares, need, e_one)
            lines.append(
                f"| {K} | needed for the study's 5x: {s5:.1f} | {'1 (no idle lane)' if e_one else 'measured'} | {need:.2f}x | 5.00x "
                f"| {minutes_now / need:.1f} |".replace("needed for the study's 5x: inf", "5x out of reach at any s")
            )
    return lines


if __name__ == "__main__":
    main()
