"""Compare the verdicts of two studies run by run (a kernel change that is not bit for bit).

    python tools/compare_verdicts.py REFERENCE.nc NEW.nc [--out docs/report.md]

The runs are matched by ``run_key`` (a study at fewer samples is a subset of the same
design at more: the first samples of every cell), so NEW may be the 50-sample version of
a 200-sample REFERENCE. Reported:

- runs in both, valid in both (:func:`tumblemc.model.outcome.is_valid`), and the share of
  those whose ``climbed`` verdict agrees (the issue's acceptance: at least 99.5%);
- runs valid in one study only;
- per cell, over the matched runs valid in both: ``p_success`` of each, and whether NEW's
  lies in REFERENCE's Wilson interval at the studies' level (every cell should);
- the progress ratios of the climbing runs of both: median and largest relative difference;
- runs stopped by an early decision (``decided_early``) in each, and how many of those
  climbed in the other study.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from tumblemc.analysis.maps import proportion_ci
from tumblemc.io import open_result
from tumblemc.model.outcome import is_valid


def compare(ref: Path, new: Path) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """Rows per cell and the totals."""
    rr, rm = open_result(ref)
    nr, _ = open_result(new)
    level = float(rm["p_success_lower"].attrs.get("confidence_level", 0.95))
    rk, nk = rr["run_key"].values, nr["run_key"].values
    common, ir, inn = np.intersect1d(rk, nk, assume_unique=True, return_indices=True)
    if common.size == 0:
        raise SystemExit(f"{ref} and {new} share no run_key: not the same design")
    vr, vn = is_valid(rr["status"].values[ir]), is_valid(nr["status"].values[inn])
    both = vr & vn
    cr, cn = rr["climbed"].values[ir] == 1, nr["climbed"].values[inn] == 1
    agree = cr[both] == cn[both]
    pr, pn = rr["progress_ratio"].values[ir], nr["progress_ratio"].values[inn]
    climbing = both & cr & cn
    rel = np.abs(pn[climbing] - pr[climbing]) / np.maximum(np.abs(pr[climbing]), 1e-12)
    cells = rr["cell_key"].values[ir]
    rows = []
    for ck in np.unique(cells):
        sel = (cells == ck) & both
        i0 = ir[np.flatnonzero(cells == ck)[0]]
        n, kr, kn = int(sel.sum()), int(cr[sel].sum()), int(cn[sel].sum())
        lo, hi = proportion_ci(kr, n, level) if n else (np.nan, np.nan)
        p_r, p_n = (kr / n, kn / n) if n else (np.nan, np.nan)
        rows.append(
            {
                "shape": str(rr["shape"].values[i0]),
                "substrate": str(rr["substrate"].values[i0]),
                "incline_deg": float(rr["incline_deg"].values[i0]),
                "n": n,
                "p_ref": p_r,
                "p_new": p_n,
                "lo": float(lo),
                "hi": float(hi),
                "inside": bool(n == 0 or lo - 1e-12 <= p_n <= hi + 1e-12),
                "disagree": int((cr[sel] != cn[sel]).sum()),
            }
        )
    rows.sort(key=lambda r: (r["shape"], r["substrate"], r["incline_deg"]))
    totals: dict[str, Any] = {
        "matched": int(common.size),
        "valid_both": int(both.sum()),
        "agree": int(agree.sum()),
        "agreement": float(agree.mean()) if agree.size else float("nan"),
        "valid_ref_only": int((vr & ~vn).sum()),
        "valid_new_only": int((vn & ~vr).sum()),
        "cells": len(rows),
        "cells_inside": sum(bool(r["inside"]) for r in rows),
        "level": level,
        "climbing_both": int(climbing.sum()),
        "ratio_rel_median": float(np.median(rel)) if rel.size else float("nan"),
        "ratio_rel_max": float(rel.max()) if rel.size else float("nan"),
        "iterations_ref": float(np.nanmean(rr["newton_iterations"].values[ir])),
        "iterations_new": float(np.nanmean(nr["newton_iterations"].values[inn])),
    }
    for tag, runs, idx, valid in (("ref", rr, ir, vr), ("new", nr, inn, vn)):
        early = runs["decided_early"].values[idx] == 1 if "decided_early" in runs.variables else np.zeros(idx.size, dtype=bool)
        totals[f"early_{tag}"] = int(early.sum())
        # stopped by an early decision (verdict failure) in one study, climbed in the other
        other = cn if tag == "ref" else cr
        totals[f"early_{tag}_climbed_other"] = int((early & valid & other).sum())
    return rows, totals


def report(rows: list[dict[str, Any]], t: dict[str, Any], ref: Path, new: Path) -> str:
    lines = [
        f"# Verdicts of `{new.name}` against `{ref.name}`",
        "",
        f"- Runs matched by `run_key`: {t['matched']:,}; valid in both: {t['valid_both']:,}; "
        f"valid only in the reference: {t['valid_ref_only']}; only in the new study: {t['valid_new_only']}.",
        f"- **Verdicts agree in {t['agree']:,} of {t['valid_both']:,} ({100 * float(t['agreement']):.2f}%)** (acceptance: at least 99.5%).",
        f"- **Cells whose new `p_success` lies in the reference's {100 * float(t['level']):.0f}% Wilson interval "
        f"(same runs): {t['cells_inside']} of {t['cells']}.**",
        f"- Progress ratios of the {t['climbing_both']:,} runs that climb in both: relative difference median "
        f"{float(t['ratio_rel_median']):.2e}, largest {float(t['ratio_rel_max']):.2e}.",
        f"- Iterations per step (mean over runs): {float(t['iterations_ref']):.2f} in the reference, "
        f"{float(t['iterations_new']):.2f} in the new study (over the steps taken).",
        f"- Runs stopped by an early decision: {t['early_ref']:,} in the reference, {t['early_new']:,} in the new study; "
        f"of the new study's, {t['early_new_climbed_other']} climbed in the reference.",
        "",
        "| shape | substrate | incline | runs | p (reference) | p (new) | reference interval | inside | verdicts differ |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['shape']} | {r['substrate']} | {float(r['incline_deg']):g} | {r['n']} | {float(r['p_ref']):.3f} | "
            f"{float(r['p_new']):.3f} | {float(r['lo']):.3f}-{float(r['hi']):.3f} | "
            f"{'yes' if r['inside'] else '**no**'} | {r['disagree']} |"
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("reference", type=Path)
    ap.add_argument("new", type=Path)
    ap.add_argument("--out", type=Path, default=None, help="write the markdown report here (default: print it)")
    a = ap.parse_args(argv)
    rows, totals = compare(a.reference, a.new)
    text = report(rows, totals, a.reference, a.new)
    if a.out is None:
        print(text, end="")
    else:
        a.out.write_text(text)
        print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
