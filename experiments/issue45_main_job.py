"""The main job before and after a change: per-run verdicts of runs valid in both, statuses, time.

    python experiments/issue45_main_job.py BEFORE.nc AFTER.nc

The main job is a threshold study: a run's verdict at each grid incline follows from its
``threshold`` (the steepest incline it passes) and ``grid_verdict``; two runs agree at an
incline when both verdicts are the same there.
"""

from __future__ import annotations

import sys

import numpy as np

import tumblemc as tm


def main(before: str, after: str) -> None:
    a, _ = tm.open_result(before)
    b, _ = tm.open_result(after)
    assert np.array_equal(a.run_key.values, b.run_key.values), "not the same robots"
    va = a.status.values == 0
    vb = b.status.values == 0
    both = va & vb
    ga = a.grid_verdict.values[both]
    gb = b.grid_verdict.values[both]
    agree = float(np.mean(ga == gb))
    print(f"runs: {a.sizes['run']}; valid before {va.sum()}, after {vb.sum()}, in both {both.sum()}")
    pairs, counts = np.unique(np.stack([a.status.values, b.status.values]), axis=1, return_counts=True)
    print("status before -> after (counts):", {(int(p), int(q)): int(c) for (p, q), c in zip(pairs.T, counts, strict=True)})
    print(f"verdicts (run x incline) agreeing among runs valid in both: {agree:.4%} ({int((ga != gb).sum())} of {ga.size} differ)")
    ta, tb = a.threshold.values[both], b.threshold.values[both]
    same = (ta == tb) | (np.isnan(ta) & np.isnan(tb))
    print(f"thresholds equal: {same.mean():.4%}")
    for k in ("early_decision_audit_dt_runs", "audit_disagreements"):
        print(k, a.attrs.get(k), b.attrs.get(k))


if __name__ == "__main__":
    main(*sys.argv[1:3])
