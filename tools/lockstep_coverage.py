"""How much of a study's work could run in lockstep? Issue 15, item 2, measured on the default study's runs.

    python tools/lockstep_coverage.py [--runs 32] [--lanes 8,32]

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
  residual, Jacobian and solve per iteration; the profile's split, docs/kernel_experiments.md);
- **coverage** ``c``: the plain lanes' share of the total cost;
- **efficiency** ``e``: the plain lanes' cost over ``(plain lanes) x (1 + the largest
  plain lane's iterations)``: the group runs until its slowest plain lane converges.

Then a lockstep whose kernels make a plain lane's step ``s`` times cheaper (all lanes
busy) gives at most ``1 / ((1 - c) + c / (s e))`` per run. The table prints the
break-even ``s = 1 / e`` (below it lockstep is slower than the scalar path), the ``s``
that the issue's 2.5x per run would need, the bound at ``s = 4`` (what straight-line
kernel code gained in lockstep at K = 8, ``tools/lockstep_lu.py --block``), the bound of
perfect K-wide vectors with no lane ever idle (``s = K``, ``e = 1``), and the ceiling
``1 / (1 - c)`` of an infinitely fast lockstep. The last two columns let a group wait only
for its median plain lane, the lanes that need more finishing their step on the scalar
path (:func:`coverage` with ``leave``).

Reported in docs/kernel_experiments.md ("Lockstep LU").
"""

from __future__ import annotations

import argparse
import functools
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
    """Per-run speed-up bound ``1 / ((1 - c) + c / (s e))``."""
    return 1.0 / ((1.0 - c) + c / (s * e))


def s_needed(c: float, e: float, target: float) -> float:
    """The kernel gain ``s`` at which :func:`bound` reaches ``target`` (inf beyond the ceiling)."""
    room = 1.0 / target - (1.0 - c)
    return c / (e * room) if room > 0.0 else float("inf")


def main(argv: list[str] | None = None) -> str:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=32, help="runs per cell (default 32)")
    ap.add_argument("--lanes", default="8,32", help="lockstep widths K (default 8,32)")
    ap.add_argument("--duration", type=float, default=None, help="simulated seconds per run (default: the study's 2 periods)")
    args = ap.parse_args(argv)
    lanes = [int(k) for k in args.lanes.split(",")]
    if any(K > args.runs for K in lanes):
        raise SystemExit(f"--lanes {args.lanes}: every K must be at most --runs {args.runs}")
    extra = f" --duration {args.duration:g}" if args.duration is not None else ""
    lines = [
        f"`python tools/lockstep_coverage.py --runs {args.runs} --lanes {args.lanes}{extra}`:",
        "",
        "| cell | K | coverage c | efficiency e | break-even s = 1/e | s for 2.5x per run | bound at s = 4 "
        "| s = K, e = 1 | ceiling 1/(1-c) | lanes above the median leave: c, e | their bound at s = 4 |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for shape, substrate, incline in CELLS:
        print(f"simulating {shape}, {substrate}, {incline:g} deg ...", file=sys.stderr, flush=True)
        rec = lane_records(shape, substrate, incline, args.runs, args.duration)
        for K in lanes:
            c, e = coverage(rec, K)
            need = s_needed(c, e, 2.5)
            cl, el = coverage(rec, K, leave=True)
            lines.append(
                f"| {shape}, {substrate}, {incline:g} deg | {K} | {c:.3f} | {e:.3f} | {1.0 / e:.2f} "
                f"| {need:.2f} | {bound(c, e, 4.0):.2f}x | {bound(c, 1.0, float(K)):.2f}x "
                f"| {1.0 / (1.0 - c):.2f}x | {cl:.3f}, {el:.3f} | {bound(cl, el, 4.0):.2f}x |".replace("| inf |", "| out of reach |")
            )
    text = "\n".join(lines)
    print(text)
    return text


if __name__ == "__main__":
    main()
