"""How stable are the Newton matrices' sparsity patterns and pivot orders? Issue 15, item 1, measured.

    python tools/jacobian_patterns.py [--seconds 1.0]

Issue 15 proposes straight-line LU code generated per contact state: a fixed sparsity
pattern and pivot order per frequent state, guarded, with the general LU as fallback. That
pays only if a few patterns and orders cover most factorizations of every kind of run.
This script measures it. Each scenario runs ``tumblemc.simulate`` in a subprocess with
``NUMBA_DISABLE_JIT=1`` (the kernels as plain Python, so ``newton.lu_factor`` can be
wrapped) and records, for every factorisation, the nonzero pattern of the Newton matrix,
partial pivoting's row order and the matrix itself. It then reports, per scenario:

- distinct patterns and (pattern, order) pairs, and the share of the most common pattern;
- the share covered by the 40 most common patterns of the two training scenarios (the
  cuboid on paper at 45 deg and on aluminum at 30 deg): the code a generator would emit;
- one static order on the union of the scenario's patterns: how often a threshold guard
  (``|pivot| >= 0.1 x`` the largest candidate of its column, the usual sparse-LU threshold)
  passes, that is how often the straight-line code could be used;
- a static order per pattern (that pattern's most common partial-pivoting order): the
  guard's pass rate over the training scenarios' top-40 patterns.

Reported in docs/kernel_experiments.md ("Straight-line LU per contact state").
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
def spy(A, order, n, unz, ucnt, lnz, lcnt, amax):
    vals = A[:n, :n].copy()
    ok = lu(A, order, n, unz, ucnt, lnz, lcnt, amax)
    rec.append((vals, tuple(int(i) for i in order[:n]), bool(ok)))
    return ok
newton.lu_factor = spy  # solve() looks the name up at call time when nothing is compiled
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
    a = a[list(order)].copy()
    n = a.shape[0]
    ratio = np.inf
    for k in range(n):
        m = float(np.abs(a[k:, k]).max())
        if a[k, k] == 0.0 or m == 0.0:
            return 0.0
        ratio = min(ratio, abs(a[k, k]) / m)
        a[k + 1 :, k] /= a[k, k]
        a[k + 1 :, k + 1 :] -= np.outer(a[k + 1 :, k], a[k, k + 1 :])
    return float(ratio)


def key(v: np.ndarray) -> bytes:
    return bytes(np.packbits(v != 0.0))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=1.0, help="simulated time per scenario")
    args = ap.parse_args()
    data = {}
    with tempfile.TemporaryDirectory() as tmp:
        for i, (name, kw) in enumerate(SCENARIOS.items()):
            print(f"capturing {name} ...", file=sys.stderr, flush=True)
            data[name] = capture({**kw, "duration_s": args.seconds}, Path(tmp) / f"{i}.pkl")
    train = [r for name in TRAINING for r in data[name]]
    counts = collections.Counter(key(v) for v, _, _ in train)
    top = {p for p, _ in counts.most_common(40)}
    print(f"Simulated {args.seconds:g} s per scenario (`python tools/jacobian_patterns.py --seconds {args.seconds:g}`).\n")
    print(
        "| scenario | n | factorisations | distinct patterns | (pattern, order) pairs | most common pattern "
        "| covered by the top-40 training patterns | one static order, guard passes |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for name, rec in data.items():
        pats = collections.Counter(key(v) for v, _, _ in rec)
        pairs = {(key(v), o) for v, o, _ in rec}
        order = collections.Counter(o for _, o, _ in rec).most_common(1)[0][0]
        passes = np.mean([guard_ratio(v, order) >= GUARD for v, _, _ in rec])
        covered = sum(c for p, c in pats.items() if p in top) / len(rec)
        print(
            f"| {name} | {rec[0][0].shape[0]} | {len(rec):,} | {len(pats)} | {len(pairs)} | {pats.most_common(1)[0][1] / len(rec):.1%} | "
            f"{covered:.1%} | {passes:.1%} |"
        )
    ok = tot = 0
    for p in top:
        rs = [r for r in train if key(r[0]) == p]
        order = collections.Counter(o for _, o, _ in rs).most_common(1)[0][0]
        ok += sum(guard_ratio(v, order) >= GUARD for v, _, _ in rs)
        tot += len(rs)
    share = tot / len(train)
    print(
        f"\nA static order per pattern (its most common partial-pivoting order) on the training scenarios' top-40 patterns "
        f"({share:.1%} of their factorisations): the guard passes in {ok / tot:.1%} of them, so generated code would serve "
        f"{share * ok / tot:.1%} of the training scenarios' factorisations."
    )


if __name__ == "__main__":
    main()
