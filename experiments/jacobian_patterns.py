"""How stable are the Newton matrices' sparsity patterns and pivot orders? Issue 15, item 1, measured.

    python experiments/jacobian_patterns.py [--seconds 1.0]

Issue 15 proposes straight-line LU code generated per contact state: a fixed sparsity
pattern and pivot order per frequent state, guarded, with the general LU as fallback. That
pays only if a few patterns and orders cover most factorizations of every kind of run.
This script measures it. Each scenario runs ``tumblemc.simulate`` in a subprocess with
``NUMBA_DISABLE_JIT=1`` (the kernels as plain Python, so ``newton.lu_factor`` can be
wrapped) and records, for every factorisation of a Newton matrix (not those of the
Levenberg-Marquardt fallback's ``J^T J + nu I``), its nonzero pattern, partial pivoting's
row order and the matrix itself. It then reports, per scenario:

- distinct patterns and (pattern, order) pairs, the share of the most common pattern, and
  the distinct pivot orders;
- the union of the scenario's patterns: its nonzeros, its nonzeros with the fill of
  elimination in the scenario's most common pivot order, and that elimination's
  multiply-adds (the size of straight-line code for it);
- one static order for the whole scenario (its most common partial-pivoting order, chosen
  from the same data it is tested on, so an upper bound): how often a threshold guard
  (``|pivot| >= 0.1 x`` the largest remaining candidate of its column, the usual sparse-LU
  threshold) passes;
- coverage by the 40 most common patterns of the two training scenarios (the cuboid on
  paper at 45 deg and on aluminum at 30 deg), the code a generator would emit: exactly
  (the same pattern) and by inclusion (the matrix's nonzeros lie inside one of them, so
  that pattern's code could factor it);
- for the matrices covered by inclusion, the guard's pass rate with the order of the
  first top-40 pattern (most common first) that contains them, that pattern's most common
  partial-pivoting order.

With ``--groups`` it also tries the hybrid the survey points to, on the cuboid runs: the
pivot positions whose row is the same in at least a share ``--fix`` of the training
factorisations keep that row, and the other positions pivot by partial pivoting among the
remaining rows (the rows that take turns); it reports how often the 0.1 guard passes.

Reported in docs/notes/kernel_experiments.md ("Straight-line LU per contact state").
"""

from __future__ import annotations

import argparse
import collections
import os
import pickle
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = {
    "cuboid, paper, 45 deg": dict(shape="cuboid", preset="paper", incline_deg=45.0),
    "cuboid, aluminum, 30 deg": dict(shape="cuboid", preset="aluminum", incline_deg=30.0),
    "cuboid, flat paper, 10 Hz": dict(shape="cuboid", preset="paper", incline_deg=0.0, freq_hz=10.0),
    "curved, paper, 45 deg": dict(shape="curved", preset="paper", incline_deg=45.0),
    "spiked, aluminum, 25 deg": dict(shape="spiked", preset="aluminum", incline_deg=25.0),
}
TRAINING = ("cuboid, paper, 45 deg", "cuboid, aluminum, 30 deg")
GUARD = 0.1

CAPTURE = r"""
import os, pickle, sys
import numpy as np
import tumblemc
from tumblemc.kernels import newton
rec = []
lu = newton.lu_factor
lm = newton._lm_direction
in_lm = [False]
def spy(A, order, n, unz, ucnt, lnz, lcnt, amax, J, rowrel):
    vals = A[:n, :n].copy()
    ok = lu(A, order, n, unz, ucnt, lnz, lcnt, amax, J, rowrel)
    if not in_lm[0]:  # a Newton matrix, not the Levenberg-Marquardt fallback's
        rec.append((vals, tuple(int(i) for i in order[:n]), bool(ok)))
    return ok
def lm_spy(*args):
    in_lm[0] = True
    try:
        return lm(*args)
    finally:
        in_lm[0] = False
newton.lu_factor = spy  # solve() looks the names up at call time when nothing is compiled
newton._lm_direction = lm_spy
tumblemc.simulate(**eval(sys.argv[1]))
with open(sys.argv[2], "wb") as fh:
    pickle.dump(rec, fh)
"""


def capture(kw: dict[str, object], path: Path) -> list[tuple[np.ndarray, tuple[int, ...], bool]]:
    env = {**os.environ, "NUMBA_DISABLE_JIT": "1", "PYTHONPATH": str(ROOT)}
    subprocess.run([sys.executable, "-c", CAPTURE, repr(kw), str(path)], check=True, env=env, cwd=ROOT)
    with path.open("rb") as fh:
        rec: list[tuple[np.ndarray, tuple[int, ...], bool]] = pickle.load(fh)
    n = collections.Counter(v.shape[0] for v, _, _ in rec).most_common(1)[0][0]
    return [r for r in rec if r[0].shape[0] == n]  # the step's system (a few small projection solves aside)


def guard_ratio(a: np.ndarray, order: tuple[int, ...]) -> float:
    """Smallest ``|pivot| / max |candidates|`` of elimination in the static row order ``order``."""
    return group_guard(a, dict(enumerate(order)), [])


def group_guard(a: np.ndarray, fixed: dict[int, int], free_rows: list[int]) -> float:
    """Smallest guard ratio of the hybrid elimination (0.0 if a fixed row is taken or a pivot is 0).

    Columns in order; position k takes row ``fixed[k]``, or else the largest entry of column
    k among the unused ``free_rows``.
    """
    a = a.copy()
    n = a.shape[0]
    used = np.zeros(n, dtype=bool)
    ratio = np.inf
    for k in range(n):
        colmax = float(np.abs(a[~used, k]).max())
        if k in fixed:
            r = fixed[k]
            if used[r]:
                return 0.0
        else:
            rows = [i for i in free_rows if not used[i]]
            if not rows:
                return 0.0
            r = rows[int(np.argmax(np.abs(a[rows, k])))]
        piv = a[r, k]
        if piv == 0.0 or colmax == 0.0:
            return 0.0
        ratio = min(ratio, abs(piv) / colmax)
        used[r] = True
        rest = np.flatnonzero(~used)
        f = a[rest, k] / piv
        a[rest, k + 1 :] -= np.outer(f, a[r, k + 1 :])
        a[rest, k] = f
    return float(ratio)


def key(v: np.ndarray) -> bytes:
    return bytes(np.packbits(v != 0.0))


def mask(k: bytes, n: int) -> np.ndarray:
    return np.unpackbits(np.frombuffer(k, np.uint8))[: n * n].reshape(n, n).astype(bool)


def fill(pattern: np.ndarray, order: tuple[int, ...]) -> tuple[int, int]:
    """Nonzeros of L + U and the multiply-adds of eliminating ``pattern`` in the static row order ``order``."""
    f = pattern[list(order)].copy()
    n = f.shape[0]
    madds = 0
    for k in range(n):
        rows = np.flatnonzero(f[k + 1 :, k]) + k + 1
        cols = np.flatnonzero(f[k, k + 1 :]) + k + 1
        f[np.ix_(rows, cols)] = True
        madds += rows.size * cols.size
    return int(f.sum()), madds


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=1.0, help="simulated time per scenario")
    ap.add_argument("--groups", action="store_true", help="also the hybrid: fixed pivots where they never move, pivoting among the rest")
    ap.add_argument("--fix", type=float, default=0.95, help="share of the training factorisations a fixed pivot must have (default 0.95)")
    args = ap.parse_args()
    data = {}
    with tempfile.TemporaryDirectory() as tmp:
        for i, (name, kw) in enumerate(SCENARIOS.items()):
            print(f"capturing {name} ...", file=sys.stderr, flush=True)
            data[name] = capture({**kw, "duration_s": args.seconds}, Path(tmp) / f"{i}.pkl")
    train = [r for name in TRAINING for r in data[name]]
    counts = collections.Counter(key(v) for v, _, _ in train)
    top = [p for p, _ in counts.most_common(40)]
    n_train = train[0][0].shape[0]
    top_masks = [mask(p, n_train) for p in top]
    top_order = {p: collections.Counter(o for v, o, _ in train if key(v) == p).most_common(1)[0][0] for p in top}
    print(f"Simulated {args.seconds:g} s per scenario (`python experiments/jacobian_patterns.py --seconds {args.seconds:g}`).\n")
    print(
        "| scenario | n | factorisations | distinct patterns | (pattern, order) pairs | pivot orders | most common pattern "
        "| union nonzeros (with fill; multiply-adds) | one static order: guard passes "
        "| top-40 training patterns: exact | by inclusion | included, guard passes |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name, rec in data.items():
        n = rec[0][0].shape[0]
        pats = collections.Counter(key(v) for v, _, _ in rec)
        pairs = {(key(v), o) for v, o, _ in rec}
        orders = collections.Counter(o for _, o, _ in rec)
        order = orders.most_common(1)[0][0]
        union = np.any([mask(p, n) for p in pats], axis=0)
        nz_fill, madds = fill(union, order)
        passes = np.mean([guard_ratio(v, order) >= GUARD for v, _, _ in rec])
        exact = sum(c for p, c in pats.items() if p in counts and p in top) / len(rec)
        inside = guarded = 0
        for v, _, _ in rec:
            if n != n_train:
                break
            m = v != 0.0
            hit = next((p for p, t in zip(top, top_masks, strict=True) if not np.any(m & ~t)), None)
            if hit is not None:
                inside += 1
                guarded += guard_ratio(v, top_order[hit]) >= GUARD
        print(
            f"| {name} | {n} | {len(rec):,} | {len(pats)} | {len(pairs)} | {len(orders)} | {pats.most_common(1)[0][1] / len(rec):.1%} "
            f"| {int(union.sum())} ({nz_fill}; {madds}) | {passes:.1%} | {exact:.1%} | {inside / len(rec):.1%} "
            + (f"| {guarded / inside:.1%} |" if inside else "| n/a |")
        )
    if args.groups:
        pos = np.array([o for _, o, _ in train])
        fixed = {}
        for k in range(n_train):
            row, cnt = collections.Counter(pos[:, k].tolist()).most_common(1)[0]
            if cnt / len(pos) >= args.fix:
                fixed[k] = int(row)
        free_rows = sorted(set(range(n_train)) - set(fixed.values()))
        print(
            f"\nHybrid (`--groups --fix {args.fix:g}`): {len(fixed)} fixed pivot positions {sorted(fixed)}, "
            f"partial pivoting among the other {len(free_rows)} rows {free_rows}.\n"
        )
        print("| scenario | factorisations | guard 0.1 passes | guard 0.01 passes |")
        print("|---|---|---|---|")
        for name, rec in data.items():
            if rec[0][0].shape[0] != n_train or not name.startswith("cuboid"):
                continue
            g = np.array([group_guard(v, fixed, free_rows) for v, _, _ in rec])
            print(f"| {name} | {len(rec):,} | {np.mean(g >= GUARD):.1%} | {np.mean(g >= 0.01):.1%} |")


if __name__ == "__main__":
    main()
